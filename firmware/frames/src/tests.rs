//! Unit tests: layout, every malformed kind, known byte vectors, saturation, SLCAN, bus load.

extern crate std;
use std::println;

use crate::bus_load::{self, Schedule};
use crate::dbc;
use crate::slcan::{self, LineBuffer, SlcanFrame, SlcanLine};
use crate::*;
use embedded_can::{ExtendedId, Frame, Id, StandardId};

const L: Layout = Layout::DEFAULT;

fn meas(channel: u8, position_m: f32, road_m: f32, counter: u8) -> Measurement {
    Measurement {
        channel,
        position_m,
        road_m,
        counter,
    }
}

fn demand(demand_n: f32) -> Demand {
    Demand {
        channel: 1,
        demand_n,
        counter: 9,
        flags: DemandFlags::default(),
    }
}

fn raw(id: u16, payload: &[u8]) -> RawFrame {
    RawFrame::from_parts(id, payload).unwrap()
}

/// A Measurement frame of channel 0 with the given raw position and road (24-bit each).
fn meas_raw(position: i32, road: i32) -> RawFrame {
    let p = (position as u32).to_le_bytes();
    let r = (road as u32).to_le_bytes();
    raw(0x100, &[p[0], p[1], p[2], r[0], r[1], r[2], 0])
}

// ---------------------------------------------------------------- layout

#[test]
fn default_layout_equals_the_validated_constructor() {
    assert_eq!(Layout::new(0x100, Scales::DBC), Ok(Layout::DEFAULT));
    assert_eq!(Layout::default(), Layout::DEFAULT);
    assert_eq!(dbc::DEFAULT_BASE_ID, 0x100);
    assert_eq!(L.scales(), Scales::DBC);
}

#[test]
fn base_id_plus_highest_offset_must_fit_11_bits() {
    assert_eq!(dbc::HIGHEST_OFFSET, 0x22);
    assert!(Layout::with_base_id(0x7FF - 0x22).is_ok());
    assert_eq!(
        Layout::with_base_id(0x7FF - 0x21),
        Err(LayoutError::BaseIdTooHigh)
    );
    assert_eq!(
        Layout::with_base_id(0xFFFF),
        Err(LayoutError::BaseIdTooHigh)
    );
}

#[test]
fn factors_must_be_finite_and_positive() {
    for bad in [0.0, -1e-6, f32::NAN, f32::INFINITY] {
        let s = Scales {
            position_m: bad,
            ..Scales::DBC
        };
        assert_eq!(Layout::new(0x100, s), Err(LayoutError::BadFactor), "{bad}");
        let s = Scales {
            demand_n: bad,
            ..Scales::DBC
        };
        assert_eq!(Layout::new(0x100, s), Err(LayoutError::BadFactor), "{bad}");
    }
}

#[test]
fn ids_follow_the_base() {
    let l = Layout::with_base_id(0x300).unwrap();
    assert_eq!(l.id(MessageKind::Measurement, 0), Some(0x300));
    assert_eq!(l.id(MessageKind::Measurement, 7), Some(0x307));
    assert_eq!(l.id(MessageKind::Measurement, 8), None);
    assert_eq!(l.id(MessageKind::MeasurementAux, 2), Some(0x30A));
    assert_eq!(l.id(MessageKind::Demand, 3), Some(0x313));
    assert_eq!(l.id(MessageKind::Status, 5), Some(0x320));
    assert_eq!(l.id(MessageKind::Command, 0), Some(0x321));
    assert_eq!(l.id(MessageKind::CommandAck, 0), Some(0x322));
    assert_eq!(l.id_range(), (0x300, 0x32F));
    assert_eq!(
        Layout::with_base_id(0x7DD).unwrap().id_range(),
        (0x7DD, 0x7FF)
    );
}

