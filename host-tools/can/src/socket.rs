//! SocketCAN transport (feature `socketcan`, Linux).

use std::io;
use std::time::Duration;

use mil_frames::embedded_can::{Frame as _, StandardId};
use mil_frames::RawFrame;
use socketcan::{CanFrame, CanSocket, Socket};

use crate::transport::Transport;

/// A SocketCAN interface (`can0`, `vcan0`, a USB adapter's `slcan0`).
///
/// Built by construction only: no test exercises it, because the `vcan` kernel module is
/// not available on the machines the tests run on. The SLCAN transport ([`crate::SlcanTcp`])
/// is the tested one.
pub struct SocketCan {
    socket: CanSocket,
    skipped: u64,
}

impl SocketCan {
    /// Opens the interface `ifname`.
    ///
    /// # Errors
    /// No such interface, or the socket could not be bound.
    pub fn open(ifname: &str) -> io::Result<Self> {
        Ok(Self {
            socket: CanSocket::open(ifname)?,
            skipped: 0,
        })
    }

    /// Extended, remote and error frames received and skipped by `recv`.
    pub fn skipped(&self) -> u64 {
        self.skipped
    }
}

impl Transport for SocketCan {
    fn send(&mut self, frame: &RawFrame) -> io::Result<()> {
        let invalid = || io::Error::new(io::ErrorKind::InvalidInput, "not a standard data frame");
        let id = StandardId::new(frame.id).ok_or_else(invalid)?;
        let data = frame
            .data
            .get(..usize::from(frame.len))
            .ok_or_else(invalid)?;
        let out = CanFrame::new(id, data).ok_or_else(invalid)?;
        self.socket.write_frame(&out)
    }

    fn recv(&mut self, timeout: Duration) -> io::Result<Option<RawFrame>> {
        let deadline = std::time::Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(std::time::Instant::now());
            match self.socket.read_frame_timeout(left) {
                Ok(f) => match RawFrame::try_from_frame(&f) {
                    Ok(raw) => return Ok(Some(raw)),
                    Err(_) => self.skipped += 1,
                },
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock
                    ) =>
                {
                    return Ok(None)
                }
                Err(e) => return Err(e),
            }
        }
    }
}
