//! DAQ: a full session down to the DTO bytes, allocation rules, checks, queries.

use super::{err, write_daq, Rig};
use crate::commands::daq::event_cycle;
use crate::mock::{CAL_START, MEAS_START};
use crate::protocol::{cmd, resource};
use crate::{ErrorCode, Page};

fn sample(rig: &mut Rig, event: u16, ts: u32) -> Vec<Vec<u8>> {
    let mut dtos = Vec::new();
    rig.slave
        .sample_daq(event, ts, &rig.ecu, |dto| dtos.push(dto.to_vec()));
    dtos
}

/// Two lists: list 0 (timestamped) with ODT 0 = meas[0x10..0x12] + meas[0x20] and
/// ODT 1 = calibration parameter 1 (f32) + meas[0x30..0x33]; list 1 with ODT 0 =
/// meas[0x40..0x44].
fn configure(rig: &mut Rig) {
    rig.ok(&[cmd::FREE_DAQ]);
    rig.ok(&[cmd::ALLOC_DAQ, 0, 2, 0]);
    rig.ok(&[cmd::ALLOC_ODT, 0, 0, 0, 2]);
    rig.ok(&[cmd::ALLOC_ODT, 0, 1, 0, 1]);
    rig.ok(&[cmd::ALLOC_ODT_ENTRY, 0, 0, 0, 0, 2]);
    rig.ok(&[cmd::ALLOC_ODT_ENTRY, 0, 0, 0, 1, 2]);
    rig.ok(&[cmd::ALLOC_ODT_ENTRY, 0, 1, 0, 0, 1]);
    rig.ok(&[cmd::SET_DAQ_PTR, 0, 0, 0, 0, 0]);
    rig.ok(&write_daq(2, MEAS_START + 0x10));
    rig.ok(&write_daq(1, MEAS_START + 0x20));
    rig.ok(&[cmd::SET_DAQ_PTR, 0, 0, 0, 1, 0]);
    rig.ok(&write_daq(4, CAL_START + 4));
    rig.ok(&write_daq(3, MEAS_START + 0x30));
    rig.ok(&[cmd::SET_DAQ_PTR, 0, 1, 0, 0, 0]);
    rig.ok(&write_daq(4, MEAS_START + 0x40));
    // list 0: timestamp, event 0, prescaler 1, priority 0xFF (as pyxcp sends).
    rig.ok(&[cmd::SET_DAQ_LIST_MODE, 0x10, 0, 0, 0, 0, 1, 0xFF]);
    rig.ok(&[cmd::SET_DAQ_LIST_MODE, 0x00, 1, 0, 0, 0, 1, 0]);
}

