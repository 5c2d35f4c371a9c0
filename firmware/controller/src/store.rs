//! Stored calibrations: the working page kept in the board's flash, power-fail safe.
//!
//! A store (XCP `SET_REQUEST STORE_CAL_REQ`, `mil param store`) saves the working page as one
//! record in a `sequential-storage` map (one key, the last record wins): the crate appends
//! records to flash pages and erases a page only when it must, and every record carries its
//! own CRC, so a store cut short by a power failure at any write or erase step leaves the
//! previous record readable (`power_cut_at_every_step_leaves_a_bootable_page` checks every
//! step against a NOR flash model). On top of that the record holds a format tag, the page
//! layout's fingerprint ([`layout_id`]: a page stored by a firmware with other slots is not
//! read as this one's) and a CRC-32 of its own.
//!
//! At boot ([`boot`]) the board runs the stored page when it passes the format,
//! layout and CRC checks and the same validation as any page ([`calibration::decode_page`]),
//! else the build's defaults; [`Source`] says which, in the status frame and the
//! measurement block.
//!
//! The flash is anything that implements `embedded-storage-async`'s `NorFlash`: on the board
//! the STM32F405's own flash (sectors 10 and 11, 2 × 128 KB, through a blocking adapter), in
//! the QEMU build (whose flash controller QEMU does not emulate) and in tests a [`RamFlash`].

use core::ops::Range;

use embedded_storage_async::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};
use sequential_storage::cache::{Cache, Uncached};
use sequential_storage::map::{MapConfig, MapStorage};

use crate::calibration::{self, meas, Source, SLOTS};

/// The record's format tag: "MIL" and format version 1.
pub const FORMAT: u32 = u32::from_le_bytes(*b"MIL\x01");
/// Words of a record: format, layout, the page's slots, CRC-32.
pub const RECORD_WORDS: usize = SLOTS + 3;
/// Bytes of a record.
pub const RECORD_BYTES: usize = 4 * RECORD_WORDS;
/// The map's one key.
const KEY: u8 = 0;
/// The work buffer: key and record, rounded up to the largest flash word the crate supports.
const BUFFER_BYTES: usize = (1 + RECORD_BYTES).div_ceil(32) * 32;

/// What [`Store::load`] found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[allow(clippy::large_enum_variant)] // read once at boot and on a store's check: the page
pub enum Loaded {
    /// Nothing stored.
    Empty,
    /// A record of this build (format, layout and CRC checked); the page itself is
    /// validated once, where it is installed ([`boot`]).
    Stored([u32; SLOTS]),
    /// A stored record that is not one of this build.
    Refused(Refusal),
    /// The flash could not be read.
    Unreadable,
}

impl Loaded {
    /// The boot source this result gives.
    pub fn source(&self) -> Source {
        match self {
            Self::Empty => Source::Defaults,
            Self::Stored(_) => Source::Stored,
            Self::Refused(_) => Source::Refused,
            Self::Unreadable => Source::Unreadable,
        }
    }
}

/// Why a stored record was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Refusal {
    /// Not a record of this format (length or tag).
    Format,
    /// Stored by a firmware with another page layout.
    Layout,
    /// The record's CRC-32 does not match.
    Crc,
}

/// Why a store failed (measurement `calibration_store_error`; 0 means the last store went
/// through).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum StoreError {
    /// The working page does not validate: nothing was written.
    Invalid = 1,
    /// The flash refused a read, write or erase.
    Flash = 2,
    /// Read back, the stored page is not the one written.
    Verify = 3,
    /// Refused while the controller runs (a flash erase stalls the processor).
    Running = 4,
}

/// The record's CRC: CRC-32/ISO-HDLC (zlib's, Ethernet's; what crc32fast computes), from
/// the `crc` crate without a lookup table (crc32fast's 16 KB table was 5 % of the image for
/// a check made at boot and on a store; bit by bit a record takes well under a millisecond at
/// 168 MHz).
pub static CRC: crc::Crc<u32, crc::NoTable> =
    crc::Crc::<u32, crc::NoTable>::new(&crc::CRC_32_ISO_HDLC);

