//! `mil param`, `mil daq record` and `mil filter upload` run as programs: the parameter table
//! of an A2L file (made by `mil_a2l` for the mock board's memory layout), one-line errors,
//! and, against the board's XCP slave over a mock ECU behind SLCAN over TCP (as QEMU exposes
//! the board), reads, writes, a recording and a filter upload checked in the board's memory.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use mil_analysis::filter_file::FilterFile;
use mil_xcp::mock::{self, MockEcu, MockPlatform, TEST_SECRET};
use mil_xcp::Slave;
use mil_xcp_master::loopback::SimBoard;
use mil_xcp_master::CanIds;
use model_core::{BiquadCoefficients, CascadeCoefficients};

mod xcp_board;
use xcp_board::{a2l_fixture, board, Board};

fn mil(args: &[&str], secret: Option<&[u8]>) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_mil"));
    c.args(args).env_remove("MIL_XCP_SECRET");
    if let Some(s) = secret {
        c.env("MIL_XCP_SECRET", std::str::from_utf8(s).unwrap());
    }
    c.output().expect("run mil")
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A failed run with exactly one line on stderr, `Error: ...`.
fn one_line_error(o: &Output) -> String {
    assert!(!o.status.success(), "succeeded: {}", stdout(o));
    let e = stderr(o);
    assert_eq!(e.lines().count(), 1, "not one line: {e}");
    assert!(e.starts_with("Error: "), "{e}");
    e
}

fn port(b: &Board) -> String {
    format!("tcp:{}", b.addr())
}

/// The page slot of the parameter named `name` (the A2L's name).
fn at(name: &str) -> usize {
    mil_firmware::calibration::slot_named(name).unwrap_or_else(|| panic!("no slot {name}"))
}

/// What the mock's working page holds in slot `slot` before any write: `slot × 0.5`.
fn initial(slot: usize) -> f32 {
    slot as f32 * 0.5
}

fn working_f32(b: &Board, slot: usize) -> f32 {
    b.with_board(|s| {
        let w = s.target.working();
        f32::from_le_bytes(w[4 * slot..4 * slot + 4].try_into().unwrap())
    })
}

fn text(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn param_list_prints_the_a2l_table_without_a_board() {
    let dir = tempfile::tempdir().unwrap();
    let a2l = a2l_fixture(dir.path());
    let o = mil(&["param", "list", "--a2l", text(&a2l)], None);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    use mil_firmware::calibration::{slot_named, MEAS_ITEMS, SLOTS};
    assert!(
        out.starts_with(&format!("{SLOTS} calibration parameters")),
        "{out}"
    );
    let line = |name: &str| {
        out.lines()
            .find(|l| l.split_whitespace().next() == Some(name))
            .unwrap_or_else(|| panic!("{name} missing:\n{out}"))
            .split_whitespace()
            .map(str::to_string)
            .collect::<Vec<_>>()
    };
    let address = |name: &str| format!("0x{:08x}", 0x2000_0000 + 4 * slot_named(name).unwrap());
    let stiffness = line("tyre_stiffness_0");
    assert_eq!(stiffness[1], "N/m");
    assert_eq!(stiffness[4], address("tyre_stiffness_0"));
    assert_eq!(stiffness[5..].join(" "), "tyre radial stiffness k_t");
    let alpha = line("filter_alpha2_0_3");
    assert_eq!(&alpha[1..5], ["-", "0", "4", &address("filter_alpha2_0_3")]);
    let kind = line("model_kind");
    assert_eq!(&kind[1..4], ["-", "0", "2"]);
    assert!(
        out.contains(&format!(
            "\n{} measurements (mil daq record --signals):",
            MEAS_ITEMS.len()
        )),
        "{out}"
    );
    let position = line("position");
    assert_eq!(
        &position[1..5],
        [
            "m",
            "-1",
            "1",
            &format!("0x{:08x}", mil_xcp::mock::MEAS_START)
        ]
    );
}

#[test]
fn a_bad_a2l_is_a_one_line_error() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("nothing-here.a2l");
    let e = one_line_error(&mil(&["param", "list", "--a2l", text(&missing)], None));
    assert!(
        e.contains("nothing-here.a2l") && e.contains("No such file"),
        "{e}"
    );
    let junk = dir.path().join("junk.a2l");
    std::fs::write(&junk, "/begin PROJECT broken \"\"\n").unwrap();
    let e = one_line_error(&mil(&["param", "list", "--a2l", text(&junk)], None));
    assert!(e.contains("junk.a2l: not a valid A2L file"), "{e}");
}

