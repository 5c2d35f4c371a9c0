//! The master against the board's own slave (`mil_xcp::Slave`) over the mock ECU, through
//! the in-process loopback (and once through SLCAN over TCP), with the parameter table read
//! from an A2L file that `mil_a2l` generates for the mock's memory layout.

use std::time::{Duration, Instant};

use mil_a2l::{Block, Layout};
use mil_xcp::mock::{self, MockEcu, MockPlatform, TEST_SECRET};
use mil_xcp::{Calibration, Memory, Page, Rejected, Slave};
use mil_xcp_master::loopback::{Loopback, SimBoard, SlcanTcpBoard};
use mil_xcp_master::protocol::cmd;
use mil_xcp_master::{
    page_mode, resource, A2l, CanIds, DaqOptions, Error, Item, Master, PortSpec, REFERENCE_PAGE,
    WORKING_PAGE,
};

const TIMEOUT: Duration = Duration::from_millis(300);

/// The page slot of the firmware's parameter `name`.
fn slot(name: &str) -> usize {
    mil_firmware::calibration::slot_named(name).expect("a parameter")
}

/// The mock's initial value of the firmware's parameter `name`: the mock's working page
/// holds i * 0.5 in slot i.
fn mock_value(name: &str) -> f64 {
    slot(name) as f64 * 0.5
}

/// The A2L of the firmware's tables, placed at the mock's regions.
fn a2l() -> A2l {
    let layout = Layout {
        calibration: Block {
            address: mock::CAL_START,
            size: mil_firmware::calibration::PAGE_BYTES as u32,
        },
        measurement: Block {
            address: mock::MEAS_START,
            size: mil_firmware::calibration::MEASUREMENT_BYTES as u32,
        },
    };
    A2l::parse(&mil_a2l::generate(&layout, "test"), "fixture").expect("the generated A2L parses")
}

fn sim<M: Memory + Calibration>(target: M) -> SimBoard<M, MockPlatform> {
    SimBoard::new(
        Slave::new(mock::config()).expect("mock config"),
        target,
        MockPlatform::default(),
        CanIds::default(),
    )
}

type MockMaster = Master<Loopback<MockEcu, MockPlatform>>;

fn master() -> MockMaster {
    Master::new(
        Loopback::new(sim(MockEcu::new())),
        CanIds::default(),
        TIMEOUT,
    )
}

fn connected() -> MockMaster {
    let mut m = master();
    m.connect().expect("connect");
    m.unlock_all(resource::CAL_PAG | resource::DAQ, TEST_SECRET)
        .expect("unlock");
    m
}

fn ecu(m: &mut MockMaster) -> &mut MockEcu {
    &mut m.transport_mut().board.target
}

fn f32_at(page: &[u8], slot: usize) -> f32 {
    f32::from_le_bytes(page[4 * slot..4 * slot + 4].try_into().unwrap())
}

fn downloads(m: &mut MockMaster) -> usize {
    m.transport_mut()
        .sent
        .iter()
        .filter(|f| f.payload()[0] == cmd::DOWNLOAD)
        .count()
}