#[test]
fn every_id_of_the_range_classifies() {
    let mut known = 0;
    for offset in 0..0x30_u16 {
        let id = 0x100 + offset;
        match L.classify(id) {
            Ok((kind, ch)) => {
                known += 1;
                assert_eq!(L.id(kind, ch), Some(id));
            }
            Err(e) => {
                assert_eq!(e, DecodeError::UnknownId, "{id:#x}");
                assert!((0x18..0x20).contains(&offset) || offset >= 0x23, "{id:#x}");
            }
        }
    }
    assert_eq!(known, 3 * 8 + 3);
    assert_eq!(L.classify(0x0FF), Err(DecodeError::Foreign));
    assert_eq!(L.classify(0x130), Err(DecodeError::Foreign));
    assert_eq!(L.classify(0x800), Err(DecodeError::Foreign));
}

#[test]
fn other_factors_move_the_raw_limits() {
    // 1e-5 m per count: ±1 m is ±100000 counts.
    let l = Layout::new(
        0x100,
        Scales {
            position_m: 1e-5,
            ..Scales::DBC
        },
    )
    .unwrap();
    let (lo, hi) = l.position_range_m();
    assert!(
        (hi - 1.0).abs() < 1e-6 && (lo + 1.0).abs() < 1e-6,
        "{lo} {hi}"
    );
    let f = encode_measurement(&l, &meas(0, 0.5, 0.0, 0)).unwrap();
    let p = i32::from_le_bytes([f.data[0], f.data[1], f.data[2], 0]);
    assert_eq!(p, 50_000);
    assert_eq!(decode(&l, &meas_raw(100_000, 0)).map(|_| ()), Ok(()));
    assert_eq!(
        decode(&l, &meas_raw(100_001, 0)),
        Err(DecodeError::OutOfRange)
    );
    // At 1e-7 m per count, 24 bits reach only ±0.84 m: the range narrows, no error.
    let l = Layout::new(
        0x100,
        Scales {
            position_m: 1e-7,
            ..Scales::DBC
        },
    )
    .unwrap();
    let (_, hi) = l.position_range_m();
    assert!((hi - 0.838_860_7).abs() < 1e-6, "{hi}");
}

#[test]
fn documented_ranges() {
    assert_eq!(L.position_range_m(), (-1.0, 1.0));
    assert_eq!(L.road_range_m(), (-1.0, 1.0));
    assert_eq!(L.speed_range_m_s(), (0.0, 150.0));
    assert_eq!(L.force_range_n(), (-400_000.0, 400_000.0));
    assert_eq!(L.demand_range_n(), (-400_000.0, 400_000.0));
}

// ---------------------------------------------------------------- known vectors

#[test]
fn measurement_bytes_match_cantools() {
    // cantools 45.1: db.encode_message('Measurement_Ch3', {'Position': 0.5, 'Road': -1,
    // 'Counter': 7}).hex() == '20a107c0bdf007'
    let f = encode_measurement(&L, &meas(3, 0.5, -1.0, 7)).unwrap();
    assert_eq!(f.id, 0x103);
    assert_eq!(f.len, 7);
    assert_eq!(f.payload(), &[0x20, 0xa1, 0x07, 0xc0, 0xbd, 0xf0, 0x07]);
    assert_eq!(f.data[7], 0);
    assert_eq!(
        decode(&L, &f),
        Ok(Message::Measurement(meas(3, 0.5, -1.0, 7)))
    );
}

#[test]
fn demand_flags_pack_into_byte_5() {
    let d = Demand {
        channel: 2,
        demand_n: -12.3,
        counter: 0xAB,
        flags: DemandFlags {
            mode: Mode::Fault,
            fault_latched: true,
            amplitude_limited: false,
            rate_limited: true,
        },
    };
    let f = encode_demand(&L, &d).unwrap();
    assert_eq!(f.id, 0x112);
    assert_eq!(f.payload(), &[0x85, 0xFF, 0xFF, 0xFF, 0xAB, 0b0001_0110]);
    let Ok(Message::Demand(back)) = decode(&L, &f) else {
        panic!("{:?}", decode(&L, &f))
    };
    assert_eq!(back.flags, d.flags);
    assert_eq!(back.counter, 0xAB);
    assert!((back.demand_n + 12.3).abs() <= 0.05);
}