#[test]
fn full_daq_session() {
    let mut rig = Rig::new();
    rig.connect_unlocked();
    configure(&mut rig);
    // Select both; FIRST_PID of list 1 follows list 0's two ODTs.
    assert_eq!(rig.one(&[cmd::START_STOP_DAQ_LIST, 2, 0, 0]), [0xFF, 0]);
    assert_eq!(rig.one(&[cmd::START_STOP_DAQ_LIST, 2, 1, 0]), [0xFF, 2]);
    assert_eq!(
        rig.one(&[cmd::GET_DAQ_LIST_MODE, 0, 0, 0]),
        [0xFF, 0x11, 0, 0, 0, 0, 1, 0xFF] // selected + timestamp, event 0, prescaler 1
    );
    assert!(sample(&mut rig, 0, 1).is_empty(), "selected is not running");
    rig.ok(&[cmd::START_STOP_SYNCH, 1]);
    assert!(rig.slave.daq_running());
    assert_eq!(rig.one(&[cmd::GET_STATUS]), [0xFF, 0x40, 0x00, 0, 0, 0]);
    assert_eq!(
        rig.one(&[cmd::GET_DAQ_LIST_MODE, 0, 0, 0]),
        [0xFF, 0x50, 0, 0, 0, 0, 1, 0xFF] // running + timestamp, selection cleared
    );
    assert_eq!(
        rig.one(&[cmd::GET_DAQ_LIST_MODE, 0, 1, 0]),
        [0xFF, 0x40, 0, 0, 0, 0, 1, 0]
    );
    assert_eq!(
        sample(&mut rig, 0, 0x1234_5678),
        [
            vec![0x00, 0x78, 0x56, 0x34, 0x12, 0x10, 0x11, 0x20],
            vec![0x01, 0x00, 0x00, 0x00, 0x3F, 0x30, 0x31, 0x32], // 0.5f32, meas 30..32
            vec![0x02, 0x40, 0x41, 0x42, 0x43],
        ]
    );
    // Other events sample nothing; new values are sampled.
    assert!(sample(&mut rig, 1, 0).is_empty());
    rig.ecu.measurement_mut()[0x10] = 0xAB;
    rig.ecu.measurement_mut()[0x43] = 0xCD;
    assert_eq!(
        sample(&mut rig, 0, 7),
        [
            vec![0x00, 7, 0, 0, 0, 0xAB, 0x11, 0x20],
            vec![0x01, 0x00, 0x00, 0x00, 0x3F, 0x30, 0x31, 0x32],
            vec![0x02, 0x40, 0x41, 0x42, 0xCD],
        ]
    );
    // Configuration changes are refused while running.
    assert_eq!(
        rig.one(&[cmd::ALLOC_DAQ, 0, 1, 0]),
        err(ErrorCode::DaqActive)
    );
    assert_eq!(
        rig.one(&[cmd::SET_DAQ_LIST_MODE, 0, 0, 0, 0, 0, 1, 0]),
        err(ErrorCode::DaqActive)
    );
    assert_eq!(
        rig.one(&[cmd::SET_DAQ_PTR, 0, 0, 0, 0, 0]),
        err(ErrorCode::DaqActive)
    );
    // Stop list 1 alone, then everything.
    assert_eq!(rig.one(&[cmd::START_STOP_DAQ_LIST, 0, 1, 0]), [0xFF, 2]);
    assert_eq!(sample(&mut rig, 0, 0).len(), 2);
    rig.ok(&[cmd::START_STOP_SYNCH, 0]);
    assert!(!rig.slave.daq_running());
    assert!(sample(&mut rig, 0, 0).is_empty());
    assert_eq!(rig.one(&[cmd::GET_STATUS]), [0xFF, 0x00, 0x00, 0, 0, 0]);
    assert_eq!(rig.ecu.violations.get(), 0);
}

#[test]
fn start_stop_list_directly_and_stop_selected() {
    let mut rig = Rig::new();
    rig.connect_unlocked();
    configure(&mut rig);
    assert_eq!(rig.one(&[cmd::START_STOP_DAQ_LIST, 1, 1, 0]), [0xFF, 2]);
    assert_eq!(sample(&mut rig, 0, 0), [vec![0x02, 0x40, 0x41, 0x42, 0x43]]);
    rig.one(&[cmd::START_STOP_DAQ_LIST, 2, 1, 0]);
    rig.ok(&[cmd::START_STOP_SYNCH, 2]);
    assert!(!rig.slave.daq_running());
    assert_eq!(
        rig.one(&[cmd::START_STOP_DAQ_LIST, 3, 1, 0]),
        err(ErrorCode::OutOfRange)
    );
    assert_eq!(
        rig.one(&[cmd::START_STOP_DAQ_LIST, 1, 2, 0]),
        err(ErrorCode::OutOfRange)
    );
    assert_eq!(
        rig.one(&[cmd::START_STOP_SYNCH, 3]),
        err(ErrorCode::OutOfRange)
    );
}

#[test]
fn calibration_entries_are_sampled_from_the_ecu_page() {
    let mut rig = Rig::new();
    rig.connect_unlocked();
    configure(&mut rig);
    rig.ok(&[cmd::SET_CAL_PAGE, 0x01, 0, 1]);
    rig.one(&[cmd::START_STOP_DAQ_LIST, 1, 0, 0]);
    let dtos = sample(&mut rig, 0, 0);
    assert_eq!(&dtos[1][1..5], 101.0_f32.to_le_bytes());
    assert_eq!(rig.slave.xcp_page(), Page::Working);
}

