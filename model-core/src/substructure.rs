//! General linear mass-spring-damper substructure (up to [`MAX_DOF`] degrees of freedom), the
//! numerical part of any of the paper's four MiL configurations.
//!
//! # Model
//! Positions `x` (m, relative to the reference configuration), `n = dof` masses:
//!
//! ```text
//! M ẍ + C ẋ + K x = G_k z + G_c ż + f_interface
//! ```
//!
//! `M`, `C`, `K`: the network between the masses (and to fixed ground). `G_k`, `G_c`: springs
//! and dampers from mass `j` to the road input `z` of channel `ch`
//! (`ground_stiffness[j][ch]`, `ground_damping[j][ch]`); their stiffness and damping are added
//! to the diagonal of `K` and `C` automatically. Each actuator channel `ch` couples to one
//! interface DOF `d = interface[ch].dof`. Two causalities:
//!
//! - [`Causality::Admittance`] (measured interface force in, interface position demand out):
//!   `f_interface = -Qᵀ F̂_i`, demand `x_ni = Q x`. The interface masses are in the numerical
//!   model and the interface impedance `B_i` in the physical part (the paper's case 1 with
//!   position-controlled actuators).
//! - [`Causality::Impedance`] (measured interface position in, interface force demand out):
//!   the interface impedance `B_i = c_i s + k_i` is in the numerical model,
//!   `F_i = k_i (Q x - x̂_pi) + c_i (Q ẋ - ẋ̂_pi)`, `f_interface = -Qᵀ F_i`, demand `F_i` (the
//!   paper's case 4, force-controlled actuators; with no masses at all this reduces to the
//!   tyre's `F_i = -B_i x_pi + F_np` special case).
//!
//! Which causality each of the four configurations uses, and with which actuator, is set by
//! the loop analysis; the real-time part only needs these two forms. Velocities of measured
//! positions and road inputs come from [`crate::velocity`] estimators.
//!
//! # Integration
//! The trapezoidal rule (Tustin), applied to the first-order form `[x; ẋ]` and computed in
//! `f64` from the physical parameters whenever a parameter set is prepared (`O((2n)³)`, off the
//! step path): `Φ - I = T (I - AT/2)⁻¹ A`, `Γ = T (I - AT/2)⁻¹ B`, `C_d = C (I - AT/2)⁻¹`,
//! `D_d = D + C_d B T/2`. It is A-stable (every stable continuous system stays stable, for any
//! step), preserves the energy of undamped modes, and warps frequencies by
//! `ω_d = (2/T) atan(ωT/2)`: relative error `(ωT)²/12`, 5.3e-5 for a 20 Hz mode at 5 kHz (use a higher
//! rate or pre-warp the parameters where that matters).
//! A free mass (a pole at `s = 0`) is allowed: such models are stabilised by the loop.
//!
//! Damp every mode. An undamped mode maps to `|z| = 1` exactly in `f64`, but rounding the
//! coefficients to `f32` moves it by ~1e-11 either way, so an undamped model neither decays
//! nor stays bit-comparable with an `f64` run over minutes (the long-run drift test in
//! `tests/` shows this: with every mode damped, f32 stays within 1.1e-6 RMS of f64 over
//! 10 minutes at 5 kHz, flat).

use crate::controller::{Model, ModelInput};
use crate::linalg::Lu;
use crate::params::{check_all, Field, ParamError, Range};
use crate::velocity::{VelocityEstimator, VelocityFilterCoefficients};

/// Largest number of degrees of freedom of a substructure.
pub const MAX_DOF: usize = 6;
const MAX_STATES: usize = 2 * MAX_DOF;

/// Allowed entries of the mass matrix (kg).
pub const SUBSTRUCTURE_MASS: Range = Range::new(-1.0e6, 1.0e6);
/// Allowed entries of the damping matrix and interface/ground damping (N s/m).
pub const SUBSTRUCTURE_DAMPING: Range = Range::new(-1.0e7, 1.0e7);
/// Allowed entries of the stiffness matrix and interface/ground stiffness (N/m).
pub const SUBSTRUCTURE_STIFFNESS: Range = Range::new(-1.0e9, 1.0e9);

