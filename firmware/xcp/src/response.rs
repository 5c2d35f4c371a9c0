//! The response frames of one command: usually one, up to [`MAX_RESPONSE_FRAMES`] for an
//! UPLOAD in slave block mode, none for a command that is not answered.

use crate::protocol::{pid, ErrorCode, MAX_CTO, MAX_RESPONSE_FRAMES};

/// A fixed buffer of response frames (no heap), filled by [`Slave::handle`](crate::Slave::handle).
/// Send the frames in order, each as one CAN frame (the transport may pad to DLC 8).
#[derive(Clone, Debug)]
pub struct Responses {
    frames: [[u8; MAX_CTO]; MAX_RESPONSE_FRAMES],
    lens: [u8; MAX_RESPONSE_FRAMES],
    count: usize,
}

impl Default for Responses {
    fn default() -> Self {
        Self::new()
    }
}

impl Responses {
    /// An empty buffer.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            frames: [[0; MAX_CTO]; MAX_RESPONSE_FRAMES],
            lens: [0; MAX_RESPONSE_FRAMES],
            count: 0,
        }
    }

    /// Number of frames.
    #[must_use]
    pub const fn len(&self) -> usize {
        self.count
    }

    /// Whether there is no frame (the command is not answered).
    #[must_use]
    pub const fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Frame `index`, `None` beyond the last.
    #[must_use]
    pub fn get(&self, index: usize) -> Option<&[u8]> {
        if index >= self.count {
            return None;
        }
        let len = usize::from(*self.lens.get(index)?);
        self.frames.get(index)?.get(..len)
    }

    /// The frames in sending order.
    pub fn iter(&self) -> impl Iterator<Item = &[u8]> + '_ {
        (0..self.count).filter_map(|i| self.get(i))
    }

    pub(crate) fn clear(&mut self) {
        self.count = 0;
    }

    /// Append a frame (at most [`MAX_CTO`] bytes are kept; a full buffer drops it, which
    /// cannot happen: no command produces more than [`MAX_RESPONSE_FRAMES`] frames).
    pub(crate) fn push(&mut self, frame: &[u8]) {
        let len = frame.len().min(MAX_CTO);
        if let (Some(slot), Some(slot_len), Some(src)) = (
            self.frames.get_mut(self.count),
            self.lens.get_mut(self.count),
            frame.get(..len),
        ) {
            if let Some(dst) = slot.get_mut(..len) {
                dst.copy_from_slice(src);
                // `len <= MAX_CTO = 8` always fits a byte.
                *slot_len = u8::try_from(len).unwrap_or(0);
                self.count += 1;
            }
        }
    }

    /// Replace everything by one error packet `FE code [detail]`.
    pub(crate) fn set_error(&mut self, code: ErrorCode, detail: Option<u8>) {
        self.clear();
        match detail {
            Some(d) => self.push(&[pid::ERR, code.code(), d]),
            None => self.push(&[pid::ERR, code.code()]),
        }
    }

    /// Positive response `FF payload…`.
    pub(crate) fn ok(&mut self, payload: &[u8]) {
        let mut frame = [0_u8; MAX_CTO];
        frame[0] = pid::RES;
        let n = payload.len().min(MAX_CTO - 1);
        if let (Some(dst), Some(src)) = (frame.get_mut(1..=n), payload.get(..n)) {
            dst.copy_from_slice(src);
        }
        if let Some(f) = frame.get(..=n) {
            self.push(f);
        }
    }
}
