//! A linear hub-coupled rig in the time domain: the reference force-controlled servo-hydraulic
//! actuator driving the hub of a quarter car, written as one continuous state-space model
//! from the actuator's documented physics and stepped exactly between controller samples
//! (zero-order hold of the force demand).
//!
//! The physics is that documented at the top of `mil_analysis::reference_actuator`
//! (linearised about mid-stroke and zero load pressure), *not* its transfer functions
//! `p_f`, `r_f`, so that comparing this model with the analysis checks both. SI units
//! throughout; positions and forces up positive, deviations from the static equilibrium (no
//! gravity, no static load).
//!
//! ```text
//! servovalve      ẍ_v = ω_v² (u − x_v) − 2 ζ_v ω_v ẋ_v
//! force loop      u = K_p (F_c − F) + K_i q,   q̇ = F_c − F          (analogue PI)
//! orifice flow    Q = K_q x_v + κ A ẋ_u − K_c P_L                   (κ: velocity feed-forward)
//! chambers        V/(4β) Ṗ_L = Q − A ẋ_u
//! load cell       F = A P_L − m_a ẍ_u − c_a ẋ_u                     (force on the hub)
//! hub             m_u ẍ_u = F + k_c (x_s − x_u) + c_c (ẋ_s − ẋ_u)
//! body            m_s ẍ_s = −k_c (x_s − x_u) − c_c (ẋ_s − ẋ_u)
//! ```
//!
//! The actuator rod moves with the hub (`y = x_u`). The load cell's inertia term makes `F`
//! depend on `ẍ_u`; eliminating it, `(m_u + m_a) ẍ_u = A P_L − c_a ẋ_u + k_c (x_s − x_u) +
//! c_c (ẋ_s − ẋ_u)`, and `F` is a linear function of the state. The input is the force
//! demand `F_c` (N); the outputs are the hub position `x_u` (m, what the rig's displacement
//! transducer measures) and the load-cell force `F` (N, the interface force).

use mil_discretise::{zoh_ss, DiscretiseError, StateSpace};
use mil_params::ServoHydraulicActuator;
use nalgebra::{DMatrix, SMatrix, SVector};
use std::f64::consts::TAU;

/// Number of states of [`HubRig`].
pub const STATES: usize = 8;

/// State indices of [`HubRig`] (SI units).
pub mod state {
    /// Body (sprung mass) position `x_s` (m).
    pub const BODY_POSITION: usize = 0;
    /// Body velocity `ẋ_s` (m/s).
    pub const BODY_VELOCITY: usize = 1;
    /// Hub (unsprung mass, actuator rod) position `x_u` (m).
    pub const HUB_POSITION: usize = 2;
    /// Hub velocity `ẋ_u` (m/s).
    pub const HUB_VELOCITY: usize = 3;
    /// Servovalve spool opening `x_v` (fraction of full opening).
    pub const SPOOL: usize = 4;
    /// Spool velocity `ẋ_v` (1/s).
    pub const SPOOL_RATE: usize = 5;
    /// Load pressure `P_L` (Pa).
    pub const LOAD_PRESSURE: usize = 6;
    /// Integral of the force error `q = ∫ (F_c − F) dt` (N·s).
    pub const FORCE_ERROR_INTEGRAL: usize = 7;
}

/// The physical part of the quarter car on a hub-coupled rig: the body on the suspension
/// over the hub (wheel and tyre removed; the hub actuator replaces the tyre).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QuarterCar {
    /// Sprung mass `m_s` (kg).
    pub sprung_mass_kg: f64,
    /// Suspension stiffness `k_c` (N/m).
    pub suspension_stiffness: f64,
    /// Suspension damping `c_c` (N·s/m).
    pub suspension_damping: f64,
    /// Unsprung mass `m_u` (kg), the hub side of the load cell.
    pub unsprung_mass_kg: f64,
}

/// The reference actuator driving the hub of a quarter car (continuous time).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HubRig {
    /// The force-controlled actuator (physical parameters and its analogue force loop).
    pub actuator: ServoHydraulicActuator,
    /// The quarter car.
    pub car: QuarterCar,
}

/// Output rows of [`HubRig::state_space`].
pub mod output {
    /// Hub position `x_u` (m).
    pub const HUB_POSITION: usize = 0;
    /// Load-cell force `F` on the hub (N).
    pub const LOAD_CELL_FORCE: usize = 1;
}

