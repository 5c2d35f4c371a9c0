//! What every `mil` subcommand shares on its way out: stdout that ends quietly on a closed
//! pipe, the progress bar, and output files written whole or not at all.

use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::Write;
use std::path::Path;

/// Writes to stdout; a closed pipe (`mil ... | head`) ends the program quietly with status 0
/// where `print!` would panic; other write errors are returned.
///
/// # Errors
/// A write error other than a closed pipe.
pub fn print(args: std::fmt::Arguments<'_>) -> std::io::Result<()> {
    if let Err(e) = std::io::stdout().lock().write_fmt(args) {
        if e.kind() == std::io::ErrorKind::BrokenPipe {
            std::process::exit(0);
        }
        return Err(e);
    }
    Ok(())
}

/// A progress bar on stderr with `message`, `length` steps long, hidden with `--json` (or
/// when stderr is not a terminal, as indicatif does).
pub fn progress_bar(hidden: bool, length: u64, message: &'static str) -> ProgressBar {
    if hidden {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(length).with_style(
        ProgressStyle::with_template("{msg} [{bar:40}] {percent:>3}% {elapsed} (eta {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.set_message(message);
    bar
}

/// A spinner on stderr with `message` for work whose length is not known in advance
/// (reading a large record), ticking by itself; hidden with `--json`.
pub fn spinner(hidden: bool, message: &'static str) -> ProgressBar {
    if hidden {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new_spinner().with_style(
        ProgressStyle::with_template("{spinner} {msg} {elapsed}")
            .unwrap_or_else(|_| ProgressStyle::default_spinner()),
    );
    bar.set_message(message);
    bar.enable_steady_tick(std::time::Duration::from_millis(120));
    bar
}

/// Writes `path` whole or not at all ([`mil_numerics::files`]): `write` fills a temporary
/// file beside it, which then replaces `path` (a rename), so an interrupted run (Ctrl-C, an
/// error) never leaves a truncated file where a complete one is expected. The folder is
/// created if missing.
///
/// # Errors
/// The folder or the file cannot be written (the path named), or `write` fails.
pub fn write_atomic(
    path: &Path,
    write: impl FnOnce(&mut mil_numerics::files::AtomicFile) -> Result<()>,
) -> Result<()> {
    let mut file = mil_numerics::files::AtomicFile::create(path)?;
    write(&mut file)?;
    file.commit()?;
    Ok(())
}

/// Checks before a long run that `folder` can take the run's files (created if missing),
/// so that a bad `--out` fails at once, naming the folder, not after the run.
///
/// # Errors
/// The folder cannot be created or written.
pub fn check_output_folder(folder: &Path) -> Result<()> {
    std::fs::create_dir_all(folder)
        .with_context(|| format!("--out: cannot create the folder {}", folder.display()))?;
    tempfile::NamedTempFile::new_in(folder)
        .with_context(|| format!("--out: cannot write in {}", folder.display()))?;
    Ok(())
}

/// The set-up and the command filter of the commands that run or analyse one (`mil sim`,
/// `mil run`, `mil analyze`), flattened into their arguments.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct SetUpArgs {
    /// MiL set-up (TOML); examples in host-tools/mil/examples/. None: the built-in tyre
    /// example.
    pub setup: Option<std::path::PathBuf>,
    /// Command filter (JSON) in place of the set-up's; `none`: without a filter.
    #[arg(long)]
    pub filter: Option<std::path::PathBuf>,
}

impl SetUpArgs {
    /// The set-up as [`set_up`] reads it.
    ///
    /// # Errors
    /// As [`set_up`].
    pub fn read(&self) -> Result<crate::setup::SetUp> {
        set_up(self.setup.as_deref(), self.filter.as_deref())
    }

    /// Neither a set-up nor a filter given: the main job's built-in example as it ships.
    pub fn is_builtin(&self) -> bool {
        self.setup.is_none() && self.filter.is_none()
    }
}

/// The set-up at `path` (none: the built-in tyre example), its command filter replaced by
/// `filter` if given (`none`: no filter; relative to the working folder).
pub fn set_up(path: Option<&Path>, filter: Option<&Path>) -> Result<crate::setup::SetUp> {
    let mut s = match path {
        Some(path) => crate::setup::SetUp::read(path)?,
        None => crate::setup::SetUp::builtin()?,
    };
    if let Some(f) = filter {
        s.controller.filter = if f == Path::new("none") {
            None
        } else {
            Some(std::env::current_dir()?.join(f))
        };
    }
    Ok(s)
}

/// The firmware image `elf`, or the one under the build folder.
pub fn firmware_elf(elf: Option<std::path::PathBuf>) -> Result<std::path::PathBuf> {
    match elf {
        Some(e) => Ok(e),
        None => anyhow::Context::with_context(mil_can::find_firmware_elf(), || {
            format!(
                "no firmware image found: build it with `{}` or give --elf",
                mil_can::FIRMWARE_BUILD_COMMAND
            )
        }),
    }
}

pub use mil_numerics::format::number;

/// The one line `mil` prints for an error: the context chain joined by `: `, outermost
/// first, each cause once. A cause whose text a message before it already carries (a library
/// error that prints its I/O source and also reports it as its source, "x.a2l: No such
/// file or directory (os error 2)" then "No such file or directory (os error 2)") is not
/// repeated.
pub fn error_message(error: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in error.chain() {
        let part = cause.to_string();
        if text.contains(part.as_str()) {
            continue;
        }
        if !text.is_empty() {
            text.push_str(": ");
        }
        text.push_str(&part);
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_error_chain_names_each_cause_once() {
        // A library error as thiserror's `#[error("{path}: {source}")]` makes it.
        #[derive(Debug)]
        struct Read {
            path: String,
            source: std::io::Error,
        }
        impl std::fmt::Display for Read {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                write!(f, "{}: {}", self.path, self.source)
            }
        }
        impl std::error::Error for Read {
            fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
                Some(&self.source)
            }
        }
        let io = || std::io::Error::from(std::io::ErrorKind::NotFound);
        let e = anyhow::Error::new(Read {
            path: "x.a2l".into(),
            source: io(),
        })
        .context("loading the A2L");
        let plain = io().to_string();
        assert_eq!(
            error_message(&e),
            format!("loading the A2L: x.a2l: {plain}")
        );
        // What anyhow's alternate form prints: the I/O text twice.
        assert_eq!(format!("{e:#}").matches(plain.as_str()).count(), 2);
        // Distinct causes are all kept, in order.
        let e = anyhow::anyhow!("inner").context("middle").context("outer");
        assert_eq!(error_message(&e), "outer: middle: inner");
    }

    #[test]
    fn a_failed_write_leaves_the_previous_file_whole_and_no_debris() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sub/out.csv");
        write_atomic(&path, |w| Ok(writeln!(w, "a,b\n1,2")?)).unwrap();
        let err = write_atomic(&path, |w| {
            writeln!(w, "a,b")?;
            anyhow::bail!("interrupted")
        });
        assert!(err.is_err());
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "a,b\n1,2\n");
        let files: Vec<_> = std::fs::read_dir(path.parent().unwrap()).unwrap().collect();
        assert_eq!(files.len(), 1, "{files:?}");
    }

    #[test]
    fn an_unwritable_output_folder_is_named_before_the_run() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("a-file");
        std::fs::write(&file, "x").unwrap();
        let err = check_output_folder(&file.join("out")).unwrap_err();
        let text = format!("{err:#}");
        assert!(
            text.starts_with("--out: cannot create the folder"),
            "{text}"
        );
        assert!(text.contains("a-file"), "{text}");
    }
}
