//! Parameter validation: documented ranges and the error a rejected parameter set reports.
//!
//! Every tunable constant of the controller lives in one fixed-layout parameter struct
//! ([`crate::ControllerParams`]). A set is validated as a whole before the step may use it;
//! a rejected set changes nothing. The ranges below are the single source of the limits that
//! the calibration interface (A2L) will publish.

/// Closed range `[min, max]` for one parameter, in the parameter's documented unit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Range {
    /// Smallest allowed value.
    pub min: f32,
    /// Largest allowed value.
    pub max: f32,
}

impl Range {
    /// A range from `min` to `max` (inclusive).
    pub const fn new(min: f32, max: f32) -> Self {
        Self { min, max }
    }

    /// `Ok(())` if `value` is finite and inside the range, otherwise the error for `field`.
    pub fn check(&self, field: Field, value: f32) -> Result<(), ParamError> {
        if !value.is_finite() {
            Err(ParamError::NotFinite(field))
        } else if value < self.min || value > self.max {
            Err(ParamError::OutOfRange(field))
        } else {
            Ok(())
        }
    }
}

/// Names the parameter (group) a validation error refers to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Field {
    /// Tyre radial stiffness `k_t`.
    TyreStiffness,
    /// Tyre radial damping `c_t`.
    TyreDamping,
    /// Tyre static load.
    TyreStaticLoad,
    /// Tyre lift-off switch.
    TyreLiftOff,
    /// Cut-off of a velocity estimator's low-pass filter.
    VelocityCutoff,
    /// Aero stiffness matrix `K_i`.
    AeroStiffness,
    /// Aero nominal force `F_n`.
    AeroNominalForce,
    /// Aero reference speed.
    AeroReferenceSpeed,
    /// Axle distances `l_f`, `l_r`.
    AeroAxleDistance,
    /// Ride-height map (grid, values, size).
    AeroMap,
    /// Substructure degree-of-freedom count.
    SubstructureDof,
    /// Substructure mass matrix.
    SubstructureMass,
    /// Substructure damping matrix.
    SubstructureDamping,
    /// Substructure stiffness matrix.
    SubstructureStiffness,
    /// Substructure interface definition (DOF index, impedance).
    SubstructureInterface,
    /// Substructure ground connections to the road inputs.
    SubstructureGround,
    /// Substructure causality selector.
    SubstructureCausality,
    /// A substructure element's nonlinear law ([`crate::element::ElementLaw`]).
    SubstructureElement,
    /// The board's model kind ([`crate::board::ModelKind`]).
    ModelKind,
    /// The board's number of actuator channels.
    Channels,
    /// Command filter coefficients.
    CommandFilter,
    /// Demand amplitude limits.
    DemandAmplitude,
    /// Demand rate limit.
    DemandRate,
    /// Safe demand value.
    SafeDemand,
    /// Ramp rate towards the safe demand.
    SafeRampRate,
    /// Sample period.
    SamplePeriod,
}

/// Why a parameter set was rejected. The running parameters stay untouched.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParamError {
    /// The field holds NaN or an infinity.
    NotFinite(Field),
    /// The field is outside its documented range.
    OutOfRange(Field),
    /// A filter or discretised model would be unstable (poles on or outside the unit circle).
    Unstable(Field),
    /// The field is inconsistent with another (e.g. amplitude minimum above maximum, a
    /// singular mass matrix, a ride-height grid that is not increasing).
    Inconsistent(Field),
}

impl Field {
    /// The parameter's name as a person reads it (the board's A2L and the set-up name it
    /// likewise), e.g. "tyre stiffness k_t".
    pub fn name(&self) -> &'static str {
        match self {
            Field::TyreStiffness => "tyre stiffness k_t",
            Field::TyreDamping => "tyre damping c_t",
            Field::TyreStaticLoad => "tyre static load",
            Field::TyreLiftOff => "tyre lift-off switch",
            Field::VelocityCutoff => "velocity estimator cut-off",
            Field::AeroStiffness => "aero stiffness matrix K_i",
            Field::AeroNominalForce => "aero nominal force F_n",
            Field::AeroReferenceSpeed => "aero reference speed",
            Field::AeroAxleDistance => "axle distances l_f, l_r",
            Field::AeroMap => "ride-height map",
            Field::SubstructureDof => "substructure DOF count",
            Field::SubstructureMass => "substructure mass matrix",
            Field::SubstructureDamping => "substructure damping matrix",
            Field::SubstructureStiffness => "substructure stiffness matrix",
            Field::SubstructureInterface => "substructure interface",
            Field::SubstructureGround => "substructure ground connections",
            Field::SubstructureCausality => "substructure causality",
            Field::SubstructureElement => "substructure element law",
            Field::ModelKind => "model kind",
            Field::Channels => "channel count",
            Field::CommandFilter => "command filter",
            Field::DemandAmplitude => "demand limits",
            Field::DemandRate => "demand rate limit",
            Field::SafeDemand => "safe demand",
            Field::SafeRampRate => "safe ramp rate",
            Field::SamplePeriod => "sample period",
        }
    }
}

impl core::fmt::Display for Field {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.name())
    }
}

/// "command filter: unstable (error kind 3)": the field, why, and the code the board's
/// status and XCP replies carry.
impl core::fmt::Display for ParamError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "{}: {} (error kind {})",
            self.field(),
            self.reason(),
            self.kind_code()
        )
    }
}

impl ParamError {
    /// The field the error refers to.
    pub fn field(&self) -> Field {
        match *self {
            ParamError::NotFinite(f)
            | ParamError::OutOfRange(f)
            | ParamError::Unstable(f)
            | ParamError::Inconsistent(f) => f,
        }
    }

    /// Why, in words: "not finite", "out of range", "unstable", "inconsistent".
    pub fn reason(&self) -> &'static str {
        match self {
            ParamError::NotFinite(_) => "not finite",
            ParamError::OutOfRange(_) => "out of range",
            ParamError::Unstable(_) => "unstable",
            ParamError::Inconsistent(_) => "inconsistent",
        }
    }

    /// A stable numeric code for the error kind (for status frames and XCP): 1 not finite,
    /// 2 out of range, 3 unstable, 4 inconsistent.
    pub fn kind_code(&self) -> u8 {
        match self {
            ParamError::NotFinite(_) => 1,
            ParamError::OutOfRange(_) => 2,
            ParamError::Unstable(_) => 3,
            ParamError::Inconsistent(_) => 4,
        }
    }
}

/// Checks every value of a slice against `range`.
pub(crate) fn check_all(range: &Range, field: Field, values: &[f32]) -> Result<(), ParamError> {
    values.iter().try_for_each(|&v| range.check(field, v))
}

/// Allowed sample periods: 50 µs (20 kHz) to 10 ms (100 Hz).
pub const SAMPLE_PERIOD: Range = Range::new(5.0e-5, 1.0e-2);

/// `Ok(())` if `dt` is a usable sample period (s).
pub fn check_sample_period(dt: f32) -> Result<(), ParamError> {
    SAMPLE_PERIOD.check(Field::SamplePeriod, dt)
}
