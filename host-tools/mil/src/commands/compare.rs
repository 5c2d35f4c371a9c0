//! `mil compare`: a MiL recording against the emulated system or another run (J1-J3, the
//! responses, plots).

use anyhow::Result;

pub use crate::compare::Args;

/// Runs `mil compare`.
///
/// # Errors
/// What the command refuses or fails on, one line naming it.
pub fn run(args: Args) -> Result<()> {
    let summary = crate::compare::run(&args)?;
    if args.json {
        outln!("{}", serde_json::to_string(&summary)?);
    } else {
        outln!("{}", summary.text());
    }
    Ok(())
}
