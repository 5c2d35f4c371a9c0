//! Aerodynamic down-force model for a racing car on a four-poster rig with two
//! force-controlled down-force actuators (front axle: channel 0, rear axle: channel 1).
//!
//! Bicycle model (heave `z`, up positive, m; pitch `θ`, rad). The rig measures the body
//! displacement at the two down-force actuators, `x_f` and `x_r` (m, up positive, relative to
//! the static ride height), with `[x_f; x_r] = L [z; θ]`, `L = [1 -l_f; 1 l_r]`.
//!
//! **Linear model** (the paper's, at reference speed `v_ref`):
//! `[F_z; M_θ] = (v / v_ref)² (K_i [z; θ] + F_n)`.
//!
//! **Ride-height map** (optional): front and rear down force (N, positive downwards) at the
//! reference speed as a table over front and rear ride height, interpolated bilinearly and
//! clamped at the table's edges (never extrapolated); ride height = static ride height + `x`.
//! `F_f = -(v / v_ref)² D_f(h_f, h_r)`, likewise rear.
//!
//! The outputs are the axle forces on the body (N, up positive) that the front and rear
//! actuators must apply: `[F_z; M_θ] = Lᵀ [F_f; F_r]`, so
//! `F_f = (l_r F_z - M_θ)/(l_f + l_r)`, `F_r = (l_f F_z + M_θ)/(l_f + l_r)`.

use crate::controller::{Model, ModelInput};
use crate::params::{check_all, Field, ParamError, Range};

/// Largest number of break points per axis of the ride-height map.
pub const MAP_POINTS: usize = 8;
/// Allowed entries of the aero stiffness matrix (N/m, N/rad, N m/m, N m/rad).
pub const AERO_STIFFNESS: Range = Range::new(-1.0e8, 1.0e8);
/// Allowed nominal aero force and moment (N, N m).
pub const AERO_NOMINAL_FORCE: Range = Range::new(-1.0e6, 1.0e6);
/// Allowed reference speed (m/s).
pub const AERO_REFERENCE_SPEED: Range = Range::new(1.0, 150.0);
/// Allowed axle distances from the centroid (m).
pub const AERO_AXLE_DISTANCE: Range = Range::new(0.05, 10.0);
/// Allowed ride heights in the map (m).
pub const AERO_RIDE_HEIGHT: Range = Range::new(-1.0, 1.0);
/// Allowed map down-force values (N).
pub const AERO_MAP_FORCE: Range = Range::new(-1.0e6, 1.0e6);
/// Largest speed accepted as input (m/s); faster is treated as an invalid input.
pub const AERO_MAX_SPEED: f32 = 150.0;
/// Largest axle displacement accepted as input (m, either sign, from the static ride
/// height): beyond a four-poster's travel, so a larger value is a corrupt or misscaled
/// frame and latches an invalid-input fault.
pub const AERO_MAX_DISPLACEMENT: f32 = 1.0;

/// Ride-height map: down force per axle over a grid of front and rear ride heights.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct RideHeightMap {
    /// Number of front ride-height break points used (2..=MAP_POINTS).
    pub front_points: u32,
    /// Number of rear ride-height break points used (2..=MAP_POINTS).
    pub rear_points: u32,
    /// Front ride-height break points (m), strictly increasing.
    pub front_height: [f32; MAP_POINTS],
    /// Rear ride-height break points (m), strictly increasing.
    pub rear_height: [f32; MAP_POINTS],
    /// Front-axle down force (N, positive downwards) at the reference speed,
    /// `[front index][rear index]`.
    pub front_force: [[f32; MAP_POINTS]; MAP_POINTS],
    /// Rear-axle down force (N, positive downwards) at the reference speed,
    /// `[front index][rear index]`.
    pub rear_force: [[f32; MAP_POINTS]; MAP_POINTS],
    /// Static front ride height (m) at which `x_f = 0`.
    pub static_front_height: f32,
    /// Static rear ride height (m) at which `x_r = 0`.
    pub static_rear_height: f32,
}

