//! proptest fuzzing against the mock ECU.
//!
//! 1. Random command sequences (raw bytes, known codes with random parameters, and
//!    well-formed commands at addresses around the regions, whole DOWNLOAD blocks and DAQ
//!    set-ups so deep states are reached), from a disconnected, a connected and an unlocked
//!    start: no panic; every response frame is 1..=8 bytes and starts with 0xFF or 0xFE;
//!    nothing answers a non-CONNECT frame while disconnected; only UPLOAD answers with more
//!    than one frame; every DTO is 1..=8 bytes with a PID of at most 0xFB, and none is sent
//!    while no list runs; the guards, the reference page and the measurement region never
//!    change, the working page changes only while CAL/PAG is unlocked; the mock never sees
//!    an offset outside a region.
//! 2. Random valid DAQ layouts: the DTOs are exactly the bytes a model computes from the
//!    mock's memory.

use proptest::collection::vec;
use proptest::prelude::*;

use super::Rig;
use crate::compute_key;
use crate::mock::{self, CAL_LEN, CAL_START, MEAS_LEN, MEAS_START};
use crate::protocol::{cmd, resource, MAX_RESPONSE_FRAMES};

/// Every command code the slave knows, and a few it does not.
const CODES: [u8; 38] = [
    cmd::CONNECT,
    cmd::DISCONNECT,
    cmd::GET_STATUS,
    cmd::SYNCH,
    cmd::GET_COMM_MODE_INFO,
    cmd::GET_ID,
    cmd::GET_SEED,
    cmd::UNLOCK,
    cmd::SET_MTA,
    cmd::UPLOAD,
    cmd::SHORT_UPLOAD,
    cmd::DOWNLOAD,
    cmd::DOWNLOAD_NEXT,
    cmd::SET_CAL_PAGE,
    cmd::GET_CAL_PAGE,
    cmd::GET_PAG_PROCESSOR_INFO,
    cmd::GET_SEGMENT_INFO,
    cmd::GET_PAGE_INFO,
    cmd::COPY_CAL_PAGE,
    cmd::SET_DAQ_PTR,
    cmd::WRITE_DAQ,
    cmd::SET_DAQ_LIST_MODE,
    cmd::GET_DAQ_LIST_MODE,
    cmd::START_STOP_DAQ_LIST,
    cmd::START_STOP_SYNCH,
    cmd::GET_DAQ_CLOCK,
    cmd::GET_DAQ_PROCESSOR_INFO,
    cmd::GET_DAQ_RESOLUTION_INFO,
    cmd::GET_DAQ_EVENT_INFO,
    cmd::FREE_DAQ,
    cmd::ALLOC_DAQ,
    cmd::ALLOC_ODT,
    cmd::ALLOC_ODT_ENTRY,
    0xF9,
    0xF3,
    0xED,
    0xC7,
    0x00,
];

fn addr() -> impl Strategy<Value = u32> {
    prop_oneof![
        3 => (CAL_START - 8)..(CAL_START + CAL_LEN as u32 + 8),
        3 => (MEAS_START - 8)..(MEAS_START + MEAS_LEN as u32 + 8),
        1 => (u32::MAX - 8)..=u32::MAX,
        1 => any::<u32>(),
    ]
}

/// One step: a burst of command frames built from a kind, random bytes and an address.
fn step() -> impl Strategy<Value = Vec<Vec<u8>>> {
    (0_u8..40, any::<[u8; 8]>(), addr()).prop_map(|(kind, r, a)| build(kind, r, a))
}

fn set_mta(a: [u8; 4]) -> Vec<u8> {
    vec![cmd::SET_MTA, 0, 0, 0, a[0], a[1], a[2], a[3]]
}