#[test]
fn the_a2l_table_is_the_firmwares() {
    let a = a2l();
    use mil_firmware::calibration::{MEAS_ITEMS, SLOTS};
    assert_eq!(a.characteristics.len(), SLOTS);
    assert_eq!(a.measurements.len(), MEAS_ITEMS.len());
    assert!(a.skipped.is_empty(), "{:?}", a.skipped);
    assert!(a.warnings.is_empty(), "{:?}", a.warnings);
    assert_eq!(
        (a.project.as_str(), a.module.as_str()),
        ("mil", "mil_firmware")
    );
    let segments: Vec<(&str, u32)> = a
        .segments
        .iter()
        .map(|s| (s.name.as_str(), s.address))
        .collect();
    assert_eq!(
        segments,
        vec![
            ("calibration", mock::CAL_START),
            ("measurement", mock::MEAS_START)
        ]
    );
    for slot in 0..SLOTS {
        let item = mil_firmware::calibration::item(slot).unwrap();
        let name = item.to_string();
        let c = a.characteristic(&name).unwrap();
        assert_eq!(c.address, mock::CAL_START + 4 * slot as u32);
        assert_eq!(c.min, f64::from(item.min), "{name}");
        assert_eq!(c.max, f64::from(item.max), "{name}");
        assert_eq!(c.unit_or_dash(), item.unit, "{name}");
        assert_eq!(c.datatype.name(), "FLOAT32_IEEE");
        assert_eq!(c.description, item.description);
    }
    let mode = a.measurement("mode").unwrap();
    assert_eq!(mode.datatype.name(), "ULONG");
    assert_eq!(a.measurement("demand").unwrap().unit, "N");
    let e = a.characteristic("tyre_stifness_0").unwrap_err();
    assert_eq!(
        e.to_string(),
        "no CHARACTERISTIC `tyre_stifness_0` in the A2L file (did you mean `tyre_stiffness_0`?)"
    );
    assert!(matches!(
        a.measurement("nothing_like_it"),
        Err(Error::UnknownName {
            suggestion: None,
            ..
        })
    ));
}

#[test]
fn connect_reads_the_boards_session_and_skips_foreign_and_padded_frames() {
    let mut m = master();
    m.transport_mut().foreign_traffic = true;
    m.transport_mut().pad_responses = true;
    let info = m.connect().unwrap();
    assert_eq!((info.max_cto, info.max_dto), (8, 8));
    assert_eq!(info.resources, resource::CAL_PAG | resource::DAQ);
    assert!(info.slave_block_mode);
    let comm = info.comm_mode.expect("GET_COMM_MODE_INFO");
    assert!(comm.master_block_mode);
    assert_eq!(comm.max_bs, 42);
    assert_eq!(info.max_one_change(), 252);
    let status = m.get_status().unwrap();
    assert!(status.locked(resource::CAL_PAG) && status.locked(resource::DAQ));
    assert_eq!(m.get_id().unwrap(), "mil_rig_mock");
    assert!(m.counters().foreign_frames >= 3);
    // Padded to 8 bytes, the values read are still the right ones.
    let a = a2l();
    let v = m
        .read_items(&[a.characteristic("tyre_damping_0").unwrap()])
        .unwrap();
    assert_eq!(v, vec![mock_value("tyre_damping_0")]);
    m.disconnect().unwrap();
    assert!(!m.transport_mut().board.slave.connected());
    assert!(matches!(m.get_status(), Err(Error::NotConnected)));
}

#[test]
fn unlock_with_the_secret_opens_both_resources() {
    let mut m = master();
    m.connect().unwrap();
    m.unlock(resource::CAL_PAG, TEST_SECRET).unwrap();
    assert_eq!(m.get_status().unwrap().protection, resource::DAQ);
    m.unlock_all(resource::CAL_PAG | resource::DAQ, TEST_SECRET)
        .unwrap();
    assert_eq!(m.get_status().unwrap().protection, 0);
    // Already unlocked: GET_SEED answers length 0 and nothing else is sent.
    let before = m.transport_mut().sent.len();
    m.unlock(resource::DAQ, TEST_SECRET).unwrap();
    assert_eq!(m.transport_mut().sent.len(), before + 1);
}

#[test]
fn a_wrong_secret_is_refused_and_the_board_disconnects() {
    let mut m = master();
    m.connect().unwrap();
    let e = m
        .unlock(resource::CAL_PAG, b"not-the-board-secret-0123456789")
        .unwrap_err();
    assert!(
        matches!(
            e,
            Error::KeyRejected {
                resource: "CAL/PAG"
            }
        ),
        "{e:?}"
    );
    assert!(e.to_string().contains("wrong key"), "{e}");
    assert!(m.session().is_none());
    assert!(!m.transport_mut().board.slave.connected());
}

