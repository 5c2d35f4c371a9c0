//! `mil check`: any of the project's files validated exactly as the commands that read it do.

use anyhow::Result;
use std::path::PathBuf;

/// The arguments of `mil check`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The file.
    pub file: PathBuf,
    /// For a record: the structure whose input and output columns it must hold.
    #[arg(long, value_name = "STRUCTURE")]
    pub against: Option<PathBuf>,
}

/// Runs `mil check`.
///
/// # Errors
/// What the command refuses or fails on, one line naming it.
pub fn run(args: Args) -> Result<()> {
    let Args { file, against } = args;
    outln!("{}", crate::check::check(&file, against.as_deref())?);
    Ok(())
}