impl HubRig {
    /// The continuous model `ẋ = A x + B F_c`, `[x_u; F] = C x` (no feed-through): states
    /// as in [`state`], outputs as in [`output`], input the force demand `F_c` (N).
    pub fn state_space(&self) -> StateSpace {
        use state::*;
        let act = &self.actuator;
        let car = &self.car;
        let area = act.piston_area_m2;
        let wv = TAU * act.valve_frequency_hz;
        let zv = act.valve_damping_ratio;
        let compressibility = act.oil_volume_m3 / (4.0 * act.bulk_modulus_pa); // V/(4β)
        let mass = car.unsprung_mass_kg + act.moving_mass_kg;

        let row = |entries: &[(usize, f64)]| {
            let mut r = [0.0; STATES];
            for &(i, v) in entries {
                r[i] += v;
            }
            r
        };
        let add = |a: [f64; STATES], b: [f64; STATES], k: f64| {
            let mut r = a;
            for (x, y) in r.iter_mut().zip(b) {
                *x += k * y;
            }
            r
        };
        // Suspension force on the hub k_c (x_s − x_u) + c_c (ẋ_s − ẋ_u).
        let suspension = row(&[
            (BODY_POSITION, car.suspension_stiffness),
            (BODY_VELOCITY, car.suspension_damping),
            (HUB_POSITION, -car.suspension_stiffness),
            (HUB_VELOCITY, -car.suspension_damping),
        ]);
        // Hub acceleration with the load-cell inertia eliminated.
        let hub_acceleration = row(&[
            (LOAD_PRESSURE, area / mass),
            (HUB_VELOCITY, -act.seal_damping_n_s_per_m / mass),
        ]);
        let hub_acceleration = add(hub_acceleration, suspension, 1.0 / mass);
        // Load-cell force F = A P_L − m_a ẍ_u − c_a ẋ_u.
        let force = add(
            row(&[
                (LOAD_PRESSURE, area),
                (HUB_VELOCITY, -act.seal_damping_n_s_per_m),
            ]),
            hub_acceleration,
            -act.moving_mass_kg,
        );

        let mut a = DMatrix::zeros(STATES, STATES);
        let mut set_row = |i: usize, r: [f64; STATES]| {
            for (j, v) in r.into_iter().enumerate() {
                a[(i, j)] = v;
            }
        };
        set_row(BODY_POSITION, row(&[(BODY_VELOCITY, 1.0)]));
        set_row(
            BODY_VELOCITY,
            add([0.0; STATES], suspension, -1.0 / car.sprung_mass_kg),
        );
        set_row(HUB_POSITION, row(&[(HUB_VELOCITY, 1.0)]));
        set_row(HUB_VELOCITY, hub_acceleration);
        set_row(SPOOL, row(&[(SPOOL_RATE, 1.0)]));
        // ẍ_v = ω² (K_p (F_c − F) + K_i q − x_v) − 2 ζ ω ẋ_v (the F_c part is in B).
        set_row(
            SPOOL_RATE,
            add(
                row(&[
                    (FORCE_ERROR_INTEGRAL, wv * wv * act.integral_gain_per_n_s),
                    (SPOOL, -wv * wv),
                    (SPOOL_RATE, -2.0 * zv * wv),
                ]),
                force,
                -wv * wv * act.proportional_gain_per_n,
            ),
        );
        // Ṗ_L = (K_q x_v − (1 − κ) A ẋ_u − K_c P_L) / (V/(4β)).
        set_row(
            LOAD_PRESSURE,
            row(&[
                (SPOOL, act.flow_gain_m3_per_s / compressibility),
                (
                    HUB_VELOCITY,
                    -(1.0 - act.velocity_feedforward) * area / compressibility,
                ),
                (
                    LOAD_PRESSURE,
                    -act.flow_pressure_coefficient / compressibility,
                ),
            ]),
        );
        // q̇ = F_c − F.
        set_row(FORCE_ERROR_INTEGRAL, add([0.0; STATES], force, -1.0));

        let mut b = DMatrix::zeros(STATES, 1);
        b[(SPOOL_RATE, 0)] = wv * wv * act.proportional_gain_per_n;
        b[(FORCE_ERROR_INTEGRAL, 0)] = 1.0;

        let mut c = DMatrix::zeros(2, STATES);
        c[(output::HUB_POSITION, HUB_POSITION)] = 1.0;
        for (j, v) in force.into_iter().enumerate() {
            c[(output::LOAD_CELL_FORCE, j)] = v;
        }
        StateSpace {
            a,
            b,
            c,
            d: DMatrix::zeros(2, 1),
        }
    }

    /// The model sampled every `dt` seconds with the force demand held constant over each
    /// sample (zero-order hold, `mil_discretise::zoh_ss`), exact for this linear model,
    /// starting at rest.
    ///
    /// # Errors
    /// An invalid `dt` or non-finite parameters.
    pub fn sampled(&self, dt: f64) -> Result<SampledHubRig, DiscretiseError> {
        let discrete = zoh_ss(&self.state_space(), dt)?;
        Ok(SampledHubRig {
            phi: SMatrix::from_fn(|i, j| discrete.delta[(i, j)] + if i == j { 1.0 } else { 0.0 }),
            gamma: SVector::from_fn(|i, _| discrete.gamma[(i, 0)]),
            c: SMatrix::from_fn(|i, j| discrete.c[(i, j)]),
            x: SVector::zeros(),
            dt,
        })
    }
}

/// [`HubRig`] sampled with a zero-order hold: `x[k+1] = Φ x[k] + Γ F_c[k]`.
#[derive(Clone, Debug, PartialEq)]
pub struct SampledHubRig {
    phi: SMatrix<f64, STATES, STATES>,
    gamma: SVector<f64, STATES>,
    c: SMatrix<f64, 2, STATES>,
    x: SVector<f64, STATES>,
    dt: f64,
}

