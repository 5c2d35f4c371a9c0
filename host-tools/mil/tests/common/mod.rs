//! What the `mil` command-line tests share.

use std::path::Path;

/// Runs the `mil` binary with `args` in the folder `dir`: its exit code, stdout and stderr.
#[allow(dead_code)] // The XCP test binaries use `mil_with_secret`.
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

/// Runs the `mil` binary with `args` in the folder `dir`, the board's XCP secret `secret` in
/// `MIL_XCP_SECRET` (as an engineer exports it for the XCP tools).
#[allow(dead_code)] // Only the test binaries that talk XCP to a board use it.
pub fn mil_with_secret(dir: &Path, args: &[&str], secret: &[u8]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_mil"))
        .args(args)
        .current_dir(dir)
        .env("MIL_XCP_SECRET", std::str::from_utf8(secret).unwrap())
        .output()
        .expect("run mil")
}

/// A command's stdout then stderr, for messages and checks on either.
#[allow(dead_code)] // Only the test binaries that keep an `Output` use it.
pub fn text(o: &std::process::Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}