#[test]
fn disconnect_stops_and_frees_daq() {
    let mut rig = Rig::new();
    rig.connect_unlocked();
    configure(&mut rig);
    rig.one(&[cmd::START_STOP_DAQ_LIST, 1, 0, 0]);
    assert!(rig.slave.daq_running());
    rig.ok(&[cmd::DISCONNECT]);
    assert!(!rig.slave.daq_running());
    assert!(sample(&mut rig, 0, 0).is_empty());
    rig.connect_unlocked();
    assert_eq!(
        rig.one(&[cmd::GET_DAQ_LIST_MODE, 0, 0, 0]),
        err(ErrorCode::OutOfRange)
    );
    assert_eq!(
        rig.one(&[cmd::GET_DAQ_PROCESSOR_INFO])[2],
        0,
        "no lists allocated"
    );
}

#[test]
fn empty_first_odt_with_timestamp_is_sent_as_pid_and_timestamp() {
    // pyxcp with MAX_ODT_ENTRY_SIZE 4 and a timestamped list: the first ODT has no room
    // (4 - 4 bytes), so it allocates 0 entries there and writes the data into ODT 1.
    let mut rig = Rig::new();
    rig.connect_unlocked();
    rig.ok(&[cmd::FREE_DAQ]);
    rig.ok(&[cmd::ALLOC_DAQ, 0, 1, 0]);
    rig.ok(&[cmd::ALLOC_ODT, 0, 0, 0, 2]);
    rig.ok(&[cmd::ALLOC_ODT_ENTRY, 0, 0, 0, 0, 0]);
    rig.ok(&[cmd::ALLOC_ODT_ENTRY, 0, 0, 0, 1, 1]);
    rig.ok(&[cmd::SET_DAQ_PTR, 0, 0, 0, 1, 0]);
    rig.ok(&write_daq(4, MEAS_START + 4));
    rig.ok(&[cmd::SET_DAQ_LIST_MODE, 0x10, 0, 0, 0, 0, 1, 0xFF]);
    assert_eq!(rig.one(&[cmd::START_STOP_DAQ_LIST, 2, 0, 0]), [0xFF, 0]);
    rig.ok(&[cmd::START_STOP_SYNCH, 1]);
    assert_eq!(
        sample(&mut rig, 0, 0xA0B0C0D0),
        [vec![0x00, 0xD0, 0xC0, 0xB0, 0xA0], vec![0x01, 4, 5, 6, 7]]
    );
}

