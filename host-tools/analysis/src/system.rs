//! The paper's general linear MiL framework (its section 2), evaluated at one frequency.
//!
//! Sign conventions: positions and forces positive in the same direction per degree of
//! freedom (DOF); the interface force `F_i = B_i(s)(x_ni − x_pi)` pushes the physical part
//! positively and the numerical part negatively:
//!
//! ```text
//! A_n(s) x_n = F_n − Q_nᵀ F_i        A_p(s) x_p = F_p + Q_pᵀ F_i
//! A(s) = M s² + C s + K               B_i(s) = C_i V(s) + K_i
//! ```
//!
//! `V(s)` is how the interface velocity is obtained ([`VelocityEstimate`]): `V(s) = s` for a
//! physical `B_i` and for an ideal numerical one; for a numerical `B_i` computed by the
//! board from sampled positions (the tyre), `V(s) = D(e^{sT})`, the exact discrete response
//! of model-core's velocity estimator (backward difference and first-order low-pass,
//! `model_core::velocity`) at the controller sample period `T` (s):
//!
//! ```text
//! D(z) = (1 − z⁻¹)/T · g / (1 − (1 − g) z⁻¹),   g = 1 − e^{−2π f_c T}   (g = 1: f_c = 0)
//! ```
//!
//! with `1/T` and `g` the board's own `f32` coefficients
//! (`model_core::VelocityFilterCoefficients`). `D(e^{sT})` is analytic right of
//! `Re s = ln(1 − g)/T < 0`, so it is evaluated on complex `s` like every other block and the
//! stability count ([`MilSystem::stability`]) stays valid. At 2 kHz it lags `s` by 2.3° at
//! 17 Hz with the board's default 500 Hz cut-off (5.0° at 200 Hz; `ωT/2` = 1.5° for a plain
//! difference), which moves the tyre example's MiL response near its 17 Hz resonance by
//! 0.36 dB and 1.4° and its gain margin from 1.398 to 1.380 (the integration test
//! `analysis_consistency` checks the analysis against the board's controller step in a
//! time-domain loop); and its gain is bounded at the Nyquist frequency where `|s|` is not (a
//! lower control sensitivity to measurement noise). The estimator is part of the MiL implementation: the
//! emulated system (the ideal coupling that MiL emulates) keeps `V(s) = s`.
//!
//! External inputs `w` (road displacements, forces) act through `F_n = E_n(s) w`,
//! `F_p = E_p(s) w` with `E(s) = C_e s + K_e`, and, for a numerical part without masses
//! (the paper's special case 2.4), through a prescribed numerical interface position
//! `x_ni = G_w w` (the tyre's road input).
//!
//! Actuators: force control `F = P_f(s) F_c + R_f(s) y` (`y`: rod displacement, the
//! actuator's output in its own positive direction), position control
//! `x = P_d(s) x_c + R_d(s) F_load` (`F_load`: force the specimen applies to the rod in its
//! positive direction, `−F_i`). With actuator coordinates `x_a = T x_i` (e.g. the aero
//! example's axle transform `L`): `P = p I`, `R_f = r Tᵀ T`, `R_d = r T⁻¹ T⁻ᵀ`.
//!
//! Every configuration is reduced to one loop form at each frequency:
//!
//! ```text
//! v = N_w w + N_u û            numerical model output (force or position command)
//! y = G v,  G = F(s) e^{−sτ}    command filter and loop transport delay
//! û = H_c y + H_w w + n         measured interface signal, with measurement noise n
//! ```
//!
//! so that `y = (I − G N_u H_c)⁻¹ G [(N_w + N_u H_w) w + N_u n]`. Breaking the loop at the
//! numerical model's summing junction gives the open-loop matrix `L = −G N_u H_c`
//! (negative-feedback convention: the return difference is `I + L`). The emulated system
//! is the same with `P = I`, `R = 0`, `G = 1`, `n = 0` and `V(s) = s`.

use crate::error::{setup_error, AnalysisError, Result};
use crate::metrics::Stability;
use crate::response::{CommandFilter, ResponseSource};
use model_core::VelocityFilterCoefficients;
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;
use serde::Serialize;
use std::f64::consts::TAU;

/// Complex matrix.
pub type CMatrix = DMatrix<Complex64>;

fn c(x: f64) -> Complex64 {
    Complex64::new(x, 0.0)
}

fn complexify(m: &DMatrix<f64>) -> CMatrix {
    m.map(c)
}

fn solve(a: &CMatrix, b: &CMatrix, what: &'static str, frequency_hz: f64) -> Result<CMatrix> {
    if a.nrows() == 0 {
        return Ok(CMatrix::zeros(0, b.ncols()));
    }
    a.clone()
        .lu()
        .solve(b)
        .filter(|x| x.iter().all(|v| v.re.is_finite() && v.im.is_finite()))
        .ok_or(AnalysisError::Singular { what, frequency_hz })
}

fn inverse(a: &CMatrix, what: &'static str, frequency_hz: f64) -> Result<CMatrix> {
    solve(
        a,
        &CMatrix::identity(a.nrows(), a.nrows()),
        what,
        frequency_hz,
    )
}