impl SampledHubRig {
    /// Sample period (s).
    pub fn dt(&self) -> f64 {
        self.dt
    }

    /// The state now (indices in [`state`], SI units).
    pub fn state(&self) -> &SVector<f64, STATES> {
        &self.x
    }

    /// Hub position `x_u` now (m).
    pub fn hub_position(&self) -> f64 {
        (self.c.row(output::HUB_POSITION) * self.x)[0]
    }

    /// Load-cell force `F` on the hub now (N).
    pub fn load_cell_force(&self) -> f64 {
        (self.c.row(output::LOAD_CELL_FORCE) * self.x)[0]
    }

    /// Advances one sample period with the force demand `force_demand` (N) held constant.
    pub fn hold(&mut self, force_demand: f64) {
        self.x = self.phi * self.x + self.gamma * force_demand;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mil_analysis::LinearActuator;
    use nalgebra::{Matrix2, SVector};
    use num_complex::Complex64;

    fn paper_rig() -> HubRig {
        HubRig {
            actuator: ServoHydraulicActuator::REFERENCE,
            car: QuarterCar {
                sprung_mass_kg: 150.0,
                suspension_stiffness: 120e3,
                suspension_damping: 2.5e3,
                unsprung_mass_kg: 20.0,
            },
        }
    }

    /// The state-space model, derived from the documented physics, gives the same hub
    /// position and load-cell force per force demand as the analysis' closed forms `p_f`,
    /// `r_f` coupled to the quarter car (`F = p_f F_c + r_f x_u`, `x_u = S F` with `S` the
    /// hub compliance of the car), with and without velocity feed-forward.
    #[test]
    fn physics_reproduces_the_actuator_transfer_functions() {
        for kappa in [1.0, 0.5, 0.0] {
            let mut rig = paper_rig();
            rig.actuator.velocity_feedforward = kappa;
            let ss = rig.state_space();
            let (p, r) = (
                rig.actuator.tracking().unwrap(),
                rig.actuator.disturbance().unwrap(),
            );
            let car = rig.car;
            for f in [0.3, 1.0, 4.0, 17.0, 60.0, 300.0] {
                let s = Complex64::new(0.0, TAU * f);
                let (k, c) = (car.suspension_stiffness, car.suspension_damping);
                let spring = c * s + k;
                let a_p = Matrix2::new(
                    car.sprung_mass_kg * s * s + spring,
                    -spring,
                    -spring,
                    car.unsprung_mass_kg * s * s + spring,
                );
                let compliance = a_p.try_inverse().unwrap()[(1, 1)];
                let (pf, rf) = (p.response(f), r.response(f));
                let force = pf / (1.0 - rf * compliance);
                let position = compliance * force;
                let h = ss.response(f).unwrap();
                for (got, want, what) in [
                    (h[(output::HUB_POSITION, 0)], position, "x_u/F_c"),
                    (h[(output::LOAD_CELL_FORCE, 0)], force, "F/F_c"),
                ] {
                    assert!(
                        (got - want).norm() <= 1e-9 * want.norm(),
                        "κ {kappa}, {f} Hz, {what}: {got} vs {want}"
                    );
                }
            }
        }
    }

    /// One held sample of the sampled rig equals a fine Runge–Kutta integration of the
    /// continuous model, from a non-zero state (the states span many decades of units: Pa
    /// next to m, so this also checks the matrix exponential's accuracy on them).
    #[test]
    fn sampling_is_exact() {
        let rig = paper_rig();
        let ss = rig.state_space();
        let dt = 5e-4;
        let mut sampled = rig.sampled(dt).unwrap();
        // A state of typical sizes: mm, cm/s, kPa-to-MPa, a partly open valve.
        let x0 = SVector::<f64, STATES>::from_column_slice(&[
            1e-3, -2e-2, 2e-3, 5e-2, 0.05, 3.0, 2.0e5, 1.0,
        ]);
        sampled.x = x0;
        let demand = 800.0;
        let mut x = DMatrix::from_column_slice(STATES, 1, x0.as_slice());
        let u = DMatrix::from_element(1, 1, demand);
        let rhs = |x: &DMatrix<f64>| &ss.a * x + &ss.b * &u;
        let steps = 2000;
        let h = dt / f64::from(steps);
        for _ in 0..steps {
            let k1 = rhs(&x);
            let k2 = rhs(&(&x + &k1 * (h / 2.0)));
            let k3 = rhs(&(&x + &k2 * (h / 2.0)));
            let k4 = rhs(&(&x + &k3 * h));
            x += (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (h / 6.0);
        }
        sampled.hold(demand);
        for i in 0..STATES {
            let scale = x0[i].abs().max(x[(i, 0)].abs());
            assert!(
                (sampled.state()[i] - x[(i, 0)]).abs() <= 1e-9 * scale,
                "state {i}: {} vs {}",
                sampled.state()[i],
                x[(i, 0)]
            );
        }
    }
}
