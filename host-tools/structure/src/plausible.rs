//! Physical plausibility of a structure: the checks that catch unit mistakes (a stiffness in
//! N/mm, a mass in g, a load in kg) where the file alone is consistent. Every command that
//! reads a structure runs them ([`crate::Model::new`] hands them its numbers), so `mil check`
//! accepts exactly what the commands accept.
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

use crate::{Error, Result};
use nalgebra::DMatrix;

/// Largest static compression (m) of an element under the weights: half a metre, beyond
/// any suspension's or tyre's travel.
pub const MAX_STATIC_COMPRESSION_M: f64 = 0.5;
/// Lowest natural frequency (Hz) of a restrained mode: a 100 s period.
pub const MIN_NATURAL_FREQUENCY_HZ: f64 = 0.01;
/// Highest natural frequency (Hz): 50 kHz, beyond any rig's control rate.
pub const MAX_NATURAL_FREQUENCY_HZ: f64 = 50e3;

/// An element as the static-compression check sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoadedElement<'a> {
    /// Name.
    pub name: &'a str,
    /// Static force (N, compression) at equilibrium.
    pub preload_n: f64,
    /// Small-signal stiffness (N/m) about the equilibrium.
    pub stiffness_n_per_m: f64,
}

/// Checks gravity and the static compression of each element under the weights (see the
/// module documentation); without gravity there is nothing to check.
///
/// # Errors
/// A gravity that is no gravity in m/s², or the first element compressed beyond
/// [`MAX_STATIC_COMPRESSION_M`], with the likely unit mistake.
pub fn static_compression<'a>(
    gravity_m_per_s2: Option<f64>,
    elements: impl IntoIterator<Item = LoadedElement<'a>>,
) -> Result<()> {
    let Some(g) = gravity_m_per_s2 else {
        return Ok(());
    };
    if g > 0.0 && !(1.0..=30.0).contains(&g) {
        return Err(Error::Model(format!(
            "gravity_m_per_s2 = {g}: not a gravity in m/s² (9.81 on earth; {g} is in mm/s² or \
             in g?)"
        )));
    }
    for e in elements {
        let k = e.stiffness_n_per_m;
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

/// The undamped modes of the stiffness matrix `stiffness` (N/m, N·m/rad; the small-signal
/// one, [`crate::model::Linearised::stiffness`]) on the diagonal masses `mass_kg` (kg, kg·m²),
/// by ascending frequency; unrestrained directions (a free mass) have none. A model's are
/// [`crate::Model::modes`].
pub fn modes(stiffness: DMatrix<f64>, mass_kg: &[f64]) -> Vec<Mode> {
    let n = mass_kg.len();
    let scale: Vec<f64> = mass_kg.iter().map(|m| 1.0 / m.sqrt()).collect();
    let mut a = stiffness;
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

/// Checks that every mode of `modes` (on DOFs named `dofs` with masses `mass_kg`) lies
/// between [`MIN_NATURAL_FREQUENCY_HZ`] and [`MAX_NATURAL_FREQUENCY_HZ`].
///
/// # Errors
/// The first mode outside, naming the DOF that moves most in it and the likely unit mistake.
pub fn natural_frequencies(modes: &[Mode], dofs: &[String], mass_kg: &[f64]) -> Result<()> {
    for &Mode {
        frequency_hz: f,
        dof,
    } in modes
    {
        if (MIN_NATURAL_FREQUENCY_HZ..=MAX_NATURAL_FREQUENCY_HZ).contains(&f) {
            continue;
        }
        let name = &dofs[dof];
        let mass = mass_kg[dof];
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