/// A mechanical network of masses, dampers and springs: `A(s) = M s² + C s + K`.
#[derive(Clone, Debug, PartialEq)]
pub struct MechanicalPart {
    /// DOF names (for selecting outputs and interface DOFs).
    pub dofs: Vec<String>,
    /// Mass matrix `M` (kg, kg·m² for rotations).
    pub mass: DMatrix<f64>,
    /// Damping matrix `C` (N·s/m).
    pub damping: DMatrix<f64>,
    /// Stiffness matrix `K` (N/m).
    pub stiffness: DMatrix<f64>,
}

impl MechanicalPart {
    /// A part from its matrices.
    ///
    /// # Errors
    /// Sizes that do not match the DOF list, non-finite entries, duplicate DOF names.
    pub fn new(
        dofs: Vec<String>,
        mass: DMatrix<f64>,
        damping: DMatrix<f64>,
        stiffness: DMatrix<f64>,
    ) -> Result<Self> {
        let n = dofs.len();
        for (name, m) in [
            ("mass", &mass),
            ("damping", &damping),
            ("stiffness", &stiffness),
        ] {
            if m.nrows() != n || m.ncols() != n {
                return Err(setup_error(format!(
                    "{name} matrix is {}x{}, expected {n}x{n} for DOFs {dofs:?}",
                    m.nrows(),
                    m.ncols()
                )));
            }
            if m.iter().any(|v| !v.is_finite()) {
                return Err(setup_error(format!("{name} matrix has a non-finite entry")));
            }
        }
        for (i, d) in dofs.iter().enumerate() {
            if dofs[..i].contains(d) {
                return Err(setup_error(format!("duplicate DOF name {d:?}")));
            }
        }
        Ok(Self {
            dofs,
            mass,
            damping,
            stiffness,
        })
    }

    /// A part without any DOF (the numerical part of the tyre and aero examples).
    pub fn massless() -> Self {
        Self {
            dofs: Vec::new(),
            mass: DMatrix::zeros(0, 0),
            damping: DMatrix::zeros(0, 0),
            stiffness: DMatrix::zeros(0, 0),
        }
    }

    /// Number of DOFs.
    pub fn len(&self) -> usize {
        self.dofs.len()
    }

    /// True for a part without DOFs.
    pub fn is_empty(&self) -> bool {
        self.dofs.is_empty()
    }

    /// Index of a DOF by name.
    pub fn index(&self, name: &str) -> Option<usize> {
        self.dofs.iter().position(|d| d == name)
    }

    /// Dynamic stiffness `M s² + C s + K` at `s`.
    pub fn dynamic_stiffness(&self, s: Complex64) -> CMatrix {
        complexify(&self.mass) * (s * s)
            + complexify(&self.damping) * s
            + complexify(&self.stiffness)
    }
}

/// An external input `w_k` (road displacement in m, or a force in N) and how it enters.
#[derive(Clone, Debug, PartialEq)]
pub struct ExternalInput {
    /// Name (used to select inputs of responses).
    pub name: String,
    /// Unit of the input, for reports (e.g. "m", "N").
    pub unit: String,
    /// Force on each numerical DOF per unit input: stiffness part `K_e` (N per unit).
    pub numerical_stiffness: DVector<f64>,
    /// Force on each numerical DOF per unit input rate: damping part `C_e` (N·s per unit).
    pub numerical_damping: DVector<f64>,
    /// As `numerical_stiffness`, on the physical DOFs.
    pub physical_stiffness: DVector<f64>,
    /// As `numerical_damping`, on the physical DOFs.
    pub physical_damping: DVector<f64>,
    /// Prescribed numerical interface position per unit input (only for a numerical part
    /// without DOFs; the tyre's road input), one entry per interface channel.
    pub interface_position: DVector<f64>,
}

impl ExternalInput {
    /// An input that acts on nothing yet (fill in the vectors).
    pub fn new(name: &str, unit: &str, n_numerical: usize, n_physical: usize, m: usize) -> Self {
        Self {
            name: name.to_string(),
            unit: unit.to_string(),
            numerical_stiffness: DVector::zeros(n_numerical),
            numerical_damping: DVector::zeros(n_numerical),
            physical_stiffness: DVector::zeros(n_physical),
            physical_damping: DVector::zeros(n_physical),
            interface_position: DVector::zeros(m),
        }
    }
}

/// Where the interface impedance `B_i` is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ImpedanceLocation {
    /// A physical spring/damper joins the actuator to the physical part (cases 1 and 2).
    Physical,
    /// `B_i` is computed by the numerical model (cases 3 and 4).
    Numerical,
}

/// What the actuators' own controllers control.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ActuatorControl {
    /// Displacement-controlled actuators.
    Position,
    /// Force-controlled actuators.
    Force,
}

