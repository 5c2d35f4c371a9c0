//! # mil-a2l
//!
//! The A2L file (ASAM MCD-2 MC, ASAP2 1.71) of the MiL board, generated from the firmware's
//! own tables and the linked ELF, so that CANape, INCA or pyxcp find every parameter and
//! signal where the firmware keeps it:
//! - one `CHARACTERISTIC` (`VALUE`, `FLOAT32_IEEE`) per calibration slot of
//!   `mil_firmware::calibration::ITEMS`, at the address of the working page
//!   (`mil_firmware::calibration::WORKING`) plus 4 × its slot, with the item's limits (the
//!   firmware refuses values outside them) and unit;
//! - one `MEASUREMENT` (`FLOAT32_IEEE` or `ULONG`) per slot of
//!   `mil_firmware::calibration::MEAS_ITEMS`, at `mil_firmware::calibration::MEASUREMENT`
//!   plus 4 × its slot;
//! - `MOD_PAR` with the two `MEMORY_SEGMENT`s (calibration data with a working and a
//!   reference page, measurement variables) and `MOD_COMMON` (Intel byte order);
//! - one `COMPU_METHOD` (`IDENTICAL`) per unit, one `RECORD_LAYOUT`;
//! - the XCP interface: `IF_DATA XCP` with `PROTOCOL_LAYER` and `XCP_ON_CAN` (the CAN IDs
//!   of the build, `MIL_XCP_CAN_IDS`, see `firmware/controller/build.rs`), described by the
//!   file's own `A2ML` ([`A2ML`], [`xcp_interface`]). The IDs come from the host build of
//!   `mil-firmware`'s tables: build the A2L with the same `MIL_XCP_CAN_IDS` as the firmware.
//!
//! The addresses come from the ELF's symbol table: the statics' symbols are found by their
//! demangled paths, so the firmware needs no `#[no_mangle]` (no `unsafe`). Build the ELF
//! with symbols (the release profile keeps them).

use std::collections::BTreeMap;
use std::fmt::Write as _;

use mil_firmware::calibration::{
    item, CalItem, MeasItem, MEASUREMENT_BYTES, MEAS_ITEMS, PAGE_BYTES, SLOTS,
};
use object::{Object, ObjectSymbol};

/// Demangled path of the working calibration page's static.
pub const WORKING_SYMBOL: &str = "mil_firmware::calibration::WORKING";
/// Demangled path of the measurement block's static.
pub const MEASUREMENT_SYMBOL: &str = "mil_firmware::calibration::MEASUREMENT";

/// Errors of the generator.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The file is not an ELF object the reader understands.
    #[error("not a readable ELF file: {0}")]
    Elf(String),
    /// A symbol the A2L needs is not in the ELF's symbol table.
    #[error(
        "symbol `{0}` not found in the ELF (a firmware built without it, or stripped of symbols)"
    )]
    MissingSymbol(&'static str),
    /// A symbol's size differs from the firmware table's (the ELF and the tables come from
    /// different builds).
    #[error("symbol `{name}` is {found} bytes in the ELF, the firmware's tables say {expected}")]
    SizeMismatch {
        /// The symbol.
        name: &'static str,
        /// Its size in the ELF (bytes).
        found: u64,
        /// The size the tables give (bytes).
        expected: u64,
    },
    /// An address does not fit XCP's 32-bit addresses.
    #[error("symbol `{0}` lies above 4 GiB")]
    AddressRange(&'static str),
}

/// Where a block lives in the target's memory.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Block {
    /// Start address.
    pub address: u32,
    /// Size (bytes).
    pub size: u32,
}

/// The two blocks the A2L file points into.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layout {
    /// The working calibration page.
    pub calibration: Block,
    /// The measurement block.
    pub measurement: Block,
}

/// The symbols of an ELF image: demangled path (without hash) → (address, size).
///
/// # Errors
/// The bytes are not a readable ELF file.
pub fn symbols(elf: &[u8]) -> Result<BTreeMap<String, (u64, u64)>, Error> {
    let file = object::File::parse(elf).map_err(|e| Error::Elf(e.to_string()))?;
    let mut out = BTreeMap::new();
    for sym in file.symbols() {
        let Ok(name) = sym.name() else { continue };
        let path = format!("{:#}", rustc_demangle::demangle(name));
        out.insert(path, (sym.address(), sym.size()));
    }
    Ok(out)
}

