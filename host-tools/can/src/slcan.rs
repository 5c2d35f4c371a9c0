//! SLCAN (Lawicel ASCII) over TCP.

use std::io::{self, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::time::{Duration, Instant};

use mil_frames::slcan::{self, SlcanLine};
use mil_frames::RawFrame;

use crate::transport::Transport;

/// Lines [`SlcanTcp`] received that were not standard data frames (skipped by `recv`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LineCounts {
    /// Standard data frames returned by `recv`.
    pub frames: u64,
    /// OK replies (an empty line, `\r`).
    pub ok: u64,
    /// Error replies (BEL).
    pub error: u64,
    /// Extended or remote frames (skipped).
    pub other_frames: u64,
    /// Other lines: version, serial number or status replies, and lines that do not parse.
    pub other: u64,
}

/// SLCAN over a TCP stream, e.g. QEMU's `-serial tcp:127.0.0.1:PORT,server=on` for the QEMU
/// build's USART1. `TCP_NODELAY` is on: each line is one small write.
///
/// Receiving cuts lines at `\r` and at BEL (the error reply has no `\r`), as python-can does.
#[derive(Debug)]
pub struct SlcanTcp {
    stream: TcpStream,
    pending: Vec<u8>,
    counts: LineCounts,
}

impl SlcanTcp {
    /// Connects to `addr`, retrying (QEMU opens its port a moment after it starts) until
    /// `timeout` has passed.
    ///
    /// # Errors
    /// The last connection error when the deadline passed.
    pub fn connect(addr: SocketAddr, timeout: Duration) -> io::Result<Self> {
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match TcpStream::connect_timeout(&addr, left.max(Duration::from_millis(10))) {
                Ok(stream) => return Self::from_stream(stream),
                Err(e) if Instant::now() >= deadline => return Err(e),
                Err(_) => std::thread::sleep(Duration::from_millis(20)),
            }
        }
    }

    /// Wraps a connected stream (sets `TCP_NODELAY`).
    ///
    /// # Errors
    /// Setting the socket option failed.
    pub fn from_stream(stream: TcpStream) -> io::Result<Self> {
        stream.set_nodelay(true)?;
        Ok(Self {
            stream,
            pending: Vec::with_capacity(256),
            counts: LineCounts::default(),
        })
    }

    /// The opening handshake, as the firmware's `link::SlcanSession` expects it.
    ///
    /// Bytes sent before the firmware enables its USART are dropped, so the host repeats
    /// `C\r` `S8\r` (close, 1 Mbit/s) every 100 ms until any reply arrives (`\r`, or BEL for
    /// a line cut by the dropped bytes). Both are harmless while the channel is closed; `O`
    /// is not repeated, because a `C` reaching an *open* session ends the QEMU run (the
    /// firmware prints its report and exits). Then, after the replies have stopped for
    /// 100 ms, `O\r` once, and its OK is awaited.
    ///
    /// # Errors
    /// No reply within `timeout`, or a socket error.
    pub fn open(&mut self, timeout: Duration) -> io::Result<()> {
        let deadline = Instant::now() + timeout;
        let timed_out = || io::Error::new(io::ErrorKind::TimedOut, "SLCAN handshake: no reply");
        // 1. Until the board answers anything.
        'probe: loop {
            if Instant::now() >= deadline {
                return Err(timed_out());
            }
            self.send_line(b"C\rS8\r")?;
            let until = Instant::now() + Duration::from_millis(100);
            while Instant::now() < until {
                if self.read_line(until)?.is_some() {
                    break 'probe;
                }
            }
        }
        // 2. Drain the replies to the repeated probes.
        loop {
            let quiet = Instant::now() + Duration::from_millis(100);
            if self.read_line(quiet)?.is_none() {
                break;
            }
            if Instant::now() >= deadline {
                return Err(timed_out());
            }
        }
        // 3. Open, once.
        self.send_line(b"O\r")?;
        while let Some(line) = self.read_line(deadline)? {
            if line.is_empty() {
                self.counts.ok += 1;
                return Ok(());
            }
            self.count(&line);
        }
        Err(timed_out())
    }

    /// Closes the channel (`C\r`). The QEMU build answers OK, prints its report on
    /// semihosting and exits.
    ///
    /// # Errors
    /// A socket error.
    pub fn close(&mut self) -> io::Result<()> {
        self.send_line(b"C\r")
    }

    /// Sends raw bytes as they are (include the `\r`): for malformed-input tests.
    ///
    /// # Errors
    /// A socket error.
    pub fn send_line(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.stream.write_all(bytes)
    }

    /// The lines received so far, by kind.
    pub fn line_counts(&self) -> LineCounts {
        self.counts
    }

    /// Next line (without its `\r`; a BEL line is `[0x07]`) by `deadline`.
    fn read_line(&mut self, deadline: Instant) -> io::Result<Option<Vec<u8>>> {
        loop {
            if let Some(i) = self.pending.iter().position(|b| *b == b'\r' || *b == 0x07) {
                let keep = usize::from(self.pending[i] == 0x07);
                let mut line: Vec<u8> = self.pending.drain(..=i).collect();
                line.truncate(i + keep);
                return Ok(Some(line));
            }
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Ok(None);
            }
            self.stream.set_read_timeout(Some(left))?;
            let mut chunk = [0u8; 1024];
            match self.stream.read(&mut chunk) {
                Ok(0) => {
                    return Err(io::Error::new(
                        io::ErrorKind::UnexpectedEof,
                        "SLCAN peer closed the connection",
                    ))
                }
                Ok(n) => self.pending.extend_from_slice(&chunk[..n]),
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                    ) =>
                {
                    return Ok(None)
                }
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
        }
    }

    /// Counts a line that is not a standard data frame.
    fn count(&mut self, line: &[u8]) {
        match line {
            [] => self.counts.ok += 1,
            [0x07] => self.counts.error += 1,
            _ => match slcan::parse_line(line) {
                Ok(SlcanLine::Frame(_)) => self.counts.other_frames += 1,
                _ => self.counts.other += 1,
            },
        }
    }
}

impl Transport for SlcanTcp {
    fn send(&mut self, frame: &RawFrame) -> io::Result<()> {
        let mut line = [0u8; slcan::MAX_LINE + 1];
        let n = slcan::format_frame(frame, &mut line)
            .map_err(|e| io::Error::new(io::ErrorKind::InvalidInput, e.to_string()))?;
        self.stream.write_all(&line[..n])
    }

    fn recv(&mut self, timeout: Duration) -> io::Result<Option<RawFrame>> {
        let deadline = Instant::now() + timeout;
        while let Some(line) = self.read_line(deadline)? {
            if let Ok(SlcanLine::Frame(f)) = slcan::parse_line(&line) {
                if let Ok(raw) = RawFrame::try_from_frame(&f) {
                    self.counts.frames += 1;
                    return Ok(Some(raw));
                }
            }
            self.count(&line);
        }
        Ok(None)
    }
}