/// A running CRC that formatted text can be written into.
struct Hash(crc::Digest<'static, u32, crc::NoTable>);

impl core::fmt::Write for Hash {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        self.0.update(s.as_bytes());
        Ok(())
    }
}

/// The fingerprint of the page layout: CRC-32 of every slot's name (group, name and
/// indices) and kind, in slot order.
pub fn layout_id() -> u32 {
    let mut h = Hash(CRC.digest());
    let mut add = |item: &calibration::CalItem| {
        use core::fmt::Write as _;
        let _ = write!(h, "{item};");
        h.0.update(&[item.kind as u8]);
    };
    for slot in 0..calibration::SETTINGS_SLOTS {
        if let Some(item) = calibration::item(slot) {
            add(&item);
        }
    }
    model_core::page::for_each_info(&mut |_, item| add(item));
    h.0.finalize()
}

/// The record of `words`.
pub fn encode(words: &[u32; SLOTS]) -> [u8; RECORD_BYTES] {
    let mut out = [0u8; RECORD_BYTES];
    let head = [FORMAT, layout_id()];
    for (chunk, w) in out.chunks_exact_mut(4).zip(head.iter().chain(words.iter())) {
        chunk.copy_from_slice(&w.to_le_bytes());
    }
    let body = RECORD_BYTES - 4;
    let crc = CRC.checksum(out.get(..body).unwrap_or(&[]));
    if let Some(tail) = out.get_mut(body..) {
        tail.copy_from_slice(&crc.to_le_bytes());
    }
    out
}

/// The page a record holds, checked for format, layout and CRC (not yet validated as a
/// page).
pub fn decode(record: &[u8]) -> Result<[u32; SLOTS], Refusal> {
    if record.len() != RECORD_BYTES {
        return Err(Refusal::Format);
    }
    let word = |k: usize| {
        record
            .get(4 * k..4 * k + 4)
            .and_then(|b| b.try_into().ok())
            .map_or(0, u32::from_le_bytes)
    };
    if word(0) != FORMAT {
        return Err(Refusal::Format);
    }
    if word(1) != layout_id() {
        return Err(Refusal::Layout);
    }
    let body = RECORD_BYTES - 4;
    if CRC.checksum(record.get(..body).unwrap_or(&[])) != word(RECORD_WORDS - 1) {
        return Err(Refusal::Crc);
    }
    Ok(core::array::from_fn(|s| word(2 + s)))
}

/// The map's cache: none (a store is rare; at boot and after a store the flash is read).
type NoCache = Cache<Uncached, Uncached, Uncached, u8>;

/// The stored calibration on flash `F` (see the module documentation).
pub struct Store<F: NorFlash> {
    map: MapStorage<u8, F, NoCache>,
}

impl<F: NorFlash> Store<F> {
    /// The store over `range` of `flash` (byte offsets, whole erase pages, at least two);
    /// `None` for a range the crate cannot use.
    pub fn new(flash: F, range: Range<u32>) -> Option<Self> {
        let config = MapConfig::try_new(range).ok()?;
        Some(Self {
            map: MapStorage::new(flash, config, Cache::new_uncached()),
        })
    }

    /// The flash back.
    pub fn into_flash(self) -> F {
        self.map.destroy().0
    }

    /// Saves `words` (the working page) as the page to boot with. A page that does not
    /// validate (`valid`: [`calibration::decode_page_into`] succeeds on it, into the
    /// configuration tasks' candidate on the board) is refused before anything is written;
    /// after writing, the record is read back and compared.
    pub async fn save(
        &mut self,
        words: &[u32; SLOTS],
        valid: impl FnOnce(&[u32; SLOTS]) -> bool,
    ) -> Result<(), StoreError> {
        if !valid(words) {
            return Err(StoreError::Invalid);
        }
        let record = encode(words);
        let mut buffer = [0u8; BUFFER_BYTES];
        self.map
            .store_item(&mut buffer, &KEY, &&record[..])
            .await
            .map_err(|_| StoreError::Flash)?;
        match self.load().await {
            Loaded::Stored(read) if read == *words => Ok(()),
            Loaded::Unreadable => Err(StoreError::Flash),
            _ => Err(StoreError::Verify),
        }
    }

