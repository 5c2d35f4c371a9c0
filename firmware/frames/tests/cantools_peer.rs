//! Interoperability with Python `cantools` (a real peer reading mil.dbc):
//! - frames our encoders produce, decoded by cantools, give the values we encoded (within
//!   half a count plus f32 rounding) and exactly our own decoded values (`raw · f32 factor`);
//! - frames cantools encodes from physical values decode here to those values, and re-encode
//!   to cantools' bytes;
//! - malformed frames cantools builds (NaN value, "not available", beyond 1 m, bad mode,
//!   unknown command) are refused with the right error.
//!
//! Needs the Python peers (see `tests/common/mod.rs`): fails, saying how to install them,
//! when they are missing.

mod common;

use std::collections::BTreeMap;
use std::process::Command as Process;

use mil_frames::dbc::{self, SignalKind, SignalSpec};
use mil_frames::*;
use serde_json::{json, Value};

use common::Rng;

const L: Layout = Layout::DEFAULT;

/// DBC message name of a message.
fn dbc_name(m: &Message) -> String {
    let kind = m.kind();
    match m.channel() {
        Some(ch) => format!("{}_Ch{ch}", kind.spec().name),
        None => kind.spec().name.to_string(),
    }
}

fn specs(kind: MessageKind) -> &'static [SignalSpec] {
    match kind {
        MessageKind::Measurement => &dbc::measurement::SIGNALS,
        MessageKind::MeasurementAux => &dbc::measurement_aux::SIGNALS,
        MessageKind::Demand => &dbc::demand::SIGNALS,
        MessageKind::Status => &dbc::status::SIGNALS,
        MessageKind::Command => &dbc::command::SIGNALS,
        MessageKind::CommandAck => &dbc::command_ack::SIGNALS,
    }
}

/// Signal values of a message by DBC signal name (physical units).
fn signals(m: &Message) -> BTreeMap<&'static str, f64> {
    let b = |v: bool| f64::from(u8::from(v));
    let v: Vec<(&str, f64)> = match m {
        Message::Measurement(m) => vec![
            ("Position", m.position_m.into()),
            ("Road", m.road_m.into()),
            ("Counter", m.counter.into()),
        ],
        Message::MeasurementAux(m) => {
            vec![("Force", m.force_n.into()), ("Speed", m.speed_m_s.into())]
        }
        Message::Demand(m) => vec![
            ("Demand", m.demand_n.into()),
            ("Counter", m.counter.into()),
            ("Mode", f64::from(m.flags.mode as u8)),
            ("FaultLatched", b(m.flags.fault_latched)),
            ("AmplitudeLimited", b(m.flags.amplitude_limited)),
            ("RateLimited", b(m.flags.rate_limited)),
        ],
        Message::Status(s) => vec![
            ("Mode", f64::from(s.mode as u8)),
            ("CalibrationSource", s.calibration_source.into()),
            ("FaultCauses", s.fault_causes.into()),
            ("MissedSamples", s.missed_samples.into()),
            ("LateSamples", s.late_samples.into()),
            ("MalformedFrames", s.malformed_frames.into()),
        ],
        Message::Command(c) => vec![
            ("Command", f64::from(c.command as u8)),
            ("Index", c.index.into()),
            ("Value", c.value.into()),
        ],
        Message::CommandAck(a) => vec![
            ("Command", a.command.into()),
            ("Index", a.index.into()),
            ("Result", a.result.into()),
            ("Mode", f64::from(a.mode as u8)),
        ],
    };
    v.into_iter().collect()
}

/// The physical factor the layout uses for a physical signal.
fn factor(kind: MessageKind, name: &str) -> f32 {
    let s = L.scales();
    match (kind, name) {
        (MessageKind::Measurement, "Position") => s.position_m,
        (MessageKind::Measurement, "Road") => s.road_m,
        (MessageKind::MeasurementAux, "Force") => s.force_n,
        (MessageKind::MeasurementAux, "Speed") => s.speed_m_s,
        (MessageKind::Demand, "Demand") => s.demand_n,
        _ => panic!("{kind:?}.{name} is not physical"),
    }
}

