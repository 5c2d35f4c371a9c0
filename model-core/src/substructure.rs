//! General linear mass-spring-damper substructure (up to [`MAX_DOF`] degrees of freedom), the
//! numerical part of any of the paper's four MiL configurations.
//!
//! # Model
//! Positions `x` (m, relative to the reference configuration), `n = dof` masses:
//!
//! ```text
//! M ẍ + C ẋ + K x = G_k z + G_c ż - Qᵀ F_i
//! ```
//!
//! `M`, `C`, `K`: the network between the masses (and to fixed ground). `G_k`, `G_c`: springs
//! and dampers from mass `j` to the road input `z` of channel `ch`
//! (`ground_stiffness[j][ch]`, `ground_damping[j][ch]`); their stiffness and damping are added
//! to the diagonal of `K` and `C` automatically. Each actuator channel `ch` couples to one
//! interface DOF `d = interface[ch].dof`; `F_i` is the interface force acting on the physical
//! part (the paper's sign convention, `A_n x_n = F_n - Q_nᵀ F_i`).
//!
//! # The four configurations ([`Causality`])
//! | paper case | interface impedance `B_i` | actuator | causality | measured in | demand out |
//! |---|---|---|---|---|---|
//! | 1 | physical | position | [`Causality::Admittance`] | `F̂_i` (N) | `x_ni = Q x` (m) |
//! | 2 | physical | force | [`Causality::PrescribedMotion`] | `x̂_ni` (m) | `F_i` (N) |
//! | 3 | numerical | position | [`Causality::AdmittanceThroughImpedance`] | `F̂_i` (N) | `x_pi` (m) |
//! | 4 | numerical | force | [`Causality::Impedance`] | `x̂_pi` (m) | `F_i` (N) |
//!
//! - **Admittance**: `F̂_i` drives the masses, the interface DOF's position is the demand.
//! - **AdmittanceThroughImpedance**: as admittance, and the demand is the position of the
//!   physical side of `B_i = c_i s + k_i`: `x_pi = Q x - B_i⁻¹ F̂_i` (one extra state per
//!   channel with `c_i > 0`; `x_pi = Q x - F̂_i / k_i` when `c_i = 0`).
//! - **Impedance**: `F_i = k_i (Q x - x̂_pi) + c_i (Q ẋ - ẋ̂_pi)` drives the masses and is the
//!   demand (with no masses this is the tyre's `F_i = -B_i x_pi + F_np`).
//! - **PrescribedMotion**: the measured motion is imposed on the interface DOFs; the free DOFs
//!   follow; the demand is the force the numerical part exerts on the rig at the interface,
//!   `F_i = F_n,I - (M ẍ + C ẋ + K x)_I`. Interface DOFs may be massless (the aero example's
//!   `F'_i = K_i x_pi + F_np` is this form with `M = 0`); an interface mass needs the measured
//!   acceleration, estimated here by differencing twice, which is noise-sensitive: keep
//!   interface masses small or filtered.
//!
//! Velocities and accelerations of measured positions and road inputs come from
//! [`crate::velocity`] estimators (backward differences with a low-pass).
//!
//! # Integration
//! The trapezoidal rule (Tustin), applied to the first-order form and computed in `f64` from
//! the physical parameters whenever a parameter set is prepared (`O(N³)`, off the step path):
//! `Φ - I = T (I - AT/2)⁻¹ A`, `Γ = T (I - AT/2)⁻¹ B`, `C_d = C (I - AT/2)⁻¹`,
//! `D_d = D + C_d B T/2`. It is A-stable (every stable continuous system stays stable, for any
//! step), preserves the energy of undamped modes, and warps frequencies by
//! `ω_d = (2/T) atan(ωT/2)`: relative error `(ωT)²/12`, 5.3e-5 for a 20 Hz mode at 5 kHz
//! (use a higher rate or pre-warp the parameters where that matters). A free mass (a pole at
//! `s = 0`) is allowed: such models are stabilised by the loop.
//!
//! Damp every mode. An undamped mode maps to `|z| = 1` exactly in `f64`, but rounding the
//! coefficients to `f32` moves it by ~1e-11 either way, so an undamped model neither decays
//! nor stays comparable with an `f64` run over minutes (the long-run drift test in `tests/`
//! shows this: with every mode damped, f32 stays within 1.1e-6 RMS of f64 over 10 minutes at
//! 5 kHz, flat).

