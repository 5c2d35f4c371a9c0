//! `mil identify`: an actuator's frequency response from test records, its table and plots.

use anyhow::Result;
use std::path::PathBuf;

/// The arguments of `mil identify`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Record file (CSV with a header, `time` first, uniform); repeat to average several.
    #[arg(long = "data", required = true)]
    pub data: Vec<PathBuf>,
    /// Input column (e.g. the force command).
    #[arg(long)]
    pub input: String,
    /// Output column (e.g. the measured force).
    #[arg(long)]
    pub output: String,
    /// Welch segment length (samples); resolution = sample rate / length. Default: the
    /// longest power of two that fits 8 times into the shortest record, 16 to 4096.
    #[arg(long)]
    pub segment: Option<usize>,
    /// Band kept in the table, LOW:HIGH in Hz (the excited band).
    #[arg(long, default_value = "0.5:140")]
    pub band: String,
    /// Points with lower coherence are dropped.
    #[arg(long, default_value_t = 0.9)]
    pub min_coherence: f64,
    /// Table file to write.
    #[arg(long, default_value = "out/actuator-frf.csv")]
    pub out: PathBuf,
    /// Print one JSON object with the summary.
    #[arg(long)]
    pub json: bool,
}

/// Runs `mil identify`.
///
/// # Errors
/// What the command refuses or fails on, one line naming it.
pub fn run(args: Args) -> Result<()> {
    let Args {
        data,
        input,
        output,
        segment,
        band,
        min_coherence,
        out,
        json,
    } = args;
    let bar = crate::cli::spinner(json, "reading the records and estimating the response");
    let (_, summary) = crate::identify::run_identify(&crate::identify::IdentifyOptions {
        records: data,
        input,
        output,
        segment_length: segment,
        band_hz: crate::identify::parse_band(&band)?,
        min_coherence,
        out,
    })?;
    bar.finish_and_clear();
    if json {
        outln!("{}", serde_json::to_string(&summary)?);
    } else {
        outln!("{}", summary.text());
    }
    Ok(())
}