#[test]
fn writing_while_locked_names_the_lock() {
    let a = a2l();
    let mut m = master();
    m.connect().unwrap();
    let e = m
        .write_items(&[a.characteristic("tyre_damping_0").unwrap()], &[600.0])
        .unwrap_err();
    assert_eq!(
        e.xcp_code().map(|c| c.name()),
        Some("ERR_ACCESS_LOCKED".into())
    );
    assert!(e.to_string().contains("wrong key or not unlocked"), "{e}");
}

#[test]
fn get_and_set_by_name_with_old_and_new_values() {
    let a = a2l();
    let mut m = connected();
    let stiffness = a.characteristic("tyre_stiffness_0").unwrap();
    let damping = a.characteristic("tyre_damping_0").unwrap();
    let watchdog = a.characteristic("watchdog_limit").unwrap();
    let old = [
        mock_value("tyre_damping_0"),
        mock_value("tyre_stiffness_0"),
        mock_value("watchdog_limit"),
    ];
    assert_eq!(
        m.read_items(&[damping, stiffness, watchdog]).unwrap(),
        old.to_vec()
    );
    let writes_before = ecu(&mut m).writes;
    let changes = m
        .write_items(&[damping, stiffness, watchdog], &[800.0, 2.0e5, 20.0])
        .unwrap();
    assert_eq!(changes.len(), 3);
    assert_eq!(
        (changes[0].name.as_str(), changes[0].old, changes[0].new),
        ("tyre_damping_0", old[0], 800.0)
    );
    assert_eq!(changes[1].unit, "N/m");
    assert_eq!((changes[1].old, changes[1].new), (old[1], 2.0e5));
    assert_eq!((changes[2].old, changes[2].new), (old[2], 20.0));
    // Stiffness and damping are contiguous: one change; the watchdog another.
    assert_eq!(slot("tyre_damping_0"), slot("tyre_stiffness_0") + 1);
    assert_eq!(ecu(&mut m).writes - writes_before, 2);
    let page = ecu(&mut m).working().to_vec();
    assert_eq!(f32_at(&page, slot("tyre_stiffness_0")), 2.0e5);
    assert_eq!(f32_at(&page, slot("tyre_damping_0")), 800.0);
    assert_eq!(f32_at(&page, slot("watchdog_limit")), 20.0);
    let neighbour = slot("tyre_static_load_0");
    assert_eq!(
        f32_at(&page, neighbour),
        neighbour as f32 * 0.5,
        "a neighbour is untouched"
    );
}

#[test]
fn values_outside_the_a2l_limits_are_refused_before_anything_is_sent() {
    let a = a2l();
    let mut m = connected();
    let stiffness = a.characteristic("tyre_stiffness_0").unwrap();
    let sent = downloads(&mut m);
    for bad in [
        f64::NAN,
        f64::INFINITY,
        stiffness.max * 2.0,
        stiffness.min - 1.0,
    ] {
        let e = m.write_items(&[stiffness], &[bad]).unwrap_err();
        assert!(matches!(e, Error::InvalidValue { .. }), "{e:?}");
        assert!(e.to_string().contains("nothing was sent"), "{e}");
    }
    assert_eq!(downloads(&mut m), sent);
    assert_eq!(
        f64::from(f32_at(ecu(&mut m).working(), slot("tyre_stiffness_0"))),
        mock_value("tyre_stiffness_0")
    );
}

/// The mock ECU with a switch that refuses every write the way the firmware refuses an
/// out-of-range value or an unstable set.
struct Picky {
    ecu: MockEcu,
    refuse: Option<Rejected>,
}

impl Memory for Picky {
    fn read_calibration(&self, page: Page, offset: usize, out: &mut [u8]) {
        self.ecu.read_calibration(page, offset, out);
    }
    fn read_measurement(&self, offset: usize, out: &mut [u8]) {
        self.ecu.read_measurement(offset, out);
    }
}

