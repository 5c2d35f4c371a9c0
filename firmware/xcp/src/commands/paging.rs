//! Page switching: SET_CAL_PAGE, GET_CAL_PAGE, GET_PAG_PROCESSOR_INFO, GET_SEGMENT_INFO,
//! GET_PAGE_INFO, COPY_CAL_PAGE. One segment (0) with page 0 (working, RAM) and page 1
//! (reference, flash, read-only). Changing anything needs CAL/PAG unlocked; the queries do
//! not.

use crate::memory::{Calibration, Page};
use crate::pages::{mode, page_properties, PAGES, SEGMENTS};
use crate::protocol::{resource, ErrorCode};
use crate::response::Responses;
use crate::slave::Slave;
use crate::wire::{byte, CmdResult};

fn check_segment(segment: u8) -> CmdResult {
    if segment < SEGMENTS {
        Ok(())
    } else {
        Err(ErrorCode::SegmentNotValid.into())
    }
}

fn page(number: u8) -> Result<Page, ErrorCode> {
    Page::from_number(number).ok_or(ErrorCode::PageNotValid)
}

impl Slave {
    /// SET_CAL_PAGE `EB mode segment page`: mode bits 0x01 ECU, 0x02 XCP (at least one),
    /// 0x80 all segments. The ECU page changes only when the application accepts it.
    pub(crate) fn set_cal_page(
        &mut self,
        cto: &[u8],
        target: &mut impl Calibration,
        out: &mut Responses,
    ) -> CmdResult {
        self.require_unlocked(resource::CAL_PAG)?;
        let m = byte(cto, 1)?;
        let segment = byte(cto, 2)?;
        let number = byte(cto, 3)?;
        if m & !(mode::ECU | mode::XCP | mode::ALL) != 0 || m & (mode::ECU | mode::XCP) == 0 {
            return Err(ErrorCode::ModeNotValid.into());
        }
        if m & mode::ALL == 0 {
            check_segment(segment)?;
        }
        let p = page(number)?;
        if m & mode::ECU != 0 {
            target
                .select_ecu_page(p)
                .map_err(|reason| self.rejected(reason))?;
            self.pages.ecu = p;
        }
        if m & mode::XCP != 0 {
            self.pages.xcp = p;
        }
        out.ok(&[]);
        Ok(())
    }

    /// GET_CAL_PAGE `EA mode segment`: mode exactly 0x01 (ECU) or 0x02 (XCP).
    /// `FF reserved reserved page`.
    pub(crate) fn get_cal_page(&mut self, cto: &[u8], out: &mut Responses) -> CmdResult {
        let m = byte(cto, 1)?;
        let segment = byte(cto, 2)?;
        let p = match m {
            mode::ECU => self.pages.ecu,
            mode::XCP => self.pages.xcp,
            _ => return Err(ErrorCode::ModeNotValid.into()),
        };
        check_segment(segment)?;
        out.ok(&[0, 0, p.number()]);
        Ok(())
    }

    /// GET_PAG_PROCESSOR_INFO `E9`: `FF max_segment(1) properties(0: no freeze)`.
    pub(crate) fn get_pag_processor_info(&mut self, out: &mut Responses) -> CmdResult {
        out.ok(&[SEGMENTS, 0]);
        Ok(())
    }

    /// GET_SEGMENT_INFO `E8 mode segment info mapping_index`: mode 0 (info 0 address, 1
    /// length: `FF reserved(3) value(u32)`), mode 1 (`FF max_pages(2) ext(0) max_mapping(0)
    /// compression(0) encryption(0)`); mode 2 (mappings) does not apply.
    pub(crate) fn get_segment_info(&mut self, cto: &[u8], out: &mut Responses) -> CmdResult {
        let m = byte(cto, 1)?;
        let segment = byte(cto, 2)?;
        let info = byte(cto, 3)?;
        check_segment(segment)?;
        match m {
            0 => {
                let value = match info {
                    0 => self.config.calibration.start,
                    1 => self.config.calibration.len,
                    _ => return Err(ErrorCode::OutOfRange.into()),
                };
                let [v0, v1, v2, v3] = value.to_le_bytes();
                out.ok(&[0, 0, 0, v0, v1, v2, v3]);
            }
            1 => out.ok(&[PAGES, 0, 0, 0, 0]),
            _ => return Err(ErrorCode::OutOfRange.into()),
        }
        Ok(())
    }

    /// GET_PAGE_INFO `E7 reserved segment page`: `FF page_properties init_segment(0)`.
    pub(crate) fn get_page_info(&mut self, cto: &[u8], out: &mut Responses) -> CmdResult {
        let segment = byte(cto, 2)?;
        let number = byte(cto, 3)?;
        check_segment(segment)?;
        let p = page(number)?;
        out.ok(&[page_properties(p), 0]);
        Ok(())
    }

    /// COPY_CAL_PAGE `E4 src_segment src_page dst_segment dst_page`: reference → working is
    /// a full-page write the application validates; working → working does nothing; anything
    /// into the reference page is `ERR_WRITE_PROTECTED`.
    pub(crate) fn copy_cal_page(
        &mut self,
        cto: &[u8],
        target: &mut impl Calibration,
        out: &mut Responses,
    ) -> CmdResult {
        self.require_unlocked(resource::CAL_PAG)?;
        let src_segment = byte(cto, 1)?;
        let src_page = byte(cto, 2)?;
        let dst_segment = byte(cto, 3)?;
        let dst_page = byte(cto, 4)?;
        check_segment(src_segment)?;
        check_segment(dst_segment)?;
        let src = page(src_page)?;
        let dst = page(dst_page)?;
        if dst == Page::Reference {
            return Err(ErrorCode::WriteProtected.into());
        }
        if src == Page::Reference {
            target
                .copy_reference_to_working()
                .map_err(|reason| self.rejected(reason))?;
        }
        out.ok(&[]);
        Ok(())
    }
}
