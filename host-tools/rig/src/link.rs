//! The CAN link between the rig controller and the MiL board, one channel in one direction.
//!
//! Per control sample the sender puts one value into a CAN frame as a fixed-point signal, as
//! a DBC file describes it:
//!
//! ```text
//! raw   = round((value − offset) / factor)   signed, `bits` wide (16 or 32), saturating
//! value = raw · factor + offset
//! ```
//!
//! Rounding is to the nearest count, ties away from zero. Values beyond the raw range
//! saturate at `−2^(bits−1)` and `2^(bits−1) − 1` (also ±∞); a NaN cannot be encoded by a
//! real sender and is sent as raw 0 (which decodes to `offset`), as a saturating float-to-
//! integer conversion does. With `factor = 0` there is no fixed point: the value travels as
//! an IEEE-754 double (raw = its bit pattern, `bits` is then unused) and arrives bit for
//! bit, NaN included.
//!
//! The link delays each frame by a whole number of control samples and may fail a frame:
//!
//! - **dropped**: the frame does not arrive (CAN error frames, bus-off, lost arbitration);
//!   the receiver gets [`Received::Dropped`] and must hold or extrapolate.
//! - **corrupted**: the frame arrives with one random bit of its raw integer flipped. On a
//!   real bus the 15-bit CRC catches most such errors, so this models an error the CRC
//!   misses or a faulty sender; it is there to exercise the receiver's input validation.
//!   The wrong value is always finite (a flip that would make a double non-finite is moved
//!   to the next bit).
//!
//! Each frame is first dropped with `drop_probability`; a frame that is not dropped is then
//! corrupted with `corrupt_probability`. The faults are drawn when the frame is sent, from a
//! seeded [`SplitMix64`], in the order of sending, so the fault sequence of a seed does not
//! depend on the delay.

use mil_numerics::rng::SplitMix64;
use serde::{Deserialize, Serialize};

/// The largest transport delay accepted (control samples): 100 s at 10 kHz.
pub const MAX_DELAY_SAMPLES: usize = 1_000_000;

/// One channel of the CAN link in one direction: delay, fixed-point encoding and faults. By
/// default an ideal link: no delay, the value passes through as a double, no faults.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LinkSpec {
    /// Transport delay in whole control samples (0: the value is available in the same
    /// sample); at most [`MAX_DELAY_SAMPLES`].
    pub delay_samples: usize,
    /// Fixed-point scaling: value per count (unit of the value per bit, e.g. 1e-6 m or
    /// 0.1 N); 0: no quantisation (the double passes through).
    pub factor: f64,
    /// Offset of the encoding (unit of the value), default 0.
    pub offset: f64,
    /// Width of the signed raw integer (bits): 16 or 32, default 32.
    pub bits: u8,
    /// Probability that a frame is dropped (0…1), default 0.
    pub drop_probability: f64,
    /// Probability that a frame that is not dropped arrives with a corrupted payload (0…1),
    /// default 0.
    pub corrupt_probability: f64,
    /// Seed of the fault generator.
    pub seed: u64,
}

impl Default for LinkSpec {
    fn default() -> Self {
        Self {
            delay_samples: 0,
            factor: 0.0,
            offset: 0.0,
            bits: 32,
            drop_probability: 0.0,
            corrupt_probability: 0.0,
            seed: 0,
        }
    }
}

/// What arrives at the receiver in one sample (values in the unit of the channel).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Received {
    /// The frame arrived intact: the decoded value.
    Value(f64),
    /// No frame arrived.
    Dropped,
    /// A frame arrived with a corrupted payload: the decoded wrong value (always finite),
    /// which a real receiver would take at face value.
    Corrupted(f64),
}

impl Received {
    /// The value the receiver reads from the frame (intact or corrupted), `None` if no
    /// frame arrived.
    pub fn value(self) -> Option<f64> {
        match self {
            Self::Value(v) | Self::Corrupted(v) => Some(v),
            Self::Dropped => None,
        }
    }
}

/// Frame counts of a link so far.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LinkCounts {
    /// Frames sent (calls of [`CanLink::transfer`]).
    pub sent: u64,
    /// Frames that failed to arrive so far ([`Received::Dropped`] returned). Frames still in
    /// flight (at most `delay_samples`) are not counted yet.
    pub dropped: u64,
    /// Corrupted frames that arrived so far ([`Received::Corrupted`] returned).
    pub corrupted: u64,
}

