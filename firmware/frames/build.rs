//! Reads `mil.dbc` with `can-dbc` and writes the codec's layout table
//! (`$OUT_DIR/dbc_layout.rs`, included by `src/dbc.rs`): message ID offsets, DLCs, and each
//! signal's start bit, length, signedness, factor, offset, limits and raw limits. The DBC is the
//! source of truth: change a factor, a bit position or a DLC there and the codec follows.
//!
//! The build fails with a message naming the DBC line's object when the file does not describe
//! what the codec implements: a message or signal missing or unknown, big-endian byte order, a
//! signal outside its frame or overlapping another, a type the codec cannot hold, channels
//! that differ from channel 0, IDs that collide or leave the MiL ID range.

use std::collections::BTreeSet;
use std::fmt::Write as _;
use std::path::PathBuf;

use can_dbc::{
    ByteOrder, Dbc, Message, MessageId, NumericValue, SignalExtendedValueType, ValueType,
};

#[path = "src/limits.rs"]
#[allow(dead_code)]
mod limits;

/// Width of the MiL ID range above the base ID (offsets `0..ID_RANGE`); see `src/dbc.rs`.
const ID_RANGE: u16 = 0x30;
/// Channels of every per-channel message (`<name>_Ch0` .. `<name>_Ch7`).
const CHANNELS: u16 = 8;

#[derive(Clone, Copy, PartialEq)]
enum Kind {
    /// Fixed-point physical quantity: integer, 2..=32 bits, factor > 0, "not available" pattern.
    Physical,
    /// A whole byte (counter, command number, index, result, bit mask): unsigned, 8 bits.
    Byte,
    /// An enumeration (mode): unsigned, 2..=8 bits.
    Enum,
    /// One bit.
    Flag,
    /// An event count: unsigned, 1..=16 bits (the codec saturates to the width).
    Count,
    /// An index (the command's parameter index): unsigned, 8..=16 bits.
    Index,
    /// IEEE-754 single precision (`SIG_VALTYPE_ ... : 1`).
    Float32,
}

impl Kind {
    fn rust(self) -> &'static str {
        match self {
            Kind::Physical => "SignalKind::Physical",
            Kind::Byte => "SignalKind::Byte",
            Kind::Enum => "SignalKind::Enum",
            Kind::Flag => "SignalKind::Flag",
            Kind::Count => "SignalKind::Count",
            Kind::Index => "SignalKind::Index",
            Kind::Float32 => "SignalKind::Float32",
        }
    }
}

struct Expected {
    /// DBC message name (per-channel ones: `<name>_Ch<n>`).
    name: &'static str,
    /// Module of the generated table.
    module: &'static str,
    per_channel: bool,
    /// (DBC signal name, generated constant, kind)
    signals: &'static [(&'static str, &'static str, Kind)],
}

const EXPECTED: &[Expected] = &[
    Expected {
        name: "Measurement",
        module: "measurement",
        per_channel: true,
        signals: &[
            ("Position", "POSITION", Kind::Physical),
            ("Road", "ROAD", Kind::Physical),
            ("Counter", "COUNTER", Kind::Byte),
        ],
    },
    Expected {
        name: "MeasurementAux",
        module: "measurement_aux",
        per_channel: true,
        signals: &[
            ("Force", "FORCE", Kind::Physical),
            ("Speed", "SPEED", Kind::Physical),
        ],
    },
    Expected {
        name: "Demand",
        module: "demand",
        per_channel: true,
        signals: &[
            ("Demand", "DEMAND", Kind::Physical),
            ("Counter", "COUNTER", Kind::Byte),
            ("Mode", "MODE", Kind::Enum),
            ("FaultLatched", "FAULT_LATCHED", Kind::Flag),
            ("AmplitudeLimited", "AMPLITUDE_LIMITED", Kind::Flag),
            ("RateLimited", "RATE_LIMITED", Kind::Flag),
        ],
    },
    Expected {
        name: "Status",
        module: "status",
        per_channel: false,
        signals: &[
            ("Mode", "MODE", Kind::Enum),
            ("CalibrationSource", "CALIBRATION_SOURCE", Kind::Enum),
            ("FaultCauses", "FAULT_CAUSES", Kind::Byte),
            ("MissedSamples", "MISSED_SAMPLES", Kind::Count),
            ("LateSamples", "LATE_SAMPLES", Kind::Count),
            ("MalformedFrames", "MALFORMED_FRAMES", Kind::Count),
        ],
    },
    Expected {
        name: "Command",
        module: "command",
        per_channel: false,
        signals: &[
            ("Command", "COMMAND", Kind::Byte),
            ("Index", "INDEX", Kind::Index),
            ("Value", "VALUE", Kind::Float32),
        ],
    },
    Expected {
        name: "CommandAck",
        module: "command_ack",
        per_channel: false,
        signals: &[
            ("Command", "COMMAND", Kind::Byte),
            ("Index", "INDEX", Kind::Byte),
            ("Result", "RESULT", Kind::Byte),
            ("Mode", "MODE", Kind::Enum),
        ],
    },
];

