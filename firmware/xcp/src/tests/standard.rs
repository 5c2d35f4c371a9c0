//! CONNECT, DISCONNECT, GET_STATUS, SYNCH, GET_COMM_MODE_INFO, GET_ID, unknown and malformed
//! commands.

use super::{err, Rig};
use crate::mock;
use crate::protocol::{cmd, resource};
use crate::{ConfigError, ErrorCode, Region, Slave};

#[test]
fn connect_answers_the_fields_pyxcp_parses() {
    let mut rig = Rig::new();
    let res = rig.one(&[cmd::CONNECT, 0x00]);
    assert_eq!(res, [0xFF, 0x05, 0xC0, 0x08, 0x08, 0x00, 0x01, 0x01]);
    // pyxcp `ConnectResponse`: resource BitStruct (Padding(2), dbg, pgm, stim, daq,
    // Padding(1), calpag), commModeBasic (optional, slaveBlockMode, Padding(3),
    // addressGranularity(2), byteOrder), maxCto, maxDto Int16u, protocol, transport.
    let resource_byte = res[1];
    assert_eq!(resource_byte & 0x01, 0x01, "CAL/PAG");
    assert_eq!(resource_byte & 0x04, 0x04, "DAQ");
    assert_eq!(resource_byte & (0x08 | 0x10 | 0x20), 0, "no STIM, PGM, DBG");
    let comm_mode_basic = res[2];
    assert_eq!(comm_mode_basic & 0x01, 0, "Intel byte order");
    assert_eq!((comm_mode_basic >> 1) & 0x03, 0, "address granularity BYTE");
    assert_eq!(comm_mode_basic & 0x40, 0x40, "slave block mode");
    assert_eq!(comm_mode_basic & 0x80, 0x80, "optional: GET_COMM_MODE_INFO");
    assert_eq!(res[3], 8, "MAX_CTO");
    assert_eq!(u16::from_le_bytes([res[4], res[5]]), 8, "MAX_DTO");
    assert!(rig.slave.connected());
    assert_eq!(rig.slave.protection(), resource::CAL_PAG | resource::DAQ);
}

#[test]
fn connect_accepts_padding_and_refuses_other_modes() {
    let mut rig = Rig::new();
    assert_eq!(rig.one(&[cmd::CONNECT, 0x01]), err(ErrorCode::OutOfRange));
    assert!(!rig.slave.connected());
    assert_eq!(rig.one(&[cmd::CONNECT]), err(ErrorCode::CmdSyntax));
    // pyxcp pads requests to DLC 8 when `MAX_DLC_REQUIRED` is set.
    let res = rig.one(&[cmd::CONNECT, 0, 0, 0, 0, 0, 0, 0]);
    assert_eq!(res[0], 0xFF);
    assert!(rig.slave.connected());
}

#[test]
fn nothing_is_answered_while_disconnected() {
    let mut rig = Rig::new();
    for cto in [
        &[cmd::GET_STATUS][..],
        &[cmd::SYNCH],
        &[cmd::DISCONNECT],
        &[cmd::GET_SEED, 0, 1],
        &[0x00],
        &[],
        &[0x12, 0x34, 0x56],
        &[cmd::CONNECT, 0, 0, 0, 0, 0, 0, 0, 0], // 9 bytes: not a CTO
    ] {
        assert!(rig.send(cto).is_empty(), "{cto:02X?}");
    }
    assert!(!rig.slave.connected());
}

#[test]
fn disconnect_answers_then_goes_silent_and_relocks() {
    let mut rig = Rig::new();
    rig.connect_unlocked();
    assert_eq!(rig.slave.protection(), 0);
    rig.ok(&[cmd::DISCONNECT]);
    assert!(!rig.slave.connected());
    assert!(rig.send(&[cmd::GET_STATUS]).is_empty());
    rig.connect();
    assert_eq!(
        rig.one(&[cmd::GET_STATUS]),
        [0xFF, 0x00, 0x05, 0x00, 0x00, 0x00]
    );
}

