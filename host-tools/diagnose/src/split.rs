//! The split of a record into fitting and validation samples: interleaved blocks.
//!
//! The record is cut into blocks of equal length; every block whose index `b` satisfies
//! `⌊(b + 1) f⌋ > ⌊b f⌋` (with `f` the validation fraction) is a validation block, the
//! others are fitting blocks. So both parts span the whole record: its frequency content
//! (a sweep's start and end), its amplitudes and its operating regions, whatever the
//! record's order. A guard of samples on each side of every block boundary belongs to
//! neither part, so that a filtered regression row does not carry a validation sample into
//! the fit (or the reverse).
//!
//! ```
//! use mil_diagnose::split::Split;
//! let s = Split::new(10_000, 0.3, 100, 10);
//! let val = (0..10_000).filter(|&t| s.is_validation(t)).count();
//! let fit = (0..10_000).filter(|&t| s.is_fit(t)).count();
//! assert!((val as f64 / (val + fit) as f64 - 0.3).abs() < 0.05);
//! // Validation samples lie in the first and in the last fifth of the record alike.
//! assert!((0..2_000).any(|t| s.is_validation(t)));
//! assert!((8_000..10_000).any(|t| s.is_validation(t)));
//! ```

/// Blocks per record the split aims for: 40, so that a third of them (the validation part)
/// is a dozen blocks spread over the record.
pub const BLOCKS: usize = 40;

/// Interleaved fitting and validation blocks (see the module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct Split {
    /// Samples in the record.
    pub len: usize,
    /// Samples per block.
    pub block: usize,
    /// Validation fraction `f` (0, 1).
    pub fraction: f64,
    /// Samples on each side of a block boundary that belong to neither part.
    pub guard: usize,
    /// Per block (one past the last), whether it is a validation block: the per-sample
    /// tests look it up instead of recomputing it.
    validation_blocks: Vec<bool>,
}

impl Split {
    /// A split of `len` samples with validation fraction `fraction`, blocks of at least
    /// `min_block` samples ([`BLOCKS`] blocks when the record is long enough) and `guard`
    /// samples on each side of a boundary left out (at most a quarter of a block).
    pub fn new(len: usize, fraction: f64, min_block: usize, guard: usize) -> Self {
        let block = (len / BLOCKS).max(min_block).max(1);
        let validation_blocks = (0..=len / block + 1)
            .map(|b| ((b + 1) as f64 * fraction).floor() > (b as f64 * fraction).floor())
            .collect();
        Self {
            len,
            block,
            fraction,
            guard: guard.min(block / 4),
            validation_blocks,
        }
    }

    /// Whether block `b` is a validation block (every `1/f`-th block, spread evenly).
    fn block_is_validation(&self, b: usize) -> bool {
        self.validation_blocks.get(b).copied().unwrap_or(false)
    }

    /// Whether sample `t` is within the guard of a boundary between parts.
    fn guarded(&self, t: usize) -> bool {
        if self.guard == 0 {
            return false;
        }
        let b = t / self.block;
        let off = t % self.block;
        let here = self.block_is_validation(b);
        (off < self.guard && b > 0 && self.block_is_validation(b - 1) != here)
            || (off + self.guard >= self.block
                && (b + 1) * self.block < self.len
                && self.block_is_validation(b + 1) != here)
    }

    /// Whether sample `t` is a validation sample.
    pub fn is_validation(&self, t: usize) -> bool {
        t < self.len && self.block_is_validation(t / self.block) && !self.guarded(t)
    }

    /// Whether sample `t` is a fitting sample.
    pub fn is_fit(&self, t: usize) -> bool {
        t < self.len && !self.block_is_validation(t / self.block) && !self.guarded(t)
    }

    /// Index of the block holding sample `t`.
    pub fn block_of(&self, t: usize) -> usize {
        t / self.block
    }

    /// The middle `len` samples of every block that holds that many (the ranges, in the
    /// record's order) and the split of their concatenation: blocks of `len` samples, each
    /// in its block's part, the guard at most a quarter block. A shorter record that still
    /// spans the whole record and keeps its parts' shares.
    pub fn middles(&self, len: usize) -> (Vec<std::ops::Range<usize>>, Split) {
        let len = len.max(1);
        let (mut ranges, mut roles) = (Vec::new(), Vec::new());
        for b in 0..self.len.div_ceil(self.block) {
            let (start, end) = (b * self.block, ((b + 1) * self.block).min(self.len));
            if end - start >= len {
                let s = start + (end - start - len) / 2;
                ranges.push(s..s + len);
                roles.push(self.block_is_validation(b));
            }
        }
        let split = Split {
            len: ranges.len() * len,
            block: len,
            fraction: self.fraction,
            guard: self.guard.min(len / 4),
            validation_blocks: roles,
        };
        (ranges, split)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parts_are_disjoint_spread_and_of_the_asked_share() {
        for (len, f) in [(20_000, 0.3), (60_000, 0.25), (3_000, 0.5), (123_457, 0.3)] {
            let s = Split::new(len, f, 200, 20);
            let val = (0..len).filter(|&t| s.is_validation(t)).count();
            let fit = (0..len).filter(|&t| s.is_fit(t)).count();
            assert!(val > 0 && fit > 0);
            assert!(val + fit <= len);
            assert!((0..len).all(|t| !(s.is_fit(t) && s.is_validation(t))));
            let share = val as f64 / (val + fit) as f64;
            assert!((share - f).abs() < 0.1, "{len} {f}: {share}");
            // Each tenth of the record holds fitting samples, and each half validation ones.
            for k in 0..10 {
                assert!((k * len / 10..(k + 1) * len / 10).any(|t| s.is_fit(t)));
            }
            assert!((0..len / 2).any(|t| s.is_validation(t)));
            assert!((len / 2..len).any(|t| s.is_validation(t)));
        }
    }

    #[test]
    fn the_middles_keep_each_blocks_part_and_span_the_record() {
        let s = Split::new(600_000, 0.3, 1000, 30);
        let (ranges, sub) = s.middles(3000);
        assert_eq!(ranges.len(), 40);
        assert_eq!(sub.len, 40 * 3000);
        for (k, r) in ranges.iter().enumerate() {
            assert_eq!(r.len(), 3000);
            // The middle of block k, in block k's part.
            assert_eq!(r.start, k * s.block + (s.block - 3000) / 2);
            let mid = r.start + 1500;
            assert_eq!(s.is_validation(mid), sub.is_validation(k * 3000 + 1500));
            assert_eq!(s.is_fit(mid), sub.is_fit(k * 3000 + 1500));
        }
        let val = (0..sub.len).filter(|&t| sub.is_validation(t)).count();
        let fit = (0..sub.len).filter(|&t| sub.is_fit(t)).count();
        let share = val as f64 / (val + fit) as f64;
        assert!((share - 0.3).abs() < 0.05, "{share}");
        // A block shorter than the asked length (the record's last) is left out.
        let (ranges, _) = Split::new(10_050, 0.3, 250, 10).middles(251);
        assert!(ranges.iter().all(|r| r.end <= 10_050 && r.len() == 251));
        assert_eq!(ranges.len(), 40);
    }

    #[test]
    fn guard_separates_the_parts() {
        let s = Split::new(10_000, 0.3, 250, 10);
        for t in 1..10_000 {
            // A fitting sample never lies within the guard of a validation sample.
            if s.is_fit(t) {
                let lo = t.saturating_sub(10);
                assert!(
                    (lo..(t + 10).min(10_000)).all(|u| !s.is_validation(u)),
                    "{t}"
                );
            }
        }
    }
}
