//! README.md's "Reference actuator (tyre example, paper section 4)" table reproduces from the
//! shipped set-up files: every figure of its "here" column is computed with the library as
//! the commands compute it (`mil analyze` on `examples/tyre.toml` and `examples/aero.toml`,
//! `mil design-filter` on `examples/tyre.toml`, least squares and optimal), formatted as the
//! README prints it, and looked for in the README's row (found by its first cell). A figure
//! the code no longer gives, or a row reworded, fails the test with the computed figure and
//! the row, so the README cannot drift from the code.
//!
//! The bracketed figures of the tyre rows are the same analysis with the ideal `c_t s`
//! (`[numerical.tyre] velocity_estimate = "continuous"`).

use mil::design_filter::{run_design_filter, DesignRequest, DesignSummary, Method};
use mil::setup::SetUp;
use mil_analysis::analyze::{analyze, AnalysisReport, ResponseFigures};
use mil_analysis::metrics::Resonance;
use mil_analysis::Stability;
use mil_params::TyreVelocity;
use std::path::PathBuf;
use std::sync::OnceLock;

/// The table's heading in README.md.
const TABLE: &str = "## Reference actuator (tyre example, paper section 4)";

fn example(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../host-tools/mil/examples")
        .join(name)
}

/// Checks that the "here" cell of the table's row `first` holds every `(what, text)`.
fn check(first: &str, figures: &[(&str, String)]) {
    mil_integration_tests::readme::assert_cell_holds(TABLE, first, figures);
}

/// `mil analyze` on an example set-up (its file as read, or edited by `edit`).
fn analysed(name: &str, edit: impl FnOnce(&mut SetUp)) -> AnalysisReport {
    let mut set_up = SetUp::read(&example(name)).unwrap();
    edit(&mut set_up);
    let setup = set_up.analysis().unwrap();
    analyze(&setup.system, &setup.options).unwrap()
}

/// The tyre example as shipped (the board's velocity estimator).
fn tyre_board() -> &'static AnalysisReport {
    static R: OnceLock<AnalysisReport> = OnceLock::new();
    R.get_or_init(|| {
        analysed("tyre.toml", |s| {
            let tyre = s.numerical.tyre.as_ref().unwrap();
            assert_eq!(tyre.velocity_estimate, TyreVelocity::Board);
            assert!(
                s.controller.filter.is_none(),
                "the tyre example has no filter"
            );
        })
    })
}

/// The tyre example with the ideal `c_t s`.
fn tyre_continuous() -> &'static AnalysisReport {
    static R: OnceLock<AnalysisReport> = OnceLock::new();
    R.get_or_init(|| {
        analysed("tyre.toml", |s| {
            s.numerical.tyre.as_mut().unwrap().velocity_estimate = TyreVelocity::Continuous;
        })
    })
}

/// `mil design-filter` on the tyre example (its files in a temporary folder).
fn design(method: Method) -> DesignSummary {
    let set_up = SetUp::read(&example("tyre.toml")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let request = DesignRequest {
        method,
        out: dir.path().join("tyre-filter.json"),
        structure: None,
        weights: None,
    };
    run_design_filter(&set_up, &request, |_, _| {})
        .unwrap()
        .summary
}

fn least_squares() -> &'static DesignSummary {
    static D: OnceLock<DesignSummary> = OnceLock::new();
    D.get_or_init(|| design(Method::Ls))
}

/// The one resonance of `list` within `band` (Hz).
fn resonance<'a>(list: &'a [Resonance], band: std::ops::Range<f64>, what: &str) -> &'a Resonance {
    let found: Vec<&Resonance> = list.iter().filter(|r| band.contains(&r.hz)).collect();
    assert_eq!(
        found.len(),
        1,
        "{what}: resonances in {band:?} Hz: {list:?}"
    );
    found[0]
}

/// The tyre example's first response, the one the table's resonances are of.
fn tyre_response(r: &AnalysisReport) -> &ResponseFigures {
    let response = &r.responses[0];
    assert_eq!(response.name, "tyre force / road");
    response
}

#[test]
fn body_bounce() {
    let t = tyre_response(tyre_board());
    let mil = resonance(&t.mil_resonances, 3.0..5.0, "MiL bounce");
    let emulated = resonance(&t.emulated_resonances, 3.0..5.0, "emulated bounce");
    eprintln!("body bounce: MiL {mil:?}, emulated {emulated:?}");
    check(
        "body bounce, MiL vs emulated",
        &[
            (
                "bounce frequency, MiL vs emulated",
                format!("{:.2} vs {:.2} Hz", mil.hz, emulated.hz),
            ),
            (
                "bounce damping ratio, MiL vs emulated",
                format!(
                    "(ζ {:.2} vs {:.2})",
                    mil.damping_ratio, emulated.damping_ratio
                ),
            ),
        ],
    );
}

