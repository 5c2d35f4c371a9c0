//! Long work shows progress: every command that can run for seconds draws a progress bar (or
//! a spinner) on stderr when stderr is a terminal, and none with `--json`. The commands run
//! with stderr on a pseudo-terminal, as in an engineer's shell.
#![cfg(unix)]

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use nix::pty::{openpty, Winsize};

fn examples() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples")
}

/// Runs `mil args` in `dir` with stderr on a fresh pseudo-terminal (100 columns), stdout
/// discarded: its exit code and everything it drew on the terminal.
fn on_a_terminal(dir: &Path, args: &[&str]) -> (Option<i32>, String) {
    let size = Winsize {
        ws_row: 40,
        ws_col: 100,
        ws_xpixel: 0,
        ws_ypixel: 0,
    };
    let pty = openpty(Some(&size), None).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_mil"))
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::from(pty.slave))
        .spawn()
        .unwrap();
    // The parent's copy of the terminal's slave side went into the Command, which is gone:
    // the master reads until the child's side closes (EIO on Linux).
    let mut master = std::fs::File::from(pty.master);
    let reader = std::thread::spawn(move || {
        let mut drawn = Vec::new();
        let mut buffer = [0u8; 4096];
        while let Ok(n) = master.read(&mut buffer) {
            if n == 0 {
                break;
            }
            drawn.extend_from_slice(&buffer[..n]);
        }
        drawn
    });
    let status = child.wait().unwrap();
    let drawn = reader.join().unwrap();
    (status.code(), String::from_utf8_lossy(&drawn).into_owned())
}

/// Each long command draws its bar, naming the work, and finishes; `--json` draws none.
#[test]
fn long_commands_show_progress_on_a_terminal_and_none_with_json() {
    let dir = tempfile::tempdir().unwrap();
    let tyre = examples().join("tyre.toml");
    let tyre = tyre.to_str().unwrap();
    let structure = examples().join("tyre-physical.toml");
    let structure = structure.to_str().unwrap();
    let cases: [(&[&str], &str); 6] = [
        (
            &[
                "actuator-test",
                tyre,
                "--duration",
                "4",
                "--out",
                "act/sweep.csv",
            ],
            "testing the actuator",
        ),
        (
            &[
                "identify",
                "--data",
                "act/sweep.csv",
                "--input",
                "force_command",
                "--output",
                "force",
                "--out",
                "table.csv",
            ],
            "reading the records and estimating the response",
        ),
        (
            &["sim", tyre, "--duration", "2", "--out", "sim"],
            "simulating the rig",
        ),
        (&["run", tyre, "--out", "run"], "running controller"),
        (
            &[
                "design-filter",
                tyre,
                "--method",
                "optimal",
                "--out",
                "filter/f.json",
            ],
            "optimising over the weights",
        ),
        (
            &[
                "diagnose",
                "--model",
                structure,
                "--data",
                "sim/sim.csv",
                "--out",
                "diagnose",
            ],
            "estimating states",
        ),
    ];
    for (args, message) in cases {
        let (code, drawn) = on_a_terminal(dir.path(), args);
        assert_eq!(code, Some(0), "mil {args:?}: {drawn}");
        assert!(
            drawn.contains(message),
            "mil {args:?} drew no progress {message:?}: {drawn:?}"
        );
        if args[0] != "identify" {
            // A bar with its share done, not a bare message.
            assert!(drawn.contains("% "), "mil {args:?}: {drawn:?}");
        }
        let mut json = args.to_vec();
        json.push("--json");
        let (code, drawn) = on_a_terminal(dir.path(), &json);
        assert_eq!(code, Some(0), "mil {json:?}: {drawn}");
        assert!(!drawn.contains(message), "mil {json:?}: {drawn:?}");
    }
}
