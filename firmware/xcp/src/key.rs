//! Seed & key: the 6-byte seed and the key algorithm shared with the host tool and Python.
//!
//! `key = HMAC-SHA256(secret, [resource] ‖ seed)[0..6]`: the HMAC key is the secret, the
//! message is 7 bytes, the resource byte (0x01 CAL/PAG or 0x04 DAQ, as sent in GET_SEED)
//! followed by the 6 seed bytes as received; the key is the first 6 bytes of the 32-byte tag.
//! In Python: `hmac.new(secret, bytes([resource]) + seed, hashlib.sha256).digest()[:6]`.

use hmac::{Hmac, Mac};
use sha2::{Digest, Sha256};

/// Seed length in bytes (fits one CAN frame: `FF 06 s0..s5`).
pub const SEED_LEN: usize = 6;
/// Key length in bytes (fits one CAN frame: `F7 06 k0..k5`).
pub const KEY_LEN: usize = 6;

/// The key for `resource` and `seed` (see the module documentation for the algorithm).
#[must_use]
pub fn compute_key(secret: &[u8], resource: u8, seed: &[u8; SEED_LEN]) -> [u8; KEY_LEN] {
    let mut key = [0_u8; KEY_LEN];
    // HMAC accepts keys of every length, so this never fails; the all-zero fallback is
    // unreachable (and `SlaveConfig::validate` refuses short secrets anyway).
    if let Ok(mut mac) = <Hmac<Sha256> as Mac>::new_from_slice(secret) {
        mac.update(&[resource]);
        mac.update(seed);
        let tag = mac.finalize().into_bytes();
        for (k, t) in key.iter_mut().zip(tag.iter()) {
            *k = *t;
        }
    }
    key
}

/// Whether `given` is the key for `resource` and `seed`; the comparison takes the same time
/// whatever the bytes.
#[must_use]
pub fn verify_key(secret: &[u8], resource: u8, seed: &[u8; SEED_LEN], given: &[u8]) -> bool {
    let expected = compute_key(secret, resource, seed);
    if given.len() != KEY_LEN {
        return false;
    }
    let diff = expected
        .iter()
        .zip(given.iter())
        .fold(0_u8, |acc, (e, g)| acc | (e ^ g));
    diff == 0
}

/// A fresh seed from the slave's counter and two entropy words of the platform: the first
/// 6 bytes of `SHA-256("mil-xcp seed" ‖ counter ‖ a ‖ b)` (little-endian words).
#[must_use]
pub(crate) fn derive_seed(counter: u32, a: u32, b: u32) -> [u8; SEED_LEN] {
    let digest = Sha256::new()
        .chain_update(b"mil-xcp seed")
        .chain_update(counter.to_le_bytes())
        .chain_update(a.to_le_bytes())
        .chain_update(b.to_le_bytes())
        .finalize();
    let mut seed = [0_u8; SEED_LEN];
    for (s, d) in seed.iter_mut().zip(digest.iter()) {
        *s = *d;
    }
    seed
}