/// How the substructure connects to the actuators.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum Causality {
    /// Measured interface force (N) in, interface position demand (m) out.
    Admittance = 0,
    /// Measured interface position (m) in, interface force demand (N) out.
    Impedance = 1,
}

/// The coupling of one actuator channel to the substructure.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct InterfaceParams {
    /// Index of the interface degree of freedom, `0..dof`.
    pub dof: u32,
    /// Interface stiffness `k_i` (N/m); used by [`Causality::Impedance`].
    pub stiffness: f32,
    /// Interface damping `c_i` (N s/m); used by [`Causality::Impedance`].
    pub damping: f32,
}

/// Physical parameters of a substructure serving `CH` actuator channels.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct SubstructureParams<const CH: usize> {
    /// Number of degrees of freedom used, `1..=MAX_DOF`.
    pub dof: u32,
    /// [`Causality`] as its `u32` value (0 admittance, 1 impedance).
    pub causality: u32,
    /// Mass matrix `M` (kg; kg m² for rotations), symmetric positive definite on the used block.
    pub mass: [[f32; MAX_DOF]; MAX_DOF],
    /// Damping matrix `C` between masses and to fixed ground (N s/m).
    pub damping: [[f32; MAX_DOF]; MAX_DOF],
    /// Stiffness matrix `K` between masses and to fixed ground (N/m).
    pub stiffness: [[f32; MAX_DOF]; MAX_DOF],
    /// Spring from mass `j` to the road input of channel `ch`: `[j][ch]` (N/m).
    pub ground_stiffness: [[f32; CH]; MAX_DOF],
    /// Damper from mass `j` to the road input of channel `ch`: `[j][ch]` (N s/m).
    pub ground_damping: [[f32; CH]; MAX_DOF],
    /// Interface coupling per channel.
    pub interface: [InterfaceParams; CH],
    /// Cut-off of the velocity estimators' low-pass (Hz); 0: plain backward difference.
    pub velocity_cutoff_hz: f32,
}

impl<const CH: usize> SubstructureParams<CH> {
    /// All-zero parameters with `dof` degrees of freedom and the given causality; fill in the
    /// matrices before use.
    pub const fn zeroed(dof: u32, causality: Causality) -> Self {
        Self {
            dof,
            causality: causality as u32,
            mass: [[0.0; MAX_DOF]; MAX_DOF],
            damping: [[0.0; MAX_DOF]; MAX_DOF],
            stiffness: [[0.0; MAX_DOF]; MAX_DOF],
            ground_stiffness: [[0.0; CH]; MAX_DOF],
            ground_damping: [[0.0; CH]; MAX_DOF],
            interface: [InterfaceParams {
                dof: 0,
                stiffness: 0.0,
                damping: 0.0,
            }; CH],
            velocity_cutoff_hz: 0.0,
        }
    }

    /// The causality, if the selector is valid.
    pub fn causality(&self) -> Option<Causality> {
        match self.causality {
            0 => Some(Causality::Admittance),
            1 => Some(Causality::Impedance),
            _ => None,
        }
    }

    /// Validates ranges, sizes and a symmetric positive definite mass block.
    pub fn validate(&self) -> Result<(), ParamError> {
        let n = self.dof as usize;
        if !(1..=MAX_DOF).contains(&n) {
            return Err(ParamError::OutOfRange(Field::SubstructureDof));
        }
        if self.causality().is_none() {
            return Err(ParamError::OutOfRange(Field::SubstructureCausality));
        }
        for row in &self.mass {
            check_all(&SUBSTRUCTURE_MASS, Field::SubstructureMass, row)?;
        }
        for row in &self.damping {
            check_all(&SUBSTRUCTURE_DAMPING, Field::SubstructureDamping, row)?;
        }
        for row in &self.stiffness {
            check_all(&SUBSTRUCTURE_STIFFNESS, Field::SubstructureStiffness, row)?;
        }
        for row in &self.ground_stiffness {
            check_all(&SUBSTRUCTURE_STIFFNESS, Field::SubstructureGround, row)?;
        }
        for row in &self.ground_damping {
            check_all(&SUBSTRUCTURE_DAMPING, Field::SubstructureGround, row)?;
        }
        for i in &self.interface {
            SUBSTRUCTURE_STIFFNESS.check(Field::SubstructureInterface, i.stiffness)?;
            SUBSTRUCTURE_DAMPING.check(Field::SubstructureInterface, i.damping)?;
            if i.dof as usize >= n {
                return Err(ParamError::OutOfRange(Field::SubstructureInterface));
            }
        }
        crate::velocity::VELOCITY_CUTOFF.check(Field::VelocityCutoff, self.velocity_cutoff_hz)?;
        if !positive_definite(&self.mass, n) {
            return Err(ParamError::Inconsistent(Field::SubstructureMass));
        }
        Ok(())
    }
}