#[test]
fn param_get_and_set_against_the_board() {
    let dir = tempfile::tempdir().unwrap();
    let a2l = a2l_fixture(dir.path());
    let b = board();
    let p = port(&b);
    let o = mil(
        &[
            "param",
            "get",
            "tyre_damping_0",
            "watchdog_limit",
            "mode",
            "--a2l",
            text(&a2l),
            "--port",
            &p,
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    // The mock's working page holds i * 0.5 in slot i; the measurement block byte i = i.
    assert_eq!(
        stdout(&o),
        format!(
            "tyre_damping_0 = {} N*s/m\nwatchdog_limit = {} -\nmode           = 252579084 -\n",
            initial(at("tyre_damping_0")),
            initial(at("watchdog_limit"))
        )
    );

    let secret_file = dir.path().join("secret");
    std::fs::write(&secret_file, [TEST_SECRET, b"\n"].concat()).unwrap();
    let o = mil(
        &[
            "param",
            "set",
            "tyre_damping_0=800",
            "tyre_stiffness_0=2.5e5",
            "--a2l",
            text(&a2l),
            "--port",
            &p,
            "--secret-file",
            text(&secret_file),
        ],
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        stdout(&o),
        format!(
            "tyre_damping_0  : {} → 800 N*s/m\ntyre_stiffness_0: {} → 250000 N/m\n",
            initial(at("tyre_damping_0")),
            initial(at("tyre_stiffness_0"))
        )
    );
    assert_eq!(working_f32(&b, at("tyre_stiffness_0")), 2.5e5);
    assert_eq!(working_f32(&b, at("tyre_damping_0")), 800.0);

    // Outside the A2L limits: refused before the board is contacted.
    let o = mil(
        &[
            "param",
            "set",
            "tyre_damping_0=1e12",
            "--a2l",
            text(&a2l),
            "--port",
            &p,
        ],
        Some(TEST_SECRET),
    );
    let e = one_line_error(&o);
    assert!(
        e.contains("outside the A2L limits") && e.contains("nothing was sent"),
        "{e}"
    );
    let e = one_line_error(&mil(
        &[
            "param",
            "set",
            "tyre_dampng_0=1",
            "--a2l",
            text(&a2l),
            "--port",
            &p,
        ],
        Some(TEST_SECRET),
    ));
    assert!(e.contains("did you mean `tyre_damping_0`"), "{e}");
    // A wrong secret, and none at all.
    let e = one_line_error(&mil(
        &[
            "param",
            "set",
            "tyre_damping_0=700",
            "--a2l",
            text(&a2l),
            "--port",
            &p,
        ],
        Some(b"not-the-secret-of-this-board"),
    ));
    assert!(e.contains("wrong key"), "{e}");
    let e = one_line_error(&mil(
        &[
            "param",
            "set",
            "tyre_damping_0=700",
            "--a2l",
            text(&a2l),
            "--port",
            &p,
        ],
        None,
    ));
    assert!(
        e.contains("--secret-file") && e.contains("MIL_XCP_SECRET"),
        "{e}"
    );
    assert_eq!(working_f32(&b, at("tyre_damping_0")), 800.0);
}

#[test]
fn daq_record_writes_timestamped_csv() {
    let dir = tempfile::tempdir().unwrap();
    let a2l = a2l_fixture(dir.path());
    let b = board();
    let csv = dir.path().join("rec/daq.csv");
    let o = mil(
        &[
            "daq",
            "record",
            "--signals",
            "position,mode",
            "--samples",
            "40",
            "--a2l",
            text(&a2l),
            "--port",
            &port(&b),
            "--out",
            text(&csv),
        ],
        Some(TEST_SECRET),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("40 samples"), "{}", stdout(&o));
    assert!(
        stdout(&o).contains("position [m], mode [-]"),
        "{}",
        stdout(&o)
    );
    let written = std::fs::read_to_string(&csv).unwrap();
    let mut lines = written.lines();
    assert_eq!(lines.next(), Some("time [s],position [m],mode"));
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 40);
    for (i, r) in rows.iter().enumerate() {
        assert!((r[0] - i as f64 * 500e-6).abs() < 1e-9, "{i}: {r:?}");
        assert_eq!(r[2], rows[0][2] + i as f64, "{i}: {r:?}");
        assert_eq!(r[1] as f32, 1e-3 * r[2] as f32, "{i}: {r:?}");
    }
    assert!(
        !b.with_board(|s| s.slave.daq_running()),
        "stopped at the end"
    );

    // Every fourth control step, by the board's prescaler.
    let o = mil(
        &[
            "daq",
            "record",
            "--signals",
            "mode",
            "--samples",
            "5",
            "--prescaler",
            "4",
            "--a2l",
            text(&a2l),
            "--port",
            &port(&b),
            "--out",
            text(&csv),
        ],
        Some(TEST_SECRET),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("(1 in 4 control steps at 2000 Hz; 2 CAN frames per sample)"),
        "{}",
        stdout(&o)
    );
    let written = std::fs::read_to_string(&csv).unwrap();
    let rows: Vec<Vec<f64>> = written
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 5);
    for w in rows.windows(2) {
        assert!((w[1][0] - w[0][0] - 2e-3).abs() < 1e-9, "{w:?}");
        assert_eq!(w[1][1] - w[0][1], 4.0, "{w:?}");
    }
}