fn build(kind: u8, r: [u8; 8], addr: u32) -> Vec<Vec<u8>> {
    let a = addr.to_le_bytes();
    let one = |v: Vec<u8>| vec![v];
    match kind {
        0 | 1 => one(r[..usize::from(r[0] % 9)].to_vec()),
        2..=4 => {
            let mut v = vec![CODES[usize::from(r[0]) % CODES.len()]];
            v.extend_from_slice(&r[1..1 + usize::from(r[1] % 8)]);
            one(v)
        }
        5 => one(vec![
            cmd::SET_MTA,
            0,
            0,
            r[1] % 2 * (r[2] % 2),
            a[0],
            a[1],
            a[2],
            a[3],
        ]),
        6 => one(vec![cmd::UPLOAD, r[1]]),
        7 => vec![set_mta(a), vec![cmd::UPLOAD, r[1] % 16]],
        8 => one(vec![
            cmd::SHORT_UPLOAD,
            r[1] % 9,
            0,
            0,
            a[0],
            a[1],
            a[2],
            a[3],
        ]),
        9..=12 => {
            let n = r[1] % 15;
            let mut v = vec![cmd::DOWNLOAD, n];
            v.extend_from_slice(&r[2..8]);
            v.truncate(2 + usize::from(n).min(6) + usize::from(r[0] % 2));
            vec![set_mta(a), v]
        }
        13 => {
            let mut v = vec![cmd::DOWNLOAD_NEXT, r[1] % 21];
            v.extend_from_slice(&r[2..8]);
            one(v)
        }
        14..=16 => {
            // A whole block as pyxcp sends it, at a random address.
            let len = 7 + usize::from(r[1] % 30);
            let data: Vec<u8> = (0..len).map(|i| r[i % 8] ^ (i as u8)).collect();
            let mut frames = vec![set_mta(a)];
            let mut remaining = len;
            for (i, chunk) in data.chunks(6).enumerate() {
                let mut f = if i == 0 {
                    vec![cmd::DOWNLOAD, len as u8]
                } else {
                    vec![cmd::DOWNLOAD_NEXT, remaining as u8]
                };
                f.extend_from_slice(chunk);
                frames.push(f);
                remaining -= chunk.len();
            }
            frames
        }
        17 => {
            let modes = [1_u8, 2, 3, 0x80, 0x81, 0x82, 0x83, 0, 4];
            one(vec![
                cmd::SET_CAL_PAGE,
                modes[usize::from(r[1]) % modes.len()],
                r[2] % 2,
                r[3] % 3,
            ])
        }
        18 => one(vec![
            cmd::COPY_CAL_PAGE,
            r[1] % 2,
            r[2] % 3,
            r[3] % 2,
            r[4] % 3,
        ]),
        19 => one(vec![cmd::ALLOC_DAQ, 0, r[1] % 6, 0]),
        20 => one(vec![cmd::ALLOC_ODT, 0, r[1] % 5, 0, r[2] % 12]),
        21 => one(vec![
            cmd::ALLOC_ODT_ENTRY,
            0,
            r[1] % 5,
            0,
            r[2] % 5,
            r[3] % 9,
        ]),
        22 => one(vec![cmd::SET_DAQ_PTR, 0, r[1] % 5, 0, r[2] % 5, r[3] % 9]),
        23 | 24 => {
            let bit = if r[1] % 8 == 0 { r[2] } else { 0xFF };
            one(vec![
                cmd::WRITE_DAQ,
                bit,
                r[3] % 6,
                r[4] % 8 / 7,
                a[0],
                a[1],
                a[2],
                a[3],
            ])
        }
        25 => {
            let modes = [0_u8, 0x10, 0x02, 0x20, 0x11];
            one(vec![
                cmd::SET_DAQ_LIST_MODE,
                modes[usize::from(r[1]) % modes.len()],
                r[2] % 5,
                0,
                r[3] % 2,
                0,
                r[4] % 3,
                r[5],
            ])
        }
        26 => one(vec![cmd::START_STOP_DAQ_LIST, r[1] % 4, r[2] % 5, 0]),
        27 => one(vec![cmd::START_STOP_SYNCH, r[1] % 4]),
        28 => {
            let resources = [1_u8, 4, 5, 8];
            one(vec![
                cmd::GET_SEED,
                r[1] % 2,
                resources[usize::from(r[2]) % 4],
            ])
        }
        29 => one(vec![
            cmd::UNLOCK,
            r[1] % 8,
            r[2],
            r[3],
            r[4],
            r[5],
            r[6],
            r[7],
        ]),
        30 => one(vec![cmd::FREE_DAQ]),
        31..=35 => {
            // A small valid DAQ set-up that starts one list on event 0 (the address is
            // random around the regions, so WRITE_DAQ and the start may still be refused).
            let size = 1 + r[1] % 4;
            vec![
                vec![cmd::FREE_DAQ],
                vec![cmd::ALLOC_DAQ, 0, 1, 0],
                vec![cmd::ALLOC_ODT, 0, 0, 0, 1],
                vec![cmd::ALLOC_ODT_ENTRY, 0, 0, 0, 0, 1],
                vec![cmd::SET_DAQ_PTR, 0, 0, 0, 0, 0],
                vec![cmd::WRITE_DAQ, 0xFF, size, 0, a[0], a[1], a[2], a[3]],
                vec![cmd::SET_DAQ_LIST_MODE, (r[2] % 2) << 4, 0, 0, 0, 0, 1, 0],
                vec![cmd::START_STOP_DAQ_LIST, 1, 0, 0],
            ]
        }
        36 => {
            let first = if r[1] % 2 == 0 {
                vec![cmd::GET_ID, r[2] % 3]
            } else {
                vec![cmd::GET_DAQ_EVENT_INFO, 0, r[2] % 2, 0]
            };
            vec![first, vec![cmd::UPLOAD, r[3] % 16]]
        }
        37 | 38 => {
            let queries = [
                vec![cmd::GET_STATUS],
                vec![cmd::GET_CAL_PAGE, 1 + r[2] % 2, 0],
                vec![cmd::GET_DAQ_LIST_MODE, 0, r[2] % 5, 0],
                vec![cmd::GET_SEGMENT_INFO, r[2] % 3, 0, r[3] % 3, 0],
                vec![cmd::GET_PAGE_INFO, 0, 0, r[2] % 3],
                vec![cmd::GET_DAQ_CLOCK],
                vec![cmd::SYNCH],
            ];
            one(queries[usize::from(r[1]) % queries.len()].clone())
        }
        _ => one(vec![
            if r[1] % 2 == 0 {
                cmd::CONNECT
            } else {
                cmd::DISCONNECT
            },
            0,
        ]),
    }
}

