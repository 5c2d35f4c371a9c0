//! The parameter and measurement table of an A2L file (ASAM MCD-2 MC), read with the
//! `a2lfile` parser: what the master needs of each `CHARACTERISTIC` (type `VALUE`) and
//! `MEASUREMENT` — address, data type, byte order, conversion, limits, unit, description —
//! and the `MEMORY_SEGMENT`s. The A2L is the source of truth for the host tool, as it is for
//! CANape or INCA; `mil a2l` writes the board's.
//!
//! Supported: scalar items (`VALUE` characteristics, measurements without arrays), data
//! types `UBYTE` … `A_INT64`, `FLOAT32_IEEE`, `FLOAT64_IEEE`, byte orders `MSB_LAST` /
//! `LITTLE_ENDIAN` and `MSB_FIRST` / `BIG_ENDIAN`, conversions `IDENTICAL`, `LINEAR` and the
//! linear case of `RAT_FUNC` (or `NO_COMPU_METHOD`). Other items are listed in
//! [`A2l::skipped`] with the reason; other conversions load, and are refused when the item is
//! read or written.

use std::collections::BTreeMap;
use std::path::Path;

use a2lfile::{
    A2lObjectName, ByteOrderEnum, CharacteristicType, ConversionType, DataType as A2lDataType,
};

use crate::error::{Error, Result};

/// Why an A2L file could not be used.
#[derive(Debug, thiserror::Error)]
pub enum A2lError {
    /// The file could not be read.
    #[error("{path}: {source}")]
    Read {
        /// The file.
        path: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The parser refused the file.
    #[error("{path}: not a valid A2L file: {message}")]
    Parse {
        /// The file.
        path: String,
        /// The parser's message.
        message: String,
    },
    /// The file has no MODULE.
    #[error("{path}: the A2L file has no MODULE")]
    NoModule {
        /// The file.
        path: String,
    },
}

/// A scalar's encoding in the target's memory.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DataType {
    /// `UBYTE`.
    U8,
    /// `SBYTE`.
    I8,
    /// `UWORD`.
    U16,
    /// `SWORD`.
    I16,
    /// `ULONG`.
    U32,
    /// `SLONG`.
    I32,
    /// `A_UINT64`.
    U64,
    /// `A_INT64`.
    I64,
    /// `FLOAT32_IEEE`.
    F32,
    /// `FLOAT64_IEEE`.
    F64,
}

impl DataType {
    fn from_a2l(t: &A2lDataType) -> Option<Self> {
        Some(match t {
            A2lDataType::Ubyte => Self::U8,
            A2lDataType::Sbyte => Self::I8,
            A2lDataType::Uword => Self::U16,
            A2lDataType::Sword => Self::I16,
            A2lDataType::Ulong => Self::U32,
            A2lDataType::Slong => Self::I32,
            A2lDataType::AUint64 => Self::U64,
            A2lDataType::AInt64 => Self::I64,
            A2lDataType::Float32Ieee => Self::F32,
            A2lDataType::Float64Ieee => Self::F64,
            A2lDataType::Float16Ieee => return None,
        })
    }

    /// Size in bytes.
    #[must_use]
    pub fn size(self) -> usize {
        match self {
            Self::U8 | Self::I8 => 1,
            Self::U16 | Self::I16 => 2,
            Self::U32 | Self::I32 | Self::F32 => 4,
            Self::U64 | Self::I64 | Self::F64 => 8,
        }
    }

