//! Reading request parameters (Intel byte order) and the internal failure type.
//!
//! A request may be longer than its parameters (XCP on CAN masters often pad to DLC 8); a
//! request too short for its parameters answers `ERR_CMD_SYNTAX`.

use crate::protocol::ErrorCode;

/// A failed command: the error code and, for DOWNLOAD_NEXT's `ERR_SEQUENCE`, the number of
/// data bytes the slave expected.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Failure {
    pub code: ErrorCode,
    pub detail: Option<u8>,
}

impl From<ErrorCode> for Failure {
    fn from(code: ErrorCode) -> Self {
        Self { code, detail: None }
    }
}

pub(crate) type CmdResult = Result<(), Failure>;

/// Byte `i` of the request.
pub(crate) fn byte(cto: &[u8], i: usize) -> Result<u8, Failure> {
    cto.get(i)
        .copied()
        .ok_or(Failure::from(ErrorCode::CmdSyntax))
}

/// Little-endian `u16` at `i`.
pub(crate) fn word(cto: &[u8], i: usize) -> Result<u16, Failure> {
    let bytes = cto
        .get(i..i + 2)
        .and_then(|b| <[u8; 2]>::try_from(b).ok())
        .ok_or(Failure::from(ErrorCode::CmdSyntax))?;
    Ok(u16::from_le_bytes(bytes))
}

/// Little-endian `u32` at `i`.
pub(crate) fn dword(cto: &[u8], i: usize) -> Result<u32, Failure> {
    let bytes = cto
        .get(i..i + 4)
        .and_then(|b| <[u8; 4]>::try_from(b).ok())
        .ok_or(Failure::from(ErrorCode::CmdSyntax))?;
    Ok(u32::from_le_bytes(bytes))
}

/// `n` bytes from `i`.
pub(crate) fn bytes(cto: &[u8], i: usize, n: usize) -> Result<&[u8], Failure> {
    cto.get(i..i + n).ok_or(Failure::from(ErrorCode::CmdSyntax))
}

/// Address extension 0 only.
pub(crate) fn check_extension(ext: u8) -> CmdResult {
    if ext == 0 {
        Ok(())
    } else {
        Err(ErrorCode::OutOfRange.into())
    }
}