fn filter_file(dir: &Path, sample_rate_hz: f64) -> PathBuf {
    let sections = [
        BiquadCoefficients::from_direct_form([0.5, -0.3, 0.1], [-1.8, 0.82]),
        BiquadCoefficients::from_direct_form([0.2, 0.1, 0.05], [-1.5, 0.6]),
    ];
    let cascade = CascadeCoefficients::from_sections(&sections).unwrap();
    let path = dir.join(format!("filter-{sample_rate_hz}.json"));
    FilterFile::new(&cascade, sample_rate_hz)
        .write(&path)
        .unwrap();
    path
}

#[test]
fn filter_upload_writes_each_channels_filter_as_one_change() {
    let dir = tempfile::tempdir().unwrap();
    let a2l = a2l_fixture(dir.path());
    let b = board();
    let p = port(&b);
    let writes = b.with_board(|s| s.target.writes);
    let filter = filter_file(dir.path(), 2000.0);
    let o = mil(
        &[
            "filter",
            "upload",
            text(&filter),
            "--a2l",
            text(&a2l),
            "--port",
            &p,
        ],
        Some(TEST_SECRET),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    let channels = model_core::board::BOARD_CHANNELS;
    assert!(
        out.starts_with(&format!(
            "filter_sections: {} → 2 on each of {channels} channel(s) (one block of 21 \
             parameters a channel at 2000 Hz)",
            initial(at("filter_sections_0"))
        )),
        "{out}"
    );
    assert!(out.contains("(pass-through)"), "{out}");
    assert_eq!(
        b.with_board(|s| s.target.writes),
        writes + channels as u32,
        "one change a channel"
    );
    let (file, cascade) = FilterFile::read(&filter).unwrap();
    assert_eq!(file.sections.len(), 2);
    for ch in 0..channels {
        assert_eq!(working_f32(&b, at(&format!("filter_sections_{ch}"))), 2.0);
        for (k, s) in cascade.section.iter().enumerate() {
            let expected = [s.beta0, s.beta1, s.beta2, s.alpha1, s.alpha2];
            for (c, e) in expected.iter().enumerate() {
                assert_eq!(
                    working_f32(&b, at(&format!("filter_beta0_{ch}_{k}")) + c),
                    *e,
                    "channel {ch} section {k} coefficient {c}"
                );
            }
        }
        assert_eq!(
            working_f32(&b, at(&format!("filter_beta0_{ch}_3"))),
            1.0,
            "section 3 is the pass-through"
        );
    }

    // A coefficient outside its A2L limits is refused before the board is contacted.
    let loud = dir.path().join("loud.json");
    let sections = [BiquadCoefficients::from_direct_form(
        [2000.0, 0.0, 0.0],
        [-1.8, 0.82],
    )];
    FilterFile::new(
        &CascadeCoefficients::from_sections(&sections).unwrap(),
        2000.0,
    )
    .write(&loud)
    .unwrap();
    let e = one_line_error(&mil(
        &[
            "filter",
            "upload",
            text(&loud),
            "--a2l",
            text(&a2l),
            "--port",
            "tcp:127.0.0.1:1",
        ],
        Some(TEST_SECRET),
    ));
    assert!(
        e.contains("filter_beta0_0_0 = 2000: outside the A2L limits"),
        "{e}"
    );

    // A filter for another sample rate is refused before anything is written.
    let other = filter_file(dir.path(), 1000.0);
    let e = one_line_error(&mil(
        &[
            "filter",
            "upload",
            text(&other),
            "--a2l",
            text(&a2l),
            "--port",
            &p,
        ],
        Some(TEST_SECRET),
    ));
    assert!(
        e.contains("designed for 1000 Hz") && e.contains("2000 Hz"),
        "{e}"
    );
    assert_eq!(b.with_board(|s| s.target.writes), writes + channels as u32);
}

#[test]
fn an_unreachable_port_is_a_one_line_error() {
    let dir = tempfile::tempdir().unwrap();
    let a2l = a2l_fixture(dir.path());
    // A port nothing listens on: bind one and release it.
    let free = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap();
    let e = one_line_error(&mil(
        &[
            "param",
            "get",
            "tyre_damping_0",
            "--a2l",
            text(&a2l),
            "--port",
            &format!("tcp:{free}"),
            "--timeout-ms",
            "200",
        ],
        None,
    ));
    assert!(e.contains("cannot open the port"), "{e}");
    // A malformed --port is clap's usage error, naming the forms.
    let o = mil(
        &[
            "param",
            "get",
            "tyre_damping_0",
            "--a2l",
            text(&a2l),
            "--port",
            "usb:0",
        ],
        None,
    );
    assert!(!o.status.success());
    assert!(stderr(&o).contains("tcp:HOST:PORT"), "{}", stderr(&o));
}

#[test]
fn a_recording_stops_when_asked_and_frees_the_list() {
    use mil::daq_record::{record, Length, Request};
    use mil_xcp_master::loopback::Loopback;
    use mil_xcp_master::Master;
    let dir = tempfile::tempdir().unwrap();
    let a2l = mil::xcp::load_a2l(&a2l_fixture(dir.path())).unwrap();
    let mut sim = SimBoard::new(
        Slave::new(mock::config()).unwrap(),
        MockEcu::new(),
        MockPlatform::default(),
        CanIds::default(),
    );
    sim.step_hook = Some(Box::new(|ecu: &mut MockEcu, time_us: u32| {
        let k = time_us / mock::EVENT_PERIOD_US;
        ecu.measurement_mut()[12..16].copy_from_slice(&k.to_le_bytes());
    }));
    let mut m = Master::new(
        Loopback::new(sim),
        CanIds::default(),
        std::time::Duration::from_millis(300),
    );
    m.connect().unwrap();
    let signals = mil::daq_record::resolve_signals(&a2l, &["mode".into()]).unwrap();
    let request = Request {
        prescaler: 1,
        length: Length::Duration(60.0),
        out: dir.path().join("stopped.csv"),
    };
    let calls = std::cell::Cell::new(0);
    let recorded = record(
        &mut m,
        &signals,
        TEST_SECRET,
        &request,
        |_| {},
        || {
            calls.set(calls.get() + 1);
            calls.get() > 25
        },
    )
    .unwrap();
    assert!(recorded.interrupted);
    assert_eq!(recorded.samples, 25);
    assert_eq!(recorded.dtos_per_sample, 2);
    assert!(!m.transport_mut().board.slave.daq_running());
    let csv = std::fs::read_to_string(&request.out).unwrap();
    assert_eq!(csv.lines().count(), 26);
}