use crate::controller::{Model, ModelInput};
use crate::linalg::Lu;
use crate::params::{check_all, Field, ParamError, Range};
use crate::velocity::{VelocityEstimator, VelocityFilterCoefficients};
use crate::MAX_CHANNELS;

/// Largest number of degrees of freedom of a substructure.
pub const MAX_DOF: usize = 6;
/// Largest number of discrete states: positions and velocities of every DOF plus one
/// interface-compliance state per channel.
pub const MAX_STATES: usize = 2 * MAX_DOF + MAX_CHANNELS;

/// Allowed entries of the mass matrix (kg).
pub const SUBSTRUCTURE_MASS: Range = Range::new(-1.0e6, 1.0e6);
/// Allowed entries of the damping matrix and interface/ground damping (N s/m).
pub const SUBSTRUCTURE_DAMPING: Range = Range::new(-1.0e7, 1.0e7);
/// Allowed entries of the stiffness matrix and interface/ground stiffness (N/m).
pub const SUBSTRUCTURE_STIFFNESS: Range = Range::new(-1.0e9, 1.0e9);

/// How the substructure connects to the actuators (see the module docs' table).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum Causality {
    /// Case 1: measured interface force (N) in, interface position demand (m) out.
    Admittance = 0,
    /// Case 4: measured interface position (m) in, force through the numerical `B_i` (N) out.
    Impedance = 1,
    /// Case 3: measured interface force (N) in, position of the physical side of the
    /// numerical `B_i` (m) out.
    AdmittanceThroughImpedance = 2,
    /// Case 2: measured interface position (m) imposed on the interface DOFs, the force the
    /// numerical part exerts there (N) out.
    PrescribedMotion = 3,
}

/// The coupling of one actuator channel to the substructure.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct InterfaceParams {
    /// Index of the interface degree of freedom, `0..dof`.
    pub dof: u32,
    /// Interface stiffness `k_i` (N/m); used when `B_i` is numerical (cases 3 and 4).
    pub stiffness: f32,
    /// Interface damping `c_i` (N s/m); used when `B_i` is numerical (cases 3 and 4).
    pub damping: f32,
}