/// Symmetric (to 1e-6 relative) and positive definite (Cholesky succeeds) leading block.
#[allow(clippy::indexing_slicing, clippy::needless_range_loop)] // i, j, k < n <= MAX_DOF
fn positive_definite(m: &[[f32; MAX_DOF]; MAX_DOF], n: usize) -> bool {
    let n = n.min(MAX_DOF);
    let mut l = [[0.0f64; MAX_DOF]; MAX_DOF];
    for i in 0..n {
        for j in 0..n {
            let (a, b) = (f64::from(m[i][j]), f64::from(m[j][i]));
            if (a - b).abs() > 1e-6 * a.abs().max(b.abs()) {
                return false;
            }
        }
    }
    for j in 0..n {
        let mut d = f64::from(m[j][j]);
        for k in 0..j {
            d -= l[j][k] * l[j][k];
        }
        if d.is_nan() || d <= 0.0 {
            return false;
        }
        let d = libm::sqrt(d);
        l[j][j] = d;
        for i in (j + 1)..n {
            let mut s = f64::from(m[i][j]);
            for k in 0..j {
                s -= l[i][k] * l[j][k];
            }
            l[i][j] = s / d;
        }
    }
    true
}

/// Discrete (Tustin) coefficients of a substructure, derived from [`SubstructureParams`].
///
/// Inputs are grouped by kind, each one value per channel: the measured interface signal
/// (force for admittance, position for impedance), its velocity (impedance only), the road
/// input `z` and the road velocity `ż`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SubstructurePrepared<const CH: usize> {
    /// Number of states used (`2 · dof`).
    pub states: usize,
    /// Causality.
    pub causality: Causality,
    /// `Φ - I`.
    pub delta: [[f32; MAX_STATES]; MAX_STATES],
    /// `Γ` for the interface signal, `[state][channel]`.
    pub gamma_signal: [[f32; CH]; MAX_STATES],
    /// `Γ` for the interface signal's velocity.
    pub gamma_signal_rate: [[f32; CH]; MAX_STATES],
    /// `Γ` for the road input.
    pub gamma_road: [[f32; CH]; MAX_STATES],
    /// `Γ` for the road velocity.
    pub gamma_road_rate: [[f32; CH]; MAX_STATES],
    /// `C_d`, `[channel][state]`.
    pub c: [[f32; MAX_STATES]; CH],
    /// `D_d` for the interface signal, `[output channel][input channel]`.
    pub d_signal: [[f32; CH]; CH],
    /// `D_d` for the interface signal's velocity.
    pub d_signal_rate: [[f32; CH]; CH],
    /// `D_d` for the road input.
    pub d_road: [[f32; CH]; CH],
    /// `D_d` for the road velocity.
    pub d_road_rate: [[f32; CH]; CH],
    /// Velocity estimator coefficients.
    pub velocity: VelocityFilterCoefficients,
}