/// Finds the working page and the measurement block in `elf`, checking their sizes against
/// the firmware's tables.
///
/// # Errors
/// Not an ELF file, a symbol missing, a size or an address that does not fit.
pub fn layout(elf: &[u8]) -> Result<Layout, Error> {
    let syms = symbols(elf)?;
    let block = |name: &'static str, expected: usize| -> Result<Block, Error> {
        let &(address, size) = syms.get(name).ok_or(Error::MissingSymbol(name))?;
        if size != expected as u64 {
            return Err(Error::SizeMismatch {
                name,
                found: size,
                expected: expected as u64,
            });
        }
        Ok(Block {
            address: u32::try_from(address).map_err(|_| Error::AddressRange(name))?,
            size: u32::try_from(size).map_err(|_| Error::AddressRange(name))?,
        })
    };
    Ok(Layout {
        calibration: block(WORKING_SYMBOL, PAGE_BYTES)?,
        measurement: block(MEASUREMENT_SYMBOL, MEASUREMENT_BYTES)?,
    })
}

/// A2L-safe identifier for a unit's conversion method (`N*s/m` → `cm_N_s_per_m`).
fn compu_method_name(unit: &str) -> String {
    if unit == "-" {
        return "cm_none".into();
    }
    let mut s = String::from("cm_");
    for c in unit.chars() {
        match c {
            'a'..='z' | 'A'..='Z' | '0'..='9' => s.push(c),
            '/' => s.push_str("_per_"),
            _ => s.push('_'),
        }
    }
    s
}

/// A number as A2L writes it (shortest exact form; A2L takes exponents).
fn number(v: f32) -> String {
    let v = f64::from(v);
    if v == v.trunc() && v.abs() < 1e15 {
        format!("{v:.0}")
    } else {
        format!("{v:e}")
    }
}

/// A string literal for A2L (`"` and `\` escaped with a backslash).
fn quoted(s: &str) -> String {
    format!("\"{}\"", s.replace('\\', "\\\\").replace('"', "\\\""))
}

/// The calibration item's address in `layout`.
pub fn characteristic_address(layout: &Layout, slot: usize) -> u32 {
    layout.calibration.address + 4 * slot as u32
}

/// The measurement's address in `layout`.
pub fn measurement_address(layout: &Layout, slot: usize) -> u32 {
    layout.measurement.address + 4 * slot as u32
}

/// The A2L text for `layout` (see the crate documentation); `version` goes into the header
/// (e.g. the firmware's version and commit).
pub fn generate(layout: &Layout, version: &str) -> String {
    let items: Vec<(usize, CalItem)> = (0..SLOTS).filter_map(|s| item(s).map(|i| (s, i))).collect();
    let mut units: BTreeMap<String, &str> = BTreeMap::new();
    for unit in items
        .iter()
        .map(|(_, i)| i.unit)
        .chain(MEAS_ITEMS.iter().map(|m| m.unit))
    {
        units.insert(compu_method_name(unit), unit);
    }
    let mut a = String::new();
    let w = &mut a;
    let _ = writeln!(w, "ASAP2_VERSION 1 71");
    let _ = writeln!(
        w,
        "/begin PROJECT mil \"Model-in-the-loop board: tyre (1-4 hubs), aero (2 channels) or substructure (1-4 channels), chosen by model_kind\""
    );
    let _ = writeln!(
        w,
        "  /begin HEADER \"generated by mil-a2l from the firmware's tables and its ELF\"\n    VERSION {}\n  /end HEADER",
        quoted(version)
    );
    let _ = writeln!(
        w,
        "  /begin MODULE mil_firmware \"calibration parameters and measurements\""
    );
    let _ = writeln!(
        w,
        "    /begin MOD_COMMON \"\"\n      BYTE_ORDER MSB_LAST\n      ALIGNMENT_BYTE 1\n      ALIGNMENT_WORD 2\n      ALIGNMENT_LONG 4\n      ALIGNMENT_FLOAT32_IEEE 4\n    /end MOD_COMMON"
    );
    w.push_str(A2ML);
    let _ = writeln!(w, "    /begin MOD_PAR \"STM32F405\"");
    let _ = writeln!(
        w,
        "      /begin MEMORY_SEGMENT calibration \"working page 0 (RAM), reference page 1 (flash, read-only)\"\n        DATA RAM INTERN 0x{:08X} 0x{:X} -1 -1 -1 -1 -1\n      /end MEMORY_SEGMENT",
        layout.calibration.address, layout.calibration.size
    );
    let _ = writeln!(
        w,
        "      /begin MEMORY_SEGMENT measurement \"signals, stored once per control step\"\n        VARIABLES RAM INTERN 0x{:08X} 0x{:X} -1 -1 -1 -1 -1\n      /end MEMORY_SEGMENT",
        layout.measurement.address, layout.measurement.size
    );
    let _ = writeln!(w, "    /end MOD_PAR");
    for (name, unit) in &units {
        let _ = writeln!(
            w,
            "    /begin COMPU_METHOD {name} \"{}\"\n      IDENTICAL \"%.6\" {}\n    /end COMPU_METHOD",
            if *unit == "-" { "no unit" } else { "physical value" },
            quoted(if *unit == "-" { "" } else { unit })
        );
    }
    let _ = writeln!(
        w,
        "    /begin RECORD_LAYOUT rl_float32\n      FNC_VALUES 1 FLOAT32_IEEE COLUMN_DIR DIRECT\n    /end RECORD_LAYOUT"
    );
    for (slot, item) in &items {
        characteristic(w, layout, *slot, item);
    }
    groups(w, &items);
    for (slot, item) in MEAS_ITEMS.iter().enumerate() {
        measurement(w, layout, slot, item);
    }
    w.push_str(&xcp_interface());
    let _ = writeln!(w, "  /end MODULE");
    let _ = writeln!(w, "/end PROJECT");
    a
}

