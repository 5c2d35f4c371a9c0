//! Timing statistics (clock counts of the control path: SysTick core cycles on the board,
//! TIM5 counts of QEMU's virtual nanoseconds in the QEMU build) and the stack high-water mark.

/// Minimum, maximum and mean of a series of timing windows (clock counts).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Timing {
    /// Windows recorded.
    pub count: u32,
    /// Sum of all windows.
    pub sum: u64,
    /// Shortest window (0 before the first).
    pub min: u32,
    /// Longest window.
    pub max: u32,
    /// The first window (the first step after a start resets the model: longer).
    pub first: u32,
}

impl Timing {
    /// No windows yet.
    pub const fn new() -> Self {
        Self {
            count: 0,
            sum: 0,
            min: 0,
            max: 0,
            first: 0,
        }
    }

    /// Records one window.
    pub fn record(&mut self, counts: u32) {
        if self.count == 0 {
            self.first = counts;
            self.min = counts;
        }
        self.count = self.count.saturating_add(1);
        self.sum = self.sum.saturating_add(u64::from(counts));
        self.min = self.min.min(counts);
        self.max = self.max.max(counts);
    }

    /// Mean window, 0 before the first.
    pub fn mean(&self) -> f64 {
        if self.count == 0 {
            0.0
        } else {
            self.sum as f64 / f64::from(self.count)
        }
    }
}

/// The value cortex-m-rt's `paint-stack` feature writes over the whole stack region before
/// `main` (`cortex_m_rt::STACK_PAINT_VALUE`).
pub const STACK_PAINT: u32 = 0xCCCC_CCCC;

/// Bytes of stack used at most, from the words of the stack region listed from its lowest
/// address (`_stack_end`) upwards: everything above the first word that lost its paint has
/// been written at some time (the stack grows down from the top).
pub fn stack_used(words_from_bottom: impl IntoIterator<Item = u32>, region_words: usize) -> usize {
    let untouched = words_from_bottom
        .into_iter()
        .take_while(|w| *w == STACK_PAINT)
        .count();
    region_words.saturating_sub(untouched).saturating_mul(4)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn timing_and_stack() {
        let mut t = Timing::new();
        for c in [900, 700, 800] {
            t.record(c);
        }
        assert_eq!((t.count, t.min, t.max, t.first), (3, 700, 900, 900));
        assert_eq!(t.mean(), 800.0);
        let words = [STACK_PAINT, STACK_PAINT, 7, STACK_PAINT, 1];
        assert_eq!(stack_used(words, words.len()), 12);
        assert_eq!(stack_used([STACK_PAINT; 4], 4), 0);
    }
}