/// Half a count plus f32 rounding, with room for cantools' decimal factor (f64) vs our f32.
fn bound(factor: f32, x: f64) -> f64 {
    0.5 * f64::from(factor) * (1.0 + 1e-6) + x.abs() * 2.0_f64.powi(-22)
}

fn num(v: &Value) -> f64 {
    match v {
        Value::Number(n) => n.as_f64().unwrap(),
        Value::String(s) => s.parse().unwrap(),
        other => panic!("not a number: {other}"),
    }
}

/// Messages to exchange: every kind and channel, edges and pseudo-random values.
fn messages() -> Vec<Message> {
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let mut out = Vec::new();
    for ch in 0..dbc::CHANNELS {
        for (p, r) in [(1.0, -1.0), (0.0, 1e-6), (-0.5, 0.25)] {
            out.push(Message::Measurement(Measurement {
                channel: ch,
                position_m: p,
                road_m: r,
                counter: rng.byte(),
            }));
        }
        for _ in 0..4 {
            let (p, r) = (rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0));
            out.push(Message::Measurement(Measurement {
                channel: ch,
                position_m: p,
                road_m: r,
                counter: rng.byte(),
            }));
            let (f, s) = (rng.uniform(-4e5, 4e5), rng.uniform(0.0, 150.0));
            out.push(Message::MeasurementAux(MeasurementAux {
                channel: ch,
                force_n: f,
                speed_m_s: s,
            }));
            let d = rng.uniform(-2e4, 2e4);
            let bits = rng.byte();
            let flags = DemandFlags {
                mode: Mode::ALL[usize::from(bits % 3)],
                fault_latched: bits & 0x08 != 0,
                amplitude_limited: bits & 0x10 != 0,
                rate_limited: bits & 0x20 != 0,
            };
            out.push(Message::Demand(Demand {
                channel: ch,
                demand_n: d,
                counter: rng.byte(),
                flags,
            }));
        }
        for (f, s) in [(4e5, 150.0), (-4e5, 0.0)] {
            out.push(Message::MeasurementAux(MeasurementAux {
                channel: ch,
                force_n: f,
                speed_m_s: s,
            }));
        }
        for d in [4e5, -4e5, 0.0] {
            let flags = DemandFlags {
                mode: Mode::Running,
                ..DemandFlags::default()
            };
            out.push(Message::Demand(Demand {
                channel: ch,
                demand_n: d,
                counter: 255,
                flags,
            }));
        }
    }
    for mode in Mode::ALL {
        out.push(Message::Status(Status::saturating(
            mode,
            rng.byte(),
            70_000,
            u32::from(rng.byte()),
            12_345,
        )));
    }
    for command in CommandKind::ALL {
        for value in [0.0, -0.0, 1.5e-40, 3.4e38, -1.25, rng.uniform(-1e3, 1e3)] {
            // 16 bits: the high byte too (every slot of the board's page).
            let index = if command.takes_index() {
                u16::from_le_bytes([rng.byte(), rng.byte()])
            } else {
                0
            };
            out.push(Message::Command(Command {
                command,
                index,
                value,
            }));
        }
    }
    for mode in Mode::ALL {
        out.push(Message::CommandAck(CommandAck {
            command: rng.byte(),
            index: rng.byte(),
            result: rng.byte(),
            mode,
        }));
    }
    out
}

