//! README.md's bus-load row ("Board and firmware") states what `mil-frames`' budget computes
//! for the configurations issue 21 asks for: tyre ×1 at 2 kHz, tyre ×4 at 1 kHz on one bus
//! and on two, aero ×2 at 1 kHz, and the highest rates within the 60 % budget.

use mil_frames::bus_load::{Schedule, BUDGET};
use mil_integration_tests::readme::assert_section_states;

const SECTION: &str = "## Board and firmware";
const BIT_PER_S: f64 = 1e6;

fn percent(x: f64) -> String {
    format!("{:.1} %", 100.0 * x)
}

fn hz(s: Schedule) -> String {
    format!("{:.0} Hz", s.max_sample_rate_hz(BIT_PER_S, BUDGET))
}

#[test]
fn the_readme_states_the_bus_budget() {
    let tyre1 = Schedule::tyre(1, 2000.0);
    let tyre4 = Schedule::tyre(4, 1000.0);
    let aero = Schedule::aero(1000.0);
    assert!(tyre1.check(BIT_PER_S).is_ok() && aero.check(BIT_PER_S).is_ok());
    assert!(tyre4.check(BIT_PER_S).is_err() && tyre4.on_buses(2).check(BIT_PER_S).is_ok());
    for figure in [
        format!(
            "tyre ×1 at 2 kHz: {} ({} without stuffing)",
            percent(tyre1.load(BIT_PER_S)),
            percent(tyre1.load_nominal(BIT_PER_S))
        ),
        format!(
            "tyre ×4 at 1 kHz: {} on one bus (over budget), {} of the busier",
            percent(tyre4.load(BIT_PER_S)),
            percent(tyre4.on_buses(2).load(BIT_PER_S))
        ),
        format!(
            "aero ×2 at 1 kHz with the speed at 100 Hz: {}",
            percent(aero.load(BIT_PER_S))
        ),
        format!(
            "tyre ×1 {}, ×2 {}, ×4 {} on one bus and {} on two, aero ×2 {}, a substructure \
             with measured forces ×2 {}",
            hz(Schedule::tyre(1, 0.0)),
            hz(Schedule::tyre(2, 0.0)),
            hz(Schedule::tyre(4, 0.0)),
            hz(Schedule::tyre(4, 0.0).on_buses(2)),
            hz(Schedule::aero(0.0)),
            hz(Schedule::substructure(2, true, 0.0)),
        ),
    ] {
        assert_section_states(SECTION, &figure);
    }
}