    /// The A2L keyword.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::U8 => "UBYTE",
            Self::I8 => "SBYTE",
            Self::U16 => "UWORD",
            Self::I16 => "SWORD",
            Self::U32 => "ULONG",
            Self::I32 => "SLONG",
            Self::U64 => "A_UINT64",
            Self::I64 => "A_INT64",
            Self::F32 => "FLOAT32_IEEE",
            Self::F64 => "FLOAT64_IEEE",
        }
    }

    /// Whether it holds integers only.
    #[must_use]
    pub fn is_integer(self) -> bool {
        !matches!(self, Self::F32 | Self::F64)
    }

    /// The raw value `bytes` hold (exactly [`DataType::size`] of them).
    #[must_use]
    pub fn decode(self, bytes: &[u8], order: Endian) -> f64 {
        let mut b = [0u8; 8];
        let n = self.size().min(bytes.len());
        b[..n].copy_from_slice(&bytes[..n]);
        if order == Endian::Big {
            b[..n].reverse();
        }
        match self {
            Self::U8 => f64::from(b[0]),
            Self::I8 => f64::from(b[0] as i8),
            Self::U16 => f64::from(u16::from_le_bytes([b[0], b[1]])),
            Self::I16 => f64::from(i16::from_le_bytes([b[0], b[1]])),
            Self::U32 => f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            Self::I32 => f64::from(i32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            Self::U64 => u64::from_le_bytes(b) as f64,
            Self::I64 => i64::from_le_bytes(b) as f64,
            Self::F32 => f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            Self::F64 => f64::from_le_bytes(b),
        }
    }

    /// The bytes of raw value `raw`, or why it cannot be stored (not an integer, outside
    /// the type's range, not finite for a float type, too large for `FLOAT32_IEEE`).
    ///
    /// # Errors
    /// A sentence saying why.
    pub fn encode(self, raw: f64, order: Endian) -> std::result::Result<Vec<u8>, String> {
        if !raw.is_finite() {
            return Err("not a finite number".into());
        }
        let int = |lo: f64, hi: f64| -> std::result::Result<f64, String> {
            if raw.fract() != 0.0 {
                return Err(format!("{} holds integers only", self.name()));
            }
            if raw < lo || raw > hi {
                return Err(format!(
                    "outside the range of {} ({lo}..={hi})",
                    self.name()
                ));
            }
            Ok(raw)
        };
        let mut out = match self {
            Self::U8 => vec![int(0.0, 255.0)? as u8],
            Self::I8 => vec![int(-128.0, 127.0)? as i8 as u8],
            Self::U16 => (int(0.0, 65535.0)? as u16).to_le_bytes().to_vec(),
            Self::I16 => (int(-32768.0, 32767.0)? as i16).to_le_bytes().to_vec(),
            Self::U32 => (int(0.0, 4_294_967_295.0)? as u32).to_le_bytes().to_vec(),
            Self::I32 => (int(-2_147_483_648.0, 2_147_483_647.0)? as i32)
                .to_le_bytes()
                .to_vec(),
            Self::U64 => (int(0.0, 1.8e19)? as u64).to_le_bytes().to_vec(),
            Self::I64 => (int(-9.2e18, 9.2e18)? as i64).to_le_bytes().to_vec(),
            Self::F32 => {
                let v = raw as f32;
                if !v.is_finite() {
                    return Err("too large for FLOAT32_IEEE".into());
                }
                v.to_le_bytes().to_vec()
            }
            Self::F64 => raw.to_le_bytes().to_vec(),
        };
        if order == Endian::Big {
            out.reverse();
        }
        Ok(out)
    }
}

/// Byte order of a value in the target's memory.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Endian {
    /// `MSB_LAST` / `LITTLE_ENDIAN` (Intel), the board's.
    Little,
    /// `MSB_FIRST` / `BIG_ENDIAN` (Motorola).
    Big,
}

/// Raw (memory) value ↔ physical value.
#[derive(Clone, Debug, PartialEq)]
pub enum Conversion {
    /// Physical = raw.
    Identical,
    /// Physical = `a` · raw + `b` (`a` ≠ 0).
    Linear {
        /// Factor.
        a: f64,
        /// Offset (physical unit).
        b: f64,
    },
    /// A conversion this master does not implement (its A2L kind).
    Unsupported(String),
}

impl Conversion {
    /// The physical value of `raw`.
    ///
    /// # Errors
    /// An unsupported conversion.
    pub fn to_physical(&self, raw: f64) -> std::result::Result<f64, String> {
        match self {
            Self::Identical => Ok(raw),
            Self::Linear { a, b } => Ok(a * raw + b),
            Self::Unsupported(kind) => Err(format!("conversion {kind} is not supported")),
        }
    }

    /// The raw value of `physical` (rounded to the nearest integer for integer types by the
    /// caller).
    ///
    /// # Errors
    /// An unsupported conversion.
    pub fn to_raw(&self, physical: f64) -> std::result::Result<f64, String> {
        match self {
            Self::Identical => Ok(physical),
            Self::Linear { a, b } => Ok((physical - b) / a),
            Self::Unsupported(kind) => Err(format!("conversion {kind} is not supported")),
        }
    }

    /// Whether physical = raw.
    #[must_use]
    pub fn is_identity(&self) -> bool {
        match self {
            Self::Identical => true,
            Self::Linear { a, b } => *a == 1.0 && *b == 0.0,
            Self::Unsupported(_) => false,
        }
    }
}

