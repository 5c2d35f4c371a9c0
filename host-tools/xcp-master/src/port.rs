//! Where the board is: `--port` specifications and the transport they open.
//!
//! - `tcp:HOST:PORT`: SLCAN over TCP ([`mil_can::SlcanTcp`]), as QEMU exposes the board's
//!   serial port; the SLCAN handshake is the one the QEMU build expects.
//! - `serial:PATH[@BAUD]`: an SLCAN adapter on a serial device ([`SlcanSerial`]), CAN at
//!   1 Mbit/s.
//! - `socketcan:IFNAME`: a SocketCAN interface (feature `socketcan`, Linux).

use std::io;
use std::net::ToSocketAddrs;
use std::str::FromStr;
use std::time::Duration;

use mil_can::{SlcanTcp, Transport};
use mil_frames::RawFrame;

use crate::serial::{SlcanSerial, BITRATE_1M, DEFAULT_BAUD};

/// A parsed `--port` (see the module documentation).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum PortSpec {
    /// SLCAN over TCP to `HOST:PORT`.
    Tcp(String),
    /// SLCAN on a serial device.
    Serial {
        /// The device.
        path: String,
        /// Line speed (bit/s).
        baud: u32,
    },
    /// A SocketCAN interface.
    SocketCan(String),
}

impl FromStr for PortSpec {
    type Err = String;

    fn from_str(text: &str) -> Result<Self, String> {
        let (kind, rest) = text.split_once(':').ok_or_else(|| {
            format!("`{text}`: expected tcp:HOST:PORT, serial:DEVICE[@BAUD] or socketcan:IFNAME")
        })?;
        match kind {
            "tcp" => {
                let ok = rest
                    .rsplit_once(':')
                    .is_some_and(|(h, p)| !h.is_empty() && p.parse::<u16>().is_ok());
                if !ok {
                    return Err(format!("`{text}`: expected tcp:HOST:PORT"));
                }
                Ok(Self::Tcp(rest.to_string()))
            }
            "serial" => {
                let (path, baud) = match rest.rsplit_once('@') {
                    Some((p, b)) => (
                        p,
                        b.parse::<u32>()
                            .map_err(|_| format!("`{text}`: `{b}` is not a baud rate"))?,
                    ),
                    None => (rest, DEFAULT_BAUD),
                };
                if path.is_empty() {
                    return Err(format!("`{text}`: expected serial:DEVICE[@BAUD]"));
                }
                Ok(Self::Serial {
                    path: path.to_string(),
                    baud,
                })
            }
            "socketcan" if !rest.is_empty() => Ok(Self::SocketCan(rest.to_string())),
            _ => Err(format!(
                "`{text}`: expected tcp:HOST:PORT, serial:DEVICE[@BAUD] or socketcan:IFNAME"
            )),
        }
    }
}

/// An open transport of any kind.
pub enum Port {
    /// SLCAN over TCP.
    Tcp(SlcanTcp),
    /// SLCAN on a serial device.
    Serial(SlcanSerial),
    /// SocketCAN.
    #[cfg(feature = "socketcan")]
    SocketCan(mil_can::SocketCan),
}

impl std::fmt::Debug for Port {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Tcp(t) => f.debug_tuple("Tcp").field(t).finish(),
            Self::Serial(s) => f.debug_tuple("Serial").field(s).finish(),
            #[cfg(feature = "socketcan")]
            Self::SocketCan(_) => f.write_str("SocketCan"),
        }
    }
}

/// How long [`PortSpec::open`] tries a TCP port that refuses the connection (a board in QEMU
/// still starting).
pub const CONNECT_WAIT: Duration = Duration::from_secs(10);

impl PortSpec {
    /// Opens the port; `timeout` bounds the TCP connection and the SLCAN handshake.
    ///
    /// # Errors
    /// The port cannot be reached or opened (the message names it).
    pub fn open(&self, timeout: Duration) -> io::Result<Port> {
        let named = |e: io::Error, what: &str| io::Error::new(e.kind(), format!("{what}: {e}"));
        match self {
            Self::Tcp(addr) => {
                let target = addr
                    .to_socket_addrs()
                    .map_err(|e| named(e, addr))?
                    .next()
                    .ok_or_else(|| io::Error::new(io::ErrorKind::NotFound, format!("{addr}: no address")))?;
                // A port not open yet (QEMU or `mil sim --xcp` starting) is tried again for
                // up to CONNECT_WAIT.
                let mut t = SlcanTcp::connect(target, timeout.max(CONNECT_WAIT))
                    .map_err(|e| named(e, addr))?;
                t.open(timeout)
                    .map_err(|e| named(e, &format!("{addr} (SLCAN open)")))?;
                Ok(Port::Tcp(t))
            }
            Self::Serial { path, baud } => {
                Ok(Port::Serial(SlcanSerial::open(path, *baud, BITRATE_1M)?))
            }
            #[cfg(feature = "socketcan")]
            Self::SocketCan(ifname) => Ok(Port::SocketCan(
                mil_can::SocketCan::open(ifname).map_err(|e| named(e, ifname))?,
            )),
            #[cfg(not(feature = "socketcan"))]
            Self::SocketCan(_) => Err(io::Error::new(
                io::ErrorKind::Unsupported,
                "socketcan ports need a build with the `socketcan` feature (cargo build -p mil --features socketcan)",
            )),
        }
    }
}

impl Transport for Port {
    fn send(&mut self, frame: &RawFrame) -> io::Result<()> {
        match self {
            Self::Tcp(t) => t.send(frame),
            Self::Serial(s) => s.send(frame),
            #[cfg(feature = "socketcan")]
            Self::SocketCan(s) => s.send(frame),
        }
    }

    fn recv(&mut self, timeout: Duration) -> io::Result<Option<RawFrame>> {
        match self {
            Self::Tcp(t) => t.recv(timeout),
            Self::Serial(s) => s.recv(timeout),
            #[cfg(feature = "socketcan")]
            Self::SocketCan(s) => s.recv(timeout),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn port_specs() {
        assert_eq!(
            "tcp:127.0.0.1:5555".parse(),
            Ok(PortSpec::Tcp("127.0.0.1:5555".into()))
        );
        assert_eq!(
            "tcp:localhost:1".parse(),
            Ok(PortSpec::Tcp("localhost:1".into()))
        );
        assert_eq!(
            "serial:/dev/ttyACM0".parse(),
            Ok(PortSpec::Serial {
                path: "/dev/ttyACM0".into(),
                baud: DEFAULT_BAUD
            })
        );
        assert_eq!(
            "serial:/dev/ttyUSB1@921600".parse(),
            Ok(PortSpec::Serial {
                path: "/dev/ttyUSB1".into(),
                baud: 921_600
            })
        );
        assert_eq!(
            "socketcan:can0".parse(),
            Ok(PortSpec::SocketCan("can0".into()))
        );
        for bad in [
            "tcp:5555",
            "tcp::5555",
            "tcp:host:x",
            "serial:",
            "serial:/dev/x@fast",
            "can0",
            "usb:x",
        ] {
            assert!(bad.parse::<PortSpec>().is_err(), "{bad}");
        }
    }
}
