//! Starting the QEMU build of the firmware.

use std::io::{self, Read};
use std::net::{Ipv4Addr, SocketAddr, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crate::slcan::SlcanTcp;

/// The command that builds the firmware ELF [`find_firmware_elf`] looks for.
pub const FIRMWARE_BUILD_COMMAND: &str =
    "cargo build -p mil-firmware --target thumbv7em-none-eabihf --release --features qemu";

/// The QEMU build of the firmware (`thumbv7em-none-eabihf/release/mil-firmware`) under
/// `$CARGO_TARGET_DIR`, else under `<workspace>/target`; `None` if neither exists.
pub fn find_firmware_elf() -> Option<PathBuf> {
    let tail = Path::new("thumbv7em-none-eabihf/release/mil-firmware");
    let workspace = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .map(|t| {
            if t.is_relative() {
                workspace.join(t)
            } else {
                t
            }
        })
        .into_iter()
        .chain([workspace.join("target")])
        .map(|t| t.join(tail))
        .find(|p| p.is_file())
}

/// How to start QEMU.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct QemuOptions {
    /// The QEMU binary (default `qemu-system-arm`).
    pub program: PathBuf,
    /// `Some(S)` adds `-icount shift=S,align=off`: every instruction advances QEMU's virtual
    /// time by 2^S ns, so the firmware's instruction figures (timed with TIM5, which counts
    /// virtual nanoseconds) are exact; `None` (default) runs QEMU without `-icount`.
    /// Lockstep works with either.
    pub icount_shift: Option<u8>,
    /// With `icount_shift`: `false` adds `sleep=off` (virtual time no longer follows wall
    /// time while the guest waits: it jumps to the next timer deadline, so the instruction
    /// figures do not depend on host timing). The firmware's watchdog ticks would then
    /// race and trip between lockstep samples: switch it off first (parameter `watchdog_limit` = 0,
    /// accepted by the QEMU build only), as the `qemu_budget` example does. Default `true`.
    pub icount_sleep: bool,
    /// How long to wait for the TCP connection and the SLCAN handshake.
    pub open_timeout: Duration,
    /// `true` adds the firmware's XCP port (USART2, `-serial` 1) on a second TCP port,
    /// [`Qemu::xcp_port`], free for an XCP master (`mil param --port tcp:127.0.0.1:PORT`,
    /// pyxcp through python-can's slcan). Default `false` (USART2 unconnected).
    pub xcp_port: bool,
}

impl Default for QemuOptions {
    fn default() -> Self {
        Self {
            program: PathBuf::from("qemu-system-arm"),
            icount_shift: None,
            icount_sleep: true,
            open_timeout: Duration::from_secs(30),
            xcp_port: false,
        }
    }
}

/// What QEMU printed and how it ended.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct QemuOutput {
    /// Exit status (`None`: still running when it was killed or not waited for).
    pub status: Option<ExitStatus>,
    /// Standard output: the firmware's semihosting report.
    pub stdout: String,
    /// Standard error: QEMU's messages.
    pub stderr: String,
}

/// A running QEMU `netduinoplus2` with the firmware; killed on drop.
///
/// Its USART1 is `-serial tcp:127.0.0.1:0,server=on,wait=on,nodelay=on`: QEMU listens on a
/// port the kernel picks and names it on stderr ([`listening_ports`]); stdout and stderr are
/// captured ([`Qemu::output`]).
///
/// Why QEMU picks the port: finding a free port by binding port 0 and releasing it, then
/// handing it to QEMU, races with any process forked in between (the test harness starts
/// several QEMUs at once). A child forked while the probe listener was open holds a copy
/// until it execs; a connection made to that copy is reset when it closes, while QEMU, bound
/// a moment later, waits for a connection that never comes (seen about once in 150 starts
/// with six starting at once).
#[derive(Debug)]
pub struct Qemu {
    child: Child,
    port: u16,
    xcp_port: Option<u16>,
    stdout: Arc<Mutex<Vec<u8>>>,
    stderr: Arc<Mutex<Vec<u8>>>,
    readers: Vec<JoinHandle<()>>,
}

