//! SET_CAL_PAGE, GET_CAL_PAGE, COPY_CAL_PAGE and the page queries.

use super::{err, short_upload, Rig};
use crate::mock::{self, CAL_LEN, CAL_START};
use crate::protocol::{cmd, resource};
use crate::{ErrorCode, Page, Rejected};

#[test]
fn both_pages_start_on_the_working_page() {
    let mut rig = Rig::new();
    rig.connect();
    assert_eq!(rig.one(&[cmd::GET_CAL_PAGE, 0x01, 0]), [0xFF, 0, 0, 0]);
    assert_eq!(rig.one(&[cmd::GET_CAL_PAGE, 0x02, 0]), [0xFF, 0, 0, 0]);
    assert_eq!(
        rig.one(&[cmd::GET_CAL_PAGE, 0x03, 0]),
        err(ErrorCode::ModeNotValid)
    );
    assert_eq!(
        rig.one(&[cmd::GET_CAL_PAGE, 0x00, 0]),
        err(ErrorCode::ModeNotValid)
    );
    assert_eq!(
        rig.one(&[cmd::GET_CAL_PAGE, 0x02, 1]),
        err(ErrorCode::SegmentNotValid)
    );
}

#[test]
fn xcp_page_switch_reads_the_reference_and_refuses_writes() {
    let mut rig = Rig::new();
    rig.connect_unlocked();
    rig.ok(&[cmd::SET_CAL_PAGE, 0x02, 0, 1]);
    assert_eq!(rig.one(&[cmd::GET_CAL_PAGE, 0x02, 0]), [0xFF, 0, 0, 1]);
    assert_eq!(
        rig.one(&[cmd::GET_CAL_PAGE, 0x01, 0]),
        [0xFF, 0, 0, 0],
        "ECU page unchanged"
    );
    assert_eq!(rig.slave.xcp_page(), Page::Reference);
    assert_eq!(rig.ecu.ecu_page, Page::Working);
    // Reading page 1 gives the reference bytes (parameter 1 = 101.0).
    let res = rig.one(&short_upload(4, CAL_START + 4));
    assert_eq!(&res[1..], 101.0_f32.to_le_bytes());
    rig.set_mta(CAL_START);
    let frames = rig.send(&[cmd::UPLOAD, 255]);
    let data: Vec<u8> = frames.iter().flat_map(|f| f[1..].to_vec()).collect();
    assert_eq!(data, &mock::initial_reference()[..255]);
    // Writes are refused while XCP accesses the reference page.
    let before = rig.snapshot();
    rig.set_mta(CAL_START);
    assert_eq!(
        rig.one(&[cmd::DOWNLOAD, 4, 0, 0, 0, 0]),
        err(ErrorCode::WriteProtected)
    );
    assert_eq!(
        rig.one(&[cmd::DOWNLOAD, 12, 0, 0, 0, 0, 0, 0]),
        err(ErrorCode::WriteProtected)
    );
    assert_eq!(rig.snapshot(), before);
    // Back on the working page, writes work again.
    rig.ok(&[cmd::SET_CAL_PAGE, 0x02, 0, 0]);
    rig.set_mta(CAL_START);
    rig.ok(&[cmd::DOWNLOAD, 4, 0, 0, 0, 0]);
    assert_eq!(&rig.ecu.working()[..4], [0, 0, 0, 0]);
}

#[test]
fn ecu_page_switch_goes_through_the_application() {
    let mut rig = Rig::new();
    rig.connect_unlocked();
    rig.ok(&[cmd::SET_CAL_PAGE, 0x01, 0, 1]);
    assert_eq!(rig.ecu.ecu_page, Page::Reference);
    assert_eq!(rig.slave.ecu_page(), Page::Reference);
    assert_eq!(rig.slave.xcp_page(), Page::Working);
    // Both at once, "all segments" ignores the segment number.
    rig.ok(&[cmd::SET_CAL_PAGE, 0x83, 7, 0]);
    assert_eq!(rig.slave.ecu_page(), Page::Working);
    assert_eq!(rig.slave.xcp_page(), Page::Working);
    // A refused switch changes nothing and is reported.
    rig.ecu.refuse_page_switch = Some(Rejected::Inconsistent);
    assert_eq!(
        rig.one(&[cmd::SET_CAL_PAGE, 0x03, 0, 1]),
        err(ErrorCode::Generic)
    );
    assert_eq!(rig.slave.ecu_page(), Page::Working);
    assert_eq!(rig.slave.xcp_page(), Page::Working);
    assert_eq!(rig.slave.last_rejection(), Some(Rejected::Inconsistent));
}

#[test]
fn set_cal_page_parameters() {
    let mut rig = Rig::new();
    rig.connect_unlocked();
    assert_eq!(
        rig.one(&[cmd::SET_CAL_PAGE, 0x02, 0, 2]),
        err(ErrorCode::PageNotValid)
    );
    assert_eq!(
        rig.one(&[cmd::SET_CAL_PAGE, 0x02, 1, 0]),
        err(ErrorCode::SegmentNotValid)
    );
    assert_eq!(
        rig.one(&[cmd::SET_CAL_PAGE, 0x00, 0, 0]),
        err(ErrorCode::ModeNotValid)
    );
    assert_eq!(
        rig.one(&[cmd::SET_CAL_PAGE, 0x80, 0, 0]),
        err(ErrorCode::ModeNotValid)
    );
    assert_eq!(
        rig.one(&[cmd::SET_CAL_PAGE, 0x06, 0, 0]),
        err(ErrorCode::ModeNotValid)
    );
    assert_eq!(
        rig.one(&[cmd::SET_CAL_PAGE, 0x02, 0]),
        err(ErrorCode::CmdSyntax)
    );
}

