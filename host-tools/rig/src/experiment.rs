//! The whole MiL experiment in one call: model-core's controller with a prepared parameter
//! set (the board), the rig built around its channels (the specimen on force-controlled
//! actuators, sensors and CAN links) and the emulated system beside it, run over the
//! inputs ([`run`]). `mil sim` describes the experiment from a set-up file and hands it
//! here; tests build it directly.

use crate::actuator::ForceActuator;
use crate::harness::{
    self, Board, HarnessError, Histories, Instrumentation, LinkStatistics, RigPart,
};
use crate::rigs::{
    aero_input_varying_speed, aero_static_demand, half_car_part_varying_speed, quarter_car_part,
    substructure_input, substructure_part, IdealAero,
};
use crate::specimen::{Specimen, SpecimenError, STATIC_DEMAND_TOLERANCE};
use mil_structure::Element;
use model_core::{AeroModel, Controller, PreparedParams, SubstructureModel, TyreModel};

/// The tyre board's channels (model-core's tyre model is sized for a car's four wheels).
pub const TYRE_CHANNELS: usize = 4;

/// A substructure's board parameters, by its number of channels (model-core sizes the
/// controller at compile time).
#[derive(Clone, Debug)]
pub enum PreparedSubstructure {
    /// One channel.
    One(Box<PreparedParams<SubstructureModel<1>, 1>>),
    /// Two channels.
    Two(Box<PreparedParams<SubstructureModel<2>, 2>>),
    /// Three channels.
    Three(Box<PreparedParams<SubstructureModel<3>, 3>>),
    /// Four channels.
    Four(Box<PreparedParams<SubstructureModel<4>, 4>>),
}

impl PreparedSubstructure {
    /// The number of channels.
    pub fn channels(&self) -> usize {
        match self {
            Self::One(_) => 1,
            Self::Two(_) => 2,
            Self::Three(_) => 3,
            Self::Four(_) => 4,
        }
    }
}

/// The specimen on the rig and the board's model for it: the paper's two vehicles or any
/// mass-spring-damper structure.
#[derive(Clone, Debug)]
pub enum Setting {
    /// The paper's tyre rig: [`TYRE_CHANNELS`] quarter cars, each hanging on its hub
    /// actuator, with a numerical tyre per wheel on the board. Input `c` is wheel `c`'s road
    /// (m); the rig starts at rest at the board's static tyre loads.
    QuarterCars {
        /// The board's tyre model.
        board: Box<PreparedParams<TyreModel<TYRE_CHANNELS>, TYRE_CHANNELS>>,
        /// One wheel's quarter car, its one attachment the hub (at rest when the hub
        /// actuator holds the board's static tyre load), on every wheel.
        specimen: Specimen,
        /// The emulated system's tyre (the law the board's tyre stands for).
        tyre: Element,
    },
    /// The paper's four-poster: a half car on front and rear down-force actuators with the
    /// aerodynamic model on the board. Inputs: front and rear road (m), then the speed (m/s)
    /// per sample, which the board reads per sample and the emulated aero model follows
    /// ramped between samples; the rig starts at rest at the first sample's speed.
    HalfCar {
        /// The board's aero model.
        board: Box<PreparedParams<AeroModel, 2>>,
        /// The half car: two attachments (front and rear axle) and two road inputs (front
        /// and rear post), at rest under the board's static down force at the first
        /// sample's speed ([`aero_static_demand`]).
        specimen: Specimen,
    },
    /// Any mass-spring-damper specimen on force-controlled actuators (one per attachment)
    /// with model-core's substructure model on the board (the paper's configuration 4).
    /// The model's road input of channel `c` is input `c`; the specimen's displacement
    /// inputs are the inputs `specimen_inputs`.
    Structure {
        /// The board's substructure model.
        board: PreparedSubstructure,
        /// The physical specimen, with one attachment per channel.
        specimen: Specimen,
        /// Which input drives each of the specimen's displacement inputs.
        specimen_inputs: Vec<usize>,
    },
}

impl Setting {
    /// The number of force-controlled channels.
    pub fn channels(&self) -> usize {
        match self {
            Self::QuarterCars { .. } => TYRE_CHANNELS,
            Self::HalfCar { .. } => 2,
            Self::Structure { board, .. } => board.channels(),
        }
    }

    /// The channels' names, as a rig engineer calls them.
    pub fn channel_names(&self) -> Vec<String> {
        match self {
            Self::QuarterCars { .. } => (0..TYRE_CHANNELS)
                .map(|c| format!("wheel {c} hub"))
                .collect(),
            Self::HalfCar { .. } => vec!["front axle".into(), "rear axle".into()],
            Self::Structure { board, .. } => (0..board.channels())
                .map(|c| format!("channel {c}"))
                .collect(),
        }
    }

