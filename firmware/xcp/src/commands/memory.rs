//! Memory transfer: SET_MTA, UPLOAD, SHORT_UPLOAD, DOWNLOAD, DOWNLOAD_NEXT.
//!
//! Reads are permitted inside the calibration region (through the XCP access page), the
//! measurement region and the virtual areas the MTA points at after GET_ID /
//! GET_DAQ_EVENT_INFO; writes only inside the calibration region, only to the working page
//! and only with CAL/PAG unlocked. Every access is checked as a whole before anything is read
//! or written; the MTA is post-incremented only after a successful transfer.
//!
//! Master block mode: DOWNLOAD with `n > 6` starts a block of `n <= 252` bytes (checked
//! then), DOWNLOAD_NEXT frames carry the rest with the remaining count; the block is written
//! with one [`Calibration::write`] when its last byte arrives, and answered then. A
//! DOWNLOAD_NEXT whose count is not the one expected answers `ERR_SEQUENCE` with the expected
//! count and drops the block; so does a DOWNLOAD that arrives while a block is pending (pyxcp
//! sends one for blocks of 7–11 bytes, see the crate documentation), and any other command
//! drops the block silently. Nothing of a dropped block is written.

use crate::access::{resolve, to_usize, virtual_bytes, Area, Mta, Virtual};
use crate::commands::daq::EVENT_NAME;
use crate::memory::{Calibration, Memory, Page};
use crate::protocol::{resource, ErrorCode, MAX_BLOCK_BYTES, MAX_CTO, UPLOAD_BYTES_PER_FRAME};
use crate::response::Responses;
use crate::slave::{Block, Slave};
use crate::wire::{byte, bytes, check_extension, dword, CmdResult, Failure};

/// Data bytes in a DOWNLOAD or DOWNLOAD_NEXT frame.
const DOWNLOAD_BYTES_PER_FRAME: usize = MAX_CTO - 2;

impl Slave {
    /// SET_MTA `F6 reserved(2) ext addr(u32)`: extension 0 only. The address is checked when
    /// it is used.
    pub(crate) fn set_mta(&mut self, cto: &[u8], out: &mut Responses) -> CmdResult {
        let ext = byte(cto, 3)?;
        let addr = dword(cto, 4)?;
        check_extension(ext)?;
        self.mta = Mta::Address(addr);
        out.ok(&[]);
        Ok(())
    }

    /// UPLOAD `F5 n`: `n` (1..=255) bytes from the MTA, in frames of up to 7 data bytes
    /// (slave block mode), then MTA += n.
    pub(crate) fn upload(
        &mut self,
        cto: &[u8],
        memory: &impl Memory,
        out: &mut Responses,
    ) -> CmdResult {
        let n = byte(cto, 1)?;
        self.read_into(self.mta, n, memory, out)?;
        self.mta = self.mta.advanced(u32::from(n));
        Ok(())
    }

    /// SHORT_UPLOAD `F4 n reserved ext addr(u32)`: `n` (1..=7) bytes from `addr` in one frame;
    /// the MTA is then `addr + n`, as the standard says.
    pub(crate) fn short_upload(
        &mut self,
        cto: &[u8],
        memory: &impl Memory,
        out: &mut Responses,
    ) -> CmdResult {
        let n = byte(cto, 1)?;
        let ext = byte(cto, 3)?;
        let addr = dword(cto, 4)?;
        if n == 0 || usize::from(n) > UPLOAD_BYTES_PER_FRAME {
            return Err(ErrorCode::OutOfRange.into());
        }
        check_extension(ext)?;
        let mta = Mta::Address(addr);
        self.read_into(mta, n, memory, out)?;
        self.mta = mta.advanced(u32::from(n));
        Ok(())
    }

    /// Read `n` bytes at `mta` (all permitted, or nothing) and push them as response frames.
    fn read_into(&self, mta: Mta, n: u8, memory: &impl Memory, out: &mut Responses) -> CmdResult {
        if n == 0 {
            return Err(ErrorCode::OutOfRange.into());
        }
        let mut buf = [0_u8; u8::MAX as usize];
        let data = buf.get_mut(..usize::from(n)).ok_or(ErrorCode::OutOfRange)?;
        match mta {
            Mta::Address(addr) => {
                let r = resolve(&self.config, addr, u32::from(n), false)
                    .ok_or(ErrorCode::AccessDenied)?;
                let offset = to_usize(r.offset).ok_or(ErrorCode::AccessDenied)?;
                match r.area {
                    Area::Calibration => memory.read_calibration(self.pages.xcp, offset, data),
                    Area::Measurement => memory.read_measurement(offset, data),
                }
            }
            Mta::Virtual { area, offset } => {
                let source = match area {
                    Virtual::Id => self.config.id,
                    Virtual::EventName => EVENT_NAME,
                };
                let src =
                    virtual_bytes(source, offset, u32::from(n)).ok_or(ErrorCode::AccessDenied)?;
                data.copy_from_slice(src);
            }
        }
        for chunk in data.chunks(UPLOAD_BYTES_PER_FRAME) {
            out.ok(chunk);
        }
        Ok(())
    }

