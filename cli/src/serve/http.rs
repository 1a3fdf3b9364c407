//! The HTTP/1.1 of `throng serve`: one request per connection, read within stated ceilings.
//!
//! A thread accepts connections; each connection gets a thread that reads the request line and
//! the headers, at most [`MAX_LINE`] bytes a line and [`MAX_HEADERS`] headers, within
//! [`HEAD_TIMEOUT`]. A request past a ceiling is answered at once (414 for the request line,
//! 431 for the headers, 400 for anything that is not HTTP) and the connection closed, so a
//! client sending endless header lines costs the server one line's bytes, not the whole line.
//! Requests that were read go to [`Server::recv_timeout`]; every answer says
//! `Connection: close`.

use std::io::{self, BufRead, BufReader, Read, Write};
use std::net::{Shutdown, SocketAddr, TcpListener, TcpStream};
use std::sync::mpsc::{self, Receiver, SyncSender};
use std::time::Duration;

/// The longest request line or header line, bytes (its line end included).
pub const MAX_LINE: usize = 8 * 1024;
/// The most header lines of a request.
pub const MAX_HEADERS: usize = 100;
/// How long a client may take to send its request line and headers.
const HEAD_TIMEOUT: Duration = Duration::from_secs(30);
/// Requests read but not yet routed; a connection's thread waits when this many are queued.
const QUEUE: usize = 64;
/// What is read and dropped after an early answer before the connection is closed, so that the
/// client reads the answer instead of a reset: at most this many bytes, for at most a second.
const DRAIN_BYTES: u64 = 1 << 20;

/// The listening server.
#[derive(Debug)]
pub struct Server {
    addr: SocketAddr,
    requests: Receiver<Request>,
}

impl Server {
    /// Listens on `addr` and starts accepting.
    ///
    /// # Errors
    /// When the address cannot be bound or the accepting thread cannot start.
    pub fn bind(addr: SocketAddr) -> io::Result<Server> {
        let listener = TcpListener::bind(addr)?;
        let addr = listener.local_addr()?;
        let (tx, requests) = mpsc::sync_channel(QUEUE);
        std::thread::Builder::new()
            .name("throng-accept".into())
            .spawn(move || accept(&listener, &tx))?;
        Ok(Server { addr, requests })
    }

    /// The address listened on (with the port chosen for port 0).
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// The next request read within `timeout`, if any.
    pub fn recv_timeout(&self, timeout: Duration) -> Option<Request> {
        self.requests.recv_timeout(timeout).ok()
    }
}

fn accept(listener: &TcpListener, tx: &SyncSender<Request>) {
    for stream in listener.incoming() {
        let Ok(stream) = stream else { continue };
        let tx = tx.clone();
        let spawned = std::thread::Builder::new()
            .name("throng-conn".into())
            .spawn(move || {
                if let Some(rq) = read_request(stream) {
                    let _ = tx.send(rq);
                }
            });
        if spawned.is_err() {
            eprintln!("throng: warning: cannot start a thread for a connection");
        }
    }
}