impl RideHeightMap {
    /// An unused map (two break points, zero force).
    pub const EMPTY: Self = Self {
        front_points: 2,
        rear_points: 2,
        front_height: [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7],
        rear_height: [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7],
        front_force: [[0.0; MAP_POINTS]; MAP_POINTS],
        rear_force: [[0.0; MAP_POINTS]; MAP_POINTS],
        static_front_height: 0.05,
        static_rear_height: 0.05,
    };

    /// Validates sizes, monotonic break points and finite values.
    pub fn validate(&self) -> Result<(), ParamError> {
        let nf = self.front_points as usize;
        let nr = self.rear_points as usize;
        if !(2..=MAP_POINTS).contains(&nf) || !(2..=MAP_POINTS).contains(&nr) {
            return Err(ParamError::OutOfRange(Field::AeroMap));
        }
        check_all(&AERO_RIDE_HEIGHT, Field::AeroMap, &self.front_height)?;
        check_all(&AERO_RIDE_HEIGHT, Field::AeroMap, &self.rear_height)?;
        AERO_RIDE_HEIGHT.check(Field::AeroMap, self.static_front_height)?;
        AERO_RIDE_HEIGHT.check(Field::AeroMap, self.static_rear_height)?;
        for row in self.front_force.iter().chain(&self.rear_force) {
            check_all(&AERO_MAP_FORCE, Field::AeroMap, row)?;
        }
        let increasing = |h: &[f32]| h.windows(2).all(|w| matches!(w, [a, b] if a < b));
        if !increasing(self.front_height.get(..nf).unwrap_or(&[]))
            || !increasing(self.rear_height.get(..nr).unwrap_or(&[]))
        {
            return Err(ParamError::Inconsistent(Field::AeroMap));
        }
        Ok(())
    }

    /// Front and rear down force (N, positive downwards) at the reference speed for ride
    /// heights `h_front`, `h_rear` (m), bilinear, clamped to the grid.
    pub fn down_force(&self, h_front: f32, h_rear: f32) -> (f32, f32) {
        let (i, tf) = locate(&self.front_height, self.front_points, h_front);
        let (j, tr) = locate(&self.rear_height, self.rear_points, h_rear);
        (
            bilinear(&self.front_force, i, j, tf, tr),
            bilinear(&self.rear_force, i, j, tf, tr),
        )
    }
}

/// Index of the grid cell holding `h` and the fractional position in it, clamped to the grid.
fn locate(grid: &[f32; MAP_POINTS], points: u32, h: f32) -> (usize, f32) {
    let n = (points as usize).clamp(2, MAP_POINTS);
    let used = grid.get(..n).unwrap_or(&[]);
    let first = used.first().copied().unwrap_or(0.0);
    let last = used.last().copied().unwrap_or(0.0);
    if h.is_nan() || h <= first {
        return (0, 0.0);
    }
    if h >= last {
        return (n - 2, 1.0);
    }
    let mut i = 0;
    for (k, w) in used.windows(2).enumerate() {
        if let [lo, hi] = w {
            if h >= *lo && h < *hi {
                i = k;
                break;
            }
        }
    }
    let lo = grid.get(i).copied().unwrap_or(0.0);
    let hi = grid.get(i + 1).copied().unwrap_or(1.0);
    let t = ((h - lo) / (hi - lo)).clamp(0.0, 1.0);
    (i, t)
}

fn bilinear(table: &[[f32; MAP_POINTS]; MAP_POINTS], i: usize, j: usize, ti: f32, tj: f32) -> f32 {
    let at = |a: usize, b: usize| table.get(a).and_then(|r| r.get(b)).copied().unwrap_or(0.0);
    let f00 = at(i, j);
    let f01 = at(i, j + 1);
    let f10 = at(i + 1, j);
    let f11 = at(i + 1, j + 1);
    let lo = f00 + (f01 - f00) * tj;
    let hi = f10 + (f11 - f10) * tj;
    lo + (hi - lo) * ti
}

