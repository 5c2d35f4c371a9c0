//! `mil param list | get | set | store`: the board's calibration parameters over XCP.

use crate::xcp::BoardArgs;
use anyhow::Result;
use std::path::PathBuf;

/// The subcommands of `mil param`.
#[derive(clap::Subcommand, Debug)]
pub enum ParamCommand {
    /// List the calibration parameters and the measurements of an A2L file: name, unit,
    /// limits, address, description (no board needed).
    List {
        /// The board's A2L file (`mil a2l` writes it).
        #[arg(long)]
        a2l: PathBuf,
    },
    /// Read parameters (or measurements) from the board.
    Get {
        /// A2L names.
        #[arg(required = true)]
        names: Vec<String>,
        /// The board: its A2L file and how to reach it.
        #[command(flatten)]
        board: BoardArgs,
    },
    /// Write parameters: each value is checked against the A2L limits before anything is
    /// sent; contiguous parameters go to the board as one change it validates as a whole,
    /// the others one after another; prints old → new as read back.
    Set {
        /// NAME=VALUE pairs (SI units as in the A2L); with --setup, they replace the set-up's
        /// values.
        #[arg(required_unless_present = "setup")]
        assignments: Vec<String>,
        /// Configure the board for this MiL set-up (TOML): its model, parameters, limits,
        /// command filter and sample rate, as `mil sim --board qemu` configures the board
        /// in QEMU; only the parameters that differ are written, and printed old → new.
        #[arg(long)]
        setup: Option<PathBuf>,
        /// The board: its A2L file and how to reach it.
        #[command(flatten)]
        board: BoardArgs,
    },
    /// Store the board's working page in its flash (XCP SET_REQUEST STORE_CAL_REQ): the board
    /// boots with it from then on (its status frame and the measurement `calibration_source`
    /// say so). Only while the controller does not run: a flash erase stalls the board.
    Store {
        /// The board: its A2L file and how to reach it.
        #[command(flatten)]
        board: BoardArgs,
    },
}

/// Runs `mil param ...`.
///
/// # Errors
/// What the board or the tool refuses, one line naming it.
pub fn run(command: ParamCommand) -> Result<()> {
    match command {
        ParamCommand::List { a2l } => {
            let a2l = crate::xcp::load_a2l(&a2l)?;
            out!("{}", crate::param::list_table(&a2l));
        }
        ParamCommand::Get { names, board } => {
            let a2l = crate::xcp::load_a2l(&board.a2l)?;
            crate::param::resolve(&a2l, &names)?;
            let table = crate::xcp::session(&board, &a2l, |m| crate::param::get(m, &a2l, &names))?;
            out!("{table}");
        }
        ParamCommand::Set {
            assignments,
            setup,
            board,
        } => {
            let a2l = crate::xcp::load_a2l(&board.a2l)?;
            let given = crate::param::parse_assignments(&assignments)?;
            let assignments = match &setup {
                Some(path) => {
                    let config = crate::cli::set_up(Some(path), None)?.sim()?;
                    let mut all = crate::param::page_assignments(&crate::sim::board_page(&config)?);
                    for (name, v) in given {
                        match all.iter_mut().find(|(n, _)| *n == name) {
                            Some(slot) => slot.1 = v,
                            None => all.push((name, v)),
                        }
                    }
                    all
                }
                None => given,
            };
            // Everything the host can check, before the board is contacted.
            crate::param::check_assignments(&a2l, &assignments)?;
            let secret = crate::xcp::secret(&board)?;
            let changes = crate::xcp::session(&board, &a2l, |m| match &setup {
                Some(_) => crate::param::set_all(m, &a2l, &assignments, &secret),
                None => crate::param::set(m, &a2l, &assignments, &secret),
            })?;
            out!("{}", crate::param::changes_table(&a2l, &changes));
            if let Some(path) = &setup {
                outln!(
                    "the board is configured for {} ({} of {} parameters changed)",
                    path.display(),
                    changes.len(),
                    assignments.len()
                );
            }
        }
        ParamCommand::Store { board } => {
            let a2l = crate::xcp::load_a2l(&board.a2l)?;
            let secret = crate::xcp::secret(&board)?;
            let line =
                crate::xcp::session(&board, &a2l, |m| crate::param::store(m, &a2l, &secret))?;
            out!("{line}");
        }
    }
    Ok(())
}
