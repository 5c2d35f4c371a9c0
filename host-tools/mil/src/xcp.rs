//! What `mil param`, `mil daq` and `mil filter` share: the board options (`--a2l`, `--port`,
//! `--xcp-ids`, `--secret-file`, `--timeout-ms`), the A2L table, the seed & key secret and
//! the connection to the board (CONNECT, then a check that the A2L's parameters lie inside
//! the board's calibration page).

use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{anyhow, bail, Context, Result};
use mil_xcp_master::{A2l, CanIds, Item, Master, Port, PortSpec};

/// Environment variable holding the seed & key secret when no `--secret-file` is given (the
/// firmware build reads the same variable).
pub const SECRET_ENV: &str = "MIL_XCP_SECRET";

/// Shortest secret the board accepts (bytes).
pub const MIN_SECRET_LEN: usize = mil_xcp::MIN_SECRET_LEN;

/// The A2L file and the way to the board.
#[derive(clap::Args, Clone, Debug)]
pub struct BoardArgs {
    /// The board's A2L file (`mil a2l --elf FIRMWARE --out mil.a2l` writes it).
    #[arg(long)]
    pub a2l: PathBuf,
    /// Where the board is: `tcp:HOST:PORT` (SLCAN over TCP, e.g. QEMU's serial port),
    /// `serial:DEVICE[@BAUD]` (SLCAN adapter, CAN at 1 Mbit/s) or `socketcan:IFNAME` (builds
    /// with the `socketcan` feature).
    #[arg(long)]
    pub port: PortSpec,
    /// XCP CAN IDs CMD,RES (master → board, board → master), hex with 0x or decimal: as the
    /// firmware's build-time MIL_XCP_CAN_IDS.
    #[arg(long, default_value = "0x7E0,0x7E1")]
    pub xcp_ids: CanIds,
    /// File holding the seed & key secret (text, or hex:... as MIL_XCP_SECRET); without it
    /// the environment variable MIL_XCP_SECRET is used.
    #[arg(long)]
    pub secret_file: Option<PathBuf>,
    /// How long to wait for each response of the board (ms).
    #[arg(long, default_value_t = 1000)]
    pub timeout_ms: u64,
}

impl BoardArgs {
    /// The response timeout.
    pub fn timeout(&self) -> Duration {
        Duration::from_millis(self.timeout_ms.max(1))
    }
}

/// Reads and parses the A2L file; parser warnings go to stderr.
///
/// # Errors
/// The file cannot be read or is not a valid A2L file (one line naming it).
pub fn load_a2l(path: &Path) -> Result<A2l> {
    let a2l = A2l::load(path)?;
    for w in a2l.warnings.iter().take(3) {
        eprintln!("warning: {}: {w}", path.display());
    }
    if a2l.warnings.len() > 3 {
        eprintln!(
            "warning: {}: {} more parser warnings",
            path.display(),
            a2l.warnings.len() - 3
        );
    }
    Ok(a2l)
}

/// The secret as the firmware build takes it: `hex:` followed by hex digits, else the text's
/// bytes; at least [`MIN_SECRET_LEN`] bytes.
///
/// # Errors
/// Bad hex, or too short.
pub fn parse_secret(text: &str, source: &str) -> Result<Vec<u8>> {
    let bytes = match text.strip_prefix("hex:") {
        Some(hex) => {
            let hex = hex.trim();
            if hex.len() % 2 != 0 {
                bail!("{source}: odd number of hex digits");
            }
            (0..hex.len() / 2)
                .map(|i| {
                    hex.get(2 * i..2 * i + 2)
                        .and_then(|pair| u8::from_str_radix(pair, 16).ok())
                })
                .collect::<Option<Vec<u8>>>()
                .ok_or_else(|| anyhow!("{source}: bad hex digits"))?
        }
        None => text.as_bytes().to_vec(),
    };
    if bytes.len() < MIN_SECRET_LEN {
        bail!(
            "{source}: {} bytes, the board's secret has at least {MIN_SECRET_LEN}",
            bytes.len()
        );
    }
    Ok(bytes)
}

/// The secret from `--secret-file` (one trailing line break dropped) or from
/// [`SECRET_ENV`].
///
/// # Errors
/// Neither is given, the file cannot be read, or the secret is malformed.
pub fn secret(args: &BoardArgs) -> Result<Vec<u8>> {
    if let Some(path) = &args.secret_file {
        let text = std::fs::read_to_string(path)
            .map_err(|e| anyhow!("secret file {}: {e}", path.display()))?;
        let text = text
            .strip_suffix("\r\n")
            .or_else(|| text.strip_suffix('\n'))
            .unwrap_or(&text);
        return parse_secret(text, &path.display().to_string());
    }
    match std::env::var(SECRET_ENV) {
        Ok(text) => parse_secret(&text, SECRET_ENV),
        Err(_) => bail!(
            "this needs the board's seed & key secret: give --secret-file PATH or set {SECRET_ENV} (text or hex:...)"
        ),
    }
}

/// Opens the port, connects, and checks that the A2L's calibration parameters lie inside
/// the board's calibration page (GET_SEGMENT_INFO; skipped where the board does not answer
/// it).
///
/// # Errors
/// The port cannot be opened, the board does not answer, or the A2L does not match it.
pub fn connect(args: &BoardArgs, a2l: &A2l) -> Result<Master<Port>> {
    let timeout = args.timeout();
    let port = args
        .port
        .open(timeout.max(Duration::from_secs(2)))
        .with_context(|| "cannot open the port".to_string())?;
    let mut master = Master::new(port, args.xcp_ids, timeout);
    master
        .connect()
        .with_context(|| format!("no XCP connection on CAN IDs {}", args.xcp_ids))?;
    check_layout(&mut master, a2l, &args.a2l)?;
    Ok(master)
}

