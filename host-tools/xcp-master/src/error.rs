//! Errors of the master, the A2L table and the parameter operations, each with what it means
//! for the user; and the XCP error codes by name.

use std::time::Duration;

use crate::protocol::cmd;

/// An XCP error code (the second byte of a negative response `FE code`), with its name in
/// the standard and what it means on this board.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct XcpErrorCode(pub u8);

impl XcpErrorCode {
    /// The standard's name (`ERR_OUT_OF_RANGE`), or `ERR_0xNN` for a code it does not define.
    #[must_use]
    pub fn name(self) -> String {
        let known = match self.0 {
            0x00 => "ERR_CMD_SYNCH",
            0x10 => "ERR_CMD_BUSY",
            0x11 => "ERR_DAQ_ACTIVE",
            0x12 => "ERR_PGM_ACTIVE",
            0x20 => "ERR_CMD_UNKNOWN",
            0x21 => "ERR_CMD_SYNTAX",
            0x22 => "ERR_OUT_OF_RANGE",
            0x23 => "ERR_WRITE_PROTECTED",
            0x24 => "ERR_ACCESS_DENIED",
            0x25 => "ERR_ACCESS_LOCKED",
            0x26 => "ERR_PAGE_NOT_VALID",
            0x27 => "ERR_MODE_NOT_VALID",
            0x28 => "ERR_SEGMENT_NOT_VALID",
            0x29 => "ERR_SEQUENCE",
            0x2A => "ERR_DAQ_CONFIG",
            0x30 => "ERR_MEMORY_OVERFLOW",
            0x31 => "ERR_GENERIC",
            0x32 => "ERR_VERIFY",
            0x33 => "ERR_RESOURCE_TEMPORARY_NOT_ACCESSIBLE",
            0x34 => "ERR_SUBCMD_UNKNOWN",
            _ => return format!("ERR_0x{:02X}", self.0),
        };
        known.to_string()
    }

    /// What the code means for the user when the board answers it to `command` (a command
    /// code, [`crate::protocol::cmd`]): the board's own documented reasons where it has them.
    #[must_use]
    pub fn meaning(self, command: u8) -> &'static str {
        let writes = matches!(
            command,
            cmd::DOWNLOAD | cmd::DOWNLOAD_NEXT | cmd::COPY_CAL_PAGE | cmd::SET_CAL_PAGE
        );
        match self.0 {
            0x00 => "command processor synchronisation",
            0x10 => "the board is busy",
            0x11 => "refused while DAQ is running",
            0x12 => "refused while programming",
            0x20 => "the board does not implement this command",
            0x21 => "malformed command",
            0x22 if writes => "value refused by the board: outside limits/not finite",
            0x22 => "a parameter of the command is out of range",
            0x23 => "write-protected: the XCP page is the read-only reference page",
            0x24 => {
                "address not accessible: outside the board's calibration/measurement regions (does the A2L match the firmware?)"
            }
            0x25 => "wrong key or not unlocked",
            0x26 => "no such calibration page",
            0x27 => "page mode not valid",
            0x28 => "no such calibration segment",
            0x29 => "command out of sequence",
            0x2A => "DAQ configuration not valid",
            0x30 => "the board's DAQ memory is exhausted (fewer signals)",
            0x31 if writes => "refused: unstable or inconsistent parameter set",
            0x31 => "generic error",
            0x32 => "verification failed",
            0x33 if command == cmd::SET_REQUEST => {
                "the board stores its calibration only while the controller does not run: stop it first"
            }
            0x33 => "resource temporarily not accessible",
            0x34 => "sub-command unknown",
            _ => "error code not defined by the standard",
        }
    }
}

impl std::fmt::Display for XcpErrorCode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.name())
    }
}

/// Errors of [`Master`](crate::Master) and of the operations built on it.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The board did not answer a command in time.
    #[error(
        "no response to {command} within {} ms (board not running, wrong port or CAN IDs?)",
        .timeout.as_millis()
    )]
    Timeout {
        /// The command's name.
        command: &'static str,
        /// How long the master waited.
        timeout: Duration,
    },
    /// A DAQ session received no data in time.
    #[error(
        "no DAQ data within {} ms (the board samples DAQ in its control step: is the controller stepping?)",
        .timeout.as_millis()
    )]
    NoDaqData {
        /// How long the master waited.
        timeout: Duration,
    },
    /// The board answered a command with an XCP error.
    #[error("{command}: the board answered {} ({})", .code.name(), meaning(.code, .command_code))]
    Negative {
        /// The command's name.
        command: &'static str,
        /// The command's code.
        command_code: u8,
        /// The XCP error code.
        code: XcpErrorCode,
        /// The byte after the code, when the board sent one (e.g. the expected count of a
        /// DOWNLOAD_NEXT).
        detail: Option<u8>,
    },
    /// UNLOCK was refused: the key does not match (the board then disconnects).
    #[error(
        "the board refused the key for {resource}: wrong key or not unlocked (wrong secret? the board has disconnected)"
    )]
    KeyRejected {
        /// The resource (`CAL/PAG`, `DAQ`).
        resource: &'static str,
    },
    /// A response that is not what the command should get.
    #[error("{command}: unexpected response [{}]: {why}", hex(.bytes))]
    Unexpected {
        /// The command's name.
        command: &'static str,
        /// The response's bytes.
        bytes: Vec<u8>,
        /// What is wrong with it.
        why: String,
    },
    /// The board cannot do what was asked (a property it reports does not allow it).
    #[error("{0}")]
    Unsupported(String),
    /// A command other than CONNECT without a connection.
    #[error("not connected to the board (CONNECT first)")]
    NotConnected,
    /// The CAN transport failed.
    #[error("CAN transport: {0}")]
    Io(#[from] std::io::Error),
    /// A name the A2L file does not have.
    #[error("no {kind} `{name}` in the A2L file{}", did_you_mean(.suggestion))]
    UnknownName {
        /// `CHARACTERISTIC` or `MEASUREMENT`.
        kind: &'static str,
        /// The name asked for.
        name: String,
        /// The closest name the file has.
        suggestion: Option<String>,
    },
    /// An item the A2L describes in a way this master cannot read or write.
    #[error("{name}: {why}")]
    UnsupportedItem {
        /// The item.
        name: String,
        /// Why.
        why: String,
    },
    /// A value refused on the host before anything was sent.
    #[error("{name} = {value}: {why}; nothing was sent to the board")]
    InvalidValue {
        /// The parameter.
        name: String,
        /// The value given (physical unit).
        value: f64,
        /// Why it was refused.
        why: String,
    },
    /// The board refused a parameter change (the parameters are as they were).
    // The board's answer is part of the message (not an error `source`), so that a chain
    // printed with its sources says it once.
    #[error("{names}: {reason}{}", already_applied(.applied))]
    Refused {
        /// The parameters of the refused change.
        names: String,
        /// The board's answer ([`Error::Negative`]).
        reason: Box<Error>,
        /// Parameters of earlier changes of the same call that the board had accepted.
        applied: Vec<String>,
    },
}

