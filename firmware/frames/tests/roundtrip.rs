//! Property tests: round trips within half a count, decode → encode reproduces the bytes,
//! no input makes the decoder or the SLCAN parser panic.

use mil_frames::slcan::{self, LineBuffer, SlcanLine};
use mil_frames::*;
use proptest::prelude::*;

/// The documented accuracy: half a count plus the f32 rounding of two operations.
fn bound(factor: f32, x: f32) -> f64 {
    let eps = f64::from(f32::EPSILON); // 2^-23
    0.5 * f64::from(factor) * (1.0 + eps) + eps * f64::from(x).abs()
}

fn close(got: f32, want: f32, factor: f32) -> Result<(), TestCaseError> {
    let err = (f64::from(got) - f64::from(want)).abs();
    prop_assert!(
        err <= bound(factor, want),
        "got {got}, want {want}: error {err} > {}",
        bound(factor, want)
    );
    Ok(())
}

fn mode() -> impl Strategy<Value = Mode> {
    prop::sample::select(Mode::ALL.to_vec())
}

fn kind() -> impl Strategy<Value = CommandKind> {
    prop::sample::select(CommandKind::ALL.to_vec())
}

/// Frames biased towards the MiL range and the right lengths.
fn any_frame() -> impl Strategy<Value = RawFrame> {
    let id = prop_oneof![0x100_u16..0x130, 0_u16..0x800, 0x800_u16..=u16::MAX];
    let len = prop_oneof![4_u8..=8, 0_u8..=8, any::<u8>()];
    let data = prop_oneof![
        any::<[u8; 8]>(),
        // Mostly-valid payloads: small magnitudes, top bytes clear.
        (any::<[u8; 8]>()).prop_map(|mut d| {
            d[2] &= 0x07;
            d[5] &= 0x07;
            d
        }),
    ];
    (id, len, data).prop_map(|(id, len, data)| RawFrame { id, len, data })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(4000))]

    #[test]
    fn measurement_round_trip(ch in 0_u8..8, p in -1.0_f32..=1.0, r in -1.0_f32..=1.0, c in any::<u8>()) {
        let l = Layout::DEFAULT;
        let m = Measurement { channel: ch, position_m: p, road_m: r, counter: c };
        let f = encode_measurement(&l, &m).unwrap();
        let Ok(Message::Measurement(back)) = decode(&l, &f) else { panic!("{:?}", decode(&l, &f)) };
        prop_assert_eq!((back.channel, back.counter), (ch, c));
        close(back.position_m, p, l.scales().position_m)?;
        close(back.road_m, r, l.scales().road_m)?;
    }

    #[test]
    fn measurement_aux_round_trip(ch in 0_u8..8, force in -4e5_f32..=4e5, speed in 0.0_f32..=150.0) {
        let l = Layout::DEFAULT;
        let m = MeasurementAux { channel: ch, force_n: force, speed_m_s: speed };
        let f = encode_measurement_aux(&l, &m).unwrap();
        let Ok(Message::MeasurementAux(back)) = decode(&l, &f) else { panic!() };
        prop_assert_eq!(back.channel, ch);
        close(back.force_n, force, l.scales().force_n)?;
        close(back.speed_m_s, speed, l.scales().speed_m_s)?;
    }

    #[test]
    fn demand_round_trip_or_saturation(
        ch in 0_u8..8,
        d in prop_oneof![-4e5_f32..=4e5, any::<f32>()],
        counter in any::<u8>(),
        mode in mode(),
        bits in any::<[bool; 3]>(),
    ) {
        let l = Layout::DEFAULT;
        let flags = DemandFlags { mode, fault_latched: bits[0], amplitude_limited: bits[1], rate_limited: bits[2] };
        let m = Demand { channel: ch, demand_n: d, counter, flags };
        let f = encode_demand(&l, &m);
        if !d.is_finite() {
            prop_assert_eq!(f, Err(EncodeError::NotFinite));
            return Ok(());
        }
        let f = f.unwrap();
        let Ok(Message::Demand(back)) = decode(&l, &f) else { panic!("{:?}", decode(&l, &f)) };
        prop_assert_eq!((back.channel, back.counter, back.flags), (ch, counter, flags));
        let (lo, hi) = l.demand_range_n();
        close(back.demand_n, d.clamp(lo, hi), l.scales().demand_n)?;
    }

    #[test]
    fn status_round_trip(mode in mode(), source in 0u8..16, faults in any::<u8>(), counts in any::<[u16; 3]>()) {
        let l = Layout::DEFAULT;
        let s = Status { mode, calibration_source: source, fault_causes: faults, missed_samples: counts[0], late_samples: counts[1], malformed_frames: counts[2] };
        prop_assert_eq!(decode(&l, &encode_status(&l, &s)), Ok(Message::Status(s)));
    }

    #[test]
    fn command_round_trip(command in kind(), index in any::<u16>(), value in any::<f32>()) {
        let l = Layout::DEFAULT;
        let index = if command.takes_index() { index } else { 0 };
        let c = Command { command, index, value };
        match encode_command(&l, &c) {
            Ok(f) => {
                prop_assert!(value.is_finite());
                let Ok(Message::Command(back)) = decode(&l, &f) else { panic!() };
                prop_assert_eq!(back.value.to_bits(), value.to_bits());
                prop_assert_eq!((back.command, back.index), (command, index));
            }
            Err(e) => {
                prop_assert!(!value.is_finite());
                prop_assert_eq!(e, EncodeError::NotFinite);
            }
        }
    }

    #[test]
    fn command_ack_round_trip(command in any::<u8>(), index in any::<u8>(), result in any::<u8>(), mode in mode()) {
        let l = Layout::DEFAULT;
        let a = CommandAck { command, index, result, mode };
        prop_assert_eq!(decode(&l, &encode_command_ack(&l, &a)), Ok(Message::CommandAck(a)));
    }

    /// Other base IDs and factors: still within half a count of the layout's factor.
    #[test]
    fn other_layouts_round_trip(
        base in 0_u16..=0x7DD,
        pf in 1e-7_f32..1e-4,
        ff in 1e-3_f32..1.0,
        p in -1.0_f32..=1.0,
        force in -4e5_f32..=4e5,
    ) {
        let l = Layout::new(base, Scales { position_m: pf, demand_n: ff, ..Scales::DBC }).unwrap();
        let (lo, hi) = l.position_range_m();
        let p = p.clamp(lo, hi);
        let m = Measurement { channel: 5, position_m: p, road_m: 0.0, counter: 1 };
        let f = encode_measurement(&l, &m).unwrap();
        prop_assert_eq!(f.id, base + 5);
        let Ok(Message::Measurement(back)) = decode(&l, &f) else { panic!("{:?}", decode(&l, &f)) };
        close(back.position_m, p, pf)?;
        let d = Demand { channel: 0, demand_n: force, counter: 0, flags: DemandFlags::default() };
        let f = encode_demand(&l, &d).unwrap();
        let Ok(Message::Demand(back)) = decode(&l, &f) else { panic!() };
        let (lo, hi) = l.demand_range_n();
        close(back.demand_n, force.clamp(lo, hi), ff)?;
        // Another layout's frames are foreign or something else, never a panic.
        let _ = decode(&Layout::DEFAULT, &f);
    }

    /// Whatever arrives: no panic; what decodes re-encodes to the same bytes (canonical).
    #[test]
    fn decode_is_total_and_canonical(frame in any_frame()) {
        let l = Layout::DEFAULT;
        if let Ok(m) = decode(&l, &frame) {
            let again = encode(&l, &m).unwrap();
            prop_assert_eq!(again.id, frame.id);
            prop_assert_eq!(again.len, frame.len);
            prop_assert_eq!(again.payload(), frame.payload());
        }
    }

    /// Any line: no panic; a parsed frame formats back to the same line (upper-case hex).
    #[test]
    fn slcan_parse_is_total_and_canonical(line in prop_oneof![
        prop::collection::vec(any::<u8>(), 0..40),
        "[tTrR][0-9A-Fa-f]{3,8}[0-9][0-9A-Fa-f]{0,16}".prop_map(String::into_bytes),
    ]) {
        if let Ok(SlcanLine::Frame(f)) = slcan::parse_line(&line) {
            let mut out = [0_u8; slcan::MAX_LINE + 1];
            let n = slcan::format_frame(&f, &mut out).unwrap();
            let mut want = line.to_ascii_uppercase();
            if let Some(first) = want.first_mut() { *first = line[0]; }
            want.push(b'\r');
            prop_assert_eq!(&out[..n], &want[..]);
        }
    }

    /// Any byte stream: no panic, lines never hold `\r` or `\n` and fit the buffer.
    #[test]
    fn line_buffer_is_total(bytes in prop::collection::vec(prop_oneof![any::<u8>(), Just(b'\r')], 0..200)) {
        let mut lb = LineBuffer::<{ slcan::MAX_LINE }>::new();
        for b in bytes {
            if let Ok(Some(line)) = lb.push(b) {
                prop_assert!(line.len() <= slcan::MAX_LINE);
                prop_assert!(!line.contains(&b'\r') && !line.contains(&b'\n'));
            }
        }
    }
}
