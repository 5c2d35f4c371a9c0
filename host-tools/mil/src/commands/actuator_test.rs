//! `mil actuator-test`: the set-up's actuator tested on the simulated rig, rod blocked, as a
//! rig engineer tests the real one; the record `mil identify` reads.

use anyhow::Result;

pub use crate::actuator_test::Args;

/// Runs `mil actuator-test`.
///
/// # Errors
/// What the command refuses or fails on, one line naming it.
pub fn run(args: Args) -> Result<()> {
    let summary = crate::actuator_test::run(&args)?;
    if args.json {
        outln!("{}", serde_json::to_string(&summary)?);
    } else {
        outln!("{}", summary.text());
    }
    Ok(())
}