/// How the numerical model obtains the interface velocity that multiplies `C_i` (module
/// docs): `B_i(s) = C_i V(s) + K_i`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum VelocityEstimate {
    /// `V(s) = s`: a continuous derivative (a physical `B_i`, or an ideal numerical model).
    #[default]
    Continuous,
    /// `V(s) = D(e^{sT})`: the board's velocity estimator (`model_core::velocity`: backward
    /// difference and first-order low-pass) applied to the sampled interface deflection, with
    /// its `f32` coefficients as the board computes them. Valid only for a numerical `B_i`
    /// with a numerical part without DOFs under force control (configuration 4, the tyre:
    /// `F_i = K_i δ + C_i D δ̂` with `δ` the sampled deflection). Used in the MiL loop; the
    /// emulated loop keeps `V(s) = s`.
    Board {
        /// Controller sample period `T` (s); model-core's range, 5e-5 to 1e-2 s.
        sample_period_s: f64,
        /// Cut-off of the estimator's low-pass (Hz), 0 for a plain backward difference; the
        /// range of `model_core::velocity::VELOCITY_CUTOFF` (0–20 kHz).
        cutoff_hz: f64,
    },
}

impl VelocityEstimate {
    /// One line for reports: how the numerical model obtains the interface velocity.
    pub fn describe(&self) -> String {
        match self {
            Self::Continuous => "continuous derivative (C_i s)".to_string(),
            Self::Board {
                sample_period_s,
                cutoff_hz,
            } if *cutoff_hz > 0.0 => format!(
                "board estimator: backward difference at {:.0} Hz, low-pass {cutoff_hz:.0} Hz",
                1.0 / sample_period_s
            ),
            Self::Board {
                sample_period_s, ..
            } => format!(
                "board estimator: plain backward difference at {:.0} Hz",
                1.0 / sample_period_s
            ),
        }
    }

    /// The board's estimator coefficients, exactly as model-core derives them (`f32`),
    /// `None` for [`VelocityEstimate::Continuous`].
    ///
    /// # Errors
    /// A sample period or cut-off that model-core refuses (named).
    pub fn coefficients(&self) -> Result<Option<VelocityFilterCoefficients>> {
        match *self {
            Self::Continuous => Ok(None),
            Self::Board {
                sample_period_s,
                cutoff_hz,
            } => VelocityFilterCoefficients::new(cutoff_hz as f32, sample_period_s as f32)
                .map(Some)
                .map_err(|e| {
                    setup_error(format!(
                        "board velocity estimate: model-core refuses a cut-off of {cutoff_hz} Hz \
                         at a sample period of {sample_period_s} s ({e}): the cut-off must be \
                         0 (plain backward difference) to 20000 Hz, the sample period 5e-5 to \
                         1e-2 s"
                    ))
                }),
        }
    }

    /// `V(s)` (1/s) at a complex `s` (rad/s): `s`, or the board estimator's `D(e^{sT})`.
    ///
    /// # Errors
    /// As [`VelocityEstimate::coefficients`].
    pub fn response_s(&self, s: Complex64) -> Result<Complex64> {
        let Self::Board {
            sample_period_s, ..
        } = *self
        else {
            return Ok(s);
        };
        let v = self
            .coefficients()?
            .ok_or_else(|| setup_error("velocity estimate without coefficients"))?;
        let z_inv = (-s * sample_period_s).exp();
        let g = f64::from(v.gain);
        Ok(f64::from(v.inv_dt) * g * (1.0 - z_inv) / (1.0 - (1.0 - g) * z_inv))
    }

    /// `V(j 2π f)` (1/s) at `frequency_hz` (Hz).
    ///
    /// # Errors
    /// As [`VelocityEstimate::coefficients`].
    pub fn response(&self, frequency_hz: f64) -> Result<Complex64> {
        self.response_s(Complex64::new(0.0, TAU * frequency_hz))
    }
}

/// The interface between the numerical and the physical part.
#[derive(Clone, Debug, PartialEq)]
pub struct Interface {
    /// Where `B_i` sits.
    pub location: ImpedanceLocation,
    /// `Q_n` (m × n_n): selects numerical interface positions.
    pub numerical_select: DMatrix<f64>,
    /// `Q_p` (m × n_p): selects physical interface positions.
    pub physical_select: DMatrix<f64>,
    /// `K_i` (m × m, N/m). May be negative (the aero stiffness).
    pub stiffness: DMatrix<f64>,
    /// `C_i` (m × m, N·s/m).
    pub damping: DMatrix<f64>,
    /// How the velocity multiplying `C_i` is obtained in the MiL loop (default
    /// [`VelocityEstimate::Continuous`]).
    pub velocity: VelocityEstimate,
}

impl Interface {
    /// Number of interface channels `m`.
    pub fn channels(&self) -> usize {
        self.stiffness.nrows()
    }

    /// `B_i(s) = C_i s + K_i`, the continuous impedance (the emulated system's).
    pub fn impedance(&self, s: Complex64) -> CMatrix {
        complexify(&self.damping) * s + complexify(&self.stiffness)
    }

    /// `B_i(s) = C_i V(s) + K_i` with the velocity as the numerical model obtains it
    /// ([`Interface::velocity`]): the MiL loop's impedance.
    ///
    /// # Errors
    /// An invalid [`VelocityEstimate`].
    pub fn impedance_estimated(&self, s: Complex64) -> Result<CMatrix> {
        let v = self.velocity.response_s(s)?;
        Ok(complexify(&self.damping) * v + complexify(&self.stiffness))
    }
}