/// Continuous-time model in first-order form, `f64`, before discretisation.
#[allow(clippy::indexing_slicing, clippy::needless_range_loop)] // indices < 2·dof <= MAX_STATES
fn continuous<const CH: usize>(
    p: &SubstructureParams<CH>,
    causality: Causality,
) -> Result<Continuous<CH>, ParamError> {
    let n = (p.dof as usize).min(MAX_DOF);
    let ns = 2 * n;
    let f = |x: f32| f64::from(x);
    let mut k_eff = [[0.0f64; MAX_DOF]; MAX_DOF];
    let mut c_eff = [[0.0f64; MAX_DOF]; MAX_DOF];
    let mut mass = [[0.0f64; MAX_DOF]; MAX_DOF];
    for i in 0..n {
        for j in 0..n {
            k_eff[i][j] = f(p.stiffness[i][j]);
            c_eff[i][j] = f(p.damping[i][j]);
            mass[i][j] = f(p.mass[i][j]);
        }
        for ch in 0..CH {
            k_eff[i][i] += f(p.ground_stiffness[i][ch]);
            c_eff[i][i] += f(p.ground_damping[i][ch]);
        }
    }
    // Physical force per unit input, [dof][channel], for each input kind.
    let mut p_signal = [[0.0f64; CH]; MAX_DOF];
    let mut p_signal_rate = [[0.0f64; CH]; MAX_DOF];
    let mut p_road = [[0.0f64; CH]; MAX_DOF];
    let mut p_road_rate = [[0.0f64; CH]; MAX_DOF];
    let mut out = Continuous::<CH>::zero(ns);
    for ch in 0..CH {
        for j in 0..n {
            p_road[j][ch] = f(p.ground_stiffness[j][ch]);
            p_road_rate[j][ch] = f(p.ground_damping[j][ch]);
        }
        let iface = &p.interface[ch];
        let d = (iface.dof as usize).min(n.saturating_sub(1));
        match causality {
            Causality::Admittance => {
                p_signal[d][ch] = -1.0;
                out.c[ch][d] = 1.0;
            }
            Causality::Impedance => {
                let (ki, ci) = (f(iface.stiffness), f(iface.damping));
                k_eff[d][d] += ki;
                c_eff[d][d] += ci;
                p_signal[d][ch] = ki;
                p_signal_rate[d][ch] = ci;
                out.c[ch][d] = ki;
                out.c[ch][n + d] = ci;
                out.d_signal[ch][ch] = -ki;
                out.d_signal_rate[ch][ch] = -ci;
            }
        }
    }
    let lu_m = Lu::<MAX_DOF>::factor(&mass, n)
        .map_err(|_| ParamError::Inconsistent(Field::SubstructureMass))?;
    // A = [0 I; -M⁻¹K -M⁻¹C], B = [0; M⁻¹ P].
    for j in 0..n {
        out.a[j][n + j] = 1.0;
        let mut kc = [0.0f64; MAX_DOF];
        let mut cc = [0.0f64; MAX_DOF];
        for i in 0..n {
            kc[i] = k_eff[i][j];
            cc[i] = c_eff[i][j];
        }
        lu_m.solve(&mut kc);
        lu_m.solve(&mut cc);
        for i in 0..n {
            out.a[n + i][j] = -kc[i];
            out.a[n + i][n + j] = -cc[i];
        }
    }
    for ch in 0..CH {
        let kinds = [
            (&p_signal, &mut out.b_signal),
            (&p_signal_rate, &mut out.b_signal_rate),
            (&p_road, &mut out.b_road),
            (&p_road_rate, &mut out.b_road_rate),
        ];
        for (force, b) in kinds {
            let mut col = [0.0f64; MAX_DOF];
            for i in 0..n {
                col[i] = force[i][ch];
            }
            lu_m.solve(&mut col);
            for i in 0..n {
                b[n + i][ch] = col[i];
            }
        }
    }
    Ok(out)
}

struct Continuous<const CH: usize> {
    ns: usize,
    a: [[f64; MAX_STATES]; MAX_STATES],
    b_signal: [[f64; CH]; MAX_STATES],
    b_signal_rate: [[f64; CH]; MAX_STATES],
    b_road: [[f64; CH]; MAX_STATES],
    b_road_rate: [[f64; CH]; MAX_STATES],
    c: [[f64; MAX_STATES]; CH],
    d_signal: [[f64; CH]; CH],
    d_signal_rate: [[f64; CH]; CH],
}

impl<const CH: usize> Continuous<CH> {
    fn zero(ns: usize) -> Self {
        Self {
            ns,
            a: [[0.0; MAX_STATES]; MAX_STATES],
            b_signal: [[0.0; CH]; MAX_STATES],
            b_signal_rate: [[0.0; CH]; MAX_STATES],
            b_road: [[0.0; CH]; MAX_STATES],
            b_road_rate: [[0.0; CH]; MAX_STATES],
            c: [[0.0; MAX_STATES]; CH],
            d_signal: [[0.0; CH]; CH],
            d_signal_rate: [[0.0; CH]; CH],
        }
    }
}

