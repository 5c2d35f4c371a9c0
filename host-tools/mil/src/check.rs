//! `mil check FILE`: any of the project's files, validated exactly as the commands that read
//! it validate it (each kind through its command's own reader), so that what `mil check`
//! accepts every command accepts.
//!
//! | file | recognised by | validated as |
//! |---|---|---|
//! | structure (`[[dof]]`) | TOML with `dof` | `mil diagnose` and a set-up's part: schema, names, effects, statics, plausibility |
//! | MiL set-up | TOML with `[controller]` | `mil analyze` / `mil design-filter`, and for configuration 4 `mil sim` / `mil run` (board parameters, rig, excitation, the comparison) |
//! | filter file | JSON | `[controller] filter`, `mil filter upload`: model-core's checks |
//! | record | CSV | `mil diagnose`'s reader: header, units, uniform time base; `--against` a structure, everything `mil diagnose` checks before its search |
//!
//! A record checked `--against` a structure must also hold the structure's input and output
//! columns, as `mil diagnose` requires.

use crate::setup::SetUp;
use anyhow::{anyhow, bail, Context, Result};
use mil_diagnose::{Model, Record};
use std::path::Path;

/// What kind of file a path holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FileKind {
    /// A structure file (`mil diagnose`'s model, a set-up's part).
    Structure,
    /// A MiL set-up (`mil analyze`, `mil design-filter`, `mil sim`, `mil run`).
    Setup,
    /// A command-filter file (JSON).
    Filter,
    /// A measured or simulated record (CSV).
    Record,
    /// A frequency-response table (CSV, `frequency_hz` first: `mil identify`'s).
    ResponseTable,
}

impl FileKind {
    /// The kind's name in messages.
    pub fn name(self) -> &'static str {
        match self {
            FileKind::Structure => "structure",
            FileKind::Setup => "MiL set-up",
            FileKind::Filter => "filter file",
            FileKind::Record => "record",
            FileKind::ResponseTable => "frequency-response table",
        }
    }
}

/// The kind of `path`: by extension (`.json`, `.csv`), and a TOML file by its top-level keys.
///
/// # Errors
/// An unreadable file, TOML that is none of the kinds.
pub fn kind_of(path: &Path) -> Result<FileKind> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let header = text
        .lines()
        .map(str::trim)
        .find(|l| !l.is_empty() && !l.starts_with('#'))
        .unwrap_or("");
    match ext.as_deref() {
        Some("json") => return Ok(FileKind::Filter),
        Some("csv") | Some("txt") | Some("tsv") if header.starts_with("frequency_hz") => {
            return Ok(FileKind::ResponseTable)
        }
        Some("csv") | Some("txt") | Some("tsv") => return Ok(FileKind::Record),
        // Without a telling extension, a JSON object is a filter file.
        _ if header.starts_with('{') => return Ok(FileKind::Filter),
        _ => {}
    }
    let table: toml::Table = toml::from_str(&text)
        .map_err(|e| anyhow!("{}: not TOML, JSON or CSV: {e}", path.display()))?;
    if table.contains_key("dof") {
        Ok(FileKind::Structure)
    } else if table.contains_key("controller") {
        Ok(FileKind::Setup)
    } else {
        bail!(
            "{}: not a structure ([[dof]]) or a MiL set-up ([controller]); its keys: {:?}",
            path.display(),
            table.keys().collect::<Vec<_>>()
        )
    }
}