/// Parameters of the aerodynamic model.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct AeroParams {
    /// Aero stiffness `K_i` at the reference speed, rows `[F_z; M_θ]`, columns `[z; θ]`
    /// (N/m, N/rad; N m/m, N m/rad).
    pub stiffness: [[f32; 2]; 2],
    /// Nominal aero force `F_n = [F_z; M_θ]` at zero body displacement and the reference
    /// speed (N, N m; up positive, so down force is negative).
    pub nominal_force: [f32; 2],
    /// Speed at which `stiffness`, `nominal_force` and the map hold (m/s).
    pub reference_speed: f32,
    /// Centroid to front axle `l_f` (m).
    pub front_axle: f32,
    /// Centroid to rear axle `l_r` (m).
    pub rear_axle: f32,
    /// 1: use the ride-height map instead of the linear model; 0: linear model.
    pub use_map: u32,
    /// Ride-height map (used when `use_map == 1`).
    pub map: RideHeightMap,
}

impl AeroParams {
    /// Every field zero (not a valid set): a place holder.
    pub const ZERO: Self = Self {
        stiffness: [[0.0; 2]; 2],
        nominal_force: [0.0; 2],
        reference_speed: 0.0,
        front_axle: 0.0,
        rear_axle: 0.0,
        use_map: 0,
        map: RideHeightMap {
            front_points: 0,
            rear_points: 0,
            front_height: [0.0; MAP_POINTS],
            rear_height: [0.0; MAP_POINTS],
            front_force: [[0.0; MAP_POINTS]; MAP_POINTS],
            rear_force: [[0.0; MAP_POINTS]; MAP_POINTS],
            static_front_height: 0.0,
            static_rear_height: 0.0,
        },
    };

    /// The paper's Formula One parameters (Table 1): `K_i` in kN units converted to SI,
    /// `F_n = [-8.28 kN, -1.49 kN m]`, `l_f = 1.8 m`, `l_r = 1.4 m`. The paper gives one
    /// (unnamed) speed; 50 m/s is taken as that reference speed here.
    pub const PAPER: Self = Self {
        stiffness: [[-83.9e3, 45.3e3], [-51.9e3, 231.6e3]],
        nominal_force: [-8.28e3, -1.49e3],
        reference_speed: 50.0,
        front_axle: 1.8,
        rear_axle: 1.4,
        use_map: 0,
        map: RideHeightMap::EMPTY,
    };

    /// Validates ranges and the map.
    pub fn validate(&self) -> Result<(), ParamError> {
        for row in &self.stiffness {
            check_all(&AERO_STIFFNESS, Field::AeroStiffness, row)?;
        }
        check_all(
            &AERO_NOMINAL_FORCE,
            Field::AeroNominalForce,
            &self.nominal_force,
        )?;
        AERO_REFERENCE_SPEED.check(Field::AeroReferenceSpeed, self.reference_speed)?;
        AERO_AXLE_DISTANCE.check(Field::AeroAxleDistance, self.front_axle)?;
        AERO_AXLE_DISTANCE.check(Field::AeroAxleDistance, self.rear_axle)?;
        if self.use_map > 1 {
            return Err(ParamError::OutOfRange(Field::AeroMap));
        }
        self.map.validate()
    }

    /// `[z, θ]` from the axle displacements `x_f`, `x_r` (m).
    #[inline]
    pub fn heave_pitch(&self, x_front: f32, x_rear: f32) -> [f32; 2] {
        heave_pitch(
            self,
            1.0 / (self.front_axle + self.rear_axle),
            x_front,
            x_rear,
        )
    }

    /// Front and rear axle forces (N) from heave force `F_z` (N) and pitch moment `M_θ` (N m).
    #[inline]
    pub fn axle_forces(&self, f_z: f32, m_theta: f32) -> [f32; 2] {
        axle_forces(self, 1.0 / (self.front_axle + self.rear_axle), f_z, m_theta)
    }