#[test]
fn odt_capacity_and_unwritten_entries_are_daq_config_errors() {
    let mut rig = Rig::new();
    rig.connect_unlocked();
    rig.ok(&[cmd::FREE_DAQ]);
    rig.ok(&[cmd::ALLOC_DAQ, 0, 3, 0]);
    rig.ok(&[cmd::ALLOC_ODT, 0, 0, 0, 1]);
    rig.ok(&[cmd::ALLOC_ODT, 0, 1, 0, 1]);
    rig.ok(&[cmd::ALLOC_ODT, 0, 2, 0, 0]);
    rig.ok(&[cmd::ALLOC_ODT_ENTRY, 0, 0, 0, 0, 2]);
    rig.ok(&[cmd::ALLOC_ODT_ENTRY, 0, 1, 0, 0, 2]);
    // List 0: 4 + 4 = 8 bytes > 7.
    rig.ok(&[cmd::SET_DAQ_PTR, 0, 0, 0, 0, 0]);
    rig.ok(&write_daq(4, MEAS_START));
    rig.ok(&write_daq(4, MEAS_START + 4));
    assert_eq!(
        rig.one(&[cmd::START_STOP_DAQ_LIST, 2, 0, 0]),
        err(ErrorCode::DaqConfig)
    );
    assert_eq!(
        rig.one(&[cmd::START_STOP_DAQ_LIST, 1, 0, 0]),
        err(ErrorCode::DaqConfig)
    );
    // List 1: 4 + 3 = 7 fits, but with a timestamp only 3 bytes are left.
    rig.ok(&[cmd::SET_DAQ_PTR, 0, 1, 0, 0, 0]);
    rig.ok(&write_daq(4, MEAS_START));
    // ... second entry not written yet.
    assert_eq!(
        rig.one(&[cmd::START_STOP_DAQ_LIST, 2, 1, 0]),
        err(ErrorCode::DaqConfig)
    );
    rig.ok(&write_daq(3, MEAS_START + 4));
    assert_eq!(rig.one(&[cmd::START_STOP_DAQ_LIST, 2, 1, 0]), [0xFF, 1]);
    rig.ok(&[cmd::SET_DAQ_LIST_MODE, 0x10, 1, 0, 0, 0, 1, 0]);
    assert_eq!(
        rig.one(&[cmd::START_STOP_DAQ_LIST, 1, 1, 0]),
        err(ErrorCode::DaqConfig)
    );
    // A selected list that no longer fits stops START_STOP_SYNCH from starting anything.
    assert_eq!(
        rig.one(&[cmd::START_STOP_SYNCH, 1]),
        err(ErrorCode::DaqConfig)
    );
    assert!(!rig.slave.daq_running());
    // List 2 has no ODT.
    assert_eq!(
        rig.one(&[cmd::START_STOP_DAQ_LIST, 1, 2, 0]),
        err(ErrorCode::DaqConfig)
    );
}

#[test]
fn allocation_order_and_limits() {
    let mut rig = Rig::new();
    rig.connect_unlocked();
    // After CONNECT the configuration is free: ALLOC_ODT / _ENTRY are out of sequence.
    assert_eq!(
        rig.one(&[cmd::ALLOC_ODT, 0, 0, 0, 1]),
        err(ErrorCode::Sequence)
    );
    assert_eq!(
        rig.one(&[cmd::ALLOC_ODT_ENTRY, 0, 0, 0, 0, 1]),
        err(ErrorCode::Sequence)
    );
    assert_eq!(
        rig.one(&[cmd::ALLOC_DAQ, 0, 5, 0]),
        err(ErrorCode::MemoryOverflow)
    );
    rig.ok(&[cmd::ALLOC_DAQ, 0, 4, 0]);
    assert_eq!(
        rig.one(&[cmd::ALLOC_DAQ, 0, 1, 0]),
        err(ErrorCode::Sequence)
    );
    assert_eq!(
        rig.one(&[cmd::ALLOC_ODT_ENTRY, 0, 0, 0, 0, 1]),
        err(ErrorCode::Sequence)
    );
    assert_eq!(
        rig.one(&[cmd::ALLOC_ODT, 0, 4, 0, 1]),
        err(ErrorCode::OutOfRange)
    );
    assert_eq!(
        rig.one(&[cmd::ALLOC_ODT, 0, 0, 0, 33]),
        err(ErrorCode::MemoryOverflow)
    );
    rig.ok(&[cmd::ALLOC_ODT, 0, 0, 0, 20]);
    assert_eq!(
        rig.one(&[cmd::ALLOC_ODT, 0, 0, 0, 1]),
        err(ErrorCode::Sequence),
        "twice"
    );
    rig.ok(&[cmd::ALLOC_ODT, 0, 1, 0, 12]);
    assert_eq!(
        rig.one(&[cmd::ALLOC_ODT, 0, 2, 0, 1]),
        err(ErrorCode::MemoryOverflow)
    );
    rig.ok(&[cmd::ALLOC_ODT_ENTRY, 0, 0, 0, 0, 7]);
    assert_eq!(
        rig.one(&[cmd::ALLOC_ODT, 0, 2, 0, 0]),
        err(ErrorCode::Sequence)
    );
    assert_eq!(
        rig.one(&[cmd::ALLOC_ODT_ENTRY, 0, 0, 0, 0, 1]),
        err(ErrorCode::Sequence)
    );
    assert_eq!(
        rig.one(&[cmd::ALLOC_ODT_ENTRY, 0, 0, 0, 1, 8]),
        err(ErrorCode::OutOfRange)
    );
    assert_eq!(
        rig.one(&[cmd::ALLOC_ODT_ENTRY, 0, 0, 0, 20, 1]),
        err(ErrorCode::OutOfRange)
    );
    assert_eq!(
        rig.one(&[cmd::ALLOC_ODT_ENTRY, 0, 3, 0, 0, 1]),
        err(ErrorCode::OutOfRange)
    );
    // 128 entries in total: 7 + 17 × 7 = 126, then 2 more fit, a third does not.
    for odt in 1..18_u8 {
        rig.ok(&[cmd::ALLOC_ODT_ENTRY, 0, 0, 0, odt, 7]);
    }
    assert_eq!(
        rig.one(&[cmd::ALLOC_ODT_ENTRY, 0, 0, 0, 18, 3]),
        err(ErrorCode::MemoryOverflow)
    );
    rig.ok(&[cmd::ALLOC_ODT_ENTRY, 0, 0, 0, 18, 2]);
    assert_eq!(
        rig.one(&[cmd::ALLOC_ODT_ENTRY, 0, 1, 0, 0, 1]),
        err(ErrorCode::MemoryOverflow)
    );
    // FREE_DAQ starts over.
    rig.ok(&[cmd::FREE_DAQ]);
    rig.ok(&[cmd::ALLOC_DAQ, 0, 1, 0]);
    assert_eq!(rig.one(&[cmd::GET_DAQ_PROCESSOR_INFO])[2], 1);
}