/// The actuators (one per interface channel, all of one type).
#[derive(Clone, Debug)]
pub struct Actuators {
    /// Position or force control.
    pub control: ActuatorControl,
    /// Tracking response `p(s)` of one actuator (dimensionless).
    pub tracking: ResponseSource,
    /// Disturbance response `r(s)` of one actuator (N/m for force control, m/N for position
    /// control).
    pub disturbance: ResponseSource,
    /// `T` (m × m): actuator displacements `x_a = T x_i`; identity when the actuators act
    /// directly on the interface coordinates.
    pub transform: DMatrix<f64>,
    /// Pure delay (s) of the loop between a measurement and the actuator command it causes:
    /// bus transport, computation and the servo controller's sampling (zero-order hold).
    pub loop_delay_s: f64,
}

/// A complete linear MiL set-up.
#[derive(Clone, Debug)]
pub struct MilSystem {
    /// Numerical part `A_n` (may have no DOFs).
    pub numerical: MechanicalPart,
    /// Physical part `A_p`.
    pub physical: MechanicalPart,
    /// The interface.
    pub interface: Interface,
    /// External inputs.
    pub inputs: Vec<ExternalInput>,
    /// The actuators.
    pub actuators: Actuators,
    /// Optional command filter before the actuators (same filter on every channel).
    pub filter: Option<CommandFilter>,
}

/// What the MiL loop is made of, for reports (the elements that shape its figures).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LoopDescription {
    /// "force" or "position".
    pub control: String,
    /// The actuator tracking response ([`ResponseSource::describe`]).
    pub tracking: String,
    /// The actuator disturbance response.
    pub disturbance: String,
    /// Loop transport delay (s).
    pub loop_delay_s: f64,
    /// How the numerical model obtains the interface velocity
    /// ([`VelocityEstimate::describe`]).
    pub velocity: String,
    /// The command filter, `None` without one ([`CommandFilter::describe`]).
    pub filter: Option<String>,
}

impl MilSystem {
    /// Describes the MiL loop's elements.
    pub fn describe_loop(&self) -> LoopDescription {
        LoopDescription {
            control: match self.actuators.control {
                ActuatorControl::Force => "force",
                ActuatorControl::Position => "position",
            }
            .to_string(),
            tracking: self.actuators.tracking.describe(),
            disturbance: self.actuators.disturbance.describe(),
            loop_delay_s: self.actuators.loop_delay_s,
            velocity: self.interface.velocity.describe(),
            filter: self.filter.as_ref().map(CommandFilter::describe),
        }
    }
}

/// Which loop to evaluate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Loop {
    /// The real MiL system: actuator responses, filter, delay, and the numerical model's
    /// velocity estimate ([`Interface::velocity`]).
    Mil,
    /// The emulated system: perfect actuators (`P = I`, `R = 0`), no filter, no delay, and
    /// the continuous interface velocity `V(s) = s` (no velocity estimator).
    Emulated,
}

/// Every signal of the loop at one frequency, as responses to the external inputs (columns)
/// and to measurement noise.
#[derive(Clone, Debug)]
pub struct LoopPoint {
    /// Frequency (Hz).
    pub frequency_hz: f64,
    /// Open-loop matrix `L` (m × m), loop broken at the numerical model's summing junction.
    pub open_loop: CMatrix,
    /// Actuator command `y` per input (m × n_w).
    pub command: CMatrix,
    /// Measured interface signal `û` per input (m × n_w).
    pub measured: CMatrix,
    /// True interface force on the physical part per input (m × n_w).
    pub interface_force: CMatrix,
    /// Physical DOF positions per input (n_p × n_w).
    pub physical: CMatrix,
    /// Numerical DOF positions per input (n_n × n_w).
    pub numerical: CMatrix,
    /// Control sensitivity: actuator command per unit measurement noise (m × m).
    pub noise_to_command: CMatrix,
}

/// The physical side of the loop (actuators and physical part) at one frequency.
struct PhysicalSide {
    h_c: CMatrix,
    h_w: CMatrix,
    /// Physical positions `x_p = x_c y + x_w w`.
    x_c: CMatrix,
    x_w: CMatrix,
    /// True interface force `f_c y + f_w w`.
    f_c: CMatrix,
    f_w: CMatrix,
}

impl MilSystem {
    /// The paper's configuration number: 1 (B_i physical, position control), 2 (B_i
    /// physical, force control), 3 (B_i numerical, position control), 4 (B_i numerical,
    /// force control).
    pub fn configuration(&self) -> u8 {
        match (self.interface.location, self.actuators.control) {
            (ImpedanceLocation::Physical, ActuatorControl::Position) => 1,
            (ImpedanceLocation::Physical, ActuatorControl::Force) => 2,
            (ImpedanceLocation::Numerical, ActuatorControl::Position) => 3,
            (ImpedanceLocation::Numerical, ActuatorControl::Force) => 4,
        }
    }

    /// Number of interface channels.
    pub fn channels(&self) -> usize {
        self.interface.channels()
    }

