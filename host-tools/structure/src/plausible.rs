//! Physical plausibility of a structure: the checks that catch unit mistakes (a stiffness in
//! N/mm, a mass in g, a load in kg) where the file alone is consistent. Every command that
//! reads a structure runs them ([`crate::Model::new`]), so `mil check` accepts exactly what
//! the commands accept.
//!
//! - Static compression: with gravity, an element whose static compression under the
//!   weights (`preload_n / stiffness_n_per_m`) exceeds [`MAX_STATIC_COMPRESSION_M`] is refused,
//!   naming its stiffness (N/mm for N/m gives 1000x) and the masses it carries (g for kg).
//! - Natural frequencies: the undamped modes the springs restrain must lie between
//!   [`MIN_NATURAL_FREQUENCY_HZ`] and [`MAX_NATURAL_FREQUENCY_HZ`]; the message names the DOF
//!   that moves most in the offending mode and the likely unit.
//!
//! The bounds are wide on purpose (a vehicle on air springs has body modes near 0.5 Hz, a
//! stiff fixture kilohertz modes): they refuse what no specimen on a servo-hydraulic rig can
//! be, not what is merely unusual.

use crate::model::Model;
use crate::{Error, Result};

/// Largest static compression (m) of an element under the weights: half a metre, beyond
/// any suspension's or tyre's travel.
pub const MAX_STATIC_COMPRESSION_M: f64 = 0.5;
/// Lowest natural frequency (Hz) of a restrained mode: a 100 s period.
pub const MIN_NATURAL_FREQUENCY_HZ: f64 = 0.01;
/// Highest natural frequency (Hz): 50 kHz, beyond any rig's control rate.
pub const MAX_NATURAL_FREQUENCY_HZ: f64 = 50e3;

/// Checks `model` (see the module documentation).
///
/// # Errors
/// The first implausible quantity, with the fields and the likely unit mistake.
pub fn check(model: &Model) -> Result<()> {
    static_compression(model)?;
    natural_frequencies(model)
}

fn static_compression(model: &Model) -> Result<()> {
    let Some(g) = model.file.gravity_m_per_s2 else {
        return Ok(());
    };
    if g > 0.0 && !(1.0..=30.0).contains(&g) {
        return Err(Error::Model(format!(
            "gravity_m_per_s2 = {g}: not a gravity in m/s² (9.81 on earth; {g} is in mm/s² or \
             in g?)"
        )));
    }
    for e in &model.elements {
        let (k, _) = e.law.linearised();
        if k <= 0.0 || e.preload_n == 0.0 {
            continue;
        }
        let compression = e.preload_n / k;
        if compression.abs() > MAX_STATIC_COMPRESSION_M {
            return Err(Error::Model(format!(
                "element {:?}: it carries {:.1} N of weight with stiffness_n_per_m = {k}, a \
                 static compression of {:.2} m: a stiffness in N/mm ({k} N/mm = {:e} N/m) or a \
                 mass in g?",
                e.name,
                e.preload_n,
                compression,
                k * 1e3
            )));
        }
    }
    Ok(())
}

/// An undamped mode of the restrained structure.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mode {
    /// Natural frequency (Hz).
    pub frequency_hz: f64,
    /// The DOF (index) that moves most in it.
    pub dof: usize,
}

/// The undamped modes the springs restrain (small-signal stiffnesses, [`Model::linearised`]),
/// by ascending frequency; unrestrained directions (a free mass) have none.
pub fn modes(model: &Model) -> Vec<Mode> {
    let n = model.n();
    let l = model.linearised();
    let scale: Vec<f64> = model.mass.iter().map(|m| 1.0 / m.sqrt()).collect();
    let mut a = l.stiffness;
    for i in 0..n {
        for j in 0..n {
            a[(i, j)] *= scale[i] * scale[j];
        }
    }
    if !a.iter().all(|v| v.is_finite()) {
        return Vec::new();
    }
    let eig = a.symmetric_eigen();
    let largest = eig.eigenvalues.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    let mut modes: Vec<Mode> = eig
        .eigenvalues
        .iter()
        .enumerate()
        .filter(|(_, &lambda)| lambda > 1e-12 * largest && lambda > 0.0)
        .map(|(k, &lambda)| Mode {
            frequency_hz: lambda.sqrt() / std::f64::consts::TAU,
            // The mass-normalised shape back in coordinates.
            dof: (0..n)
                .max_by(|&i, &j| {
                    let si = (eig.eigenvectors[(i, k)] * scale[i]).abs();
                    let sj = (eig.eigenvectors[(j, k)] * scale[j]).abs();
                    si.total_cmp(&sj)
                })
                .unwrap_or(0),
        })
        .collect();
    modes.sort_by(|a, b| a.frequency_hz.total_cmp(&b.frequency_hz));
    modes
}

fn natural_frequencies(model: &Model) -> Result<()> {
    for Mode {
        frequency_hz: f,
        dof,
    } in modes(model)
    {
        if (MIN_NATURAL_FREQUENCY_HZ..=MAX_NATURAL_FREQUENCY_HZ).contains(&f) {
            continue;
        }
        let name = &model.dofs[dof];
        let mass = model.mass[dof];
        let hint = if f < MIN_NATURAL_FREQUENCY_HZ {
            "a stiffness in N/mm, or a mass in g?"
        } else {
            "a stiffness 1000x too large (N/mm as N/m), or a mass in tonnes?"
        };
        return Err(Error::Model(format!(
            "a natural frequency of {f:.3e} Hz (mostly dof {name:?}, mass {mass}) is outside \
             {MIN_NATURAL_FREQUENCY_HZ}-{MAX_NATURAL_FREQUENCY_HZ} Hz: check its mass and the \
             stiffness_n_per_m of the elements on it: {hint}"
        )));
    }
    Ok(())
}
