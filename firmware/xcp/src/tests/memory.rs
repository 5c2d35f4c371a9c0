//! SET_MTA, UPLOAD, SHORT_UPLOAD, DOWNLOAD, DOWNLOAD_NEXT, and the region checks.

use super::{err, short_upload, write_daq, Rig};
use crate::mock::{self, CAL_LEN, CAL_START, MEAS_LEN, MEAS_START};
use crate::protocol::cmd;
use crate::{ErrorCode, Page, Region, Rejected};

fn f32_bytes(x: f32) -> [u8; 4] {
    x.to_le_bytes()
}

#[test]
fn upload_in_block_mode_and_mta_post_increment() {
    let mut rig = Rig::new();
    rig.connect();
    rig.set_mta(MEAS_START + 3);
    let frames = rig.send(&[cmd::UPLOAD, 20]);
    assert_eq!(
        frames,
        [
            vec![0xFF, 3, 4, 5, 6, 7, 8, 9],
            vec![0xFF, 10, 11, 12, 13, 14, 15, 16],
            vec![0xFF, 17, 18, 19, 20, 21, 22],
        ]
    );
    // The MTA moved on by 20.
    assert_eq!(rig.send(&[cmd::UPLOAD, 2]), [vec![0xFF, 23, 24]]);
    // Exactly 7 bytes: one full frame.
    assert_eq!(
        rig.send(&[cmd::UPLOAD, 7]),
        [vec![0xFF, 25, 26, 27, 28, 29, 30, 31]]
    );
}

#[test]
fn upload_of_255_bytes_is_37_frames() {
    let mut rig = Rig::new();
    rig.connect();
    rig.set_mta(CAL_START);
    let frames = rig.send(&[cmd::UPLOAD, 255]);
    assert_eq!(frames.len(), 37);
    assert!(frames.iter().all(|f| f[0] == 0xFF && f.len() <= 8));
    let data: Vec<u8> = frames.iter().flat_map(|f| f[1..].to_vec()).collect();
    assert_eq!(data, &mock::initial_working()[..255]);
    assert_eq!(rig.one(&[cmd::UPLOAD, 0]), err(ErrorCode::OutOfRange));
}

#[test]
fn short_upload_reads_and_sets_the_mta_behind_the_block() {
    let mut rig = Rig::new();
    rig.connect();
    assert_eq!(
        rig.one(&short_upload(4, CAL_START + 8)),
        [0xFF, 0x00, 0x00, 0x80, 0x3F] // parameter 2 = 1.0
    );
    // MTA = address + n.
    assert_eq!(rig.one(&[cmd::UPLOAD, 4]), [0xFF, 0x00, 0x00, 0xC0, 0x3F]); // 1.5
    assert_eq!(
        rig.one(&short_upload(7, MEAS_START + 0x40)),
        [0xFF, 0x40, 0x41, 0x42, 0x43, 0x44, 0x45, 0x46]
    );
    assert_eq!(
        rig.one(&short_upload(8, MEAS_START)),
        err(ErrorCode::OutOfRange)
    );
    assert_eq!(
        rig.one(&short_upload(0, MEAS_START)),
        err(ErrorCode::OutOfRange)
    );
    let mut ext1 = short_upload(1, MEAS_START);
    ext1[3] = 1;
    assert_eq!(rig.one(&ext1), err(ErrorCode::OutOfRange));
    assert_eq!(
        rig.one(&[cmd::SET_MTA, 0, 0, 2, 0, 0, 0, 0x20]),
        err(ErrorCode::OutOfRange)
    );
}

#[test]
fn download_writes_once_and_moves_the_mta() {
    let mut rig = Rig::new();
    rig.connect_unlocked();
    rig.set_mta(CAL_START + 4);
    let mut cto = vec![cmd::DOWNLOAD, 4];
    cto.extend_from_slice(&f32_bytes(-2.5));
    rig.ok(&cto);
    assert_eq!(&rig.ecu.working()[4..8], f32_bytes(-2.5));
    assert_eq!(rig.ecu.writes, 1);
    // MTA = CAL_START + 8 now.
    rig.ok(&[cmd::DOWNLOAD, 2, 0xAA, 0xBB, 0, 0, 0, 0]); // padded request
    assert_eq!(&rig.ecu.working()[8..10], [0xAA, 0xBB]);
    assert_eq!(
        rig.one(&[cmd::DOWNLOAD, 3, 1, 2]),
        err(ErrorCode::CmdSyntax)
    );
    assert_eq!(rig.one(&[cmd::DOWNLOAD, 0]), err(ErrorCode::OutOfRange));
}

