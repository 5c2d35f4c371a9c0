//! Puts the workspace's `memory.x` (the STM32F405RG memory map) on the linker's search path,
//! where cortex-m-rt's `link.x` (passed as `-Tlink.x` in `.cargo/config.toml`) includes it,
//! and links defmt's `defmt.x` into the board build's binary (the QEMU build has no defmt).
//! Only for the bare-metal target: the library part also builds for the host (unit tests).

use std::path::PathBuf;
use std::{env, fs};

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    if env::var("CARGO_CFG_TARGET_OS").as_deref() != Ok("none") {
        return;
    }
    let manifest_dir = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").unwrap_or_default());
    let memory_x = manifest_dir.join("../../memory.x");
    let out_dir = PathBuf::from(env::var_os("OUT_DIR").unwrap_or_default());
    if let Err(e) = fs::copy(&memory_x, out_dir.join("memory.x")) {
        panic!("cannot copy {} to OUT_DIR: {e}", memory_x.display());
    }
    println!("cargo:rustc-link-search={}", out_dir.display());
    println!("cargo:rerun-if-changed={}", memory_x.display());
    if env::var_os("CARGO_FEATURE_QEMU").is_none() {
        println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
    }
}