/// Physical parameters of a substructure serving `CH` actuator channels.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct SubstructureParams<const CH: usize> {
    /// Number of degrees of freedom used, `1..=MAX_DOF`.
    pub dof: u32,
    /// [`Causality`] as its `u32` value.
    pub causality: u32,
    /// Mass matrix `M` (kg; kg m² for rotations), symmetric; positive definite on the used
    /// block (on the free DOFs for [`Causality::PrescribedMotion`]).
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
    /// Cut-off of the velocity (and acceleration) estimators' low-pass (Hz); 0: plain
    /// backward differences.
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
            2 => Some(Causality::AdmittanceThroughImpedance),
            3 => Some(Causality::PrescribedMotion),
            _ => None,
        }
    }

    /// Validates ranges, sizes, the interface definition and the mass matrix.
    pub fn validate(&self) -> Result<(), ParamError> {
        let n = self.dof as usize;
        if !(1..=MAX_DOF).contains(&n) {
            return Err(ParamError::OutOfRange(Field::SubstructureDof));
        }
        if CH > MAX_CHANNELS {
            return Err(ParamError::OutOfRange(Field::SubstructureInterface));
        }
        let causality = self
            .causality()
            .ok_or(ParamError::OutOfRange(Field::SubstructureCausality))?;
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
        let mut interface_dofs = [false; MAX_DOF];
        for i in &self.interface {
            SUBSTRUCTURE_STIFFNESS.check(Field::SubstructureInterface, i.stiffness)?;
            SUBSTRUCTURE_DAMPING.check(Field::SubstructureInterface, i.damping)?;
            let slot = interface_dofs
                .get_mut(i.dof as usize)
                .filter(|_| (i.dof as usize) < n)
                .ok_or(ParamError::OutOfRange(Field::SubstructureInterface))?;
            if causality == Causality::PrescribedMotion && *slot {
                // Two channels cannot impose the motion of the same DOF.
                return Err(ParamError::Inconsistent(Field::SubstructureInterface));
            }
            *slot = true;
            if causality == Causality::AdmittanceThroughImpedance
                && (i.stiffness < 0.0
                    || i.damping < 0.0
                    || (i.stiffness == 0.0 && i.damping == 0.0))
            {
                // B_i must be invertible: a rigid (zero) or active (negative) coupling is not.
                return Err(ParamError::Inconsistent(Field::SubstructureInterface));
            }
        }
        crate::velocity::VELOCITY_CUTOFF.check(Field::VelocityCutoff, self.velocity_cutoff_hz)?;
        let mut free = [true; MAX_DOF];
        if causality == Causality::PrescribedMotion {
            for (f, i) in free.iter_mut().zip(interface_dofs) {
                *f = !i;
            }
        }
        if !symmetric_positive_definite(&self.mass, n, &free) {
            return Err(ParamError::Inconsistent(Field::SubstructureMass));
        }
        Ok(())
    }
}

/// The mass block is symmetric (to 1e-6 relative) on the used DOFs, and positive definite
/// (Cholesky succeeds) on the DOFs marked in `block`.
#[allow(clippy::indexing_slicing, clippy::needless_range_loop)] // i, j, k < n <= MAX_DOF
fn symmetric_positive_definite(
    m: &[[f32; MAX_DOF]; MAX_DOF],
    n: usize,
    block: &[bool; MAX_DOF],
) -> bool {
    let n = n.min(MAX_DOF);
    for i in 0..n {
        for j in 0..n {
            let (a, b) = (f64::from(m[i][j]), f64::from(m[j][i]));
            if (a - b).abs() > 1e-6 * a.abs().max(b.abs()) {
                return false;
            }
        }
    }
    let mut idx = [0usize; MAX_DOF];
    let mut k = 0;
    for i in 0..n {
        if block[i] {
            idx[k] = i;
            k += 1;
        }
    }
    let mut l = [[0.0f64; MAX_DOF]; MAX_DOF];
    for j in 0..k {
        let mut d = f64::from(m[idx[j]][idx[j]]);
        for p in 0..j {
            d -= l[j][p] * l[j][p];
        }
        if d.is_nan() || d <= 0.0 {
            return false;
        }
        let d = libm::sqrt(d);
        l[j][j] = d;
        for i in (j + 1)..k {
            let mut s = f64::from(m[idx[i]][idx[j]]);
            for p in 0..j {
                s -= l[i][p] * l[j][p];
            }
            l[i][j] = s / d;
        }
    }
    true
}

/// Number of input kinds: each kind has one value per channel.
pub const INPUT_KINDS: usize = 5;
/// Input kind: the measured interface signal (force or position, per causality).
pub const SIGNAL: usize = 0;
/// Input kind: velocity of the measured interface position.
pub const SIGNAL_RATE: usize = 1;
/// Input kind: acceleration of the measured interface position.
pub const SIGNAL_ACCELERATION: usize = 2;
/// Input kind: road input `z`.
pub const ROAD: usize = 3;
/// Input kind: road velocity `ż`.
pub const ROAD_RATE: usize = 4;

