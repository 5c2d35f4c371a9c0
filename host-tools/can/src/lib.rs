//! # mil-can
//!
//! The host side of the link to the MiL board (`mil-firmware`): CAN frames (`mil-frames`)
//! over a [`Transport`], and a [`RemoteBoard`] that plugs the board into the rig harness
//! (`mil_rig::harness::run`) in place of the host's own controller.
//!
//! - [`Transport`]: send and receive raw CAN frames ([`mil_frames::RawFrame`]).
//! - [`SlcanTcp`]: SLCAN (Lawicel ASCII) over TCP, the form QEMU's
//!   `-serial tcp:...` gives the QEMU build's USART1. The tested transport.
//! - `SocketCan` (feature `socketcan`, Linux): a SocketCAN interface (`can0`, `vcan0`).
//!   Built, not tested: vcan is not available on the machines the tests run on.
//! - [`Qemu`]: starts the QEMU build of the firmware on QEMU's `netduinoplus2` with its
//!   USART1 on a free TCP port, and returns the connected, opened [`SlcanTcp`].
//! - [`XcpRelay`]: the board's XCP port served at a chosen address for XCP tools while a
//!   harness drives the board, and the moment a DAQ measurement starts.
//! - [`RemoteBoard`]: `mil_rig::harness::Board<1>` over any transport, with a host mirror of
//!   the firmware's controller that checks every demand frame bit for bit.
//! - [`footprint`]: flash and static RAM of a firmware ELF from its section headers.
//!
//! The firmware's budgets (instructions per control step in QEMU with
//! `-icount shift=0,align=off,sleep=off`, flash and static RAM, stack high-water mark):
//! `cargo run -p mil-can --example qemu_budget` (`examples/qemu_budget.rs`).
//!
//! The lockstep test (`tests/qemu_lockstep.rs`) needs the firmware ELF, built by
//! `cargo build -p mil-firmware --target thumbv7em-none-eabihf --release --features qemu`,
//! and `qemu-system-arm` (`apt-get install -y qemu-system-arm`).
#![forbid(unsafe_code)]
#![deny(missing_docs)]

mod board;
mod configure;
pub mod footprint;
mod qemu;
mod relay;
mod slcan;
#[cfg(feature = "socketcan")]
mod socket;
mod transport;

pub use board::{RemoteBoard, Sample, DEFAULT_REPLY_TIMEOUT};
pub use configure::{configure, Configured, XcpLink};
pub use qemu::{
    find_firmware_elf, listening_ports, Qemu, QemuOptions, QemuOutput, FIRMWARE_BUILD_COMMAND,
};
pub use relay::XcpRelay;
pub use slcan::{LineCounts, SlcanTcp};
#[cfg(feature = "socketcan")]
pub use socket::SocketCan;
pub use transport::Transport;

/// The frame layout the firmware uses (the DBC's base ID 0x100 and factors).
pub const LAYOUT: mil_frames::Layout = mil_firmware::link::LAYOUT;