fn fail(msg: impl AsRef<str>) -> ! {
    panic!(
        "\n\nmil-frames: mil.dbc does not describe the frames the codec implements:\n  {}\n\n",
        msg.as_ref()
    );
}

fn num(v: NumericValue) -> f64 {
    match v {
        NumericValue::Uint(u) => u as f64,
        NumericValue::Int(i) => i as f64,
        NumericValue::Double(d) => d,
    }
}

fn std_id(m: &Message) -> u16 {
    match m.id {
        MessageId::Standard(id) if id <= 0x7FF => id,
        _ => fail(format!(
            "message `{}`: needs a standard 11-bit ID, has {:?}",
            m.name, m.id
        )),
    }
}

/// Everything of a signal that must agree between channels.
fn signal_key(dbc: &Dbc, m: &Message, name: &str) -> String {
    let s = m.signals.iter().find(|s| s.name == name);
    match s {
        None => String::from("missing"),
        Some(s) => format!(
            "{}|{}@{:?}{:?} ({},{}) [{}|{}] {:?} {:?}",
            s.start_bit,
            s.size,
            s.byte_order,
            s.value_type,
            s.factor,
            s.offset,
            num(s.min),
            num(s.max),
            s.unit,
            dbc.extended_value_type_for_signal(m.id, name)
        ),
    }
}

fn doc(out: &mut String, indent: &str, text: &str) {
    for line in text.lines() {
        let _ = writeln!(out, "{indent}#[doc = {line:?}]");
    }
}