/// Tustin discretisation of the continuous model (see the module docs).
#[allow(clippy::indexing_slicing, clippy::needless_range_loop)] // indices < ns <= MAX_STATES
fn tustin<const CH: usize>(
    m: &Continuous<CH>,
    dt: f64,
    causality: Causality,
    velocity: VelocityFilterCoefficients,
) -> Result<SubstructurePrepared<CH>, ParamError> {
    let ns = m.ns;
    let mut e = [[0.0f64; MAX_STATES]; MAX_STATES];
    for i in 0..ns {
        for j in 0..ns {
            e[i][j] = -0.5 * dt * m.a[i][j];
        }
        e[i][i] += 1.0;
    }
    let lu = Lu::<MAX_STATES>::factor(&e, ns)
        .map_err(|_| ParamError::Unstable(Field::SubstructureMass))?;
    let mut out = SubstructurePrepared::<CH> {
        states: ns,
        causality,
        delta: [[0.0; MAX_STATES]; MAX_STATES],
        gamma_signal: [[0.0; CH]; MAX_STATES],
        gamma_signal_rate: [[0.0; CH]; MAX_STATES],
        gamma_road: [[0.0; CH]; MAX_STATES],
        gamma_road_rate: [[0.0; CH]; MAX_STATES],
        c: [[0.0; MAX_STATES]; CH],
        d_signal: [[0.0; CH]; CH],
        d_signal_rate: [[0.0; CH]; CH],
        d_road: [[0.0; CH]; CH],
        d_road_rate: [[0.0; CH]; CH],
        velocity,
    };
    // Δ = T E⁻¹ A, column by column.
    for j in 0..ns {
        let mut col = [0.0f64; MAX_STATES];
        for i in 0..ns {
            col[i] = dt * m.a[i][j];
        }
        lu.solve(&mut col);
        for i in 0..ns {
            out.delta[i][j] = col[i] as f32;
        }
    }
    // C_d = C E⁻¹: rows from Eᵀ y = cᵀ.
    let mut cd = [[0.0f64; MAX_STATES]; CH];
    for ch in 0..CH {
        let mut row = m.c[ch];
        lu.solve_transposed(&mut row);
        cd[ch] = row;
        for i in 0..ns {
            out.c[ch][i] = row[i] as f32;
        }
    }
    // Γ = T E⁻¹ B and D_d = D + C_d B T/2 for each input kind.
    let zero = [[0.0f64; CH]; CH];
    let kinds = [
        (
            &m.b_signal,
            &m.d_signal,
            &mut out.gamma_signal,
            &mut out.d_signal,
        ),
        (
            &m.b_signal_rate,
            &m.d_signal_rate,
            &mut out.gamma_signal_rate,
            &mut out.d_signal_rate,
        ),
        (&m.b_road, &zero, &mut out.gamma_road, &mut out.d_road),
        (
            &m.b_road_rate,
            &zero,
            &mut out.gamma_road_rate,
            &mut out.d_road_rate,
        ),
    ];
    for (b, d, gamma, dd) in kinds {
        for ch in 0..CH {
            let mut col = [0.0f64; MAX_STATES];
            for i in 0..ns {
                col[i] = b[i][ch];
            }
            for o in 0..CH {
                let mut s = d[o][ch];
                for i in 0..ns {
                    s += cd[o][i] * col[i] * 0.5 * dt;
                }
                dd[o][ch] = s as f32;
            }
            for v in col.iter_mut() {
                *v *= dt;
            }
            lu.solve(&mut col);
            for i in 0..ns {
                gamma[i][ch] = col[i] as f32;
            }
        }
    }
    let finite = out.delta.iter().flatten().all(|v| v.is_finite())
        && out.c.iter().flatten().all(|v| v.is_finite())
        && [
            &out.gamma_signal,
            &out.gamma_signal_rate,
            &out.gamma_road,
            &out.gamma_road_rate,
        ]
        .iter()
        .all(|g| g.iter().flatten().all(|v| v.is_finite()))
        && [
            &out.d_signal,
            &out.d_signal_rate,
            &out.d_road,
            &out.d_road_rate,
        ]
        .iter()
        .all(|g| g.iter().flatten().all(|v| v.is_finite()));
    if finite {
        Ok(out)
    } else {
        Err(ParamError::NotFinite(Field::SubstructureStiffness))
    }
}