/// A scalar in the target's memory: a calibration parameter (`CHARACTERISTIC VALUE`) or a
/// measurement.
#[derive(Clone, Debug, PartialEq)]
pub struct Item {
    /// A2L name.
    pub name: String,
    /// A2L long identifier.
    pub description: String,
    /// Address (XCP address, with [`Item::extension`]).
    pub address: u32,
    /// Address extension.
    pub extension: u8,
    /// Memory encoding.
    pub datatype: DataType,
    /// Byte order in memory.
    pub endian: Endian,
    /// Raw → physical.
    pub conversion: Conversion,
    /// Lowest physical value (the A2L's lower limit, physical unit).
    pub min: f64,
    /// Highest physical value.
    pub max: f64,
    /// Physical unit (SI as the A2L gives it; empty or `-` for none).
    pub unit: String,
}

impl Item {
    /// Size in bytes.
    #[must_use]
    pub fn size(&self) -> usize {
        self.datatype.size()
    }

    /// The unit for display: `-` when the A2L gives none.
    #[must_use]
    pub fn unit_or_dash(&self) -> &str {
        if self.unit.is_empty() {
            "-"
        } else {
            &self.unit
        }
    }

    /// The physical value held by `bytes` (the item's raw bytes).
    ///
    /// # Errors
    /// An unsupported conversion.
    pub fn decode(&self, bytes: &[u8]) -> Result<f64> {
        let raw = self.datatype.decode(bytes, self.endian);
        self.conversion
            .to_physical(raw)
            .map_err(|why| Error::UnsupportedItem {
                name: self.name.clone(),
                why,
            })
    }

    /// Checks `value` (physical) on the host: finite, within the A2L limits, representable;
    /// returns the raw bytes to write.
    ///
    /// # Errors
    /// [`Error::InvalidValue`] saying why, [`Error::UnsupportedItem`] for an unsupported
    /// conversion.
    pub fn encode_checked(&self, value: f64) -> Result<Vec<u8>> {
        let invalid = |why: String| Error::InvalidValue {
            name: self.name.clone(),
            value,
            why,
        };
        if !value.is_finite() {
            return Err(invalid("not a finite number".into()));
        }
        if value < self.min || value > self.max {
            return Err(invalid(format!(
                "outside the A2L limits {} ..= {} {}",
                self.min,
                self.max,
                self.unit_or_dash()
            )));
        }
        let mut raw = self
            .conversion
            .to_raw(value)
            .map_err(|why| Error::UnsupportedItem {
                name: self.name.clone(),
                why,
            })?;
        if self.datatype.is_integer() {
            raw = raw.round();
        }
        self.datatype.encode(raw, self.endian).map_err(invalid)
    }
}

/// A `MEMORY_SEGMENT` of `MOD_PAR`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Segment {
    /// Its name.
    pub name: String,
    /// `DATA`, `VARIABLES`, `CODE`, ...
    pub kind: String,
    /// Start address.
    pub address: u32,
    /// Size in bytes.
    pub size: u32,
}

/// An item of the file that the table leaves out, and why.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Skipped {
    /// The item's name.
    pub name: String,
    /// Why it is left out.
    pub why: String,
}

/// The parameter and measurement table of an A2L file (see the module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct A2l {
    /// The PROJECT's name.
    pub project: String,
    /// The (first) MODULE's name.
    pub module: String,
    /// Calibration parameters (`CHARACTERISTIC VALUE`), in file order.
    pub characteristics: Vec<Item>,
    /// Measurements, in file order.
    pub measurements: Vec<Item>,
    /// The memory segments.
    pub segments: Vec<Segment>,
    /// Items left out, with the reason.
    pub skipped: Vec<Skipped>,
    /// Parser warnings.
    pub warnings: Vec<String>,
}

impl A2l {
    /// Reads and parses `path`.
    ///
    /// # Errors
    /// The file cannot be read, is not a valid A2L file, or has no MODULE.
    pub fn load(path: &Path) -> std::result::Result<Self, A2lError> {
        let shown = path.display().to_string();
        let text = std::fs::read(path).map_err(|source| A2lError::Read {
            path: shown.clone(),
            source,
        })?;
        // A2L files are ASCII or UTF-8 in practice; Latin-1 bytes are taken as such.
        let text = match String::from_utf8(text) {
            Ok(t) => t,
            Err(e) => e.into_bytes().iter().map(|&b| char::from(b)).collect(),
        };
        Self::parse(&text, &shown)
    }