#[test]
fn status_and_command_bytes() {
    let s = Status::saturating(Mode::Running, 0b11, 70_000, 2, 0x1234);
    assert_eq!(s.missed_samples, u16::MAX);
    let f = encode_status(&L, &s);
    assert_eq!(f.id, 0x120);
    assert_eq!(f.payload(), &[1, 3, 0xFF, 0xFF, 2, 0, 0x34, 0x12]);
    assert_eq!(decode(&L, &f), Ok(Message::Status(s)));

    let c = Command {
        command: CommandKind::SetParam,
        index: 7,
        value: 1.5,
    };
    let f = encode_command(&L, &c).unwrap();
    assert_eq!(f.id, 0x121);
    assert_eq!(f.payload(), &[4, 7, 0, 0, 0x00, 0x00, 0xC0, 0x3F]);
    assert_eq!(decode(&L, &f), Ok(Message::Command(c)));

    let a = CommandAck::answering(&c, CommandAck::OK, Mode::Idle);
    let f = encode_command_ack(&L, &a);
    assert_eq!((f.id, f.payload()), (0x122, &[4_u8, 7, 0, 0][..]));
    assert_eq!(decode(&L, &f), Ok(Message::CommandAck(a)));
}

// ---------------------------------------------------------------- malformed input

#[test]
fn foreign_and_unknown_ids() {
    assert_eq!(decode(&L, &raw(0x0FF, &[0; 7])), Err(DecodeError::Foreign));
    assert_eq!(decode(&L, &raw(0x130, &[0; 7])), Err(DecodeError::Foreign));
    let bogus = RawFrame {
        id: 0x900,
        len: 7,
        data: [0; 8],
    };
    assert_eq!(decode(&L, &bogus), Err(DecodeError::Foreign));
    assert_eq!(
        decode(&L, &raw(0x118, &[0; 6])),
        Err(DecodeError::UnknownId)
    );
    assert_eq!(
        decode(&L, &raw(0x123, &[0; 8])),
        Err(DecodeError::UnknownId)
    );
}

#[test]
fn extended_and_remote_frames() {
    let ext = SlcanFrame::new(ExtendedId::new(0x100).unwrap(), &[0; 7]).unwrap();
    assert_eq!(decode_frame(&L, &ext), Err(DecodeError::ExtendedId));
    assert!(DecodeError::ExtendedId.is_foreign());
    let rtr = SlcanFrame::new_remote(StandardId::new(0x100).unwrap(), 7).unwrap();
    assert_eq!(decode_frame(&L, &rtr), Err(DecodeError::RemoteFrame));
    assert!(!DecodeError::RemoteFrame.is_foreign());
    let rtr_foreign = SlcanFrame::new_remote(StandardId::new(0x500).unwrap(), 0).unwrap();
    assert_eq!(decode_frame(&L, &rtr_foreign), Err(DecodeError::Foreign));
    assert_eq!(RawFrame::try_from_frame(&ext), Err(DecodeError::ExtendedId));
    assert_eq!(
        RawFrame::try_from_frame(&rtr),
        Err(DecodeError::RemoteFrame)
    );
    let data = SlcanFrame::from(encode_measurement(&L, &meas(1, 0.1, 0.2, 3)).unwrap());
    assert_eq!(
        decode_frame(&L, &data),
        Ok(Message::Measurement(meas(1, 0.1, 0.2, 3)))
    );
}

#[test]
fn wrong_lengths() {
    for kind in MessageKind::ALL {
        let id = L.id(kind, 0).unwrap();
        for len in 0..=8_u8 {
            let f = RawFrame {
                id,
                len,
                data: [0; 8],
            };
            if len != kind.dlc() {
                assert_eq!(
                    decode(&L, &f),
                    Err(DecodeError::WrongLength),
                    "{kind:?} {len}"
                );
            }
        }
        let f = RawFrame {
            id,
            len: 200,
            data: [0; 8],
        };
        assert_eq!(decode(&L, &f), Err(DecodeError::WrongLength));
    }
}

