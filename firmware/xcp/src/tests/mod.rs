//! Unit tests: byte-exact command layouts, seed & key, region checks, block downloads, page
//! switching, a full DAQ session, and proptest fuzzing against the mock ECU.

mod daq;
mod fuzz;
mod key;
mod memory;
mod paging;
mod standard;

use crate::mock::{self, MockEcu, MockPlatform};
use crate::protocol::{cmd, resource};
use crate::{compute_key, Responses, Slave, SlaveConfig};

/// A slave, the mock ECU and the response buffer.
pub(crate) struct Rig {
    pub slave: Slave,
    pub ecu: MockEcu,
    pub platform: MockPlatform,
    pub out: Responses,
}

impl Rig {
    pub fn new() -> Self {
        Self::with_config(mock::config())
    }

    pub fn with_config(config: SlaveConfig) -> Self {
        Self {
            slave: Slave::new(config).expect("valid config"),
            ecu: MockEcu::new(),
            platform: MockPlatform::default(),
            out: Responses::new(),
        }
    }

    /// Send one command; all response frames.
    pub fn send(&mut self, cto: &[u8]) -> Vec<Vec<u8>> {
        self.slave
            .handle(cto, &mut self.ecu, &mut self.platform, &mut self.out);
        self.out.iter().map(<[u8]>::to_vec).collect()
    }

    /// Send one command that must be answered with exactly one frame.
    pub fn one(&mut self, cto: &[u8]) -> Vec<u8> {
        let frames = self.send(cto);
        assert_eq!(frames.len(), 1, "{cto:02X?} answered {frames:02X?}");
        frames.into_iter().next().unwrap_or_default()
    }

    /// Send one command that must be answered `FF` (nothing else).
    pub fn ok(&mut self, cto: &[u8]) {
        assert_eq!(self.one(cto), [0xFF], "{cto:02X?}");
    }

    pub fn connect(&mut self) {
        assert_eq!(self.one(&[cmd::CONNECT, 0])[0], 0xFF);
    }

    /// GET_SEED + UNLOCK with the right key; returns the UNLOCK answer.
    pub fn unlock(&mut self, res: u8) -> Vec<u8> {
        let seed_frame = self.one(&[cmd::GET_SEED, 0, res]);
        assert_eq!(&seed_frame[..2], [0xFF, 6]);
        let seed: [u8; 6] = seed_frame[2..8].try_into().unwrap();
        let key = compute_key(mock::TEST_SECRET, res, &seed);
        let mut unlock = vec![cmd::UNLOCK, 6];
        unlock.extend_from_slice(&key);
        self.one(&unlock)
    }

    pub fn connect_unlocked(&mut self) {
        self.connect();
        assert_eq!(self.unlock(resource::CAL_PAG), [0xFF, resource::DAQ]);
        assert_eq!(self.unlock(resource::DAQ), [0xFF, 0x00]);
    }

    pub fn set_mta(&mut self, addr: u32) {
        let a = addr.to_le_bytes();
        self.ok(&[cmd::SET_MTA, 0, 0, 0, a[0], a[1], a[2], a[3]]);
    }

    /// Everything the slave must never change by itself: image and reference page.
    pub fn snapshot(&self) -> (Vec<u8>, Vec<u8>) {
        (self.ecu.image.to_vec(), self.ecu.reference.to_vec())
    }
}

/// An error frame `FE code`.
pub(crate) fn err(code: crate::ErrorCode) -> Vec<u8> {
    vec![0xFE, code.code()]
}

/// `SHORT_UPLOAD n addr`.
pub(crate) fn short_upload(n: u8, addr: u32) -> Vec<u8> {
    let a = addr.to_le_bytes();
    vec![cmd::SHORT_UPLOAD, n, 0, 0, a[0], a[1], a[2], a[3]]
}

/// `WRITE_DAQ 0xFF size 0 addr`.
pub(crate) fn write_daq(size: u8, addr: u32) -> Vec<u8> {
    let a = addr.to_le_bytes();
    vec![cmd::WRITE_DAQ, 0xFF, size, 0, a[0], a[1], a[2], a[3]]
}
