//! Seed & key: the algorithm against Python's `hmac`, GET_SEED / UNLOCK sequences.

use super::{err, Rig};
use crate::key::derive_seed;
use crate::mock;
use crate::protocol::{cmd, resource};
use crate::{compute_key, verify_key, ErrorCode};

#[test]
fn key_matches_python_hmac() {
    // python3: hmac.new(b"FAKE-TEST-SECRET-do-not-use-0000", bytes([r]) + seed,
    //                   hashlib.sha256).digest()[:6].hex()
    assert_eq!(
        compute_key(mock::TEST_SECRET, 0x01, &[1, 2, 3, 4, 5, 6]),
        [0xF4, 0xED, 0xD6, 0x78, 0x83, 0x46]
    );
    assert_eq!(
        compute_key(
            mock::TEST_SECRET,
            0x04,
            &[0xDE, 0xAD, 0xBE, 0xEF, 0x00, 0xFF]
        ),
        [0x1D, 0x24, 0x88, 0x3C, 0xDD, 0x55]
    );
    // python3: hashlib.sha256(b"mil-xcp seed" + (1).to_bytes(4, "little")
    //          + (2).to_bytes(4, "little") + (3).to_bytes(4, "little")).digest()[:6].hex()
    assert_eq!(derive_seed(1, 2, 3), [0xF0, 0xC8, 0x01, 0x3B, 0x4C, 0xC2]);
}

#[test]
fn verify_key_checks_every_byte_and_the_length() {
    let seed = [9, 8, 7, 6, 5, 4];
    let key = compute_key(mock::TEST_SECRET, 1, &seed);
    assert!(verify_key(mock::TEST_SECRET, 1, &seed, &key));
    for i in 0..6 {
        let mut k = key;
        k[i] ^= 0x01;
        assert!(!verify_key(mock::TEST_SECRET, 1, &seed, &k), "byte {i}");
    }
    assert!(
        !verify_key(mock::TEST_SECRET, 4, &seed, &key),
        "other resource"
    );
    assert!(!verify_key(
        b"another-fake-secret-for-tests!!",
        1,
        &seed,
        &key
    ));
    assert!(!verify_key(mock::TEST_SECRET, 1, &seed, &key[..5]));
}

#[test]
fn right_key_unlocks_that_resource_only() {
    let mut rig = Rig::new();
    rig.connect();
    assert_eq!(rig.unlock(resource::CAL_PAG), [0xFF, resource::DAQ]);
    assert_eq!(rig.slave.protection(), resource::DAQ);
    assert_eq!(rig.unlock(resource::DAQ), [0xFF, 0x00]);
    // An unlocked resource has no seed: length 0 (pyxcp `cond_unlock` skips it).
    assert_eq!(rig.one(&[cmd::GET_SEED, 0, resource::DAQ]), [0xFF, 0x00]);
}

#[test]
fn seeds_differ_and_one_unlock_per_seed() {
    let mut rig = Rig::new();
    rig.connect();
    let a = rig.one(&[cmd::GET_SEED, 0, 1]);
    let b = rig.one(&[cmd::GET_SEED, 0, 1]);
    assert_eq!(a.len(), 8);
    assert_ne!(a, b);
    // The newest seed counts.
    let seed: [u8; 6] = b[2..8].try_into().unwrap();
    let key = compute_key(mock::TEST_SECRET, 1, &seed);
    let mut unlock = vec![cmd::UNLOCK, 6];
    unlock.extend_from_slice(&key);
    assert_eq!(rig.one(&unlock), [0xFF, 0x04]);
    // The seed is used up.
    assert_eq!(rig.one(&unlock), err(ErrorCode::Sequence));
    assert!(rig.slave.connected());
}

#[test]
fn unlock_without_get_seed_is_a_sequence_error() {
    let mut rig = Rig::new();
    rig.connect();
    assert_eq!(
        rig.one(&[cmd::UNLOCK, 6, 1, 2, 3, 4, 5, 6]),
        err(ErrorCode::Sequence)
    );
    assert!(rig.slave.connected());
    assert_eq!(rig.slave.protection(), 0x05);
}

#[test]
fn wrong_key_answers_access_locked_and_disconnects() {
    let mut rig = Rig::new();
    rig.connect();
    let seed_frame = rig.one(&[cmd::GET_SEED, 0, 1]);
    let seed: [u8; 6] = seed_frame[2..8].try_into().unwrap();
    let mut key = compute_key(mock::TEST_SECRET, 1, &seed);
    key[5] ^= 0x80;
    let mut unlock = vec![cmd::UNLOCK, 6];
    unlock.extend_from_slice(&key);
    assert_eq!(rig.one(&unlock), err(ErrorCode::AccessLocked));
    assert!(!rig.slave.connected());
    assert!(rig.send(&[cmd::GET_STATUS]).is_empty());
    rig.connect();
    assert_eq!(rig.slave.protection(), 0x05);
}

#[test]
fn key_of_another_length_is_a_wrong_key() {
    let mut rig = Rig::new();
    rig.connect();
    rig.one(&[cmd::GET_SEED, 0, 4]);
    assert_eq!(
        rig.one(&[cmd::UNLOCK, 5, 1, 2, 3, 4, 5]),
        err(ErrorCode::AccessLocked)
    );
    assert!(!rig.slave.connected());
}

#[test]
fn get_seed_parameters() {
    let mut rig = Rig::new();
    rig.connect();
    for res in [
        0x00_u8,
        0x02,
        0x05,
        resource::STIM,
        resource::PGM,
        0x20,
        0xFF,
    ] {
        assert_eq!(
            rig.one(&[cmd::GET_SEED, 0, res]),
            err(ErrorCode::OutOfRange),
            "{res:02X}"
        );
    }
    // Mode 1 (remaining part) is not needed: the seed fits one frame.
    assert_eq!(rig.one(&[cmd::GET_SEED, 1, 1]), err(ErrorCode::OutOfRange));
    assert_eq!(rig.one(&[cmd::GET_SEED, 0]), err(ErrorCode::CmdSyntax));
}

#[test]
fn debug_output_does_not_show_the_secret() {
    let mut rig = Rig::new();
    rig.connect();
    let text = format!("{:?} {:?}", rig.slave, rig.slave.config());
    assert!(text.contains("secret_len: 32"), "{text}");
    let secret = core::str::from_utf8(mock::TEST_SECRET).unwrap();
    assert!(!text.contains(secret));
    assert!(!text.contains(&format!("{:?}", mock::TEST_SECRET)));
}