#[test]
fn reserved_bits_must_be_zero() {
    // Demand byte 5 bits 5..7 are reserved.
    let mut f = encode_demand(&L, &demand(1.0)).unwrap();
    f.data[5] |= 0x20;
    assert_eq!(decode(&L, &f), Err(DecodeError::ReservedNotZero));
    // Command bytes 2 and 3.
    let c = Command {
        command: CommandKind::Start,
        index: 0,
        value: 0.0,
    };
    for byte in [2, 3] {
        let mut f = encode_command(&L, &c).unwrap();
        f.data[byte] = 1;
        assert_eq!(decode(&L, &f), Err(DecodeError::ReservedNotZero));
    }
    // An index on a command that takes none.
    let mut f = encode_command(&L, &c).unwrap();
    f.data[1] = 3;
    assert_eq!(decode(&L, &f), Err(DecodeError::ReservedNotZero));
    assert_eq!(
        encode_command(&L, &Command { index: 3, ..c }),
        Err(EncodeError::OutOfRange)
    );
    // Bytes beyond the DLC are not the frame's and are ignored.
    let mut f = encode_demand(&L, &demand(1.0)).unwrap();
    f.data[7] = 0xFF;
    assert!(decode(&L, &f).is_ok());
}

#[test]
fn not_available_values() {
    assert_eq!(
        decode(&L, &meas_raw(-0x80_0000, 0)),
        Err(DecodeError::NotAvailable)
    );
    assert_eq!(
        decode(&L, &meas_raw(0, -0x80_0000)),
        Err(DecodeError::NotAvailable)
    );
    let aux = |force: i32, speed: u16| {
        let f = force.to_le_bytes();
        let s = speed.to_le_bytes();
        raw(0x108, &[f[0], f[1], f[2], f[3], s[0], s[1]])
    };
    assert_eq!(
        decode(&L, &aux(i32::MIN, 0)),
        Err(DecodeError::NotAvailable)
    );
    assert_eq!(decode(&L, &aux(0, 0xFFFF)), Err(DecodeError::NotAvailable));
    assert!(decode(&L, &aux(0, 15_000)).is_ok());
    let mut f = encode_demand(&L, &demand(0.0)).unwrap();
    f.data[..4].copy_from_slice(&i32::MIN.to_le_bytes());
    assert_eq!(decode(&L, &f), Err(DecodeError::NotAvailable));
}

#[test]
fn out_of_range_values() {
    // ±1 m is 1_000_000 counts: inside; one more count: out.
    assert!(decode(&L, &meas_raw(1_000_000, -1_000_000)).is_ok());
    assert_eq!(
        decode(&L, &meas_raw(1_000_001, 0)),
        Err(DecodeError::OutOfRange)
    );
    assert_eq!(
        decode(&L, &meas_raw(0, -1_000_001)),
        Err(DecodeError::OutOfRange)
    );
    assert_eq!(
        decode(&L, &meas_raw(0x7F_FFFF, 0)),
        Err(DecodeError::OutOfRange)
    );
    let f = raw(0x108, &[0, 0, 0, 0, 0x99, 0x3A]); // 15001 → 150.01 m/s
    assert_eq!(decode(&L, &f), Err(DecodeError::OutOfRange));
    let f = raw(0x108, &[0x01, 0x09, 0x3D, 0x00, 0, 0]); // 4_000_001 → 400000.1 N
    assert_eq!(decode(&L, &f), Err(DecodeError::OutOfRange));
    // Encoders refuse what would not decode.
    assert_eq!(
        encode_measurement(&L, &meas(0, 1.000_001, 0.0, 0)),
        Err(EncodeError::OutOfRange)
    );
    assert!(encode_measurement(&L, &meas(0, 1.0, -1.0, 0)).is_ok());
    let aux = MeasurementAux {
        channel: 0,
        force_n: 0.0,
        speed_m_s: -0.01,
    };
    assert_eq!(
        encode_measurement_aux(&L, &aux),
        Err(EncodeError::OutOfRange)
    );
}

#[test]
fn invalid_modes() {
    let mut f = encode_demand(&L, &demand(0.0)).unwrap();
    f.data[5] |= 0b11;
    assert_eq!(decode(&L, &f), Err(DecodeError::InvalidMode));
    let mut f = encode_status(&L, &Status::default());
    f.data[0] = 3;
    assert_eq!(decode(&L, &f), Err(DecodeError::InvalidMode));
    let mut f = encode_command_ack(
        &L,
        &CommandAck {
            command: 1,
            index: 0,
            result: 0,
            mode: Mode::Idle,
        },
    );
    f.data[3] = 0xFF;
    assert_eq!(decode(&L, &f), Err(DecodeError::InvalidMode));
}