#[test]
fn calibration_writes_need_cal_pag_unlocked() {
    let mut rig = Rig::new();
    rig.connect();
    assert_eq!(rig.unlock(crate::protocol::resource::DAQ), [0xFF, 0x01]);
    rig.set_mta(CAL_START);
    let before = rig.snapshot();
    assert_eq!(
        rig.one(&[cmd::DOWNLOAD, 1, 0]),
        err(ErrorCode::AccessLocked)
    );
    assert_eq!(
        rig.one(&[cmd::DOWNLOAD, 8, 1, 2, 3, 4, 5, 6]),
        err(ErrorCode::AccessLocked)
    );
    assert_eq!(rig.snapshot(), before);
    // Reads need only the connection.
    assert_eq!(rig.one(&short_upload(1, CAL_START + 3))[0], 0xFF);
}

#[test]
fn rejected_write_answers_the_mapped_error_and_changes_nothing() {
    let mut rig = Rig::new();
    rig.connect_unlocked();
    rig.set_mta(CAL_START + 12);
    let before = rig.snapshot();
    let mut cto = vec![cmd::DOWNLOAD, 4];
    cto.extend_from_slice(&f32_bytes(f32::NAN));
    assert_eq!(rig.one(&cto), err(ErrorCode::OutOfRange));
    assert_eq!(rig.snapshot(), before);
    assert_eq!(rig.slave.last_rejection(), Some(Rejected::NotFinite));
    // The MTA did not move: a valid write lands at CAL_START + 12.
    cto[2..6].copy_from_slice(&f32_bytes(7.0));
    rig.ok(&cto);
    assert_eq!(&rig.ecu.working()[12..16], f32_bytes(7.0));
    assert_eq!(Rejected::Unstable.xcp_error(), ErrorCode::Generic);
    assert_eq!(Rejected::Inconsistent.xcp_error(), ErrorCode::Generic);
    assert_eq!(Rejected::OutOfRange.xcp_error(), ErrorCode::OutOfRange);
    assert_eq!(
        [
            Rejected::NotFinite,
            Rejected::OutOfRange,
            Rejected::Unstable,
            Rejected::Inconsistent
        ]
        .map(Rejected::code),
        [1, 2, 3, 4]
    );
}

/// The frames pyxcp's `_block_downloader` sends for `data` (master block mode, MAX_CTO 8).
fn pyxcp_block(data: &[u8]) -> Vec<Vec<u8>> {
    let mut frames = Vec::new();
    let mut remaining = data.len();
    for (i, chunk) in data.chunks(6).enumerate() {
        let mut f = if i == 0 {
            vec![cmd::DOWNLOAD, data.len() as u8]
        } else {
            vec![cmd::DOWNLOAD_NEXT, remaining as u8]
        };
        f.extend_from_slice(chunk);
        frames.push(f);
        remaining -= chunk.len();
    }
    frames
}

#[test]
fn block_download_is_one_write_when_the_last_byte_arrives() {
    let mut rig = Rig::new();
    rig.connect_unlocked();
    rig.set_mta(CAL_START + 16);
    // 5 parameters in 4 frames, handed to the application as one write.
    let values = [1.0_f32, 2.0, 3.0, 4.0, 5.0];
    let data: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
    let frames = pyxcp_block(&data);
    assert_eq!(frames.len(), 4); // 6 + 6 + 6 + 2 bytes
    for f in &frames[..3] {
        assert!(rig.send(f).is_empty(), "no answer before the last frame");
    }
    assert_eq!(rig.ecu.writes, 0);
    rig.ok(&frames[3]);
    assert_eq!(rig.ecu.writes, 1);
    assert_eq!(&rig.ecu.working()[16..36], &data[..]);
    // MTA += 20.
    assert_eq!(rig.one(&[cmd::UPLOAD, 4]), [0xFF, 0x00, 0x00, 0x90, 0x40]); // param 9 = 4.5
}

#[test]
fn largest_block_is_252_bytes() {
    let mut rig = Rig::new();
    rig.connect_unlocked();
    rig.set_mta(CAL_START);
    let data: Vec<u8> = (0..63)
        .flat_map(|i| (i as f32 * 3.0).to_le_bytes())
        .collect();
    let frames = pyxcp_block(&data);
    assert_eq!(frames.len(), 42);
    for f in &frames[..41] {
        assert!(rig.send(f).is_empty());
    }
    rig.ok(&frames[41]);
    assert_eq!(&rig.ecu.working()[..252], &data[..]);
    assert_eq!(rig.ecu.writes, 1);
    rig.set_mta(CAL_START);
    assert_eq!(
        rig.one(&[cmd::DOWNLOAD, 253, 0, 0, 0, 0, 0, 0]),
        err(ErrorCode::OutOfRange)
    );
}