/// An invalid [`LinkSpec`].
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum LinkError {
    /// A field has an invalid value.
    #[error("CAN link: `{field}` must be {requirement} (is {value})")]
    Invalid {
        /// Name of the field (`delay_samples`, `factor`, `offset`, `bits`,
        /// `drop_probability` or `corrupt_probability`).
        field: &'static str,
        /// Its value (unit of the field).
        value: f64,
        /// What it must be.
        requirement: &'static str,
    },
}

impl LinkError {
    /// Name of the offending field.
    pub fn field(&self) -> &'static str {
        match self {
            Self::Invalid { field, .. } => field,
        }
    }
}

/// Fate of a frame in flight, drawn when it was sent.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Fate {
    Intact,
    Dropped,
    Corrupted,
}

/// A frame on the bus: its raw payload (after any corruption) and fate.
#[derive(Clone, Copy, Debug)]
struct Frame {
    raw: i64,
    fate: Fate,
}

/// One channel of the CAN link in one direction. The frames in flight are kept in a ring
/// buffer of `delay_samples` frames, allocated once; [`CanLink::transfer`] does not
/// allocate.
#[derive(Clone, Debug)]
pub struct CanLink {
    spec: LinkSpec,
    /// Saturation range of the raw integer.
    raw_min: i64,
    raw_max: i64,
    ring: Box<[Frame]>,
    /// Next frame to arrive, and the slot the frame sent now takes.
    head: usize,
    rng: SplitMix64,
    counts: LinkCounts,
}

fn invalid(field: &'static str, value: f64, requirement: &'static str) -> LinkError {
    LinkError::Invalid {
        field,
        value,
        requirement,
    }
}

fn probability(field: &'static str, p: f64) -> Result<(), LinkError> {
    if (0.0..=1.0).contains(&p) {
        Ok(())
    } else {
        Err(invalid(field, p, "in [0, 1]"))
    }
}

impl CanLink {
    /// A link with `spec`, its bus primed with 0.0 (see [`CanLink::prime`]).
    ///
    /// # Errors
    /// [`LinkError::Invalid`] naming the field: `delay_samples` above
    /// [`MAX_DELAY_SAMPLES`], `factor` not finite and `>= 0`, `offset` not finite, `bits`
    /// not 16 or 32, a probability not in `[0, 1]` (or NaN).
    pub fn new(spec: &LinkSpec) -> Result<Self, LinkError> {
        if spec.delay_samples > MAX_DELAY_SAMPLES {
            return Err(invalid(
                "delay_samples",
                spec.delay_samples as f64,
                "at most MAX_DELAY_SAMPLES (1e6)",
            ));
        }
        if !(spec.factor.is_finite() && spec.factor >= 0.0) {
            return Err(invalid("factor", spec.factor, "finite and >= 0"));
        }
        if !spec.offset.is_finite() {
            return Err(invalid("offset", spec.offset, "finite"));
        }
        if !matches!(spec.bits, 16 | 32) {
            return Err(invalid("bits", f64::from(spec.bits), "16 or 32"));
        }
        probability("drop_probability", spec.drop_probability)?;
        probability("corrupt_probability", spec.corrupt_probability)?;
        let raw_max = (1i64 << (spec.bits - 1)) - 1;
        let mut link = Self {
            spec: spec.clone(),
            raw_min: -raw_max - 1,
            raw_max,
            ring: vec![
                Frame {
                    raw: 0,
                    fate: Fate::Intact,
                };
                spec.delay_samples
            ]
            .into_boxed_slice(),
            head: 0,
            rng: SplitMix64::new(spec.seed),
            counts: LinkCounts::default(),
        };
        link.prime(0.0);
        Ok(link)
    }

    /// The link's spec.
    pub fn spec(&self) -> &LinkSpec {
        &self.spec
    }

    /// Sends this sample's value (unit of the channel) and returns what arrives at the
    /// receiver in this sample: the frame sent `delay_samples` samples ago (this one's with
    /// no delay), decoded, or its fault. During the first `delay_samples` samples after
    /// [`CanLink::new`] or [`CanLink::prime`] the receiver gets the primed value, always
    /// intact (it is the bus state at start, not a frame of this run).
    pub fn transfer(&mut self, value: f64) -> Received {
        let sent = self.send(value);
        self.counts.sent += 1;
        let frame = match self.ring.get_mut(self.head) {
            Some(slot) => {
                let arriving = *slot;
                *slot = sent;
                self.head += 1;
                if self.head == self.ring.len() {
                    self.head = 0;
                }
                arriving
            }
            None => sent, // no delay
        };
        match frame.fate {
            Fate::Intact => Received::Value(self.decode(frame.raw)),
            Fate::Dropped => {
                self.counts.dropped += 1;
                Received::Dropped
            }
            Fate::Corrupted => {
                self.counts.corrupted += 1;
                Received::Corrupted(self.decode(frame.raw))
            }
        }
    }

