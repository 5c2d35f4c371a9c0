//! `mil diagnose`: where a lumped model and a record disagree, the missing effect named and
//! fitted, the updated model, report and plots.

use anyhow::Result;
use std::path::PathBuf;

/// The arguments of `mil diagnose`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Model file (TOML): DOFs, elements, inputs and outputs mapped to CSV columns.
    #[arg(long)]
    pub model: PathBuf,
    /// Measured record (CSV with a header, `time` first, uniform, SI units).
    #[arg(long)]
    pub data: PathBuf,
    /// Output folder for the updated model, the report and the plots.
    #[arg(long, default_value = "out/diagnose")]
    pub out: PathBuf,
    /// Print one JSON object (named_effects, recalibrated, gap_before, gap_after,
    /// updated_model) instead of the summary.
    #[arg(long)]
    pub json: bool,
    /// Also write the updated model's element ELEMENT as model-core's real-time tyre
    /// (numerical-tyre.toml: the [numerical.tyre] table of a MiL set-up; stiffness, damping,
    /// static load and lift-off).
    #[arg(long, value_name = "ELEMENT")]
    pub tyre: Option<String>,
    /// Static wheel load (N) for --tyre when the updated model has no lift-off.
    #[arg(long, requires = "tyre")]
    pub tyre_static_load_n: Option<f64>,
}

/// Runs `mil diagnose`.
///
/// # Errors
/// What the command refuses or fails on, one line naming it.
pub fn run(args: Args) -> Result<()> {
    let Args {
        model,
        data,
        out,
        json,
        tyre,
        tyre_static_load_n,
    } = args;
    let bar = crate::cli::progress_bar(json, 1000, "estimating states");
    let request = crate::diagnose::DiagnoseRequest {
        model,
        data,
        out,
        tyre: tyre.map(|element| crate::diagnose::TyreExport {
            element,
            static_load_n: tyre_static_load_n,
        }),
    };
    let result = crate::diagnose::run_diagnose(&request, &|f, m| {
        bar.set_position((f * 1000.0) as u64);
        bar.set_message(m.to_string());
    });
    bar.finish_and_clear();
    let result = result?;
    if json {
        outln!("{}", serde_json::to_string(&result.json_report())?);
    } else {
        out!("{}", result.table());
    }
    // After the diagnosis, which stands without it.
    if let Some(Err(why)) = &result.tyre {
        anyhow::bail!("--tyre: {why}");
    }
    Ok(())
}