    /// The calibration offset a write of `n` bytes at the MTA goes to, or why it may not.
    fn write_offset(&self, n: u8) -> Result<u32, Failure> {
        let Mta::Address(addr) = self.mta else {
            return Err(ErrorCode::AccessDenied.into());
        };
        let r = resolve(&self.config, addr, u32::from(n), true).ok_or(ErrorCode::AccessDenied)?;
        if self.pages.xcp == Page::Reference {
            return Err(ErrorCode::WriteProtected.into());
        }
        Ok(r.offset)
    }

    /// Hand a write to the application; a refusal is recorded and answered.
    fn write_calibration(
        &mut self,
        target: &mut impl Calibration,
        offset: u32,
        data: &[u8],
    ) -> CmdResult {
        let offset = to_usize(offset).ok_or(ErrorCode::AccessDenied)?;
        target
            .write(offset, data)
            .map_err(|reason| self.rejected(reason))
    }

    /// DOWNLOAD `F0 n data…`: `n <= 6` is written at once; `7 <= n <= 252` starts a block
    /// (no answer until its last DOWNLOAD_NEXT). MTA += n after the write.
    pub(crate) fn download(
        &mut self,
        cto: &[u8],
        target: &mut impl Calibration,
        out: &mut Responses,
    ) -> CmdResult {
        self.require_unlocked(resource::CAL_PAG)?;
        let n = byte(cto, 1)?;
        let len = usize::from(n);
        if n == 0 || len > MAX_BLOCK_BYTES {
            return Err(ErrorCode::OutOfRange.into());
        }
        let first = bytes(cto, 2, len.min(DOWNLOAD_BYTES_PER_FRAME))?;
        let offset = self.write_offset(n)?;
        let Mta::Address(addr) = self.mta else {
            return Err(ErrorCode::AccessDenied.into());
        };
        if len <= DOWNLOAD_BYTES_PER_FRAME {
            self.write_calibration(target, offset, first)?;
            self.mta = self.mta.advanced(u32::from(n));
            out.ok(&[]);
            return Ok(());
        }
        let mut block = Block {
            addr,
            offset,
            total: n,
            received: 0,
            data: [0; MAX_BLOCK_BYTES],
        };
        if let Some(dst) = block.data.get_mut(..first.len()) {
            dst.copy_from_slice(first);
        }
        // `first.len()` is DOWNLOAD_BYTES_PER_FRAME here.
        block.received = u8::try_from(first.len()).map_err(|_| ErrorCode::OutOfRange)?;
        self.block = Some(block);
        Ok(())
    }

    /// DOWNLOAD_NEXT `EF remaining data…` (master block mode).
    pub(crate) fn download_next(
        &mut self,
        cto: &[u8],
        target: &mut impl Calibration,
        out: &mut Responses,
    ) -> CmdResult {
        let Some(mut block) = self.block.take() else {
            return Err(Failure {
                code: ErrorCode::Sequence,
                detail: Some(0),
            });
        };
        let expected = block.total.saturating_sub(block.received);
        let remaining = byte(cto, 1)?;
        if remaining != expected {
            return Err(Failure {
                code: ErrorCode::Sequence,
                detail: Some(expected),
            });
        }
        let n = usize::from(remaining).min(DOWNLOAD_BYTES_PER_FRAME);
        let data = bytes(cto, 2, n)?;
        let start = usize::from(block.received);
        let dst = block
            .data
            .get_mut(start..start + n)
            .ok_or(ErrorCode::OutOfRange)?;
        dst.copy_from_slice(data);
        block.received = block
            .received
            .saturating_add(u8::try_from(n).map_err(|_| ErrorCode::OutOfRange)?);
        if block.received < block.total {
            self.block = Some(block);
            return Ok(());
        }
        let whole = block
            .data
            .get(..usize::from(block.total))
            .ok_or(ErrorCode::OutOfRange)?;
        self.write_calibration(target, block.offset, whole)?;
        self.mta = Mta::Address(block.addr).advanced(u32::from(block.total));
        out.ok(&[]);
        Ok(())
    }
}
