//! SLCAN (Lawicel ASCII) on a serial device: USB-CAN adapters such as CANable or CANtact
//! (`/dev/ttyACM0`), or a board's USART behind a USB-serial converter.
//!
//! Opening closes the channel, sets the CAN bit rate (`S8`: 1 Mbit/s, the board's bus) and
//! opens it; replies (OK or BEL) are read and dropped, as python-can does. Receiving cuts
//! lines at `\r` and BEL and keeps standard data frames; anything else is counted.

use std::io::{self, Read, Write};
use std::time::{Duration, Instant};

use mil_can::Transport;
use mil_frames::slcan::{self, SlcanLine};
use mil_frames::RawFrame;

/// Serial line speed used when none is given (USB CDC adapters ignore it).
pub const DEFAULT_BAUD: u32 = 115_200;

/// SLCAN bit-rate code of 1 Mbit/s (`S8`), the board's CAN bus.
pub const BITRATE_1M: u8 = 8;

/// An SLCAN adapter on a serial device.
pub struct SlcanSerial {
    port: Box<dyn serialport::SerialPort>,
    pending: Vec<u8>,
    skipped: u64,
}

impl std::fmt::Debug for SlcanSerial {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SlcanSerial")
            .field("port", &self.port.name())
            .field("skipped", &self.skipped)
            .finish()
    }
}

impl SlcanSerial {
    /// Opens `path` at `baud` and the CAN channel at SLCAN bit-rate code `bitrate_code`
    /// (`S0`…`S8`; 8 = 1 Mbit/s).
    ///
    /// # Errors
    /// The device cannot be opened or written.
    pub fn open(path: &str, baud: u32, bitrate_code: u8) -> io::Result<Self> {
        let port = serialport::new(path, baud)
            .timeout(Duration::from_millis(10))
            .open()
            .map_err(|e| {
                io::Error::new(io::Error::from(e.clone()).kind(), format!("{path}: {e}"))
            })?;
        let mut s = Self {
            port,
            pending: Vec::with_capacity(256),
            skipped: 0,
        };
        s.port.write_all(b"C\r")?;
        s.port.write_all(format!("S{bitrate_code}\r").as_bytes())?;
        s.port.write_all(b"O\r")?;
        // Drop the replies (OK or BEL for each line; an adapter already closed answers BEL
        // to C).
        let until = Instant::now() + Duration::from_millis(100);
        while s.read_line(until)?.is_some() {}
        Ok(s)
    }

    /// Lines received that were not standard data frames.
    pub fn skipped(&self) -> u64 {
        self.skipped
    }

    /// Closes the CAN channel (`C`).
    ///
    /// # Errors
    /// The device cannot be written.
    pub fn close(&mut self) -> io::Result<()> {
        self.port.write_all(b"C\r")
    }

    fn read_line(&mut self, deadline: Instant) -> io::Result<Option<Vec<u8>>> {
        loop {
            if let Some(i) = self.pending.iter().position(|b| *b == b'\r' || *b == 0x07) {
                let keep = usize::from(self.pending[i] == 0x07);
                let mut line: Vec<u8> = self.pending.drain(..=i).collect();
                line.truncate(i + keep);
                return Ok(Some(line));
            }
            if Instant::now() >= deadline {
                return Ok(None);
            }
            let mut chunk = [0u8; 256];
            match self.port.read(&mut chunk) {
                Ok(0) => {}
                Ok(n) => self.pending.extend_from_slice(&chunk[..n]),
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::TimedOut
                            | io::ErrorKind::WouldBlock
                            | io::ErrorKind::Interrupted
                    ) => {}
                Err(e) => return Err(e),
            }
        }
    }
}

impl Transport for SlcanSerial {
    fn send(&mut self, frame: &RawFrame) -> io::Result<()> {
        let mut line = [0u8; slcan::MAX_LINE + 1];
        let n = slcan::format_frame(frame, &mut line)
            .map_err(|e| io::Error::new(io::ErrorKind::InvalidInput, e.to_string()))?;
        self.port.write_all(&line[..n])
    }

    fn recv(&mut self, timeout: Duration) -> io::Result<Option<RawFrame>> {
        let deadline = Instant::now() + timeout;
        while let Some(line) = self.read_line(deadline)? {
            if let Ok(SlcanLine::Frame(f)) = slcan::parse_line(&line) {
                if let Ok(raw) = RawFrame::try_from_frame(&f) {
                    return Ok(Some(raw));
                }
            }
            self.skipped += 1;
        }
        Ok(None)
    }
}