fn main() {
    let manifest = PathBuf::from(
        std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| fail("CARGO_MANIFEST_DIR not set")),
    );
    let path = manifest.join("mil.dbc");
    println!("cargo:rerun-if-changed={}", path.display());
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed=src/limits.rs");
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| fail(format!("cannot read {}: {e}", path.display())));
    let dbc = Dbc::try_from(text.as_str())
        .unwrap_or_else(|e| fail(format!("{} does not parse: {e:?}", path.display())));

    let find = |name: &str| dbc.messages.iter().find(|m| m.name == name);
    let dbc_name = |e: &Expected, ch: u16| {
        if e.per_channel {
            format!("{}_Ch{ch}", e.name)
        } else {
            e.name.to_string()
        }
    };

    // Every message of the DBC must be one the codec knows.
    let mut known = BTreeSet::new();
    for e in EXPECTED {
        let n = if e.per_channel { CHANNELS } else { 1 };
        for ch in 0..n {
            known.insert(dbc_name(e, ch));
        }
    }
    for m in &dbc.messages {
        if !known.contains(&m.name) {
            fail(format!(
                "message `{}` is not known to the codec (known: {})",
                m.name,
                known.iter().cloned().collect::<Vec<_>>().join(", ")
            ));
        }
    }

    let base_msg = find("Measurement_Ch0").unwrap_or_else(|| {
        fail("message `Measurement_Ch0` is missing: its ID is the default base ID")
    });
    let base = std_id(base_msg);

    let mut out = String::new();
    let _ = writeln!(
        out,
        "// @generated by build.rs from mil.dbc; do not edit.\n"
    );
    let _ = writeln!(
        out,
        "/// Default base ID: the ID of `Measurement_Ch0` in mil.dbc."
    );
    let _ = writeln!(out, "pub const DEFAULT_BASE_ID: u16 = {base:#05X};");
    let _ = writeln!(
        out,
        "/// Channels of every per-channel message (`<name>_Ch0` .. `<name>_Ch{}` in mil.dbc).",
        CHANNELS - 1
    );
    let _ = writeln!(out, "pub const CHANNELS: u8 = {CHANNELS};");
    let _ = writeln!(
        out,
        "/// Width of the MiL ID range: offsets `0..ID_RANGE` above the base ID belong to MiL."
    );
    let _ = writeln!(out, "pub const ID_RANGE: u16 = {ID_RANGE:#04X};\n");

    let mut used_ids: BTreeSet<u16> = BTreeSet::new();
    let mut highest = 0_u16;
    let mut all_messages = Vec::new();

    for e in EXPECTED {
        let m0_name = dbc_name(e, 0);
        let m0 = find(&m0_name).unwrap_or_else(|| fail(format!("message `{m0_name}` is missing")));
        let id0 = std_id(m0);
        let Some(offset) = id0.checked_sub(base) else {
            fail(format!(
                "message `{m0_name}`: ID {id0:#X} is below the base ID {base:#X} (Measurement_Ch0)"
            ))
        };
        let dlc = m0.size;
        if dlc > 8 {
            fail(format!(
                "message `{m0_name}`: DLC {dlc} exceeds 8 (classic CAN)"
            ));
        }
        let n = if e.per_channel { CHANNELS } else { 1 };
        for ch in 0..n {
            let name = dbc_name(e, ch);
            let m = find(&name).unwrap_or_else(|| {
                fail(format!(
                    "message `{name}` is missing (the codec expects {}_Ch0..{}_Ch{})",
                    e.name,
                    e.name,
                    CHANNELS - 1
                ))
            });
            let id = std_id(m);
            if id != id0 + ch {
                fail(format!(
                    "message `{name}`: ID {id:#X}, expected {:#X} (channel 0's ID + channel)",
                    id0 + ch
                ));
            }
            if id - base >= ID_RANGE {
                fail(format!("message `{name}`: offset {:#X} from the base ID is outside the MiL range 0..{ID_RANGE:#X}", id - base));
            }
            if !used_ids.insert(id) {
                fail(format!("message `{name}`: ID {id:#X} is used twice"));
            }
            highest = highest.max(id - base);
            if m.size != dlc {
                fail(format!(
                    "message `{name}`: DLC {} differs from channel 0's {dlc}",
                    m.size
                ));
            }
            if m.signals.len() != m0.signals.len() {
                fail(format!(
                    "message `{name}`: its signals differ from `{m0_name}`'s"
                ));
            }
            for s in &m0.signals {
                if signal_key(&dbc, m, &s.name) != signal_key(&dbc, m0, &s.name) {
                    fail(format!(
                        "signal `{name}.{}` differs from `{m0_name}.{}`",
                        s.name, s.name
                    ));
                }
            }
        }
        for s in &m0.signals {
            if !e.signals.iter().any(|(n, _, _)| *n == s.name) {
                fail(format!(
                    "signal `{m0_name}.{}` is not known to the codec",
                    s.name
                ));
            }
        }

        let mut used_bits: u64 = 0;
        let mut sig_code = String::new();
        let mut sig_consts = Vec::new();
        for (sname, cname, kind) in e.signals {
            let s = m0
                .signals
                .iter()
                .find(|s| s.name == *sname)
                .unwrap_or_else(|| fail(format!("signal `{m0_name}.{sname}` is missing")));
            let what = format!("signal `{m0_name}.{sname}`");
            if s.byte_order != ByteOrder::LittleEndian {
                fail(format!(
                    "{what}: byte order must be Intel (little-endian, `@1`)"
                ));
            }
            let start = s.start_bit;
            let len = s.size;
            if len == 0 || start + len > 8 * dlc {
                fail(format!(
                    "{what}: bits {start}..{} do not fit the {dlc}-byte frame",
                    start + len
                ));
            }
            let mask = (if len >= 64 {
                u64::MAX
            } else {
                (1_u64 << len) - 1
            }) << start;
            if used_bits & mask != 0 {
                fail(format!("{what}: overlaps another signal"));
            }
            used_bits |= mask;
            let signed = s.value_type == ValueType::Signed;
            let float = matches!(
                dbc.extended_value_type_for_signal(m0.id, sname),
                Some(
                    SignalExtendedValueType::IEEEfloat32Bit
                        | SignalExtendedValueType::IEEEdouble64bit
                )
            );
            let (factor, offset, min, max) = (s.factor, s.offset, num(s.min), num(s.max));
            let integral = factor == 1.0 && offset == 0.0;
            let ok = match kind {
                Kind::Physical => {
                    !float
                        && (2..=u64::from(limits::MAX_INT_BITS)).contains(&len)
                        && factor.is_finite()
                        && factor > 0.0
                        && min < max
                }
                Kind::Byte => !float && !signed && len == 8 && integral,
                Kind::Enum => !float && !signed && (2..=8).contains(&len) && integral,
                Kind::Flag => !float && !signed && len == 1 && integral,
                Kind::Count => !float && !signed && (1..=16).contains(&len) && integral,
                Kind::Index => !float && !signed && (8..=16).contains(&len) && integral,
                Kind::Float32 => {
                    float
                        && matches!(
                            dbc.extended_value_type_for_signal(m0.id, sname),
                            Some(SignalExtendedValueType::IEEEfloat32Bit)
                        )
                        && len == 32
                        && integral
                }
            };
            if !ok {
                let need = match kind {
                    Kind::Physical => {
                        "an integer of 2..=32 bits with a finite factor > 0 and min < max"
                    }
                    Kind::Byte => "an unsigned 8-bit integer with factor 1, offset 0",
                    Kind::Enum => "an unsigned integer of 2..=8 bits with factor 1, offset 0",
                    Kind::Flag => "an unsigned 1-bit integer with factor 1, offset 0",
                    Kind::Count => "an unsigned integer of 1..=16 bits with factor 1, offset 0",
                    Kind::Index => "an unsigned integer of 8..=16 bits with factor 1, offset 0",
                    Kind::Float32 => {
                        "a 32-bit IEEE float (SIG_VALTYPE_ ... : 1) with factor 1, offset 0"
                    }
                };
                fail(format!("{what}: must be {need}"));
            }
            let (raw_min, raw_max) = match kind {
                Kind::Physical => {
                    // The codec holds factors and offsets as f32: compute the default limits
                    // exactly as `Layout::new` will for the same f32 values.
                    let f = f64::from(factor as f32);
                    let o = f64::from(offset as f32);
                    limits::raw_limits(f, o, min, max, len as u8, signed).unwrap_or_else(|| {
                        fail(format!(
                            "{what}: no raw value is valid in [{min}, {max}] with factor {factor}"
                        ))
                    })
                }
                Kind::Float32 => (0, 0),
                _ => (0, (1_i64 << len) - 1),
            };
            let comment = dbc.signal_comment(m0.id, sname).unwrap_or("");
            doc(&mut sig_code, "    ", &format!("`{sname}`: {comment}"));
            let _ = writeln!(
                sig_code,
                "    pub const {cname}: SignalSpec = SignalSpec {{ name: {sname:?}, kind: {}, start_bit: {start}, len: {len}, signed: {signed}, factor: {factor:?}, offset: {offset:?}, min: {min:?}, max: {max:?}, unit: {:?}, raw_min: {raw_min}, raw_max: {raw_max} }};",
                kind.rust(),
                s.unit
            );
            sig_consts.push(*cname);
        }

        let comment = dbc.message_comment(m0.id).unwrap_or("");
        doc(
            &mut out,
            "",
            &format!(
                "Layout of `{m0_name}`{} (mil.dbc): {comment}",
                if e.per_channel {
                    " and the other channels"
                } else {
                    ""
                }
            ),
        );
        let _ = writeln!(out, "pub mod {} {{", e.module);
        let _ = writeln!(
            out,
            "    use super::{{MessageSpec, SignalKind, SignalSpec}};"
        );
        let _ = writeln!(
            out,
            "    /// The message: name, ID offset from the base ID, DLC, bits used."
        );
        let _ = writeln!(
            out,
            "    pub const MESSAGE: MessageSpec = MessageSpec {{ name: {:?}, per_channel: {}, id_offset: {offset:#04X}, dlc: {dlc}, used_bits: {used_bits:#018X} }};",
            e.name, e.per_channel
        );
        out.push_str(&sig_code);
        let _ = writeln!(
            out,
            "    /// Every signal of the message, in the codec's order."
        );
        let _ = writeln!(
            out,
            "    pub const SIGNALS: [SignalSpec; {}] = [{}];",
            sig_consts.len(),
            sig_consts.join(", ")
        );
        let _ = writeln!(out, "}}\n");
        all_messages.push(format!("{}::MESSAGE", e.module));
    }
    if u32::from(base) + u32::from(highest) > 0x7FF {
        fail(format!(
            "base ID {base:#X} + highest offset {highest:#X} exceeds 0x7FF"
        ));
    }
    let _ = writeln!(
        out,
        "/// Highest ID offset in use (the base ID plus this must fit 11 bits)."
    );
    let _ = writeln!(out, "pub const HIGHEST_OFFSET: u16 = {highest:#04X};");
    let _ = writeln!(out, "/// Every message, in the codec's order.");
    let _ = writeln!(
        out,
        "pub const MESSAGES: [MessageSpec; {}] = [{}];",
        all_messages.len(),
        all_messages.join(", ")
    );

    let out_dir =
        PathBuf::from(std::env::var("OUT_DIR").unwrap_or_else(|_| fail("OUT_DIR not set")));
    std::fs::write(out_dir.join("dbc_layout.rs"), out)
        .unwrap_or_else(|e| fail(format!("cannot write the generated table: {e}")));
}