/// Discrete (Tustin) coefficients of a substructure, derived from [`SubstructureParams`].
///
/// Inputs are grouped by kind ([`SIGNAL`], [`SIGNAL_RATE`], [`SIGNAL_ACCELERATION`], [`ROAD`],
/// [`ROAD_RATE`]), each one value per channel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SubstructurePrepared<const CH: usize> {
    /// Number of states used.
    pub states: usize,
    /// Causality.
    pub causality: Causality,
    /// `Φ - I` (leading `states × states` block used).
    pub delta: [[f32; MAX_STATES]; MAX_STATES],
    /// `Γ` per input kind, `[kind][state][channel]`.
    pub gamma: [[[f32; CH]; MAX_STATES]; INPUT_KINDS],
    /// `C_d`, `[channel][state]`.
    pub c: [[f32; MAX_STATES]; CH],
    /// `D_d` per input kind, `[kind][output channel][input channel]`.
    pub d: [[[f32; CH]; CH]; INPUT_KINDS],
    /// Velocity and acceleration estimator coefficients.
    pub velocity: VelocityFilterCoefficients,
}

/// Continuous-time model `ẋ = A x + Σ B_k u_k`, `y = C x + Σ D_k u_k` in `f64`.
struct Continuous<const CH: usize> {
    ns: usize,
    a: [[f64; MAX_STATES]; MAX_STATES],
    b: [[[f64; CH]; MAX_STATES]; INPUT_KINDS],
    c: [[f64; MAX_STATES]; CH],
    d: [[[f64; CH]; CH]; INPUT_KINDS],
}

impl<const CH: usize> Continuous<CH> {
    fn zero(ns: usize) -> Self {
        Self {
            ns,
            a: [[0.0; MAX_STATES]; MAX_STATES],
            b: [[[0.0; CH]; MAX_STATES]; INPUT_KINDS],
            c: [[0.0; MAX_STATES]; CH],
            d: [[[0.0; CH]; CH]; INPUT_KINDS],
        }
    }
}

/// The network in `f64` with ground connections folded into `K` and `C`.
struct Network<const CH: usize> {
    n: usize,
    m: [[f64; MAX_DOF]; MAX_DOF],
    c: [[f64; MAX_DOF]; MAX_DOF],
    k: [[f64; MAX_DOF]; MAX_DOF],
    gk: [[f64; CH]; MAX_DOF],
    gc: [[f64; CH]; MAX_DOF],
    iface: [usize; CH],
}

#[allow(clippy::indexing_slicing, clippy::needless_range_loop)] // indices < n <= MAX_DOF
fn network<const CH: usize>(p: &SubstructureParams<CH>) -> Network<CH> {
    let n = (p.dof as usize).min(MAX_DOF);
    let f = f64::from;
    let mut net = Network {
        n,
        m: [[0.0; MAX_DOF]; MAX_DOF],
        c: [[0.0; MAX_DOF]; MAX_DOF],
        k: [[0.0; MAX_DOF]; MAX_DOF],
        gk: [[0.0; CH]; MAX_DOF],
        gc: [[0.0; CH]; MAX_DOF],
        iface: [0; CH],
    };
    for i in 0..n {
        for j in 0..n {
            net.m[i][j] = f(p.mass[i][j]);
            net.c[i][j] = f(p.damping[i][j]);
            net.k[i][j] = f(p.stiffness[i][j]);
        }
        for ch in 0..CH {
            net.gk[i][ch] = f(p.ground_stiffness[i][ch]);
            net.gc[i][ch] = f(p.ground_damping[i][ch]);
            net.k[i][i] += net.gk[i][ch];
            net.c[i][i] += net.gc[i][ch];
        }
    }
    for ch in 0..CH {
        net.iface[ch] = (p.interface[ch].dof as usize).min(n.saturating_sub(1));
    }
    net
}

