//! `throng serve` through its protocol, with the real binary on a free port and plain TCP: the
//! page is served; frames decode to the positions `throng demo --trajectories` writes for the
//! same seed; controls change the world (a goal click moves the field's goal cells and rebuilds
//! the channel); bad requests get 4xx and the server goes on; a client that never reads does
//! not hold the simulation back; Ctrl-C stops the server with exit status 0.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::Value;

const TIMEOUT: Duration = Duration::from_secs(20);

/// A running `throng serve` on a free port; killed when dropped.
struct Server {
    child: Child,
    port: u16,
}

impl Server {
    fn start(args: &[&str]) -> Server {
        let mut child = Command::new(env!("CARGO_BIN_EXE_throng"))
            .arg("serve")
            .args(args)
            .args(["--port", "0"])
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("start throng serve");
        let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
        let port = loop {
            let line = lines
                .next()
                .expect("throng serve printed no URL")
                .expect("read stdout");
            if let Some(rest) = line.strip_prefix("throng: serving http://127.0.0.1:") {
                break rest.split('/').next().unwrap().parse().expect("a port");
            }
        };
        // Keep draining stdout so that the server never blocks on a full pipe.
        std::thread::spawn(move || for _ in lines {});
        Server { child, port }
    }

    fn connect(&self) -> TcpStream {
        let s = TcpStream::connect(("127.0.0.1", self.port)).expect("connect");
        s.set_read_timeout(Some(TIMEOUT)).unwrap();
        s.set_write_timeout(Some(TIMEOUT)).unwrap();
        s
    }

    /// One request; returns the status, the head (lower-cased) and the body.
    fn request(&self, method: &str, path: &str, body: Option<&str>) -> (u16, String, Vec<u8>) {
        let head = match body {
            Some(b) => format!(
                "Content-Type: application/json\r\nContent-Length: {}\r\n\r\n{b}",
                b.len()
            ),
            None => "\r\n".into(),
        };
        self.raw(&format!(
            "{method} {path} HTTP/1.1\r\nHost: 127.0.0.1:{}\r\nConnection: close\r\n{head}",
            self.port
        ))
    }

    /// Sends `text` as it is and reads the answer to the end.
    fn raw(&self, text: &str) -> (u16, String, Vec<u8>) {
        let mut s = self.connect();
        s.write_all(text.as_bytes()).unwrap();
        let mut answer = Vec::new();
        s.read_to_end(&mut answer).expect("read the answer");
        let split = answer
            .windows(4)
            .position(|w| w == b"\r\n\r\n")
            .expect("a head");
        let head = String::from_utf8_lossy(&answer[..split]).to_ascii_lowercase();
        let status = head
            .split_whitespace()
            .nth(1)
            .and_then(|s| s.parse().ok())
            .expect("a status");
        (status, head, answer[split + 4..].to_vec())
    }

    fn json(&self, method: &str, path: &str, body: Option<&str>) -> (u16, Value) {
        let (status, _, body) = self.request(method, path, body);
        let v = serde_json::from_slice(&body)
            .unwrap_or_else(|e| panic!("{path} answered no JSON ({e}): {} bytes", body.len()));
        (status, v)
    }

    fn state(&self) -> Value {
        let (status, v) = self.json("GET", "/state", None);
        assert_eq!(status, 200);
        v
    }

    fn control(&self, body: &str) -> Value {
        let (status, v) = self.json("POST", "/control", Some(body));
        assert_eq!(status, 200, "{body} -> {v}");
        v
    }

