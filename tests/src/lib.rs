//! Host-side integration tests live in `tests/`; this library holds their shared
//! f64 reference implementations.
//!
//! - [`ReferenceSystem`]: an f64 discrete state-space reference.
//! - [`linear_rig`]: the reference servo-hydraulic actuator on a quarter car, in the time
//!   domain.
//! - [`readme`]: README.md's figures, checked where it cites the test that computes them.

pub mod linear_rig;
pub mod readme;

use nalgebra::{DMatrix, DVector};

/// An f64 discrete state-space reference `ξ[k+1] = Φ ξ[k] + Γ u[k]`, `y = C ξ + D u`, built
/// with nalgebra independently of model-core's fixed-size f32 code.
pub struct ReferenceSystem {
    /// State transition.
    pub phi: DMatrix<f64>,
    /// Input matrix.
    pub gamma: DMatrix<f64>,
    /// Output matrix.
    pub c: DMatrix<f64>,
    /// Feed-through.
    pub d: DMatrix<f64>,
    /// State.
    pub x: DVector<f64>,
}

impl ReferenceSystem {
    /// One sample: returns `y[k]`, advances the state.
    pub fn step(&mut self, u: &DVector<f64>) -> DVector<f64> {
        let y = &self.c * &self.x + &self.d * u;
        self.x = &self.phi * &self.x + &self.gamma * u;
        y
    }
}
