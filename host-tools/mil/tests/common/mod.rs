//! What the `mil` command-line tests share.

use std::path::Path;

/// Runs the `mil` binary with `args` in the folder `dir`: its exit code, stdout and stderr.
pub fn mil_in(dir: &Path, args: &[&str]) -> (Option<i32>, String, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_mil"))
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).to_string(),
        String::from_utf8_lossy(&out.stderr).to_string(),
    )
}
