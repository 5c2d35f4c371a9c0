//! 1. Writes `$OUT_DIR/xcp_build.rs`, the build-time XCP settings included by
//!    `config.rs`: the XCP CAN IDs and the seed & key secret (see below).
//! 2. For the bare-metal target only: puts the workspace's `memory.x` (the STM32F405RG
//!    memory map) on the linker's search path, where cortex-m-rt's `link.x` (passed as
//!    `-Tlink.x` in `.cargo/config.toml`) includes it, and links defmt's `defmt.x` into the
//!    board build's binary (the QEMU build has no defmt). The library part also builds for
//!    the host (unit tests).
//!
//! # Build-time XCP settings (environment variables)
//! - `MIL_XCP_CAN_IDS` = `CMD,RES` (hex with `0x` or decimal; default `0x7E0,0x7E1`): the
//!   standard 11-bit IDs of XCP commands (master → board) and of responses and DAQ packets
//!   (board → master). Both must lie above the MiL frame range (0x100..=0x13F), so that the
//!   measurement and demand frames win every arbitration on the bus, and differ.
//! - `MIL_XCP_SECRET`: the seed & key secret, at least 16 bytes, as text or as `hex:...`.
//!   Never commit one. Unset: the QEMU build (feature `qemu`, a test build that never
//!   reaches a rig) uses the public test secret of `mil-xcp`'s mock; the board build has
//!   no secret and then answers no XCP command at all (a warning says so).

use std::path::PathBuf;
use std::{env, fs};

/// The MiL frame range (the DBC's base ID 0x100 and its 64 IDs).
const MIL_RANGE: (u16, u16) = (0x100, 0x13F);
/// `mil_xcp::mock::TEST_SECRET`: public, for the QEMU test build only.
const QEMU_TEST_SECRET: &str = "FAKE-TEST-SECRET-do-not-use-0000";

fn parse_id(text: &str) -> Result<u16, String> {
    let t = text.trim();
    let value = match t.strip_prefix("0x").or_else(|| t.strip_prefix("0X")) {
        Some(hex) => u16::from_str_radix(hex, 16),
        None => t.parse::<u16>(),
    };
    value.map_err(|e| format!("`{t}` is not a CAN ID ({e})"))
}

fn xcp_ids() -> Result<(u16, u16), String> {
    let Ok(text) = env::var("MIL_XCP_CAN_IDS") else {
        return Ok((0x7E0, 0x7E1));
    };
    let mut parts = text.split(',');
    let (Some(cmd), Some(res), None) = (parts.next(), parts.next(), parts.next()) else {
        return Err(format!("MIL_XCP_CAN_IDS=`{text}`: expected `CMD,RES`"));
    };
    let (cmd, res) = (parse_id(cmd)?, parse_id(res)?);
    for id in [cmd, res] {
        if id > 0x7FF {
            return Err(format!("MIL_XCP_CAN_IDS: {id:#x} is not an 11-bit ID"));
        }
        if id <= MIL_RANGE.1 {
            return Err(format!(
                "MIL_XCP_CAN_IDS: {id:#x} must lie above the MiL frames ({:#x}..={:#x}) so that they keep priority on the bus",
                MIL_RANGE.0, MIL_RANGE.1
            ));
        }
    }
    if cmd == res {
        return Err("MIL_XCP_CAN_IDS: the command and response IDs must differ".into());
    }
    Ok((cmd, res))
}

fn secret() -> Result<Option<Vec<u8>>, String> {
    let bytes = match env::var("MIL_XCP_SECRET") {
        Ok(text) => match text.strip_prefix("hex:") {
            Some(hex) => {
                let hex = hex.trim();
                if hex.len() % 2 != 0 {
                    return Err("MIL_XCP_SECRET: odd number of hex digits".into());
                }
                (0..hex.len() / 2)
                    .map(|i| u8::from_str_radix(&hex[2 * i..2 * i + 2], 16))
                    .collect::<Result<Vec<u8>, _>>()
                    .map_err(|e| format!("MIL_XCP_SECRET: bad hex ({e})"))?
            }
            None => text.into_bytes(),
        },
        Err(_) if env::var_os("CARGO_FEATURE_QEMU").is_some() => {
            QEMU_TEST_SECRET.as_bytes().to_vec()
        }
        Err(_) => return Ok(None),
    };
    if bytes.len() < 16 {
        return Err(format!(
            "MIL_XCP_SECRET: {} bytes, at least 16 are needed",
            bytes.len()
        ));
    }
    Ok(Some(bytes))
}

fn write_xcp_settings(out_dir: &std::path::Path) {
    println!("cargo:rerun-if-env-changed=MIL_XCP_CAN_IDS");
    println!("cargo:rerun-if-env-changed=MIL_XCP_SECRET");
    let (cmd, res) = xcp_ids().unwrap_or_else(|e| panic!("{e}"));
    let secret = secret().unwrap_or_else(|e| panic!("{e}"));
    let bare_metal = env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("none");
    if secret.is_none() && bare_metal {
        println!(
            "cargo:warning=MIL_XCP_SECRET is not set: this board build answers no XCP command (no calibration or measurement over XCP)"
        );
    }
    let secret = match secret {
        Some(bytes) => format!("Some(&{bytes:?})"),
        None => "None".to_string(),
    };
    let text = format!(
        "/// CAN ID of XCP commands, master → board (build-time `MIL_XCP_CAN_IDS`).\n\
         pub const XCP_COMMAND_ID: u16 = {cmd:#x};\n\
         /// CAN ID of XCP responses and DAQ packets, board → master (build-time `MIL_XCP_CAN_IDS`).\n\
         pub const XCP_RESPONSE_ID: u16 = {res:#x};\n\
         /// The seed & key secret (build-time `MIL_XCP_SECRET`); `None`: XCP is off.\n\
         pub const XCP_SECRET: Option<&[u8]> = {secret};\n"
    );
    let path = out_dir.join("xcp_build.rs");
    // Rewritten only when it changes, so an unchanged setting rebuilds nothing.
    if fs::read_to_string(&path).ok().as_deref() != Some(text.as_str()) {
        if let Err(e) = fs::write(&path, text) {
            panic!("cannot write {}: {e}", path.display());
        }
    }
}

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    let out_dir = PathBuf::from(env::var_os("OUT_DIR").unwrap_or_default());
    write_xcp_settings(&out_dir);
    if env::var("CARGO_CFG_TARGET_OS").as_deref() != Ok("none") {
        return;
    }
    let manifest_dir = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").unwrap_or_default());
    let memory_x = manifest_dir.join("../../memory.x");
    if let Err(e) = fs::copy(&memory_x, out_dir.join("memory.x")) {
        panic!("cannot copy {} to OUT_DIR: {e}", memory_x.display());
    }
    println!("cargo:rustc-link-search={}", out_dir.display());
    println!("cargo:rerun-if-changed={}", memory_x.display());
    if env::var_os("CARGO_FEATURE_QEMU").is_none() {
        println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
    }
}
