//! `throng serve`: a live view of a running simulation in the browser.
//!
//! A small synchronous HTTP server ([`http`]: a thread that accepts, a thread per connection
//! that reads its request within stated ceilings, no async runtime) serves one page embedded in
//! the binary, the world's geometry as
//! JSON, the state as JSON, a binary stream of frames, and the page's controls. The world steps
//! on its own thread ([`sim`]) in its own rayon pool; docs/SERVE.md describes the protocol.
//!
//! Invariants: the server thread never waits for the simulation (controls are answered on a
//! thread of their own; `/state` and `/world` are the last published bodies); a streaming
//! client that stops reading blocks only its own thread, and the simulation drops frames for it;
//! every request that is not understood gets a 4xx answer and the server goes on.

mod frame;
mod http;
mod sim;

use std::io::Write;
use std::net::{IpAddr, SocketAddr};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc::{self, Sender};
use std::sync::{Arc, atomic::AtomicBool};
use std::time::Duration;

use clap::Args;
use throng::scenario::Scenario;
use throng::{Error, Result};

use self::http::{BodyError, Request, Response, Server};

use self::sim::{Control, Setup, Shared, Sim, lock};
use crate::{CommonArgs, WorldArgs};

/// The page, with its script and style inline.
const PAGE: &str = include_str!("index.html");
/// Largest control body read, bytes.
const MAX_BODY: u64 = 64 * 1024;
/// Most frame streams served at once.
const MAX_STREAMS: usize = 16;
/// How long a control may wait for the simulation thread.
const CONTROL_TIMEOUT: Duration = Duration::from_secs(120);

/// Options of `throng serve`.
#[derive(Debug, Args)]
pub struct ServeArgs {
    /// Port to listen on (0: any free port; the URL printed names it).
    #[arg(long, default_value_t = 8080)]
    port: u16,
    /// Address to listen on. Anything but a loopback address lets other machines watch and
    /// steer the run.
    #[arg(long, default_value = "127.0.0.1")]
    bind: String,
    #[command(flatten)]
    world: WorldArgs,
    /// Steps between frames sent to the page.
    #[arg(long, default_value_t = 1)]
    steps_per_frame: u64,
    /// Start paused at frame 0.
    #[arg(long)]
    paused: bool,
    /// Step as fast as the machine allows instead of `dt` seconds of wall time a step.
    #[arg(long)]
    fast: bool,
}