#[test]
fn unknown_commands_and_non_finite_values() {
    for c in [0_u8, 6, 0xFF] {
        let f = raw(0x121, &[c, 0, 0, 0, 0, 0, 0, 0]);
        assert_eq!(decode(&L, &f), Err(DecodeError::UnknownCommand), "{c}");
    }
    for v in [
        f32::NAN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::from_bits(0x7FC0_0001),
    ] {
        let b = v.to_bits().to_le_bytes();
        let f = raw(0x121, &[4, 1, 0, 0, b[0], b[1], b[2], b[3]]);
        assert_eq!(decode(&L, &f), Err(DecodeError::NotFinite));
        let c = Command {
            command: CommandKind::SetParam,
            index: 1,
            value: v,
        };
        assert_eq!(encode_command(&L, &c), Err(EncodeError::NotFinite));
    }
    // The board's answer to a command that did not decode echoes the raw bytes.
    let f = raw(0x121, &[9, 4, 0, 0, 0, 0, 0, 0]);
    let err = decode(&L, &f).unwrap_err();
    let ack = CommandAck::rejecting(&f, err, Mode::Running);
    assert_eq!((ack.command, ack.index, ack.result), (9, 4, 10));
    assert_eq!(
        decode(&L, &encode_command_ack(&L, &ack)),
        Ok(Message::CommandAck(ack))
    );
}

#[test]
fn bad_channels_are_refused() {
    assert_eq!(
        encode_measurement(&L, &meas(8, 0.0, 0.0, 0)),
        Err(EncodeError::BadChannel)
    );
    let d = Demand {
        channel: 200,
        ..demand(0.0)
    };
    assert_eq!(encode_demand(&L, &d), Err(EncodeError::BadChannel));
}

// ---------------------------------------------------------------- demand saturation

#[test]
fn demand_saturates_and_refuses_non_finite() {
    let raw_of = |f: &RawFrame| i32::from_le_bytes([f.data[0], f.data[1], f.data[2], f.data[3]]);
    for (v, want) in [
        (1e9_f32, 4_000_000),
        (-1e9, -4_000_000),
        (f32::MAX, 4_000_000),
        (f32::MIN, -4_000_000),
        (400_000.04, 4_000_000),
        (0.04, 0),
        (0.05, 1),
        (-0.05, -1),
        (123.44, 1234),
    ] {
        let f = encode_demand(&L, &demand(v)).unwrap();
        assert_eq!(raw_of(&f), want, "{v}");
        assert!(decode(&L, &f).is_ok(), "{v}");
    }
    for v in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        assert_eq!(encode_demand(&L, &demand(v)), Err(EncodeError::NotFinite));
    }
}

// ---------------------------------------------------------------- codes

#[test]
fn error_codes_are_stable_and_unique() {
    let mut codes = std::vec::Vec::new();
    codes.extend(DecodeError::ALL.iter().map(|e| e.code()));
    codes.extend(EncodeError::ALL.iter().map(|e| e.code()));
    codes.extend(LayoutError::ALL.iter().map(|e| e.code()));
    codes.extend(SlcanError::ALL.iter().map(|e| e.code()));
    assert_eq!(
        codes,
        [
            1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 32, 33, 34, 48, 49, 64, 65, 66, 67, 68, 69, 70, 71,
            72, 73
        ]
    );
    for e in DecodeError::ALL {
        assert_eq!(DecodeError::from_code(e.code()), Some(e));
    }
    assert_eq!(DecodeError::from_code(0), None);
    assert!(codes.iter().all(|c| *c != 0 && *c < 128));
}

#[test]
fn modes_match_model_core() {
    use model_core::Mode as M;
    assert_eq!(Mode::Idle as u8, M::Idle as u8);
    assert_eq!(Mode::Running as u8, M::Running as u8);
    assert_eq!(Mode::Fault as u8, M::Fault as u8);
}

