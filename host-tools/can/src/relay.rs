//! The board's XCP port served at an address of the user's choice, for XCP tools (`mil param`,
//! `mil filter upload`, `mil daq record`, pyxcp through python-can's slcan) while a rig
//! harness drives the board on its other port: a TCP relay of the SLCAN byte stream, one
//! client at a time (the board's XCP port takes one master), that watches the XCP traffic
//! for the start of a DAQ measurement so the rig can start its run with the recording.

use std::io::{self, Read, Write};
use std::net::{Shutdown, SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use mil_frames::embedded_can::{Frame as _, Id};
use mil_frames::slcan::{parse_line, LineBuffer, SlcanLine, MAX_LINE};

/// XCP START_STOP_SYNCH and START_STOP_DAQ_LIST command codes, and the positive response.
const START_STOP_SYNCH: u8 = 0xDD;
const START_STOP_DAQ_LIST: u8 = 0xDE;
const POSITIVE: u8 = 0xFF;

/// What the relay has seen.
#[derive(Debug, Default)]
struct Seen {
    /// The board acknowledged a DAQ start (START_STOP_SYNCH start selected, or
    /// START_STOP_DAQ_LIST start).
    daq_started: bool,
    /// Clients served.
    clients: usize,
}

/// Shared between the relay's threads.
#[derive(Debug, Default)]
struct Shared {
    seen: Mutex<Seen>,
    changed: Condvar,
}

impl Shared {
    fn update(&self, f: impl FnOnce(&mut Seen)) {
        if let Ok(mut s) = self.seen.lock() {
            f(&mut s);
        }
        self.changed.notify_all();
    }
}

/// The board's XCP port served at [`XcpRelay::local_addr`] until dropped.
pub struct XcpRelay {
    addr: SocketAddr,
    shared: Arc<Shared>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl XcpRelay {
    /// Listens at `listen` and relays each client's connection to the board's XCP port at
    /// `board` (SLCAN over TCP, e.g. [`crate::Qemu::xcp_port`]); the XCP command and response
    /// CAN IDs `ids` (CMD, RES) are watched for a DAQ start.
    ///
    /// # Errors
    /// The address cannot be bound (in use, not local).
    pub fn start(listen: SocketAddr, board: SocketAddr, ids: (u16, u16)) -> io::Result<Self> {
        let listener = TcpListener::bind(listen)
            .map_err(|e| io::Error::new(e.kind(), format!("cannot listen at {listen}: {e}")))?;
        listener.set_nonblocking(true)?;
        let addr = listener.local_addr()?;
        let shared = Arc::new(Shared::default());
        let stop = Arc::new(AtomicBool::new(false));
        let thread = {
            let (shared, stop) = (shared.clone(), stop.clone());
            std::thread::spawn(move || serve(&listener, board, ids, &shared, &stop))
        };
        Ok(Self {
            addr,
            shared,
            stop,
            thread: Some(thread),
        })
    }

    /// Where the clients connect.
    pub fn local_addr(&self) -> SocketAddr {
        self.addr
    }

    /// Clients served so far.
    pub fn clients(&self) -> usize {
        self.shared.seen.lock().map_or(0, |s| s.clients)
    }

    /// Waits until the board has acknowledged the start of a DAQ measurement; `false` when
    /// `timeout` passed first.
    pub fn wait_for_daq_start(&self, timeout: Duration) -> bool {
        let deadline = Instant::now() + timeout;
        let Ok(mut seen) = self.shared.seen.lock() else {
            return false;
        };
        while !seen.daq_started {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return false;
            }
            seen = match self.shared.changed.wait_timeout(seen, left) {
                Ok((s, _)) => s,
                Err(_) => return false,
            };
        }
        true
    }
}

impl Drop for XcpRelay {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Accepts clients one after another until `stop`.
fn serve(
    listener: &TcpListener,
    board: SocketAddr,
    ids: (u16, u16),
    shared: &Arc<Shared>,
    stop: &Arc<AtomicBool>,
) {
    while !stop.load(Ordering::Relaxed) {
        match listener.accept() {
            Ok((client, _)) => {
                shared.update(|s| s.clients += 1);
                // A client the board's port does not take (QEMU gone) is closed at once.
                if let Ok(to_board) = TcpStream::connect_timeout(&board, Duration::from_secs(5)) {
                    relay(client, to_board, ids, shared, stop);
                }
            }
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => {
                std::thread::sleep(Duration::from_millis(20));
            }
            Err(_) => std::thread::sleep(Duration::from_millis(20)),
        }
    }
}

/// Relays one client until either side closes (or `stop`).
fn relay(
    client: TcpStream,
    board: TcpStream,
    ids: (u16, u16),
    shared: &Arc<Shared>,
    stop: &Arc<AtomicBool>,
) {
    let _ = client.set_nonblocking(false);
    let _ = client.set_nodelay(true);
    let _ = board.set_nodelay(true);
    let (Ok(client_write), Ok(board_read), Ok(board_write)) =
        (client.try_clone(), board.try_clone(), board.try_clone())
    else {
        return;
    };
    // The last XCP command the client sent: its first two bytes.
    let last_command = Arc::new(Mutex::new([0u8; 2]));
    let upstream = {
        let (last, stop) = (last_command.clone(), stop.clone());
        std::thread::spawn(move || {
            pump(client, board_write, &stop, |(id, head)| {
                if id == ids.0 {
                    if let Ok(mut l) = last.lock() {
                        *l = head;
                    }
                }
            });
        })
    };
    pump(board_read, client_write, stop, |(id, head)| {
        if id == ids.1 && head[0] == POSITIVE {
            let command = last_command.lock().map(|l| *l).unwrap_or_default();
            if matches!(command, [START_STOP_SYNCH, 1] | [START_STOP_DAQ_LIST, 1]) {
                shared.update(|s| s.daq_started = true);
            }
        }
    });
    let _ = upstream.join();
}

/// Copies `from` to `to` until either fails or closes (then both are shut down, which ends
/// the other direction's copy too), calling `frame` with the ID and first two data bytes (0
/// beyond its length) of each standard-ID data frame in the stream.
fn pump(
    mut from: TcpStream,
    mut to: TcpStream,
    stop: &AtomicBool,
    mut frame: impl FnMut((u16, [u8; 2])),
) {
    let _ = from.set_read_timeout(Some(Duration::from_millis(100)));
    let mut lines: LineBuffer<{ MAX_LINE + 1 }> = LineBuffer::new();
    let mut chunk = [0u8; 4096];
    while !stop.load(Ordering::Relaxed) {
        let n = match from.read(&mut chunk) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                ) =>
            {
                continue
            }
            Err(_) => break,
        };
        let Some(bytes) = chunk.get(..n) else { break };
        if to.write_all(bytes).is_err() {
            break;
        }
        for &b in bytes {
            if let Ok(Some(line)) = lines.push(b) {
                if let Ok(SlcanLine::Frame(f)) = parse_line(line) {
                    if let (Id::Standard(id), false) = (f.id(), f.remote) {
                        let d = f.data();
                        let at = |k: usize| d.get(k).copied().unwrap_or(0);
                        frame((id.as_raw(), [at(0), at(1)]));
                    }
                }
            }
        }
    }
    let _ = from.shutdown(Shutdown::Both);
    let _ = to.shutdown(Shutdown::Both);
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::BufRead;

    /// A fake board on a local port: answers each SLCAN line from the master with `answer`'s
    /// line (none: no answer), and records what it got.
    fn fake_board(answer: fn(&str) -> Option<String>) -> (SocketAddr, JoinHandle<Vec<String>>) {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = listener.local_addr().unwrap();
        let t = std::thread::spawn(move || {
            let mut got = Vec::new();
            // Two clients, one after another.
            for _ in 0..2 {
                let (stream, _) = listener.accept().unwrap();
                let mut out = stream.try_clone().unwrap();
                let mut reader = io::BufReader::new(stream);
                let mut line = Vec::new();
                while reader.read_until(b'\r', &mut line).unwrap_or(0) > 0 {
                    let text = String::from_utf8_lossy(&line).trim_end().to_string();
                    if let Some(a) = answer(&text) {
                        out.write_all(a.as_bytes()).unwrap();
                    }
                    got.push(text);
                    line.clear();
                }
            }
            got
        });
        (addr, t)
    }

    /// Positive response to every XCP command on 0x7E0.
    fn positive(line: &str) -> Option<String> {
        line.starts_with("t7E0").then(|| "t7E11FF\r".to_string())
    }

    fn client(addr: SocketAddr, lines: &[&str]) -> Vec<u8> {
        let mut s = TcpStream::connect(addr).unwrap();
        s.set_read_timeout(Some(Duration::from_millis(500)))
            .unwrap();
        let mut got = Vec::new();
        for l in lines {
            s.write_all(l.as_bytes()).unwrap();
            let mut buf = [0u8; 64];
            if let Ok(n) = s.read(&mut buf) {
                got.extend_from_slice(&buf[..n]);
            }
        }
        got
    }

    #[test]
    fn relays_both_ways_and_sees_the_daq_start_only_when_acknowledged() {
        let (board, fake) = fake_board(positive);
        let relay = XcpRelay::start("127.0.0.1:0".parse().unwrap(), board, (0x7E0, 0x7E1)).unwrap();
        // CONNECT, then START_STOP_SYNCH stop all (mode 0): no start.
        let got = client(relay.local_addr(), &["t7E02FF00\r", "t7E02DD00\r"]);
        assert_eq!(got, b"t7E11FF\rt7E11FF\r");
        assert!(!relay.wait_for_daq_start(Duration::from_millis(300)));
        // A second client: START_STOP_SYNCH start selected, acknowledged.
        let got = client(relay.local_addr(), &["t7E02DD01\r"]);
        assert_eq!(got, b"t7E11FF\r");
        assert!(relay.wait_for_daq_start(Duration::from_secs(2)));
        assert_eq!(relay.clients(), 2);
        drop(relay);
        let seen = fake.join().unwrap();
        assert_eq!(seen, ["t7E02FF00", "t7E02DD00", "t7E02DD01"]);
    }

    /// A refused start (negative response) is no start.
    #[test]
    fn a_refused_daq_start_is_not_a_start() {
        fn refuse(line: &str) -> Option<String> {
            line.starts_with("t7E0").then(|| "t7E12FE22\r".to_string())
        }
        let (board, _fake) = fake_board(refuse);
        let relay = XcpRelay::start("127.0.0.1:0".parse().unwrap(), board, (0x7E0, 0x7E1)).unwrap();
        let got = client(relay.local_addr(), &["t7E02DD01\r"]);
        assert_eq!(got, b"t7E12FE22\r");
        assert!(!relay.wait_for_daq_start(Duration::from_millis(300)));
    }

    #[test]
    fn an_address_in_use_is_named() {
        let taken = TcpListener::bind("127.0.0.1:0").unwrap();
        let at = taken.local_addr().unwrap();
        let e = XcpRelay::start(at, at, (0x7E0, 0x7E1)).err().unwrap();
        assert!(e.to_string().contains(&at.to_string()), "{e}");
    }
}
