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
//! # Nonlinear elements
//! Up to [`MAX_ELEMENTS`] elements ([`SubstructureElement`]) add the effects `mil diagnose`
//! names on elements and the board can run (cubic stiffness, bump and rebound stops,
//! lift-off, quadratic and asymmetric damping, smoothed dry friction: the laws of
//! [`crate::element`]). Element `e` has compression `x_e = a_e·x + b_e·z`, rate
//! `v_e = a_e·ẋ + b_e·ż` and force `F_e(x_e, v_e)`, which acts on the DOFs as `−a_e F_e`.
//! The force splits into a linear part `k x_e + c̄ v_e` (the law's stiffness and mean
//! damping `c̄ = (c_bump + c_rebound)/2`), which joins `K` and `C` and is integrated by
//! Tustin with the network, and a remainder `r_e = F_e − k x_e − c̄ v_e`, a generalised
//! force input evaluated once per sample (IMEX: implicit trapezoidal for the linear
//! network, explicit for the remainder):
//!
//! ```text
//! m_k = C_e,d ξ_k + Σ D_e,d u_k + D_e,r r_(k−1)     element motion (x_e, v_e) at sample k
//! r_k = F(m_k) − k x_e − c̄ v_e
//! y_k = C_d ξ_k + Σ D_d u_k + D_r,d r_k
//! ξ_(k+1) = ξ_k + Δ ξ_k + Σ Γ u_k + Γ_r r_k
//! ```
//!
//! The motion's own dependence on this sample's remainder (`D_e,r`, of order `T²/m` on the
//! compression and `T/m` on the rate) takes the previous sample's remainder, so one law
//! evaluation per element and sample suffices: the cost is fixed (no iteration). The scheme
//! is first order in the remainder; with the remainder zero (linear elements) it is the
//! network's Tustin exactly.
//!
//! Stability: an explicit term of stiffness `k_x` and damping `c_x` on an effective mass
//! `m_e = 1/(aᵀ M⁻¹ a)` is stable at step `T` while `k_x T²/m_e` and `c_x T/m_e` stay
//! small; preparing a parameter set refuses ([`ParamError::Unstable`] of
//! [`Field::SubstructureElement`]) an element whose bounded explicit part exceeds 1 in
//! either: the stops' stiffness, half the damping asymmetry, the friction's slope at rest
//! `F_c/v_eps`, and with lift-off the linear part the lifted element cancels. The cubic
//! stiffness and quadratic damping have slopes `3 k3 x²` and `2 c2 |v|` that grow without
//! bound: they stay stable while `3 |k3| x² T²/m_e` and `2 c2 |v| T/m_e` stay below 1 (at
//! 2 kHz, a 40 kg mass with `k3 = 1e9 N/m³`: up to 0.23 m, far beyond any stroke); beyond,
//! the state grows, the demand limits hold the demand and a non-finite state latches the
//! controller's fault.
//!
//! Accuracy (the workspace's `tests/substructure_elements.rs`): the 2-DOF example's mass on
//! a car-like suspension with stops engaged two thirds of the time, a cubic spring,
//! asymmetric damping and friction, driven by measured position and road at 2 kHz, gives
//! an interface force within 1 % RMS (2 % of the peak at worst) of the structure's `f64`
//! RK4 simulation; the effects add at most 0.5 percentage points to the linear scheme's
//! difference, which is mostly the causal backward-difference road rate.
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
use crate::element::ElementLaw;
use crate::linalg::Lu;
use crate::params::{check_all, Field, ParamError, Range};
use crate::velocity::{VelocityEstimator, VelocityFilterCoefficients};

/// Largest number of degrees of freedom of a substructure.
pub const MAX_DOF: usize = 6;
/// Most actuator channels a substructure serves (the board's: a hub-coupled rig's four
/// hubs). Fewer than a controller's [`crate::MAX_CHANNELS`]: every state costs the board
/// RAM in each copy of the coefficients and in the `f64` preparation.
pub const MAX_SUBSTRUCTURE_CHANNELS: usize = 4;
/// Largest number of discrete states: positions and velocities of every DOF plus one
/// interface-compliance state per channel.
pub const MAX_STATES: usize = 2 * MAX_DOF + MAX_SUBSTRUCTURE_CHANNELS;