// ---------------------------------------------------------------- SLCAN

fn parse(s: &str) -> Result<SlcanLine, SlcanError> {
    slcan::parse_line(s.as_bytes())
}

fn std_frame(id: u16, data: &[u8]) -> SlcanFrame {
    SlcanFrame::new(StandardId::new(id).unwrap(), data).unwrap()
}

#[test]
fn slcan_parses_frames() {
    assert_eq!(
        parse("t103720A107C0BDF007"),
        Ok(SlcanLine::Frame(std_frame(
            0x103,
            &[0x20, 0xA1, 0x07, 0xC0, 0xBD, 0xF0, 0x07]
        )))
    );
    assert_eq!(parse("t7FF0"), Ok(SlcanLine::Frame(std_frame(0x7FF, &[]))));
    assert_eq!(
        parse("t1002abCD"),
        Ok(SlcanLine::Frame(std_frame(0x100, &[0xAB, 0xCD])))
    );
    let Ok(SlcanLine::Frame(ext)) = parse("T1FFFFFFF81122334455667788") else {
        panic!()
    };
    assert_eq!(ext.id(), Id::Extended(ExtendedId::MAX));
    assert_eq!(
        ext.data(),
        &[0x11, 0x22, 0x33, 0x44, 0x55, 0x66, 0x77, 0x88]
    );
    let Ok(SlcanLine::Frame(rtr)) = parse("r1204") else {
        panic!()
    };
    assert!(rtr.is_remote_frame());
    assert_eq!((rtr.dlc(), rtr.data().len()), (4, 0));
    let Ok(SlcanLine::Frame(rtr)) = parse("R000001008") else {
        panic!()
    };
    assert!(rtr.is_remote_frame() && rtr.is_extended());
}

#[test]
fn slcan_parses_commands() {
    assert_eq!(parse(""), Ok(SlcanLine::Empty));
    assert_eq!(parse("O"), Ok(SlcanLine::Open));
    assert_eq!(parse("L"), Ok(SlcanLine::ListenOnly));
    assert_eq!(parse("C"), Ok(SlcanLine::Close));
    assert_eq!(parse("V"), Ok(SlcanLine::Version));
    assert_eq!(parse("v"), Ok(SlcanLine::FirmwareVersion));
    assert_eq!(parse("N"), Ok(SlcanLine::SerialNumber));
    assert_eq!(parse("F"), Ok(SlcanLine::StatusFlags));
    assert_eq!(parse("Z0"), Ok(SlcanLine::Timestamps(false)));
    assert_eq!(parse("Z1"), Ok(SlcanLine::Timestamps(true)));
    assert_eq!(
        parse("S8"),
        Ok(SlcanLine::SetBitrate {
            code: 8,
            bit_per_s: 1_000_000
        })
    );
    assert_eq!(
        parse("S0"),
        Ok(SlcanLine::SetBitrate {
            code: 0,
            bit_per_s: 10_000
        })
    );
    assert_eq!(
        parse("s031C"),
        Ok(SlcanLine::SetBtr {
            btr0: 0x03,
            btr1: 0x1C
        })
    );
}

#[test]
fn slcan_errors() {
    for (line, err) in [
        ("t10", SlcanError::Truncated),
        ("t100", SlcanError::Truncated),
        ("T1234567", SlcanError::Truncated),
        ("t1G01", SlcanError::BadHex),
        ("t1001GG", SlcanError::BadHex),
        ("t8000", SlcanError::BadId),
        ("T200000000", SlcanError::BadId),
        ("t1009", SlcanError::BadDlc),
        ("t100X", SlcanError::BadDlc),
        ("t1002AB", SlcanError::DlcMismatch),
        ("t1001ABCD", SlcanError::DlcMismatch),
        ("r1001AB", SlcanError::DlcMismatch),
        ("O1", SlcanError::TrailingData),
        ("S88", SlcanError::TrailingData),
        ("S", SlcanError::Truncated),
        ("SA", SlcanError::BadDlc),
        ("Z2", SlcanError::BadDlc),
        ("s03", SlcanError::Truncated),
        ("s031C0", SlcanError::TrailingData),
        ("d1001AB", SlcanError::Unsupported),
        ("Y2", SlcanError::Unsupported),
        ("?", SlcanError::UnknownCommand),
        ("\x07", SlcanError::UnknownCommand),
        ("T1FFFFFFF81122334455667788990", SlcanError::Overflow),
    ] {
        assert_eq!(parse(line), Err(err), "{line:?}");
    }
}