#[test]
fn page_switching_and_copying_need_cal_pag_unlocked() {
    let mut rig = Rig::new();
    rig.connect();
    rig.unlock(resource::DAQ);
    let before = rig.snapshot();
    assert_eq!(
        rig.one(&[cmd::SET_CAL_PAGE, 0x03, 0, 1]),
        err(ErrorCode::AccessLocked)
    );
    assert_eq!(
        rig.one(&[cmd::COPY_CAL_PAGE, 0, 1, 0, 0]),
        err(ErrorCode::AccessLocked)
    );
    assert_eq!(rig.snapshot(), before);
    assert_eq!(rig.slave.ecu_page(), Page::Working);
    assert_eq!(rig.ecu.ecu_page, Page::Working);
}

#[test]
fn copy_reference_to_working() {
    let mut rig = Rig::new();
    rig.connect_unlocked();
    rig.ok(&[cmd::COPY_CAL_PAGE, 0, 1, 0, 0]);
    assert_eq!(rig.ecu.working(), &mock::initial_reference()[..]);
    assert_eq!(rig.ecu.writes, 1);
    // Working → working does nothing; anything into the reference page is refused.
    rig.ok(&[cmd::COPY_CAL_PAGE, 0, 0, 0, 0]);
    assert_eq!(rig.ecu.writes, 1);
    let before = rig.snapshot();
    assert_eq!(
        rig.one(&[cmd::COPY_CAL_PAGE, 0, 0, 0, 1]),
        err(ErrorCode::WriteProtected)
    );
    assert_eq!(
        rig.one(&[cmd::COPY_CAL_PAGE, 0, 1, 0, 1]),
        err(ErrorCode::WriteProtected)
    );
    assert_eq!(
        rig.one(&[cmd::COPY_CAL_PAGE, 0, 2, 0, 0]),
        err(ErrorCode::PageNotValid)
    );
    assert_eq!(
        rig.one(&[cmd::COPY_CAL_PAGE, 1, 1, 0, 0]),
        err(ErrorCode::SegmentNotValid)
    );
    assert_eq!(
        rig.one(&[cmd::COPY_CAL_PAGE, 0, 1, 0]),
        err(ErrorCode::CmdSyntax)
    );
    assert_eq!(rig.snapshot(), before);
}

#[test]
fn copy_of_an_invalid_reference_is_refused() {
    let mut rig = Rig::new();
    rig.ecu.reference[8..12].copy_from_slice(&f32::NAN.to_le_bytes());
    rig.connect_unlocked();
    let before = rig.snapshot();
    assert_eq!(
        rig.one(&[cmd::COPY_CAL_PAGE, 0, 1, 0, 0]),
        err(ErrorCode::OutOfRange)
    );
    assert_eq!(rig.snapshot(), before);
    assert_eq!(rig.slave.last_rejection(), Some(Rejected::NotFinite));
}

#[test]
fn page_queries() {
    let mut rig = Rig::new();
    rig.connect();
    // One segment, no freeze mode.
    assert_eq!(rig.one(&[cmd::GET_PAG_PROCESSOR_INFO]), [0xFF, 0x01, 0x00]);
    // GET_SEGMENT_INFO mode 0: address and length; mode 1: 2 pages, ext 0, no mappings.
    let a = CAL_START.to_le_bytes();
    assert_eq!(
        rig.one(&[cmd::GET_SEGMENT_INFO, 0, 0, 0, 0]),
        [0xFF, 0, 0, 0, a[0], a[1], a[2], a[3]]
    );
    assert_eq!(
        rig.one(&[cmd::GET_SEGMENT_INFO, 0, 0, 1, 0]),
        [0xFF, 0, 0, 0, CAL_LEN as u8, (CAL_LEN >> 8) as u8, 0, 0]
    );
    assert_eq!(
        rig.one(&[cmd::GET_SEGMENT_INFO, 1, 0, 0, 0]),
        [0xFF, 2, 0, 0, 0, 0]
    );
    assert_eq!(
        rig.one(&[cmd::GET_SEGMENT_INFO, 2, 0, 0, 0]),
        err(ErrorCode::OutOfRange)
    );
    assert_eq!(
        rig.one(&[cmd::GET_SEGMENT_INFO, 0, 0, 2, 0]),
        err(ErrorCode::OutOfRange)
    );
    assert_eq!(
        rig.one(&[cmd::GET_SEGMENT_INFO, 0, 1, 0, 0]),
        err(ErrorCode::SegmentNotValid)
    );
    // GET_PAGE_INFO: page 0 read/write for ECU and XCP, page 1 read only.
    assert_eq!(rig.one(&[cmd::GET_PAGE_INFO, 0, 0, 0]), [0xFF, 0x3F, 0x00]);
    assert_eq!(rig.one(&[cmd::GET_PAGE_INFO, 0, 0, 1]), [0xFF, 0x0F, 0x00]);
    assert_eq!(
        rig.one(&[cmd::GET_PAGE_INFO, 0, 0, 2]),
        err(ErrorCode::PageNotValid)
    );
    assert_eq!(
        rig.one(&[cmd::GET_PAGE_INFO, 0, 3, 0]),
        err(ErrorCode::SegmentNotValid)
    );
}
