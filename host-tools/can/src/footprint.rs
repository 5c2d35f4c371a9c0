//! Flash and static RAM of a Cortex-M firmware, read from its ELF section headers (32-bit,
//! little-endian ELF as `thumbv7em-none-eabihf` links it; no tools needed).
//!
//! - **Flash**: every allocated section with contents (`SHF_ALLOC`, not `SHT_NOBITS`): the
//!   vector table, `.text`, `.rodata` and the initial values of `.data`, which cortex-m-rt
//!   copies from flash to RAM at start-up.
//! - **Static RAM**: every allocated section whose address lies in the Cortex-M SRAM region
//!   (0x2000_0000 to 0x3FFF_FFFF): `.data`, `.bss`, `.uninit`. The stack is not a section:
//!   it takes the rest of RAM (its use is measured at run time by stack painting).
//!
//! The same split as `llvm-size -A` or `arm-none-eabi-size` with their section list.

/// Section flag: occupies memory at run time.
const SHF_ALLOC: u32 = 0x2;
/// Section type: no contents in the file (`.bss`, `.uninit`).
const SHT_NOBITS: u32 = 8;
/// The Cortex-M SRAM region.
const SRAM: std::ops::Range<u64> = 0x2000_0000..0x4000_0000;

/// One allocated section.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Section {
    /// Section name (e.g. `.text`).
    pub name: String,
    /// Run-time address.
    pub address: u32,
    /// Size in bytes.
    pub size: u32,
    /// Its contents are stored in flash.
    pub in_flash: bool,
    /// It occupies RAM at run time.
    pub in_ram: bool,
}

/// Memory use of a firmware ELF.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Footprint {
    /// Bytes of flash (sections with contents).
    pub flash: u64,
    /// Bytes of statically allocated RAM (sections in the SRAM region).
    pub static_ram: u64,
    /// The allocated sections, in file order (empty ones included).
    pub sections: Vec<Section>,
}

fn u16_at(b: &[u8], at: usize) -> Option<u16> {
    Some(u16::from_le_bytes(b.get(at..at + 2)?.try_into().ok()?))
}

fn u32_at(b: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_le_bytes(b.get(at..at + 4)?.try_into().ok()?))
}