impl Calibration for Picky {
    fn write(&mut self, offset: usize, data: &[u8]) -> Result<(), Rejected> {
        match self.refuse {
            Some(r) => Err(r),
            None => self.ecu.write(offset, data),
        }
    }
    fn copy_reference_to_working(&mut self) -> Result<(), Rejected> {
        self.ecu.copy_reference_to_working()
    }
    fn select_ecu_page(&mut self, page: Page) -> Result<(), Rejected> {
        self.ecu.select_ecu_page(page)
    }
}

#[test]
fn the_boards_own_refusal_is_reported_with_its_meaning() {
    let a = a2l();
    let picky = Picky {
        ecu: MockEcu::new(),
        refuse: None,
    };
    let mut m = Master::new(Loopback::new(sim(picky)), CanIds::default(), TIMEOUT);
    m.connect().unwrap();
    m.unlock(resource::CAL_PAG, TEST_SECRET).unwrap();
    let damping = a.characteristic("tyre_damping_0").unwrap();
    let watchdog = a.characteristic("watchdog_limit").unwrap();
    m.transport_mut().board.target.refuse = Some(Rejected::OutOfRange);
    let e = m.write_items(&[damping], &[700.0]).unwrap_err();
    assert_eq!(
        e.xcp_code().map(|c| c.name()),
        Some("ERR_OUT_OF_RANGE".into())
    );
    assert!(
        e.to_string()
            .starts_with("tyre_damping_0 = 700: DOWNLOAD: the board answered ERR_OUT_OF_RANGE (value refused by the board: outside limits/not finite)"),
        "{e}"
    );
    m.transport_mut().board.target.refuse = Some(Rejected::Unstable);
    let e = m
        .write_items(&[damping, watchdog], &[700.0, 20.0])
        .unwrap_err();
    let text = e.to_string();
    assert!(
        text.contains("ERR_GENERIC (refused: unstable or inconsistent parameter set)"),
        "{text}"
    );
    assert!(matches!(&e, Error::Refused { applied, .. } if applied.is_empty()));
    assert_eq!(f32_at(m.transport_mut().board.target.ecu.working(), 1), 0.5);
}

#[test]
fn a_block_download_is_one_change_and_all_or_nothing() {
    let a = a2l();
    let mut m = connected();
    // Channel 0's filter_sections and its four sections: 21 contiguous slots, 84 bytes.
    let mut names = vec!["filter_sections_0".to_string()];
    for s in 0..4 {
        for c in ["beta0", "beta1", "beta2", "alpha1", "alpha2"] {
            names.push(format!("filter_{c}_0_{s}"));
        }
    }
    let items: Vec<&Item> = names.iter().map(|n| a.characteristic(n).unwrap()).collect();
    let values: Vec<f64> = std::iter::once(2.0)
        .chain((0..20).map(|k| 0.25 + 0.125 * f64::from(k)))
        .collect();
    let writes = ecu(&mut m).writes;
    let first_sent = m.transport_mut().sent.len();
    let changes = m.write_items_as_one_change(&items, &values).unwrap();
    assert_eq!(ecu(&mut m).writes, writes + 1, "one change");
    let frames: Vec<Vec<u8>> = m.transport_mut().sent[first_sent..]
        .iter()
        .map(|f| f.payload().to_vec())
        .collect();
    let download: Vec<&Vec<u8>> = frames.iter().filter(|f| f[0] == cmd::DOWNLOAD).collect();
    let next: Vec<&Vec<u8>> = frames
        .iter()
        .filter(|f| f[0] == cmd::DOWNLOAD_NEXT)
        .collect();
    assert_eq!(download.len(), 1);
    assert_eq!(download[0][1], 84);
    assert_eq!(next.len(), 13);
    assert_eq!(next[0][1], 78, "remaining count");
    for (c, v) in changes.iter().zip(&values) {
        assert_eq!(c.new, *v, "{}", c.name);
    }
    let page = ecu(&mut m).working().to_vec();
    let first = slot("filter_sections_0");
    assert_eq!(f32_at(&page, first), 2.0);
    assert_eq!(f32_at(&page, first + 20), 0.25 + 0.125 * 19.0);

    // The mock refuses a page with a non-finite word: the whole block changes nothing.
    let mut raw = Vec::new();
    for k in 0..21 {
        let v: f32 = if k == 20 { f32::NAN } else { 9.0 };
        raw.extend_from_slice(&v.to_le_bytes());
    }
    let e = m
        .download_one_change(items[0].address, 0, &raw)
        .unwrap_err();
    assert_eq!(
        e.xcp_code().map(|c| c.name()),
        Some("ERR_OUT_OF_RANGE".into())
    );
    assert_eq!(ecu(&mut m).working(), page.as_slice());
    // The line is clean afterwards: the next command gets its own answer.
    assert_eq!(m.read_items(&[items[0]]).unwrap(), vec![2.0]);

    // Items that are not contiguous cannot be one change: refused before sending.
    let sent = downloads(&mut m);
    let apart = [
        a.characteristic("tyre_damping_0").unwrap(),
        a.characteristic("watchdog_limit").unwrap(),
    ];
    let e = m
        .write_items_as_one_change(&apart, &[1.0, 10.0])
        .unwrap_err();
    assert!(e.to_string().contains("not contiguous"), "{e}");
    assert_eq!(downloads(&mut m), sent);
}