/// Why a head was refused.
enum Refused {
    /// The client went, or sent nothing in time: no answer.
    Gone,
    /// An answer: status and message.
    Answer(u16, &'static str),
}

/// Reads one line of at most [`MAX_LINE`] bytes (without its `\r\n` or `\n`).
fn line(r: &mut BufReader<TcpStream>, too_long: Refused) -> Result<String, Refused> {
    let mut buf = Vec::new();
    let n = r
        .by_ref()
        .take(MAX_LINE as u64)
        .read_until(b'\n', &mut buf)
        .map_err(|_| Refused::Gone)?;
    if n == 0 {
        return Err(Refused::Gone);
    }
    if buf.last() != Some(&b'\n') {
        return Err(if n >= MAX_LINE {
            too_long
        } else {
            Refused::Gone
        });
    }
    buf.pop();
    if buf.last() == Some(&b'\r') {
        buf.pop();
    }
    String::from_utf8(buf).map_err(|_| Refused::Answer(400, "the request head is not UTF-8"))
}

/// Reads a request's head from a new connection; answers and closes it when the head is refused.
fn read_request(stream: TcpStream) -> Option<Request> {
    let _ = stream.set_read_timeout(Some(HEAD_TIMEOUT));
    let _ = stream.set_write_timeout(Some(HEAD_TIMEOUT));
    let mut reader = BufReader::new(stream.try_clone().ok()?);
    match read_head(&mut reader) {
        Ok((method, url, headers)) => {
            let _ = stream.set_read_timeout(None);
            let unread = headers.iter().any(|(n, v)| {
                n.eq_ignore_ascii_case("Transfer-Encoding")
                    || (n.eq_ignore_ascii_case("Content-Length") && v != "0")
            });
            Some(Request {
                method,
                url,
                headers,
                reader,
                stream,
                unread,
            })
        }
        Err(Refused::Gone) => None,
        Err(Refused::Answer(status, message)) => {
            let mut stream = stream;
            let _ = write_response(&mut stream, &Response::error(status, message));
            linger(stream, reader);
            None
        }
    }
}

type Head = (String, String, Vec<(String, String)>);

fn read_head(r: &mut BufReader<TcpStream>) -> Result<Head, Refused> {
    let request_line = line(
        r,
        Refused::Answer(414, "the request line is longer than 8 KiB"),
    )?;
    let mut parts = request_line.split(' ');
    let (Some(method), Some(url), Some(version), None) =
        (parts.next(), parts.next(), parts.next(), parts.next())
    else {
        return Err(Refused::Answer(400, "not an HTTP request line"));
    };
    if method.is_empty()
        || !method.bytes().all(|b| b.is_ascii_uppercase())
        || !url.starts_with('/')
        || !matches!(version, "HTTP/1.0" | "HTTP/1.1")
    {
        return Err(Refused::Answer(400, "not an HTTP request line"));
    }
    let mut headers = Vec::new();
    loop {
        let l = line(
            r,
            Refused::Answer(431, "a header line is longer than 8 KiB"),
        )?;
        if l.is_empty() {
            break;
        }
        if headers.len() == MAX_HEADERS {
            return Err(Refused::Answer(431, "more than 100 header lines"));
        }
        let Some((name, value)) = l.split_once(':') else {
            return Err(Refused::Answer(400, "a header line without a colon"));
        };
        if name.is_empty() || name.bytes().any(|b| b.is_ascii_whitespace()) {
            return Err(Refused::Answer(400, "a malformed header name"));
        }
        headers.push((name.to_string(), value.trim().to_string()));
    }
    Ok((method.to_string(), url.to_string(), headers))
}

/// Closes a connection whose request was not read to its end: stops writing, then reads and
/// drops what the client still sends (a little, briefly), so that it gets the answer, not a
/// reset.
fn linger(stream: TcpStream, mut reader: BufReader<TcpStream>) {
    let _ = stream.shutdown(Shutdown::Write);
    let _ = stream.set_read_timeout(Some(Duration::from_secs(1)));
    let _ = io::copy(&mut reader.by_ref().take(DRAIN_BYTES), &mut io::sink());
}

/// A request whose head was read; its body is still on the connection.
#[derive(Debug)]
pub struct Request {
    method: String,
    url: String,
    headers: Vec<(String, String)>,
    reader: BufReader<TcpStream>,
    stream: TcpStream,
    /// Whether the client may still be sending a body nobody read.
    unread: bool,
}

/// Why a body was not read.
#[derive(Debug)]
pub enum BodyError {
    /// Longer than the limit given.
    TooLarge,
    /// The request has no `Content-Length` (a chunked body, say).
    NoLength,
    /// The connection failed or ended early.
    Unreadable,
}

impl Request {
    /// The method (`GET`, `POST`, ...).
    pub fn method(&self) -> &str {
        &self.method
    }

    /// The request target (path and query).
    pub fn url(&self) -> &str {
        &self.url
    }