/// Connects ([`connect`]), runs `f` and disconnects (also when `f` fails; a failing
/// DISCONNECT after a successful `f` is reported on stderr only, unless the board's side
/// of the link is gone: nothing is left to disconnect).
///
/// # Errors
/// Those of [`connect`] and of `f`.
pub fn session<R>(
    args: &BoardArgs,
    a2l: &A2l,
    f: impl FnOnce(&mut Master<Port>) -> Result<R>,
) -> Result<R> {
    let mut master = connect(args, a2l)?;
    let result = f(&mut master);
    if let Err(e) = master.disconnect() {
        let gone = matches!(&e, mil_xcp_master::Error::Io(io) if matches!(
            io.kind(),
            std::io::ErrorKind::BrokenPipe
                | std::io::ErrorKind::ConnectionReset
                | std::io::ErrorKind::ConnectionAborted
                | std::io::ErrorKind::NotConnected
                | std::io::ErrorKind::UnexpectedEof
        ));
        if result.is_ok() && !gone {
            eprintln!("warning: DISCONNECT: {e}");
        }
    }
    result
}

/// Every characteristic of `a2l` must lie inside the board's calibration segment 0.
fn check_layout(master: &mut Master<Port>, a2l: &A2l, path: &Path) -> Result<()> {
    let Ok((start, len)) = master.segment_address(0) else {
        return Ok(());
    };
    let end = u64::from(start) + u64::from(len);
    for c in &a2l.characteristics {
        let (a, b) = (u64::from(c.address), u64::from(c.address) + c.size() as u64);
        if a < u64::from(start) || b > end {
            bail!(
                "{} does not match the board: `{}` at 0x{:08X}, the board's calibration page is 0x{start:08X}..0x{end:08X} (regenerate it with `mil a2l --elf` from the running firmware)",
                path.display(),
                c.name,
                c.address
            );
        }
    }
    Ok(())
}

/// A value as the item holds it: the shortest form of its data type that reads back
/// exactly, with an exponent outside 1e-6 ..= 1e9.
pub fn format_value(item: &Item, v: f64) -> String {
    use mil_xcp_master::a2l::DataType;
    let plain = |a: f64| a == 0.0 || (1e-6..1e9).contains(&a.abs());
    if item.conversion.is_identity() {
        match item.datatype {
            DataType::F32 => {
                let x = v as f32;
                return if plain(v) {
                    format!("{x}")
                } else {
                    format!("{x:e}")
                };
            }
            d if d.is_integer() => return format!("{v:.0}"),
            _ => {}
        }
    }
    if plain(v) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

/// A limit for tables: plain for moderate magnitudes, else with an exponent.
pub fn format_limit(v: f64) -> String {
    let a = v.abs();
    if a != 0.0 && !(1e-3..1e7).contains(&a) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn secrets_are_text_or_hex_as_for_the_firmware_build() {
        assert_eq!(
            parse_secret("FAKE-TEST-SECRET-do-not-use-0000", "t").unwrap(),
            b"FAKE-TEST-SECRET-do-not-use-0000".to_vec()
        );
        let hex = parse_secret("hex:000102030405060708090a0b0c0d0e0F", "t").unwrap();
        assert_eq!(hex, (0u8..16).collect::<Vec<_>>());
        assert!(parse_secret("hex:0001020", "t")
            .unwrap_err()
            .to_string()
            .contains("odd"));
        assert!(parse_secret("hex:zz0102030405060708090a0b0c0d0e0f", "t").is_err());
        let short = parse_secret("short", "MIL_XCP_SECRET")
            .unwrap_err()
            .to_string();
        assert_eq!(
            short,
            "MIL_XCP_SECRET: 5 bytes, the board's secret has at least 16"
        );
    }

    #[test]
    fn values_print_in_their_types_shortest_form() {
        use mil_xcp_master::a2l::{Conversion, DataType, Endian};
        let mut item = Item {
            name: "x".into(),
            description: String::new(),
            address: 0,
            extension: 0,
            datatype: DataType::F32,
            endian: Endian::Little,
            conversion: Conversion::Identical,
            min: -1e30,
            max: 1e30,
            unit: String::new(),
        };
        assert_eq!(format_value(&item, f64::from(0.1f32)), "0.1");
        assert_eq!(format_value(&item, 2.5e5), "250000");
        assert_eq!(
            format_value(&item, f64::from(3.8204714e-37f32)),
            "3.8204714e-37"
        );
        assert_eq!(format_value(&item, 0.0), "0");
        item.datatype = DataType::U32;
        assert_eq!(format_value(&item, 4_000_000_000.0), "4000000000");
        item.datatype = DataType::F64;
        item.conversion = Conversion::Linear { a: 0.5, b: 0.0 };
        assert_eq!(format_value(&item, 0.1), "0.1");
    }

    #[test]
    fn limits_print_compactly() {
        assert_eq!(format_limit(1000.0), "1000");
        assert_eq!(format_limit(-4.0), "-4");
        assert_eq!(format_limit(0.0), "0");
        assert_eq!(format_limit(1e9), "1e9");
        assert_eq!(format_limit(4294967296.0), "4.294967296e9");
    }
}