/// Largest number of nonlinear elements of a substructure.
pub const MAX_ELEMENTS: usize = 6;
/// Rows of the element motion: compression and compression rate of each element.
const ELEMENT_OUTPUTS: usize = 2 * MAX_ELEMENTS;
/// Allowed compression per unit of a DOF or road input (m/m; m/rad for rotations: a lever
/// arm).
pub const ELEMENT_COEFFICIENT: Range = Range::new(-100.0, 100.0);

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
    /// Index of the interface degree of freedom, `0..dof`, or [`UNCONNECTED`]: the channel
    /// does not couple (its measurement is ignored, its demand is zero).
    pub dof: u32,
    /// Interface stiffness `k_i` (N/m); used when `B_i` is numerical (cases 3 and 4).
    pub stiffness: f32,
    /// Interface damping `c_i` (N s/m); used when `B_i` is numerical (cases 3 and 4).
    pub damping: f32,
}

/// [`InterfaceParams::dof`] of a channel that does not couple to the substructure (a board
/// configuration with fewer channels than the model's width).
pub const UNCONNECTED: u32 = u32::MAX;

impl InterfaceParams {
    /// A channel that does not couple.
    pub const NONE: Self = Self {
        dof: UNCONNECTED,
        stiffness: 0.0,
        damping: 0.0,
    };

    /// `true` when the channel couples to a DOF.
    pub const fn connected(&self) -> bool {
        self.dof != UNCONNECTED
    }
}

/// A nonlinear element of the substructure (see the module docs' *Nonlinear elements*): a
/// spring-damper with law [`ElementLaw`] whose compression is
/// `x_e = Σ_j a_j x_j + Σ_ch b_ch z_ch` over the DOFs and the channels' road inputs; its
/// force `F_e` acts on the DOFs as the generalised force `−a F_e`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct SubstructureElement<const CH: usize> {
    /// Compression per unit of each DOF `a_j` (m/m, m/rad); zero beyond the used DOFs.
    pub dof_coefficients: [f32; MAX_DOF],
    /// Compression per unit of each channel's road input `b_ch` (m/m).
    pub road_coefficients: [f32; CH],
    /// The force law.
    pub law: ElementLaw,
}

impl<const CH: usize> SubstructureElement<CH> {
    /// No element: no coefficients, no force.
    pub const NONE: Self = Self {
        dof_coefficients: [0.0; MAX_DOF],
        road_coefficients: [0.0; CH],
        law: ElementLaw::NONE,
    };
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
    /// Number of nonlinear elements used, `0..=MAX_ELEMENTS`.
    pub element_count: u32,
    /// The nonlinear elements (the first `element_count` used); their linear part is added
    /// to `K` and `C` by the model, so it is not in `stiffness` and `damping`.
    pub elements: [SubstructureElement<CH>; MAX_ELEMENTS],
}

