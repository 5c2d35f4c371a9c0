//! The generated A2L file, parsed by an independent parser (the `a2lfile` crate, strict),
//! against the ELF it was made from and the firmware's tables: every characteristic and
//! measurement at its symbol's address plus 4 × its slot, with the table's limits.
//!
//! The ELF here is a small object file written with the `object` crate holding the two
//! statics' symbols under their mangled Rust names at known addresses (the real firmware
//! ELF holds them once the XCP path uses them).

use mil_a2l::{generate, layout, Error, Layout};
use mil_firmware::calibration::{item, MEASUREMENT_BYTES, MEAS_ITEMS, PAGE_BYTES, SLOTS};
use object::write::{Object, StandardSection, Symbol, SymbolSection};
use object::{Architecture, BinaryFormat, Endianness, SymbolFlags, SymbolKind, SymbolScope};

/// Legacy-mangled names of the statics (with a made-up hash, as rustc appends one).
const WORKING: &str = "_ZN12mil_firmware11calibration7WORKING17h0123456789abcdefE";
const MEASUREMENT: &str = "_ZN12mil_firmware11calibration11MEASUREMENT17hfedcba9876543210E";

/// An ELF object with `symbols` (mangled name, address, size) in its data section.
fn elf(symbols: &[(&str, u64, u64)]) -> Vec<u8> {
    let mut obj = Object::new(BinaryFormat::Elf, Architecture::Arm, Endianness::Little);
    let data = obj.section_id(StandardSection::Data);
    obj.append_section_data(data, &[0u8; 1024], 4);
    for &(name, value, size) in symbols {
        obj.add_symbol(Symbol {
            name: name.as_bytes().to_vec(),
            value,
            size,
            kind: SymbolKind::Data,
            scope: SymbolScope::Compilation,
            weak: false,
            section: SymbolSection::Section(data),
            flags: SymbolFlags::None,
        });
    }
    obj.write().expect("write the object")
}

fn firmware_like_elf() -> Vec<u8> {
    elf(&[
        (WORKING, 0x2000_0100, PAGE_BYTES as u64),
        (MEASUREMENT, 0x2000_2000, MEASUREMENT_BYTES as u64),
        // Unrelated symbols are ignored.
        ("_ZN4core3fmt5write17h1111111111111111E", 0x0800_1000, 0x40),
    ])
}

#[test]
fn every_address_and_limit_matches_the_elf_and_the_tables() {
    let l: Layout = layout(&firmware_like_elf()).expect("layout");
    assert_eq!(l.calibration.address, 0x2000_0100);
    assert_eq!(l.measurement.address, 0x2000_2000);
    let text = generate(&l, "test");
    let (a2l, log) = a2lfile::load_from_string(&text, None, true)
        .unwrap_or_else(|e| panic!("a2lfile refuses the generated file: {e}\n{text}"));
    assert!(log.is_empty(), "parser warnings: {log:?}");
    let module = &a2l.project.module[0];
    assert_eq!(module.characteristic.len(), SLOTS);
    assert_eq!(module.measurement.len(), MEAS_ITEMS.len());
    for slot in 0..SLOTS {
        let item = item(slot).unwrap();
        let name = item.to_string();
        let c = module
            .characteristic
            .get(&name)
            .unwrap_or_else(|| panic!("characteristic {name} missing"));
        assert_eq!(c.address, 0x2000_0100 + 4 * slot as u32, "{name}");
        assert_eq!(c.lower_limit, f64::from(item.min), "{name}");
        assert_eq!(c.upper_limit, f64::from(item.max), "{name}");
        assert_eq!(c.long_identifier, item.description);
    }
    // Grouped by model, the configuration (model kind, channels, rate) first.
    use a2lfile::A2lObjectName;
    let groups: Vec<&str> = module.group.iter().map(|g| g.get_name()).collect();
    for g in [
        "configuration",
        "tyre",
        "aero",
        "substructure",
        "element",
        "filter",
        "limits",
    ] {
        assert!(groups.contains(&g), "group {g} missing: {groups:?}");
    }
    for (slot, item) in MEAS_ITEMS.iter().enumerate() {
        let m = module
            .measurement
            .get(item.name)
            .unwrap_or_else(|| panic!("measurement {} missing", item.name));
        let address = m.ecu_address.as_ref().map(|a| a.address);
        assert_eq!(
            address,
            Some(0x2000_2000 + 4 * slot as u32),
            "{}",
            item.name
        );
        assert_eq!(m.lower_limit, f64::from(item.min), "{}", item.name);
        assert_eq!(m.upper_limit, f64::from(item.max), "{}", item.name);
    }
    // The XCP interface: valid against the file's own A2ML, with the build's CAN IDs.
    assert_eq!(module.if_data.len(), 1);
    let if_data = &module.if_data[0];
    assert!(if_data.ifdata_valid, "IF_DATA does not match the A2ML");
    let tree = format!("{:?}", if_data.ifdata_items);
    for wanted in [
        "CAN_ID_MASTER",
        "CAN_ID_SLAVE",
        "BAUDRATE",
        "PROTOCOL_LAYER",
    ] {
        assert!(tree.contains(wanted), "{wanted} missing in {tree}");
    }
    for id in [
        mil_firmware::config::XCP_COMMAND_ID,
        mil_firmware::config::XCP_RESPONSE_ID,
    ] {
        assert!(
            text.contains(&format!("0x{id:X}")),
            "CAN ID {id:#X} missing"
        );
    }
    // The check has teeth: a misspelt tag does not match the A2ML.
    let broken = text.replace("CAN_ID_MASTER 0x", "CAN_ID_MASTR 0x");
    let (broken, _) = a2lfile::load_from_string(&broken, None, false).expect("lenient parse");
    assert!(!broken.project.module[0].if_data[0].ifdata_valid);
    // The memory segments span the two blocks.
    let segments = &module.mod_par.as_ref().expect("MOD_PAR").memory_segment;
    let spans: Vec<(u32, u32)> = segments.iter().map(|s| (s.address, s.size)).collect();
    assert!(
        spans.contains(&(0x2000_0100, PAGE_BYTES as u32)),
        "{spans:?}"
    );
    assert!(
        spans.contains(&(0x2000_2000, MEASUREMENT_BYTES as u32)),
        "{spans:?}"
    );
}

#[test]
fn a_missing_or_resized_symbol_is_refused() {
    let only_working = elf(&[(WORKING, 0x2000_0100, PAGE_BYTES as u64)]);
    assert!(matches!(
        layout(&only_working),
        Err(Error::MissingSymbol(s)) if s.ends_with("MEASUREMENT")
    ));
    let resized = elf(&[
        (WORKING, 0x2000_0100, PAGE_BYTES as u64 - 4),
        (MEASUREMENT, 0x2000_2000, MEASUREMENT_BYTES as u64),
    ]);
    assert!(matches!(
        layout(&resized),
        Err(Error::SizeMismatch { found, .. }) if found == PAGE_BYTES as u64 - 4
    ));
    assert!(matches!(layout(b"not an elf"), Err(Error::Elf(_))));
}
