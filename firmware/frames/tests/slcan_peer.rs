//! Interoperability with python-can's `slcan` interface (a real host): the test serves an
//! SLCAN device on a loopback TCP port built from this crate's `LineBuffer`, `parse_line` and
//! `format_*`, and python-can (`socket://127.0.0.1:PORT`) opens it at 1 Mbit/s, sends
//! frames, asks for the version and serial number, receives frames and shuts down.
//!
//! Checks the exact opening handshake python-can sends (`C`, `S8`, empty line, `O`, `O`), the
//! frames both ways (MiL frames decode to what was encoded), and the `V` / `N` replies.
//! Needs the Python peers (see `tests/common/mod.rs`).

mod common;

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::process::Command as Process;
use std::time::{Duration, Instant};

use mil_frames::embedded_can::{ExtendedId, Frame, Id, StandardId};
use mil_frames::slcan::{self, LineBuffer, SlcanFrame, SlcanLine};
use mil_frames::*;
use serde_json::{json, Value};

const L: Layout = Layout::DEFAULT;

fn frame_json(f: &SlcanFrame) -> Value {
    let (id, extended) = match f.id() {
        Id::Standard(id) => (u32::from(id.as_raw()), false),
        Id::Extended(id) => (id.as_raw(), true),
    };
    let data: String = f.data().iter().map(|b| format!("{b:02x}")).collect();
    json!({"id": id, "extended": extended, "remote": f.is_remote_frame(), "dlc": f.dlc(), "data": data})
}

fn accept(listener: &TcpListener, deadline: Instant) -> TcpStream {
    listener.set_nonblocking(true).unwrap();
    loop {
        match listener.accept() {
            Ok((s, _)) => {
                s.set_nonblocking(false).unwrap();
                return s;
            }
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                assert!(Instant::now() < deadline, "python-can never connected");
                std::thread::sleep(Duration::from_millis(10));
            }
            Err(e) => panic!("accept: {e}"),
        }
    }
}

/// The device: answers every line, sends `to_host` after the serial number, returns the
/// parsed lines until the host closes the connection.
fn serve(listener: TcpListener, to_host: Vec<SlcanFrame>) -> Vec<Result<SlcanLine, SlcanError>> {
    let mut s = accept(&listener, Instant::now() + Duration::from_secs(60));
    s.set_read_timeout(Some(Duration::from_secs(30))).unwrap();
    s.set_nodelay(true).unwrap();
    let mut lb = LineBuffer::<{ slcan::MAX_LINE }>::new();
    let mut lines = Vec::new();
    let mut byte = [0_u8; 1];
    let mut out = [0_u8; slcan::MAX_LINE + 1];
    loop {
        match s.read(&mut byte) {
            Ok(0) => return lines,
            Ok(_) => {}
            Err(e) => panic!("device read: {e} (lines so far: {lines:?})"),
        }
        let parsed = match lb.push(byte[0]) {
            Ok(Some(line)) => slcan::parse_line(line),
            Ok(None) => continue,
            Err(e) => Err(e),
        };
        let reply: &[u8] = match parsed {
            Ok(SlcanLine::Version) => {
                let n = slcan::format_version(10, 13, &mut out).unwrap();
                &out[..n]
            }
            Ok(SlcanLine::SerialNumber) => {
                let n = slcan::format_serial_number(0xA1B2, &mut out).unwrap();
                s.write_all(&out[..n]).unwrap();
                for f in &to_host {
                    let n = slcan::format_frame(f, &mut out).unwrap();
                    s.write_all(&out[..n]).unwrap();
                }
                &[]
            }
            Ok(_) => slcan::OK,
            Err(_) => slcan::ERROR,
        };
        s.write_all(reply).unwrap();
        lines.push(parsed);
    }
}

