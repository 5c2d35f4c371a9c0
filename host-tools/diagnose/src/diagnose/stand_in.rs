//! The stand-in check: when one effect is named, the first round's runners-up, each
//! continued by a round of its own (best first by the criterion), may explain the record
//! better with two (a Bouc-Wen loop standing in for dry friction and a hardening spring
//! together). The first pair that pays off against the one effect in simulation, by the
//! same test as any added effect, replaces it.

use super::selection::{Branch, Findings, Selection};

impl Selection<'_> {
    /// The stand-in check on `main` (the forward search's branch) with the first round's
    /// `runners_up`: the branch named, `main` or the first pair that pays off against it;
    /// the verdicts go to `notes`.
    pub(super) fn stand_in(
        &self,
        mut main: Branch,
        runners_up: Vec<Branch>,
        notes: &mut Vec<String>,
    ) -> Branch {
        let stand_in = self.oe && main.named.len() == 1 && self.options.max_effects >= 2;
        let runners_up = if stand_in { runners_up } else { Vec::new() };
        for mut alt in runners_up {
            (self.log)(0.86, "stand-in check: a runner-up continued");
            let mut alt_found = Findings::default();
            // One round: the pair is what is compared; each of its candidates must gain on
            // the one effect named, by the equation error first (a pair that fits the record
            // worse than the one effect is not refined: most of the check's cost) and then in
            // simulation.
            self.forward(
                &mut alt,
                1..2,
                Some((&main.updated, main.current.sse_val)),
                &mut alt_found,
                false,
            );
            let pair = |b: &Branch| {
                b.named
                    .iter()
                    .map(|n| format!("{} on {:?}", n.named.effect, n.named.element))
                    .collect::<Vec<_>>()
                    .join(" + ")
            };
            if let (2.., Some(one), Some(two)) = (alt.named.len(), &main.cur_eval, &alt.cur_eval) {
                let added = alt
                    .added_of
                    .iter()
                    .sum::<usize>()
                    .saturating_sub(main.added_of.iter().sum());
                let verdict = self.sim.pays_off(one, two, added);
                notes.push(format!(
                    "stand-in check: {} against {}: {} ({})",
                    pair(&alt),
                    pair(&main),
                    if verdict.confirmed {
                        "the pair is named"
                    } else {
                        "the one effect stays"
                    },
                    verdict.text
                ));
                if verdict.confirmed {
                    notes.extend(
                        alt_found
                            .notes
                            .into_iter()
                            .map(|n| format!("stand-in check: {n}")),
                    );
                    main = alt;
                    break;
                }
            }
        }
        main
    }
}