/// Runs the peer on a request; `tag` keeps concurrent tests' files apart.
fn run_peer(tag: &str, request: &Value) -> Value {
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR"));
    let path = dir.join(format!("cantools-{tag}-{}.json", std::process::id()));
    std::fs::write(&path, serde_json::to_vec(request).unwrap()).unwrap();
    let out = Process::new(common::python())
        .arg(common::peer_script("cantools_peer.py"))
        .arg(concat!(env!("CARGO_MANIFEST_DIR"), "/mil.dbc"))
        .arg(&path)
        .output()
        .expect("run the cantools peer");
    let _ = std::fs::remove_file(&path);
    assert!(
        out.status.success(),
        "cantools peer failed: {}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("peer JSON")
}

#[test]
fn cantools_decodes_our_frames_and_encodes_frames_we_decode() {
    let inputs = messages();
    let frames: Vec<RawFrame> = inputs.iter().map(|m| encode(&L, m).unwrap()).collect();
    let ours: Vec<Message> = frames.iter().map(|f| decode(&L, f).unwrap()).collect();

    let decode_req: Vec<Value> = frames
        .iter()
        .map(|f| json!({"id": f.id, "data": hex(f.payload())}))
        .collect();
    // Ask cantools to encode the values we decoded (inside the limits by construction).
    let encode_req: Vec<Value> = ours
        .iter()
        .map(|m| {
            let s: BTreeMap<_, _> = signals(m).into_iter().map(|(k, v)| (k, json!(v))).collect();
            json!({"message": dbc_name(m), "signals": s})
        })
        .collect();
    let reply = run_peer(
        "both-ways",
        &json!({"decode": decode_req, "encode": encode_req}),
    );
    println!("peer: cantools {}", reply["cantools"]);

    let decoded = reply["decoded"].as_array().unwrap();
    let encoded = reply["encoded"].as_array().unwrap();
    assert_eq!(decoded.len(), inputs.len());
    assert_eq!(encoded.len(), inputs.len());
    let mut checked = 0;
    for (i, ((input, our), frame)) in inputs.iter().zip(&ours).zip(&frames).enumerate() {
        let kind = input.kind();
        // --- cantools decoding our frame.
        let d = &decoded[i];
        assert!(
            d.get("error").is_none(),
            "cantools could not decode {frame:?}: {}",
            d["error"]
        );
        assert_eq!(d["name"], dbc_name(input), "{frame:?}");
        let want_in = signals(input);
        let want_ours = signals(our);
        let got = d["signals"].as_object().unwrap();
        let raw = d["raw"].as_object().unwrap();
        assert_eq!(got.len(), want_ours.len(), "{}", d["name"]);
        for spec in specs(kind) {
            let name = spec.name;
            let g = num(&got[name]);
            match spec.kind {
                SignalKind::Physical => {
                    let f = factor(kind, name);
                    let mut x = want_in[name];
                    if kind == MessageKind::Demand {
                        let (lo, hi) = L.demand_range_n();
                        x = x.clamp(lo.into(), hi.into());
                    }
                    assert!(
                        (g - x).abs() <= bound(f, x),
                        "{}.{name}: cantools {g}, encoded {x}",
                        d["name"]
                    );
                    // Bit-exact agreement of the layout: cantools' raw value × our f32 factor
                    // is our decoded value.
                    let r = num(&raw[name]);
                    assert_eq!(
                        (r as f32 * f).to_bits(),
                        (want_ours[name] as f32).to_bits(),
                        "{}.{name}",
                        d["name"]
                    );
                }
                SignalKind::Float32 => {
                    assert_eq!((g as f32).to_bits(), (want_in[name] as f32).to_bits())
                }
                _ => assert_eq!(g, want_in[name], "{}.{name}", d["name"]),
            }
            checked += 1;
        }

        // --- our decoding of cantools' frame.
        let e = &encoded[i];
        assert!(
            e.get("error").is_none(),
            "cantools could not encode {}: {}",
            dbc_name(our),
            e["error"]
        );
        let theirs = RawFrame::from_parts(
            e["id"].as_u64().unwrap() as u16,
            &unhex(e["data"].as_str().unwrap()),
        )
        .unwrap();
        let back =
            decode(&L, &theirs).unwrap_or_else(|err| panic!("{theirs:?} from cantools: {err}"));
        assert_eq!(back.kind(), kind);
        assert_eq!(back.channel(), our.channel());
        let got = signals(&back);
        for spec in specs(kind) {
            let name = spec.name;
            if spec.kind == SignalKind::Physical {
                let f = factor(kind, name);
                let x = want_ours[name];
                assert!(
                    (got[name] - x).abs() <= bound(f, x),
                    "{name}: {} vs {x}",
                    got[name]
                );
            } else {
                assert_eq!(got[name].to_bits(), want_ours[name].to_bits(), "{name}");
            }
        }
        // Our own values, encoded by cantools, give our bytes back.
        assert_eq!(theirs, *frame, "cantools' encoding of {our:?}");
    }
    println!(
        "{} frames, {checked} signals compared both ways",
        inputs.len()
    );
    assert!(checked > 500);
}

#[test]
fn malformed_frames_from_cantools_are_refused() {
    let cases = [
        (
            json!({"message": "Command", "signals": {"Command": 4, "Index": 1, "Value": "nan"}, "strict": false}),
            DecodeError::NotFinite,
        ),
        (
            json!({"message": "Command", "signals": {"Command": 4, "Index": 1, "Value": "-inf"}, "strict": false}),
            DecodeError::NotFinite,
        ),
        (
            json!({"message": "Command", "signals": {"Command": 9, "Index": 0, "Value": 0.0}, "strict": false}),
            DecodeError::UnknownCommand,
        ),
        (
            json!({"message": "Command", "signals": {"Command": 1, "Index": 2, "Value": 0.0}}),
            DecodeError::ReservedNotZero,
        ),
        (
            json!({"message": "Measurement_Ch0", "signals": {"Position": -8388608, "Road": 0, "Counter": 0}, "scaling": false, "strict": false}),
            DecodeError::NotAvailable,
        ),
        (
            json!({"message": "Measurement_Ch5", "signals": {"Position": 0.0, "Road": 1.000002, "Counter": 0}, "strict": false}),
            DecodeError::OutOfRange,
        ),
        (
            json!({"message": "MeasurementAux_Ch2", "signals": {"Force": 0, "Speed": 65535}, "scaling": false, "strict": false}),
            DecodeError::NotAvailable,
        ),
        (
            json!({"message": "MeasurementAux_Ch2", "signals": {"Force": 0.0, "Speed": 150.02}, "strict": false}),
            DecodeError::OutOfRange,
        ),
        (
            json!({"message": "Demand_Ch7", "signals": {"Demand": 400000.2, "Counter": 0, "Mode": 1, "FaultLatched": 0, "AmplitudeLimited": 0, "RateLimited": 0}, "strict": false}),
            DecodeError::OutOfRange,
        ),
        (
            json!({"message": "Demand_Ch7", "signals": {"Demand": 0, "Counter": 0, "Mode": 3, "FaultLatched": 0, "AmplitudeLimited": 0, "RateLimited": 0}, "strict": false}),
            DecodeError::InvalidMode,
        ),
        (
            json!({"message": "Status", "signals": {"Mode": 7, "CalibrationSource": 0, "FaultCauses": 0, "MissedSamples": 0, "LateSamples": 0, "MalformedFrames": 0}, "strict": false}),
            DecodeError::InvalidMode,
        ),
        (
            json!({"message": "CommandAck", "signals": {"Command": 1, "Index": 0, "Result": 0, "Mode": 200}, "strict": false}),
            DecodeError::InvalidMode,
        ),
    ];
    let req: Vec<Value> = cases.iter().map(|(r, _)| r.clone()).collect();
    let reply = run_peer("malformed", &json!({"encode": req}));
    let encoded = reply["encoded"].as_array().unwrap();
    assert_eq!(encoded.len(), cases.len());
    for ((req, want), e) in cases.iter().zip(encoded) {
        assert!(
            e.get("error").is_none(),
            "cantools could not encode {req}: {}",
            e["error"]
        );
        let f = RawFrame::from_parts(
            e["id"].as_u64().unwrap() as u16,
            &unhex(e["data"].as_str().unwrap()),
        )
        .unwrap();
        assert_eq!(decode(&L, &f), Err(*want), "{req} → {f:?}");
    }
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

fn unhex(s: &str) -> Vec<u8> {
    (0..s.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap())
        .collect()
}