    /// Parses A2L text (`source` names it in messages).
    ///
    /// # Errors
    /// Not a valid A2L file, or no MODULE.
    pub fn parse(text: &str, source: &str) -> std::result::Result<Self, A2lError> {
        let (file, log) =
            a2lfile::load_from_string(text, None, false).map_err(|e| A2lError::Parse {
                path: source.to_string(),
                message: e.to_string(),
            })?;
        let module = file
            .project
            .module
            .first()
            .ok_or_else(|| A2lError::NoModule {
                path: source.to_string(),
            })?;
        let default_endian = module
            .mod_common
            .as_ref()
            .and_then(|c| c.byte_order.as_ref())
            .map_or(Some(Endian::Little), |b| endian(&b.byte_order));
        let mut out = A2l {
            project: file.project.get_name().to_string(),
            module: module.get_name().to_string(),
            characteristics: Vec::new(),
            measurements: Vec::new(),
            segments: Vec::new(),
            skipped: Vec::new(),
            warnings: log.iter().map(ToString::to_string).collect(),
        };
        let conversions: BTreeMap<&str, (Conversion, String)> = module
            .compu_method
            .iter()
            .map(|m| (m.get_name(), (conversion(m), m.unit.clone())))
            .collect();
        let lookup = |name: &str| -> (Conversion, String) {
            if name == "NO_COMPU_METHOD" {
                return (Conversion::Identical, String::new());
            }
            conversions.get(name).cloned().unwrap_or_else(|| {
                (
                    Conversion::Unsupported(format!("`{name}` (no such COMPU_METHOD)")),
                    String::new(),
                )
            })
        };
        for c in module.characteristic.iter() {
            let name = c.get_name().to_string();
            let skip = |why: &str| Skipped {
                name: name.clone(),
                why: why.to_string(),
            };
            if c.characteristic_type != CharacteristicType::Value {
                out.skipped.push(skip("not a VALUE characteristic"));
                continue;
            }
            let Some(datatype) = module
                .record_layout
                .get(&c.deposit)
                .and_then(|r| r.fnc_values.as_ref())
                .and_then(|f| DataType::from_a2l(&f.datatype))
            else {
                out.skipped.push(skip(
                    "its RECORD_LAYOUT has no FNC_VALUES of a supported data type",
                ));
                continue;
            };
            let Some(item_endian) = c
                .byte_order
                .as_ref()
                .map_or(default_endian, |b| endian(&b.byte_order))
            else {
                out.skipped.push(skip("unsupported BYTE_ORDER"));
                continue;
            };
            let Ok(extension) =
                u8::try_from(c.ecu_address_extension.as_ref().map_or(0, |e| e.extension))
            else {
                out.skipped.push(skip("address extension outside 0..=255"));
                continue;
            };
            let (conversion, method_unit) = lookup(&c.conversion);
            out.characteristics.push(Item {
                description: c.long_identifier.clone(),
                address: c.address,
                extension,
                datatype,
                endian: item_endian,
                conversion,
                min: c.lower_limit,
                max: c.upper_limit,
                unit: c.phys_unit.as_ref().map_or(method_unit, |u| u.unit.clone()),
                name,
            });
        }
        for m in module.measurement.iter() {
            let name = m.get_name().to_string();
            let skip = |why: &str| Skipped {
                name: name.clone(),
                why: why.to_string(),
            };
            let Some(address) = m.ecu_address.as_ref().map(|a| a.address) else {
                out.skipped.push(skip("no ECU_ADDRESS"));
                continue;
            };
            if m.array_size.is_some() || m.matrix_dim.is_some() {
                out.skipped.push(skip("arrays are not supported"));
                continue;
            }
            if m.bit_mask.is_some() {
                out.skipped.push(skip("bit masks are not supported"));
                continue;
            }
            let Some(datatype) = DataType::from_a2l(&m.datatype) else {
                out.skipped.push(skip("unsupported data type"));
                continue;
            };
            let Some(item_endian) = m
                .byte_order
                .as_ref()
                .map_or(default_endian, |b| endian(&b.byte_order))
            else {
                out.skipped.push(skip("unsupported BYTE_ORDER"));
                continue;
            };
            let Ok(extension) =
                u8::try_from(m.ecu_address_extension.as_ref().map_or(0, |e| e.extension))
            else {
                out.skipped.push(skip("address extension outside 0..=255"));
                continue;
            };
            let (conversion, method_unit) = lookup(&m.conversion);
            out.measurements.push(Item {
                description: m.long_identifier.clone(),
                address,
                extension,
                datatype,
                endian: item_endian,
                conversion,
                min: m.lower_limit,
                max: m.upper_limit,
                unit: m.phys_unit.as_ref().map_or(method_unit, |u| u.unit.clone()),
                name,
            });
        }
        if let Some(par) = &module.mod_par {
            for s in par.memory_segment.iter() {
                out.segments.push(Segment {
                    name: s.get_name().to_string(),
                    kind: format!("{:?}", s.prg_type),
                    address: s.address,
                    size: s.size,
                });
            }
        }
        Ok(out)
    }