    /// Opens the frame stream.
    fn frames(&self) -> Frames {
        let mut s = self.connect();
        write!(
            s,
            "GET /frames HTTP/1.1\r\nHost: 127.0.0.1:{}\r\n\r\n",
            self.port
        )
        .unwrap();
        let mut r = BufReader::new(s);
        let mut head = String::new();
        loop {
            let mut line = String::new();
            r.read_line(&mut line).expect("read the head");
            if line == "\r\n" || line.is_empty() {
                break;
            }
            head.push_str(&line);
        }
        assert!(head.starts_with("HTTP/1.1 200"), "{head}");
        assert!(head.contains("application/octet-stream"), "{head}");
        Frames(r)
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// A frame stream being read.
struct Frames(BufReader<TcpStream>);

/// A decoded frame.
#[derive(Debug)]
struct Frame {
    paused: bool,
    frame: u64,
    agents: usize,
    world_version: u32,
    quantum: (f32, f32),
    x: Vec<f32>,
    y: Vec<f32>,
    heading: Vec<u8>,
    group: Vec<u8>,
    gravity: usize,
}

fn f32_at(b: &[u8], at: usize) -> f32 {
    f32::from_le_bytes(b[at..at + 4].try_into().unwrap())
}

impl Frames {
    fn next(&mut self) -> Frame {
        let mut len = [0u8; 4];
        self.0.read_exact(&mut len).expect("a frame length");
        let mut b = vec![0u8; u32::from_le_bytes(len) as usize];
        self.0.read_exact(&mut b).expect("a frame");
        assert_eq!(&b[..4], b"THRF");
        assert_eq!(u16::from_le_bytes([b[4], b[5]]), 1, "frame layout version");
        let n = u32::from_le_bytes(b[24..28].try_into().unwrap()) as usize;
        let g = u16::from_le_bytes([b[86], b[87]]) as usize;
        assert_eq!(b.len(), 88 + 7 * n + 16 * g, "frame length");
        let (ox, oy, qx, qy) = (
            f32_at(&b, 32),
            f32_at(&b, 36),
            f32_at(&b, 40),
            f32_at(&b, 44),
        );
        let u16s = |at: usize| -> Vec<u16> {
            (0..n)
                .map(|i| u16::from_le_bytes([b[at + 2 * i], b[at + 2 * i + 1]]))
                .collect()
        };
        let base = 88;
        Frame {
            paused: u16::from_le_bytes([b[6], b[7]]) & 1 == 1,
            frame: u64::from_le_bytes(b[8..16].try_into().unwrap()),
            agents: n,
            world_version: u32::from_le_bytes(b[28..32].try_into().unwrap()),
            quantum: (qx, qy),
            x: u16s(base).iter().map(|&q| ox + f32::from(q) * qx).collect(),
            y: u16s(base + 2 * n)
                .iter()
                .map(|&q| oy + f32::from(q) * qy)
                .collect(),
            heading: b[base + 4 * n..base + 5 * n].to_vec(),
            group: b[base + 6 * n..base + 7 * n].to_vec(),
            gravity: g,
        }
    }
}

/// Polls until `f` holds or the time runs out.
fn eventually(what: &str, mut f: impl FnMut() -> bool) {
    let start = Instant::now();
    while start.elapsed() < TIMEOUT {
        if f() {
            return;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    panic!("timed out waiting for {what}");
}

fn frame_of(state: &Value) -> u64 {
    state["frame"].as_u64().expect("a frame number")
}

#[test]
fn the_page_is_served_with_its_canvas() {
    let s = Server::start(&["flock", "--agents", "100"]);
    let (status, head, body) = s.request("GET", "/", None);
    assert_eq!(status, 200);
    assert!(head.contains("content-type: text/html"), "{head}");
    let page = String::from_utf8(body).unwrap();
    assert!(page.contains("<canvas"), "the page has no canvas");
    assert!(
        !page.contains("http://") && !page.contains("https://"),
        "the page loads nothing from elsewhere"
    );
}

#[test]
fn frames_decode_to_the_trajectories_of_the_same_seed() {
    let args = ["--agents", "300", "--seed", "7", "--threads", "2"];
    let s = Server::start(&[&["flock", "--paused"][..], &args].concat());
    let state = s.control(r#"{"cmd":"step","n":5}"#);
    assert_eq!(frame_of(&state), 5);
    assert_eq!(state["paused"], true);
    let f = s.frames().next();
    assert_eq!(f.frame, 5);
    assert!(f.paused);
    assert_eq!(f.agents, 300);

    let dir = std::env::temp_dir().join(format!("throng-serve-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let csv = dir.join("flock.csv");
    let o = Command::new(env!("CARGO_BIN_EXE_throng"))
        .args(["demo", "flock", "--steps", "5", "--every", "5", "--quiet"])
        .args(args)
        .arg("--trajectories")
        .arg(&csv)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(&csv).unwrap();
    let rows: Vec<Vec<f64>> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .filter(|r: &Vec<f64>| r[0] == 5.0)
        .collect();
    assert_eq!(rows.len(), 300);
    let tol = (f.quantum.0.max(f.quantum.1) * 0.5 + 1e-4) as f64;
    for (i, r) in rows.iter().enumerate() {
        assert!((f64::from(f.x[i]) - r[3]).abs() <= tol, "x of agent {i}");
        assert!((f64::from(f.y[i]) - r[4]).abs() <= tol, "y of agent {i}");
        let turn = std::f64::consts::TAU;
        let h = (f64::from(f.heading[i]) / 256.0 * turn - r[7]).rem_euclid(turn);
        assert!(
            h.min(turn - h) <= turn / 512.0 + 1e-6,
            "heading of agent {i}"
        );
        assert_eq!(f64::from(f.group[i]), r[8], "group of agent {i}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn frames_keep_coming_with_rising_numbers_and_positions_inside_the_world() {
    let s = Server::start(&["fields", "--agents", "400", "--fast"]);
    let (_, world) = s.json("GET", "/world", None);
    assert_eq!(world["bounds"]["kind"], "bounded");
    let size = &world["bounds"]["size"];
    let (w, h) = (size[0].as_f64().unwrap(), size[1].as_f64().unwrap());
    let field = &world["fields"][0];
    assert_eq!(field["width"], 400);
    assert!(field["layer"]["cells"].as_str().unwrap().len() >= 400 * 400 * 4 / 3);
    let mut frames = s.frames();
    let mut last = frames.next().frame;
    for _ in 0..5 {
        let f = frames.next();
        assert!(f.frame > last, "frame {} after {last}", f.frame);
        last = f.frame;
        assert_eq!(f.agents, 400);
        for (&x, &y) in f.x.iter().zip(&f.y) {
            assert!((0.0..=w as f32).contains(&x) && (0.0..=h as f32).contains(&y));
        }
    }
}

#[test]
fn a_goal_click_moves_the_field_goal_and_rebuilds_its_channel() {
    let s = Server::start(&["fields", "--paused"]);
    s.control(r#"{"cmd":"step"}"#);
    let before = s.state();
    let rebuilds = before["field_rebuilds"].as_u64().unwrap();
    let old_goals = before["goals"].clone();
    assert_eq!(old_goals.as_array().unwrap().len(), 4);
    let version = before["world_version"].as_u64().unwrap();

    let after = s.control(r#"{"cmd":"goal","x":200.2,"y":199.7}"#);
    let goals = after["goals"].as_array().unwrap();
    assert_eq!(goals.len(), 1, "one goal where the click was: {after}");
    let (gx, gy) = (goals[0][0].as_f64().unwrap(), goals[0][1].as_f64().unwrap());
    assert!(
        (gx - 200.0).abs() <= 8.0 && (gy - 199.0).abs() <= 8.0,
        "{goals:?}"
    );
    assert_ne!(after["goals"], old_goals);
    assert!(after["world_version"].as_u64().unwrap() > version);
    let (_, world) = s.json("GET", "/world", None);
    assert_eq!(world["fields"][0]["goals"][0][0][0].as_f64(), Some(gx));

    let stepped = s.control(r#"{"cmd":"step"}"#);
    assert_eq!(
        stepped["field_rebuilds"].as_u64().unwrap(),
        rebuilds + 1,
        "the channel was rebuilt for the new goal"
    );

    let shuffled = s.control(r#"{"cmd":"shuffle_goals"}"#);
    assert_eq!(shuffled["goals"].as_array().unwrap().len(), 1);
    assert_ne!(shuffled["goals"], after["goals"]);
}

#[test]
fn obstacles_and_gravity_points_join_the_world_and_the_frames() {
    let s = Server::start(&["antigravity", "--agents", "200", "--paused"]);
    let points = s.state()["gravity_points"].as_u64().unwrap();
    let state = s.control(r#"{"cmd":"gravity","x":200,"y":200,"strength":-50,"radius":30}"#);
    assert_eq!(state["gravity_points"].as_u64(), Some(points + 1));
    let state = s.control(r#"{"cmd":"wall","x0":100,"y0":10,"x1":100,"y1":390}"#);
    assert_eq!(state["walls"].as_u64(), Some(1));
    let state = s.control(r#"{"cmd":"circle","x":300,"y":10,"radius":2}"#);
    assert_eq!(state["circles"].as_u64(), Some(1));
    let (_, world) = s.json("GET", "/world", None);
    assert_eq!(
        world["walls"][0],
        serde_json::json!([100.0, 10.0, 100.0, 390.0])
    );
    assert_eq!(world["version"], state["world_version"]);
    let f = s.frames().next();
    assert_eq!(f.gravity as u64, points + 1);
    assert_eq!(
        u64::from(f.world_version),
        state["world_version"].as_u64().unwrap()
    );
}

/// Four walls clicked into the circle, a spur and a triangle on its end (three
/// wall ends at one point): the simulation goes on while the crowd crosses them, and `/state`
/// reports no error.
#[test]
fn walls_meeting_at_one_point_keep_the_simulation_running() {
    let s = Server::start(&["circle", "--agents", "100", "--paused", "--fast"]);
    for [x0, y0, x1, y1] in [
        [0, 0, -30, -30],
        [0, 0, 40, 0],
        [40, 0, 0, 40],
        [0, 40, 0, 0],
    ] {
        s.control(&format!(
            r#"{{"cmd":"wall","x0":{x0},"y0":{y0},"x1":{x1},"y1":{y1}}}"#
        ));
    }
    let start = frame_of(&s.state());
    s.control(r#"{"cmd":"play"}"#);
    // 160 units across at speed 1 and 0.25 s a step: 640 steps take everyone past the walls.
    eventually("frames past the walls", || {
        let state = s.state();
        assert_eq!(state["error"], Value::Null, "{state}");
        frame_of(&state) > start + 800
    });
}

#[test]
fn bad_requests_get_4xx_with_a_message_and_the_server_goes_on() {
    let s = Server::start(&[
        "fields",
        "--agents",
        "300",
        "--fast",
        "--max-memory",
        "256M",
    ]);
    for (body, needle) in [
        ("{not json", "not JSON"),
        (r#"{"cmd":"fly"}"#, "unknown cmd"),
        (r#"{"cmd":"goal","x":1}"#, "`y` is missing"),
        (r#"{"cmd":"goal","x":-50,"y":10}"#, "outside the field"),
        (
            r#"{"cmd":"wall","x0":1,"y0":1,"x1":1,"y1":1}"#,
            "same point",
        ),
        (
            r#"{"cmd":"gravity","x":1,"y":1,"strength":1,"radius":-2}"#,
            "radius",
        ),
        (
            r#"{"cmd":"gravity","x":1e300,"y":1,"strength":1}"#,
            "finite",
        ),
        (r#"{"cmd":"reset","agents":0}"#, "agents"),
        (r#"{"cmd":"steps_per_frame","n":5000}"#, "1000"),
        (r#"{"cmd":"reset","agents":50000000}"#, "memory"),
        // The coordinate ceiling of scenario files holds for controls too.
        (r#"{"cmd":"wall","x0":1,"y0":1,"x1":1e20,"y1":1}"#, "1e18"),
        (r#"{"cmd":"gravity","x":-1e20,"y":1,"strength":1}"#, "1e18"),
        (r#"{"cmd":"circle","x":1,"y":1e20,"radius":1}"#, "1e18"),
    ] {
        let (status, v) = s.json("POST", "/control", Some(body));
        assert_eq!(status, 400, "{body} -> {v}");
        let message = v["error"].as_str().unwrap_or_default();
        assert!(message.contains(needle), "{body} -> {message}");
    }
    let (status, _) = s.json("GET", "/nowhere", None);
    assert_eq!(status, 404);
    let (status, _) = s.json("GET", "/control", None);
    assert_eq!(status, 405);
    let (status, _, _) = s.raw(&format!(
        "POST /control HTTP/1.1\r\nHost: 127.0.0.1:{}\r\nContent-Type: text/plain\r\nContent-Length: 15\r\nConnection: close\r\n\r\n{{\"cmd\":\"pause\"}}",
        s.port
    ));
    assert_eq!(status, 415, "a form of another site cannot send controls");
    let (status, _, _) = s.raw(&format!(
        "POST /control HTTP/1.1\r\nHost: 127.0.0.1:{}\r\nContent-Type: application/jsonx\r\nContent-Length: 15\r\nConnection: close\r\n\r\n{{\"cmd\":\"pause\"}}",
        s.port
    ));
    assert_eq!(status, 415, "application/jsonx is not JSON");
    let (status, _, _) = s.raw(&format!(
        "POST /control HTTP/1.1\r\nHost: 127.0.0.1:{}\r\nContent-Type: Application/JSON; charset=utf-8\r\nContent-Length: 15\r\nConnection: close\r\n\r\n{{\"cmd\":\"pause\"}}",
        s.port
    ));
    assert_eq!(status, 200, "JSON with a charset is JSON");
    s.control(r#"{"cmd":"play"}"#);
    let (status, _, _) =
        s.raw("GET /state HTTP/1.1\r\nHost: example.com\r\nConnection: close\r\n\r\n");
    assert_eq!(status, 403, "a page of another name is refused");
    // Garbage that is not HTTP at all: the connection ends, the server stays.
    let mut c = s.connect();
    c.write_all(b"\x00\x01\x02 nonsense\r\n\r\n").unwrap();
    let _ = c.read_to_end(&mut Vec::new());

    let first = frame_of(&s.state());
    eventually("frames after bad requests", || frame_of(&s.state()) > first);
    assert_eq!(s.state()["error"], Value::Null);
}

/// Header lines were read without a limit: eight connections with 200 MB lines took the server
/// from 35 MB to 1.46 GB. A request line, a header line or a header count past its ceiling is
/// answered at once (414 or 431) and the connection closed, and the server goes on.
#[test]
fn long_header_lines_and_too_many_headers_are_refused() {
    let s = Server::start(&["flock", "--agents", "100", "--fast"]);
    let host = format!("Host: 127.0.0.1:{}\r\n", s.port);
    let long = "a".repeat(64 * 1024);
    let many: String = (0..200).map(|k| format!("X-H{k}: 1\r\n")).collect();
    for (request, wanted) in [
        (format!("GET /{long} HTTP/1.1\r\n{host}\r\n"), 414),
        (
            format!("GET /state HTTP/1.1\r\n{host}X-Long: {long}\r\n\r\n"),
            431,
        ),
        (format!("GET /state HTTP/1.1\r\n{host}{many}\r\n"), 431),
    ] {
        let (status, _, body) = s.raw(&request);
        assert_eq!(status, wanted, "{}", String::from_utf8_lossy(&body));
    }
    // A line that never ends: the answer comes after the ceiling, not at the end of the line.
    let mut c = s.connect();
    c.write_all(b"GET /state HTTP/1.1\r\nX-Endless: ").unwrap();
    let chunk = vec![b'a'; 64 * 1024];
    let mut sent = 0;
    while sent < 64 << 20 && c.write_all(&chunk).is_ok() {
        sent += chunk.len();
    }
    assert!(sent < 64 << 20, "the server read 64 MiB of one header line");
    assert_eq!(s.state()["error"], Value::Null);
}

#[test]
fn clients_that_never_read_do_not_hold_the_simulation_back() {
    let s = Server::start(&["flock", "--agents", "20000", "--fast", "--threads", "1"]);
    // Two streams that are never read: their socket buffers fill within a few frames.
    let stuck: Vec<TcpStream> = (0..2)
        .map(|_| {
            let mut c = s.connect();
            write!(
                c,
                "GET /frames HTTP/1.1\r\nHost: 127.0.0.1:{}\r\n\r\n",
                s.port
            )
            .unwrap();
            c
        })
        .collect();
    eventually("both stuck clients to be registered", || {
        s.state()["clients"].as_u64() >= Some(2)
    });
    std::thread::sleep(Duration::from_millis(500));
    let start = frame_of(&s.state());
    eventually("the frame to advance by 20", || {
        frame_of(&s.state()) >= start + 20
    });
    // Two readers at the same time both see fresh frames.
    let mut frames = s.frames();
    let mut other = s.frames();
    for stream in [&mut frames, &mut other] {
        let a = stream.next().frame;
        let b = stream.next().frame;
        assert!(b > a, "{b} after {a}");
    }
    // A client that goes is forgotten.
    drop(stuck);
    drop(frames);
    drop(other);
    eventually("the gone clients to be forgotten", || {
        s.state()["clients"].as_u64() == Some(0)
    });
}

#[test]
fn pause_holds_the_frame_play_resumes_and_reset_rebuilds() {
    let s = Server::start(&["flock", "--agents", "500", "--fast"]);
    eventually("a few frames", || frame_of(&s.state()) > 3);
    let paused = s.control(r#"{"cmd":"pause"}"#);
    assert_eq!(paused["paused"], true);
    let at = frame_of(&paused);
    std::thread::sleep(Duration::from_millis(300));
    assert_eq!(frame_of(&s.state()), at, "paused at {at}");
    let f = s.frames().next();
    assert_eq!(f.frame, at);
    assert!(f.paused);

    let stepped = s.control(r#"{"cmd":"step","n":3}"#);
    assert_eq!(frame_of(&stepped), at + 3);
    s.control(r#"{"cmd":"steps_per_frame","n":4}"#);
    let playing = s.control(r#"{"cmd":"play"}"#);
    assert_eq!(playing["paused"], false);
    assert_eq!(playing["steps_per_frame"], 4);
    eventually("frames after play", || frame_of(&s.state()) > at + 10);

    let reset = s.control(r#"{"cmd":"reset","seed":9,"agents":123}"#);
    assert_eq!(reset["agents"], 123);
    assert_eq!(reset["seed"], 9);
    assert!(frame_of(&reset) < 10, "a reset starts again: {reset}");
}

#[test]
fn ctrl_c_stops_the_server_with_success() {
    let mut s = Server::start(&["flock", "--agents", "200"]);
    let _frames = s.frames();
    let status = Command::new("kill")
        .args(["-INT", &s.child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    let start = Instant::now();
    let exit = loop {
        if let Some(exit) = s.child.try_wait().unwrap() {
            break exit;
        }
        assert!(start.elapsed() < TIMEOUT, "throng serve did not stop");
        std::thread::sleep(Duration::from_millis(20));
    };
    assert!(exit.success(), "{exit:?}");
}

#[test]
fn a_bad_bind_address_or_steps_per_frame_is_refused_before_serving() {
    for (args, needle) in [
        (&["flock", "--bind", "nowhere"][..], "not an IP address"),
        (&["flock", "--steps-per-frame", "0"][..], "steps-per-frame"),
        (&["nosuchscenario"][..], "unknown scenario"),
    ] {
        let o = Command::new(env!("CARGO_BIN_EXE_throng"))
            .arg("serve")
            .args(args)
            .args(["--port", "0"])
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(1), "{args:?}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains(needle), "{args:?}: {err}");
    }
}

#[cfg(feature = "render")]
#[test]
fn the_page_colours_the_heat_map_the_way_the_pictures_do() {
    use throng::render::Palette;
    let s = Server::start(&["fields", "--agents", "10", "--paused"]);
    let (_, world) = s.json("GET", "/world", None);
    // The page colours layer value v (0 at a goal, 253 farthest) at v / 253 along `heat_ramp`;
    // `--render` colours a cell at 1 - steps / farthest along its palette's ramp.
    let ramp: Vec<[u8; 3]> = serde_json::from_value(world["heat_ramp"].clone())
        .unwrap_or_else(|e| panic!("no heat_ramp in /world ({e}): {world}"));
    let palette = Palette::standard();
    assert_eq!(ramp[0], palette.rgb(Palette::heat(1.0)), "at a goal");
    assert_eq!(
        ramp[ramp.len() - 1],
        palette.rgb(Palette::heat(0.0)),
        "farthest from the goals"
    );
    // Halfway, within the palette's 64 steps.
    let (page, picture) = (ramp[ramp.len() / 2], palette.rgb(Palette::heat(0.5)));
    assert!(
        page.iter().zip(picture).all(|(&a, b)| a.abs_diff(b) <= 4),
        "halfway: the page's {page:?}, the pictures' {picture:?}"
    );
}

#[test]
fn the_world_offers_only_click_modes_that_act_and_an_extent_to_fit() {
    let modes = |scenario: &str| -> Vec<String> {
        let s = Server::start(&[scenario, "--agents", "50", "--paused"]);
        let (_, world) = s.json("GET", "/world", None);
        serde_json::from_value(world["modes"].clone())
            .unwrap_or_else(|e| panic!("{scenario}: no modes in /world ({e})"))
    };
    // Flock agents feel no gravity point and follow no field.
    assert_eq!(modes("flock"), ["wall", "circle"]);
    assert_eq!(modes("antigravity"), ["gravity", "wall", "circle"]);
    assert_eq!(modes("fields"), ["goal", "wall", "circle"]);

    // The bottleneck is an open world: its extent covers the 10 x 10 m room and the corridor,
    // not a default 100 x 100 box.
    let s = Server::start(&["bottleneck", "--paused"]);
    let (_, world) = s.json("GET", "/world", None);
    let e: Vec<f64> = serde_json::from_value(world["extent"].clone())
        .unwrap_or_else(|e| panic!("no extent in /world ({e}): {world}"));
    let (w, h) = (e[2] - e[0], e[3] - e[1]);
    assert!(
        e[0] <= 0.0 && e[1] <= 0.0 && e[2] >= 14.0 && e[3] >= 10.0,
        "{e:?}"
    );
    assert!(
        w < 20.0 && h < 16.0,
        "the extent {e:?} is much larger than the room"
    );
}
