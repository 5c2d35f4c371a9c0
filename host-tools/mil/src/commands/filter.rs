//! `mil filter upload`: a filter file onto the board over XCP, one block per channel.

use crate::xcp::BoardArgs;
use anyhow::Result;
use std::path::PathBuf;

/// The subcommands of `mil filter`.
#[derive(clap::Subcommand, Debug)]
pub enum FilterCommand {
    /// Write a filter file (`mil design-filter`) to the board: every channel's
    /// filter_sections and section coefficients (delta form) as ONE block download, so the
    /// board validates the whole filter at once; prints the coefficients written.
    Upload {
        /// Filter file (JSON, `mil-command-filter`).
        filter: PathBuf,
        /// The board: its A2L file and how to reach it.
        #[command(flatten)]
        board: BoardArgs,
    },
}

/// Runs `mil filter ...`.
///
/// # Errors
/// What the board or the tool refuses, one line naming it.
pub fn run(command: FilterCommand) -> Result<()> {
    let FilterCommand::Upload { filter, board } = command;
    let a2l = crate::xcp::load_a2l(&board.a2l)?;
    let plan = crate::filter_upload::plan(&a2l, &filter)?;
    let secret = crate::xcp::secret(&board)?;
    let changes = crate::xcp::session(&board, &a2l, |m| {
        crate::filter_upload::upload(m, &plan, &secret)
    })?;
    out!("{}", crate::filter_upload::table(&plan, &changes));
    Ok(())
}