/// Runs the server until Ctrl-C.
pub fn serve(scenario: Scenario, args: &ServeArgs) -> Result<()> {
    let common = CommonArgs {
        world: args.world.clone(),
        steps: None,
    };
    if !(1..=sim::MAX_STEPS).contains(&args.steps_per_frame) {
        return Err(Error::OutOfRange {
            name: "steps-per-frame",
            value: args.steps_per_frame as f64,
            range: "[1, 1000]",
        });
    }
    let bind: IpAddr = args.bind.parse().map_err(|_| Error::Invalid {
        name: "bind".into(),
        reason: format!("`{}` is not an IP address", args.bind),
    })?;
    let base = scenario.clone();
    let (s, world, pool, threads) = crate::prepare(scenario, &common)?;
    let memory = crate::memory_limit(&common.world)?;
    let server = Server::bind(SocketAddr::new(bind, args.port)).map_err(|e| Error::Invalid {
        name: "port".into(),
        reason: format!("cannot listen on {bind}:{}: {e}", args.port),
    })?;
    let addr = server.addr();
    if !bind.is_loopback() {
        eprintln!(
            "throng: warning: listening on {bind}, not a loopback address: anyone who can reach it can watch and steer this run"
        );
    }
    let shared = Arc::new(Shared::default());
    let stop = Arc::new(AtomicBool::new(false));
    {
        let stop = stop.clone();
        ctrlc::set_handler(move || stop.store(true, Ordering::SeqCst)).map_err(|e| {
            Error::Invalid {
                name: "serve".into(),
                reason: format!("cannot handle Ctrl-C: {e}"),
            }
        })?;
    }
    crate::files::say(&format!(
        "throng: scenario {} | {} agents | dt {} | {threads} threads | seed {}",
        s.name,
        world.len(),
        s.dt,
        world.seed()
    ))?;
    let setup = Setup {
        base,
        common: common.world,
        name: s.name.clone(),
        dt: s.dt,
        memory,
        threads,
        paused: args.paused,
        realtime: !args.fast,
        steps_per_frame: args.steps_per_frame,
    };
    let (tx, rx) = mpsc::channel();
    let sim = Sim::new(setup, world, pool, shared.clone());
    let sim_shared = shared.clone();
    let sim_thread = std::thread::Builder::new()
        .name("throng-sim".into())
        .spawn(move || sim::guarded(&sim_shared, || sim.run(&rx)))
        .map_err(|e| Error::Invalid {
            name: "serve".into(),
            reason: format!("cannot start the simulation thread: {e}"),
        })?;
    let shown = match addr.ip() {
        IpAddr::V4(v4) if v4.is_unspecified() => {
            SocketAddr::new([127, 0, 0, 1].into(), addr.port())
        }
        _ => addr,
    };
    crate::files::say(&format!("throng: serving http://{shown}/ (Ctrl-C stops)"))?;
    let ctx = Context {
        shared: shared.clone(),
        control: tx,
        streams: Arc::new(AtomicUsize::new(0)),
        loopback: bind.is_loopback(),
        port: addr.port(),
    };
    while !stop.load(Ordering::SeqCst) {
        if let Some(rq) = server.recv_timeout(Duration::from_millis(100)) {
            route(rq, &ctx);
        }
    }
    shared.stop.store(true, Ordering::SeqCst);
    drop(ctx);
    let _ = sim_thread.join();
    lock(&shared.clients).clear();
    let frame = serde_json::from_str::<serde_json::Value>(&lock(&shared.state))
        .ok()
        .and_then(|v| v.get("frame").and_then(serde_json::Value::as_u64))
        .unwrap_or(0);
    crate::files::say(&format!("throng: stopped at frame {frame}"))
}

/// What every request handler needs.
struct Context {
    shared: Arc<Shared>,
    control: Sender<sim::Request>,
    streams: Arc<AtomicUsize>,
    /// Whether the server listens on loopback only (then the Host header must name it).
    loopback: bool,
    port: u16,
}

/// A JSON answer.
fn json(status: u16, body: String) -> Response {
    Response::new(status, "application/json", body)
}

/// A JSON error answer: `{"error": message}`.
fn error(status: u16, message: &str) -> Response {
    Response::error(status, message)
}

/// Answers a request; a client that has gone while being answered is no concern of the server.
fn respond(rq: Request, response: Response) {
    rq.respond(&response);
}

/// Whether the Host header names this server (a page of another site that made a browser
/// resolve its own name to 127.0.0.1 sends its own name there).
fn host_ok(rq: &Request, ctx: &Context) -> bool {
    if !ctx.loopback {
        return true;
    }
    let Some(host) = rq.header("Host").map(str::to_ascii_lowercase) else {
        return true;
    };
    let port = format!(":{}", ctx.port);
    let name = host.strip_suffix(&port).unwrap_or(&host);
    matches!(name, "127.0.0.1" | "localhost" | "[::1]")
}

fn route(rq: Request, ctx: &Context) {
    if !host_ok(&rq, ctx) {
        return respond(rq, error(403, "unexpected Host header"));
    }
    let path = rq.url().split('?').next().unwrap_or("").to_string();
    let method = rq.method().to_string();
    match (method.as_str(), path.as_str()) {
        ("GET", "/" | "/index.html") => {
            let csp = "default-src 'none'; script-src 'unsafe-inline'; style-src 'unsafe-inline'; \
                       connect-src 'self'; img-src 'self' data:";
            let response = Response::new(200, "text/html; charset=utf-8", PAGE)
                .with_header("Content-Security-Policy", csp);
            respond(rq, response);
        }
        ("GET", "/state") => {
            let body = lock(&ctx.shared.state).as_ref().clone();
            respond(rq, json(200, body));
        }
        ("GET", "/world") => {
            let body = lock(&ctx.shared.world).as_ref().clone();
            respond(rq, json(200, body));
        }
        ("GET", "/frames") => stream(rq, ctx),
        ("POST", "/control") => control(rq, ctx),
        (_, "/" | "/index.html" | "/state" | "/world" | "/frames") => {
            let r = error(405, "method not allowed").with_header("Allow", "GET");
            respond(rq, r);
        }
        (_, "/control") => {
            let r = error(405, "method not allowed").with_header("Allow", "POST");
            respond(rq, r);
        }
        _ => respond(rq, error(404, &format!("no such path: {path}"))),
    }
}