    /// The calibration parameter `name`.
    ///
    /// # Errors
    /// [`Error::UnknownName`] with the closest name.
    pub fn characteristic(&self, name: &str) -> Result<&Item> {
        find(&self.characteristics, name, "CHARACTERISTIC")
    }

    /// The measurement `name`.
    ///
    /// # Errors
    /// [`Error::UnknownName`] with the closest name.
    pub fn measurement(&self, name: &str) -> Result<&Item> {
        find(&self.measurements, name, "MEASUREMENT")
    }
}

fn find<'a>(items: &'a [Item], name: &str, kind: &'static str) -> Result<&'a Item> {
    if let Some(item) = items.iter().find(|i| i.name == name) {
        return Ok(item);
    }
    let suggestion = items
        .iter()
        .map(|i| (edit_distance(&i.name, name), &i.name))
        .filter(|(d, n)| *d <= (n.len().max(name.len()) / 3).max(2))
        .min()
        .map(|(_, n)| n.clone());
    Err(Error::UnknownName {
        kind,
        name: name.to_string(),
        suggestion,
    })
}

/// Levenshtein distance (for "did you mean").
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut cur = vec![i + 1; b.len() + 1];
        for (j, cb) in b.iter().enumerate() {
            let cost = usize::from(ca != *cb);
            cur[j + 1] = (prev[j] + cost).min(prev[j + 1] + 1).min(cur[j] + 1);
        }
        prev = cur;
    }
    prev[b.len()]
}

fn endian(b: &ByteOrderEnum) -> Option<Endian> {
    match b {
        ByteOrderEnum::MsbLast | ByteOrderEnum::LittleEndian => Some(Endian::Little),
        ByteOrderEnum::MsbFirst | ByteOrderEnum::BigEndian => Some(Endian::Big),
        _ => None,
    }
}

fn conversion(m: &a2lfile::CompuMethod) -> Conversion {
    match m.conversion_type {
        ConversionType::Identical => Conversion::Identical,
        ConversionType::Linear => match &m.coeffs_linear {
            Some(c) if c.a != 0.0 && c.a.is_finite() && c.b.is_finite() => {
                Conversion::Linear { a: c.a, b: c.b }
            }
            _ => Conversion::Unsupported("LINEAR without usable COEFFS_LINEAR".into()),
        },
        ConversionType::RatFunc => match &m.coeffs {
            // raw = (a x² + b x + c) / (d x² + e x + f), x physical: linear when a = d = e = 0.
            Some(k) if k.a == 0.0 && k.d == 0.0 && k.e == 0.0 && k.b != 0.0 && k.f != 0.0 => {
                Conversion::Linear {
                    a: k.f / k.b,
                    b: -k.c / k.b,
                }
            }
            _ => Conversion::Unsupported("RAT_FUNC (non-linear)".into()),
        },
        ref other => Conversion::Unsupported(format!("{other:?}")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn encodings_round_trip_and_refuse_what_does_not_fit() {
        for (t, v) in [
            (DataType::U8, 200.0),
            (DataType::I8, -100.0),
            (DataType::U16, 60000.0),
            (DataType::I16, -30000.0),
            (DataType::U32, 4e9),
            (DataType::I32, -2e9),
            (DataType::F32, 0.1f32 as f64),
            (DataType::F64, 0.1),
        ] {
            for e in [Endian::Little, Endian::Big] {
                let b = t.encode(v, e).unwrap();
                assert_eq!(b.len(), t.size());
                assert_eq!(t.decode(&b, e), v, "{t:?} {e:?}");
            }
        }
        assert_eq!(
            DataType::U16.encode(0x1234 as f64, Endian::Big).unwrap(),
            vec![0x12, 0x34]
        );
        assert!(DataType::U8.encode(256.0, Endian::Little).is_err());
        assert!(DataType::U8.encode(1.5, Endian::Little).is_err());
        assert!(DataType::F32.encode(1e39, Endian::Little).is_err());
        assert!(DataType::F64.encode(f64::NAN, Endian::Little).is_err());
    }

    #[test]
    fn closest_name_is_suggested() {
        assert_eq!(edit_distance("tyre_stifness", "tyre_stiffness"), 1);
        assert_eq!(edit_distance("", "abc"), 3);
        assert_eq!(edit_distance("kitten", "sitting"), 3);
    }
}