    /// The model's axle forces (N, up positive) for axle displacements `x_f`, `x_r` (m) and
    /// speed `v` (m/s).
    pub fn forces(&self, x_front: f32, x_rear: f32, speed: f32) -> [f32; 2] {
        AeroPrepared::new(self).forces(x_front, x_rear, speed)
    }
}

#[inline]
fn heave_pitch(p: &AeroParams, inv_wheelbase: f32, x_front: f32, x_rear: f32) -> [f32; 2] {
    [
        (p.rear_axle * x_front + p.front_axle * x_rear) * inv_wheelbase,
        (x_rear - x_front) * inv_wheelbase,
    ]
}

#[inline]
fn axle_forces(p: &AeroParams, inv_wheelbase: f32, f_z: f32, m_theta: f32) -> [f32; 2] {
    [
        (p.rear_axle * f_z - m_theta) * inv_wheelbase,
        (p.front_axle * f_z + m_theta) * inv_wheelbase,
    ]
}

/// Validated aero parameters with the reciprocals the step uses (no divisions at run time).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AeroPrepared {
    /// The parameters.
    pub params: AeroParams,
    /// `1 / v_ref` (s/m).
    pub inv_reference_speed: f32,
    /// `1 / (l_f + l_r)` (1/m).
    pub inv_wheelbase: f32,
}

impl AeroPrepared {
    fn new(params: &AeroParams) -> Self {
        Self {
            params: *params,
            inv_reference_speed: 1.0 / params.reference_speed,
            inv_wheelbase: 1.0 / (params.front_axle + params.rear_axle),
        }
    }

    /// Axle forces (N, up positive) for axle displacements `x_f`, `x_r` (m) and speed (m/s).
    #[inline]
    pub fn forces(&self, x_front: f32, x_rear: f32, speed: f32) -> [f32; 2] {
        let p = &self.params;
        let ratio = speed * self.inv_reference_speed;
        let q = ratio * ratio;
        if p.use_map == 1 {
            let (d_f, d_r) = p.map.down_force(
                p.map.static_front_height + x_front,
                p.map.static_rear_height + x_rear,
            );
            [-q * d_f, -q * d_r]
        } else {
            let [z, theta] = heave_pitch(p, self.inv_wheelbase, x_front, x_rear);
            let [[k11, k12], [k21, k22]] = p.stiffness;
            let [f_n, m_n] = p.nominal_force;
            let f_z = q * (k11 * z + k12 * theta + f_n);
            let m_theta = q * (k21 * z + k22 * theta + m_n);
            axle_forces(p, self.inv_wheelbase, f_z, m_theta)
        }
    }
}

/// The aerodynamic model (stateless: down force follows body position and speed at once).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AeroModel;

impl Model<2> for AeroModel {
    type Params = AeroParams;
    type Prepared = AeroPrepared;

    fn prepare(params: &Self::Params, dt: f32) -> Result<Self::Prepared, ParamError> {
        crate::params::check_sample_period(dt)?;
        params.validate()?;
        Ok(AeroPrepared::new(params))
    }

    fn new() -> Self {
        Self
    }

    fn reset(&mut self, _prepared: &Self::Prepared, _input: &ModelInput<2>) {}

    fn input_valid(input: &ModelInput<2>) -> bool {
        input.is_finite()
            && input.speed.abs() <= AERO_MAX_SPEED
            && input
                .position
                .iter()
                .all(|v| v.abs() <= AERO_MAX_DISPLACEMENT)
    }

    #[inline]
    fn step(&mut self, prepared: &Self::Prepared, input: &ModelInput<2>) -> [f32; 2] {
        let [x_front, x_rear] = input.position;
        prepared.forces(x_front, x_rear, input.speed)
    }

    fn is_finite(&self) -> bool {
        true
    }
}