/// Send one frame and check the per-frame invariants.
fn send_checked(rig: &mut Rig, cto: &[u8], working_before: &[u8]) -> Result<(), TestCaseError> {
    let was_connected = rig.slave.connected();
    let cal_locked = !was_connected || rig.slave.protection() & resource::CAL_PAG != 0;
    let frames = rig.send(cto);
    prop_assert!(frames.len() <= MAX_RESPONSE_FRAMES);
    for f in &frames {
        prop_assert!((1..=8).contains(&f.len()), "{cto:02X?} → {f:02X?}");
        prop_assert!(f[0] == 0xFF || f[0] == 0xFE, "{cto:02X?} → {f:02X?}");
    }
    if !was_connected {
        if cto.first() == Some(&cmd::CONNECT) && cto.len() <= 8 {
            prop_assert_eq!(frames.len(), 1);
        } else {
            prop_assert!(
                frames.is_empty(),
                "disconnected, {cto:02X?} → {frames:02X?}"
            );
        }
    }
    if frames.len() > 1 {
        prop_assert_eq!(cto.first(), Some(&cmd::UPLOAD));
    }
    if cal_locked {
        prop_assert_eq!(
            rig.ecu.working(),
            working_before,
            "written while locked: {:02X?}",
            cto
        );
    }
    Ok(())
}

fn check_memory(rig: &Rig) -> Result<(), TestCaseError> {
    prop_assert!(rig.ecu.guards_intact());
    prop_assert_eq!(&rig.ecu.reference[..], &mock::initial_reference()[..]);
    prop_assert_eq!(rig.ecu.measurement(), &mock::initial_measurement()[..]);
    prop_assert_eq!(rig.ecu.violations.get(), 0);
    Ok(())
}

fn unlock_all(rig: &mut Rig) {
    rig.connect();
    for res in [resource::CAL_PAG, resource::DAQ] {
        let seed_frame = rig.one(&[cmd::GET_SEED, 0, res]);
        let seed: [u8; 6] = seed_frame[2..8].try_into().unwrap();
        let mut unlock = vec![cmd::UNLOCK, 6];
        unlock.extend_from_slice(&compute_key(mock::TEST_SECRET, res, &seed));
        rig.one(&unlock);
    }
    assert_eq!(rig.slave.protection(), 0);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

    #[test]
    fn random_command_sequences_keep_the_invariants(
        start in 0_u8..6,
        steps in vec((step(), any::<u32>()), 1..80),
    ) {
        let mut rig = Rig::new();
        match start {
            0 => {}
            1 => rig.connect(),
            _ => unlock_all(&mut rig),
        }
        for (burst, ts) in steps {
            for cto in &burst {
                let working_before = rig.ecu.working().to_vec();
                send_checked(&mut rig, cto, &working_before)?;
            }
            let running = rig.slave.daq_running();
            let mut dtos = Vec::new();
            rig.slave.sample_daq(0, ts, &rig.ecu, |d| dtos.push(d.to_vec()));
            for d in &dtos {
                prop_assert!((1..=8).contains(&d.len()));
                prop_assert!(d[0] <= 0xFB);
            }
            if !running {
                prop_assert!(dtos.is_empty());
            }
            check_memory(&rig)?;
        }
    }
}