#[test]
fn actuator_induced_mil_resonance() {
    let board = tyre_response(tyre_board());
    let continuous = tyre_response(tyre_continuous());
    let b = resonance(&board.mil_resonances, 10.0..30.0, "MiL resonance, board");
    let c = resonance(
        &continuous.mil_resonances,
        10.0..30.0,
        "MiL resonance, c_t s",
    );
    eprintln!("actuator-induced MiL resonance: board {b:?}, c_t s {c:?}");
    // "absent from the emulated system": no emulated resonance above the bounce, either way.
    for (what, response) in [("board", board), ("c_t s", continuous)] {
        assert!(
            !response.emulated_resonances.iter().any(|r| r.hz > 10.0),
            "{what}: the README says the emulated system has no such resonance: {:?}",
            response.emulated_resonances
        );
    }
    check(
        "actuator-induced MiL resonance",
        &[
            (
                "frequency and damping ratio, board's velocity estimate",
                format!("{:.2} Hz, ζ {:.3}", b.hz, b.damping_ratio),
            ),
            (
                "frequency and damping ratio, c_t s",
                format!("({:.2} Hz, ζ {:.3};", c.hz, c.damping_ratio),
            ),
            ("emulated", "absent from the emulated system".to_string()),
        ],
    );
}

#[test]
fn open_loop_gain_margin() {
    let (b, c) = (tyre_board(), tyre_continuous());
    for (what, r) in [("board", b), ("c_t s", c)] {
        assert_eq!(r.mil.stability, Stability::Stable, "{what}");
        assert_eq!(
            (r.emulated.gain_margin, r.emulated.gain_margin_hz),
            (None, None),
            "{what}: the README says the emulated loop has no phase crossover"
        );
        assert_eq!(r.emulated.stability, Stability::Stable, "{what}");
    }
    let margin = |r: &AnalysisReport| {
        (
            r.mil.gain_margin.expect("a MiL gain margin"),
            r.mil.gain_margin_hz.expect("its frequency"),
        )
    };
    let ((gb, fb), (gc, fc)) = (margin(b), margin(c));
    eprintln!("gain margin: board {gb} at {fb} Hz, c_t s {gc} at {fc} Hz");
    check(
        "open-loop phase lag beyond 180°, gain margin",
        &[
            (
                "gain margin, board's velocity estimate",
                format!("{gb:.2} at {fb:.2} Hz"),
            ),
            ("gain margin, c_t s", format!("({gc:.2} at {fc:.2} Hz;")),
            ("emulated", "emulated: passive, no crossover".to_string()),
        ],
    );
}

#[test]
fn aero_pitch_resonance() {
    let r = analysed("aero.toml", |_| {});
    let (vertical, pitch) = (&r.responses[0], &r.responses[1]);
    assert_eq!(vertical.name, "body vertical / road heave");
    assert_eq!(pitch.name, "body pitch / road pitch");
    let mil = resonance(&pitch.mil_resonances, 6.0..10.0, "MiL pitch");
    let emulated = resonance(&pitch.emulated_resonances, 6.0..10.0, "emulated pitch");
    let worst = vertical
        .band_errors
        .iter()
        .map(|b| b.max_magnitude_db)
        .fold(0.0, f64::max);
    eprintln!(
        "aero pitch: MiL {mil:?}, emulated {emulated:?}; vertical worst {worst} dB over {:?}",
        vertical
            .band_errors
            .iter()
            .map(|b| (b.from_hz, b.to_hz))
            .collect::<Vec<_>>()
    );
    // "within 1 dB": the worst MiL-vs-emulated magnitude error over the set-up's bands,
    // stated in whole dB.
    check(
        "aero pitch resonance, MiL and emulated",
        &[
            (
                "pitch resonance, MiL and emulated",
                format!("{:.2} and {:.2} Hz", mil.hz, emulated.hz),
            ),
            (
                "vertical response's worst band error",
                format!("vertical response within {:.0} dB", worst.ceil()),
            ),
        ],
    );
}

#[test]
fn least_squares_phase_lag_reduction() {
    let d = least_squares();
    let f = &d.figures;
    eprintln!(
        "least squares: lag reduction {} %, lag {} -> {} deg, magnitude {} dB",
        f.phase_lag_reduction_pct,
        f.mean_phase_lag_without_deg,
        f.mean_phase_lag_with_deg,
        f.magnitude_error_db
    );
    check(
        "least-squares command filter: phase-lag reduction 0.5–30 Hz",
        &[
            (
                "phase-lag reduction",
                format!("{:.1} %", f.phase_lag_reduction_pct),
            ),
            (
                "mean phase lag with / without the filter",
                format!(
                    "({:.1}° mean lag left of {:.1}°)",
                    f.mean_phase_lag_with_deg, f.mean_phase_lag_without_deg
                ),
            ),
            (
                "worst magnitude error",
                format!("magnitude within {:.2} dB", f.magnitude_error_db),
            ),
        ],
    );
}