impl<const CH: usize> SubstructureParams<CH> {
    /// As [`SubstructureParams::zeroed`] with `dof` 0, [`Causality::Admittance`] and
    /// [`ElementLaw::ZERO`] laws: every field zero bits (not a valid set), a place holder.
    pub const ZERO: Self = Self {
        elements: [SubstructureElement {
            law: ElementLaw::ZERO,
            ..SubstructureElement::NONE
        }; MAX_ELEMENTS],
        ..Self::zeroed(0, Causality::Admittance)
    };

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
            element_count: 0,
            elements: [SubstructureElement::NONE; MAX_ELEMENTS],
        }
    }

    /// The same substructure serving the first `C2` channels (channels beyond `CH` get no
    /// couplings and are [`UNCONNECTED`]).
    pub fn first_channels<const C2: usize>(&self) -> SubstructureParams<C2> {
        let mut out = SubstructureParams::<C2>::zeroed(self.dof, Causality::Impedance);
        out.causality = self.causality;
        out.mass = self.mass;
        out.damping = self.damping;
        out.stiffness = self.stiffness;
        out.velocity_cutoff_hz = self.velocity_cutoff_hz;
        out.element_count = self.element_count;
        use crate::controller::fit;
        for (to, from) in out.ground_stiffness.iter_mut().zip(&self.ground_stiffness) {
            *to = fit(from, 0.0);
        }
        for (to, from) in out.ground_damping.iter_mut().zip(&self.ground_damping) {
            *to = fit(from, 0.0);
        }
        out.interface = fit(&self.interface, InterfaceParams::NONE);
        for (to, from) in out.elements.iter_mut().zip(&self.elements) {
            to.dof_coefficients = from.dof_coefficients;
            to.law = from.law;
            to.road_coefficients = fit(&from.road_coefficients, 0.0);
        }
        out
    }

    /// The elements used.
    pub fn used_elements(&self) -> &[SubstructureElement<CH>] {
        self.elements
            .get(..self.element_count as usize)
            .unwrap_or(&self.elements)
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
        if CH > MAX_SUBSTRUCTURE_CHANNELS {
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
            if !i.connected() {
                continue;
            }
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
        if !self.interface.iter().any(InterfaceParams::connected) {
            // Coupled to no actuator: nothing to measure, nothing to demand.
            return Err(ParamError::Inconsistent(Field::SubstructureInterface));
        }
        crate::velocity::VELOCITY_CUTOFF.check(Field::VelocityCutoff, self.velocity_cutoff_hz)?;
        if self.element_count as usize > MAX_ELEMENTS {
            return Err(ParamError::OutOfRange(Field::SubstructureElement));
        }
        for e in self.used_elements() {
            e.law.validate()?;
            check_all(
                &ELEMENT_COEFFICIENT,
                Field::SubstructureElement,
                &e.dof_coefficients,
            )?;
            check_all(
                &ELEMENT_COEFFICIENT,
                Field::SubstructureElement,
                &e.road_coefficients,
            )?;
            if e.dof_coefficients.iter().skip(n).any(|&a| a != 0.0) {
                // A compression along a DOF the model does not have.
                return Err(ParamError::Inconsistent(Field::SubstructureElement));
            }
        }
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
    /// Number of nonlinear elements.
    pub elements: usize,
    /// Their laws.
    pub laws: [ElementLaw; MAX_ELEMENTS],
    /// Their linear parts (stiffness, mean damping), integrated with the network.
    pub linear: [[f32; 2]; MAX_ELEMENTS],
    /// `Γ_r`: the state update per unit remainder, `[state][element]`.
    pub gamma_r: [[f32; MAX_ELEMENTS]; MAX_STATES],
    /// `D_r`: the output per unit remainder, `[channel][element]`.
    pub d_r: [[f32; MAX_ELEMENTS]; CH],
    /// `C_e`: the element motion (compression, rate of each element) per state.
    pub c_e: [[f32; MAX_STATES]; ELEMENT_OUTPUTS],
    /// `D_e` per input kind, `[kind][motion][channel]`.
    pub d_e: [[[f32; CH]; ELEMENT_OUTPUTS]; INPUT_KINDS],
    /// `D_e,r`: the element motion per unit remainder (applied to the previous sample's).
    pub d_er: [[f32; MAX_ELEMENTS]; ELEMENT_OUTPUTS],
}

impl<const CH: usize> SubstructurePrepared<CH> {
    /// All coefficients zero (no states), every field zero bits (the discriminant-0
    /// causality, no law): a place to prepare into.
    pub const ZERO: Self = Self {
        states: 0,
        causality: Causality::Admittance,
        delta: [[0.0; MAX_STATES]; MAX_STATES],
        gamma: [[[0.0; CH]; MAX_STATES]; INPUT_KINDS],
        c: [[0.0; MAX_STATES]; CH],
        d: [[[0.0; CH]; CH]; INPUT_KINDS],
        velocity: VelocityFilterCoefficients {
            inv_dt: 0.0,
            gain: 0.0,
        },
        elements: 0,
        laws: [ElementLaw::ZERO; MAX_ELEMENTS],
        linear: [[0.0; 2]; MAX_ELEMENTS],
        gamma_r: [[0.0; MAX_ELEMENTS]; MAX_STATES],
        d_r: [[0.0; MAX_ELEMENTS]; CH],
        c_e: [[0.0; MAX_STATES]; ELEMENT_OUTPUTS],
        d_e: [[[0.0; CH]; ELEMENT_OUTPUTS]; INPUT_KINDS],
        d_er: [[0.0; MAX_ELEMENTS]; ELEMENT_OUTPUTS],
    };

    /// Back to [`Self::ZERO`], in place (no kilobyte temporary).
    fn clear(&mut self) {
        self.states = 0;
        self.elements = 0;
        self.delta.iter_mut().for_each(|r| r.fill(0.0));
        self.gamma.iter_mut().flatten().for_each(|r| r.fill(0.0));
        self.c.iter_mut().for_each(|r| r.fill(0.0));
        self.d.iter_mut().flatten().for_each(|r| r.fill(0.0));
        self.laws.fill(ElementLaw::NONE);
        self.linear.fill([0.0; 2]);
        self.gamma_r.iter_mut().for_each(|r| r.fill(0.0));
        self.d_r.iter_mut().for_each(|r| r.fill(0.0));
        self.c_e.iter_mut().for_each(|r| r.fill(0.0));
        self.d_e.iter_mut().flatten().for_each(|r| r.fill(0.0));
        self.d_er.iter_mut().for_each(|r| r.fill(0.0));
    }
}

/// Continuous-time model `ẋ = A x + Σ B_k u_k + B_r r`, `y = C x + Σ D_k u_k + D_r r` in
/// `f64`, with the elements' remainders `r` as inputs and their motion
/// `m = C_e x + Σ D_e,k u_k` as further outputs.
struct Continuous<const CH: usize> {
    ns: usize,
    a: [[f64; MAX_STATES]; MAX_STATES],
    b: [[[f64; CH]; MAX_STATES]; INPUT_KINDS],
    c: [[f64; MAX_STATES]; CH],
    d: [[[f64; CH]; CH]; INPUT_KINDS],
    br: [[f64; MAX_ELEMENTS]; MAX_STATES],
    dr: [[f64; MAX_ELEMENTS]; CH],
    ce: [[f64; MAX_STATES]; ELEMENT_OUTPUTS],
    de: [[[f64; CH]; ELEMENT_OUTPUTS]; INPUT_KINDS],
}

impl<const CH: usize> Continuous<CH> {
    /// Back to all zeros with `ns` states, in place (no kilobyte temporary).
    fn reset(&mut self, ns: usize) {
        self.ns = ns;
        self.a.iter_mut().for_each(|r| r.fill(0.0));
        self.b.iter_mut().flatten().for_each(|r| r.fill(0.0));
        self.c.iter_mut().for_each(|r| r.fill(0.0));
        self.d.iter_mut().flatten().for_each(|r| r.fill(0.0));
        self.br.iter_mut().for_each(|r| r.fill(0.0));
        self.dr.iter_mut().for_each(|r| r.fill(0.0));
        self.ce.iter_mut().for_each(|r| r.fill(0.0));
        self.de.iter_mut().flatten().for_each(|r| r.fill(0.0));
    }

    fn zero(ns: usize) -> Self {
        Self {
            ns,
            a: [[0.0; MAX_STATES]; MAX_STATES],
            b: [[[0.0; CH]; MAX_STATES]; INPUT_KINDS],
            c: [[0.0; MAX_STATES]; CH],
            d: [[[0.0; CH]; CH]; INPUT_KINDS],
            br: [[0.0; MAX_ELEMENTS]; MAX_STATES],
            dr: [[0.0; MAX_ELEMENTS]; CH],
            ce: [[0.0; MAX_STATES]; ELEMENT_OUTPUTS],
            de: [[[0.0; CH]; ELEMENT_OUTPUTS]; INPUT_KINDS],
        }
    }
}

/// The network in `f64` with ground connections and the elements' linear parts folded into
/// `K` and `C`; `gk`, `gc`: generalised force on each DOF per unit road input and road rate.
struct Network<const CH: usize> {
    n: usize,
    m: [[f64; MAX_DOF]; MAX_DOF],
    c: [[f64; MAX_DOF]; MAX_DOF],
    k: [[f64; MAX_DOF]; MAX_DOF],
    gk: [[f64; CH]; MAX_DOF],
    gc: [[f64; CH]; MAX_DOF],
    /// Interface DOF per channel, `None` for an unconnected channel.
    iface: [Option<usize>; CH],
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
        iface: [None; CH],
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
    // The elements' linear parts: K += k a aᵀ, C += c̄ a aᵀ, road forcing −k a b, −c̄ a b.
    for e in p.used_elements() {
        let (k, c) = linear_part(&e.law);
        let (k, c) = (f(k), f(c));
        for i in 0..n {
            let ai = f(e.dof_coefficients[i]);
            for j in 0..n {
                let aa = ai * f(e.dof_coefficients[j]);
                net.k[i][j] += k * aa;
                net.c[i][j] += c * aa;
            }
            for ch in 0..CH {
                let ab = ai * f(e.road_coefficients[ch]);
                net.gk[i][ch] -= k * ab;
                net.gc[i][ch] -= c * ab;
            }
        }
    }
    for ch in 0..CH {
        let i = &p.interface[ch];
        net.iface[ch] = i
            .connected()
            .then(|| (i.dof as usize).min(n.saturating_sub(1)));
    }
    net
}

/// The part of an element's law integrated with the linear network (Tustin): its stiffness
/// and mean damping `(c_bump + c_rebound) / 2`.
fn linear_part(law: &ElementLaw) -> (f32, f32) {
    (
        law.stiffness,
        0.5 * (law.bump_damping + law.rebound_damping),
    )
}

/// Fills the first-order model of the masses on the DOFs `dofs` (positions then velocities,
/// `2·len` states): `M_dd v̇ = -K_dd x - C_dd v + Σ_kind P_kind u_kind - Σ_e a_e r_e`, where
/// `force[kind]` gives the generalised force per unit input on every DOF and `a_e` an
/// element's compression per DOF. The acceleration rows of `A`, `B` and `B_r` are left in
/// `out` for callers that need `ẍ` in an output. Checks each element's explicit part
/// against the step `dt` (see the module docs' *Nonlinear elements*).
#[allow(clippy::indexing_slicing, clippy::needless_range_loop)] // indices < len <= MAX_DOF
fn masses<const CH: usize>(
    net: &Network<CH>,
    elements: &[SubstructureElement<CH>],
    dt: f64,
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
    for (e, element) in elements.iter().enumerate().take(MAX_ELEMENTS) {
        let mut col = [0.0f64; MAX_DOF];
        for (a, &i) in dofs.iter().enumerate() {
            col[a] = -f64::from(element.dof_coefficients[i]);
        }
        let mut w = col;
        lu.solve(&mut w);
        // aᵀ M⁻¹ a: the inverse of the element's effective mass on these DOFs.
        let inverse_mass: f64 = col.iter().zip(&w).map(|(a, w)| a * w).sum::<f64>();
        let (stiffness, damping) = explicit_part(&element.law);
        if stiffness * dt * dt * inverse_mass > 1.0 || damping * dt * inverse_mass > 1.0 {
            return Err(ParamError::Unstable(Field::SubstructureElement));
        }
        for a in 0..len {
            out.br[len + a][e] = w[a];
        }
    }
    Ok(())
}

/// The largest stiffness (N/m) and damping (N s/m) an element's law adds explicitly to its
/// linear part, bounded over every state: the stops' stiffness, the damping asymmetry, the
/// friction's slope at rest, and with lift-off the linear part itself (which the lifted
/// element cancels). The cubic and quadratic terms' slopes grow without bound and are not
/// included (see the module docs).
fn explicit_part(law: &ElementLaw) -> (f64, f64) {
    let f = f64::from;
    let lift = if law.lift_off != 0 { 1.0 } else { 0.0 };
    let (k, c) = linear_part(law);
    let stops = f(law.bump_stiffness).max(f(law.rebound_stiffness));
    let friction = if law.friction_force > 0.0 {
        f(law.friction_force) / f(law.friction_velocity)
    } else {
        0.0
    };
    (
        stops + lift * f(k),
        0.5 * (f(law.bump_damping) - f(law.rebound_damping)).abs() + friction + lift * f(c),
    )
}

/// The element motion rows: compression `a·x + b·z` and rate `a·ẋ + b·ż`, with `state(j)`
/// the position and velocity states of DOF `j`, or `None` for an interface DOF whose
/// motion is the measured signal of the channel imposing it.
#[allow(clippy::indexing_slicing, clippy::needless_range_loop)] // indices < n, CH, MAX_*
fn element_motion<const CH: usize>(
    net: &Network<CH>,
    elements: &[SubstructureElement<CH>],
    state: impl Fn(usize) -> Option<(usize, usize)>,
    out: &mut Continuous<CH>,
) {
    for (e, element) in elements.iter().enumerate().take(MAX_ELEMENTS) {
        let (x, v) = (2 * e, 2 * e + 1);
        for j in 0..net.n {
            let a = f64::from(element.dof_coefficients[j]);
            match state(j) {
                Some((position, velocity)) => {
                    out.ce[x][position] += a;
                    out.ce[v][velocity] += a;
                }
                None => {
                    for ch in 0..CH {
                        if net.iface[ch] == Some(j) {
                            out.de[SIGNAL][x][ch] += a;
                            out.de[SIGNAL_RATE][v][ch] += a;
                            break;
                        }
                    }
                }
            }
        }
        for ch in 0..CH {
            let b = f64::from(element.road_coefficients[ch]);
            out.de[ROAD][x][ch] += b;
            out.de[ROAD_RATE][v][ch] += b;
        }
    }
}

/// Continuous-time model for the configured causality.
#[allow(clippy::indexing_slicing, clippy::needless_range_loop)] // indices bounded by n, CH, MAX_*
#[inline(never)]
fn continuous<const CH: usize>(
    p: &SubstructureParams<CH>,
    causality: Causality,
    dt: f64,
    out: &mut Continuous<CH>,
) -> Result<(), ParamError> {
    let net = network(p);
    let elements = p.used_elements();
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
                    if p.interface[ch].damping > 0.0 && net.iface[ch].is_some() {
                        compliance[ch] = Some(2 * n + extra);
                        extra += 1;
                    }
                }
            }
            out.reset(2 * n + extra);
            for (ch, d) in net.iface.iter().enumerate() {
                if let Some(d) = *d {
                    force[SIGNAL][d][ch] -= 1.0;
                }
            }
            masses(&net, elements, dt, all.get(..n).unwrap_or(&[]), &force, out)?;
            element_motion(&net, elements, |j| Some((j, n + j)), out);
            for ch in 0..CH {
                let Some(d) = net.iface[ch] else { continue };
                out.c[ch][d] = 1.0;
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
            Ok(())
        }
        Causality::Impedance => {
            let mut net = net;
            out.reset(2 * n);
            for ch in 0..CH {
                let Some(d) = net.iface[ch] else { continue };
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
            masses(&net, elements, dt, all.get(..n).unwrap_or(&[]), &force, out)?;
            element_motion(&net, elements, |j| Some((j, n + j)), out);
            Ok(())
        }
        Causality::PrescribedMotion => {
            let mut is_iface = [false; MAX_DOF];
            for d in net.iface.iter().flatten() {
                is_iface[*d] = true;
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
                let Some(d) = net.iface[ch] else { continue };
                for &j in free {
                    force[SIGNAL][j][ch] -= net.k[j][d];
                    force[SIGNAL_RATE][j][ch] -= net.c[j][d];
                    force[SIGNAL_ACCELERATION][j][ch] -= net.m[j][d];
                }
            }
            out.reset(2 * nf);
            masses(&net, elements, dt, free, &force, out)?;
            element_motion(
                &net,
                elements,
                |j| free.iter().position(|&f| f == j).map(|a| (a, nf + a)),
                out,
            );
            // F_i = F_n,d - (M ẍ + C ẋ + K x)_d, with ẍ_F from the free DOFs' own equations.
            for ch in 0..CH {
                let Some(d) = net.iface[ch] else { continue };
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
                    for e in 0..MAX_ELEMENTS {
                        out.dr[ch][e] -= md * out.br[nf + a][e];
                    }
                }
                // The remainders' own generalised force on the interface DOF.
                for (e, element) in elements.iter().enumerate().take(MAX_ELEMENTS) {
                    out.dr[ch][e] -= f64::from(element.dof_coefficients[d]);
                }
                for i in 0..CH {
                    if let Some(di) = net.iface[i] {
                        out.d[SIGNAL][ch][i] -= net.k[d][di];
                        out.d[SIGNAL_RATE][ch][i] -= net.c[d][di];
                        out.d[SIGNAL_ACCELERATION][ch][i] -= net.m[d][di];
                    }
                    out.d[ROAD][ch][i] += net.gk[d][i];
                    out.d[ROAD_RATE][ch][i] += net.gc[d][i];
                }
            }
            Ok(())
        }
    }
}