#[test]
fn long_uploads_take_several_frames() {
    let a = a2l();
    let mut m = connected();
    let all: Vec<&Item> = a.characteristics.iter().collect();
    let values = m.read_items(&all).unwrap();
    let expected: Vec<f64> = (0..all.len()).map(|i| i as f64 * 0.5).collect();
    assert_eq!(values, expected);
    let raw = m.upload(mock::MEAS_START, 0, 255).unwrap();
    assert_eq!(raw, (0..255u8).collect::<Vec<_>>());
}

#[test]
fn pages_switch_and_copy() {
    let a = a2l();
    let mut m = connected();
    let stiffness = a.characteristic("tyre_stiffness_0").unwrap();
    m.set_cal_page(page_mode::XCP, 0, REFERENCE_PAGE).unwrap();
    assert_eq!(m.get_cal_page(page_mode::XCP, 0).unwrap(), REFERENCE_PAGE);
    // The reference page holds 100 + i.
    assert_eq!(
        m.read_items(&[stiffness]).unwrap(),
        vec![100.0 + slot("tyre_stiffness_0") as f64]
    );
    let e = m.write_items(&[stiffness], &[2.0e5]).unwrap_err();
    assert_eq!(
        e.xcp_code().map(|c| c.name()),
        Some("ERR_WRITE_PROTECTED".into())
    );
    assert!(e.to_string().contains("read-only reference page"), "{e}");
    m.set_cal_page(page_mode::XCP, 0, WORKING_PAGE).unwrap();
    assert_eq!(
        m.read_items(&[stiffness]).unwrap(),
        vec![mock_value("tyre_stiffness_0")]
    );

    m.set_cal_page(page_mode::ECU, 0, REFERENCE_PAGE).unwrap();
    assert_eq!(m.get_cal_page(page_mode::ECU, 0).unwrap(), REFERENCE_PAGE);
    assert_eq!(ecu(&mut m).ecu_page, Page::Reference);
    m.set_cal_page(page_mode::ECU | page_mode::XCP, 0, WORKING_PAGE)
        .unwrap();
    assert_eq!(ecu(&mut m).ecu_page, Page::Working);

    m.copy_cal_page(0, REFERENCE_PAGE, 0, WORKING_PAGE).unwrap();
    assert_eq!(
        m.read_items(&[stiffness]).unwrap(),
        vec![100.0 + slot("tyre_stiffness_0") as f64]
    );
    assert_eq!(
        m.segment_address(0).unwrap(),
        (mock::CAL_START, mock::CAL_LEN as u32)
    );
}

