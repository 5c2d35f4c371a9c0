//! `mil diagnose`: the discrepancy workflow of `mil-diagnose` on a model file and a measured
//! record, with its outputs: the updated model (TOML), the JSON report, and SVG plots of the
//! residual before and after, the restoring-force view and the FRF overlay.

use anyhow::{anyhow, bail, Context, Result};
use mil_diagnose::equation::{self, States};
use mil_diagnose::simulate::{prepare_inputs, simulate};
use mil_diagnose::{diagnose::GapBasis, Diagnosis, JsonReport, Model, Options, Record};
use mil_identify::{h1_estimate, Record as FrfRecord, WelchOptions};
use mil_plots::{BodePlot, BodeSeries, SeriesStyle, XyPlot, XySeries};
use std::path::{Path, PathBuf};

/// Most points drawn per line (longer signals are decimated).
const MAX_POINTS: usize = 3000;

/// Most points drawn per scatter series.
const MAX_SCATTER: usize = 1500;

/// What `mil diagnose` was asked to do.
#[derive(Clone, Debug)]
pub struct DiagnoseRequest {
    /// Model file (TOML).
    pub model: PathBuf,
    /// Measured record (CSV, `time` first).
    pub data: PathBuf,
    /// Output folder (created if needed).
    pub out: PathBuf,
    /// Export this element of the updated model as model-core's real-time tyre (the
    /// `[numerical.tyre]` table of a MiL set-up, `numerical-tyre.toml` in the output folder).
    pub tyre: Option<TyreExport>,
}

/// What `--tyre` exports (see [`tyre_section`]).
#[derive(Clone, Debug)]
pub struct TyreExport {
    /// The element of the model that is the tyre.
    pub element: String,
    /// Static wheel load (N) when the updated model has no lift-off to tell it.
    pub static_load_n: Option<f64>,
}

/// The result of `mil diagnose`.
#[derive(Clone, Debug)]
pub struct DiagnoseOutput {
    /// Everything the workflow found.
    pub diagnosis: Diagnosis,
    /// The updated model file written.
    pub updated_model: PathBuf,
    /// The JSON report written (the same object `--json` prints).
    pub report: PathBuf,
    /// The plots written (SVG).
    pub plots: Vec<PathBuf>,
    /// The `[numerical.tyre]` table written for model-core's real-time tyre (`--tyre`), or
    /// why it could not be.
    pub tyre: Option<std::result::Result<PathBuf, String>>,
}

/// Reads the model and the record, checks that the record has the model's columns, runs the
/// workflow (reporting `progress(fraction, message)`), and writes the updated model, the
/// report and the plots into `request.out`.
///
/// # Errors
/// A file cannot be read or written, the model is invalid, the record is malformed or lacks
/// a column the model names, or the workflow cannot proceed (e.g. a record too short).
pub fn run_diagnose(
    request: &DiagnoseRequest,
    progress: &dyn Fn(f64, &str),
) -> Result<DiagnoseOutput> {
    let model = Model::read(&request.model).map_err(|e| anyhow!("model: {e}"))?;
    let record = Record::read(&request.data).map_err(|e| anyhow!("{e}"))?;
    check_columns(&model, &record, &request.data)?;
    // A record past the diagnosis' sample budget is averaged down (or refused) once here,
    // so that the plots use the record the diagnosis used.
    let (record, reduced) = mil_diagnose::diagnose::within_budget(&model, &record)
        .map_err(|e| anyhow!("{}: {e}", request.data.display()))?;
    let record = record.as_ref();
    let mut diagnosis =
        mil_diagnose::diagnose_with_progress(&model, record, &Options::default(), progress)
            .map_err(|e| anyhow!("{e}"))?;
    diagnosis.notes.splice(0..0, reduced);
    let updated_model = diagnosis.write(&request.out).map_err(|e| anyhow!("{e}"))?;
    let report = request.out.join("report.json");
    progress(1.0, "writing plots");
    let plots = write_plots(&diagnosis, record, &request.out)?;
    // A tyre that cannot be exported does not hide the diagnosis: it is reported beside it.
    let tyre = request.tyre.as_ref().map(|t| {
        let path = request.out.join("numerical-tyre.toml");
        tyre_section(&diagnosis.updated, &t.element, t.static_load_n)
            .and_then(|section| tyre_toml(&section, &t.element, &request.model))
            .and_then(|text| Ok(mil_numerics::files::write_atomic(&path, text.as_bytes())?))
            .map(|()| path)
            .map_err(|e| crate::cli::error_message(&e))
    });
    Ok(DiagnoseOutput {
        diagnosis,
        updated_model,
        report,
        plots,
        tyre,
    })
}