#[test]
fn connect_while_connected_starts_a_fresh_session() {
    let mut rig = Rig::new();
    rig.connect_unlocked();
    rig.connect();
    assert_eq!(rig.slave.protection(), resource::CAL_PAG | resource::DAQ);
}

#[test]
fn get_status_layout() {
    let mut rig = Rig::new();
    rig.connect();
    // session status, protection mask (CAL/PAG | DAQ), reserved, session configuration id 0.
    assert_eq!(
        rig.one(&[cmd::GET_STATUS]),
        [0xFF, 0x00, 0x05, 0x00, 0x00, 0x00]
    );
    assert_eq!(rig.unlock(resource::DAQ), [0xFF, 0x01]);
    assert_eq!(
        rig.one(&[cmd::GET_STATUS]),
        [0xFF, 0x00, 0x01, 0x00, 0x00, 0x00]
    );
}

#[test]
fn synch_answers_err_cmd_synch() {
    let mut rig = Rig::new();
    rig.connect();
    assert_eq!(rig.one(&[cmd::SYNCH]), [0xFE, 0x00]);
    assert!(rig.slave.connected());
}

#[test]
fn get_comm_mode_info_layout() {
    let mut rig = Rig::new();
    rig.connect();
    let res = rig.one(&[cmd::GET_COMM_MODE_INFO]);
    // reserved, COMM_MODE_OPTIONAL (bit 0 master block mode), reserved, MAX_BS, MIN_ST,
    // QUEUE_SIZE, driver version.
    assert_eq!(res, [0xFF, 0x00, 0x01, 0x00, 42, 0x00, 0x00, 0x01]);
    assert!(res[4] >= 20, "MAX_BS of at least 20 frames");
}

#[test]
fn get_id_sets_the_mta_to_the_id_string() {
    let mut rig = Rig::new();
    rig.connect();
    let len = mock::ID.len() as u32;
    let l = len.to_le_bytes();
    // Mode 0: upload from the MTA (pyxcp `identifier()`: bit 0 set would mean inline).
    assert_eq!(
        rig.one(&[cmd::GET_ID, 1]),
        [0xFF, 0x00, 0x00, 0x00, l[0], l[1], l[2], l[3]]
    );
    // pyxcp `fetch(length)` with slave block mode: one UPLOAD of the whole length.
    let frames = rig.send(&[cmd::UPLOAD, len as u8]);
    assert_eq!(frames.len(), 2);
    assert_eq!(frames[0][0], 0xFF);
    assert_eq!(frames[1][0], 0xFF);
    let text: Vec<u8> = frames.iter().flat_map(|f| f[1..].to_vec()).collect();
    assert_eq!(text, mock::ID);
    // The virtual area ends with the string.
    rig.send(&[cmd::GET_ID, 1]);
    assert_eq!(
        rig.one(&[cmd::UPLOAD, len as u8 + 1]),
        err(ErrorCode::AccessDenied)
    );
    // Nothing can be written through it.
    rig.connect_unlocked();
    rig.send(&[cmd::GET_ID, 1]);
    let before = rig.snapshot();
    assert_eq!(
        rig.one(&[cmd::DOWNLOAD, 2, 0, 0]),
        err(ErrorCode::AccessDenied)
    );
    assert_eq!(rig.snapshot(), before);
}

#[test]
fn get_id_of_other_types_is_out_of_range() {
    let mut rig = Rig::new();
    rig.connect();
    for ty in [0_u8, 2, 3, 4, 5, 0x80, 0xFF] {
        assert_eq!(
            rig.one(&[cmd::GET_ID, ty]),
            err(ErrorCode::OutOfRange),
            "{ty}"
        );
    }
    assert_eq!(rig.one(&[cmd::GET_ID]), err(ErrorCode::CmdSyntax));
}

