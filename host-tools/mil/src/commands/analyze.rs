//! `mil analyze`: the frequency-domain analysis of a MiL set-up (responses, margins,
//! resonances, band errors, noise sensitivity), its table and plots.

use anyhow::Result;
use std::path::PathBuf;

/// The arguments of `mil analyze`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The set-up and its command filter.
    #[command(flatten)]
    pub set_up: crate::cli::SetUpArgs,
    /// Output folder for the plots (SVG) and traces (CSV).
    #[arg(long, default_value = "out/analyze")]
    pub out: PathBuf,
    /// Print one JSON object with the figures instead of the table.
    #[arg(long)]
    pub json: bool,
}

/// Runs `mil analyze`.
///
/// # Errors
/// What the command refuses or fails on, one line naming it.
pub fn run(args: Args) -> Result<()> {
    let Args { set_up, out, json } = args;
    crate::cli::check_output_folder(&out)?;
    let result = crate::analyze::run_analyze(&set_up.read()?, &out)?;
    if json {
        outln!("{}", serde_json::to_string(&result.summary())?);
    } else {
        out!("{}", result.table());
    }
    Ok(())
}
