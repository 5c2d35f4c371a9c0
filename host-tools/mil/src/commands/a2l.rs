//! `mil a2l`: the board's A2L file (parameters and measurements for CANape, INCA or pyxcp)
//! with the addresses of a firmware ELF.

use anyhow::Result;
use std::path::PathBuf;

/// The arguments of `mil a2l`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The linked firmware; default: the image under the build folder
    /// (target/thumbv7em-none-eabihf/release/mil-firmware, the one `mil sim --board qemu`
    /// runs).
    #[arg(long)]
    pub elf: Option<PathBuf>,
    /// The A2L file to write.
    #[arg(long, default_value = "out/mil.a2l")]
    pub out: PathBuf,
}

/// Runs `mil a2l`.
///
/// # Errors
/// What the command refuses or fails on, one line naming it.
pub fn run(args: Args) -> Result<()> {
    let Args { elf, out } = args;
    let elf = crate::cli::firmware_elf(elf)?;
    let bytes = std::fs::read(&elf).map_err(|e| anyhow::anyhow!("{}: {e}", elf.display()))?;
    let layout = mil_a2l::layout(&bytes).map_err(|e| anyhow::anyhow!("{}: {e}", elf.display()))?;
    let version = format!(
        "{} (ELF {})",
        env!("CARGO_PKG_VERSION"),
        elf.file_name().map_or("?".into(), |n| n.to_string_lossy())
    );
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)?;
    }
    let text = mil_a2l::generate(&layout, &version);
    crate::cli::write_atomic(&out, |w| Ok(std::io::Write::write_all(w, text.as_bytes())?))?;
    outln!(
        "{}: calibration page at 0x{:08X} ({} bytes), measurements at 0x{:08X} ({} bytes)",
        out.display(),
        layout.calibration.address,
        layout.calibration.size,
        layout.measurement.address,
        layout.measurement.size
    );
    Ok(())
}
