//! A board's whole parameter set written over XCP on its link, as changes it accepts one
//! by one: how a test (or a tool) puts the firmware into another configuration.
//!
//! The board validates every write as a whole page (`mil_firmware::calibration`): a page
//! that is not a valid set at every step is refused. Going from one configuration to
//! another (tyre x1 to aero x2, say) therefore needs an order: the new channels' limits
//! before their safe demands, the channel count before the model kind that needs it.
//! [`configure`] finds one without knowing the rules: it writes every slot that differs,
//! one DOWNLOAD each, and repeats the refused ones while a pass makes progress. Each write
//! that is accepted is a valid page, so the board never runs an invalid set; the model
//! kind, channel count and sample rate change only while the controller is Idle (the
//! board refuses them otherwise).

use std::time::{Duration, Instant};

use mil_firmware::calibration::SLOTS;
use mil_firmware::config::{XCP_COMMAND_ID, XCP_RESPONSE_ID};
use mil_frames::RawFrame;

use crate::transport::Transport;

/// How long to wait for one XCP response.
const RESPONSE_TIMEOUT: Duration = Duration::from_secs(2);

/// What [`configure`] did.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Configured {
    /// The writes the board accepted, in order: slot and word. Each was one change the
    /// board installed (a mirror replays them: [`crate::RemoteBoard::replay`]).
    pub writes: Vec<(usize, u32)>,
    /// Refusals on the way (writes retried in a later pass).
    pub retried: usize,
    /// Passes over the remaining slots.
    pub passes: usize,
}

/// Raw XCP commands on the board's link (CAN IDs of `mil_firmware::config`): what tests and
/// benchmarks that drive the firmware's slave by hand use (the full master is
/// `mil-xcp-master`).
pub struct XcpLink<'a, T: Transport> {
    link: &'a mut T,
}

impl<'a, T: Transport> XcpLink<'a, T> {
    /// Commands on `link`.
    pub fn new(link: &'a mut T) -> Self {
        Self { link }
    }

    /// One command; its response packet, positive or not (DAQ packets met meanwhile are
    /// skipped).
    ///
    /// # Errors
    /// A transport error, or no response within 2 s.
    pub fn command(&mut self, cto: &[u8]) -> Result<Vec<u8>, String> {
        let frame = RawFrame::from_parts(XCP_COMMAND_ID, cto)
            .ok_or_else(|| format!("XCP command {cto:02X?}: longer than a CAN frame"))?;
        self.link
            .send(&frame)
            .map_err(|e| format!("send XCP command: {e}"))?;
        let deadline = Instant::now() + RESPONSE_TIMEOUT;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let Some(f) = self
                .link
                .recv(left)
                .map_err(|e| format!("receive XCP response: {e}"))?
            else {
                return Err(format!(
                    "no XCP response to {cto:02X?} within {RESPONSE_TIMEOUT:?}"
                ));
            };
            let p = f.payload();
            // Responses start with 0xFF (positive) or 0xFE (error); DTOs carry lower PIDs.
            if f.id == XCP_RESPONSE_ID && p.first().is_some_and(|&b| b >= 0xFE) {
                return Ok(p.to_vec());
            }
        }
    }

    /// A command that must succeed; its positive response.
    ///
    /// # Errors
    /// As [`XcpLink::command`], and a negative response.
    pub fn ok(&mut self, cto: &[u8]) -> Result<Vec<u8>, String> {
        let r = self.command(cto)?;
        if r.first() == Some(&0xFF) {
            Ok(r)
        } else {
            Err(format!("XCP command {cto:02X?} refused: {r:02X?}"))
        }
    }

    /// CONNECT, then unlocks `resource` (a `GET_SEED` resource bit) with `secret`'s key.
    ///
    /// # Errors
    /// No answer, a seed of another length than the firmware's 6 bytes, a refused key.
    pub fn connect_unlock(&mut self, secret: &[u8], resource: u8) -> Result<(), String> {
        self.ok(&[0xFF, 0x00])?;
        let seed = self.ok(&[0xF8, 0x00, resource])?;
        let seed: [u8; 6] = seed
            .get(2..8)
            .and_then(|s| s.try_into().ok())
            .ok_or_else(|| format!("a seed of another length: {seed:02X?}"))?;
        let key = mil_xcp::compute_key(secret, resource, &seed);
        let mut unlock = vec![0xF7, 6];
        unlock.extend_from_slice(&key);
        self.ok(&unlock)?;
        Ok(())
    }
}

/// Connects to the board's XCP slave, unlocks calibration with `secret`, writes every slot
/// of `target` that differs from `current` (the working page as it is, e.g. the defaults
/// after a boot without a stored page) at the page's `working_address`, and disconnects.
///
/// # Errors
/// The board does not answer, refuses the key, or refuses some slots in every order tried
/// (the slots and the board's last error code named).
pub fn configure<T: Transport>(
    link: &mut T,
    working_address: u32,
    secret: &[u8],
    current: &[u32; SLOTS],
    target: &[u32; SLOTS],
) -> Result<Configured, String> {
    let mut xcp = XcpLink::new(link);
    xcp.connect_unlock(secret, 0x01)?; // CAL/PAG
    let mut pending: Vec<usize> = (0..SLOTS).filter(|&s| current[s] != target[s]).collect();
    let mut done = Configured {
        writes: Vec::new(),
        retried: 0,
        passes: 0,
    };
    let mut last_error = Vec::new();
    while !pending.is_empty() {
        done.passes += 1;
        let before = pending.len();
        let mut refused = Vec::new();
        for slot in pending {
            let a = (working_address + 4 * slot as u32).to_le_bytes();
            xcp.ok(&[0xF6, 0, 0, 0, a[0], a[1], a[2], a[3]])?;
            let v = target[slot].to_le_bytes();
            let r = xcp.command(&[0xF0, 4, v[0], v[1], v[2], v[3]])?;
            if r.first() == Some(&0xFF) {
                done.writes.push((slot, target[slot]));
            } else {
                done.retried += 1;
                last_error = r;
                refused.push(slot);
            }
        }
        if refused.len() == before {
            let _ = xcp.command(&[0xFE]);
            return Err(format!(
                "slots {refused:?} refused in every order (last error {last_error:02X?})"
            ));
        }
        pending = refused;
    }
    xcp.ok(&[0xFE])?;
    Ok(done)
}