/// The `[numerical.tyre]` table of a MiL set-up — model-core's real-time tyre, which the
/// board runs — from element `element` of a (diagnosed) model: its stiffness and damping,
/// lift-off if the model has it, the static load from the lift-off preload (or
/// `static_load_n`, which takes precedence), and the velocity low-pass of model-core's
/// paper tyre (500 Hz). The element compresses as the tyre's deflection `δ = road − hub`,
/// as in the tyre example (`host-tools/diagnose/examples/quarter-car.toml`).
///
/// # Errors
/// No such element; the element has effects model-core's tyre does not model (it has
/// stiffness, damping, static load and lift-off); no static load (neither lift-off nor
/// `static_load_n`); or model-core rejects the values.
pub fn tyre_section(
    model: &Model,
    element: &str,
    static_load_n: Option<f64>,
) -> Result<crate::config::TyreSection> {
    let el = model
        .elements
        .iter()
        .find(|e| e.name == element)
        .ok_or_else(|| {
            anyhow!(
                "--tyre {element:?}: the model has no such element (elements: {})",
                model
                    .elements
                    .iter()
                    .map(|e| e.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        })?;
    let law = &el.law;
    let unsupported: Vec<String> = law
        .kinds()
        .into_iter()
        .filter(|k| *k != mil_diagnose::EffectKind::LiftOff)
        .map(|k| k.to_string())
        .collect();
    if !unsupported.is_empty() {
        bail!(
            "--tyre {element:?}: the element has {}, which model-core's real-time tyre does not model (it has stiffness, damping, static load and lift-off)",
            unsupported.join(", ")
        );
    }
    let static_load = static_load_n.or(law.lift_off).ok_or_else(|| {
        anyhow!(
            "--tyre {element:?}: the element has no lift-off, so the record does not tell its static load: give --tyre-static-load-n"
        )
    })?;
    let section = crate::config::TyreSection {
        stiffness_n_per_m: law.k as f32,
        damping_n_s_per_m: law.c as f32,
        static_load_n: static_load as f32,
        lift_off: law.lift_off.is_some(),
        velocity_cutoff_hz: model_core::tyre::TyreParams::PAPER.velocity_cutoff_hz,
    };
    model_core::tyre::TyreParams {
        stiffness: section.stiffness_n_per_m,
        damping: section.damping_n_s_per_m,
        static_load: section.static_load_n,
        lift_off: u32::from(section.lift_off),
        velocity_cutoff_hz: section.velocity_cutoff_hz,
    }
    .validate()
    .map_err(|e| anyhow!("--tyre {element:?}: model-core rejects the tyre: {e}"))?;
    Ok(section)
}

/// The text of `numerical-tyre.toml`: a comment saying where the values come from, then the
/// `[numerical.tyre]` table.
fn tyre_toml(section: &crate::config::TyreSection, element: &str, model: &Path) -> Result<String> {
    #[derive(serde::Serialize)]
    struct Numerical<'a> {
        tyre: &'a crate::config::TyreSection,
    }
    #[derive(serde::Serialize)]
    struct Table<'a> {
        numerical: Numerical<'a>,
    }
    let body = toml::to_string(&Table {
        numerical: Numerical { tyre: section },
    })?;
    Ok(format!(
        "# model-core's real-time tyre from element {element:?} of the model diagnosed from\n# {} (mil diagnose --tyre): this [numerical.tyre] table replaces a MiL set-up's.\n{body}",
        model.display()
    ))
}

