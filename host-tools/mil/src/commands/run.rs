//! `mil run`: the controller open-loop on a rigid rig over a road input.

use anyhow::Result;
use std::path::PathBuf;

/// The arguments of `mil run`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The set-up and its command filter.
    #[command(flatten)]
    pub set_up: crate::cli::SetUpArgs,
    /// Output folder for run.csv, run.svg (demand) and run-road.svg.
    #[arg(long, default_value = "out")]
    pub out: PathBuf,
    /// Print one JSON object with the summary instead of the table.
    #[arg(long)]
    pub json: bool,
}

/// Runs `mil run`.
///
/// # Errors
/// What the command refuses or fails on, one line naming it.
pub fn run(args: Args) -> Result<()> {
    let Args { set_up, out, json } = args;
    let config = set_up.read()?.run()?;
    crate::cli::check_output_folder(&out)?;
    let bar = crate::cli::progress_bar(json, 1000, "running controller");
    let result = crate::run(&config, |f| bar.set_position((f * 1000.0) as u64))?;
    bar.finish_and_clear();
    std::fs::create_dir_all(&out)?;
    let csv = out.join("run.csv");
    result.write_csv(&csv)?;
    let plots = crate::plot::plot_run(&result, &out)?;
    if json {
        outln!("{}", serde_json::to_string(&result.summary)?);
    } else {
        out!("{}", result.table());
        outln!("time histories: {}", csv.display());
        for p in &plots {
            outln!("plot:           {}", p.display());
        }
    }
    // A faulted run is a failed one: the files are complete, the status says so.
    if let Some(t) = result.summary.fault_at_s {
        anyhow::bail!(
            "the controller faulted at {t:.4} s: {} ({} holds the whole run)",
            crate::run::fault_causes(result.summary.fault_flags),
            csv.display()
        );
    }
    Ok(())
}