/// The "application": each step writes position = 1e-3·k (m), road = −2e-3·k (m),
/// demand = 10·k (N), mode = k (ULONG) for step k.
fn signals_hook(ecu: &mut MockEcu, time_us: u32) {
    let k = time_us / mock::EVENT_PERIOD_US;
    let m = ecu.measurement_mut();
    m[0..4].copy_from_slice(&(1e-3 * k as f32).to_le_bytes());
    m[4..8].copy_from_slice(&(-2e-3 * k as f32).to_le_bytes());
    m[8..12].copy_from_slice(&(10.0 * k as f32).to_le_bytes());
    m[12..16].copy_from_slice(&k.to_le_bytes());
}

fn daq_master() -> MockMaster {
    let mut m = connected();
    m.transport_mut().board.step_hook = Some(Box::new(signals_hook));
    m
}

#[test]
fn a_daq_list_of_three_signals_gives_timestamped_samples() {
    let a = a2l();
    let mut m = daq_master();
    let signals = [
        a.measurement("position").unwrap(),
        a.measurement("demand").unwrap(),
        a.measurement("mode").unwrap(),
    ];
    let mut session = m.start_daq(&signals, DaqOptions::default()).unwrap();
    assert!(session.board_timestamps());
    // The board samples an event's ODTs together: 4 timestamp and 12 data bytes fill three
    // DTOs, position split between the first two.
    assert_eq!(session.plan().odts.len(), 3);
    assert_eq!(session.event_cycle_s(), Some(500e-6));
    let mut samples = Vec::new();
    for _ in 0..50 {
        samples.push(session.next_sample(TIMEOUT).unwrap());
    }
    let stats = session.stop().unwrap();
    assert_eq!(stats.samples, 50);
    assert_eq!(stats.incomplete, 0);
    for (i, s) in samples.iter().enumerate() {
        assert!(
            (s.time_s - i as f64 * 500e-6).abs() < 1e-12,
            "{i}: {}",
            s.time_s
        );
        let k = s.values[2];
        assert_eq!(k, samples[0].values[2] + i as f64);
        assert_eq!(s.values[0], f64::from(1e-3 * k as f32));
        assert_eq!(s.values[1], f64::from(10.0 * k as f32));
    }
    assert!(!m.transport_mut().board.slave.daq_running());
    assert!(m.get_status().unwrap().session_status & 0x40 == 0);
}

