//! Command-filter design: the least-squares fit against an exactly representable case, the
//! paper's figures on the tyre example (A. R. Plummer, "Model-in-the-loop testing", 2006,
//! section 4.3), the export check, and the optimised trade-off. The tyre example is the
//! shipped MiL set-up `examples/tyre.toml` (no command filter), analysed.

use mil::setup::SetUp;
use mil_analysis::analyze::Signal;
use mil_analysis::design::{
    design_ls, design_optimal, filter_figures, fit_numerator, ContinuousFilter, DesignOptions,
    DesignTarget, FilterDesign, FilterStructure,
};
use mil_analysis::poly::Rational;
use mil_analysis::setup::Setup;
use mil_analysis::{CommandFilter, LoopPoint, ResponseSource, Stability};
use num_complex::Complex64;
use std::f64::consts::TAU;
use std::path::PathBuf;

fn tyre() -> Setup {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples/tyre.toml");
    let setup = SetUp::read(&path).unwrap();
    assert!(
        setup.controller.filter.is_none(),
        "the tyre example without a filter"
    );
    setup.analysis().unwrap()
}

fn tyre_force_pick(setup: &Setup) -> impl Fn(&LoopPoint) -> Complex64 + Sync {
    let out = Signal::parse("interface_force", &setup.system).unwrap();
    move |p: &LoopPoint| out.pick(p, 0)
}

/// An actuator whose tracking response is exactly `D(s)/N*(s)` for the paper structure's
/// denominator `D` and a chosen numerator `N*` (improper, but the fit only evaluates it on the
/// fit band) is cancelled exactly: the least-squares fit must return `N*`.
#[test]
fn least_squares_recovers_an_exactly_representable_inverse() {
    let mut setup = tyre();
    let wanted = ContinuousFilter {
        structure: FilterStructure::PAPER,
        numerator_normalised: vec![1.0, 3.0, 7.0, 2.5],
    };
    let tf = wanted.transfer_function().unwrap();
    setup.system.actuators.tracking = ResponseSource::Model {
        transfer_function: Rational::new(tf.den.clone(), tf.num.clone()).unwrap(),
        delay_s: 0.0,
    };
    setup.system.actuators.loop_delay_s = 0.0;
    let fitted = fit_numerator(
        &setup.system,
        FilterStructure::PAPER,
        &DesignOptions::paper(2000.0),
    )
    .unwrap();
    for (got, want) in fitted
        .numerator_normalised
        .iter()
        .zip(&wanted.numerator_normalised)
    {
        assert!((got - want).abs() < 1e-8 * want.abs(), "{got} vs {want}");
    }
}

/// The paper's least-squares design (roll-off above 100 Hz, fit 0-30 Hz) on the tyre example
/// with the reference actuator. The paper reports a 60 % phase-lag reduction and a control
/// sensitivity about 30 times larger than before near 100 Hz. Asserted:
/// - lag reduction at least the paper's 60 % (our actuator is fully known, so the fit does
///   better: about 89 %; the paper's measured actuator is not published) and at most 95 %;
/// - command-path magnitude error within 3 dB over 0.5-30 Hz;
/// - the filtered control sensitivity peaks between 80 and 200 Hz ("near 100 Hz") at 15 to 60
///   times the unfiltered one there ("about 30x", a factor 2 either way);
/// - the loop with the filter is stable and its gain margin larger than without (1.4): the
///   filter removes the lag that caused the 17 Hz resonance;
/// - the MiL-vs-emulated error falls to a third or less;
/// - the exported f32 cascade matches the continuous design within 0.2 dB and 2 degrees up to
///   30 Hz (Tustin, pre-warped at the roll-off).
#[test]
fn least_squares_design_reproduces_the_paper_on_the_tyre_example() {
    let setup = tyre();
    let pick = tyre_force_pick(&setup);
    let design = design_ls(&setup.system, &DesignOptions::paper(2000.0), &pick).unwrap();
    let f = &design.figures;
    assert!((60.0..=95.0).contains(&f.phase_lag_reduction_pct), "{f:?}");
    assert!(f.magnitude_error_db <= 3.0, "{f:?}");
    assert!((80.0..=200.0).contains(&f.noise_peak_with_hz), "{f:?}");
    assert!((15.0..=60.0).contains(&f.noise_ratio_at_peak), "{f:?}");
    assert_eq!(f.stability_with_filter, Stability::Stable);
    let (gm, gm0) = (
        f.gain_margin_with_filter.unwrap(),
        f.gain_margin_without.unwrap(),
    );
    assert!((gm0 - 1.4).abs() < 0.1 && gm > gm0 + 1.0, "{gm0} -> {gm}");
    assert!(
        f.response_error_with_pct < f.response_error_without_pct / 3.0,
        "{f:?}"
    );
    design.check_exportable().unwrap();

    let discrete = design.command_filter(2000.0);
    for k in 1..=60 {
        let hz = 0.5 * f64::from(k);
        let c = design.continuous.response_s(Complex64::new(0.0, TAU * hz));
        let d = discrete.response(hz);
        let db = 20.0 * (d.norm() / c.norm()).log10();
        let deg = (d / c).arg().to_degrees();
        assert!(db.abs() < 0.2 && deg.abs() < 2.0, "{hz} Hz: {db} dB {deg}°");
    }
}