#[test]
fn daq_pointer_rules() {
    let mut rig = Rig::new();
    rig.connect_unlocked();
    assert_eq!(
        rig.one(&[cmd::SET_DAQ_PTR, 0, 0, 0, 0, 0]),
        err(ErrorCode::Sequence)
    );
    assert_eq!(rig.one(&write_daq(1, MEAS_START)), err(ErrorCode::Sequence));
    rig.ok(&[cmd::ALLOC_DAQ, 0, 1, 0]);
    rig.ok(&[cmd::ALLOC_ODT, 0, 0, 0, 1]);
    rig.ok(&[cmd::ALLOC_ODT_ENTRY, 0, 0, 0, 0, 1]);
    assert_eq!(
        rig.one(&[cmd::SET_DAQ_PTR, 0, 1, 0, 0, 0]),
        err(ErrorCode::OutOfRange)
    );
    assert_eq!(
        rig.one(&[cmd::SET_DAQ_PTR, 0, 0, 0, 1, 0]),
        err(ErrorCode::OutOfRange)
    );
    assert_eq!(
        rig.one(&[cmd::SET_DAQ_PTR, 0, 0, 0, 0, 1]),
        err(ErrorCode::OutOfRange)
    );
    assert_eq!(rig.one(&write_daq(1, MEAS_START)), err(ErrorCode::Sequence));
    rig.ok(&[cmd::SET_DAQ_PTR, 0, 0, 0, 0, 0]);
    rig.ok(&write_daq(1, MEAS_START));
    assert_eq!(
        rig.one(&write_daq(1, MEAS_START)),
        err(ErrorCode::OutOfRange)
    );
    // FREE_DAQ forgets the pointer.
    rig.ok(&[cmd::FREE_DAQ]);
    assert_eq!(rig.one(&write_daq(1, MEAS_START)), err(ErrorCode::Sequence));
}