#[test]
fn wrong_remaining_count_discards_the_block() {
    let mut rig = Rig::new();
    rig.connect_unlocked();
    rig.set_mta(CAL_START);
    let before = rig.snapshot();
    let data = [0_u8; 20];
    let frames = pyxcp_block(&data);
    assert!(rig.send(&frames[0]).is_empty());
    // Expected 14 remaining, the master says 13.
    let mut bad = frames[1].clone();
    bad[1] = 13;
    assert_eq!(rig.one(&bad), [0xFE, 0x29, 14]);
    // The block is gone: the rest is out of sequence, and nothing was written.
    assert_eq!(rig.one(&frames[2]), [0xFE, 0x29, 0]);
    assert_eq!(rig.one(&frames[3]), [0xFE, 0x29, 0]);
    assert_eq!(rig.snapshot(), before);
    assert_eq!(rig.ecu.writes, 0);
    // A DOWNLOAD_NEXT out of the blue.
    assert_eq!(rig.one(&[cmd::DOWNLOAD_NEXT, 2, 1, 2]), [0xFE, 0x29, 0]);
}

#[test]
fn download_inside_a_block_is_refused() {
    // pyxcp `_block_downloader` for 8 bytes: `F0 08 d0..d5` then `F0 02 d6 d7` (the index of
    // the last full packet is 0, so it calls `dl_func` again instead of `dl_next_func`).
    let mut rig = Rig::new();
    rig.connect_unlocked();
    rig.set_mta(CAL_START);
    let before = rig.snapshot();
    assert!(rig.send(&[cmd::DOWNLOAD, 8, 1, 2, 3, 4, 5, 6]).is_empty());
    assert_eq!(rig.one(&[cmd::DOWNLOAD, 2, 7, 8]), err(ErrorCode::Sequence));
    assert_eq!(rig.snapshot(), before, "neither the block nor the 2 bytes");
    // Another command drops a pending block silently and is answered normally.
    assert!(rig.send(&[cmd::DOWNLOAD, 8, 1, 2, 3, 4, 5, 6]).is_empty());
    assert_eq!(rig.one(&[cmd::GET_STATUS])[0], 0xFF);
    assert_eq!(rig.one(&[cmd::DOWNLOAD_NEXT, 2, 7, 8]), [0xFE, 0x29, 0]);
    assert_eq!(rig.snapshot(), before);
}

#[test]
fn rejected_block_changes_nothing() {
    let mut rig = Rig::new();
    rig.connect_unlocked();
    rig.set_mta(CAL_START);
    let before = rig.snapshot();
    let mut data = vec![0_u8; 12];
    data[8..12].copy_from_slice(&f32::INFINITY.to_le_bytes());
    let frames = pyxcp_block(&data);
    assert!(rig.send(&frames[0]).is_empty());
    assert_eq!(rig.one(&frames[1]), err(ErrorCode::OutOfRange));
    assert_eq!(rig.snapshot(), before);
}

/// Everything that must be refused: (address, length) around both regions.
fn outside_cases() -> Vec<(u32, u8)> {
    let cal_end = CAL_START + CAL_LEN as u32;
    let meas_end = MEAS_START + MEAS_LEN as u32;
    vec![
        (CAL_START - 1, 1),                // just before
        (CAL_START - 2, 4),                // straddling the start
        (cal_end - 3, 4),                  // straddling the end
        (cal_end, 1),                      // just after
        (MEAS_START - 1, 2),               // straddling the measurement start
        (meas_end - 1, 2),                 // straddling its end
        (meas_end, 1),                     // just after it
        (0xFFFF_FFFE, 4),                  // address + length overflows u32
        (0xFFFF_FFFF, 1),                  // last address
        (0, 1),                            // somewhere else
        ((CAL_START + MEAS_START) / 2, 1), // between the regions
    ]
}

#[test]
fn accesses_outside_the_regions_are_refused_and_touch_nothing() {
    let mut rig = Rig::new();
    rig.connect_unlocked();
    let before = rig.snapshot();
    for (addr, n) in outside_cases() {
        let small = n.min(4);
        assert_eq!(
            rig.one(&short_upload(small, addr)),
            err(ErrorCode::AccessDenied),
            "{addr:X}"
        );
        rig.set_mta(addr);
        assert_eq!(
            rig.one(&[cmd::UPLOAD, n]),
            err(ErrorCode::AccessDenied),
            "{addr:X}"
        );
        rig.set_mta(addr);
        let mut dl = vec![cmd::DOWNLOAD, n];
        dl.extend(std::iter::repeat_n(0, usize::from(n)));
        assert_eq!(rig.one(&dl), err(ErrorCode::AccessDenied), "{addr:X}");
    }
    // Whole-region accesses at the very edges are fine (and read what they should).
    rig.set_mta(CAL_START + CAL_LEN as u32 - 1);
    assert_eq!(rig.one(&[cmd::UPLOAD, 1])[0], 0xFF);
    assert_eq!(
        rig.one(&short_upload(1, MEAS_START + MEAS_LEN as u32 - 1)),
        [0xFF, 0xFF]
    );
    // The measurement region is never written.
    rig.set_mta(MEAS_START);
    assert_eq!(
        rig.one(&[cmd::DOWNLOAD, 1, 0]),
        err(ErrorCode::AccessDenied)
    );
    assert_eq!(rig.snapshot(), before);
    assert_eq!(rig.ecu.violations.get(), 0);
}