/// Every input and output column the model names must be in the record.
pub(crate) fn check_columns(model: &Model, record: &Record, path: &Path) -> Result<()> {
    let wanted = model
        .inputs
        .iter()
        .map(|i| (&i.column, "input"))
        .chain(model.outputs.iter().map(|o| (&o.column, "output")));
    for (column, what) in wanted {
        if !record.names.contains(column) {
            bail!(
                "{}: the record does not fit the model {:?}: no column {column:?} for its {what} (the record has: time, {})",
                path.display(),
                model.file.name,
                record.names.join(", ")
            );
        }
    }
    Ok(())
}

impl DiagnoseOutput {
    /// The JSON object of `--json` (the keys).
    pub fn json_report(&self) -> JsonReport {
        self.diagnosis
            .json_report(&self.updated_model.display().to_string())
    }

    /// The human summary: the crate's summary (named effects with parameters ± one standard
    /// deviation, recalibrated parameters, gaps, evidence), the gap before and after, the
    /// time window that improved most, and where the files are.
    pub fn table(&self) -> String {
        let d = &self.diagnosis;
        let mut s = d.summary();
        let names: Vec<String> = d
            .named
            .iter()
            .map(|n| format!("{} on {:?}", n.named.effect, n.named.element))
            .collect();
        s.push_str(&format!(
            "named effect(s): {}\n",
            if names.is_empty() {
                "none".to_string()
            } else {
                names.join(", ")
            }
        ));
        let factor = d.gap_before.nrmse / d.gap_after.nrmse;
        s.push_str(&format!(
            "gap (NRMSE, validation blocks): {:.4} before -> {:.4} after ({}x smaller)\n",
            d.gap_before.nrmse,
            d.gap_after.nrmse,
            crate::cli::number(factor, 3)
        ));
        if let Some(w) = d
            .windows
            .iter()
            .max_by(|a, b| (a.before - a.after).total_cmp(&(b.before - b.after)))
        {
            s.push_str(&format!(
                "  window: {:.2}-{:.2} s NRMSE {:.4} -> {:.4} (recalibrated -> updated)\n",
                w.time_s[0], w.time_s[1], w.before, w.after
            ));
        }
        s.push_str(&format!(
            "updated model: {}\nreport:        {}\n",
            self.updated_model.display(),
            self.report.display()
        ));
        for p in &self.plots {
            s.push_str(&format!("plot:          {}\n", p.display()));
        }
        if let Some(Ok(t)) = &self.tyre {
            s.push_str(&format!("tyre (model-core): {}\n", t.display()));
        }
        s
    }
}