/// Fills the first-order model of the masses on the DOFs `dofs` (positions then velocities,
/// `2·len` states): `M_dd v̇ = -K_dd x - C_dd v + Σ_kind P_kind u_kind`, where `force[kind]`
/// gives the generalised force per unit input on every DOF. The acceleration rows of `A` and
/// `B` are left in `out` for callers that need `ẍ` in an output.
#[allow(clippy::indexing_slicing, clippy::needless_range_loop)] // indices < len <= MAX_DOF
fn masses<const CH: usize>(
    net: &Network<CH>,
    dofs: &[usize],
    force: &[[[f64; CH]; MAX_DOF]; INPUT_KINDS],
    out: &mut Continuous<CH>,
) -> Result<(), ParamError> {
    let len = dofs.len();
    let mut m = [[0.0f64; MAX_DOF]; MAX_DOF];
    for (a, &i) in dofs.iter().enumerate() {
        for (b, &j) in dofs.iter().enumerate() {
            m[a][b] = net.m[i][j];
        }
    }
    let lu = Lu::<MAX_DOF>::factor(&m, len)
        .map_err(|_| ParamError::Inconsistent(Field::SubstructureMass))?;
    for (b, &j) in dofs.iter().enumerate() {
        out.a[b][len + b] = 1.0;
        let mut kc = [0.0f64; MAX_DOF];
        let mut cc = [0.0f64; MAX_DOF];
        for (a, &i) in dofs.iter().enumerate() {
            kc[a] = net.k[i][j];
            cc[a] = net.c[i][j];
        }
        lu.solve(&mut kc);
        lu.solve(&mut cc);
        for a in 0..len {
            out.a[len + a][b] = -kc[a];
            out.a[len + a][len + b] = -cc[a];
        }
    }
    for kind in 0..INPUT_KINDS {
        for ch in 0..CH {
            let mut col = [0.0f64; MAX_DOF];
            for (a, &i) in dofs.iter().enumerate() {
                col[a] = force[kind][i][ch];
            }
            lu.solve(&mut col);
            for a in 0..len {
                out.b[kind][len + a][ch] = col[a];
            }
        }
    }
    Ok(())
}