    /// Checks dimensions and the configuration's requirements.
    ///
    /// # Errors
    /// Names what is inconsistent.
    pub fn validate(&self) -> Result<()> {
        let m = self.channels();
        let (nn, np) = (self.numerical.len(), self.physical.len());
        let i = &self.interface;
        if m == 0 {
            return Err(setup_error("the interface has no channels"));
        }
        let shapes = [
            (
                "interface numerical selection Q_n",
                &i.numerical_select,
                m,
                nn,
            ),
            (
                "interface physical selection Q_p",
                &i.physical_select,
                m,
                np,
            ),
            ("interface stiffness K_i", &i.stiffness, m, m),
            ("interface damping C_i", &i.damping, m, m),
            ("actuator transform", &self.actuators.transform, m, m),
        ];
        for (name, mat, r, cols) in shapes {
            if mat.nrows() != r || mat.ncols() != cols {
                return Err(setup_error(format!(
                    "{name} is {}x{}, expected {r}x{cols}",
                    mat.nrows(),
                    mat.ncols()
                )));
            }
            if mat.iter().any(|v| !v.is_finite()) {
                return Err(setup_error(format!("{name} has a non-finite entry")));
            }
        }
        if self.actuators.transform.clone().try_inverse().is_none() {
            return Err(setup_error("actuator transform is singular"));
        }
        if !(self.actuators.loop_delay_s.is_finite() && self.actuators.loop_delay_s >= 0.0) {
            return Err(setup_error("loop delay must be finite and >= 0"));
        }
        if np == 0 {
            return Err(setup_error("the physical part has no DOFs"));
        }
        for input in &self.inputs {
            let sizes = [
                (input.numerical_stiffness.len(), nn),
                (input.numerical_damping.len(), nn),
                (input.physical_stiffness.len(), np),
                (input.physical_damping.len(), np),
                (input.interface_position.len(), m),
            ];
            if sizes.iter().any(|(a, b)| a != b) {
                return Err(setup_error(format!(
                    "input {:?} has vectors of the wrong size",
                    input.name
                )));
            }
            if nn > 0 && input.interface_position.iter().any(|v| *v != 0.0) {
                return Err(setup_error(format!(
                    "input {:?}: a prescribed numerical interface position needs a numerical \
                     part without DOFs (drive a DOF through a spring instead)",
                    input.name
                )));
            }
        }
        if nn == 0 && self.configuration() == 2 {
            return Err(setup_error(
                "configuration 2 (B_i physical, force control) needs masses in the numerical \
                 part: the numerical model must turn a measured position into a force",
            ));
        }
        if let VelocityEstimate::Board { .. } = i.velocity {
            i.velocity.coefficients()?;
            if self.configuration() != 4 || nn != 0 {
                return Err(setup_error(
                    "the board's velocity estimate is modelled for a numerical B_i with a \
                     numerical part without DOFs under force control (configuration 4, the \
                     tyre: F_i = K_i δ + C_i D δ̂ from the sampled deflection δ̂); use the \
                     continuous velocity otherwise (in a set-up file: no interface \
                     velocity_cutoff_hz)",
                ));
            }
        }
        Ok(())
    }

    fn input_matrices(&self, s: Complex64) -> (CMatrix, CMatrix, CMatrix) {
        let nw = self.inputs.len();
        let m = self.channels();
        let mut en = CMatrix::zeros(self.numerical.len(), nw);
        let mut ep = CMatrix::zeros(self.physical.len(), nw);
        let mut gw = CMatrix::zeros(m, nw);
        for (k, input) in self.inputs.iter().enumerate() {
            for j in 0..self.numerical.len() {
                en[(j, k)] = c(input.numerical_stiffness[j]) + s * input.numerical_damping[j];
            }
            for j in 0..self.physical.len() {
                ep[(j, k)] = c(input.physical_stiffness[j]) + s * input.physical_damping[j];
            }
            for j in 0..m {
                gw[(j, k)] = c(input.interface_position[j]);
            }
        }
        (en, ep, gw)
    }

    /// `P` and `R` in interface coordinates for the chosen loop at `s`.
    fn actuator_matrices(&self, s: Complex64, f: f64, which: Loop) -> Result<(CMatrix, CMatrix)> {
        let m = self.channels();
        if which == Loop::Emulated {
            return Ok((CMatrix::identity(m, m), CMatrix::zeros(m, m)));
        }
        let p = self.actuators.tracking.response_s(s)?;
        let r = self.actuators.disturbance.response_s(s)?;
        let t = complexify(&self.actuators.transform);
        let r_matrix = match self.actuators.control {
            ActuatorControl::Force => t.transpose() * &t * r,
            ActuatorControl::Position => {
                let ti = inverse(&t, "actuator transform", f)?;
                &ti * ti.transpose() * r
            }
        };
        Ok((CMatrix::identity(m, m) * p, r_matrix))
    }

    /// Evaluates every signal of the chosen loop at `frequency_hz` (Hz, > 0).
    ///
    /// # Errors
    /// A singular matrix (e.g. a required interface compliance that is zero), or a table
    /// queried outside its range.
    pub fn point(&self, frequency_hz: f64, which: Loop) -> Result<LoopPoint> {
        self.point_s(Complex64::new(0.0, TAU * frequency_hz), which)
    }