#[test]
fn prescalers_lost_frames_and_timestamp_wrap() {
    let a = a2l();
    let mut m = daq_master();
    // The clock wraps after a few steps.
    m.transport_mut().board.time_us = u32::MAX - 3 * mock::EVENT_PERIOD_US;
    let signals = [
        a.measurement("road").unwrap(),
        a.measurement("mode").unwrap(),
    ];
    let options = DaqOptions {
        prescaler: 3,
        ..DaqOptions::default()
    };
    let dtos_before = m.transport_mut().dtos();
    let mut session = m.start_daq(&signals, options).unwrap();
    assert!(session.prescaler_on_board(), "the board has a prescaler");
    assert_eq!(session.board_prescaler(), 3);
    let odts = session.plan().odts.len() as u64;
    let s: Vec<_> = (0..10)
        .map(|_| session.next_sample(TIMEOUT).unwrap())
        .collect();
    let stats = session.stop().unwrap();
    assert_eq!(stats.decimated, 0);
    // Only every third step reached the bus.
    assert!(m.transport_mut().dtos() - dtos_before <= 11 * odts);
    let mut wrapped = false;
    for (i, w) in s.windows(2).enumerate() {
        // Times keep increasing across the clock's wrap-around.
        assert!(
            (w[1].time_s - w[0].time_s - 1.5e-3).abs() < 1e-12,
            "{i}: {w:?}"
        );
        // Every third step (the mode counter restarts where the clock wraps).
        if w[1].values[1] > w[0].values[1] {
            assert_eq!(w[1].values[1] - w[0].values[1], 3.0, "{i}: {w:?}");
        } else {
            wrapped = true;
        }
    }
    assert!(wrapped, "the clock wrapped during the run");

    // 300 = 150 on the board × every second of its samples on the host.
    let options = DaqOptions {
        prescaler: 300,
        ..DaqOptions::default()
    };
    let mut session = m.start_daq(&signals, options).unwrap();
    assert_eq!(
        (session.board_prescaler(), session.host_prescaler()),
        (150, 2)
    );
    let s: Vec<_> = (0..4)
        .map(|_| session.next_sample(TIMEOUT).unwrap())
        .collect();
    let stats = session.stop().unwrap();
    assert!(stats.decimated >= 3, "{stats:?}");
    for w in s.windows(2) {
        assert!((w[1].time_s - w[0].time_s - 0.15).abs() < 1e-9, "{w:?}");
        assert_eq!(w[1].values[1] - w[0].values[1], 300.0, "{w:?}");
    }

    // A lossy bus: every 7th DTO is lost, the cycles it belonged to are dropped, the rest
    // still decode consistently.
    m.transport_mut().drop_every_dto = Some(7);
    let mut session = m.start_daq(&signals, DaqOptions::default()).unwrap();
    let s: Vec<_> = (0..30)
        .map(|_| session.next_sample(TIMEOUT).unwrap())
        .collect();
    let stats = session.stop().unwrap();
    assert!(stats.incomplete > 0, "{stats:?}");
    for x in &s {
        let k = x.values[1];
        assert_eq!(x.values[0], f64::from(-2e-3 * k as f32));
    }
}

#[test]
fn daq_needs_the_daq_resource_and_dropping_a_session_stops_it() {
    let a = a2l();
    let mut m = master();
    m.connect().unwrap();
    m.unlock(resource::CAL_PAG, TEST_SECRET).unwrap();
    let signals = [a.measurement("position").unwrap()];
    let e = m.start_daq(&signals, DaqOptions::default()).unwrap_err();
    assert_eq!(
        e.xcp_code().map(|c| c.name()),
        Some("ERR_ACCESS_LOCKED".into())
    );
    m.unlock(resource::DAQ, TEST_SECRET).unwrap();
    {
        let mut session = m.start_daq(&signals, DaqOptions::default()).unwrap();
        session.next_sample(TIMEOUT).unwrap();
    }
    assert!(!m.transport_mut().board.slave.daq_running());
    // Parameters can be read while nothing runs; the DTOs left over do not confuse it.
    assert_eq!(
        m.read_items(&[a.characteristic("tyre_damping_0").unwrap()])
            .unwrap(),
        vec![mock_value("tyre_damping_0")]
    );
}

#[test]
fn a_silent_board_times_out_naming_the_command() {
    // The board listens on other IDs: nothing answers 0x7E0.
    let ids = CanIds::new(0x7E2, 0x7E3).unwrap();
    let mut board = sim(MockEcu::new());
    board.ids = ids;
    let mut m = Master::new(
        Loopback::new(board),
        CanIds::default(),
        Duration::from_millis(50),
    );
    let start = Instant::now();
    let e = m.connect().unwrap_err();
    assert!(start.elapsed() >= Duration::from_millis(50));
    assert!(
        matches!(
            e,
            Error::Timeout {
                command: "CONNECT",
                ..
            }
        ),
        "{e:?}"
    );
    assert_eq!(
        e.to_string(),
        "no response to CONNECT within 50 ms (board not running, wrong port or CAN IDs?)"
    );
    // With the board's IDs it answers.
    let mut board = sim(MockEcu::new());
    board.ids = ids;
    let mut m = Master::new(Loopback::new(board), ids, TIMEOUT);
    m.connect().unwrap();
}