/// The A2ML (the IF_DATA grammar) for the XCP interface description this file carries: the
/// part of ASAM MCD-1 XCP's A2ML that [`xcp_interface`] uses, in the standard's structure
/// (`IF_DATA XCP` holding `PROTOCOL_LAYER` and `XCP_ON_CAN` with its CAN parameters), so
/// that a tool reading the standard's layout reads the same values.
pub const A2ML: &str = r#"    /begin A2ML
      struct Protocol_Layer {
        uint;  /* XCP protocol layer version */
        uint;  /* T1 (ms) */
        uint;  /* T2 (ms) */
        uint;  /* T3 (ms) */
        uint;  /* T4 (ms) */
        uint;  /* T5 (ms) */
        uint;  /* T6 (ms) */
        uint;  /* T7 (ms) */
        uchar; /* MAX_CTO */
        uint;  /* MAX_DTO */
        enum {
          "BYTE_ORDER_MSB_LAST" = 0,
          "BYTE_ORDER_MSB_FIRST" = 1
        };
        enum {
          "ADDRESS_GRANULARITY_BYTE" = 1,
          "ADDRESS_GRANULARITY_WORD" = 2,
          "ADDRESS_GRANULARITY_DWORD" = 4
        };
        taggedstruct {
          ("OPTIONAL_CMD" enum {
            "GET_COMM_MODE_INFO" = 251,
            "GET_ID" = 250,
            "GET_SEED" = 248,
            "UNLOCK" = 247,
            "SHORT_UPLOAD" = 244,
            "DOWNLOAD_NEXT" = 239,
            "SET_CAL_PAGE" = 235,
            "GET_CAL_PAGE" = 234,
            "GET_PAG_PROCESSOR_INFO" = 233,
            "GET_SEGMENT_INFO" = 232,
            "GET_PAGE_INFO" = 231,
            "COPY_CAL_PAGE" = 228,
            "GET_DAQ_CLOCK" = 220,
            "GET_DAQ_PROCESSOR_INFO" = 218,
            "GET_DAQ_RESOLUTION_INFO" = 217,
            "GET_DAQ_EVENT_INFO" = 215,
            "FREE_DAQ" = 214,
            "ALLOC_DAQ" = 213,
            "ALLOC_ODT" = 212,
            "ALLOC_ODT_ENTRY" = 211
          })*;
          "SEED_AND_KEY_EXTERNAL_FUNCTION" char[256];
        };
      };
      struct CAN_Parameters {
        uint;  /* XCP on CAN version */
        taggedstruct {
          "CAN_ID_BROADCAST" ulong;
          "CAN_ID_MASTER" ulong;
          "CAN_ID_SLAVE" ulong;
          "BAUDRATE" ulong;
          "SAMPLE_POINT" uchar;
          "SAMPLE_RATE" enum {
            "SINGLE" = 1,
            "TRIPLE" = 3
          };
          "BTL_CYCLES" uchar;
          "SJW" uchar;
          "SYNC_EDGE" enum {
            "SINGLE" = 1,
            "DUAL" = 2
          };
          "MAX_DLC_REQUIRED";
        };
      };
      block "IF_DATA" taggedunion if_data {
        "XCP" struct {
          taggedstruct {
            block "PROTOCOL_LAYER" struct Protocol_Layer;
            (block "XCP_ON_CAN" struct {
              struct CAN_Parameters;
              taggedstruct {
                block "PROTOCOL_LAYER" struct Protocol_Layer;
              };
            })*;
          };
        };
      };
    /end A2ML
"#;

/// Bit rate of the board's CAN bus (bit/s).
pub const CAN_BAUDRATE: u32 = 1_000_000;