    /// As [`MilSystem::point`] at a complex `s` (rad/s) (used for the stability count; the
    /// frequency reported is `Im s / 2π`).
    ///
    /// # Errors
    /// As [`MilSystem::point`]; measured tables are only defined on the imaginary axis.
    pub fn point_s(&self, s: Complex64, which: Loop) -> Result<LoopPoint> {
        let f = s.im / TAU;
        let m = self.channels();
        let eye = CMatrix::identity(m, m);
        let (en, ep, gw) = self.input_matrices(s);
        let b = match which {
            Loop::Mil => self.interface.impedance_estimated(s)?,
            Loop::Emulated => self.interface.impedance(s),
        };
        let qn = complexify(&self.interface.numerical_select);
        let qp = complexify(&self.interface.physical_select);
        let an = self.numerical.dynamic_stiffness(s);
        let ap = self.physical.dynamic_stiffness(s);
        // Numerical interface compliance S_n = Q_n A_n⁻¹ Q_nᵀ and input path T_n.
        let an_inv_qnt = solve(&an, &qn.transpose(), "numerical A_n", f)?;
        let an_inv_en = solve(&an, &en, "numerical A_n", f)?;
        let s_n = &qn * &an_inv_qnt;
        let t_n = &qn * &an_inv_en + &gw;
        let (p, r) = self.actuator_matrices(s, f, which)?;

        // Numerical model: v = N_w w + N_u û, and the interface force the numerical model
        // applies to itself, F_num = Fn_w w + Fn_u û.
        let config = self.configuration();
        let (n_u, n_w, force_is_output) = match config {
            1 => (-s_n.clone(), t_n.clone(), false),
            2 => {
                let s_n_inv = inverse(&s_n, "numerical interface compliance S_n", f)?;
                (-&s_n_inv, &s_n_inv * &t_n, true)
            }
            3 => {
                let b_inv = inverse(&b, "interface impedance B_i", f)?;
                (-(&s_n + b_inv), t_n.clone(), false)
            }
            _ => {
                let k = inverse(&(&eye + &b * &s_n), "I + B_i S_n", f)?;
                (-(&k * &b), &k * &b * &t_n, true)
            }
        };
        let side = self.physical_side(config, f, &b, &qp, &ap, &ep, &p, &r)?;

        let g = match which {
            Loop::Emulated => c(1.0),
            Loop::Mil => {
                let filter = self.filter.as_ref().map_or(c(1.0), |flt| flt.response_s(s));
                filter * (-s * self.actuators.loop_delay_s).exp()
            }
        };
        let loop_gain = &n_u * &side.h_c * g;
        let return_difference = &eye - &loop_gain;
        let command = solve(
            &return_difference,
            &((&n_w + &n_u * &side.h_w) * g),
            "MiL loop return difference",
            f,
        )?;
        let noise_to_command = solve(&return_difference, &(&n_u * g), "return difference", f)?;
        let measured = &side.h_c * &command + &side.h_w;
        let physical = &side.x_c * &command + &side.x_w;
        let interface_force = &side.f_c * &command + &side.f_w;
        let numerical_output = &n_w + &n_u * &measured;
        let numerical_force = if force_is_output {
            numerical_output
        } else {
            measured.clone()
        };
        let numerical = &an_inv_en - &an_inv_qnt * numerical_force;
        Ok(LoopPoint {
            frequency_hz: f,
            open_loop: -loop_gain,
            command,
            measured,
            interface_force,
            physical,
            numerical,
            noise_to_command,
        })
    }