    /// As [`Store::load`], the page into `words` (in place; written only when stored):
    /// the boot source it gives ([`Source::Stored`] when `words` holds the stored page).
    pub async fn load_into(&mut self, words: &mut [u32; SLOTS]) -> Source {
        let loaded = self.load().await;
        if let Loaded::Stored(w) = &loaded {
            *words = *w;
        }
        loaded.source()
    }

    /// The stored record, checked for format, layout and CRC (see [`Loaded`]).
    pub async fn load(&mut self) -> Loaded {
        let mut buffer = [0u8; BUFFER_BYTES];
        match self.map.fetch_item::<&[u8]>(&mut buffer, &KEY).await {
            Ok(None) => Loaded::Empty,
            Ok(Some(record)) => match decode(record) {
                Ok(words) => Loaded::Stored(words),
                Err(why) => Loaded::Refused(why),
            },
            Err(_) => Loaded::Unreadable,
        }
    }
}

/// Boot: loads the stored page from `store` and makes `app` run it when it validates and
/// installs ([`crate::application::Application::boot_with`]; the working page then holds
/// it), or the build's defaults; the source is recorded in `app` (status frame,
/// measurement `calibration_source`) and returned. Call it before the control step starts.
pub async fn boot<F: NorFlash>(
    app: &mut crate::application::Application,
    store: &mut Store<F>,
    candidate: &mut calibration::Candidate,
) -> Source {
    let source = store.load_into(&mut candidate.words).await;
    boot_loaded(app, source, candidate)
}

/// The second half of [`boot`], once [`Store::load_into`] has read the store into
/// `candidate.words` and given `source` (the board runs the two halves one after the
/// other, so that the load's buffers and the preparation's never share the stack).
pub fn boot_loaded(
    app: &mut crate::application::Application,
    source: Source,
    candidate: &mut calibration::Candidate,
) -> Source {
    let source = app.boot_with(source, candidate);
    app.mirror_to_working_page();
    calibration::store_u32(meas::CAL_SOURCE, source as u32);
    source
}

/// Stores the working page as it is now into `store` and records the outcome in the
/// measurement block ([`note_store`]). The XCP task calls it for a pending
/// SET_REQUEST STORE_CAL_REQ, then tells the slave
/// ([`mil_xcp::Slave::store_finished`]).
pub async fn store_working<F: NorFlash>(
    store: &mut Store<F>,
    valid: impl FnOnce(&[u32; SLOTS]) -> bool,
) -> Result<(), StoreError> {
    store_words(store, &calibration::working_words(), valid).await
}

/// As [`store_working`], of the page `words` (a copy of the working page).
pub async fn store_words<F: NorFlash>(
    store: &mut Store<F>,
    words: &[u32; SLOTS],
    valid: impl FnOnce(&[u32; SLOTS]) -> bool,
) -> Result<(), StoreError> {
    let result = store.save(words, valid).await;
    note_store(result);
    result
}

/// Records the outcome of a calibration store in the measurement block:
/// [`meas::CAL_STORES`] counts the stored ones, [`meas::CAL_STORE_ERROR`] keeps 0 or the
/// [`StoreError`] of the last one.
pub fn note_store(result: Result<(), StoreError>) {
    match result {
        Ok(()) => {
            calibration::count(meas::CAL_STORES);
            calibration::store_u32(meas::CAL_STORE_ERROR, 0);
        }
        Err(e) => calibration::store_u32(meas::CAL_STORE_ERROR, e as u32),
    }
}

/// Runs a future that never waits (flash operations that complete at once, as on the board
/// and in [`RamFlash`]) to its end; `None` if it waits.
pub fn complete<T>(future: impl core::future::Future<Output = T>) -> Option<T> {
    let mut future = core::pin::pin!(future);
    let mut cx = core::task::Context::from_waker(core::task::Waker::noop());
    // A future over flash that completes at once is ready at its first poll; a few more
    // polls cover any internal yield.
    for _ in 0..16 {
        if let core::task::Poll::Ready(v) = future.as_mut().poll(&mut cx) {
            return Some(v);
        }
    }
    None
}