    /// Encodes `value` into a frame and draws its fate.
    fn send(&mut self, value: f64) -> Frame {
        let raw = self.encode(value);
        if self.spec.drop_probability > 0.0 && self.rng.uniform() < self.spec.drop_probability {
            return Frame {
                raw,
                fate: Fate::Dropped,
            };
        }
        if self.spec.corrupt_probability > 0.0 && self.rng.uniform() < self.spec.corrupt_probability
        {
            return Frame {
                raw: self.flip_random_bit(raw),
                fate: Fate::Corrupted,
            };
        }
        Frame {
            raw,
            fate: Fate::Intact,
        }
    }

    /// `raw` with one random bit of its payload flipped.
    fn flip_random_bit(&mut self, raw: i64) -> i64 {
        if self.spec.factor == 0.0 {
            // A double: flip one of its 64 bits, the next one if the result is not finite
            // (for a finite value at most one bit can make it so, for a NaN the 11 exponent
            // bits all give finite values).
            let start = (self.rng.next_u64() % 64) as u32;
            let bits = raw as u64;
            (0..64)
                .map(|i| bits ^ (1u64 << ((start + i) % 64)))
                .find(|b| f64::from_bits(*b).is_finite())
                .unwrap_or(bits ^ (1u64 << start)) as i64
        } else {
            // Two's complement in `bits` bits, flipped, sign-extended back.
            let width = u32::from(self.spec.bits);
            let k = (self.rng.next_u64() % u64::from(width)) as u32;
            let shift = 64 - width;
            (((raw as u64) ^ (1u64 << k)) << shift) as i64 >> shift
        }
    }

    /// Replaces the frames in flight by intact frames carrying `value` (unit of the channel,
    /// encoded like any frame), the bus state at start: the next `delay_samples` transfers
    /// return it. Counts and the fault generator are not reset. Without a delay it has no
    /// effect.
    pub fn prime(&mut self, value: f64) {
        let frame = Frame {
            raw: self.encode(value),
            fate: Fate::Intact,
        };
        self.ring.fill(frame);
        self.head = 0;
    }

    /// Frame counts so far.
    pub fn counts(&self) -> LinkCounts {
        self.counts
    }

    /// The raw integer of `value` (unit of the channel):
    /// `round((value − offset) / factor)`, ties away from zero, saturated to the signed range
    /// of `bits` bits; NaN gives 0. With `factor = 0` the bit pattern of the double.
    pub fn encode(&self, value: f64) -> i64 {
        if self.spec.factor == 0.0 {
            return value.to_bits() as i64;
        }
        let counts = ((value - self.spec.offset) / self.spec.factor).round();
        if counts.is_nan() {
            0
        } else {
            // In range after the clamp, so the cast is exact.
            counts.clamp(self.raw_min as f64, self.raw_max as f64) as i64
        }
    }