    #[allow(clippy::too_many_arguments)]
    fn physical_side(
        &self,
        config: u8,
        f: f64,
        b: &CMatrix,
        qp: &CMatrix,
        ap: &CMatrix,
        ep: &CMatrix,
        p: &CMatrix,
        r: &CMatrix,
    ) -> Result<PhysicalSide> {
        let m = self.channels();
        let eye = CMatrix::identity(m, m);
        match config {
            1 => {
                // Actuator position x_a drives the free end of the physical B_i.
                let apb = ap + qp.transpose() * b * qp;
                let apb_inv_qpt_b = solve(&apb, &(qp.transpose() * b), "A_p + Q_pᵀ B_i Q_p", f)?;
                let apb_inv_ep = solve(&apb, ep, "A_p + Q_pᵀ B_i Q_p", f)?;
                let y = b - b * qp * &apb_inv_qpt_b;
                let y_w = -(b * qp * &apb_inv_ep);
                let k = inverse(&(&eye + r * &y), "I + R_d Y", f)?;
                // x_a = X_y y + X_w w
                let xa_y = &k * p;
                let xa_w = -(&k * r * &y_w);
                let h_c = &y * &xa_y;
                let h_w = &y * &xa_w + &y_w;
                Ok(PhysicalSide {
                    x_c: &apb_inv_qpt_b * &xa_y,
                    x_w: &apb_inv_qpt_b * &xa_w + &apb_inv_ep,
                    f_c: h_c.clone(),
                    f_w: h_w.clone(),
                    h_c,
                    h_w,
                })
            }
            2 => {
                // Actuator force acts on the free end of the physical B_i; its rod position is
                // measured.
                let ap_inv_qpt = solve(ap, &qp.transpose(), "physical A_p", f)?;
                let ap_inv_ep = solve(ap, ep, "physical A_p", f)?;
                let s_p = qp * &ap_inv_qpt;
                let t_p = qp * &ap_inv_ep;
                let compliance = inverse(b, "interface impedance B_i", f)? + &s_p;
                let k = inverse(&(&eye - r * &compliance), "I − R_f (B_i⁻¹ + S_p)", f)?;
                let f_c = &k * p;
                let f_w = &k * r * &t_p;
                Ok(PhysicalSide {
                    h_c: &compliance * &f_c,
                    h_w: &compliance * &f_w + &t_p,
                    x_c: &ap_inv_qpt * &f_c,
                    x_w: &ap_inv_qpt * &f_w + &ap_inv_ep,
                    f_c,
                    f_w,
                })
            }
            3 => {
                // Actuator position prescribes the physical interface DOFs; the force it takes
                // is measured.
                let ap_inv_qpt = solve(ap, &qp.transpose(), "physical A_p", f)?;
                let ap_inv_ep = solve(ap, ep, "physical A_p", f)?;
                let s_p = qp * &ap_inv_qpt;
                let t_p = qp * &ap_inv_ep;
                let s_p_inv = inverse(&s_p, "physical interface compliance S_p", f)?;
                let k = inverse(&(&eye + r * &s_p_inv), "I + R_d S_p⁻¹", f)?;
                let xa_y = &k * p;
                let xa_w = &k * r * &s_p_inv * &t_p;
                let f_c = &s_p_inv * &xa_y;
                let f_w = &s_p_inv * (&xa_w - &t_p);
                Ok(PhysicalSide {
                    h_c: f_c.clone(),
                    h_w: f_w.clone(),
                    x_c: &ap_inv_qpt * &f_c,
                    x_w: &ap_inv_qpt * &f_w + &ap_inv_ep,
                    f_c,
                    f_w,
                })
            }
            _ => {
                // Actuator force acts on the physical interface DOFs; their position is measured.
                let apr = ap - qp.transpose() * r * qp;
                let x_c = solve(&apr, &(qp.transpose() * p), "A_p − Q_pᵀ R_f Q_p", f)?;
                let x_w = solve(&apr, ep, "A_p − Q_pᵀ R_f Q_p", f)?;
                let h_c = qp * &x_c;
                let h_w = qp * &x_w;
                let f_c = p + r * &h_c;
                let f_w = r * &h_w;
                Ok(PhysicalSide {
                    h_c,
                    h_w,
                    x_c,
                    x_w,
                    f_c,
                    f_w,
                })
            }
        }
    }

    /// Dynamic stiffness of the coupled emulated system at `s` (rad/s): numerical DOFs
    /// first, then physical, joined by the continuous interface impedance `B_i(s)`. Its
    /// determinant is a polynomial in `s` whose zeros are the emulated system's poles.
    pub fn coupled_dynamic_stiffness(&self, s: Complex64) -> CMatrix {
        let (nn, np) = (self.numerical.len(), self.physical.len());
        let b = self.interface.impedance(s);
        let qn = complexify(&self.interface.numerical_select);
        let qp = complexify(&self.interface.physical_select);
        let n = nn + np;
        let mut a = CMatrix::zeros(n, n);
        a.view_mut((0, 0), (nn, nn))
            .copy_from(&(self.numerical.dynamic_stiffness(s) + qn.transpose() * &b * &qn));
        a.view_mut((0, nn), (nn, np))
            .copy_from(&(-(qn.transpose() * &b * &qp)));
        a.view_mut((nn, 0), (np, nn))
            .copy_from(&(-(qp.transpose() * &b * &qn)));
        a.view_mut((nn, nn), (np, np))
            .copy_from(&(self.physical.dynamic_stiffness(s) + qp.transpose() * &b * &qp));
        a
    }

    /// The coupled emulated system solved directly (no loop form): physical and numerical
    /// positions per input. Used to check the loop forms.
    ///
    /// # Errors
    /// A singular system matrix.
    pub fn emulated_direct(&self, frequency_hz: f64) -> Result<(CMatrix, CMatrix)> {
        let f = frequency_hz;
        let s = Complex64::new(0.0, TAU * f);
        let (nn, np) = (self.numerical.len(), self.physical.len());
        let (en, ep, gw) = self.input_matrices(s);
        let b = self.interface.impedance(s);
        let a = self.coupled_dynamic_stiffness(s);
        let qp = complexify(&self.interface.physical_select);
        let n = nn + np;
        let mut rhs = CMatrix::zeros(n, self.inputs.len());
        // The prescribed numerical interface position enters like a moving ground.
        let prescribed = &b * &gw;
        rhs.view_mut((0, 0), (nn, self.inputs.len())).copy_from(&en);
        rhs.view_mut((nn, 0), (np, self.inputs.len()))
            .copy_from(&(ep + qp.transpose() * prescribed));
        let x = solve(&a, &rhs, "coupled system", f)?;
        Ok((x.rows(nn, np).into_owned(), x.rows(0, nn).into_owned()))
    }
}