/// Continuous-time model for the configured causality.
#[allow(clippy::indexing_slicing, clippy::needless_range_loop)] // indices bounded by n, CH, MAX_*
fn continuous<const CH: usize>(
    p: &SubstructureParams<CH>,
    causality: Causality,
) -> Result<Continuous<CH>, ParamError> {
    let net = network(p);
    let n = net.n;
    let all: [usize; MAX_DOF] = [0, 1, 2, 3, 4, 5];
    let mut force = [[[0.0f64; CH]; MAX_DOF]; INPUT_KINDS];
    for j in 0..n {
        for ch in 0..CH {
            force[ROAD][j][ch] = net.gk[j][ch];
            force[ROAD_RATE][j][ch] = net.gc[j][ch];
        }
    }
    match causality {
        Causality::Admittance | Causality::AdmittanceThroughImpedance => {
            // Compliance states e = B_i⁻¹ F̂_i for channels with c_i > 0.
            let mut compliance = [None; CH];
            let mut extra = 0;
            if causality == Causality::AdmittanceThroughImpedance {
                for ch in 0..CH {
                    if p.interface[ch].damping > 0.0 {
                        compliance[ch] = Some(2 * n + extra);
                        extra += 1;
                    }
                }
            }
            let mut out = Continuous::zero(2 * n + extra);
            for ch in 0..CH {
                force[SIGNAL][net.iface[ch]][ch] -= 1.0;
            }
            masses(&net, all.get(..n).unwrap_or(&[]), &force, &mut out)?;
            for ch in 0..CH {
                out.c[ch][net.iface[ch]] = 1.0;
                if causality == Causality::AdmittanceThroughImpedance {
                    let (ki, ci) = (
                        f64::from(p.interface[ch].stiffness),
                        f64::from(p.interface[ch].damping),
                    );
                    match compliance[ch] {
                        // c_i ė + k_i e = F̂: ė = (F̂ - k_i e)/c_i; x_pi = x_d - e.
                        Some(s) => {
                            out.a[s][s] = -ki / ci;
                            out.b[SIGNAL][s][ch] = 1.0 / ci;
                            out.c[ch][s] = -1.0;
                        }
                        None => out.d[SIGNAL][ch][ch] = -1.0 / ki,
                    }
                }
            }
            Ok(out)
        }
        Causality::Impedance => {
            let mut net = net;
            let mut out = Continuous::zero(2 * n);
            for ch in 0..CH {
                let d = net.iface[ch];
                let (ki, ci) = (
                    f64::from(p.interface[ch].stiffness),
                    f64::from(p.interface[ch].damping),
                );
                net.k[d][d] += ki;
                net.c[d][d] += ci;
                force[SIGNAL][d][ch] += ki;
                force[SIGNAL_RATE][d][ch] += ci;
                out.c[ch][d] += ki;
                out.c[ch][n + d] += ci;
                out.d[SIGNAL][ch][ch] -= ki;
                out.d[SIGNAL_RATE][ch][ch] -= ci;
            }
            masses(&net, all.get(..n).unwrap_or(&[]), &force, &mut out)?;
            Ok(out)
        }
        Causality::PrescribedMotion => {
            let mut is_iface = [false; MAX_DOF];
            for ch in 0..CH {
                is_iface[net.iface[ch]] = true;
            }
            let mut free = [0usize; MAX_DOF];
            let mut nf = 0;
            for j in 0..n {
                if !is_iface[j] {
                    free[nf] = j;
                    nf += 1;
                }
            }
            let free = free.get(..nf).unwrap_or(&[]);
            // Imposed interface motion acts on the free DOFs as a force.
            for ch in 0..CH {
                let d = net.iface[ch];
                for &j in free {
                    force[SIGNAL][j][ch] -= net.k[j][d];
                    force[SIGNAL_RATE][j][ch] -= net.c[j][d];
                    force[SIGNAL_ACCELERATION][j][ch] -= net.m[j][d];
                }
            }
            let mut out = Continuous::zero(2 * nf);
            masses(&net, free, &force, &mut out)?;
            // F_i = F_n,d - (M ẍ + C ẋ + K x)_d, with ẍ_F from the free DOFs' own equations.
            for ch in 0..CH {
                let d = net.iface[ch];
                for (a, &j) in free.iter().enumerate() {
                    out.c[ch][a] -= net.k[d][j];
                    out.c[ch][nf + a] -= net.c[d][j];
                    let md = net.m[d][j];
                    for s in 0..2 * nf {
                        out.c[ch][s] -= md * out.a[nf + a][s];
                    }
                    for kind in 0..INPUT_KINDS {
                        for i in 0..CH {
                            out.d[kind][ch][i] -= md * out.b[kind][nf + a][i];
                        }
                    }
                }
                for i in 0..CH {
                    let di = net.iface[i];
                    out.d[SIGNAL][ch][i] -= net.k[d][di];
                    out.d[SIGNAL_RATE][ch][i] -= net.c[d][di];
                    out.d[SIGNAL_ACCELERATION][ch][i] -= net.m[d][di];
                    out.d[ROAD][ch][i] += net.gk[d][i];
                    out.d[ROAD_RATE][ch][i] += net.gc[d][i];
                }
            }
            Ok(out)
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
        gamma: [[[0.0; CH]; MAX_STATES]; INPUT_KINDS],
        c: [[0.0; MAX_STATES]; CH],
        d: [[[0.0; CH]; CH]; INPUT_KINDS],
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
    for kind in 0..INPUT_KINDS {
        for ch in 0..CH {
            let mut col = [0.0f64; MAX_STATES];
            for i in 0..ns {
                col[i] = m.b[kind][i][ch];
            }
            for o in 0..CH {
                let mut s = m.d[kind][o][ch];
                for i in 0..ns {
                    s += cd[o][i] * col[i] * 0.5 * dt;
                }
                out.d[kind][o][ch] = s as f32;
            }
            for v in col.iter_mut() {
                *v *= dt;
            }
            lu.solve(&mut col);
            for i in 0..ns {
                out.gamma[kind][i][ch] = col[i] as f32;
            }
        }
    }
    let finite = out.delta.iter().flatten().all(|v| v.is_finite())
        && out.c.iter().flatten().all(|v| v.is_finite())
        && out.gamma.iter().flatten().flatten().all(|v| v.is_finite())
        && out.d.iter().flatten().flatten().all(|v| v.is_finite());
    if finite {
        Ok(out)
    } else {
        Err(ParamError::NotFinite(Field::SubstructureStiffness))
    }
}

/// State of a substructure model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SubstructureModel<const CH: usize> {
    /// Discrete (Tustin) state: `[x; ẋ]` of the (free) masses and the interface compliance
    /// states, up to a feed-through term.
    pub state: [f32; MAX_STATES],
    signal_rate: [VelocityEstimator; CH],
    signal_acceleration: [VelocityEstimator; CH],
    road_rate: [VelocityEstimator; CH],
}

/// `acc[r] += Σ_c m[r][c] v[c]` for the leading `rows × cols` block.
#[inline]
fn mat_vec_acc<const R: usize, const C: usize>(
    acc: &mut [f32; R],
    m: &[[f32; C]; R],
    v: &[f32; C],
    rows: usize,
    cols: usize,
) {
    for (a, row) in acc.iter_mut().zip(m).take(rows) {
        *a += row
            .iter()
            .zip(v)
            .take(cols)
            .map(|(x, y)| x * y)
            .sum::<f32>();
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
            signal_acceleration: [VelocityEstimator::new(); CH],
            road_rate: [VelocityEstimator::new(); CH],
        }
    }

    fn reset(&mut self, _prepared: &Self::Prepared, _input: &ModelInput<CH>) {
        *self = Self::new();
    }

    #[inline]
    fn step(&mut self, p: &Self::Prepared, input: &ModelInput<CH>) -> [f32; CH] {
        let mut u = [[0.0f32; CH]; INPUT_KINDS];
        let measured_position = matches!(
            p.causality,
            Causality::Impedance | Causality::PrescribedMotion
        );
        let [signal, signal_rate, signal_acceleration, road, road_rate] = &mut u;
        *signal = if measured_position {
            input.position
        } else {
            input.force
        };
        *road = input.road;
        if measured_position {
            for ((((v, a), est_v), est_a), x) in signal_rate
                .iter_mut()
                .zip(signal_acceleration.iter_mut())
                .zip(self.signal_rate.iter_mut())
                .zip(self.signal_acceleration.iter_mut())
                .zip(signal.iter())
            {
                *v = est_v.step(&p.velocity, *x);
                *a = est_a.step(&p.velocity, *v);
            }
        }
        for ((v, est), z) in road_rate
            .iter_mut()
            .zip(self.road_rate.iter_mut())
            .zip(road.iter())
        {
            *v = est.step(&p.velocity, *z);
        }
        let ns = p.states;
        // y = C_d ξ + Σ D u ;  ξ += Δ ξ + Σ Γ u
        let mut y = [0.0; CH];
        mat_vec_acc(&mut y, &p.c, &self.state, CH, ns);
        let mut dx = [0.0; MAX_STATES];
        mat_vec_acc(&mut dx, &p.delta, &self.state, ns, ns);
        for ((d, gamma), uk) in p.d.iter().zip(&p.gamma).zip(&u) {
            mat_vec_acc(&mut y, d, uk, CH, CH);
            mat_vec_acc(&mut dx, gamma, uk, ns, CH);
        }
        for (x, d) in self.state.iter_mut().zip(dx) {
            *x += d;
        }
        y
    }

    fn is_finite(&self) -> bool {
        // Branch-free: NaN and infinities propagate through the sum.
        let states: f32 = self.state.iter().sum();
        (states
            + self
                .signal_rate
                .iter()
                .chain(&self.signal_acceleration)
                .chain(&self.road_rate)
                .map(VelocityEstimator::sum)
                .sum::<f32>())
        .is_finite()
    }
}
