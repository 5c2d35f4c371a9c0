//! Whole files or none: every output the tools write (records, tables, plots, filter files)
//! goes to a temporary file in the target's folder and is renamed over the target when it
//! is complete, so an interrupted run (Ctrl-C, a full disk, an error half-way) never leaves a
//! truncated file where a complete one is expected, nor destroys the file that was there.

use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

/// A file being written: [`AtomicFile::commit`] puts it in place; dropped before, it
/// leaves nothing behind (and the target as it was).
#[derive(Debug)]
pub struct AtomicFile {
    writer: BufWriter<tempfile::NamedTempFile>,
    path: PathBuf,
}

/// `e` with `path` named in its message.
fn named(e: io::Error, what: &str, path: &Path) -> io::Error {
    io::Error::new(e.kind(), format!("cannot {what} {}: {e}", path.display()))
}

impl AtomicFile {
    /// Starts writing `path` (its folder is created if missing).
    ///
    /// # Errors
    /// The folder cannot be created or written (named in the message).
    pub fn create(path: &Path) -> io::Result<Self> {
        let folder = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
        std::fs::create_dir_all(folder).map_err(|e| named(e, "create the folder", folder))?;
        let file =
            tempfile::NamedTempFile::new_in(folder).map_err(|e| named(e, "write in", folder))?;
        Ok(Self {
            writer: BufWriter::new(file),
            path: path.to_path_buf(),
        })
    }

    /// Where the contents go until [`AtomicFile::commit`].
    pub fn writer(&mut self) -> &mut BufWriter<tempfile::NamedTempFile> {
        &mut self.writer
    }

    /// Flushes the contents and renames the file over the target.
    ///
    /// # Errors
    /// The contents could not be written or the file not renamed (the target named).
    pub fn commit(self) -> io::Result<()> {
        let path = self.path;
        let file = self
            .writer
            .into_inner()
            .map_err(|e| named(e.into_error(), "write", &path))?;
        file.persist(&path)
            .map_err(|e| named(e.error, "write", &path))?;
        Ok(())
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.writer.write(buf)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.writer.flush()
    }
}

/// Writes `contents` to `path` whole or not at all.
///
/// # Errors
/// As [`AtomicFile::create`] and [`AtomicFile::commit`].
pub fn write_atomic(path: &Path, contents: &[u8]) -> io::Result<()> {
    let mut file = AtomicFile::create(path)?;
    file.writer()
        .write_all(contents)
        .map_err(|e| named(e, "write", path))?;
    file.commit()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_is_in_place_only_once_committed() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sub/out.csv");
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(&path, "old\n").unwrap();
        let mut f = AtomicFile::create(&path).unwrap();
        writeln!(f, "new").unwrap();
        f.flush().unwrap();
        // Not committed: the old file stands.
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "old\n");
        drop(f);
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "old\n");
        // Nothing left behind.
        assert_eq!(
            std::fs::read_dir(path.parent().unwrap()).unwrap().count(),
            1
        );
        write_atomic(&path, b"new\n").unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "new\n");
    }

    #[test]
    fn a_folder_that_cannot_be_made_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("plain");
        std::fs::write(&file, "x").unwrap();
        let e = write_atomic(&file.join("out.svg"), b"x").unwrap_err();
        assert!(e.to_string().contains("plain"), "{e}");
    }
}