#[test]
fn least_squares_control_sensitivity() {
    let f = &least_squares().figures;
    eprintln!(
        "least squares: noise ratio at peak {} at {} Hz, peak ratio {}",
        f.noise_ratio_at_peak, f.noise_peak_with_hz, f.noise_sensitivity_ratio
    );
    check(
        "control sensitivity with the filter vs without, near 100 Hz",
        &[
            (
                "with / without at the filtered peak",
                format!(
                    "{:.1}× at {:.0} Hz",
                    f.noise_ratio_at_peak, f.noise_peak_with_hz
                ),
            ),
            (
                "ratio of the 60 Hz–Nyquist peaks",
                format!(
                    "(ratio of 60 Hz–Nyquist peaks {:.2})",
                    f.noise_sensitivity_ratio
                ),
            ),
        ],
    );
}

/// The remark under the table: the filtered control sensitivity's peak (60 Hz–Nyquist) in
/// kN/mm, against the paper's "12 N/mm".
#[test]
fn least_squares_control_sensitivity_peak_in_kn_per_mm() {
    let f = &least_squares().figures;
    let text = format!(
        "the analysis gives {:.1} kN/mm at {:.0} Hz",
        f.noise_peak_with * 1e-6,
        f.noise_peak_with_hz
    );
    mil_integration_tests::readme::assert_section_states(TABLE, &text);
}

#[test]
fn least_squares_gain_margin_and_error() {
    let d = least_squares();
    let f = &d.figures;
    assert_eq!(f.stability_with_filter, Stability::Stable);
    let (with, without) = (
        f.gain_margin_with_filter
            .expect("a gain margin with the filter"),
        f.gain_margin_without.expect("a gain margin without"),
    );
    eprintln!(
        "least squares: GM {with} ({without} without), error {} -> {} %, {}x at {} Hz",
        f.response_error_without_pct,
        f.response_error_with_pct,
        f.out_of_band_amplification,
        f.out_of_band_amplification_hz
    );
    check(
        "gain margin with the least-squares filter",
        &[
            (
                "gain margin with / without the filter",
                format!("{with:.2} ({without:.2} without)"),
            ),
            (
                "RMS MiL-vs-emulated error without → with the filter",
                format!(
                    "error {:.0} % → {:.1} % RMS",
                    f.response_error_without_pct, f.response_error_with_pct
                ),
            ),
            (
                "worst MiL/emulated amplification above the band",
                format!(
                    "{:.1}× amplification left at {:.0} Hz",
                    f.out_of_band_amplification, f.out_of_band_amplification_hz
                ),
            ),
        ],
    );
}

#[test]
fn optimised_filter() {
    let d = design(Method::Optimal);
    let front = d.front.as_ref().expect("the optimal method's front");
    assert_eq!(
        d.target_met,
        Some(true),
        "the README says the target is met"
    );
    // "met by the front up to weight w": the points meeting the target are the front's
    // lowest weights, up to w.
    let meeting: Vec<f64> = front
        .iter()
        .filter(|p| p.meets_target)
        .map(|p| p.weight)
        .collect();
    let w = *meeting.last().expect("a front point meets the target");
    assert!(
        front.iter().all(|p| p.meets_target == (p.weight <= w)),
        "the points meeting the target are not the front's lowest weights: {meeting:?}"
    );
    let at_w = front.iter().find(|p| p.weight == w).unwrap();
    // "chosen (most accurate)": no point meeting the target has a smaller error.
    let c = &d.figures;
    for p in front.iter().filter(|p| p.meets_target) {
        assert!(
            c.response_error_with_pct <= p.figures.response_error_with_pct,
            "weight {} meets the target with a smaller error ({} %) than the chosen filter ({} %)",
            p.weight,
            p.figures.response_error_with_pct,
            c.response_error_with_pct
        );
    }
    let gm = |g: Option<f64>| g.map_or("none".to_string(), |g| format!("{g:.2}"));
    let a = &at_w.figures;
    eprintln!(
        "optimal: met up to weight {w}; chosen (weight {:?}) {c:?}; at weight {w}: {a:?}",
        d.chosen_weight
    );
    check(
        "optimised filter (target: ≥ 80 % with ≤ 3 dB, ratio ≤ 10, GM ≥ 2; above-band \
         amplification no worse than least squares)",
        &[
            (
                "highest front weight meeting the target",
                format!("met by the front up to weight {w}"),
            ),
            (
                "the chosen filter",
                format!(
                    "chosen (most accurate): {:.1} %, {:.2} dB, ratio {:.2}, GM {}, error {:.1} %, \
                     {:.1}× at {:.0} Hz",
                    c.phase_lag_reduction_pct,
                    c.magnitude_error_db,
                    c.noise_sensitivity_ratio,
                    gm(c.gain_margin_with_filter),
                    c.response_error_with_pct,
                    c.out_of_band_amplification,
                    c.out_of_band_amplification_hz
                ),
            ),
            (
                "the front point at that weight",
                format!(
                    "at weight {w}: {:.1} %, ratio {:.2}, GM {}, error {:.1} %, {:.1}×",
                    a.phase_lag_reduction_pct,
                    a.noise_sensitivity_ratio,
                    gm(a.gain_margin_with_filter),
                    a.response_error_with_pct,
                    a.out_of_band_amplification
                ),
            ),
        ],
    );
}