#[test]
fn over_slcan_on_tcp() {
    let a = a2l();
    let board = SlcanTcpBoard::start(sim(MockEcu::new())).unwrap();
    let spec: PortSpec = format!("tcp:{}", board.addr()).parse().unwrap();
    let port = spec.open(Duration::from_secs(2)).unwrap();
    let mut m = Master::new(port, CanIds::default(), Duration::from_secs(1));
    m.connect().unwrap();
    m.unlock_all(resource::CAL_PAG, TEST_SECRET).unwrap();
    let damping = a.characteristic("tyre_damping_0").unwrap();
    let changes = m.write_items(&[damping], &[650.0]).unwrap();
    assert_eq!(
        (changes[0].old, changes[0].new),
        (mock_value("tyre_damping_0"), 650.0)
    );
    m.disconnect().unwrap();
    let page = board.with_board(|b| b.target.working().to_vec());
    assert_eq!(f32_at(&page, slot("tyre_damping_0")), 650.0);
}

#[test]
fn too_many_signals_overflow_the_boards_daq_memory_and_leave_nothing_allocated() {
    let mut m = daq_master();
    // 64 words of the measurement region: 260 bytes with the timestamp, 38 DTOs; the board
    // has 32 ODTs.
    let signals: Vec<Item> = (0..64u32)
        .map(|k| Item {
            name: format!("word{k}"),
            description: String::new(),
            address: mock::MEAS_START + 4 * k,
            extension: 0,
            datatype: mil_xcp_master::a2l::DataType::U32,
            endian: mil_xcp_master::a2l::Endian::Little,
            conversion: mil_xcp_master::a2l::Conversion::Identical,
            min: 0.0,
            max: 4e9,
            unit: String::new(),
        })
        .collect();
    let refs: Vec<&Item> = signals.iter().collect();
    let e = m.start_daq(&refs, DaqOptions::default()).unwrap_err();
    assert_eq!(
        e.xcp_code().map(|c| c.name()),
        Some("ERR_MEMORY_OVERFLOW".into())
    );
    assert!(e.to_string().contains("fewer signals"), "{e}");
    // Freed: no list allocated, nothing running; a smaller list starts.
    assert_eq!(m.daq_processor_info().unwrap().max_daq, 0);
    let mut session = m.start_daq(&refs[..30], DaqOptions::default()).unwrap();
    let s = session.next_sample(TIMEOUT).unwrap();
    // Words 4.. of the mock's measurement block still hold bytes 16.. (the hook writes 0..16).
    assert_eq!(s.values[4], f64::from(u32::from_le_bytes([16, 17, 18, 19])));
    session.stop().unwrap();
}

/// SET_REQUEST STORE_CAL_REQ: the master waits until the store is no longer pending and
/// reports EV_STORE_CAL; a board that refuses (its controller runs) is reported with what
/// to do.
#[test]
fn a_calibration_store_waits_for_the_board_and_reports_its_refusal() {
    let mut m = connected();
    assert_eq!(m.store_calibration(Duration::from_secs(1)).ok(), Some(true));
    assert_eq!(m.transport_mut().board.stores, 1);
    assert_eq!(m.counters().store_events, 1);
    assert!(!m.get_status().expect("status").store_pending());
    ecu(&mut m).refuse_store = Some(mil_xcp::StoreRefused::NotNow);
    let e = m.store_calibration(Duration::from_secs(1)).unwrap_err();
    let text = e.to_string();
    assert!(
        text.contains("ERR_RESOURCE_TEMPORARY_NOT_ACCESSIBLE") && text.contains("stop it first"),
        "{text}"
    );
    assert_eq!(m.transport_mut().board.stores, 1);
    // Locked: refused with the lock named, nothing stored.
    let mut locked = master();
    locked.connect().expect("connect");
    let e = locked
        .store_calibration(Duration::from_secs(1))
        .unwrap_err();
    assert!(e.to_string().contains("ERR_ACCESS_LOCKED"), "{e}");
    assert_eq!(locked.transport_mut().board.stores, 0);
}
