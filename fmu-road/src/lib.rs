//! The road FMU (`dist/road.fmu`): heights and vertical velocities under the four wheels, with
//! exactly the names of the plant's road inputs, from the profiles of [`vehicle::road`]. It has
//! no state but time: every output is a closed-form function of the time reached, so a step of
//! any size is exact and the FMU state is the time alone.
//!
//! The track width plays no part: the profiles are one-dimensional per track (left and right
//! independent or identical), so it is not a parameter.

use fmu_core::fmu_state::{StateReader, StateWriter};
use fmu_core::{
    Capabilities, Causality, DefaultExperiment, DiscreteUpdate, Model, ModelDescription,
    ModelError, ValueReference, Variable,
};
use std::path::Path;
use vehicle::model::CORNERS;
use vehicle::road::{Profile, Road, Side};
use vehicle::terrain::Terrain;

/// Value references: Real parameters from 0, Integer parameters from 100, Booleans from 200,
/// outputs from 300.
pub mod vr {
    pub const REAL: u32 = 0;
    pub const INTEGER: u32 = 100;
    pub const BOOLEAN: u32 = 200;
    pub const OUTPUT: u32 = 300;
}

/// A Real parameter of the road.
struct RealParameter {
    name: &'static str,
    unit: &'static str,
    start: f64,
    /// The plausible range, declared in the model description, where the runtime enforces it on
    /// every value set or restored: inside it every output is finite (the steepest velocity, a
    /// ramp of 100 m over 1 m at 100 m/s, is 10⁴ m/s).
    min: f64,
    max: f64,
    description: &'static str,
}

const fn real(
    name: &'static str,
    unit: &'static str,
    start: f64,
    [min, max]: [f64; 2],
    description: &'static str,
) -> RealParameter {
    RealParameter {
        name,
        unit,
        start,
        min,
        max,
        description,
    }
}

/// The Real parameters (validated together by `Road::new`, each against its range here).
const REALS: [RealParameter; N_REALS] = [
    real("speed", "m/s", 20.0, [0.1, 100.0], "Vehicle speed"),
    real("wheelbase", "m", 2.4, [0.5, 20.0], "Front-to-rear axle distance (the plant's L1 + L2): the rear wheels see the front track this much later"),
    real("start_distance", "m", 5.0, [-1e5, 1e5], "Distance from the front wheels at t = 0 to the start of the profile (negative: already on it)"),
    real("bump_height", "m", 0.05, [-1.0, 1.0], "profile 1: height of the 1 - cos bump"),
    real("bump_length", "m", 5.0, [0.01, 1e3], "profile 1: length of the bump"),
    real("sweep_amplitude", "m", 0.01, [-1.0, 1.0], "profile 3: amplitude of the sine sweep"),
    real("sweep_f_start", "Hz", 0.5, [0.01, 1e3], "profile 3: frequency at the start of the sweep (at the wheel, in time)"),
    real("sweep_f_end", "Hz", 20.0, [0.01, 1e3], "profile 3: frequency at the end of the sweep"),
    real("sweep_duration", "s", 10.0, [0.01, 1e5], "profile 3: duration of the linear sweep (half-cosine tapers of min(0.5 s, duration/4) at both ends)"),
    real("pothole_depth", "m", -0.05, [-1.0, 1.0], "profile 4: height of the step (negative: a pothole)"),
    real("pothole_length", "m", 0.6, [0.0, 1e4], "profile 4: length of the pothole, ramps included; 0 = a permanent step"),
    real("pothole_ramp", "m", 0.1, [0.001, 1e3], "profile 4: length of each half-cosine ramp"),
    real("fade_in", "s", 1.0, [0.0, 1e4], "profile 2: the random road is faded in over this time (the car starts at rest on a flat road)"),
    real("ramp_rise", "m", 0.0, [-100.0, 100.0], "Terrain under every profile: the road rises this much over ramp_length from the front wheels' position at t = 0 (a constant grade), then stays at that height (0 = none)"),
    real("ramp_length", "m", 100.0, [1.0, 1e5], "Terrain: length of the ramp"),
    real("hill_height", "m", 0.0, [0.0, 100.0], "Terrain: peak-to-peak height of periodic hills 1/2 h (1 - cos(2 pi d / hill_length)) from the front wheels' position at t = 0 (0 = none)"),
    real("hill_length", "m", 200.0, [10.0, 1e5], "Terrain: wavelength of the hills"),
    real("crossfall", "m", 0.0, [-1.0, 1.0], "Terrain: height of the left track above the right one (half each side of the centre line), reached with a half-cosine over crossfall_length from the front wheels' position at t = 0 (0 = none)"),
    real("crossfall_length", "m", 20.0, [1.0, 1e4], "Terrain: length over which the crossfall is reached"),
];
const N_REALS: usize = 19;