#[test]
fn python_can_slcan_talks_to_our_lines() {
    // Host → device: MiL measurements, an extended frame, a remote frame.
    let measurements: Vec<Measurement> = (0..4)
        .map(|ch| Measurement {
            channel: ch,
            position_m: 0.1 * f32::from(ch) - 0.15,
            road_m: -0.02,
            counter: 250 + ch,
        })
        .collect();
    let mut to_device: Vec<SlcanFrame> = measurements
        .iter()
        .map(|m| SlcanFrame::from(encode_measurement(&L, m).unwrap()))
        .collect();
    to_device.push(SlcanFrame::new(ExtendedId::new(0x18FF_0102).unwrap(), &[1, 2, 3]).unwrap());
    to_device.push(SlcanFrame::new_remote(StandardId::new(0x100).unwrap(), 7).unwrap());

    // Device → host: demands, the heartbeat, an extended and a remote frame.
    let demands: Vec<Demand> = (0..4)
        .map(|ch| Demand {
            channel: ch,
            demand_n: 1234.5 * f32::from(ch) - 500.0,
            counter: 250 + ch,
            flags: DemandFlags {
                mode: Mode::Running,
                rate_limited: ch == 2,
                ..DemandFlags::default()
            },
        })
        .collect();
    let status = Status::saturating(Mode::Running, 0, 1, 2, 3);
    let mut to_host: Vec<SlcanFrame> = demands
        .iter()
        .map(|d| SlcanFrame::from(encode_demand(&L, d).unwrap()))
        .collect();
    to_host.push(SlcanFrame::from(encode_status(&L, &status)));
    to_host.push(SlcanFrame::new(ExtendedId::MAX, &[0xFF; 8]).unwrap());
    to_host.push(SlcanFrame::new_remote(StandardId::new(0x7FF).unwrap(), 0).unwrap());

    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    let device = {
        let to_host = to_host.clone();
        std::thread::spawn(move || serve(listener, to_host))
    };

    let request = json!({
        "send": to_device.iter().map(frame_json).collect::<Vec<_>>(),
        "expect": to_host.len(),
    });
    let path = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("slcan-request-{}.json", std::process::id()));
    std::fs::write(&path, serde_json::to_vec(&request).unwrap()).unwrap();
    let out = Process::new(common::python())
        .arg(common::peer_script("slcan_peer.py"))
        .arg(port.to_string())
        .arg(&path)
        .output()
        .expect("run the python-can peer");
    let _ = std::fs::remove_file(&path);
    assert!(
        out.status.success(),
        "python-can peer failed: {}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    let reply: Value = serde_json::from_slice(&out.stdout).unwrap();
    let lines = device.join().unwrap();
    println!(
        "peer: python-can {}; device saw {} lines",
        reply["python_can"],
        lines.len()
    );

    // What python-can sent, in order.
    let mut expected = vec![
        Ok(SlcanLine::Close),
        Ok(SlcanLine::SetBitrate {
            code: 8,
            bit_per_s: 1_000_000,
        }),
        Ok(SlcanLine::Empty),
        Ok(SlcanLine::Open),
        Ok(SlcanLine::Open),
    ];
    expected.extend(to_device.iter().map(|f| Ok(SlcanLine::Frame(*f))));
    expected.extend([
        Ok(SlcanLine::Version),
        Ok(SlcanLine::SerialNumber),
        Ok(SlcanLine::Close),
    ]);
    assert_eq!(lines, expected);

    // The MiL frames decode to what was encoded.
    for (m, line) in measurements.iter().zip(&lines[5..]) {
        let Ok(SlcanLine::Frame(f)) = line else {
            panic!("{line:?}")
        };
        let sent = encode_measurement(&L, m).unwrap();
        assert_eq!(RawFrame::try_from_frame(f), Ok(sent));
        assert_eq!(decode_frame(&L, f), decode(&L, &sent));
        assert!(
            matches!(decode_frame(&L, f), Ok(Message::Measurement(d)) if d.channel == m.channel && d.counter == m.counter)
        );
    }
    assert_eq!(
        decode_frame(&L, &to_device[4]),
        Err(DecodeError::ExtendedId)
    );
    assert_eq!(
        decode_frame(&L, &to_device[5]),
        Err(DecodeError::RemoteFrame)
    );

    // The replies python-can parsed.
    assert_eq!(reply["version"], json!([10, 13]));
    assert_eq!(reply["serial"], "A1B2");
    let received = reply["received"].as_array().unwrap();
    let want: Vec<Value> = to_host.iter().map(frame_json).collect();
    assert_eq!(received, &want);
}