/// A flash in RAM with NOR semantics (erase sets a page's bytes to 0xFF, a write can only
/// clear bits), `PAGES` erase pages of `PAGE` bytes, 4-byte writes. It can cut its own
/// power: [`RamFlash::cut_power_at`] makes the given write or erase step (counted from 0)
/// tear halfway and every later step fail, as a power failure would. The QEMU build keeps
/// its calibrations in one (until reset); tests use it to cut power at every step.
#[derive(Clone, Debug)]
pub struct RamFlash<const PAGES: usize, const PAGE: usize> {
    pages: [[u8; PAGE]; PAGES],
    steps: u32,
    cut_at: Option<u32>,
}

/// A [`RamFlash`] error.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RamFlashError {
    /// Outside the flash or not aligned.
    OutOfBounds,
    /// The power is cut.
    PowerCut,
}

impl NorFlashError for RamFlashError {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            Self::OutOfBounds => NorFlashErrorKind::OutOfBounds,
            Self::PowerCut => NorFlashErrorKind::Other,
        }
    }
}

impl<const PAGES: usize, const PAGE: usize> Default for RamFlash<PAGES, PAGE> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const PAGES: usize, const PAGE: usize> RamFlash<PAGES, PAGE> {
    /// An erased flash with power on.
    pub const fn new() -> Self {
        Self {
            pages: [[0xFF; PAGE]; PAGES],
            steps: 0,
            cut_at: None,
        }
    }

    /// Cuts the power at write-or-erase step `step` (0: the next one; counted from the
    /// last [`Self::power_on`]).
    pub fn cut_power_at(&mut self, step: u32) {
        self.cut_at = Some(step);
    }

    /// Power back on (the contents stay as the cut left them), step count from 0.
    pub fn power_on(&mut self) {
        self.cut_at = None;
        self.steps = 0;
    }

    /// Write and erase steps since the last [`Self::power_on`].
    pub fn steps(&self) -> u32 {
        self.steps
    }

    /// The step about to run: `Ok(true)` runs whole, `Ok(false)` tears (the cut), `Err`
    /// after it.
    fn step(&mut self) -> Result<bool, RamFlashError> {
        let k = self.steps;
        self.steps = self.steps.saturating_add(1);
        match self.cut_at {
            Some(cut) if k > cut => Err(RamFlashError::PowerCut),
            Some(cut) if k == cut => Ok(false),
            _ => Ok(true),
        }
    }

    fn byte_mut(&mut self, at: usize) -> Option<&mut u8> {
        self.pages.get_mut(at / PAGE)?.get_mut(at % PAGE)
    }
}

impl<const PAGES: usize, const PAGE: usize> ErrorType for RamFlash<PAGES, PAGE> {
    type Error = RamFlashError;
}

impl<const PAGES: usize, const PAGE: usize> ReadNorFlash for RamFlash<PAGES, PAGE> {
    const READ_SIZE: usize = 1;

    async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        let start = offset as usize;
        for (k, b) in bytes.iter_mut().enumerate() {
            *b = *self
                .pages
                .get((start + k) / PAGE)
                .and_then(|p| p.get((start + k) % PAGE))
                .ok_or(RamFlashError::OutOfBounds)?;
        }
        Ok(())
    }

    fn capacity(&self) -> usize {
        PAGES * PAGE
    }
}

impl<const PAGES: usize, const PAGE: usize> NorFlash for RamFlash<PAGES, PAGE> {
    const WRITE_SIZE: usize = 4;
    const ERASE_SIZE: usize = PAGE;

