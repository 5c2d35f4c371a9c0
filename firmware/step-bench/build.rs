//! Puts the workspace's `memory.x` (the STM32F405RG memory map) on the linker's search path,
//! where cortex-m-rt's `link.x` (passed as `-Tlink.x` in `.cargo/config.toml`) includes it.

use std::path::PathBuf;
use std::{env, fs};

fn main() {
    let manifest_dir = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").unwrap_or_default());
    let memory_x = manifest_dir.join("../../memory.x");
    let out_dir = PathBuf::from(env::var_os("OUT_DIR").unwrap_or_default());
    if let Err(e) = fs::copy(&memory_x, out_dir.join("memory.x")) {
        panic!("cannot copy {} to OUT_DIR: {e}", memory_x.display());
    }
    println!("cargo:rustc-link-search={}", out_dir.display());
    println!("cargo:rerun-if-changed={}", memory_x.display());
    println!("cargo:rerun-if-changed=build.rs");
}