#[test]
fn set_daq_list_mode_parameters() {
    let mut rig = Rig::new();
    rig.connect_unlocked();
    rig.ok(&[cmd::ALLOC_DAQ, 0, 1, 0]);
    for mode in [0x02_u8, 0x20, 0x01, 0x40, 0x80, 0x08] {
        assert_eq!(
            rig.one(&[cmd::SET_DAQ_LIST_MODE, mode, 0, 0, 0, 0, 1, 0]),
            err(ErrorCode::OutOfRange),
            "{mode:02X}"
        );
    }
    assert_eq!(
        rig.one(&[cmd::SET_DAQ_LIST_MODE, 0, 0, 0, 1, 0, 1, 0]),
        err(ErrorCode::OutOfRange)
    );
    // Any prescaler is taken (see `prescalers_thin_each_list_on_its_own`).
    rig.ok(&[cmd::SET_DAQ_LIST_MODE, 0, 0, 0, 0, 0, 2, 0]);
    assert_eq!(
        rig.one(&[cmd::SET_DAQ_LIST_MODE, 0, 1, 0, 0, 0, 1, 0]),
        err(ErrorCode::OutOfRange)
    );
    assert_eq!(
        rig.one(&[cmd::SET_DAQ_LIST_MODE, 0, 0, 0, 0, 0, 1]),
        err(ErrorCode::CmdSyntax)
    );
    rig.ok(&[cmd::SET_DAQ_LIST_MODE, 0x10, 0, 0, 0, 0, 0, 7]);
    assert_eq!(
        rig.one(&[cmd::GET_DAQ_LIST_MODE, 0, 0, 0]),
        [0xFF, 0x10, 0, 0, 0, 0, 1, 7]
    );
}

#[test]
fn daq_configuration_needs_daq_unlocked() {
    let mut rig = Rig::new();
    rig.connect();
    assert_eq!(rig.unlock(resource::CAL_PAG), [0xFF, resource::DAQ]);
    for cto in [
        &[cmd::FREE_DAQ][..],
        &[cmd::ALLOC_DAQ, 0, 1, 0],
        &[cmd::ALLOC_ODT, 0, 0, 0, 1],
        &[cmd::ALLOC_ODT_ENTRY, 0, 0, 0, 0, 1],
        &[cmd::SET_DAQ_PTR, 0, 0, 0, 0, 0],
        &write_daq(1, MEAS_START),
        &[cmd::SET_DAQ_LIST_MODE, 0, 0, 0, 0, 0, 1, 0],
        &[cmd::START_STOP_DAQ_LIST, 1, 0, 0],
        &[cmd::START_STOP_SYNCH, 1],
    ] {
        assert_eq!(rig.one(cto), err(ErrorCode::AccessLocked), "{cto:02X?}");
    }
    // The queries are open.
    assert_eq!(rig.one(&[cmd::GET_DAQ_PROCESSOR_INFO])[0], 0xFF);
    assert_eq!(rig.one(&[cmd::GET_DAQ_RESOLUTION_INFO])[0], 0xFF);
    assert_eq!(rig.one(&[cmd::GET_DAQ_EVENT_INFO, 0, 0, 0])[0], 0xFF);
    assert_eq!(rig.one(&[cmd::GET_DAQ_CLOCK])[0], 0xFF);
}

#[test]
fn daq_queries() {
    let mut rig = Rig::new();
    rig.connect();
    // Dynamic + prescaler + timestamps; MAX_DAQ = lists allocated (0); 1 event; MIN_DAQ 0;
    // key byte 0 (absolute ODT number).
    assert_eq!(
        rig.one(&[cmd::GET_DAQ_PROCESSOR_INFO]),
        [0xFF, 0x13, 0, 0, 1, 0, 0, 0x00]
    );
    // Granularity 1, max entry 4, STIM 1/0, timestamp 4 bytes not fixed in 1 µs, 1 tick.
    assert_eq!(
        rig.one(&[cmd::GET_DAQ_RESOLUTION_INFO]),
        [0xFF, 1, 4, 1, 0, 0x34, 1, 0]
    );
    // Event 0: consistency per event + DAQ, 4 lists, name of 12 bytes, 500 µs = 50 × 10 µs.
    assert_eq!(
        rig.one(&[cmd::GET_DAQ_EVENT_INFO, 0, 0, 0]),
        [0xFF, 0x84, 4, 12, 50, 4, 0]
    );
    let frames = rig.send(&[cmd::UPLOAD, 12]);
    let name: Vec<u8> = frames.iter().flat_map(|f| f[1..].to_vec()).collect();
    assert_eq!(name, b"control step");
    assert_eq!(
        rig.one(&[cmd::GET_DAQ_EVENT_INFO, 0, 1, 0]),
        err(ErrorCode::OutOfRange)
    );
    rig.platform.now_us = 0xCAFE_F00D;
    assert_eq!(
        rig.one(&[cmd::GET_DAQ_CLOCK]),
        [0xFF, 0x00, 0x18, 0x01, 0x0D, 0xF0, 0xFE, 0xCA]
    );
}