#[test]
fn write_daq_outside_the_regions_is_refused() {
    let mut rig = Rig::new();
    rig.connect_unlocked();
    rig.ok(&[cmd::FREE_DAQ]);
    rig.ok(&[cmd::ALLOC_DAQ, 0, 1, 0]);
    rig.ok(&[cmd::ALLOC_ODT, 0, 0, 0, 1]);
    rig.ok(&[cmd::ALLOC_ODT_ENTRY, 0, 0, 0, 0, 1]);
    rig.ok(&[cmd::SET_DAQ_PTR, 0, 0, 0, 0, 0]);
    for (addr, n) in outside_cases() {
        let size = n.clamp(1, 4);
        assert_eq!(
            rig.one(&write_daq(size, addr)),
            err(ErrorCode::AccessDenied),
            "{addr:X}"
        );
    }
    // Sizes and bit offsets.
    for size in [0_u8, 5, 8] {
        assert_eq!(
            rig.one(&write_daq(size, MEAS_START)),
            err(ErrorCode::OutOfRange)
        );
    }
    let mut bit = write_daq(1, MEAS_START);
    bit[1] = 3;
    assert_eq!(rig.one(&bit), err(ErrorCode::OutOfRange));
    let mut ext = write_daq(1, MEAS_START);
    ext[3] = 1;
    assert_eq!(rig.one(&ext), err(ErrorCode::OutOfRange));
    // Inside: both regions are fine, 3 bytes too (granularity 1).
    rig.ok(&write_daq(3, MEAS_START + MEAS_LEN as u32 - 3));
    rig.ok(&[cmd::SET_DAQ_PTR, 0, 0, 0, 0, 0]);
    rig.ok(&write_daq(4, CAL_START + CAL_LEN as u32 - 4));
    // Past the ODT's last entry.
    assert_eq!(
        rig.one(&write_daq(1, MEAS_START)),
        err(ErrorCode::OutOfRange)
    );
    assert_eq!(rig.ecu.violations.get(), 0);
}

#[test]
fn adjacent_regions_do_not_make_one_region() {
    let mut config = mock::config();
    config.calibration = Region::new(0x1000, CAL_LEN as u32);
    config.measurement = Region::new(0x1000 + CAL_LEN as u32, MEAS_LEN as u32);
    let mut rig = Rig::with_config(config);
    rig.connect_unlocked();
    let boundary = 0x1000 + CAL_LEN as u32;
    assert_eq!(
        rig.one(&short_upload(2, boundary - 1)),
        err(ErrorCode::AccessDenied)
    );
    assert_eq!(rig.one(&short_upload(1, boundary - 1))[0], 0xFF);
    assert_eq!(rig.one(&short_upload(1, boundary)), [0xFF, 0x00]);
    assert_eq!(rig.ecu.violations.get(), 0);
}

#[test]
fn offsets_given_to_the_traits_stay_inside_the_regions() {
    // Every successful access at the edges reads the mock's region bytes (a wrong offset
    // would count a violation or read a guard byte 0xA5).
    let mut rig = Rig::new();
    rig.connect_unlocked();
    for n in 1..=7_u8 {
        let last = MEAS_START + MEAS_LEN as u32 - u32::from(n);
        let res = rig.one(&short_upload(n, last));
        let expected: Vec<u8> = (MEAS_LEN - usize::from(n)..MEAS_LEN)
            .map(|i| i as u8)
            .collect();
        assert_eq!(&res[1..], &expected[..]);
    }
    rig.set_mta(CAL_START + CAL_LEN as u32 - 6);
    rig.ok(&[cmd::DOWNLOAD, 6, 0, 0, 0x20, 0x41, 0, 0]); // the last 6 bytes, finite words
    assert_eq!(rig.ecu.violations.get(), 0);
    assert!(rig.ecu.guards_intact());
    assert_eq!(rig.ecu.ecu_page, Page::Working);
}
