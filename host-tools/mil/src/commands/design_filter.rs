//! `mil design-filter`: the actuator command filter for a set-up, its file and plots.

use crate::setup::SetUp;
use anyhow::Result;
use std::path::PathBuf;

/// The arguments of `mil design-filter`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// MiL set-up (TOML), as for `mil analyze` (its own filter is left out).
    pub setup: PathBuf,
    /// `ls`: least-squares fit; `optimal`: trade-off front, exports the most accurate
    /// design meeting the target.
    #[arg(long, value_enum, default_value = "ls")]
    pub method: crate::design_filter::Method,
    /// Filter file to write (JSON); the plots go to the same folder.
    #[arg(long, default_value = "out/design-filter/filter.json")]
    pub out: PathBuf,
    /// Roll-off frequency of the filter's poles (Hz).
    #[arg(long)]
    pub rolloff_hz: Option<f64>,
    /// Damping ratio of the roll-off pole pairs.
    #[arg(long)]
    pub rolloff_damping: Option<f64>,
    /// Number of poles (1-8).
    #[arg(long)]
    pub poles: Option<usize>,
    /// Number of zeros (< poles).
    #[arg(long)]
    pub zeros: Option<usize>,
    /// Trade-off weights for `optimal` (comma-separated, 0-1).
    #[arg(long, value_delimiter = ',')]
    pub weights: Option<Vec<f64>>,
    /// Print one JSON object with the figures instead of the table.
    #[arg(long)]
    pub json: bool,
}

/// Runs `mil design-filter`.
///
/// # Errors
/// What the command refuses or fails on, one line naming it.
pub fn run(args: Args) -> Result<()> {
    let Args {
        setup,
        method,
        out,
        rolloff_hz,
        rolloff_damping,
        poles,
        zeros,
        weights,
        json,
    } = args;
    if let Some(folder) = out.parent().filter(|p| !p.as_os_str().is_empty()) {
        crate::cli::check_output_folder(folder)?;
    }
    let paper = mil_analysis::design::FilterStructure::PAPER;
    let structure = mil_analysis::design::FilterStructure {
        rolloff_hz: rolloff_hz.unwrap_or(paper.rolloff_hz),
        rolloff_damping: rolloff_damping.unwrap_or(paper.rolloff_damping),
        poles: poles.unwrap_or(paper.poles),
        zeros: zeros.unwrap_or(paper.zeros),
    };
    let request = crate::design_filter::DesignRequest {
        method,
        out,
        structure: Some(structure),
        weights,
    };
    let bar = crate::cli::progress_bar(
        json || method == crate::design_filter::Method::Ls,
        1,
        "optimising over the weights",
    );
    let setup = SetUp::read(&setup)?;
    let result = crate::design_filter::run_design_filter(&setup, &request, |i, n| {
        bar.set_length(n as u64);
        bar.set_position(i as u64);
    })?;
    bar.finish_and_clear();
    if json {
        outln!("{}", serde_json::to_string(&result.summary)?);
    } else {
        out!("{}", result.table());
    }
    Ok(())
}