    /// The board's parameter set that runs this setting's controller (see
    /// `model_core::board`): what a board is configured with to run the experiment.
    pub fn board_params(&self) -> model_core::BoardParams {
        use model_core::BoardParams;
        match self {
            Self::QuarterCars { board, .. } => BoardParams::of_tyres(board.params()),
            Self::HalfCar { board, .. } => BoardParams::of_aero(board.params()),
            Self::Structure { board, .. } => match board {
                PreparedSubstructure::One(p) => BoardParams::of_substructure(p.params()),
                PreparedSubstructure::Two(p) => BoardParams::of_substructure(p.params()),
                PreparedSubstructure::Three(p) => BoardParams::of_substructure(p.params()),
                PreparedSubstructure::Four(p) => BoardParams::of_substructure(p.params()),
            },
        }
    }

    /// The sample period the setting's controller was prepared for (s).
    pub fn dt(&self) -> f32 {
        match self {
            Self::QuarterCars { board, .. } => board.dt(),
            Self::HalfCar { board, .. } => board.dt(),
            Self::Structure { board, .. } => match board {
                PreparedSubstructure::One(p) => p.dt(),
                PreparedSubstructure::Two(p) => p.dt(),
                PreparedSubstructure::Three(p) => p.dt(),
                PreparedSubstructure::Four(p) => p.dt(),
            },
        }
    }

    /// The inputs' names, in the order [`Experiment::inputs`] holds them.
    pub fn input_names(&self) -> Vec<String> {
        match self {
            Self::HalfCar { .. } => vec!["road_front".into(), "road_rear".into(), "speed".into()],
            _ => (0..self.channels()).map(|c| format!("road_{c}")).collect(),
        }
    }
}

/// One MiL experiment: the setting, the actuators, the instrumentation, the rates and the
/// inputs.
#[derive(Clone, Debug)]
pub struct Experiment {
    /// The specimen and the board's model.
    pub setting: Setting,
    /// Every channel's actuator.
    pub actuator: ForceActuator,
    /// Sensors and CAN links.
    pub instrumentation: Instrumentation,
    /// The board's sample rate (Hz).
    pub sample_rate_hz: f64,
    /// The plants' RK4 step (s), at most the sample period.
    pub internal_step_s: f64,
    /// Per input ([`Setting::input_names`]) its samples, all equally long.
    pub inputs: Vec<Vec<f64>>,
    /// The road and the speed as the board receives them.
    pub board_view: BoardView,
}

/// How the board receives the road, the speed and the measurements and sends its demand:
/// e.g. as its CAN frames carry them (1 µm, 0.01 m/s, 0.1 N). Applied to what the board's controller is given, never to what the
/// specimens run on (a quantised road would step their velocities).
#[derive(Clone, Copy, Debug)]
pub struct BoardView {
    /// A road displacement (m) as the board receives it.
    pub road: fn(f64) -> f64,
    /// The speed (m/s) as the board receives it.
    pub speed: fn(f64) -> f64,
    /// The host controller's demand (N) as the board sends it (a board's own demand is
    /// what it sent).
    pub demand: fn(f64) -> f64,
    /// A measured position (m) as the board receives it (after the position link).
    pub position: fn(f64) -> f64,
    /// A measured force (N) as the board receives it (after the force link).
    pub force: fn(f64) -> f64,
}

impl Default for BoardView {
    /// As they are.
    fn default() -> Self {
        fn same(x: f64) -> f64 {
            x
        }
        Self {
            road: same,
            speed: same,
            demand: same,
            position: same,
            force: same,
        }
    }
}

impl BoardView {
    /// `input`, given the inputs as the board receives them (`speed`: the index of the speed
    /// among the inputs, if there is one; the others are roads).
    fn wrap<const CH: usize>(
        self,
        speed: Option<usize>,
        input: impl Fn(&[f64; CH], &[f64; CH], &[f64], usize) -> model_core::ModelInput<CH>,
    ) -> impl Fn(&[f64; CH], &[f64; CH], &[f64], usize) -> model_core::ModelInput<CH> {
        move |position, force, inputs, k| {
            let view = |(i, &x): (usize, &f64)| {
                if Some(i) == speed {
                    (self.speed)(x)
                } else {
                    (self.road)(x)
                }
            };
            let position = position.map(self.position);
            let force = force.map(self.force);
            // The inputs on the stack where they fit (every setting has at most 4).
            let mut buffer = [0.0; 8];
            if let Some(seen) = buffer.get_mut(..inputs.len()) {
                for (s, x) in seen.iter_mut().zip(inputs.iter().enumerate().map(view)) {
                    *s = x;
                }
                input(&position, &force, seen, k)
            } else {
                let seen: Vec<f64> = inputs.iter().enumerate().map(view).collect();
                input(&position, &force, &seen, k)
            }
        }
    }
}