#[test]
fn slcan_formats_frames_and_replies() {
    let mut buf = [0_u8; slcan::MAX_LINE + 1];
    let f = encode_measurement(&L, &meas(3, 0.5, -1.0, 7)).unwrap();
    let n = slcan::format_frame(&f, &mut buf).unwrap();
    assert_eq!(&buf[..n], b"t103720A107C0BDF007\r");
    // Round trip through the parser.
    let Ok(SlcanLine::Frame(back)) = slcan::parse_line(&buf[..n - 1]) else {
        panic!()
    };
    assert_eq!(RawFrame::try_from_frame(&back), Ok(f));

    let ext = SlcanFrame::new(ExtendedId::MAX, &[1; 8]).unwrap();
    let n = slcan::format_frame(&ext, &mut buf).unwrap();
    assert_eq!(n, slcan::MAX_LINE + 1);
    assert_eq!(&buf[..n], b"T1FFFFFFF80101010101010101\r");
    let rtr = SlcanFrame::new_remote(StandardId::new(0x12).unwrap(), 3).unwrap();
    let n = slcan::format_frame(&rtr, &mut buf).unwrap();
    assert_eq!(&buf[..n], b"r0123\r");

    let mut small = [0_u8; 19];
    assert_eq!(
        slcan::format_frame(&f, &mut small),
        Err(SlcanError::BufferTooSmall)
    );
    let n = slcan::format_version(10, 3, &mut buf).unwrap();
    assert_eq!(&buf[..n], b"V1003\r");
    let n = slcan::format_serial_number(0xA1B2, &mut buf).unwrap();
    assert_eq!(&buf[..n], b"NA1B2\r");
    let n = slcan::format_status_flags(slcan::status_flag::BUS_ERROR | 1, &mut buf).unwrap();
    assert_eq!(&buf[..n], b"F81\r");
    assert_eq!(
        slcan::format_version(1, 2, &mut small[..5]),
        Err(SlcanError::BufferTooSmall)
    );
}

#[test]
fn line_buffer_assembles_and_resyncs() {
    let mut lb = LineBuffer::<8>::new();
    let mut lines = std::vec::Vec::new();
    let mut errors = 0;
    for b in b"O\r\nt1000\rTOOLONGLINE\rC\r\r".iter() {
        match lb.push(*b) {
            Ok(Some(line)) => lines.push(std::string::String::from_utf8(line.to_vec()).unwrap()),
            Ok(None) => {}
            Err(e) => {
                assert_eq!(e, SlcanError::Overflow);
                errors += 1;
            }
        }
    }
    assert_eq!(lines, ["O", "t1000", "C", ""]);
    assert_eq!(errors, 1);
    assert!(lb.is_empty());
    lb.push(b'x').unwrap();
    assert_eq!(lb.len(), 1);
    lb.clear();
    assert!(lb.is_empty());
}

// ---------------------------------------------------------------- bus load

#[test]
fn frame_lengths() {
    // 47 + 8n, plus floor((34 + 8n - 1) / 4) stuff bits in the worst case.
    let table = [
        (0, 47, 8),
        (4, 79, 16),
        (6, 95, 20),
        (7, 103, 22),
        (8, 111, 24),
    ];
    for (dlc, bits, stuff) in table {
        assert_eq!(bus_load::frame_bits(dlc), bits);
        assert_eq!(bus_load::stuff_bits_worst(dlc), stuff);
        assert_eq!(bus_load::frame_bits_worst(dlc), bits + stuff);
    }
    assert_eq!(bus_load::frame_bits_worst(8), 135);
    let pair = [
        bus_load::FrameRate { dlc: 7, per_s: 1.0 },
        bus_load::FrameRate { dlc: 6, per_s: 1.0 },
    ];
    assert_eq!(bus_load::bus_load(&pair, 240.0, true), 1.0);
    assert_eq!(bus_load::bus_load(&pair, 198.0, false), 1.0);
}