/// Integer parameters: name, start, description.
const INTEGERS: [(&str, i32, &str); 4] = [
    ("profile", 1, "1 = 1 - cos bump, 2 = ISO 8608 random road, 3 = sine sweep, 4 = pothole / step"),
    ("side", 0, "Profiles 1, 3, 4: 0 = left wheels, 1 = right wheels, 2 = both"),
    ("iso_class", 3, "Profile 2: ISO 8608 class, 1 = A … 8 = H (G_d(0.1 cycles/m) = 16, 64, 256, … , 262144 x 1e-6 m^3)"),
    ("seed", 1, "Profile 2: seed of the random phases (the same seed gives the same road everywhere)"),
];

use vehicle::model::ROAD_PORTS as OUTPUT_NAMES;

pub fn model_description() -> ModelDescription {
    let mut vars = Vec::new();
    for (i, p) in REALS.iter().enumerate() {
        vars.push(
            Variable::real(
                p.name,
                vr::REAL + i as u32,
                Causality::Parameter,
                p.unit,
                p.description,
            )
            .with_start(p.start)
            .with_min(p.min)
            .with_max(p.max),
        );
    }
    for (i, (name, start, desc)) in INTEGERS.iter().enumerate() {
        vars.push(Variable::integer(
            *name,
            vr::INTEGER + i as u32,
            Causality::Parameter,
            *start,
            *desc,
        ));
    }
    vars.push(
        Variable::boolean(
            "identical_tracks",
            vr::BOOLEAN,
            Causality::Parameter,
            "Profile 2: the right track is the left one (otherwise independent)",
        )
        .with_boolean_start(false),
    );
    // The road reads no inputs; at the start time each output depends on the whole profile.
    let parameters: Vec<String> = vars.iter().map(|v| v.name.clone()).collect();
    for (k, name) in OUTPUT_NAMES.iter().enumerate() {
        let c = CORNERS[k % 4].to_uppercase();
        let (unit, desc) = if k < 4 {
            ("m", format!("Road height under the {c} wheel"))
        } else {
            ("m/s", format!("Road vertical velocity under the {c} wheel (exact time derivative of road_z_{})", CORNERS[k % 4]))
        };
        vars.push(
            Variable::real(*name, vr::OUTPUT + k as u32, Causality::Output, unit, desc)
                .initially_depending_on(parameters.clone()),
        );
    }
    ModelDescription {
        model_name: "road".into(),
        model_identifier: "road".into(),
        guid: String::new(),
        description: "Road heights and vertical velocities under the four wheels: 1 - cos bump, ISO 8608 random road, sine sweep, pothole / step, on a terrain of grade, hills and crossfall; rear wheels on the front track one wheelbase later".into(),
        version: env!("CARGO_PKG_VERSION").into(),
        capabilities: Capabilities::exact_stepping(false),
        // Model Exchange too: no continuous state, the outputs functions of time, and the
        // times where one kinks time events (`Road::breakpoints`).
        model_exchange: Some(fmu_core::description::ModelExchange {
            number_of_event_indicators: 0,
            completed_integrator_step_not_needed: true,
        }),
        default_experiment: DefaultExperiment { start_time: 0.0, stop_time: 10.0, step_size: 1e-3, tolerance: 1e-6 },
        variables: vars,
        sample_clock: None,
        arrays: Vec::new(),
        terminals: Vec::new(),
    }
    .with_suspension_terminals()
    .with_derived_guid()
}

