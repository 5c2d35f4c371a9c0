//! The transport trait.

use std::io;
use std::time::Duration;

use mil_frames::RawFrame;

/// A CAN transport carrying standard data frames ([`RawFrame`]) to and from the board.
pub trait Transport {
    /// Sends one frame.
    ///
    /// # Errors
    /// The underlying socket's error.
    fn send(&mut self, frame: &RawFrame) -> io::Result<()>;

    /// Receives the next standard data frame, waiting at most `timeout`; `Ok(None)` on
    /// timeout. Anything else the transport receives (replies, extended or remote frames) is
    /// skipped and counted by the transport.
    ///
    /// # Errors
    /// The underlying socket's error; [`io::ErrorKind::UnexpectedEof`] when the peer closed.
    fn recv(&mut self, timeout: Duration) -> io::Result<Option<RawFrame>>;
}