fn meaning(code: &XcpErrorCode, command: &u8) -> &'static str {
    code.meaning(*command)
}

fn did_you_mean(suggestion: &Option<String>) -> String {
    suggestion
        .as_ref()
        .map(|s| format!(" (did you mean `{s}`?)"))
        .unwrap_or_default()
}

fn already_applied(applied: &[String]) -> String {
    if applied.is_empty() {
        String::new()
    } else {
        format!(" (accepted before it: {})", applied.join(", "))
    }
}

/// Bytes as `FE 22` for messages.
pub(crate) fn hex(bytes: &[u8]) -> String {
    bytes
        .iter()
        .map(|b| format!("{b:02X}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// Result with [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// The XCP error code when the board answered one (directly or inside [`Error::Refused`]).
    #[must_use]
    pub fn xcp_code(&self) -> Option<XcpErrorCode> {
        match self {
            Self::Negative { code, .. } => Some(*code),
            Self::Refused { reason, .. } => reason.xcp_code(),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mil_xcp::ErrorCode;

    #[test]
    fn every_code_the_slave_answers_has_its_standard_name() {
        let codes = [
            (ErrorCode::CmdSynch, "ERR_CMD_SYNCH"),
            (ErrorCode::CmdBusy, "ERR_CMD_BUSY"),
            (ErrorCode::DaqActive, "ERR_DAQ_ACTIVE"),
            (ErrorCode::PgmActive, "ERR_PGM_ACTIVE"),
            (ErrorCode::CmdUnknown, "ERR_CMD_UNKNOWN"),
            (ErrorCode::CmdSyntax, "ERR_CMD_SYNTAX"),
            (ErrorCode::OutOfRange, "ERR_OUT_OF_RANGE"),
            (ErrorCode::WriteProtected, "ERR_WRITE_PROTECTED"),
            (ErrorCode::AccessDenied, "ERR_ACCESS_DENIED"),
            (ErrorCode::AccessLocked, "ERR_ACCESS_LOCKED"),
            (ErrorCode::PageNotValid, "ERR_PAGE_NOT_VALID"),
            (ErrorCode::ModeNotValid, "ERR_MODE_NOT_VALID"),
            (ErrorCode::SegmentNotValid, "ERR_SEGMENT_NOT_VALID"),
            (ErrorCode::Sequence, "ERR_SEQUENCE"),
            (ErrorCode::DaqConfig, "ERR_DAQ_CONFIG"),
            (ErrorCode::MemoryOverflow, "ERR_MEMORY_OVERFLOW"),
            (ErrorCode::Generic, "ERR_GENERIC"),
            (ErrorCode::Verify, "ERR_VERIFY"),
        ];
        for (code, name) in codes {
            assert_eq!(XcpErrorCode(code.code()).name(), name);
        }
        assert_eq!(XcpErrorCode(0x7A).name(), "ERR_0x7A");
    }

    #[test]
    fn write_refusals_say_what_the_board_checks() {
        let out_of_range = XcpErrorCode(0x22);
        assert!(out_of_range
            .meaning(cmd::DOWNLOAD)
            .contains("outside limits/not finite"));
        assert!(!out_of_range.meaning(cmd::SET_MTA).contains("limits"));
        assert!(XcpErrorCode(0x31)
            .meaning(cmd::DOWNLOAD_NEXT)
            .contains("unstable or inconsistent"));
        assert!(XcpErrorCode(0x25)
            .meaning(cmd::DOWNLOAD)
            .contains("not unlocked"));
        let e = Error::Negative {
            command: "DOWNLOAD",
            command_code: cmd::DOWNLOAD,
            code: out_of_range,
            detail: None,
        };
        assert_eq!(
            e.to_string(),
            "DOWNLOAD: the board answered ERR_OUT_OF_RANGE (value refused by the board: outside limits/not finite)"
        );
        let refused = Error::Refused {
            names: "tyre_lift_off = 0.5".into(),
            reason: Box::new(e),
            applied: vec!["tyre_damping".into()],
        };
        assert_eq!(refused.xcp_code(), Some(out_of_range));
        // Said once, also where a chain of sources is printed.
        assert!(std::error::Error::source(&refused).is_none());
        assert_eq!(
            refused.to_string(),
            "tyre_lift_off = 0.5: DOWNLOAD: the board answered ERR_OUT_OF_RANGE (value refused by the board: outside limits/not finite) (accepted before it: tyre_damping)"
        );
    }
}