/// State of a substructure model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SubstructureModel<const CH: usize> {
    /// Discrete (Tustin) state; equals `[x; ẋ]` of the masses up to a feed-through term.
    pub state: [f32; MAX_STATES],
    signal_rate: [VelocityEstimator; CH],
    road_rate: [VelocityEstimator; CH],
}

#[inline]
fn mat_vec_acc<const R: usize, const C: usize>(
    acc: &mut [f32; R],
    m: &[[f32; C]; R],
    v: &[f32; C],
    rows: usize,
) {
    for (a, row) in acc.iter_mut().zip(m).take(rows) {
        *a += row.iter().zip(v).map(|(x, y)| x * y).sum::<f32>();
    }
}

impl<const CH: usize> Model<CH> for SubstructureModel<CH> {
    type Params = SubstructureParams<CH>;
    type Prepared = SubstructurePrepared<CH>;

    fn prepare(params: &Self::Params, dt: f32) -> Result<Self::Prepared, ParamError> {
        params.validate()?;
        let velocity = VelocityFilterCoefficients::new(params.velocity_cutoff_hz, dt)?;
        let causality = params
            .causality()
            .ok_or(ParamError::OutOfRange(Field::SubstructureCausality))?;
        let continuous = continuous(params, causality)?;
        tustin(&continuous, f64::from(dt), causality, velocity)
    }

    fn new() -> Self {
        Self {
            state: [0.0; MAX_STATES],
            signal_rate: [VelocityEstimator::new(); CH],
            road_rate: [VelocityEstimator::new(); CH],
        }
    }

    fn reset(&mut self, _prepared: &Self::Prepared, _input: &ModelInput<CH>) {
        *self = Self::new();
    }

    #[inline]
    fn step(&mut self, p: &Self::Prepared, input: &ModelInput<CH>) -> [f32; CH] {
        let signal = match p.causality {
            Causality::Admittance => input.force,
            Causality::Impedance => input.position,
        };
        let mut signal_rate = [0.0; CH];
        if p.causality == Causality::Impedance {
            for ((v, est), x) in signal_rate
                .iter_mut()
                .zip(self.signal_rate.iter_mut())
                .zip(&signal)
            {
                *v = est.step(&p.velocity, *x);
            }
        }
        let mut road_rate = [0.0; CH];
        for ((v, est), z) in road_rate
            .iter_mut()
            .zip(self.road_rate.iter_mut())
            .zip(&input.road)
        {
            *v = est.step(&p.velocity, *z);
        }
        let ns = p.states;
        // y = C_d ξ + Σ D u
        let mut y = [0.0; CH];
        mat_vec_acc(&mut y, &p.c, &self.state, CH);
        mat_vec_acc(&mut y, &p.d_signal, &signal, CH);
        mat_vec_acc(&mut y, &p.d_signal_rate, &signal_rate, CH);
        mat_vec_acc(&mut y, &p.d_road, &input.road, CH);
        mat_vec_acc(&mut y, &p.d_road_rate, &road_rate, CH);
        // ξ += Δ ξ + Σ Γ u
        let mut dx = [0.0; MAX_STATES];
        mat_vec_acc(&mut dx, &p.delta, &self.state, ns);
        mat_vec_acc(&mut dx, &p.gamma_signal, &signal, ns);
        mat_vec_acc(&mut dx, &p.gamma_signal_rate, &signal_rate, ns);
        mat_vec_acc(&mut dx, &p.gamma_road, &input.road, ns);
        mat_vec_acc(&mut dx, &p.gamma_road_rate, &road_rate, ns);
        for (x, d) in self.state.iter_mut().zip(dx) {
            *x += d;
        }
        y
    }

    fn is_finite(&self) -> bool {
        self.state.iter().all(|v| v.is_finite())
            && self.signal_rate.iter().all(VelocityEstimator::is_finite)
            && self.road_rate.iter().all(VelocityEstimator::is_finite)
    }
}