/// The module's `IF_DATA XCP`: protocol layer (XCP 1.0 protocol layer version 0x0100,
/// timeouts T1 = 1 s, T2 = 2 s, MAX_CTO = MAX_DTO = 8, Intel byte order, byte granularity,
/// the optional commands the board offers) and XCP on CAN (the build's command and response
/// IDs from `mil_firmware::config`, 1 Mbit/s, sample point 86 %, responses not padded).
pub fn xcp_interface() -> String {
    use mil_firmware::config::{XCP_COMMAND_ID, XCP_RESPONSE_ID};
    let optional = [
        "GET_COMM_MODE_INFO",
        "GET_ID",
        "GET_SEED",
        "UNLOCK",
        "SHORT_UPLOAD",
        "DOWNLOAD_NEXT",
        "SET_CAL_PAGE",
        "GET_CAL_PAGE",
        "GET_PAG_PROCESSOR_INFO",
        "GET_SEGMENT_INFO",
        "GET_PAGE_INFO",
        "COPY_CAL_PAGE",
        "GET_DAQ_CLOCK",
        "GET_DAQ_PROCESSOR_INFO",
        "GET_DAQ_RESOLUTION_INFO",
        "GET_DAQ_EVENT_INFO",
        "FREE_DAQ",
        "ALLOC_DAQ",
        "ALLOC_ODT",
        "ALLOC_ODT_ENTRY",
    ];
    let mut w = String::new();
    let _ = writeln!(w, "    /begin IF_DATA XCP");
    let _ = writeln!(w, "      /begin PROTOCOL_LAYER");
    let _ = writeln!(
        w,
        "        0x0100 1000 2000 0 0 0 0 0 8 8 BYTE_ORDER_MSB_LAST ADDRESS_GRANULARITY_BYTE"
    );
    for c in optional {
        let _ = writeln!(w, "        OPTIONAL_CMD {c}");
    }
    let _ = writeln!(w, "      /end PROTOCOL_LAYER");
    let _ = writeln!(w, "      /begin XCP_ON_CAN");
    let _ = writeln!(w, "        0x0100");
    let _ = writeln!(w, "        CAN_ID_MASTER 0x{XCP_COMMAND_ID:X}");
    let _ = writeln!(w, "        CAN_ID_SLAVE 0x{XCP_RESPONSE_ID:X}");
    let _ = writeln!(w, "        BAUDRATE {CAN_BAUDRATE}");
    let _ = writeln!(w, "        SAMPLE_POINT 86");
    let _ = writeln!(w, "      /end XCP_ON_CAN");
    let _ = writeln!(w, "    /end IF_DATA");
    w
}

/// One GROUP per item group (the settings and model selection, each model's parameters,
/// the filters, the limits), so that a calibration tool shows the page by model.
fn groups(w: &mut String, items: &[(usize, CalItem)]) {
    let mut by_group: BTreeMap<&str, Vec<String>> = BTreeMap::new();
    for (_, item) in items {
        let group = if item.group.is_empty() {
            "configuration"
        } else {
            item.group
        };
        by_group.entry(group).or_default().push(item.to_string());
    }
    for (group, names) in by_group {
        let _ = writeln!(
            w,
            "    /begin GROUP {group} {}\n      /begin REF_CHARACTERISTIC",
            quoted(&format!("{group} parameters"))
        );
        for name in names {
            let _ = writeln!(w, "        {name}");
        }
        let _ = writeln!(w, "      /end REF_CHARACTERISTIC\n    /end GROUP");
    }
}

fn characteristic(w: &mut String, layout: &Layout, slot: usize, item: &CalItem) {
    let _ = writeln!(
        w,
        "    /begin CHARACTERISTIC {} {}\n      VALUE 0x{:08X} rl_float32 0 {} {} {}\n      PHYS_UNIT {}\n    /end CHARACTERISTIC",
        item,
        quoted(item.description),
        characteristic_address(layout, slot),
        compu_method_name(item.unit),
        number(item.min),
        number(item.max),
        quoted(item.unit)
    );
}

fn measurement(w: &mut String, layout: &Layout, slot: usize, item: &MeasItem) {
    let _ = writeln!(
        w,
        "    /begin MEASUREMENT {} {}\n      {} {} 0 0 {} {}\n      ECU_ADDRESS 0x{:08X}\n      PHYS_UNIT {}\n    /end MEASUREMENT",
        item.name,
        quoted(item.description),
        if item.float { "FLOAT32_IEEE" } else { "ULONG" },
        compu_method_name(item.unit),
        number(item.min),
        number(item.max),
        measurement_address(layout, slot),
        quoted(item.unit)
    );
}