/// Reads the footprint of a 32-bit little-endian ELF file's contents.
///
/// # Errors
/// Not a 32-bit little-endian ELF file, or its section headers lie outside the file.
pub fn footprint(elf: &[u8]) -> Result<Footprint, String> {
    if elf.get(..4) != Some(b"\x7fELF".as_slice()) {
        return Err("not an ELF file".into());
    }
    if elf.get(4) != Some(&1) || elf.get(5) != Some(&1) {
        return Err("not a 32-bit little-endian ELF file (as thumbv7em links)".into());
    }
    let bad = || "truncated ELF header or section table".to_string();
    let shoff = u32_at(elf, 0x20).ok_or_else(bad)? as usize;
    let shentsize = usize::from(u16_at(elf, 0x2E).ok_or_else(bad)?);
    let shnum = usize::from(u16_at(elf, 0x30).ok_or_else(bad)?);
    let shstrndx = usize::from(u16_at(elf, 0x32).ok_or_else(bad)?);
    if shentsize < 40 {
        return Err(format!("section header size {shentsize} (expected 40)"));
    }
    let header = |i: usize| -> Result<[u32; 6], String> {
        let at = shoff + i * shentsize;
        let mut h = [0u32; 6];
        for (k, v) in h.iter_mut().enumerate() {
            *v = u32_at(elf, at + 4 * k).ok_or_else(bad)?;
        }
        Ok(h)
    };
    // [name, type, flags, addr, offset, size]
    let names = header(shstrndx)?;
    let name_of = |offset: u32| -> String {
        let start = names[4] as usize + offset as usize;
        let tail = elf.get(start..).unwrap_or(&[]);
        let end = tail.iter().position(|&c| c == 0).unwrap_or(tail.len());
        String::from_utf8_lossy(&tail[..end]).into_owned()
    };
    let mut sections = Vec::new();
    for i in 0..shnum {
        let [name, kind, flags, address, _, size] = header(i)?;
        if flags & SHF_ALLOC == 0 {
            continue;
        }
        sections.push(Section {
            name: name_of(name),
            address,
            size,
            in_flash: kind != SHT_NOBITS,
            in_ram: SRAM.contains(&u64::from(address)),
        });
    }
    let sum = |f: fn(&Section) -> bool| {
        sections
            .iter()
            .filter(|s| f(s))
            .map(|s| u64::from(s.size))
            .sum()
    };
    Ok(Footprint {
        flash: sum(|s| s.in_flash),
        static_ram: sum(|s| s.in_ram),
        sections,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A minimal ELF32 LE with the given (name, type, flags, address, size) sections after
    /// the null section and the section-name table.
    fn elf(sections: &[(&str, u32, u32, u32, u32)]) -> Vec<u8> {
        let mut strtab = vec![0u8];
        let mut name_offsets = Vec::new();
        for (name, ..) in sections {
            name_offsets.push(strtab.len() as u32);
            strtab.extend_from_slice(name.as_bytes());
            strtab.push(0);
        }
        let shstrtab_name = strtab.len() as u32;
        strtab.extend_from_slice(b".shstrtab\0");
        let strtab_at = 52u32;
        let shoff = strtab_at + strtab.len() as u32;
        let mut b = vec![0u8; 52];
        b[..6].copy_from_slice(b"\x7fELF\x01\x01");
        b[0x20..0x24].copy_from_slice(&shoff.to_le_bytes());
        b[0x2E..0x30].copy_from_slice(&40u16.to_le_bytes());
        let shnum = sections.len() as u16 + 2;
        b[0x30..0x32].copy_from_slice(&shnum.to_le_bytes());
        b[0x32..0x34].copy_from_slice(&(shnum - 1).to_le_bytes());
        b.extend_from_slice(&strtab);
        let mut header = |h: [u32; 10]| {
            for v in h {
                b.extend_from_slice(&v.to_le_bytes());
            }
        };
        header([0; 10]);
        for ((_, kind, flags, address, size), name) in sections.iter().zip(&name_offsets) {
            header([*name, *kind, *flags, *address, 0, *size, 0, 0, 4, 0]);
        }
        header([
            shstrtab_name,
            3,
            0,
            0,
            strtab_at,
            strtab.len() as u32,
            0,
            0,
            1,
            0,
        ]);
        b
    }

    #[test]
    fn flash_and_ram_as_llvm_size_counts_them() {
        let progbits = 1;
        let image = elf(&[
            (".vector_table", progbits, SHF_ALLOC, 0x0800_0000, 392),
            (".text", progbits, SHF_ALLOC | 0x4, 0x0800_0188, 50_000),
            (".rodata", progbits, SHF_ALLOC, 0x0800_C538, 6_000),
            (".data", progbits, SHF_ALLOC | 0x1, 0x2000_0000, 24),
            (".bss", SHT_NOBITS, SHF_ALLOC | 0x1, 0x2000_0018, 148),
            (".uninit", SHT_NOBITS, SHF_ALLOC | 0x1, 0x2000_00AC, 680),
            (".debug_info", progbits, 0, 0, 400_000),
        ]);
        let f = footprint(&image).unwrap();
        assert_eq!(f.flash, 392 + 50_000 + 6_000 + 24);
        assert_eq!(f.static_ram, 24 + 148 + 680);
        let names: Vec<_> = f.sections.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(
            names,
            [
                ".vector_table",
                ".text",
                ".rodata",
                ".data",
                ".bss",
                ".uninit"
            ]
        );
    }

    #[test]
    fn refuses_what_is_not_an_elf32_le() {
        assert!(footprint(b"hello").is_err());
        assert!(footprint(b"\x7fELF\x02\x01").is_err());
        let mut truncated = elf(&[]);
        truncated.truncate(60);
        assert!(footprint(&truncated).is_err());
    }
}
