//! Where the candidate search runs on a long record: the middle of every split block,
//! each piece filtered on its own ([`SELECTION_SAMPLES`]); the refinement and the
//! simulations use the whole record.

use crate::equation::States;
use crate::split::Split;

/// Samples the candidate search runs on, about: 120 000 (two minutes at 1 kHz). A longer
/// record whose model is refined by output error ranks and fits its candidate effects by
/// equation error on the middle of each of its split blocks, together this many samples
/// plus each piece's warm-up ([`SELECTION_WARMUP_EDGES`]), each piece filtered as a record
/// of its own; the pieces keep their blocks' parts, so they span the record and its
/// fitting and validation shares. The output-error refinement, the confirmation by
/// simulation, the gaps and the reported recalibration use the whole record. (A compute
/// budget: the candidates' ranking needs far fewer effectively independent samples than
/// ten minutes of 1 kHz data hold.)
pub const SELECTION_SAMPLES: usize = 120_000;

/// Warm-up of each piece of the candidate search, in filter transients
/// ([`crate::equation::States::edge`], two cut-off periods each): 5. The input effects and the
/// hysteretic states, integrated along the piece from its start, settle in it.
pub const SELECTION_WARMUP_EDGES: usize = 5;

/// The candidate search's states and split on the middle of every block of a long record.
pub(super) struct Pieces {
    pub(super) st: States,
    pub(super) split: Split,
    /// The note that says where the search runs.
    pub(super) note: String,
}

/// The pieces the candidate search runs on for a record of `len` samples with states `st`
/// and split `split`, when its model is refined by output error (`oe`) and the record is
/// long enough ([`SELECTION_SAMPLES`]); `None`: the whole record.
pub(super) fn selection_pieces(st: &States, split: &Split, oe: bool, len: usize) -> Option<Pieces> {
    let blocks = split.len.div_ceil(split.block).max(1);
    let warmup = SELECTION_WARMUP_EDGES * st.edge;
    let core = SELECTION_SAMPLES / blocks;
    let piece = core + warmup + st.edge;
    let selection = (oe && core >= warmup && 2 * blocks * piece <= len).then(|| {
        let (ranges, sub) = split.middles(piece);
        (st.pieces(&ranges, warmup), sub)
    });
    let (st_pieces, sub) = selection?;
    let note = format!(
        "candidate effects ranked and fitted (equation error) on {} samples of the record: {piece} in the middle of each of its {} blocks, each piece filtered on its own, the first {} of each a warm-up",
        sub.len,
        sub.len / piece.max(1),
        warmup.max(st.edge)
    );
    Some(Pieces {
        st: st_pieces,
        split: sub,
        note,
    })
}