/// One entry of a generated DAQ layout: calibration or measurement, offset, size.
type EntrySpec = (bool, u8, u8);

fn layout() -> impl Strategy<Value = Vec<(bool, Vec<Vec<EntrySpec>>)>> {
    let entry = (any::<bool>(), 0_u8..=252, 1_u8..=4);
    let odt = vec(entry, 0..=4);
    vec((any::<bool>(), vec(odt, 1..=4)), 1..=4)
}

/// Drop entries from the end of each ODT until it fits its capacity.
fn fit(layout: &mut [(bool, Vec<Vec<EntrySpec>>)]) {
    for (timestamp, odts) in layout.iter_mut() {
        for (j, odt) in odts.iter_mut().enumerate() {
            let capacity = if j == 0 && *timestamp { 3 } else { 7 };
            while odt.iter().map(|e| usize::from(e.2)).sum::<usize>() > capacity {
                odt.pop();
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    #[test]
    fn dtos_carry_exactly_the_configured_bytes(
        mut lists in layout(),
        meas in vec(any::<u8>(), MEAS_LEN),
        ts in any::<u32>(),
    ) {
        fit(&mut lists);
        let mut rig = Rig::new();
        unlock_all(&mut rig);
        rig.ok(&[cmd::FREE_DAQ]);
        rig.ok(&[cmd::ALLOC_DAQ, 0, lists.len() as u8, 0]);
        for (i, (_, odts)) in lists.iter().enumerate() {
            rig.ok(&[cmd::ALLOC_ODT, 0, i as u8, 0, odts.len() as u8]);
        }
        for (i, (_, odts)) in lists.iter().enumerate() {
            for (j, odt) in odts.iter().enumerate() {
                rig.ok(&[cmd::ALLOC_ODT_ENTRY, 0, i as u8, 0, j as u8, odt.len() as u8]);
            }
        }
        for (i, (timestamp, odts)) in lists.iter().enumerate() {
            for (j, odt) in odts.iter().enumerate() {
                if odt.is_empty() {
                    continue;
                }
                rig.ok(&[cmd::SET_DAQ_PTR, 0, i as u8, 0, j as u8, 0]);
                for &(cal, offset, size) in odt {
                    let base = if cal { CAL_START } else { MEAS_START };
                    rig.ok(&super::write_daq(size, base + u32::from(offset)));
                }
            }
            let mode = if *timestamp { 0x10 } else { 0 };
            rig.ok(&[cmd::SET_DAQ_LIST_MODE, mode, i as u8, 0, 0, 0, 1, 0]);
        }
        let mut pid = 0_u8;
        for (i, (_, odts)) in lists.iter().enumerate() {
            prop_assert_eq!(rig.one(&[cmd::START_STOP_DAQ_LIST, 2, i as u8, 0]), vec![0xFF, pid]);
            pid += odts.len() as u8;
        }
        rig.ok(&[cmd::START_STOP_SYNCH, 1]);
        rig.ecu.measurement_mut().copy_from_slice(&meas);

        let mut expected = Vec::new();
        let mut pid = 0_u8;
        for (timestamp, odts) in &lists {
            for (j, odt) in odts.iter().enumerate() {
                let mut f = vec![pid + j as u8];
                if j == 0 && *timestamp {
                    f.extend_from_slice(&ts.to_le_bytes());
                }
                for &(cal, offset, size) in odt {
                    let src = if cal { rig.ecu.working() } else { rig.ecu.measurement() };
                    let o = usize::from(offset);
                    f.extend_from_slice(&src[o..o + usize::from(size)]);
                }
                expected.push(f);
            }
            pid += odts.len() as u8;
        }
        let mut dtos = Vec::new();
        rig.slave.sample_daq(0, ts, &rig.ecu, |d| dtos.push(d.to_vec()));
        prop_assert_eq!(dtos, expected);
        prop_assert_eq!(rig.ecu.violations.get(), 0);
    }
}