    /// The value (unit of the channel) of the raw integer `raw`: `raw · factor + offset`
    /// (`raw` as read from the frame, within the signed range of `bits` bits). With
    /// `factor = 0` the double of that bit pattern.
    pub fn decode(&self, raw: i64) -> f64 {
        if self.spec.factor == 0.0 {
            f64::from_bits(raw as u64)
        } else {
            raw as f64 * self.spec.factor + self.spec.offset
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn link(spec: LinkSpec) -> CanLink {
        CanLink::new(&spec).unwrap()
    }

    fn fixed(factor: f64, bits: u8) -> LinkSpec {
        LinkSpec {
            factor,
            bits,
            ..LinkSpec::default()
        }
    }

    #[test]
    fn ideal_link_passes_values_bit_exactly_in_the_same_sample() {
        let mut l = link(LinkSpec::default());
        for v in [
            0.0,
            -0.0,
            1.5,
            -2.7e-9,
            f64::MAX,
            f64::NEG_INFINITY,
            f64::NAN,
        ] {
            match l.transfer(v) {
                Received::Value(r) => assert_eq!(r.to_bits(), v.to_bits()),
                other => panic!("{other:?}"),
            }
        }
        assert_eq!(
            l.counts(),
            LinkCounts {
                sent: 7,
                dropped: 0,
                corrupted: 0
            }
        );
    }

    #[test]
    fn delay_shifts_the_sequence_by_exactly_d_samples() {
        for d in [0, 1, 3, 17] {
            for factor in [0.0, 0.5] {
                let mut l = link(LinkSpec {
                    delay_samples: d,
                    factor,
                    ..LinkSpec::default()
                });
                l.prime(-4.0);
                let out: Vec<f64> = (0..50)
                    .map(|k| l.transfer(k as f64).value().unwrap())
                    .collect();
                for (k, y) in out.iter().enumerate() {
                    let expected = if k < d { -4.0 } else { (k - d) as f64 };
                    assert_eq!(*y, expected, "d {d}, k {k}");
                }
            }
        }
    }

    #[test]
    fn unprimed_link_starts_at_zero() {
        let mut l = link(LinkSpec {
            delay_samples: 2,
            ..LinkSpec::default()
        });
        assert_eq!(l.transfer(1.0), Received::Value(0.0));
        assert_eq!(l.transfer(2.0), Received::Value(0.0));
        assert_eq!(l.transfer(3.0), Received::Value(1.0));
    }

    #[test]
    fn encode_decode_round_trip_within_half_a_count() {
        let mut rng = SplitMix64::new(11);
        for (factor, offset, bits) in [(1e-6, 0.0, 32u8), (0.1, -50.0, 16), (0.01, 3.0, 32)] {
            let l = link(LinkSpec {
                factor,
                offset,
                bits,
                ..LinkSpec::default()
            });
            let range = factor * 30_000.0;
            for _ in 0..10_000 {
                let v = offset + (2.0 * rng.uniform() - 1.0) * range;
                let raw = l.encode(v);
                assert!(
                    (l.decode(raw) - v).abs() <= factor / 2.0 * (1.0 + 1e-9),
                    "{v}"
                );
                assert_eq!(l.encode(l.decode(raw)), raw);
            }
        }
        let l = link(fixed(0.1, 16));
        assert_eq!(l.encode(0.25), 3); // ties away from zero
        assert_eq!(l.encode(-0.25), -3);
    }

    #[test]
    fn encoding_saturates_at_the_raw_range() {
        let l = link(fixed(1.0, 16));
        assert_eq!(l.encode(1e6), 32767);
        assert_eq!(l.encode(-1e6), -32768);
        assert_eq!(l.encode(f64::INFINITY), 32767);
        assert_eq!(l.encode(f64::NEG_INFINITY), -32768);
        assert_eq!(l.encode(32767.4), 32767);
        assert_eq!(l.encode(32767.6), 32767);
        let l = link(fixed(1e-6, 32));
        assert_eq!(l.encode(1e6), i64::from(i32::MAX));
        assert_eq!(l.encode(-1e6), i64::from(i32::MIN));
        let mut l = link(fixed(1.0, 16));
        assert_eq!(l.transfer(1e6), Received::Value(32767.0));
    }

    #[test]
    fn nan_is_sent_as_raw_zero() {
        let mut l = link(LinkSpec {
            factor: 0.5,
            offset: 7.0,
            bits: 16,
            ..LinkSpec::default()
        });
        assert_eq!(l.encode(f64::NAN), 0);
        assert_eq!(l.transfer(f64::NAN), Received::Value(7.0));
    }

    fn tally(spec: &LinkSpec, n: usize) -> (Vec<Received>, LinkCounts) {
        let mut l = link(spec.clone());
        let mut rng = SplitMix64::new(5);
        let out = (0..n).map(|_| l.transfer(1000.0 * rng.normal())).collect();
        (out, l.counts())
    }

    #[test]
    fn fault_probabilities_are_met_and_counted() {
        let n = 100_000;
        let spec = LinkSpec {
            factor: 0.1,
            drop_probability: 0.01,
            corrupt_probability: 0.01,
            seed: 5,
            ..LinkSpec::default()
        };
        let (out, counts) = tally(&spec, n);
        let dropped = out.iter().filter(|r| **r == Received::Dropped).count() as u64;
        let corrupted = out
            .iter()
            .filter(|r| matches!(r, Received::Corrupted(_)))
            .count() as u64;
        assert_eq!(
            counts,
            LinkCounts {
                sent: n as u64,
                dropped,
                corrupted
            }
        );
        // The 10 % tolerance is about 3 standard deviations of a count of ~1000.
        let p_drop = dropped as f64 / n as f64;
        let p_corrupt = corrupted as f64 / (n as u64 - dropped) as f64;
        assert!((p_drop / 0.01 - 1.0).abs() < 0.1, "drop {p_drop}");
        assert!((p_corrupt / 0.01 - 1.0).abs() < 0.1, "corrupt {p_corrupt}");
    }

    #[test]
    fn faults_are_reproducible_from_the_seed_and_independent_of_the_delay() {
        let spec = LinkSpec {
            factor: 0.1,
            drop_probability: 0.05,
            corrupt_probability: 0.05,
            seed: 3,
            ..LinkSpec::default()
        };
        let (a, _) = tally(&spec, 5000);
        let (b, _) = tally(&spec, 5000);
        assert_eq!(a, b);
        let (c, _) = tally(
            &LinkSpec {
                seed: 4,
                ..spec.clone()
            },
            5000,
        );
        assert_ne!(a, c);
        let d = 5;
        let (delayed, _) = tally(
            &LinkSpec {
                delay_samples: d,
                ..spec.clone()
            },
            5000,
        );
        assert_eq!(&delayed[d..], &a[..5000 - d]);
    }

    #[test]
    fn corrupted_values_differ_by_exactly_one_raw_bit() {
        for (factor, bits) in [(0.1, 16u8), (1e-3, 32), (0.0, 32)] {
            let d = 2;
            let spec = LinkSpec {
                delay_samples: d,
                factor,
                bits,
                corrupt_probability: 0.5,
                seed: 99,
                ..LinkSpec::default()
            };
            let mut l = link(spec);
            let mut rng = SplitMix64::new(1);
            let sent: Vec<f64> = (0..20_000).map(|_| 2000.0 * rng.normal()).collect();
            let mut corrupted = 0;
            let mut flipped_bits = [false; 64];
            for (k, &v) in sent.iter().enumerate() {
                let Received::Corrupted(wrong) = l.transfer(v) else {
                    continue;
                };
                corrupted += 1;
                assert!(wrong.is_finite());
                let diff = (l.encode(wrong) ^ l.encode(sent[k - d])) as u64;
                let mask = if factor == 0.0 {
                    u64::MAX
                } else {
                    (1u64 << bits) - 1
                };
                assert_eq!((diff & mask).count_ones(), 1, "{factor} {bits}");
                flipped_bits[diff.trailing_zeros() as usize] = true;
            }
            assert!(corrupted > 9000, "{corrupted}");
            // Every bit of the payload (sign bit included) gets flipped sometime.
            let width = if factor == 0.0 { 64 } else { usize::from(bits) };
            assert!(flipped_bits[..width].iter().all(|b| *b), "{factor} {bits}");
        }
    }

    #[test]
    fn corrupting_a_nan_double_gives_a_finite_value() {
        let mut l = link(LinkSpec {
            corrupt_probability: 1.0,
            ..LinkSpec::default()
        });
        for _ in 0..1000 {
            let Received::Corrupted(v) = l.transfer(f64::NAN) else {
                panic!("not corrupted")
            };
            assert!(v.is_finite());
        }
    }

    #[test]
    fn zero_probabilities_never_fail_a_frame() {
        let spec = LinkSpec {
            delay_samples: 3,
            factor: 0.01,
            ..LinkSpec::default()
        };
        let (out, counts) = tally(&spec, 100_000);
        assert!(out.iter().all(|r| matches!(r, Received::Value(_))));
        assert_eq!((counts.dropped, counts.corrupted), (0, 0));
    }

    #[test]
    fn invalid_specs_are_refused_naming_the_field() {
        let d = LinkSpec::default;
        let cases = [
            (LinkSpec { bits: 8, ..d() }, "bits"),
            (LinkSpec { bits: 64, ..d() }, "bits"),
            (
                LinkSpec {
                    factor: -0.1,
                    ..d()
                },
                "factor",
            ),
            (
                LinkSpec {
                    factor: f64::NAN,
                    ..d()
                },
                "factor",
            ),
            (
                LinkSpec {
                    factor: f64::INFINITY,
                    ..d()
                },
                "factor",
            ),
            (
                LinkSpec {
                    offset: f64::NAN,
                    ..d()
                },
                "offset",
            ),
            (
                LinkSpec {
                    drop_probability: -0.01,
                    ..d()
                },
                "drop_probability",
            ),
            (
                LinkSpec {
                    drop_probability: f64::NAN,
                    ..d()
                },
                "drop_probability",
            ),
            (
                LinkSpec {
                    corrupt_probability: 1.5,
                    ..d()
                },
                "corrupt_probability",
            ),
            (
                LinkSpec {
                    delay_samples: MAX_DELAY_SAMPLES + 1,
                    ..d()
                },
                "delay_samples",
            ),
        ];
        for (spec, field) in cases {
            let err = CanLink::new(&spec).unwrap_err();
            assert_eq!(err.field(), field);
            assert!(err.to_string().contains(field), "{err}");
        }
        assert!(CanLink::new(&LinkSpec {
            bits: 16,
            drop_probability: 1.0,
            corrupt_probability: 1.0,
            ..d()
        })
        .is_ok());
    }
}
