//! Helpers shared by the interoperability tests (each test uses some of them).
#![allow(dead_code)]

use std::path::PathBuf;

/// The workspace root (two levels above this crate).
pub fn workspace() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The Python interpreter of the peers: `MIL_PY` if set, else
/// `<workspace>/target/py-peers/bin/python`. Panics (failing the test) with instructions when
/// neither exists: these tests need a real peer and must not pass silently without one.
pub fn python() -> PathBuf {
    let (py, from) = match std::env::var_os("MIL_PY") {
        Some(p) => (PathBuf::from(p), "MIL_PY"),
        None => (
            workspace().join("target/py-peers/bin/python"),
            "the default location",
        ),
    };
    assert!(
        py.exists(),
        "no Python peer interpreter at {} ({from}). Create the virtual environment with \
         scripts/py-peers.sh (or firmware/frames/tests/peer/setup-venv.sh), or point MIL_PY \
         at a Python with the packages of firmware/frames/tests/peer/requirements.txt.",
        py.display()
    );
    py
}

/// A peer script in `tests/peer/`.
pub fn peer_script(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/peer")
        .join(name)
}

/// Small deterministic generator (xorshift64*), so failures reproduce.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// Uniform in `[lo, hi]`.
    pub fn uniform(&mut self, lo: f32, hi: f32) -> f32 {
        let u = (self.next_u64() >> 11) as f64 / (1_u64 << 53) as f64;
        (f64::from(lo) + u * (f64::from(hi) - f64::from(lo))) as f32
    }

    pub fn byte(&mut self) -> u8 {
        (self.next_u64() >> 56) as u8
    }
}