pub struct RoadFmu {
    reals: [f64; N_REALS],
    integers: [i32; 4],
    identical_tracks: bool,
    time: f64,
    /// Built when an output is first read in Initialization Mode or when initialisation ends,
    /// dropped when a parameter changes (they are fixed once initialisation has ended).
    road: Option<Road>,
    /// The outputs at `time`, computed once per communication point.
    outputs: Option<[f64; 8]>,
}

impl RoadFmu {
    fn real(&self, name: &str) -> f64 {
        self.reals[REALS
            .iter()
            .position(|r| r.name == name)
            .expect("known parameter")]
    }

    fn parameters_changed(&mut self) {
        self.road = None;
        self.outputs = None;
    }

    /// The road of the current parameters, or why they do not make one.
    pub fn build(&self) -> Result<Road, String> {
        let [profile, side, class, seed] = self.integers;
        let side = match side {
            0 => Side::Left,
            1 => Side::Right,
            2 => Side::Both,
            other => {
                return Err(format!(
                    "side must be 0 (left), 1 (right) or 2 (both), got {other}"
                ))
            }
        };
        let profile = match profile {
            1 => Profile::Bump { height: self.real("bump_height"), length: self.real("bump_length"), side },
            2 => {
                let class = u8::try_from(class).map_err(|_| format!("iso_class must be 1 (A) … 8 (H), got {class}"))?;
                let seed = u64::try_from(seed).map_err(|_| format!("seed must be >= 0, got {seed}"))?;
                Profile::Iso { class, seed, identical_tracks: self.identical_tracks, fade_in: self.real("fade_in") }
            }
            3 => Profile::SineSweep { amplitude: self.real("sweep_amplitude"), f_start: self.real("sweep_f_start"), f_end: self.real("sweep_f_end"), duration: self.real("sweep_duration"), side },
            4 => {
                // Never negative: its declared minimum 0, enforced by the runtime.
                let length = self.real("pothole_length");
                Profile::Pothole { depth: self.real("pothole_depth"), length: if length == 0.0 { f64::INFINITY } else { length }, ramp: self.real("pothole_ramp"), side }
            }
            other => return Err(format!("profile must be 1 (bump), 2 (ISO 8608), 3 (sine sweep) or 4 (pothole/step), got {other}")),
        };
        Road::new(
            profile,
            self.real("speed"),
            self.real("wheelbase"),
            self.real("start_distance"),
        )?
        .with_terrain(Terrain {
            ramp_rise: self.real("ramp_rise"),
            ramp_length: self.real("ramp_length"),
            hill_height: self.real("hill_height"),
            hill_length: self.real("hill_length"),
            crossfall: self.real("crossfall"),
            crossfall_length: self.real("crossfall_length"),
        })
    }
}

impl Model for RoadFmu {
    fn description(_resources: Option<&Path>) -> Result<ModelDescription, ModelError> {
        Ok(model_description())
    }

    fn instantiate(_resources: Option<&Path>) -> Result<Self, ModelError> {
        let mut reals = [0.0; N_REALS];
        for (slot, r) in reals.iter_mut().zip(&REALS) {
            *slot = r.start;
        }
        Ok(RoadFmu {
            reals,
            integers: INTEGERS.map(|i| i.1),
            identical_tracks: false,
            time: 0.0,
            road: None,
            outputs: None,
        })
    }

    fn set_real(&mut self, vr: ValueReference, value: f64) {
        if let Some(slot) = self.reals.get_mut((vr - vr::REAL) as usize) {
            *slot = value;
            self.parameters_changed();
        }
    }