fn capture(mut from: impl Read + Send + 'static, into: Arc<Mutex<Vec<u8>>>) -> JoinHandle<()> {
    std::thread::spawn(move || {
        let mut chunk = [0u8; 4096];
        while let Ok(n) = from.read(&mut chunk) {
            if n == 0 {
                break;
            }
            if let Ok(mut v) = into.lock() {
                v.extend_from_slice(&chunk[..n]);
            }
        }
    })
}

impl Qemu {
    /// Starts QEMU with the firmware `elf`, connects to its serial port and opens the SLCAN
    /// channel ([`SlcanTcp::open`]).
    ///
    /// # Errors
    /// QEMU could not be started (not installed: `apt-get install -y qemu-system-arm`), the
    /// connection or the handshake failed; QEMU's stderr is in the message.
    pub fn spawn(elf: &Path, options: &QemuOptions) -> io::Result<(Qemu, SlcanTcp)> {
        let mut cmd = Command::new(&options.program);
        cmd.args([
            "-machine",
            "netduinoplus2",
            "-nographic",
            "-monitor",
            "none",
        ])
        .args(["-semihosting-config", "enable=on,target=native"])
        .arg("-serial")
        .arg(SERIAL);
        if options.xcp_port {
            cmd.arg("-serial").arg(SERIAL);
        }
        if let Some(shift) = options.icount_shift {
            let sleep = if options.icount_sleep {
                ""
            } else {
                ",sleep=off"
            };
            cmd.arg("-icount")
                .arg(format!("shift={shift},align=off{sleep}"));
        }
        cmd.arg("-kernel")
            .arg(elf)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped());
        let mut child = cmd.spawn().map_err(|e| {
            io::Error::new(
                e.kind(),
                format!(
                    "cannot start {}: {e} (install it: apt-get install -y qemu-system-arm)",
                    options.program.display()
                ),
            )
        })?;
        let stdout = Arc::new(Mutex::new(Vec::new()));
        let stderr = Arc::new(Mutex::new(Vec::new()));
        let mut readers = Vec::new();
        if let Some(out) = child.stdout.take() {
            readers.push(capture(out, stdout.clone()));
        }
        if let Some(err) = child.stderr.take() {
            readers.push(capture(err, stderr.clone()));
        }
        let mut qemu = Qemu {
            child,
            port: 0,
            xcp_port: None,
            stdout,
            stderr,
            readers,
        };
        let deadline = Instant::now() + options.open_timeout;
        let link = qemu.wait_for_port(0, deadline).and_then(|port| {
            qemu.port = port;
            let addr = SocketAddr::from((Ipv4Addr::LOCALHOST, port));
            let mut link =
                SlcanTcp::connect(addr, deadline.saturating_duration_since(Instant::now()))?;
            if options.xcp_port {
                // QEMU waits for a first connection to each port before it boots; this one
                // is closed again at once and QEMU listens for the XCP master's.
                let xcp = qemu.wait_for_port(1, deadline)?;
                qemu.xcp_port = Some(xcp);
                let addr = SocketAddr::from((Ipv4Addr::LOCALHOST, xcp));
                drop(TcpStream::connect_timeout(
                    &addr,
                    deadline.saturating_duration_since(Instant::now()),
                )?);
            }
            link.open(deadline.saturating_duration_since(Instant::now()))?;
            Ok(link)
        });
        let port = qemu.port;
        match link {
            Ok(link) => Ok((qemu, link)),
            Err(e) => {
                let _ = qemu.child.kill();
                let out = qemu.output();
                Err(io::Error::new(
                    e.kind(),
                    format!("QEMU on port {port}: {e}; stderr: {}", out.stderr.trim()),
                ))
            }
        }
    }

    /// Waits until QEMU names its `index`-th listening port on stderr.
    fn wait_for_port(&mut self, index: usize, deadline: Instant) -> io::Result<u16> {
        loop {
            if let Some(&port) = listening_ports(&self.output().stderr).get(index) {
                return Ok(port);
            }
            if let Some(status) = self.child.try_wait()? {
                return Err(io::Error::other(format!(
                    "QEMU exited ({status}) before listening"
                )));
            }
            if Instant::now() >= deadline {
                return Err(io::Error::new(
                    io::ErrorKind::TimedOut,
                    "QEMU did not say which port it listens on",
                ));
            }
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    /// The TCP port of the firmware's USART1.
    pub fn port(&self) -> u16 {
        self.port
    }

    /// The TCP port of the firmware's XCP port (USART2), when [`QemuOptions::xcp_port`]
    /// asked for it.
    pub fn xcp_port(&self) -> Option<u16> {
        self.xcp_port
    }

    /// What QEMU printed so far (status not set).
    pub fn output(&self) -> QemuOutput {
        let text = |b: &Arc<Mutex<Vec<u8>>>| {
            b.lock()
                .map(|v| String::from_utf8_lossy(&v).into_owned())
                .unwrap_or_default()
        };
        QemuOutput {
            status: None,
            stdout: text(&self.stdout),
            stderr: text(&self.stderr),
        }
    }

    /// Waits up to `timeout` for QEMU to exit (after [`SlcanTcp::close`] the QEMU build
    /// reports and exits), kills it if it has not, and returns its output and status
    /// (`None` if it had to be killed).
    ///
    /// # Errors
    /// Waiting on the process failed.
    pub fn finish(mut self, timeout: Duration) -> io::Result<QemuOutput> {
        let deadline = Instant::now() + timeout;
        let status = loop {
            if let Some(s) = self.child.try_wait()? {
                break Some(s);
            }
            if Instant::now() >= deadline {
                self.child.kill()?;
                self.child.wait()?;
                break None;
            }
            std::thread::sleep(Duration::from_millis(20));
        };
        for r in self.readers.drain(..) {
            let _ = r.join();
        }
        Ok(QemuOutput {
            status,
            ..self.output()
        })
    }
}

/// Each serial port's chardev: QEMU picks a free port and names it on stderr.
const SERIAL: &str = "tcp:127.0.0.1:0,server=on,wait=on,nodelay=on";

/// The ports of every complete `QEMU waiting for connection on: ...` line, in order (one
/// per `-serial` port, each printed once QEMU has a connection on the one before).
pub fn listening_ports(stderr: &str) -> Vec<u16> {
    const MARK: &str = "waiting for connection on: disconnected:tcp:127.0.0.1:";
    stderr
        .match_indices(MARK)
        .filter_map(|(at, _)| {
            let rest = &stderr[at + MARK.len()..];
            let digits = rest.find(|c: char| !c.is_ascii_digit())?;
            rest[..digits].parse().ok().filter(|&p| p != 0)
        })
        .collect()
}

impl Drop for Qemu {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::listening_ports;

    fn listening_port(stderr: &str) -> Option<u16> {
        listening_ports(stderr).first().copied()
    }

    #[test]
    fn the_port_comes_from_qemus_waiting_line() {
        let line = "qemu-system-arm: -serial tcp:127.0.0.1:0,server=on,wait=on,nodelay=on: info: \
                    QEMU waiting for connection on: disconnected:tcp:127.0.0.1:34363,server=on\n";
        assert_eq!(listening_port(line), Some(34363));
        // Not yet complete, or not there.
        assert_eq!(
            listening_port("QEMU waiting for connection on: disconnected:tcp:127.0.0.1:343"),
            None
        );
        assert_eq!(listening_port("qemu-system-arm: some error\n"), None);
        // Two ports, one line each.
        let two = format!("{line}{}", line.replace("34363", "40001"));
        assert_eq!(listening_ports(&two), vec![34363, 40001]);
        assert_eq!(
            listening_port("waiting for connection on: disconnected:tcp:127.0.0.1:0,server=on"),
            None
        );
    }
}
