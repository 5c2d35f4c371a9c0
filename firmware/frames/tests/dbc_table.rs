//! Parses mil.dbc at test time with `can-dbc` and checks the table `build.rs` generated from
//! it, the IDs the codec computes, and the DBC's value tables against the codec's enums.

use can_dbc::{ByteOrder, Dbc, MessageId, NumericValue, SignalExtendedValueType, ValueType};
use mil_frames::dbc::{self, MessageSpec, SignalKind, SignalSpec};
use mil_frames::{CommandKind, DecodeError, Layout, MessageKind, Mode};

fn load() -> Dbc {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/mil.dbc");
    let text = std::fs::read_to_string(path).unwrap();
    assert_eq!(text, dbc::DBC_TEXT, "DBC_TEXT is the file");
    Dbc::try_from(text.as_str()).unwrap()
}

fn num(v: NumericValue) -> f64 {
    match v {
        NumericValue::Uint(u) => u as f64,
        NumericValue::Int(i) => i as f64,
        NumericValue::Double(d) => d,
    }
}

fn tables() -> [(MessageKind, MessageSpec, &'static [SignalSpec]); 6] {
    [
        (
            MessageKind::Measurement,
            dbc::measurement::MESSAGE,
            &dbc::measurement::SIGNALS,
        ),
        (
            MessageKind::MeasurementAux,
            dbc::measurement_aux::MESSAGE,
            &dbc::measurement_aux::SIGNALS,
        ),
        (
            MessageKind::Demand,
            dbc::demand::MESSAGE,
            &dbc::demand::SIGNALS,
        ),
        (
            MessageKind::Status,
            dbc::status::MESSAGE,
            &dbc::status::SIGNALS,
        ),
        (
            MessageKind::Command,
            dbc::command::MESSAGE,
            &dbc::command::SIGNALS,
        ),
        (
            MessageKind::CommandAck,
            dbc::command_ack::MESSAGE,
            &dbc::command_ack::SIGNALS,
        ),
    ]
}

#[test]
fn generated_table_matches_the_dbc() {
    let db = load();
    let l = Layout::DEFAULT;
    let mut seen = 0;
    for (kind, msg, signals) in tables() {
        assert_eq!(kind.spec(), msg);
        let channels = if msg.per_channel { dbc::CHANNELS } else { 1 };
        for ch in 0..channels {
            let name = if msg.per_channel {
                format!("{}_Ch{ch}", msg.name)
            } else {
                msg.name.to_string()
            };
            let m = db
                .messages
                .iter()
                .find(|m| m.name == name)
                .unwrap_or_else(|| panic!("{name}"));
            seen += 1;
            let id = l.id(kind, ch).unwrap();
            assert_eq!(m.id, MessageId::Standard(id), "{name}");
            assert_eq!(id, dbc::DEFAULT_BASE_ID + msg.id_offset + u16::from(ch));
            assert_eq!(m.size, u64::from(msg.dlc), "{name}");
            assert_eq!(m.signals.len(), signals.len(), "{name}");
            let mut used = 0_u64;
            for s in signals {
                let d = m
                    .signals
                    .iter()
                    .find(|d| d.name == s.name)
                    .unwrap_or_else(|| panic!("{name}.{}", s.name));
                assert_eq!(d.start_bit, u64::from(s.start_bit), "{name}.{}", s.name);
                assert_eq!(d.size, u64::from(s.len), "{name}.{}", s.name);
                assert_eq!(d.byte_order, ByteOrder::LittleEndian);
                assert_eq!(
                    d.value_type == ValueType::Signed,
                    s.signed,
                    "{name}.{}",
                    s.name
                );
                assert_eq!(d.factor, s.factor, "{name}.{}", s.name);
                assert_eq!(d.offset, s.offset, "{name}.{}", s.name);
                assert_eq!(num(d.min), s.min, "{name}.{}", s.name);
                assert_eq!(num(d.max), s.max, "{name}.{}", s.name);
                assert_eq!(d.unit, s.unit);
                let float = db.extended_value_type_for_signal(m.id, s.name)
                    == Some(&SignalExtendedValueType::IEEEfloat32Bit);
                assert_eq!(float, s.kind == SignalKind::Float32, "{name}.{}", s.name);
                used |= (((1_u128 << s.len) - 1) as u64) << s.start_bit;
            }
            assert_eq!(used, msg.used_bits, "{name}");
        }
    }
    assert_eq!(seen, db.messages.len(), "every DBC message is in the table");
    assert_eq!(seen, 3 * 8 + 3);
}

#[test]
fn physical_limits_at_the_dbc_factors() {
    use dbc::{demand, measurement as m, measurement_aux as aux};
    assert_eq!(
        (m::POSITION.raw_min, m::POSITION.raw_max),
        (-1_000_000, 1_000_000)
    );
    assert_eq!((m::ROAD.raw_min, m::ROAD.raw_max), (-1_000_000, 1_000_000));
    assert_eq!(
        (aux::FORCE.raw_min, aux::FORCE.raw_max),
        (-4_000_000, 4_000_000)
    );
    assert_eq!((aux::SPEED.raw_min, aux::SPEED.raw_max), (0, 15_000));
    assert_eq!(
        (demand::DEMAND.raw_min, demand::DEMAND.raw_max),
        (-4_000_000, 4_000_000)
    );
    // Every valid raw value is exact in f32 with room for the encode division (2^22).
    for s in [m::POSITION, m::ROAD, aux::FORCE, aux::SPEED, demand::DEMAND] {
        assert!(s.raw_max < 1 << 22 && s.raw_min > -(1 << 22), "{}", s.name);
    }
}

#[test]
fn value_tables_match_the_codec() {
    let db = load();
    let table = |id: u16, sig: &str| -> Vec<(i64, String)> {
        db.value_descriptions_for_signal(MessageId::Standard(id), sig)
            .unwrap_or_else(|| panic!("VAL_ {id:#x} {sig}"))
            .iter()
            .map(|v| (v.id, v.description.clone()))
            .collect()
    };
    let modes: Vec<_> = Mode::ALL
        .iter()
        .map(|m| (*m as i64, m.name().to_string()))
        .collect();
    let commands: Vec<_> = CommandKind::ALL
        .iter()
        .map(|c| (*c as i64, c.name().to_string()))
        .collect();
    let mut results = vec![(0_i64, "Ok".to_string())];
    results.extend(
        DecodeError::ALL
            .iter()
            .map(|e| (i64::from(e.code()), e.name().to_string())),
    );

    let l = Layout::DEFAULT;
    for ch in 0..dbc::CHANNELS {
        assert_eq!(table(l.id(MessageKind::Demand, ch).unwrap(), "Mode"), modes);
    }
    assert_eq!(table(0x120, "Mode"), modes);
    assert_eq!(table(0x121, "Command"), commands);
    assert_eq!(table(0x122, "Command"), commands);
    assert_eq!(table(0x122, "Mode"), modes);
    assert_eq!(table(0x122, "Result"), results);
}

#[test]
fn nodes_and_senders() {
    let db = load();
    let nodes: Vec<_> = db.nodes.iter().map(|n| n.0.clone()).collect();
    assert_eq!(nodes, ["SERVO", "MIL_BOARD", "TOOL"]);
    for m in &db.messages {
        let want = match m.name.split('_').next().unwrap() {
            "Measurement" | "MeasurementAux" => "SERVO",
            "Command" => "TOOL",
            _ => "MIL_BOARD",
        };
        assert_eq!(m.transmitter.as_deref(), Some(want), "{}", m.name);
    }
}