    async fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        let (from, to) = (from as usize, to as usize);
        if from % PAGE != 0 || to % PAGE != 0 || from > to || to > PAGES * PAGE {
            return Err(RamFlashError::OutOfBounds);
        }
        // A torn erase clears the first half of the range: the rest keeps its old bytes.
        let end = if self.step()? {
            to
        } else {
            from + (to - from) / 2
        };
        for at in from..end {
            if let Some(b) = self.byte_mut(at) {
                *b = 0xFF;
            }
        }
        if end < to {
            return Err(RamFlashError::PowerCut);
        }
        Ok(())
    }

    async fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        let start = offset as usize;
        if start % 4 != 0 || bytes.len() % 4 != 0 || start + bytes.len() > PAGES * PAGE {
            return Err(RamFlashError::OutOfBounds);
        }
        // A torn write programs the first half of its bytes.
        let n = if self.step()? {
            bytes.len()
        } else {
            bytes.len() / 2
        };
        for (k, &v) in bytes.iter().take(n).enumerate() {
            if let Some(b) = self.byte_mut(start + k) {
                *b &= v; // NOR: a write only clears bits
            }
        }
        if n < bytes.len() {
            return Err(RamFlashError::PowerCut);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    /// The store's CRC-32 is the one records were stored with (crc32fast's): the
    /// catalogue's check value ("123456789" -> 0xCBF43926), and crc32fast's on drawn data of
    /// every length up to 300 bytes, whole and in pieces.
    #[test]
    fn the_crc_is_crc32_ieee() {
        assert_eq!(CRC.checksum(b"123456789"), 0xCBF4_3926);
        assert_eq!(CRC.checksum(&[]), 0);
        let mut x = 0x1234_5678u32;
        for len in 0..300 {
            let data: std::vec::Vec<u8> = (0..len)
                .map(|_| {
                    x ^= x << 13;
                    x ^= x >> 17;
                    x ^= x << 5;
                    x as u8
                })
                .collect();
            assert_eq!(CRC.checksum(&data), crc32fast::hash(&data), "length {len}");
            let mut pieces = CRC.digest();
            for chunk in data.chunks(7) {
                pieces.update(chunk);
            }
            assert_eq!(
                pieces.finalize(),
                crc32fast::hash(&data),
                "length {len} in pieces"
            );
        }
    }

    /// The page validates (what the board checks in its candidate).
    fn valid(words: &[u32; SLOTS]) -> bool {
        calibration::decode_page(words).is_ok()
    }

    use super::*;
    use crate::calibration::{page_values, test_lock, DEFAULT_SETTINGS, SLOT_WATCHDOG};
    use crate::config::default_params;
    use std::vec::Vec;

    type Flash = RamFlash<4, 4096>;

    fn store(flash: Flash) -> Store<Flash> {
        Store::new(flash, 0..16384).expect("range")
    }

    fn page(stiffness: f32) -> [u32; SLOTS] {
        let mut p = default_params();
        p.tyre.tyre[0].stiffness = stiffness;
        page_values(&p, &DEFAULT_SETTINGS).map(f32::to_bits)
    }

    #[test]
    fn a_record_round_trips_and_refuses_what_is_not_this_builds_page() {
        let words = page(3.0e5);
        let record = encode(&words);
        assert_eq!(decode(&record), Ok(words));
        let mut bad = record;
        bad[9] ^= 0x01;
        assert_eq!(decode(&bad), Err(Refusal::Crc));
        let mut other = record;
        other[4] ^= 0xFF;
        assert_eq!(decode(&other), Err(Refusal::Layout));
        assert_eq!(decode(&record[..RECORD_BYTES - 4]), Err(Refusal::Format));
        let mut tag = record;
        tag[0] = b'X';
        assert_eq!(decode(&tag), Err(Refusal::Format));
    }

    #[test]
    fn store_and_load_with_the_last_record_winning() {
        let _turn = test_lock();
        let mut s = store(Flash::new());
        assert_eq!(complete(s.load()), Some(Loaded::Empty));
        // Enough stores to fill pages and make the crate erase and move on.
        for k in 0..60 {
            let words = page(1.0e5 + 1000.0 * k as f32);
            assert_eq!(complete(s.save(&words, valid)), Some(Ok(())), "store {k}");
            assert_eq!(complete(s.load()), Some(Loaded::Stored(words)));
        }
        // A page that would not validate is not written.
        let mut bad = page(2.0e5);
        bad[SLOT_WATCHDOG] = 0.5f32.to_bits();
        assert_eq!(
            complete(s.save(&bad, valid)),
            Some(Err(StoreError::Invalid))
        );
        assert_eq!(
            complete(s.load()),
            Some(Loaded::Stored(page(1.0e5 + 59_000.0)))
        );
    }

    /// A record of this build whose page does not validate (written by hand past `save`,
    /// which refuses it) boots the defaults and says the stored page was refused.
    #[test]
    fn a_stored_page_that_does_not_validate_boots_the_defaults() {
        let _turn = test_lock();
        let mut bad = page(3.0e5);
        bad[SLOT_WATCHDOG] = 0.5f32.to_bits();
        let mut map = MapStorage::<u8, _, _>::new(
            Flash::new(),
            MapConfig::new(0..16384),
            Cache::new_uncached(),
        );
        let mut buffer = [0u8; BUFFER_BYTES];
        let record = encode(&bad);
        complete(map.store_item(&mut buffer, &KEY, &&record[..]))
            .expect("completes")
            .expect("stored");
        let mut s = Store::new(map.destroy().0, 0..16384).expect("range");
        assert_eq!(complete(s.load()), Some(Loaded::Stored(bad)));
        let mut app = crate::application::Application::new(256).expect("app");
        assert_eq!(
            complete(boot(&mut app, &mut s, crate::calibration::host_candidate())),
            Some(Source::Refused)
        );
        assert_eq!(app.params(), &default_params());
        assert_eq!(app.calibration_source(), Source::Refused);
        crate::calibration::mirror(&default_params(), &DEFAULT_SETTINGS);
    }

    /// Issue 19, point 7: a store cut short by a power failure at any of its write or erase
    /// steps (the step tears halfway, every later one fails) leaves a flash that boots
    /// either the previous page or the new one, never the defaults or garbage; so does a cut
    /// at any step of the erase that a full flash forces.
    #[test]
    fn power_cut_at_every_step_leaves_a_bootable_page() {
        let _turn = test_lock();
        let old = page(2.0e5);
        let new = page(3.0e5);
        // Flashes in several states: one record; nearly full (the next store erases).
        let mut states = Vec::new();
        // Every count up to several page changes, so cuts fall into every erase the crate
        // makes and into stores right after one.
        for records in 1usize..=40 {
            let mut s = store(Flash::new());
            for k in 0..records {
                let w = if k + 1 == records {
                    old
                } else {
                    page(1.0e5 + k as f32)
                };
                assert_eq!(complete(s.save(&w, valid)), Some(Ok(())));
            }
            states.push((records, s.into_flash()));
        }
        let mut report = Vec::new();
        for (records, flash) in states {
            // The uncut store: how many steps it takes.
            let mut whole = flash.clone();
            whole.power_on();
            let mut s = store(whole);
            assert_eq!(complete(s.save(&new, valid)), Some(Ok(())));
            let steps = s.into_flash().steps();
            let (mut booted_old, mut booted_new) = (0, 0);
            for cut in 0..steps {
                let mut f = flash.clone();
                f.power_on();
                f.cut_power_at(cut);
                let mut s = store(f);
                let result = complete(s.save(&new, valid));
                assert!(
                    matches!(result, Some(Err(_))),
                    "{records} records, cut at step {cut}: {result:?}"
                );
                // Reboot.
                let mut f = s.into_flash();
                f.power_on();
                let mut s = store(f);
                match complete(s.load()) {
                    Some(Loaded::Stored(w)) if w == old => booted_old += 1,
                    Some(Loaded::Stored(w)) if w == new => booted_new += 1,
                    other => panic!("{records} records, cut at step {cut}: boots {other:?}"),
                }
                // And the next store after the reboot goes through.
                assert_eq!(complete(s.save(&new, valid)), Some(Ok(())));
                assert_eq!(complete(s.load()), Some(Loaded::Stored(new)));
            }
            report.push(std::format!(
                "{records} records stored before: {steps} steps, boots the old page {booted_old}x, the new {booted_new}x"
            ));
        }
        for line in &report {
            std::println!("power cut: {line}");
        }
        let erases = report.iter().filter(|l| !l.contains(": 3 steps")).count();
        assert!(erases >= 3, "stores that erase: {erases}");
    }
}