/// Writes the plots into `dir`; returns their paths.
///
/// - `residual.svg`: the residual over the whole record (fitting and validation blocks), model as given,
///   recalibrated and updated (simulated output minus measured, over the measured output's standard
///   deviation; for models not restrained on their own, the inverse-dynamics force residual
///   per DOF, N).
/// - `restoring_force_x.svg`, `restoring_force_v.svg`: the restoring-force view of the named
///   element (else the first element): the element force inferred from the measured motion
///   (the recalibrated model's force plus the force its DOF's equation of motion misses)
///   against the element's compression and its rate, with the recalibrated and the updated
///   laws at the same samples.
/// - `frf.svg`, `coherence.svg` (models restrained on their own): the H1 estimate from each
///   input to each output of the data and of the simulated model as given, recalibrated and
///   updated; the data's coherence.
///
/// # Errors
/// A plot cannot be written.
pub fn write_plots(d: &Diagnosis, record: &Record, dir: &Path) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut files = Vec::new();
    let st = equation::estimate_states(&d.original, record).map_err(|e| anyhow!("{e}"))?;
    let len = record.len();
    let time = |t: usize| record.t0 + t as f64 * record.dt;
    // Residual over the whole record.
    let mut plot = XyPlot::new("Residual over the record", "time [s]", "residual");
    let initial: (Vec<f64>, Vec<f64>) = (
        st.q.iter().map(|q| q[0]).collect(),
        st.qd.iter().map(|q| q[0]).collect(),
    );
    let sims = if d.basis == GapBasis::Simulation {
        // Driven as the diagnosis drives its simulations: logged inputs low-passed above
        // their signal band.
        let (driven, _) = mil_diagnose::diagnose::prefilter_inputs(&d.original, record);
        let sim = |m: &Model| {
            let inputs = prepare_inputs(m, &driven).ok()?;
            simulate(m, &driven, &inputs, 0..len, Some((&initial.0, &initial.1)))
                .ok()
                .map(|s| s.outputs)
        };
        Some((
            sim(&d.original),
            sim(&d.recalibrated_model),
            sim(&d.updated),
        ))
    } else {
        None
    };
    let step = (len / MAX_POINTS).max(1);
    if let Some((before, recal, after)) = &sims {
        plot.y_label = "(simulated - measured) / std(measured)".into();
        for (label, sim, style) in [
            ("as given", before, SeriesStyle::Line),
            ("recalibrated", recal, SeriesStyle::Line),
            ("updated", after, SeriesStyle::Line),
        ] {
            let Some(sim) = sim else { continue };
            for (o, out) in d.original.outputs.iter().enumerate().take(3) {
                let Ok(y) = record.column(&out.column) else {
                    continue;
                };
                let sd = mil_diagnose::signal::std(y).max(1e-300);
                let points = (0..len)
                    .step_by(step)
                    .map(|t| (time(t), (sim[o][t] - y[t]) / sd))
                    .collect();
                plot.series.push(XySeries::new(
                    format!("{label}: {}", out.column),
                    points,
                    style,
                ));
            }
        }
    } else {
        plot.title = "Inverse-dynamics force residual over the record".into();
        plot.y_label = "force the model misses [N]".into();
        let ones = vec![1.0; d.original.n()];
        for (label, m) in [
            ("as given", &d.original),
            ("recalibrated", &d.recalibrated_model),
            ("updated", &d.updated),
        ] {
            let sys = equation::build(m, &st, &[], &ones);
            for (i, dof) in d.original.dofs.iter().enumerate().take(3) {
                let rows: Vec<usize> = (0..sys.rhs.len()).filter(|&r| sys.dof[r] == i).collect();
                let k = (rows.len() / MAX_POINTS).max(1);
                let points = rows
                    .iter()
                    .step_by(k)
                    .map(|&r| (time(sys.sample[r]), sys.rhs[r]))
                    .collect();
                plot.series.push(XySeries::new(
                    format!("{label}: {dof}"),
                    points,
                    SeriesStyle::Line,
                ));
            }
        }
    }
    let path = dir.join("residual.svg");
    mil_plots::xy_svg(&path, &plot)?;
    files.push(path);
    files.extend(restoring_force(d, &st, dir)?);
    if let Some((before, recal, after)) = &sims {
        files.extend(frf(d, record, [before, recal, after], dir)?);
    }
    Ok(files)
}