/// Whether a Content-Type is JSON: the media type `application/json` exactly (any case), with
/// or without parameters (`; charset=utf-8`); `application/jsonx` is another type.
fn is_json(content_type: &str) -> bool {
    let media = content_type.split(';').next().unwrap_or("");
    media.trim().eq_ignore_ascii_case("application/json")
}

/// `POST /control`: reads the body, hands the control to the simulation and answers with the
/// state after it (or 400 and the reason), on a thread of its own.
fn control(mut rq: Request, ctx: &Context) {
    if !rq.header("Content-Type").is_some_and(is_json) {
        return respond(
            rq,
            error(415, "a control's Content-Type must be application/json"),
        );
    }
    let body = match rq.read_body(MAX_BODY) {
        Ok(b) => b,
        Err(BodyError::TooLarge) => {
            return respond(rq, error(413, "a control's body is at most 64 KiB"));
        }
        Err(BodyError::NoLength) => {
            return respond(rq, error(411, "a control needs a Content-Length"));
        }
        Err(BodyError::Unreadable) => {
            return respond(rq, error(400, "the body could not be read"));
        }
    };
    let control = match Control::parse(&body) {
        Ok(c) => c,
        Err(e) => return respond(rq, error(400, &e)),
    };
    let (reply_tx, reply_rx) = mpsc::channel();
    if ctx.control.send((control, reply_tx)).is_err() {
        return respond(rq, error(503, "the simulation has stopped"));
    }
    let spawned = std::thread::Builder::new()
        .name("throng-control".into())
        .spawn(move || {
            let response = match reply_rx.recv_timeout(CONTROL_TIMEOUT) {
                Ok(Ok(state)) => json(200, state),
                Ok(Err(e)) => error(400, &e),
                Err(_) => error(503, "the simulation did not answer in time"),
            };
            respond(rq, response);
        });
    if spawned.is_err() {
        eprintln!("throng: warning: cannot start a thread to answer a control");
    }
}

/// Decrements the stream count when a stream's thread ends.
struct StreamSlot(Arc<AtomicUsize>);

impl Drop for StreamSlot {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::SeqCst);
    }
}

/// `GET /frames`: the newest frame, then each new one, as `u32` length + frame bytes, until the
/// client goes or the server stops. Runs on a thread of its own.
fn stream(rq: Request, ctx: &Context) {
    if ctx.streams.fetch_add(1, Ordering::SeqCst) >= MAX_STREAMS {
        ctx.streams.fetch_sub(1, Ordering::SeqCst);
        return respond(rq, error(503, "too many frame streams; close a tab"));
    }
    let slot = StreamSlot(ctx.streams.clone());
    let shared = ctx.shared.clone();
    let spawned = std::thread::Builder::new()
        .name("throng-stream".into())
        .spawn(move || {
            let _slot = slot;
            let (tx, rx) = mpsc::sync_channel(1);
            let first = lock(&shared.latest).clone();
            lock(&shared.clients).push(tx);
            let mut w = rq.into_stream();
            let head = "HTTP/1.1 200 OK\r\nContent-Type: application/octet-stream\r\n\
                        Cache-Control: no-store\r\nX-Content-Type-Options: nosniff\r\n\
                        Connection: close\r\n\r\n";
            if w.write_all(head.as_bytes())
                .and_then(|()| w.flush())
                .is_err()
            {
                return;
            }
            let mut send = |f: &[u8]| -> std::io::Result<()> {
                w.write_all(&(f.len() as u32).to_le_bytes())?;
                w.write_all(f)?;
                w.flush()
            };
            if let Some(f) = first
                && send(&f).is_err()
            {
                return;
            }
            while let Ok(f) = rx.recv() {
                if send(&f).is_err() {
                    return;
                }
            }
        });
    if spawned.is_err() {
        eprintln!("throng: warning: cannot start a thread for a frame stream");
    }
}
