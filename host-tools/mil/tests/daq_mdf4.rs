//! `mil daq record --out X.mf4` as a program, against the board's XCP slave over a mock ECU
//! behind SLCAN over TCP (as QEMU exposes the board): the file is ASAM MDF 4, read back with
//! `mdf4-rs`, and holds the same recording as the CSV for the same settings.

use std::path::Path;
use std::process::{Command, Output};

use mdf4_rs::{DecodedValue, MDF};
use mil_xcp::mock::TEST_SECRET;

mod xcp_board;
use xcp_board::{a2l_fixture, board, Board};

fn text(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// `mil daq record` of `samples` samples of position and mode into `out`.
fn record(a2l: &Path, b: &Board, samples: u32, out: &Path) -> Output {
    let o = Command::new(env!("CARGO_BIN_EXE_mil"))
        .args([
            "daq",
            "record",
            "--signals",
            "position,mode",
            "--samples",
            &samples.to_string(),
            "--a2l",
            text(a2l),
            "--port",
            &format!("tcp:{}", b.addr()),
            "--out",
            text(out),
        ])
        .env("MIL_XCP_SECRET", std::str::from_utf8(TEST_SECRET).unwrap())
        .output()
        .expect("run mil");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains(&format!("{samples} samples")), "{stdout}");
    o
}

fn floats(values: Vec<Option<DecodedValue>>) -> Vec<f64> {
    values
        .into_iter()
        .map(|v| match v {
            Some(DecodedValue::Float(x)) => x,
            other => panic!("not a float sample: {other:?}"),
        })
        .collect()
}

#[test]
fn daq_record_writes_mdf4_with_time_master_and_units() {
    let dir = tempfile::tempdir().unwrap();
    let a2l = a2l_fixture(dir.path());
    let b = board();
    let mf4 = dir.path().join("rec/x.mf4");
    record(&a2l, &b, 50, &mf4);
    assert!(
        !b.with_board(|s| s.slave.daq_running()),
        "stopped at the end"
    );

    // The identification block: "MDF     " then the version, "4.xx".
    let bytes = std::fs::read(&mf4).unwrap();
    assert_eq!(&bytes[0..8], b"MDF     ", "{:?}", &bytes[..16]);
    assert!(bytes[8..16].starts_with(b"4."), "{:?}", &bytes[8..16]);

    let mdf = MDF::from_file(text(&mf4)).unwrap();
    let groups = mdf.channel_groups();
    assert_eq!(groups.len(), 1, "one channel group");
    let channels = groups[0].channels();
    let names: Vec<String> = channels
        .iter()
        .map(|c| c.name().unwrap().unwrap_or_default())
        .collect();
    assert_eq!(names, ["time", "position", "mode"]);
    let units: Vec<Option<String>> = channels.iter().map(|c| c.unit().unwrap()).collect();
    assert_eq!(
        units,
        [Some("s".to_string()), Some("m".to_string()), None],
        "mode has the A2L's `-`: no unit"
    );
    // `time` is the master channel (cn_type 2), synchronised on time (cn_sync_type 1).
    assert_eq!(channels[0].block().channel_type, 2);
    assert_eq!(channels[0].block().sync_type, 1);
    assert!(channels[1..].iter().all(|c| c.block().channel_type == 0));

    let time = floats(channels[0].values().unwrap());
    let position = floats(channels[1].values().unwrap());
    let mode = floats(channels[2].values().unwrap());
    assert_eq!(time.len(), 50);
    assert_eq!(position.len(), 50);
    assert_eq!(mode.len(), 50);
    for i in 0..50 {
        // The board's 500 µs control step, 0 at the first sample.
        assert!(
            (time[i] - i as f64 * 500e-6).abs() < 1e-9,
            "{i}: {}",
            time[i]
        );
        // What the mock board wrote: mode = k and position = 1e-3·k (as f32) in step k.
        assert_eq!(mode[i], mode[0] + i as f64, "{i}");
        assert_eq!(position[i] as f32, 1e-3 * mode[i] as f32, "{i}");
        assert_eq!(
            position[i],
            f64::from(1e-3 * mode[i] as f32),
            "{i}: f32 exactly"
        );
    }

    // The CSV of the same settings has the same time column (to its 1 µs resolution).
    let csv = dir.path().join("rec/x.csv");
    record(&a2l, &b, 50, &csv);
    let written = std::fs::read_to_string(&csv).unwrap();
    let mut lines = written.lines();
    assert_eq!(lines.next(), Some("time [s],position [m],mode"));
    let csv_time: Vec<f64> = lines
        .map(|l| l.split(',').next().unwrap().parse().unwrap())
        .collect();
    assert_eq!(csv_time.len(), time.len());
    for (i, (c, m)) in csv_time.iter().zip(&time).enumerate() {
        assert!((c - m).abs() < 1e-6, "{i}: csv {c}, mdf {m}");
    }
    assert_ne!(
        &written.as_bytes()[..3],
        b"MDF",
        "other extensions stay CSV"
    );
}

#[test]
fn the_mdf_extension_is_mdf4_too() {
    assert!(mil::daq_record::is_mdf(Path::new("a/b.mf4")));
    assert!(mil::daq_record::is_mdf(Path::new("b.MDF")));
    assert!(mil::daq_record::is_mdf(Path::new("b.Mf4")));
    assert!(!mil::daq_record::is_mdf(Path::new("b.csv")));
    assert!(!mil::daq_record::is_mdf(Path::new("b.mf4.csv")));
    assert!(!mil::daq_record::is_mdf(Path::new("mf4")));

    let dir = tempfile::tempdir().unwrap();
    let a2l = a2l_fixture(dir.path());
    let b = board();
    let out = dir.path().join("y.mdf");
    record(&a2l, &b, 3, &out);
    let mdf = MDF::from_file(text(&out)).unwrap();
    let groups = mdf.channel_groups();
    let channels = groups[0].channels();
    assert_eq!(floats(channels[2].values().unwrap()).len(), 3);
}