#[test]
fn event_cycle_encoding() {
    assert_eq!(event_cycle(0), (0, 3));
    assert_eq!(event_cycle(200), (200, 3)); // 5 kHz: 200 × 1 µs
    assert_eq!(event_cycle(255), (255, 3));
    assert_eq!(event_cycle(256), (26, 4)); // 260 µs, the nearest 10 µs
    assert_eq!(event_cycle(500), (50, 4));
    assert_eq!(event_cycle(1000), (100, 4));
    assert_eq!(event_cycle(10_000), (100, 5));
    assert_eq!(event_cycle(1_000_000), (100, 7)); // 1 s = 100 × 10 ms
    assert_eq!(event_cycle(u32::MAX), (255, 9));
}

/// A prescaler of n samples every n-th event, the first right after the start; lists keep
/// their own counts; GET_DAQ_LIST_MODE echoes it, GET_DAQ_PROCESSOR_INFO offers it.
#[test]
fn prescalers_thin_each_list_on_its_own() {
    let mut rig = Rig::new();
    rig.connect_unlocked();
    configure(&mut rig);
    assert_eq!(rig.one(&[cmd::GET_DAQ_PROCESSOR_INFO])[1] & 0x02, 0x02);
    // List 0 every 3rd event, list 1 every 2nd.
    rig.ok(&[cmd::SET_DAQ_LIST_MODE, 0x10, 0, 0, 0, 0, 3, 0xFF]);
    rig.ok(&[cmd::SET_DAQ_LIST_MODE, 0x00, 1, 0, 0, 0, 2, 0]);
    assert_eq!(
        rig.one(&[cmd::GET_DAQ_LIST_MODE, 0, 0, 0]),
        [0xFF, 0x10, 0, 0, 0, 0, 3, 0xFF]
    );
    rig.one(&[cmd::START_STOP_DAQ_LIST, 2, 0, 0]);
    rig.one(&[cmd::START_STOP_DAQ_LIST, 2, 1, 0]);
    rig.ok(&[cmd::START_STOP_SYNCH, 1]);
    let pids: Vec<Vec<u8>> = (0..7)
        .map(|k| sample(&mut rig, 0, k).iter().map(|d| d[0]).collect())
        .collect();
    // List 0 (PIDs 0, 1) at events 0, 3, 6; list 1 (PID 2) at events 0, 2, 4, 6.
    assert_eq!(
        pids,
        [
            vec![0, 1, 2],
            vec![],
            vec![2],
            vec![0, 1],
            vec![2],
            vec![],
            vec![0, 1, 2]
        ]
    );
    // A restart samples at once again.
    rig.one(&[cmd::START_STOP_DAQ_LIST, 0, 0, 0]);
    assert_eq!(rig.one(&[cmd::START_STOP_DAQ_LIST, 1, 0, 0]), [0xFF, 0]);
    assert_eq!(sample(&mut rig, 0, 9)[0][0], 0);
    // Prescaler 0 means every event, like 1.
    rig.ok(&[cmd::START_STOP_SYNCH, 0]);
    rig.ok(&[cmd::SET_DAQ_LIST_MODE, 0x10, 0, 0, 0, 0, 0, 0]);
    rig.one(&[cmd::START_STOP_DAQ_LIST, 1, 0, 0]);
    for k in 0..3 {
        assert_eq!(sample(&mut rig, 0, k).len(), 2);
    }
}