    /// The first header named `name` (any case).
    pub fn header(&self, name: &str) -> Option<&str> {
        self.headers
            .iter()
            .find(|(n, _)| n.eq_ignore_ascii_case(name))
            .map(|(_, v)| v.as_str())
    }

    /// Reads the body, at most `max` bytes.
    ///
    /// # Errors
    /// [`BodyError`].
    pub fn read_body(&mut self, max: u64) -> Result<Vec<u8>, BodyError> {
        let length = match self.header("Content-Length") {
            Some(v) => v.parse::<u64>().map_err(|_| BodyError::NoLength)?,
            None if self.header("Transfer-Encoding").is_some() => {
                return Err(BodyError::NoLength);
            }
            None => 0,
        };
        if length > max {
            return Err(BodyError::TooLarge);
        }
        if self
            .header("Expect")
            .is_some_and(|e| e.eq_ignore_ascii_case("100-continue"))
        {
            let _ = self.stream.write_all(b"HTTP/1.1 100 Continue\r\n\r\n");
        }
        let _ = self.stream.set_read_timeout(Some(HEAD_TIMEOUT));
        let mut body = Vec::new();
        self.reader
            .by_ref()
            .take(length)
            .read_to_end(&mut body)
            .map_err(|_| BodyError::Unreadable)?;
        if body.len() as u64 != length {
            return Err(BodyError::Unreadable);
        }
        self.unread = false;
        Ok(body)
    }

    /// Answers and closes the connection; a client that has gone is no concern of the server.
    /// A body left unread is drained on a thread of its own, so the caller never waits.
    pub fn respond(self, response: &Response) {
        let mut stream = self.stream;
        let _ = write_response(&mut stream, response);
        if !self.unread {
            let _ = stream.shutdown(Shutdown::Write);
            return;
        }
        let reader = self.reader;
        let _ = std::thread::Builder::new()
            .name("throng-linger".into())
            .spawn(move || linger(stream, reader));
    }

    /// The connection, to write a streamed answer to (head included).
    pub fn into_stream(self) -> TcpStream {
        let _ = self.stream.set_write_timeout(None);
        self.stream
    }
}

/// An answer: status, headers and body.
#[derive(Clone, Debug)]
pub struct Response {
    status: u16,
    headers: Vec<(&'static str, String)>,
    body: Vec<u8>,
}

impl Response {
    /// An answer of `status` with `body` of `content_type`.
    pub fn new(status: u16, content_type: &str, body: impl Into<Vec<u8>>) -> Response {
        Response {
            status,
            headers: vec![
                ("Content-Type", content_type.to_string()),
                ("Cache-Control", "no-store".to_string()),
            ],
            body: body.into(),
        }
    }

    /// A JSON error answer: `{"error": message}`.
    pub fn error(status: u16, message: &str) -> Response {
        Response::new(
            status,
            "application/json",
            serde_json::json!({ "error": message }).to_string(),
        )
    }

    /// The same answer with one more header.
    #[must_use]
    pub fn with_header(mut self, name: &'static str, value: &str) -> Response {
        self.headers.push((name, value.to_string()));
        self
    }
}

fn reason(status: u16) -> &'static str {
    match status {
        200 => "OK",
        400 => "Bad Request",
        403 => "Forbidden",
        404 => "Not Found",
        405 => "Method Not Allowed",
        411 => "Length Required",
        413 => "Payload Too Large",
        414 => "URI Too Long",
        415 => "Unsupported Media Type",
        431 => "Request Header Fields Too Large",
        503 => "Service Unavailable",
        _ => "",
    }
}

fn write_response(w: &mut TcpStream, r: &Response) -> io::Result<()> {
    let mut head = format!("HTTP/1.1 {} {}\r\n", r.status, reason(r.status));
    for (name, value) in &r.headers {
        head.push_str(&format!("{name}: {value}\r\n"));
    }
    head.push_str(&format!(
        "Content-Length: {}\r\nConnection: close\r\n\r\n",
        r.body.len()
    ));
    let mut out = head.into_bytes();
    out.extend_from_slice(&r.body);
    w.write_all(&out)?;
    w.flush()
}