/// The restoring-force view (see [`write_plots`]).
fn restoring_force(d: &Diagnosis, st: &States, dir: &Path) -> Result<Vec<PathBuf>> {
    let recal = &d.recalibrated_model;
    let name = d
        .named
        .iter()
        .find(|n| !recal.is_input(&n.named.element))
        .map(|n| n.named.element.clone())
        .or_else(|| recal.elements.first().map(|e| e.name.clone()));
    let Some(name) = name else {
        return Ok(Vec::new());
    };
    let Some(e) = recal.elements.iter().position(|x| x.name == name) else {
        return Ok(Vec::new());
    };
    let el = &recal.elements[e];
    // The DOF the element acts on most (largest |a| / mass).
    let dof = (0..recal.n())
        .max_by(|&a, &b| {
            (el.a[a].abs() / recal.mass[a]).total_cmp(&(el.a[b].abs() / recal.mass[b]))
        })
        .unwrap_or(0);
    if el.a[dof] == 0.0 {
        return Ok(Vec::new());
    }
    let ones = vec![1.0; recal.n()];
    let sys = equation::build(recal, st, &[], &ones);
    let signals = |m: &Model| {
        let (u, ud) = equation::model_inputs(m, st);
        equation::element_signals(m, st, &u, &ud)
    };
    let sig = signals(recal);
    let sig_after = signals(&d.updated);
    let Some(el_after) = d.updated.elements.iter().find(|x| x.name == name) else {
        return Ok(Vec::new());
    };
    let e_after = d
        .updated
        .elements
        .iter()
        .position(|x| x.name == name)
        .unwrap_or(e);
    let rows: Vec<usize> = (0..sys.rhs.len()).filter(|&r| sys.dof[r] == dof).collect();
    let k = (rows.len() / MAX_SCATTER).max(1);
    // rhs = forces applied − M q̈ − Σ a F_model = a (F_true − F_model) when this element
    // alone misses force: the inferred force is F_model + rhs / a (all of the DOF's
    // residual attributed to this element).
    let mut inferred = Vec::new();
    let mut linear = Vec::new();
    let mut updated = Vec::new();
    for &r in rows.iter().step_by(k) {
        let t = sys.sample[r];
        let (x, v, z) = (sig[e].x[t], sig[e].v[t], sig[e].z[t]);
        let f_model = el.law.force(x, v, z);
        inferred.push((x, v, f_model + sys.rhs[r] / el.a[dof]));
        linear.push((x, v, f_model));
        let s = &sig_after[e_after];
        updated.push((x, v, el_after.law.force(s.x[t], s.v[t], s.z[t])));
    }
    let mut files = Vec::new();
    for (file, axis, pick) in [
        (
            "restoring_force_x.svg",
            "compression x [m]",
            (|p: &(f64, f64, f64)| (p.0, p.2)) as fn(&(f64, f64, f64)) -> (f64, f64),
        ),
        ("restoring_force_v.svg", "compression rate v [m/s]", |p| {
            (p.1, p.2)
        }),
    ] {
        let mut plot = XyPlot::new(
            format!(
                "Restoring force of {name:?} (equations of DOF {:?})",
                recal.dofs[dof]
            ),
            axis,
            "element force [N]",
        );
        plot.series = vec![
            XySeries::new(
                "inferred from the measured motion",
                inferred.iter().map(pick).collect(),
                SeriesStyle::Points,
            ),
            XySeries::new(
                "recalibrated linear model",
                linear.iter().map(pick).collect(),
                SeriesStyle::Points,
            ),
            XySeries::new(
                "updated model",
                updated.iter().map(pick).collect(),
                SeriesStyle::Points,
            ),
        ];
        let path = dir.join(file);
        mil_plots::xy_svg(&path, &plot)?;
        files.push(path);
    }
    Ok(files)
}