/// What an experiment yields.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// The MiL and emulated histories, per sample.
    pub histories: Histories,
    /// The CAN links' statistics.
    pub links: LinkStatistics,
    /// The active sections of the board's command filter.
    pub filter_sections: usize,
}

/// Why an experiment could not run.
#[derive(Debug, thiserror::Error)]
pub enum ExperimentError {
    /// The specimen or its coupling to the board's model is invalid.
    #[error("{0}")]
    Specimen(#[from] SpecimenError),
    /// Sensors, links or the inputs' layout are invalid.
    #[error(transparent)]
    Harness(#[from] HarnessError),
}

/// Runs `experiment`: builds the rig and the emulated system around the board's channels,
/// starts the board, and steps them over every sample of the inputs. `progress` gets the
/// fraction done now and then.
///
/// # Errors
/// An invalid specimen, a board model the rig cannot emulate, invalid sensors or links, or
/// inputs that do not fit the setting.
pub fn run(experiment: &Experiment, progress: impl FnMut(f64)) -> Result<Outcome, ExperimentError> {
    drive(experiment, None::<&mut NoBoard>, progress)
}

/// A board of every channel count the settings have (1 to 4): what [`run_on`] drives.
pub trait AnyBoard: Board<1> + Board<2> + Board<3> + Board<4> {}
impl<B: Board<1> + Board<2> + Board<3> + Board<4>> AnyBoard for B {}

/// As [`run`], with `board` in place of the host's controller: a board already configured
/// with [`Setting::board_params`] (e.g. the firmware in QEMU behind `mil-can`'s
/// `RemoteBoard`, which checks every demand against its own host mirror).
///
/// # Errors
/// As [`run`], and the board's own errors (a transport error, a timeout).
pub fn run_on<B: AnyBoard>(
    experiment: &Experiment,
    board: &mut B,
    progress: impl FnMut(f64),
) -> Result<Outcome, ExperimentError> {
    drive(experiment, Some(board), progress)
}

/// The board the harness drives: the caller's, or the host's own controller; its demands as
/// `BoardView::demand` has them (a board's own are already so).
struct Driven<'a, B, C> {
    board: Which<'a, B, C>,
    demand: fn(f64) -> f64,
}

enum Which<'a, B, C> {
    Remote(&'a mut B),
    Host(C),
}

impl<B: Board<CH>, C: Board<CH>, const CH: usize> Board<CH> for Driven<'_, B, C> {
    fn start(&mut self) -> Result<(), String> {
        match &mut self.board {
            Which::Remote(b) => b.start(),
            Which::Host(c) => c.start(),
        }
    }

    fn step(&mut self, input: &model_core::ModelInput<CH>) -> Result<[f32; CH], String> {
        let demand = match &mut self.board {
            Which::Remote(b) => b.step(input)?,
            Which::Host(c) => c.step(input)?,
        };
        Ok(demand.map(|x| (self.demand)(f64::from(x)) as f32))
    }

    fn status(&self) -> model_core::Status {
        match &self.board {
            Which::Remote(b) => b.status(),
            Which::Host(c) => c.status(),
        }
    }
}

/// No board: [`run`] builds the host's controller.
enum NoBoard {}

impl<const CH: usize> Board<CH> for NoBoard {
    fn start(&mut self) -> Result<(), String> {
        match *self {}
    }

    fn step(&mut self, _: &model_core::ModelInput<CH>) -> Result<[f32; CH], String> {
        match *self {}
    }

    fn status(&self) -> model_core::Status {
        match *self {}
    }
}