/// Validates `path` as its kind's commands do; a record also against the structure
/// `against`. Returns the one-line summary `mil check` prints.
///
/// # Errors
/// The first problem, named.
pub fn check(path: &Path, against: Option<&Path>) -> Result<String> {
    let kind = kind_of(path)?;
    if against.is_some() && kind != FileKind::Record {
        bail!("--against is for records (a {} was given)", kind.name());
    }
    let what = match kind {
        FileKind::Structure => {
            let m = Model::read(path).map_err(|e| anyhow!("{e}"))?;
            let frequencies: Vec<f64> = m.modes().iter().map(|mode| mode.frequency_hz).collect();
            format!(
                "structure {:?}: {} DOF(s), {} element(s), {} input(s), {} output(s){}{}",
                m.file.name,
                m.n(),
                m.elements.len(),
                m.inputs.len(),
                m.outputs.len(),
                match (frequencies.first(), frequencies.last()) {
                    (Some(lo), Some(hi)) => format!(", natural frequencies {lo:.3}-{hi:.3} Hz"),
                    _ => String::new(),
                },
                if m.file.gravity_m_per_s2.is_some() {
                    format!(", preloads {:?} N", round1(&m.preloads()))
                } else {
                    String::new()
                }
            )
        }
        FileKind::Setup => {
            let s = SetUp::read(path)?;
            let analysis = s.analysis()?;
            let configuration = analysis.system.configuration();
            if configuration == 4 {
                // What the board and the simulated rig run: checked as `mil sim` runs it.
                let config = s.sim()?;
                crate::sim::prepare(&config)?;
                let bus = bus_budget_line(&config);
                format!(
                    "MiL set-up {:?} (configuration 4, {:?} model: for mil analyze, \
                     design-filter, sim and run{bus})",
                    s.name, config.model.kind
                )
            } else {
                format!(
                    "MiL set-up {:?} (configuration {configuration}: for mil analyze and \
                     design-filter; the board runs configuration 4)",
                    s.name
                )
            }
        }
        FileKind::Filter => {
            let (f, cascade) =
                mil_analysis::filter_file::FilterFile::read(path).map_err(|e| anyhow!("{e}"))?;
            format!(
                "filter file: {} active section(s) at {} Hz",
                cascade.active().len(),
                f.sample_rate_hz
            )
        }
        FileKind::ResponseTable => {
            let table = mil_identify::FrfTable::read_csv(path).map_err(|e| anyhow!("{e}"))?;
            let (lo, hi) = table.frequency_range();
            let tracking = match mil_analysis::measured::MeasuredResponse::new(
                table.clone(),
                &path.display().to_string(),
            ) {
                Ok(m) => {
                    let (bandwidth, delay) = m.bandwidth();
                    format!(
                        "as a tracking response: bandwidth {bandwidth:.1} Hz, equivalent delay \
                         {:.2} ms",
                        delay * 1e3
                    )
                }
                Err(mil_analysis::AnalysisError::Setup(why)) => {
                    format!("not usable as a tracking response: {why}")
                }
                Err(e) => format!("not usable as a tracking response: {e}"),
            };
            format!(
                "frequency-response table: {} points, {lo:.3}-{hi:.1} Hz; {tracking}",
                table.points().len()
            )
        }
        FileKind::Record => {
            let r = Record::read(path).map_err(|e| anyhow!("{e}"))?;
            if let Some(structure) = against {
                let m = Model::read(structure).map_err(|e| anyhow!("{e}"))?;
                crate::diagnose::check_columns(&m, &r, path)?;
                mil_diagnose::diagnose::check_record(&m, &r, &Default::default())
                    .map_err(|e| anyhow!("{}: {e}", path.display()))?;
            }
            format!(
                "record: {} samples at {} Hz ({:.3} s), columns {}",
                r.len(),
                crate::cli::number(1.0 / r.dt, 6),
                r.dt * (r.len().saturating_sub(1)) as f64,
                r.names.join(", ")
            )
        }
    };
    Ok(format!("{}: valid {what}", path.display()))
}

/// What the board's bus budget says of the configuration-4 set-up `config`, as a clause of
/// the summary.
fn bus_budget_line(config: &crate::config::Config) -> String {
    use crate::sim::BusBudget;
    let rate = config.run.sample_rate_hz;
    match crate::sim::board_bus_budget(config) {
        Ok(BusBudget::Fits { load, buses }) => {
            let bus = if buses > 1 {
                "the busier of two 1 Mbit/s buses"
            } else {
                "one 1 Mbit/s bus"
            };
            format!(
                "; on the board {:.1} % of {bus} at {rate} Hz (budget 60 %)",
                100.0 * load
            )
        }
        Ok(BusBudget::Refused { load, max_rate_hz }) => format!(
            "; the board would refuse it at {rate} Hz: {:.1} % of a 1 Mbit/s bus (budget \
             60 %), it runs this model at up to {max_rate_hz:.0} Hz (the simulated rig has no \
             bus)",
            100.0 * load
        ),
        Err(e) => format!("; not a board configuration: {e}"),
    }
}

fn round1(v: &[f64]) -> Vec<f64> {
    v.iter().map(|x| (x * 10.0).round() / 10.0).collect()
}