#[test]
fn unknown_and_malformed_commands() {
    let mut rig = Rig::new();
    rig.connect();
    // Optional commands not implemented, and codes that are not commands.
    for code in [
        0xF3_u8, 0xF2, 0xF1, 0xEE, 0xED, 0xEC, 0xE6, 0xE5, 0xE3, 0xDB, 0xD8, 0xD2, 0xC7, 0xC0,
        0x00, 0x42,
    ] {
        assert_eq!(
            rig.one(&[code, 0, 0, 0]),
            err(ErrorCode::CmdUnknown),
            "{code:02X}"
        );
    }
    assert_eq!(rig.one(&[]), err(ErrorCode::CmdSyntax));
    assert_eq!(
        rig.one(&[cmd::GET_STATUS, 0, 0, 0, 0, 0, 0, 0, 0]),
        err(ErrorCode::CmdSyntax)
    );
    assert_eq!(
        rig.one(&[cmd::SET_MTA, 0, 0, 0, 0]),
        err(ErrorCode::CmdSyntax)
    );
    assert!(rig.slave.connected());
}

#[test]
fn configs_are_checked() {
    let good = mock::config();
    assert!(Slave::new(good).is_ok());
    let mut c = good;
    c.calibration = Region::new(0xFFFF_FF00, 0x100);
    assert_eq!(Slave::new(c).err(), Some(ConfigError::BadRegion));
    c.calibration = Region::new(0xFFFF_FF00, 0xFF);
    assert!(Slave::new(c).is_ok(), "ends at u32::MAX");
    c = good;
    c.measurement = Region::new(0x1000, 0);
    assert_eq!(Slave::new(c).err(), Some(ConfigError::BadRegion));
    c = good;
    let end = mock::CAL_START + mock::CAL_LEN as u32;
    c.measurement = Region::new(end - 1, 4);
    assert_eq!(Slave::new(c).err(), Some(ConfigError::RegionsOverlap));
    c.measurement = Region::new(end, 4);
    assert!(Slave::new(c).is_ok(), "adjacent regions");
    c = good;
    c.secret = b"short";
    assert_eq!(Slave::new(c).err(), Some(ConfigError::SecretTooShort));
}

/// SET_REQUEST STORE_CAL_REQ: locked until CAL/PAG is unlocked, other modes refused, the
/// application's refusal answered with its error, a taken request pending in GET_STATUS
/// (bit 0) until the application says it is done, which sends EV_STORE_CAL.
#[test]
fn set_request_store_cal_is_pending_until_the_store_is_done() {
    use crate::memory::StoreRefused;
    let mut rig = Rig::new();
    rig.connect();
    assert_eq!(rig.one(&[0xF9, 0x01, 0, 0]), err(ErrorCode::AccessLocked));
    rig.connect_unlocked();
    assert_eq!(rig.one(&[0xF9, 0x02, 0, 0]), err(ErrorCode::OutOfRange));
    assert_eq!(rig.one(&[0xF9]), err(ErrorCode::CmdSyntax));
    rig.ecu.refuse_store = Some(StoreRefused::NotNow);
    assert_eq!(
        rig.one(&[0xF9, 0x01, 0, 0]),
        err(ErrorCode::ResourceTemporaryNotAccessible)
    );
    assert!(!rig.slave.store_pending());
    rig.ecu.refuse_store = None;
    assert_eq!(rig.one(&[cmd::GET_STATUS])[1] & 0x01, 0);
    assert_eq!(rig.one(&[0xF9, 0x01, 0, 0]), [0xFF]);
    assert!(rig.slave.store_pending());
    assert_eq!(rig.one(&[cmd::GET_STATUS])[1] & 0x01, 0x01);
    // A second request joins the pending one.
    assert_eq!(rig.one(&[0xF9, 0x01]), [0xFF]);
    assert_eq!(rig.ecu.store_requests, 1);
    let mut out = crate::Responses::new();
    rig.slave.store_finished(true, &mut out);
    assert_eq!(out.iter().collect::<Vec<_>>(), [&[0xFD, 0x03][..]]);
    assert_eq!(rig.one(&[cmd::GET_STATUS])[1] & 0x01, 0);
    // A failed store clears the bit without the event.
    assert_eq!(rig.one(&[0xF9, 0x01, 0, 0]), [0xFF]);
    rig.slave.store_finished(false, &mut out);
    assert!(out.is_empty());
    assert!(!rig.slave.store_pending());
}