/// The FRF overlay and the data's coherence (see [`write_plots`]).
fn frf(
    d: &Diagnosis,
    record: &Record,
    sims: [&Option<Vec<Vec<f64>>>; 3],
    dir: &Path,
) -> Result<Vec<PathBuf>> {
    let inputs = prepare_inputs(&d.original, record).map_err(|e| anyhow!("{e}"))?;
    let opts = WelchOptions::for_record(record.len());
    let f_hi = d.cutoff_hz.min(0.45 / record.dt);
    let est = |u: &[f64], y: &[f64]| {
        h1_estimate(
            &[FrfRecord {
                input: u,
                output: y,
            }],
            1.0 / record.dt,
            &opts,
        )
        .ok()
    };
    let mut pages = Vec::new();
    let mut coherence = XyPlot::new("Coherence of the data", "frequency [Hz]", "coherence");
    coherence.log_x = true;
    for (inp, u) in d.original.inputs.iter().zip(&inputs).take(2) {
        for (o, out) in d.original.outputs.iter().enumerate().take(3) {
            let Ok(y) = record.column(&out.column) else {
                continue;
            };
            let Some(data) = est(u, y) else { continue };
            let keep: Vec<usize> = (0..data.frequency_hz.len())
                .filter(|&i| data.frequency_hz[i] <= f_hi)
                .collect();
            let freq: Vec<f64> = keep.iter().map(|&i| data.frequency_hz[i]).collect();
            let mut plot = BodePlot::new(
                format!("FRF {} -> {}", inp.column, out.column),
                format!("|{} / {}|", out.column, inp.column),
            );
            plot.series.push(BodeSeries::new(
                "data",
                freq.clone(),
                keep.iter().map(|&i| data.response[i]).collect(),
            ));
            for (label, sim, dashed) in [
                ("model as given", sims[0], true),
                ("recalibrated", sims[1], true),
                ("updated", sims[2], false),
            ] {
                let Some(sim) = sim else { continue };
                let Some(m) = est(u, &sim[o]) else { continue };
                let mut s = BodeSeries::new(
                    label,
                    freq.clone(),
                    keep.iter().map(|&i| m.response[i]).collect(),
                );
                s.dashed = dashed;
                plot.series.push(s);
            }
            coherence.series.push(XySeries::new(
                format!("{} -> {}", inp.column, out.column),
                keep.iter()
                    .map(|&i| (data.frequency_hz[i], data.coherence[i]))
                    .collect(),
                SeriesStyle::Line,
            ));
            pages.push(plot);
        }
    }
    if pages.is_empty() {
        return Ok(Vec::new());
    }
    let path = dir.join("frf.svg");
    if pages.len() == 1 {
        mil_plots::bode_svg(&path, &pages[0])?;
    } else {
        mil_plots::bode_page_svg(&path, &pages)?;
    }
    let cpath = dir.join("coherence.svg");
    mil_plots::xy_svg(&cpath, &coherence)?;
    Ok(vec![path, cpath])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The tyre example's model with the given effects on its `tyre` element, whose
    /// static load is `preload_n` (N).
    fn tyre_model_loaded(effects: &str, preload_n: f64) -> Model {
        let text = include_str!("../../diagnose/examples/quarter-car.toml").replace(
            "damping_n_s_per_m = 500.0",
            &format!("damping_n_s_per_m = 500.0\npreload_n = {preload_n}"),
        );
        Model::from_toml(&format!("{text}\n{effects}")).expect("model")
    }

    /// The tyre example's model with the given effects on its `tyre` element.
    fn tyre_model(effects: &str) -> Model {
        tyre_model_loaded(effects, 0.0)
    }

    #[test]
    fn the_diagnosed_tyre_becomes_model_cores_tyre() {
        let m = tyre_model_loaded(
            "[[effect]]\neffect = \"lift_off\"\nelement = \"tyre\"\n",
            1668.5,
        );
        let t = tyre_section(&m, "tyre", None).expect("tyre");
        assert_eq!(t.stiffness_n_per_m, 250.0e3);
        assert_eq!(t.damping_n_s_per_m, 500.0);
        assert_eq!(t.static_load_n, 1668.5);
        assert!(t.lift_off);
        // The file is a `[numerical.tyre]` table that a MiL set-up reads back.
        let text = tyre_toml(&t, "tyre", Path::new("tyre.toml")).expect("toml");
        #[derive(serde::Deserialize)]
        struct Table {
            numerical: crate::setup::Numerical,
        }
        let back: Table = toml::from_str(&text).expect("parses");
        let n = back.numerical.tyre.expect("tyre");
        assert_eq!(
            (
                n.stiffness_n_per_m,
                n.damping_n_s_per_m,
                n.static_load_n,
                n.lift_off,
                n.velocity_cutoff_hz
            ),
            (
                t.stiffness_n_per_m,
                t.damping_n_s_per_m,
                Some(t.static_load_n),
                t.lift_off,
                t.velocity_cutoff_hz
            )
        );
        // An explicit static load takes precedence.
        let t2 = tyre_section(&m, "tyre", Some(1700.0)).expect("tyre");
        assert_eq!(t2.static_load_n, 1700.0);
    }

    #[test]
    fn a_tyre_model_core_cannot_run_is_refused_with_the_reason() {
        let linear = tyre_model("");
        let e = tyre_section(&linear, "tyre", None).expect_err("no static load");
        assert!(e.to_string().contains("--tyre-static-load-n"), "{e}");
        assert!(tyre_section(&linear, "tyre", Some(1667.7)).is_ok_and(|t| !t.lift_off));
        let cubic = tyre_model(
            "[[effect]]\neffect = \"cubic_stiffness\"\nelement = \"tyre\"\nparameters = { stiffness_n_per_m3 = 1e9 }\n",
        );
        let e = tyre_section(&cubic, "tyre", Some(1667.7)).expect_err("cubic");
        assert!(e.to_string().contains("cubic_stiffness"), "{e}");
        let e = tyre_section(&linear, "wheel", Some(1667.7)).expect_err("no element");
        assert!(e.to_string().contains("suspension, tyre"), "{e}");
        let mut negative = linear.clone();
        negative.elements[1].law.k = -1.0;
        assert!(tyre_section(&negative, "tyre", Some(1667.7)).is_err());
    }
}