    fn get_real(&mut self, vr: ValueReference) -> f64 {
        if vr >= vr::OUTPUT {
            // The runtime builds the road before any output is read (`prepare_initial_outputs`);
            // only a read outside the state machine's allowed states finds none: flat.
            let k = (vr - vr::OUTPUT) as usize;
            let Some(road) = &self.road else { return 0.0 };
            let time = self.time;
            return self.outputs.get_or_insert_with(|| road.at(time))[k];
        }
        self.reals[(vr - vr::REAL) as usize]
    }

    fn set_integer(&mut self, vr: ValueReference, value: i32) {
        if let Some(slot) = self.integers.get_mut((vr - vr::INTEGER) as usize) {
            *slot = value;
            self.parameters_changed();
        }
    }

    fn get_integer(&mut self, vr: ValueReference) -> i32 {
        self.integers[(vr - vr::INTEGER) as usize]
    }

    fn set_boolean(&mut self, _vr: ValueReference, value: bool) {
        self.identical_tracks = value;
        self.parameters_changed();
    }

    fn get_boolean(&mut self, _vr: ValueReference) -> bool {
        self.identical_tracks
    }

    fn check_parameters(&self) -> Result<(), ModelError> {
        match self.road {
            Some(_) => Ok(()),
            None => self.build().map(|_| ()).map_err(ModelError::from),
        }
    }

    fn prepare_initial_outputs(&mut self, start_time: f64) -> Result<(), ModelError> {
        if self.road.is_none() {
            self.road = Some(self.build()?);
        }
        if self.time.to_bits() != start_time.to_bits() {
            self.time = start_time;
            self.outputs = None;
        }
        Ok(())
    }

    /// The road read in Initialization Mode (kept: any parameter set since would have dropped it).
    fn exit_initialization(&mut self, start_time: f64) -> Result<(), ModelError> {
        self.prepare_initial_outputs(start_time)
    }

    fn do_step(&mut self, time: f64, step: f64) -> Result<(), ModelError> {
        self.time = time + step;
        self.outputs = None;
        Ok(())
    }

    fn check_model_exchange(&self) -> Result<(), ModelError> {
        Ok(())
    }

    fn set_time(&mut self, time: f64) {
        if self.time.to_bits() != time.to_bits() {
            self.time = time;
            self.outputs = None;
        }
    }

    /// The next breakpoint of the road after `time`: where a height or a velocity kinks.
    fn update_discrete_states(&mut self, time: f64) -> Result<DiscreteUpdate, ModelError> {
        self.set_time(time);
        let road = self
            .road
            .as_ref()
            .ok_or("the road is built at initialisation")?;
        Ok(DiscreteUpdate {
            states_changed: false,
            // Past the one just handled, which an integrator may have reached a rounding short.
            next_event_time: road
                .breakpoints()
                .into_iter()
                .find(|t| *t > time + 1e-12 * time.abs().max(1.0)),
        })
    }

    fn save(&self, out: &mut StateWriter) {
        out.f64s(&self.reals);
        out.f64s(&self.integers.map(f64::from));
        out.bool(self.identical_tracks);
        out.f64(self.time);
    }

    fn restore(&mut self, input: &mut StateReader) -> Result<(), ModelError> {
        let reals = input.f64s_exact(N_REALS, "road parameters")?;
        let integers = input.f64s_exact(4, "road integer parameters")?;
        let identical = input.bool()?;
        let time = input.f64()?;
        input.finish()?;
        let mut next = RoadFmu {
            reals: reals.try_into().expect("length checked"),
            integers: [0; 4],
            identical_tracks: identical,
            time,
            road: None,
            outputs: None,
        };
        for (slot, v) in next.integers.iter_mut().zip(&integers) {
            *slot = *v as i32;
        }
        // Saved before initialisation ended, the parameters need not make a road yet.
        next.road = next.build().ok();
        *self = next;
        Ok(())
    }
}

fmu_core::export_fmi2!(RoadFmu);
fmu_core::export_fmi3!(RoadFmu);