fn drive<B: AnyBoard>(
    experiment: &Experiment,
    mut remote: Option<&mut B>,
    progress: impl FnMut(f64),
) -> Result<Outcome, ExperimentError> {
    let Experiment {
        setting,
        actuator,
        instrumentation,
        sample_rate_hz: fs,
        internal_step_s: step,
        inputs,
        board_view,
    } = experiment;
    let expected = setting.input_names().len();
    if matches!(setting, Setting::HalfCar { .. }) && inputs.len() != expected {
        return Err(HarnessError::Layout(format!(
            "the half car needs {expected} inputs (front road, rear road, speed), got {}",
            inputs.len()
        ))
        .into());
    }
    match setting {
        Setting::QuarterCars {
            board,
            specimen,
            tyre,
        } => {
            let initial = board.params().model.tyre.map(|t| f64::from(t.static_load));
            for load in initial {
                specimen.check_near_rest(&[load], STATIC_DEMAND_TOLERANCE)?;
            }
            let mut parts = (0..TYRE_CHANNELS)
                .map(|c| quarter_car_part(specimen.clone(), *actuator, tyre.clone(), c, c, *step))
                .collect::<Result<Vec<RigPart>, _>>()?;
            on_board(
                board,
                remote.as_deref_mut(),
                &mut parts,
                instrumentation,
                *fs,
                inputs,
                &initial,
                substructure_input(std::array::from_fn(|c| c)),
                (*board_view, None),
                progress,
            )
        }
        Setting::HalfCar { board, specimen } => {
            let params = board.params().model;
            let start = inputs
                .get(2)
                .and_then(|speed| speed.first())
                .copied()
                .unwrap_or_else(|| f64::from(params.reference_speed));
            let mut parts = vec![half_car_part_varying_speed(
                specimen.clone(),
                *actuator,
                IdealAero::new(params, start),
                0,
                [0, 1],
                2,
                *step,
            )?];
            on_board(
                board,
                remote.as_deref_mut(),
                &mut parts,
                instrumentation,
                *fs,
                inputs,
                &aero_static_demand(&params, start),
                aero_input_varying_speed(2),
                (*board_view, Some(2)),
                progress,
            )
        }
        Setting::Structure {
            board,
            specimen,
            specimen_inputs,
        } => {
            let rig = StructureRig {
                remote,
                specimen,
                specimen_inputs,
                actuator: *actuator,
                instrumentation,
                fs: *fs,
                step: *step,
                inputs,
                board_view: *board_view,
            };
            match board {
                PreparedSubstructure::One(p) => structure(p, rig, progress),
                PreparedSubstructure::Two(p) => structure(p, rig, progress),
                PreparedSubstructure::Three(p) => structure(p, rig, progress),
                PreparedSubstructure::Four(p) => structure(p, rig, progress),
            }
        }
    }
}

/// A structure run's rig, whatever the board's number of channels.
struct StructureRig<'a, B> {
    remote: Option<&'a mut B>,
    specimen: &'a Specimen,
    specimen_inputs: &'a [usize],
    actuator: ForceActuator,
    instrumentation: &'a Instrumentation,
    fs: f64,
    step: f64,
    inputs: &'a [Vec<f64>],
    board_view: BoardView,
}

/// A structure on `CH` actuators with model-core's substructure model on the board.
fn structure<B: Board<CH>, const CH: usize>(
    board: &PreparedParams<SubstructureModel<CH>, CH>,
    rig: StructureRig<'_, B>,
    progress: impl FnMut(f64),
) -> Result<Outcome, ExperimentError> {
    let model_roads: [usize; CH] = std::array::from_fn(|c| c);
    let mut parts = vec![substructure_part(
        rig.specimen.clone(),
        vec![rig.actuator; CH],
        &board.params().model,
        0,
        rig.specimen_inputs,
        model_roads,
        rig.step,
    )?];
    on_board(
        board,
        rig.remote,
        &mut parts,
        rig.instrumentation,
        rig.fs,
        rig.inputs,
        &[0.0; CH],
        substructure_input(model_roads),
        (rig.board_view, None),
        progress,
    )
}

/// Starts model-core's controller with `board` and runs it against `parts`, the board seeing
/// the inputs as `view` says (`speed`: the speed's index among them).
#[allow(clippy::too_many_arguments)]
fn on_board<M: model_core::Model<CH>, B: Board<CH>, const CH: usize>(
    board: &PreparedParams<M, CH>,
    remote: Option<&mut B>,
    parts: &mut [RigPart],
    instrumentation: &Instrumentation,
    fs: f64,
    inputs: &[Vec<f64>],
    initial_demand: &[f64; CH],
    input: impl Fn(&[f64; CH], &[f64; CH], &[f64], usize) -> model_core::ModelInput<CH>,
    (view, speed): (BoardView, Option<usize>),
    progress: impl FnMut(f64),
) -> Result<Outcome, ExperimentError>
where
    PreparedParams<M, CH>: Clone,
{
    let input = view.wrap(speed, input);
    let filter_sections = board
        .params()
        .filter
        .first()
        .map_or(0, |f| f.active().len());
    let mut driven = Driven {
        board: match remote {
            Some(remote) => Which::Remote(remote),
            None => Which::Host(Controller::new(board.clone())),
        },
        demand: view.demand,
    };
    let (histories, links) = harness::run(
        &mut driven,
        parts,
        instrumentation,
        fs,
        inputs,
        initial_demand,
        input,
        progress,
    )?;
    Ok(Outcome {
        histories,
        links,
        filter_sections,
    })
}