/// A filter with four times the static gain of the least-squares design destabilises the tyre
/// loop (gain margin about 3.2 with the filter): its figures say so and it may not be exported.
#[test]
fn a_destabilising_filter_is_refused() {
    let setup = tyre();
    let pick = tyre_force_pick(&setup);
    let options = DesignOptions::paper(2000.0);
    let good = design_ls(&setup.system, &options, &pick).unwrap();
    let loud = ContinuousFilter {
        numerator_normalised: good
            .continuous
            .numerator_normalised
            .iter()
            .map(|c| 4.0 * c)
            .collect(),
        ..good.continuous.clone()
    };
    let cascade = loud.discretise(2000.0).unwrap();
    let filter = CommandFilter::Discrete {
        cascade,
        sample_period_s: 1.0 / 2000.0,
    };
    let figures = filter_figures(&setup.system, &filter, &options, &pick).unwrap();
    assert!(
        matches!(figures.stability_with_filter, Stability::Unstable(_)),
        "{figures:?}"
    );
    let design = FilterDesign {
        continuous: loud,
        cascade,
        figures,
    };
    let err = design.check_exportable().unwrap_err().to_string();
    assert!(err.contains("unstable"), "{err}");
}

/// The optimised design traces a front: more weight on noise lowers the noise-sensitivity
/// ratio and raises the MiL-vs-emulated error. On the reference actuator the target
/// (lag reduction >= 80 % with <= 3 dB, ratio <= 10, gain margin >= 2) is reachable, and the
/// chosen design meets every part of it and is at least as accurate as the least-squares one,
/// without amplifying more than it above the band.
#[test]
fn optimised_design_trades_accuracy_for_noise_and_meets_the_target() {
    let setup = tyre();
    let pick = tyre_force_pick(&setup);
    let target = DesignTarget::DEFAULT;
    let result = design_optimal(
        &setup.system,
        &DesignOptions::paper(2000.0),
        &[0.0, 0.3, 0.6, 0.9],
        &target,
        &pick,
        |_, _| {},
    )
    .unwrap();
    assert_eq!(result.front.len(), 4);
    let (first, last) = (
        &result.front[0].design.figures,
        &result.front[3].design.figures,
    );
    assert!(
        last.noise_sensitivity_ratio < 0.5 * first.noise_sensitivity_ratio,
        "{first:?} {last:?}"
    );
    assert!(last.response_error_with_pct > first.response_error_with_pct);
    assert!(result.target_met);
    let c = &result.chosen.figures;
    assert!(c.phase_lag_reduction_pct >= 80.0, "{c:?}");
    assert!(c.magnitude_error_db <= 3.0, "{c:?}");
    assert!(c.noise_sensitivity_ratio <= 10.0, "{c:?}");
    assert!(c.gain_margin_with_filter.unwrap() >= 2.0, "{c:?}");
    assert_eq!(c.stability_with_filter, Stability::Stable);
    assert!(
        c.response_error_with_pct <= result.least_squares.figures.response_error_with_pct,
        "{c:?}"
    );
    result.chosen.check_exportable().unwrap();
    // No point buys its in-band accuracy by amplifying above the band more than the
    // least-squares design does (the optimiser's penalty; 2 % slack for a soft penalty).
    let limit = result.least_squares.figures.out_of_band_amplification;
    for p in &result.front {
        let a = p.design.figures.out_of_band_amplification;
        assert!(a <= 1.02 * limit, "weight {}: {a} vs {limit}", p.weight);
    }
}