#[test]
fn bus_load_budget() {
    const BIT_PER_S: f64 = 1e6;
    // Worst-case bits: Measurement (7 B) 125 + Demand (6 B) 115 per channel and sample;
    // MeasurementAux (6 B) 115; Status (8 B) 135 at 10 Hz; XCP headroom 50 kbit/s.
    let fixed = 135.0 * 10.0 + 50e3;
    let one = Schedule::tyre(1, 2000.0);
    let load = one.load(BIT_PER_S);
    println!(
        "tyre x1 at 2 kHz on 1 Mbit/s: {:.1} % worst case ({:.1} % without stuffing)",
        100.0 * load,
        100.0 * one.load_nominal(BIT_PER_S)
    );
    assert!(
        (load - (240.0 * 2000.0 + fixed) / BIT_PER_S).abs() < 1e-12,
        "{load}"
    );
    assert_eq!(one.check(BIT_PER_S), Ok(()));
    let nominal = (198.0 * 2000.0 + 111.0 * 10.0 + 50e3) / BIT_PER_S;
    assert!((one.load_nominal(BIT_PER_S) - nominal).abs() < 1e-12);

    // Tyre x4 at 1 kHz: beyond the budget on one bus, within it on two.
    let four = Schedule::tyre(4, 1000.0);
    let over = four.check(BIT_PER_S).expect_err("one bus is too little");
    println!(
        "tyre x4 at 1 kHz: one bus {:.1} % (at most {:.0} Hz), two buses {:.1} %",
        100.0 * over.load,
        over.max_sample_rate_hz,
        100.0 * four.on_buses(2).load(BIT_PER_S)
    );
    assert!((over.load - (960.0 * 1000.0 + fixed) / BIT_PER_S).abs() < 1e-12);
    assert_eq!(four.on_buses(2).channels_on_busiest(), 2);
    assert_eq!(four.on_buses(2).check(BIT_PER_S), Ok(()));
    // Aero x2 at 1 kHz, speed at 100 Hz.
    let aero = Schedule::aero(1000.0);
    assert!(
        (aero.load(BIT_PER_S) - (480.0 * 1000.0 + 115.0 * 100.0 + fixed) / BIT_PER_S).abs() < 1e-12
    );
    assert_eq!(aero.check(BIT_PER_S), Ok(()));

    let room = 0.6 * BIT_PER_S - fixed;
    for (name, s, want) in [
        ("tyre x1", Schedule::tyre(1, 0.0), room / 240.0),
        ("tyre x2", Schedule::tyre(2, 0.0), room / 480.0),
        ("tyre x4, one bus", Schedule::tyre(4, 0.0), room / 960.0),
        (
            "tyre x4, two buses",
            Schedule::tyre(4, 0.0).on_buses(2),
            room / 480.0,
        ),
        ("aero x2", Schedule::aero(0.0), (room - 11_500.0) / 480.0),
        (
            "substructure x2, forces measured",
            Schedule::substructure(2, true, 0.0),
            room / (2.0 * 355.0),
        ),
        (
            "substructure x3, forces measured, two buses",
            Schedule::substructure(3, true, 0.0).on_buses(2),
            room / (2.0 * 355.0),
        ),
    ] {
        let max = s.max_sample_rate_hz(BIT_PER_S, bus_load::BUDGET);
        println!("{name}: highest sample rate within 60 % of 1 Mbit/s: {max:.0} Hz");
        assert!((max - want).abs() < 1e-6, "{name} {max} != {want}");
        let at = Schedule {
            sample_rate_hz: max,
            ..s
        };
        assert!((at.load(BIT_PER_S) - bus_load::BUDGET).abs() < 1e-12);
        assert_eq!(at.check(BIT_PER_S), Ok(()));
        let beyond = Schedule {
            sample_rate_hz: max + 1.0,
            ..s
        };
        assert!(beyond.check(BIT_PER_S).is_err(), "{name}");
    }
}