/// Counts the zeros of `d(s)` right of the line `Re s = σ`, by the argument principle along
/// `s = σ + jω`, `ω` from 0 up a log grid (`points` per decade from 0.1 mHz) to
/// `w_max_rad_s`, each step sub-divided until its phase turns less than 20°. Returns the accumulated phase (rad) and the last `ω`.
fn phase_walk<F>(d: F, w_max_rad_s: f64, points: usize) -> Option<(f64, f64)>
where
    F: Fn(f64) -> Option<Complex64>,
{
    let mut ws = vec![0.0];
    ws.extend(
        crate::metrics::log_grid(1e-4, w_max_rad_s / TAU, points)
            .iter()
            .map(|f| TAU * f),
    );
    let mut previous = d(0.0)?;
    let mut total = 0.0;
    let mut w_prev = 0.0;
    for &w in &ws[1..] {
        let mut stack = vec![(w_prev, w)];
        let mut from_value = previous;
        while let Some((a, b)) = stack.pop() {
            let vb = d(b)?;
            let step = (vb / from_value).arg();
            if step.abs() > 20f64.to_radians() && b - a > 1e-9 * b.max(1.0) {
                stack.push((0.5 * (a + b), b));
                stack.push((a, 0.5 * (a + b)));
                continue;
            }
            total += step;
            from_value = vb;
        }
        previous = from_value;
        w_prev = w;
    }
    Some((total, w_prev))
}

impl MilSystem {
    /// Closed-loop stability of the chosen loop: poles with real part above
    /// `σ = 2π · 1 mHz`.
    ///
    /// - The MiL loop: [`MilSystem::loop_stability`].
    /// - The emulated system: the zeros of `det A(s)`, `A` its
    ///   [`MilSystem::coupled_dynamic_stiffness`], a polynomial of degree `n`. Along
    ///   `s = σ + jω`, `ω` from 0 to ∞, its phase turns by `(π/2)(n_left − n_right)`; `n` is
    ///   read from the slope of `|det A|` at 10 MHz (its zeros are far below). This needs no
    ///   loop form, so it holds where the emulated loop gain does not fall with frequency
    ///   (configuration 3: `|L|` grows like the physical inertia over the interface damping).
    pub fn stability(&self, which: Loop) -> Stability {
        match which {
            Loop::Mil => self.loop_stability(Loop::Mil),
            Loop::Emulated => self.coupled_stability(),
        }
    }

    fn coupled_stability(&self) -> Stability {
        let sigma = TAU * 1e-3;
        // det A / (1 + |s|²)^N keeps the values in range; the positive scale leaves the
        // phase alone.
        let n_dofs = self.numerical.len() + self.physical.len();
        let det = |w: f64| -> Option<Complex64> {
            let s = Complex64::new(sigma, w);
            let scale = (1.0 + s.norm_sqr()).powi(-(n_dofs as i32));
            let d = self.coupled_dynamic_stiffness(s).determinant() * scale;
            (d.is_finite() && d != Complex64::new(0.0, 0.0)).then_some(d)
        };
        let w_end = TAU * 1e7;
        let Some((total, w_last)) = phase_walk(det, w_end, 200) else {
            return Stability::Unknown;
        };
        // Degree from the slope of |det A| between w_last and 2 w_last.
        let (Some(d1), Some(d2)) = (det(w_last), det(2.0 * w_last)) else {
            return Stability::Unknown;
        };
        let slope_scaled = (d2.norm() / d1.norm()).ln() / 2f64.ln();
        let degree = slope_scaled + 2.0 * n_dofs as f64;
        if (degree - degree.round()).abs() > 0.05 {
            return Stability::Unknown;
        }
        let right = 0.5 * (degree.round() - 2.0 * total / std::f64::consts::PI);
        if (right - right.round()).abs() > 0.1 {
            return Stability::Unknown;
        }
        match right.round() {
            z if z <= 0.0 => Stability::Stable,
            z => Stability::Unstable(z as u32),
        }
    }

    /// Counts closed-loop poles with real part above `σ = 2π · 1 mHz` by the argument
    /// principle applied to `det(I + L(s))` along `s = σ + jω`, `ω ≥ 0` (the lower half
    /// follows by conjugate symmetry). Assumes the open loop has no poles right of `σ`
    /// (passive parts, stable actuators and filter); rigid-body modes at `s = 0` lie left of
    /// the contour, so they need no indentation. [`Stability::Unknown`] where the loop gain
    /// has not fallen below 0.1 by 20 kHz (an improper loop).
    pub fn loop_stability(&self, which: Loop) -> Stability {
        let sigma = TAU * 1e-3;
        let det = |w: f64| -> Option<Complex64> {
            let p = self.point_s(Complex64::new(sigma, w), which).ok()?;
            let m = p.open_loop.nrows();
            Some((CMatrix::identity(m, m) + &p.open_loop).determinant())
        };
        // ω from 0 to 2π·20 kHz: a dense log grid, refined where the phase steps more than
        // 20°.
        let Some((total, w_prev)) = phase_walk(det, TAU * 2e4, 400) else {
            return Stability::Unknown;
        };
        // The loop must have died out at the end of the contour.
        let Ok(end) = self.point_s(Complex64::new(sigma, w_prev), which) else {
            return Stability::Unknown;
        };
        if end.open_loop.iter().any(|v| v.norm() > 0.1) {
            return Stability::Unknown;
        }
        let z = (-total / std::f64::consts::PI).round();
        if z <= 0.0 {
            Stability::Stable
        } else {
            Stability::Unstable(z as u32)
        }
    }
}