/// Tustin discretisation of the continuous model (see the module docs). Not inlined: its
/// `f64` workspace and the continuous model's stay in separate frames, not summed in one.
#[allow(clippy::indexing_slicing, clippy::needless_range_loop)] // indices < ns <= MAX_STATES
#[inline(never)]
fn tustin<const CH: usize>(
    m: &Continuous<CH>,
    dt: f64,
    causality: Causality,
    velocity: VelocityFilterCoefficients,
    elements: &[SubstructureElement<CH>],
    out: &mut SubstructurePrepared<CH>,
) -> Result<(), ParamError> {
    let ns = m.ns;
    let mut lu = Lu::<MAX_STATES>::ZERO;
    let e = lu.matrix_mut();
    for i in 0..ns {
        for j in 0..ns {
            e[i][j] = -0.5 * dt * m.a[i][j];
        }
        e[i][i] += 1.0;
    }
    lu.factorise(ns)
        .map_err(|_| ParamError::Unstable(Field::SubstructureMass))?;
    out.clear();
    out.states = ns;
    out.causality = causality;
    out.velocity = velocity;
    out.elements = elements.len().min(MAX_ELEMENTS);
    for ((law, linear), e) in out.laws.iter_mut().zip(&mut out.linear).zip(elements) {
        *law = e.law;
        let (k, c) = linear_part(&e.law);
        *linear = [k, c];
    }
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
    // C_e,d = C_e E⁻¹; D_e,d = D_e + C_e,d B T/2; D_e,r = C_e,d B_r T/2.
    let mut ced = [[0.0f64; MAX_STATES]; ELEMENT_OUTPUTS];
    for (row_d, (row, out_row)) in ced.iter_mut().zip(m.ce.iter().zip(&mut out.c_e)) {
        let mut r = *row;
        lu.solve_transposed(&mut r);
        *row_d = r;
        for (o, v) in out_row.iter_mut().zip(&r).take(ns) {
            *o = *v as f32;
        }
    }
    let half = 0.5 * dt;
    for kind in 0..INPUT_KINDS {
        for o in 0..ELEMENT_OUTPUTS {
            for ch in 0..CH {
                let mut s = m.de[kind][o][ch];
                for i in 0..ns {
                    s += ced[o][i] * m.b[kind][i][ch] * half;
                }
                out.d_e[kind][o][ch] = s as f32;
            }
        }
    }
    // Γ_r = T E⁻¹ B_r; D_r,d = D_r + C_d B_r T/2; D_e,r = C_e,d B_r T/2.
    for e in 0..MAX_ELEMENTS {
        let mut col = [0.0f64; MAX_STATES];
        for i in 0..ns {
            col[i] = m.br[i][e];
        }
        for o in 0..CH {
            let mut s = m.dr[o][e];
            for i in 0..ns {
                s += cd[o][i] * col[i] * half;
            }
            out.d_r[o][e] = s as f32;
        }
        for o in 0..ELEMENT_OUTPUTS {
            let mut s = 0.0;
            for i in 0..ns {
                s += ced[o][i] * col[i] * half;
            }
            out.d_er[o][e] = s as f32;
        }
        for v in col.iter_mut() {
            *v *= dt;
        }
        lu.solve(&mut col);
        for i in 0..ns {
            out.gamma_r[i][e] = col[i] as f32;
        }
    }
    let finite = out.delta.iter().flatten().all(|v| v.is_finite())
        && out.c.iter().flatten().all(|v| v.is_finite())
        && out.gamma.iter().flatten().flatten().all(|v| v.is_finite())
        && out.d.iter().flatten().flatten().all(|v| v.is_finite())
        && out.gamma_r.iter().flatten().all(|v| v.is_finite())
        && out.d_r.iter().flatten().all(|v| v.is_finite())
        && out.c_e.iter().flatten().all(|v| v.is_finite())
        && out.d_e.iter().flatten().flatten().all(|v| v.is_finite())
        && out.d_er.iter().flatten().all(|v| v.is_finite());
    if finite {
        Ok(())
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
    /// The elements' remainders of the last sample (N).
    pub remainder: [f32; MAX_ELEMENTS],
    signal_rate: [VelocityEstimator; CH],
    signal_acceleration: [VelocityEstimator; CH],
    road_rate: [VelocityEstimator; CH],
}

impl<const CH: usize> SubstructureModel<CH> {
    /// At rest, every estimator fresh (as [`Model::new`]; all zero bits).
    pub const ZERO: Self = Self {
        state: [0.0; MAX_STATES],
        remainder: [0.0; MAX_ELEMENTS],
        signal_rate: [VelocityEstimator::new(); CH],
        signal_acceleration: [VelocityEstimator::new(); CH],
        road_rate: [VelocityEstimator::new(); CH],
    };
}

/// The elements' remainders `F(x, v) − k x − c̄ v` at their motion `[x_0, v_0, x_1, …]`.
#[inline]
fn remainders<const CH: usize>(
    p: &SubstructurePrepared<CH>,
    motion: &[f32; ELEMENT_OUTPUTS],
    out: &mut [f32; MAX_ELEMENTS],
) {
    for (((r, law), [k, c]), m) in out
        .iter_mut()
        .zip(&p.laws)
        .zip(&p.linear)
        .zip(motion.chunks_exact(2))
        .take(p.elements)
    {
        if let [x, v] = *m {
            *r = law.force(x, v) - k * x - c * v;
        }
    }
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
        let mut out = SubstructurePrepared::ZERO;
        Self::prepare_into(params, dt, &mut out)?;
        Ok(out)
    }

    fn prepare_into(
        params: &Self::Params,
        dt: f32,
        out: &mut Self::Prepared,
    ) -> Result<(), ParamError> {
        params.validate()?;
        let velocity = VelocityFilterCoefficients::new(params.velocity_cutoff_hz, dt)?;
        let causality = params
            .causality()
            .ok_or(ParamError::OutOfRange(Field::SubstructureCausality))?;
        let mut model = Continuous::zero(0);
        continuous(params, causality, f64::from(dt), &mut model)?;
        tustin(
            &model,
            f64::from(dt),
            causality,
            velocity,
            params.used_elements(),
            out,
        )
    }

    fn new() -> Self {
        Self::ZERO
    }

    fn reset(&mut self, _prepared: &Self::Prepared, _input: &ModelInput<CH>) {
        *self = Self::new();
    }

    // Out of line: inlined into the controller's step it costs about 5 % more
    // instructions on the board (measured with `cargo step-bench`).
    #[inline(never)]
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
        // y = C_d ξ + Σ D u (+ D_r r) ;  ξ += Δ ξ + Σ Γ u (+ Γ_r r)
        let mut y = [0.0; CH];
        mat_vec_acc(&mut y, &p.c, &self.state, CH, ns);
        let mut dx = [0.0; MAX_STATES];
        mat_vec_acc(&mut dx, &p.delta, &self.state, ns, ns);
        let ne = p.elements;
        if ne > 0 {
            // Element motion m = C_e ξ + Σ D_e u + D_e,r r⁻, remainders r = F(m) − linear
            // part (a linear substructure skips all of it).
            let mut motion = [0.0; ELEMENT_OUTPUTS];
            mat_vec_acc(&mut motion, &p.c_e, &self.state, 2 * ne, ns);
            for (d, uk) in p.d_e.iter().zip(&u) {
                mat_vec_acc(&mut motion, d, uk, 2 * ne, CH);
            }
            mat_vec_acc(&mut motion, &p.d_er, &self.remainder, 2 * ne, ne);
            let mut r = [0.0; MAX_ELEMENTS];
            remainders(p, &motion, &mut r);
            mat_vec_acc(&mut y, &p.d_r, &r, CH, ne);
            mat_vec_acc(&mut dx, &p.gamma_r, &r, ns, ne);
            self.remainder = r;
        }
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
        let states: f32 = self.state.iter().chain(&self.remainder).sum();
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
