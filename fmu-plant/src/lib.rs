//! The plant FMU (`dist/plant.fmu`): the 8-DOF full car with driver seat of the `vehicle` crate
//! and its actuators, as an FMI 2.0 Co-Simulation slave (SPEC §2).
//!
//! This file is the FMI face only: the variable table (the single source of truth for
//! `modelDescription.xml`) and the mapping of value references to the [`Simulator`].
//! The physics is in `vehicle`, the exact stepping in [`simulator`].

pub mod sensors;
pub mod simulator;

use fmu_core::fmu_state::{StateReader, StateWriter};
use fmu_core::{
    Capabilities, Causality, DefaultExperiment, DependencyKind, DiscreteUpdate, Model,
    ModelDescription, ModelError, ValueReference, Variable,
};
use sensors::{SensorParams, Sensors, N_SENSORS, SENSORS};
use simulator::{
    derivative_dependencies, model_exchange_states, ActuatorParams, ContactState, Simulator,
    N_METER,
};
use std::path::Path;
use vehicle::contact::{ContactParams, N_UNILATERAL};
use vehicle::iso2631::METER_OUTPUTS;
use vehicle::model::{
    physical_outputs, StaticEquilibrium, ACTUATORS, CORNERS, FORCE_PORTS, N_ACTUATORS,
    N_PHYSICAL_OUTPUTS, N_ROAD, N_STATES, ROAD_PORTS, STATES,
};
use vehicle::params::PARAMETERS;
use vehicle::VehicleParams;

/// Value-reference ranges, one per kind of variable.
pub mod vr {
    /// Vehicle parameters, in the order of `vehicle::params::PARAMETERS`.
    pub const VEHICLE: u32 = 0;
    /// Actuator parameters, in the order of `ACTUATOR_PARAMETERS`.
    pub const ACTUATOR: u32 = 20;
    /// Calculated static values.
    pub const STATIC: u32 = 40;
    /// Inputs: `road_z_*`, `road_v_*`, `u_*`.
    pub const INPUT: u32 = 100;
    /// `x[1]`…`x[16]`.
    pub const STATE: u32 = 200;
    /// Physical outputs, in the order of `vehicle::model::physical_outputs`.
    pub const OUTPUT: u32 = 300;
    /// `f_*`: forces actually applied.
    pub const FORCE: u32 = 400;
    /// The vibration meter's weighted accelerations, in the order of
    /// `vehicle::iso2631::METER_OUTPUTS`.
    pub const METER: u32 = 450;
    /// The sensor model's Real parameters, in the order of `SENSOR_PARAMETERS`.
    pub const SENSOR: u32 = 60;
    /// The Boolean `sensor_model` and the Integer `sensor_seed`.
    pub const SENSOR_SWITCH: u32 = 70;
    pub const SENSOR_SEED: u32 = 71;
    /// `sensor_*`: what the sensors read, in the order of `sensors::SENSORS`.
    pub const SENSOR_OUTPUT: u32 = 500;
    /// The contact and stop parameters, in the order of `CONTACT_PARAMETERS`.
    pub const CONTACT: u32 = 80;
    /// The Boolean `contact_model`.
    pub const CONTACT_SWITCH: u32 = 90;
    /// Tyre forces, stop forces, time airborne and at a stop (`CONTACT_OUTPUTS`).
    pub const CONTACT_OUTPUT: u32 = 600;
    /// The Booleans `on_road_*`.
    pub const ON_ROAD: u32 = 630;
    /// Model Exchange: `der(x[1])`…`der(x[16])`.
    pub const STATE_DERIVATIVE: u32 = 700;
    /// Model Exchange: the actuator-lag states `f_lag_*`, then their derivatives.
    pub const LAG_STATE: u32 = 730;
    pub const LAG_DERIVATIVE: u32 = 740;
    /// Model Exchange: the vibration meter's filter states `meter_state[*]`, then their
    /// derivatives.
    pub const METER_STATE: u32 = 750;
    pub const METER_DERIVATIVE: u32 = 800;
}

/// Number of the vibration meter's filter states (`ComfortMeter::order()`, checked by a test):
/// the value-reference blocks are sized at compile time.
const N_METER_STATES: usize = 20;

/// Every block of value references with the number of variables it holds. A block that
/// outgrows the room before the next (a 21st vehicle parameter, say) fails the build
/// ([`blocks_are_disjoint`], evaluated at compile time) instead of colliding at run time.
const VR_BLOCKS: [(&str, u32, usize); 21] = [
    ("contact parameters", vr::CONTACT, CONTACT_PARAMETERS.len()),
    ("contact_model", vr::CONTACT_SWITCH, 1),
    ("contact outputs", vr::CONTACT_OUTPUT, N_CONTACT_OUTPUTS),
    ("on_road", vr::ON_ROAD, 4),
    ("vehicle parameters", vr::VEHICLE, PARAMETERS.len()),
    (
        "actuator parameters",
        vr::ACTUATOR,
        ACTUATOR_PARAMETERS.len(),
    ),
    ("static values", vr::STATIC, N_STATIC),
    ("sensor parameters", vr::SENSOR, SENSOR_PARAMETERS.len()),
    ("sensor_model", vr::SENSOR_SWITCH, 1),
    ("sensor_seed", vr::SENSOR_SEED, 1),
    ("inputs", vr::INPUT, N_ROAD + N_ACTUATORS),
    ("states", vr::STATE, vehicle::model::N_STATES),
    ("physical outputs", vr::OUTPUT, N_PHYSICAL_OUTPUTS),
    ("applied forces", vr::FORCE, N_ACTUATORS),
    ("meter outputs", vr::METER, N_METER),
    ("sensor outputs", vr::SENSOR_OUTPUT, N_SENSORS),
    (
        "state derivatives",
        vr::STATE_DERIVATIVE,
        vehicle::model::N_STATES,
    ),
    ("actuator-lag states", vr::LAG_STATE, N_ACTUATORS),
    ("actuator-lag derivatives", vr::LAG_DERIVATIVE, N_ACTUATORS),
    ("meter states", vr::METER_STATE, N_METER_STATES),
    (
        "meter state derivatives",
        vr::METER_DERIVATIVE,
        N_METER_STATES,
    ),
];

/// No two blocks of [`VR_BLOCKS`] share a value reference.
const fn blocks_are_disjoint(blocks: &[(&str, u32, usize)]) -> bool {
    let mut i = 0;
    while i < blocks.len() {
        let mut j = 0;
        while j < blocks.len() {
            let (a, b) = (blocks[i], blocks[j]);
            if i != j && a.1 <= b.1 && b.1 < a.1 + a.2 as u32 {
                return false;
            }
            j += 1;
        }
        i += 1;
    }
    true
}

const _: () = assert!(
    blocks_are_disjoint(&VR_BLOCKS),
    "two blocks of the plant's value references overlap: move one (vr) or shrink it"
);

/// The sensor model's Real parameters (`sensors`): noise and bias per kind of sensor, each
/// from 0 to a bound well above any production sensor's.
const SENSOR_PARAMETERS: [SensorSpec; 5] = [
    SensorSpec {
        name: "noise_height",
        unit: "m",
        min: 0.0,
        max: Some(0.01),
        description: "Sensor model: resolution of the height (stroke) sensors, standard deviation of each sample",
        get: |p| p.noise_height,
        set: |p, v| p.noise_height = v,
    },
    SensorSpec {
        name: "noise_acceleration",
        unit: "m/s2/sqrt(Hz)",
        min: 0.0,
        max: Some(1.0),
        description: "Sensor model: noise density of the accelerometers (one-sided; a sample held over a step h has standard deviation noise / sqrt(2 h))",
        get: |p| p.noise_acceleration,
        set: |p, v| p.noise_acceleration = v,
    },
    SensorSpec {
        name: "noise_rate",
        unit: "rad/s/sqrt(Hz)",
        min: 0.0,
        max: Some(0.1),
        description: "Sensor model: noise density of the roll and pitch rate gyros (one-sided)",
        get: |p| p.noise_rate,
        set: |p, v| p.noise_rate = v,
    },
    SensorSpec {
        name: "bias_acceleration",
        unit: "m/s2",
        min: 0.0,
        max: Some(10.0),
        description: "Sensor model: largest accelerometer bias; each accelerometer's is drawn uniform in [-bias, bias] from sensor_seed",
        get: |p| p.bias_acceleration,
        set: |p, v| p.bias_acceleration = v,
    },
    SensorSpec {
        name: "bias_rate",
        unit: "rad/s",
        min: 0.0,
        max: Some(1.0),
        description: "Sensor model: largest gyro bias; each gyro's is drawn uniform in [-bias, bias] from sensor_seed",
        get: |p| p.bias_rate,
        set: |p, v| p.bias_rate = v,
    },
];

fn contact_param(vr: ValueReference) -> Option<&'static ContactSpec> {
    vr.checked_sub(vr::CONTACT)
        .and_then(|i| CONTACT_PARAMETERS.get(i as usize))
}

/// Number of Real contact outputs: tyre forces (4), stop forces (5), time airborne (4), time
/// at a stop (5).
const N_CONTACT_OUTPUTS: usize = 18;

/// Name, unit and description of each Real contact output, in value-reference order.
fn contact_outputs() -> Vec<(String, &'static str, String)> {
    let mut v = Vec::new();
    let places: Vec<(String, String)> = CORNERS
        .iter()
        .map(|c| (c.to_string(), c.to_uppercase()))
        .chain([("seat".to_string(), "seat".to_string())])
        .collect();
    for (c, upper) in &places[..4] {
        v.push((format!("tire_force_{c}"), "N", format!("Whole load of the {upper} tyre on the road, static part included (0 while the wheel is in the air; the linear car's may go negative)")));
    }
    for row in vehicle::model::stop_force_rows() {
        v.push((row.name, row.unit, row.description));
    }
    for (c, upper) in &places[..4] {
        v.push((
            format!("airborne_time_{c}"),
            "s",
            format!("Time the {upper} wheel has spent off the road since the start"),
        ));
    }
    for (c, upper) in &places {
        v.push((
            format!("stop_time_{c}"),
            "s",
            format!(
                "Time the {upper} suspension has spent on a stop (bump or rebound) since the start"
            ),
        ));
    }
    assert_eq!(v.len(), N_CONTACT_OUTPUTS);
    v
}

fn contact_values(c: &ContactState) -> [f64; N_CONTACT_OUTPUTS] {
    let mut v = [0.0; N_CONTACT_OUTPUTS];
    v[..4].copy_from_slice(&c.tyre_force);
    v[4..9].copy_from_slice(&c.stop_force);
    v[9..13].copy_from_slice(&c.dwell.airborne);
    v[13..].copy_from_slice(&c.dwell.at_stop);
    v
}

fn sensor_param(vr: ValueReference) -> Option<&'static SensorSpec> {
    vr.checked_sub(vr::SENSOR)
        .and_then(|i| SENSOR_PARAMETERS.get(i as usize))
}

/// The index among the physical outputs of what each sensor measures.
fn sensor_rows() -> [usize; N_SENSORS] {
    let rows = physical_outputs(&VehicleParams::default());
    SENSORS.map(|(name, _)| {
        rows.iter()
            .position(|r| r.name == name)
            .expect("every sensor measures a physical output")
    })
}

/// A Real parameter of a part of the plant `P` (its actuators, its sensors): its variable and
/// how to read and write it. The runtime enforces the declared `min` and `max`.
struct ParamSpec<P> {
    name: &'static str,
    unit: &'static str,
    description: &'static str,
    min: f64,
    max: Option<f64>,
    get: fn(&P) -> f64,
    set: fn(&mut P, f64),
}

impl<P> ParamSpec<P> {
    /// The parameter's variable, with its start value from `defaults`.
    fn variable(&self, value_reference: ValueReference, defaults: &P) -> Variable {
        let mut v = Variable::real(
            self.name,
            value_reference,
            Causality::Parameter,
            self.unit,
            self.description,
        )
        .with_start((self.get)(defaults));
        if self.min.is_finite() {
            v = v.with_min(self.min);
        }
        if let Some(m) = self.max {
            v = v.with_max(m);
        }
        v
    }
}

type ActuatorSpec = ParamSpec<ActuatorParams>;
type SensorSpec = ParamSpec<SensorParams>;
type ContactSpec = ParamSpec<ContactParams>;

macro_rules! spec {
    ($name:literal, $unit:literal, $min:expr, $max:expr, $desc:literal, |$p:ident| $field:expr) => {
        ParamSpec {
            name: $name,
            unit: $unit,
            description: $desc,
            min: $min,
            max: $max,
            get: |$p| $field,
            set: |$p, v| $field = v,
        }
    };
}

/// Actuator parameters (SPEC §2): limits, delay, bandwidth and the fault profile.
const ACTUATOR_PARAMETERS: [ActuatorSpec; 10] = [
    spec!(
        "u_max",
        "N",
        0.0,
        None,
        "Force limit of each corner actuator (saturation; 0 = the actuator gives no force)",
        |p| p.u_max
    ),
    spec!(
        "u_max_seat",
        "N",
        0.0,
        None,
        "Force limit of the seat actuator (saturation; 0 = the actuator gives no force)",
        |p| p.u_max_seat
    ),
    spec!(
        "tau",
        "s",
        0.0,
        Some(1.0),
        "Transport delay between force command and actuator (0 = none)",
        |p| p.tau
    ),
    spec!(
        "actuator_bandwidth",
        "Hz",
        0.0,
        Some(1e5),
        "Bandwidth of the first-order actuator lag (0 = ideal actuator)",
        |p| p.bandwidth
    ),
    spec!(
        "fault_time",
        "s",
        f64::NEG_INFINITY,
        None,
        "Time at which the actuator faults start (thesis fig. 8.2)",
        |p| p.fault_time
    ),
    spec!(
        "fault_loss_fl",
        "1",
        0.0,
        Some(1.0),
        "Loss of effectiveness of the FL actuator after fault_time (0 = healthy, 1 = dead)",
        |p| p.fault_loss[0]
    ),
    spec!(
        "fault_loss_fr",
        "1",
        0.0,
        Some(1.0),
        "Loss of effectiveness of the FR actuator after fault_time",
        |p| p.fault_loss[1]
    ),
    spec!(
        "fault_loss_rl",
        "1",
        0.0,
        Some(1.0),
        "Loss of effectiveness of the RL actuator after fault_time",
        |p| p.fault_loss[2]
    ),
    spec!(
        "fault_loss_rr",
        "1",
        0.0,
        Some(1.0),
        "Loss of effectiveness of the RR actuator after fault_time",
        |p| p.fault_loss[3]
    ),
    spec!(
        "fault_loss_seat",
        "1",
        0.0,
        Some(1.0),
        "Loss of effectiveness of the seat actuator after fault_time",
        |p| p.fault_loss[4]
    ),
];

/// The stops' Real parameters (`vehicle::contact::ContactParams`).
const CONTACT_PARAMETERS: [ContactSpec; 7] = [
    spec!(
        "bump_travel",
        "m",
        0.0,
        Some(1.0),
        "Free travel of each corner in bump (compression) from its static position before the bump stop engages",
        |p| p.bump_travel
    ),
    spec!(
        "rebound_travel",
        "m",
        0.0,
        Some(1.0),
        "Free travel of each corner in rebound (extension) from its static position before the rebound stop engages",
        |p| p.rebound_travel
    ),
    spec!(
        "stop_stiffness",
        "N/m",
        0.0,
        Some(1e9),
        "Stiffness of each corner's bump and rebound stop",
        |p| p.stop_stiffness
    ),
    spec!(
        "stop_damping",
        "N.s/m",
        0.0,
        Some(1e7),
        "Damping of each corner's bump and rebound stop",
        |p| p.stop_damping
    ),
    spec!(
        "seat_travel",
        "m",
        0.0,
        Some(1.0),
        "Free travel of the seat each way from its static position before an end stop engages",
        |p| p.seat_travel
    ),
    spec!(
        "seat_stop_stiffness",
        "N/m",
        0.0,
        Some(1e9),
        "Stiffness of each seat end stop",
        |p| p.seat_stop_stiffness
    ),
    spec!(
        "seat_stop_damping",
        "N.s/m",
        0.0,
        Some(1e7),
        "Damping of each seat end stop",
        |p| p.seat_stop_damping
    ),
];

/// Names of the 13 inputs in value-reference order.
pub fn input_names() -> Vec<String> {
    ROAD_PORTS
        .iter()
        .chain(&FORCE_PORTS)
        .map(|s| s.to_string())
        .collect()
}

const N_STATIC: usize = 13;

fn static_values(s: &StaticEquilibrium) -> [f64; N_STATIC] {
    let mut v = [0.0; N_STATIC];
    v[..4].copy_from_slice(&s.stroke);
    v[4] = s.stroke_seat;
    v[5..9].copy_from_slice(&s.tire_defl);
    v[9..].copy_from_slice(&s.tire_load);
    v
}

/// The parameters of actuator `j`'s chain from command to force.
fn actuator_parameters(j: usize) -> Vec<String> {
    let limit = if j < 4 { "u_max" } else { "u_max_seat" };
    [limit, "tau", "actuator_bandwidth", "fault_time"]
        .iter()
        .map(|s| s.to_string())
        .chain([format!("fault_loss_{}", ACTUATORS[j])])
        .collect()
}

/// For each physical output, the vehicle parameters its feed-through matrices `D_r`, `D_u`
/// depend on. The matrices are built numerically from the mechanics, so each parameter is moved
/// by 1 % in turn and the row compared: a rational function of the parameters that depends on
/// one moves with it.
fn feedthrough_parameters(p: &VehicleParams) -> Vec<Vec<String>> {
    let feedthrough = |p: &VehicleParams| -> Vec<Vec<f64>> {
        physical_outputs(p)
            .iter()
            .map(|r| r.d_r.iter().chain(&r.d_u).copied().collect())
            .collect()
    };
    let base = feedthrough(p);
    let mut deps = vec![Vec::new(); base.len()];
    for s in PARAMETERS.iter() {
        let mut moved = *p;
        (s.set)(&mut moved, (s.get)(p) * 1.01 + 1e-3);
        for (k, row) in feedthrough(&moved).iter().enumerate() {
            if row != &base[k] {
                deps[k].push(s.name.to_string());
            }
        }
    }
    deps
}

fn static_variables() -> Vec<Variable> {
    let mut v = Vec::new();
    let mut push = |name: String, unit, desc: String| {
        let vr = vr::STATIC + v.len() as u32;
        v.push(Variable::real(
            name,
            vr,
            Causality::CalculatedParameter,
            unit,
            desc,
        ));
    };
    for c in CORNERS {
        push(
            format!("static_stroke_{c}"),
            "m",
            format!(
                "Suspension stroke {} at static equilibrium under gravity (negative = compressed)",
                c.to_uppercase()
            ),
        );
    }
    push(
        "static_stroke_seat".into(),
        "m",
        "Seat stroke at static equilibrium under gravity".into(),
    );
    for c in CORNERS {
        push(
            format!("static_tire_defl_{c}"),
            "m",
            format!(
                "Tyre deflection {} at static equilibrium (negative = compressed)",
                c.to_uppercase()
            ),
        );
    }
    for c in CORNERS {
        push(
            format!("static_tire_load_{c}"),
            "N",
            format!("Tyre load {} at static equilibrium", c.to_uppercase()),
        );
    }
    v
}

/// The physical car's parameters and outputs: the stops, the switch back to the linear car,
/// each tyre's load and whether it is on the road, the stop forces, the time airborne and at
/// a stop.
fn contact_variables() -> Vec<Variable> {
    let defaults = ContactParams::default();
    let mut vars: Vec<Variable> = CONTACT_PARAMETERS
        .iter()
        .enumerate()
        .map(|(i, s)| s.variable(vr::CONTACT + i as u32, &defaults))
        .collect();
    vars.push(
        Variable::boolean(
            "contact_model",
            vr::CONTACT_SWITCH,
            Causality::Parameter,
            "The physical car: tyres leave the road, the suspensions and the seat hit their stops (off: the linear car of the thesis, whose tyres pull on the road and whose travel has no end)",
        )
        .with_boolean_start(defaults.physical),
    );
    // At the start every stroke is at its static value, so no stop is engaged whatever the
    // parameters (the stop forces depend on none); a tyre's load is its static load (the
    // static equilibrium's parameters, as `static_tire_load_*`), moved by its road's height
    // and, through the tyre's damping, velocity, and zero above the road unless the car is the
    // linear one.
    let tyre: Vec<String> = PARAMETERS
        .iter()
        .filter(|s| !matches!(s.unit, "N.s/m" | "kg.m2") || s.name == "c_t")
        .map(|s| s.name.to_string())
        .chain(["contact_model".to_string()])
        .collect();
    let road = |c: &str| vec![format!("road_z_{c}"), format!("road_v_{c}")];
    for (k, (name, unit, description)) in contact_outputs().into_iter().enumerate() {
        let mut v = Variable::real(
            name,
            vr::CONTACT_OUTPUT + k as u32,
            Causality::Output,
            unit,
            description,
        );
        if k < 4 {
            v = v
                .depending_on(road(CORNERS[k]), DependencyKind::Dependent)
                .initially_depending_on(tyre.clone());
        }
        vars.push(v);
    }
    for (i, c) in CORNERS.iter().enumerate() {
        vars.push(
            Variable::boolean(
                format!("on_road_{c}"),
                vr::ON_ROAD + i as u32,
                Causality::Output,
                format!(
                    "Whether the {} tyre touches the road (always, in the linear car)",
                    c.to_uppercase()
                ),
            )
            .depending_on(road(c), DependencyKind::Dependent)
            .initially_depending_on(tyre.clone()),
        );
    }
    vars
}

/// Model Exchange's continuous states beyond the outputs `x[*]` (the actuator lags, the
/// vibration meter's filters) and every state's derivative, in the order of
/// [`Simulator::exchange_states`]. `vars` holds the `x[*]` already.
fn model_exchange_variables(vars: &[Variable]) -> Vec<Variable> {
    let dependencies = derivative_dependencies();
    let inputs = input_names();
    // At initialisation a derivative reads the inputs through the car's matrices, the actuator
    // model and the contacts: every parameter of them may move it.
    let parameters: Vec<String> = PARAMETERS
        .iter()
        .map(|s| s.name.to_string())
        .chain(ACTUATOR_PARAMETERS.iter().map(|s| s.name.to_string()))
        .chain(CONTACT_PARAMETERS.iter().map(|s| s.name.to_string()))
        .collect();
    let per_second = |unit: &str| match unit {
        "m" => "m/s",
        "m/s" => "m/s2",
        "rad" => "rad/s",
        "rad/s" => "rad/s2",
        "N" => "N/s",
        _ => "",
    };
    let mut states: Vec<Variable> = (0..STATES.len())
        .map(|k| {
            let vr = vr::STATE + k as u32;
            vars.iter()
                .find(|v| v.value_reference == vr)
                .expect("x[k] is in the table")
                .clone()
        })
        .collect();
    let mut locals = Vec::new();
    for (i, a) in ACTUATORS.iter().enumerate() {
        let v = Variable::real(
            format!("f_lag_{a}"),
            vr::LAG_STATE + i as u32,
            Causality::Local,
            "N",
            format!(
                "Model Exchange state: the {} actuator's force behind its first-order lag (unused, and constant, with actuator_bandwidth = 0)",
                a.to_uppercase()
            ),
        );
        states.push(v.clone());
        locals.push(v);
    }
    for k in 0..N_METER_STATES {
        let v = Variable::real(
            format!("meter_state[{}]", k + 1),
            vr::METER_STATE + k as u32,
            Causality::Local,
            "",
            "Model Exchange state: a state of the vibration meter's ISO 2631-1 weighting filters (W_k seat heave, then W_e roll and pitch)",
        );
        states.push(v.clone());
        locals.push(v);
    }
    for (k, state) in states.iter().enumerate() {
        let vr = if k < STATES.len() {
            vr::STATE_DERIVATIVE + k as u32
        } else if k < STATES.len() + N_ACTUATORS {
            vr::LAG_DERIVATIVE + (k - STATES.len()) as u32
        } else {
            vr::METER_DERIVATIVE + (k - STATES.len() - N_ACTUATORS) as u32
        };
        let unit = state.unit().map_or("", per_second);
        let (on_states, on_inputs) = &dependencies[k];
        let knowns = on_states
            .iter()
            .map(|&j| states[j].name.clone())
            .chain(on_inputs.iter().map(|&j| inputs[j].clone()))
            .collect();
        locals.push(
            Variable::derivative(
                state,
                vr,
                unit,
                format!("Time derivative of {}", state.name),
            )
            .depending_on(knowns, DependencyKind::Dependent)
            .initially_depending_on(parameters.clone()),
        );
    }
    locals
}

/// The plant as an FMI model.
pub struct Plant {
    sim: Simulator,
    /// The physical outputs, then the applied forces, for the current state and inputs
    /// (computed once per change, however many of them a master reads).
    outputs: Vec<f64>,
    forces: [f64; N_ACTUATORS],
    meter: [f64; N_METER],
    sensors: Sensors,
    /// The index among the physical outputs of what each sensor measures.
    sensor_rows: [usize; N_SENSORS],
    /// What the sensors read, with the outputs.
    readings: [f64; N_SENSORS],
    /// The tyres and stops now, with the outputs.
    contact: ContactState,
    outputs_valid: bool,
    /// Model Exchange: the time up to which the time off the road and at a stop is counted
    /// (the last accepted integrator step or event).
    accounted: f64,
    /// Model Exchange: whether the actuator fault has started (changed at its time event),
    /// and whether an event has been handled (only a Model Exchange instance has events).
    faulted: bool,
    exchanging: bool,
}

impl Plant {
    fn invalidate_outputs(&mut self) {
        self.outputs_valid = false;
    }

    /// Inlined into every read (the flag check), the computation not.
    #[inline(always)]
    fn update_outputs(&mut self) {
        if !self.outputs_valid {
            self.compute_outputs();
        }
    }

    #[inline(never)]
    fn compute_outputs(&mut self) {
        (self.forces, self.contact) = self.sim.physical_outputs(&mut self.outputs);
        self.meter = self.sim.meter();
        let truth = self.sensor_rows.map(|k| self.outputs[k]);
        self.readings = self.sensors.read(&truth);
        self.outputs_valid = true;
    }
}

impl Plant {
    /// The plant's variable table and metadata (it has no resources).
    pub fn model_description() -> ModelDescription {
        let defaults = VehicleParams::default();
        let act_defaults = ActuatorParams::default();
        let mut vars = parameter_variables(&defaults, &act_defaults);
        vars.extend(input_variables());
        vars.extend(STATES.iter().enumerate().map(|(k, (name, unit, desc))| {
            Variable::real(
                format!("x[{}]", k + 1),
                vr::STATE + k as u32,
                Causality::Output,
                unit,
                format!("State {name}: {desc}, from static equilibrium"),
            )
        }));
        vars.extend(model_exchange_variables(&vars));
        vars.extend(physical_output_variables(&defaults, act_defaults));
        vars.extend(force_variables());
        // States only (no input reaches them at once; zero at the start whatever the
        // parameters).
        vars.extend(
            METER_OUTPUTS
                .iter()
                .enumerate()
                .map(|(k, (name, _, unit, desc))| {
                    Variable::real(*name, vr::METER + k as u32, Causality::Output, unit, *desc)
                }),
        );
        let sensors = sensor_variables(&vars);
        vars.extend(sensors);
        vars.extend(contact_variables());
        ModelDescription {
            model_name: "plant".into(),
            model_identifier: "plant".into(),
            guid: String::new(),
            description: "8-DOF full car with driver seat and active suspension actuators (saturation, delay, bandwidth, faults), stepped exactly".into(),
            version: env!("CARGO_PKG_VERSION").into(),
            capabilities: Capabilities::exact_stepping(true).with_directional_derivatives(),
            default_experiment: DefaultExperiment { start_time: 0.0, stop_time: 10.0, step_size: 1e-3, tolerance: 1e-6 },
            variables: vars,
            model_exchange: Some(fmu_core::description::ModelExchange {
                number_of_event_indicators: N_UNILATERAL,
                completed_integrator_step_not_needed: false,
            }),
            sample_clock: None,
            arrays: Vec::new(),
            terminals: Vec::new(),
        }
        .with_suspension_terminals()
        .with_derived_guid()
    }
}

/// The parameters: the car's, the actuators', and the static equilibrium they make.
fn parameter_variables(defaults: &VehicleParams, act_defaults: &ActuatorParams) -> Vec<Variable> {
    let mut vars = Vec::new();
    for (i, s) in PARAMETERS.iter().enumerate() {
        let v = Variable::real(
            s.name,
            vr::VEHICLE + i as u32,
            Causality::Parameter,
            s.unit,
            s.description,
        )
        .with_start((s.get)(defaults))
        .with_min(s.admissible.min)
        .with_max(s.admissible.max);
        vars.push(v);
    }
    for (i, s) in ACTUATOR_PARAMETERS.iter().enumerate() {
        vars.push(s.variable(vr::ACTUATOR + i as u32, act_defaults));
    }
    // The static equilibrium depends on masses, springs, geometry and gravity, not on the
    // dampers or the inertias.
    let static_parameters: Vec<String> = PARAMETERS
        .iter()
        .filter(|s| !matches!(s.unit, "N.s/m" | "kg.m2"))
        .map(|s| s.name.to_string())
        .collect();
    vars.extend(
        static_variables()
            .into_iter()
            .map(|v| v.initially_depending_on(static_parameters.clone())),
    );
    vars
}

/// The road under each wheel and the commands.
fn input_variables() -> Vec<Variable> {
    let mut vars = Vec::new();
    for (i, name) in input_names().into_iter().enumerate() {
        let (unit, desc) = match i {
            0..4 => (
                "m",
                format!("Road height under the {} wheel", CORNERS[i].to_uppercase()),
            ),
            4..8 => (
                "m/s",
                format!(
                    "Road vertical velocity under the {} wheel (time derivative of road_z_{})",
                    CORNERS[i - 4].to_uppercase(),
                    CORNERS[i - 4]
                ),
            ),
            _ => (
                "N",
                format!(
                    "Force command of the {} actuator (positive extends it)",
                    ACTUATORS[i - 8].to_uppercase()
                ),
            ),
        };
        vars.push(
            Variable::real(name, vr::INPUT + i as u32, Causality::Input, unit, desc)
                .with_start(0.0),
        );
    }
    vars
}

/// The car's physical outputs, with what each depends on at once and in Initialization Mode.
fn physical_output_variables(
    defaults: &VehicleParams,
    act_defaults: ActuatorParams,
) -> Vec<Variable> {
    let mut vars = Vec::new();
    // Direct feed-through, for the worst case of the actuator model (no delay, no lag): the
    // road enters through the car's matrices (fixed parameters), a command through the
    // actuator's saturation, fault and delay. The states start at the equilibrium whatever
    // the parameters, so in Initialization Mode an output is its feed-through: it reads the
    // parameters of those matrices and of the actuators it feeds through from.
    let inputs = input_names();
    let matrix_parameters = feedthrough_parameters(defaults);
    // A tyre's load reads the road only while the tyre is on it (the physical car).
    let switched = Simulator::new(*defaults, act_defaults).outputs_switched_by_tyres();
    for (k, row) in physical_outputs(defaults).iter().enumerate() {
        let road: Vec<String> = (0..N_ROAD)
            .filter(|&j| row.d_r[j] != 0.0)
            .map(|j| inputs[j].clone())
            .collect();
        let actuators: Vec<usize> = (0..N_ACTUATORS).filter(|&j| row.d_u[j] != 0.0).collect();
        let commands = actuators
            .iter()
            .map(|&j| inputs[N_ROAD + j].clone())
            .collect();
        let mut initial = matrix_parameters[k].clone();
        for &j in &actuators {
            initial.extend(actuator_parameters(j));
        }
        vars.push(
            Variable::real(
                row.name.clone(),
                vr::OUTPUT + k as u32,
                Causality::Output,
                row.unit,
                row.description.clone(),
            )
            .depending_on(
                road,
                if switched[k] {
                    DependencyKind::Dependent
                } else {
                    DependencyKind::Fixed
                },
            )
            .depending_on(commands, DependencyKind::Dependent)
            .initially_depending_on(initial),
        );
    }
    vars
}

/// The forces the actuators apply.
fn force_variables() -> Vec<Variable> {
    let inputs = input_names();
    let mut vars = Vec::new();
    for (i, a) in ACTUATORS.iter().enumerate() {
        vars.push(
            Variable::real(format!("f_{a}"), vr::FORCE + i as u32, Causality::Output, "N", format!("Force actually applied by the {} actuator (after delay, saturation, fault and lag)", a.to_uppercase()))
                .depending_on(vec![inputs[N_ROAD + i].clone()], DependencyKind::Dependent)
                .initially_depending_on(actuator_parameters(i)),
        );
    }
    vars
}

/// The sensor model's parameters and the sensors' outputs (`vars`: every variable before them,
/// the physical outputs among them).
fn sensor_variables(vars: &[Variable]) -> Vec<Variable> {
    let mut out = Vec::new();
    let sensor_defaults = SensorParams::default();
    for (i, p) in SENSOR_PARAMETERS.iter().enumerate() {
        out.push(p.variable(vr::SENSOR + i as u32, &sensor_defaults));
    }
    out.push(
        Variable::boolean(
            "sensor_model",
            vr::SENSOR_SWITCH,
            Causality::Parameter,
            "Sensor model on: the sensor_* outputs carry each sensor's bias and noise (off: they read the physical outputs exactly)",
        )
        .with_boolean_start(sensor_defaults.on),
    );
    out.push(Variable::integer(
        "sensor_seed",
        vr::SENSOR_SEED,
        Causality::Parameter,
        sensor_defaults.seed as i32,
        "Sensor model: seed of the biases and the noise (the same seed gives the same readings)",
    ));
    // A sensor depends on what its physical output depends on. Its bias and noise start
    // when initialisation ends, so in Initialization Mode it reads the physical output.
    for (k, &row) in sensor_rows().iter().enumerate() {
        let truth = vars
            .iter()
            .find(|v| v.value_reference == vr::OUTPUT + row as u32)
            .expect("the physical output")
            .clone();
        let mut v = truth.clone();
        v.name = format!("{}{}", sensors::PREFIX, SENSORS[k].0);
        v.value_reference = vr::SENSOR_OUTPUT + k as u32;
        v.description = format!(
            "What the {} sensor reads: {} (with bias and noise when sensor_model is on)",
            match SENSORS[k].1 {
                sensors::Kind::Height => "height",
                sensors::Kind::Accelerometer => "accelerometer",
                sensors::Kind::Gyro => "gyro",
            },
            truth.description
        );
        out.push(v);
    }
    out
}

impl Plant {
    /// Whether the fault acts on the derivatives: Model Exchange's discrete state, and in
    /// Co-Simulation (which reads the derivatives as outputs only) the time.
    /// Before the first event the two agree: the first event finds the fault started exactly
    /// when the start time is past its onset.
    fn faulted_now(&self) -> bool {
        if self.exchanging {
            self.faulted
        } else {
            self.sim.time() >= self.sim.actuator.fault_time
        }
    }

    /// Model Exchange: the integrator has accepted the run up to `time` (a completed step, or
    /// an event): the time since the last is counted in the current contact mode.
    fn accept(&mut self, time: f64) {
        self.sim.set_exchange_time(time);
        self.sim.account_exchange_time(self.accounted);
        (self.accounted, self.exchanging) = (time, true);
        self.invalidate_outputs();
    }

    /// A Model Exchange state or derivative beyond `x[*]`, by value reference.
    fn exchange_value(&mut self, vr: ValueReference) -> f64 {
        let mut values = vec![0.0; model_exchange_states()];
        if let Some(k) = derivative_index(vr) {
            let faulted = self.faulted_now();
            self.sim.exchange_derivatives(&mut values, faulted);
            values[k]
        } else {
            self.sim.exchange_states(&mut values);
            values[state_index(vr).expect("a Model Exchange state")]
        }
    }
}

impl Model for Plant {
    fn description(_resources: Option<&Path>) -> Result<ModelDescription, ModelError> {
        Ok(Self::model_description())
    }

    fn instantiate(_resources: Option<&Path>) -> Result<Self, ModelError> {
        Ok(Plant {
            sim: Simulator::new(VehicleParams::default(), ActuatorParams::default()),
            outputs: vec![0.0; N_PHYSICAL_OUTPUTS],
            forces: [0.0; N_ACTUATORS],
            meter: [0.0; N_METER],
            sensors: Sensors::new(SensorParams::default()),
            sensor_rows: sensor_rows(),
            readings: [0.0; N_SENSORS],
            contact: ContactState::default(),
            outputs_valid: false,
            accounted: 0.0,
            faulted: false,
            exchanging: false,
        })
    }

    fn check_real(&self, vr: ValueReference, value: f64) -> Result<(), ModelError> {
        if let Some(spec) = vehicle_param(vr) {
            let mut p = self.sim.params;
            return p
                .set(spec.name, value)
                .map_err(|e| ModelError::error(e.to_string()));
        }
        // The actuator and sensor parameters' bounds are their declared min and max, which
        // the runtime checks (inclusive, as FMI's are).
        Ok(())
    }

    fn set_real(&mut self, vr: ValueReference, value: f64) {
        if let Some(spec) = vehicle_param(vr) {
            (spec.set)(&mut self.sim.params, value);
            self.sim.invalidate();
            self.invalidate_outputs();
        } else if let Some(spec) = actuator_param(vr) {
            (spec.set)(&mut self.sim.actuator, value);
            self.sim.invalidate();
            self.invalidate_outputs();
        } else if let Some(spec) = sensor_param(vr) {
            (spec.set)(&mut self.sensors.params, value);
            self.invalidate_outputs();
        } else if let Some(spec) = contact_param(vr) {
            (spec.set)(&mut self.sim.contact, value);
            self.sim.invalidate();
            self.invalidate_outputs();
        } else if let Some(k) = input_index(vr) {
            let slot = if k < N_ROAD {
                &mut self.sim.road[k]
            } else {
                &mut self.sim.command[k - N_ROAD]
            };
            // A master sets every input at every communication point; an unchanged value
            // keeps the outputs already computed.
            if slot.to_bits() != value.to_bits() {
                *slot = value;
                self.invalidate_outputs();
            }
        }
    }

    fn get_real(&mut self, vr: ValueReference) -> f64 {
        // Outputs first: a master reads them at every communication point.
        if let Some(k) = block(vr, vr::OUTPUT, N_PHYSICAL_OUTPUTS) {
            self.update_outputs();
            self.outputs[k]
        } else if let Some(k) = block(vr, vr::FORCE, N_ACTUATORS) {
            self.update_outputs();
            self.forces[k]
        } else if let Some(k) = block(vr, vr::METER, N_METER) {
            self.update_outputs();
            self.meter[k]
        } else if let Some(k) = block(vr, vr::SENSOR_OUTPUT, N_SENSORS) {
            self.update_outputs();
            self.readings[k]
        } else if let Some(k) = block(vr, vr::CONTACT_OUTPUT, N_CONTACT_OUTPUTS) {
            self.update_outputs();
            contact_values(&self.contact)[k]
        } else if let Some(spec) = contact_param(vr) {
            (spec.get)(&self.sim.contact)
        } else if let Some(spec) = sensor_param(vr) {
            (spec.get)(&self.sensors.params)
        } else if let Some(spec) = vehicle_param(vr) {
            (spec.get)(&self.sim.params)
        } else if let Some(spec) = actuator_param(vr) {
            (spec.get)(&self.sim.actuator)
        } else if (vr::STATIC..vr::STATIC + N_STATIC as u32).contains(&vr) {
            static_values(self.sim.static_equilibrium())[(vr - vr::STATIC) as usize]
        } else if let Some(k) = input_index(vr) {
            if k < N_ROAD {
                self.sim.road[k]
            } else {
                self.sim.command[k - N_ROAD]
            }
        } else if vr >= vr::STATE_DERIVATIVE {
            self.exchange_value(vr)
        } else {
            // Instance::get_real only passes value references of the variable table.
            self.sim.state()[(vr - vr::STATE) as usize]
        }
    }

    fn set_integer(&mut self, _vr: ValueReference, value: i32) {
        // The only Integer: sensor_seed (any value; its bits seed the stream).
        self.sensors.params.seed = value as i64 as u64;
    }

    fn get_integer(&mut self, _vr: ValueReference) -> i32 {
        self.sensors.params.seed as i64 as i32
    }

    fn set_boolean(&mut self, vr: ValueReference, value: bool) {
        // The settable Booleans: sensor_model, contact_model.
        if vr == vr::CONTACT_SWITCH {
            self.sim.contact.physical = value;
            self.sim.invalidate();
        } else {
            self.sensors.params.on = value;
        }
        self.invalidate_outputs();
    }

    fn get_boolean(&mut self, vr: ValueReference) -> bool {
        match vr {
            vr::CONTACT_SWITCH => self.sim.contact.physical,
            vr::SENSOR_SWITCH => self.sensors.params.on,
            _ => {
                self.update_outputs();
                self.contact.on_road[(vr - vr::ON_ROAD) as usize]
            }
        }
    }

    fn set_input_derivative(&mut self, vr: ValueReference, value: f64) {
        if let Some(k) = input_index(vr) {
            if k < N_ROAD {
                self.sim.road_slope[k] = value;
            } else {
                self.sim.command_slope[k - N_ROAD] = value;
            }
        }
    }

    fn check_parameters(&self) -> Result<(), ModelError> {
        self.sim
            .params
            .validate()
            .map_err(|e| ModelError::error(e.to_string()))
    }

    fn exit_initialization(&mut self, start_time: f64) -> Result<(), ModelError> {
        self.check_parameters()?;
        self.sim.start(start_time);
        (self.accounted, self.faulted, self.exchanging) = (start_time, false, false);
        self.sensors.start();
        self.invalidate_outputs();
        Ok(())
    }

    fn do_step(&mut self, time: f64, step: f64) -> Result<(), ModelError> {
        self.invalidate_outputs();
        self.sim.step(time, step).map_err(|e| match e {
            // Too long for the car's stiffness: shorter steps may be taken (fmi2Discard).
            // Shorter steps hold fewer events (fmi2Discard).
            simulator::StepError::Exponential { .. } | simulator::StepError::Chattering(_) => {
                ModelError::discard(e.to_string())
            }
            simulator::StepError::NonFinite(_) => ModelError::error(e.to_string()),
        })?;
        self.sensors.advance(step);
        Ok(())
    }

    fn check_model_exchange(&self) -> Result<(), ModelError> {
        if let Some(why) = self.sim.model_exchange_refusal() {
            return Err(why.into());
        }
        if self.sensors.params.on {
            return Err("sensor_model = true: the sensor model samples its noise at the communication steps, which Model Exchange does not have (switch it off, or use Co-Simulation)".into());
        }
        Ok(())
    }

    fn set_time(&mut self, time: f64) {
        self.sim.set_exchange_time(time);
        self.invalidate_outputs();
    }

    fn continuous_states(&mut self, x: &mut [f64]) {
        self.sim.exchange_states(x);
    }

    fn set_continuous_states(&mut self, x: &[f64]) {
        self.sim.set_exchange_states(x);
        self.invalidate_outputs();
    }

    fn derivatives(&mut self, dx: &mut [f64]) {
        let faulted = self.faulted_now();
        self.sim.exchange_derivatives(dx, faulted);
    }

    fn event_indicators(&mut self, z: &mut [f64]) {
        self.sim.exchange_event_indicators(z);
    }

    fn update_discrete_states(&mut self, time: f64) -> Result<DiscreteUpdate, ModelError> {
        self.accept(time);
        let (faulted, next) = self.sim.exchange_event();
        self.faulted = faulted;
        Ok(DiscreteUpdate {
            states_changed: false,
            next_event_time: next,
        })
    }

    fn completed_integrator_step(&mut self, time: f64) {
        self.accept(time);
    }

    fn directional_derivative(
        &mut self,
        unknowns: &[ValueReference],
        knowns: &[ValueReference],
        seed: &[f64],
        out: &mut [f64],
    ) {
        let mut seed_states = vec![0.0; model_exchange_states()];
        let mut seed_inputs = [0.0; N_ROAD + N_ACTUATORS];
        for (&vr, &s) in knowns.iter().zip(seed) {
            match input_index(vr) {
                Some(k) => seed_inputs[k] += s,
                None => seed_states[state_index(vr).expect("a known is an input or a state")] += s,
            }
        }
        let faulted = self.faulted_now();
        let linear = self
            .sim
            .linear_response(&seed_states, &seed_inputs, faulted);
        let contact = contact_values(&linear.contact);
        for (o, &vr) in out.iter_mut().zip(unknowns) {
            *o = if let Some(k) = block(vr, vr::OUTPUT, N_PHYSICAL_OUTPUTS) {
                linear.outputs[k]
            } else if let Some(k) = block(vr, vr::FORCE, N_ACTUATORS) {
                linear.forces[k]
            } else if let Some(k) = block(vr, vr::METER, N_METER) {
                linear.meter[k]
            } else if let Some(k) = block(vr, vr::SENSOR_OUTPUT, N_SENSORS) {
                // Noise and bias do not move with the state or the inputs.
                linear.outputs[self.sensor_rows[k]]
            } else if let Some(k) = block(vr, vr::CONTACT_OUTPUT, N_CONTACT_OUTPUTS) {
                contact[k]
            } else if let Some(k) = derivative_index(vr) {
                linear.derivatives[k]
            } else {
                seed_states[state_index(vr).expect("an unknown is an output or a state")]
            };
        }
    }

    fn save(&self, out: &mut StateWriter) {
        let params: Vec<f64> = PARAMETERS
            .iter()
            .map(|s| (s.get)(&self.sim.params))
            .collect();
        let act: Vec<f64> = ACTUATOR_PARAMETERS
            .iter()
            .map(|s| (s.get)(&self.sim.actuator))
            .collect();
        out.f64s(&params);
        out.f64s(&act);
        out.f64s(&self.sim.save());
        let contact: Vec<f64> = CONTACT_PARAMETERS
            .iter()
            .map(|s| (s.get)(&self.sim.contact))
            .collect();
        out.f64s(&contact);
        out.bool(self.sim.contact.physical);
        let sensor_params: Vec<f64> = SENSOR_PARAMETERS
            .iter()
            .map(|s| (s.get)(&self.sensors.params))
            .collect();
        out.f64s(&sensor_params);
        out.bool(self.sensors.params.on);
        out.u64(self.sensors.params.seed);
        self.sensors.save(out);
        out.f64(self.accounted);
        out.bool(self.faulted);
        out.bool(self.exchanging);
    }

    fn restore(&mut self, input: &mut StateReader) -> Result<(), ModelError> {
        let params = input.f64s_exact(PARAMETERS.len(), "vehicle parameters")?;
        let act = input.f64s_exact(ACTUATOR_PARAMETERS.len(), "actuator parameters")?;
        let data = input.f64s()?;
        let mut contact = ContactParams::default();
        let values = input.f64s_exact(CONTACT_PARAMETERS.len(), "contact parameters")?;
        for (s, v) in CONTACT_PARAMETERS.iter().zip(values) {
            if !(v.is_finite() && v >= s.min && s.max.is_none_or(|m| v <= m)) {
                return Err(format!("FMU state: {} = {v} is out of range", s.name).into());
            }
            (s.set)(&mut contact, v);
        }
        contact.physical = input.bool()?;
        let mut sensor_params = SensorParams::default();
        let values = input.f64s_exact(SENSOR_PARAMETERS.len(), "sensor parameters")?;
        for (s, v) in SENSOR_PARAMETERS.iter().zip(values) {
            (s.set)(&mut sensor_params, v);
        }
        sensor_params.on = input.bool()?;
        sensor_params.seed = input.u64()?;
        let sensors = Sensors::restored(sensor_params, input)?;
        let accounted = input.f64()?;
        let (faulted, exchanging) = (input.bool()?, input.bool()?);
        input.finish()?;
        if !accounted.is_finite() {
            return Err("FMU state: a non-finite accounted time".into());
        }
        let mut p = VehicleParams::default();
        for (s, v) in PARAMETERS.iter().zip(&params) {
            p.set(s.name, *v).map_err(|e| format!("FMU state: {e}"))?;
        }
        let mut a = ActuatorParams::default();
        for (s, v) in ACTUATOR_PARAMETERS.iter().zip(&act) {
            (s.set)(&mut a, *v);
        }
        let mut sim = Simulator::new(p, a);
        sim.contact = contact;
        sim.restore(&data)?;
        let same = p == self.sim.params && a == self.sim.actuator && contact == self.sim.contact;
        if same {
            // Same parameters: keep the cached discretisations (they would be recomputed
            // bit-identically anyway, this only saves the matrix exponentials).
            std::mem::swap(&mut self.sim, &mut sim);
            self.sim.adopt_system(&mut sim);
        } else {
            self.sim = sim;
        }
        self.sensors = sensors;
        (self.accounted, self.faulted, self.exchanging) = (accounted, faulted, exchanging);
        self.invalidate_outputs();
        Ok(())
    }
}

fn vehicle_param(vr: ValueReference) -> Option<&'static vehicle::params::ParamSpec> {
    vr.checked_sub(vr::VEHICLE)
        .and_then(|i| PARAMETERS.get(i as usize))
        .filter(|_| vr < vr::ACTUATOR)
}

fn actuator_param(vr: ValueReference) -> Option<&'static ActuatorSpec> {
    vr.checked_sub(vr::ACTUATOR)
        .and_then(|i| ACTUATOR_PARAMETERS.get(i as usize))
}

/// `vr`'s index in the block of `n` value references from `base`, if it is in it.
#[inline]
fn block(vr: ValueReference, base: u32, n: usize) -> Option<usize> {
    (base..base + n as u32)
        .contains(&vr)
        .then(|| (vr - base) as usize)
}

/// The index in Model Exchange's order of the variable at `vr` among the blocks `bases` (the
/// car's 16, the actuators' lag, the meter's filters: their states, or their derivatives).
fn exchange_index(vr: ValueReference, bases: [u32; 3]) -> Option<usize> {
    let sizes = [N_STATES, N_ACTUATORS, N_METER_STATES];
    let mut before = 0;
    for (base, size) in bases.into_iter().zip(sizes) {
        if let Some(k) = block(vr, base, size) {
            return Some(before + k);
        }
        before += size;
    }
    None
}

/// A continuous state's index in Model Exchange's order, by value reference.
fn state_index(vr: ValueReference) -> Option<usize> {
    exchange_index(vr, [vr::STATE, vr::LAG_STATE, vr::METER_STATE])
}

/// The index of a state derivative in Model Exchange's order, by value reference.
fn derivative_index(vr: ValueReference) -> Option<usize> {
    exchange_index(
        vr,
        [
            vr::STATE_DERIVATIVE,
            vr::LAG_DERIVATIVE,
            vr::METER_DERIVATIVE,
        ],
    )
}

fn input_index(vr: ValueReference) -> Option<usize> {
    vr.checked_sub(vr::INPUT)
        .map(|k| k as usize)
        .filter(|&k| k < N_ROAD + N_ACTUATORS)
}

fmu_core::export_fmi2!(Plant);
fmu_core::export_fmi3!(Plant);

#[cfg(test)]
mod value_reference_blocks {
    use super::*;

    /// The table the build checks is the variable table's: every variable lies in one block,
    /// and each block holds exactly as many variables as it says. An overlap is caught.
    #[test]
    fn every_variable_is_in_its_block_and_overlaps_are_caught() {
        let d = Plant::model_description();
        let mut counts = [0usize; VR_BLOCKS.len()];
        for v in &d.variables {
            let r = v.value_reference;
            let holding: Vec<usize> = (0..VR_BLOCKS.len())
                .filter(|&b| {
                    let (_, base, len) = VR_BLOCKS[b];
                    base <= r && r < base + len as u32
                })
                .collect();
            assert_eq!(holding.len(), 1, "{} ({r}) in blocks {holding:?}", v.name);
            counts[holding[0]] += 1;
        }
        for (b, (name, _, len)) in VR_BLOCKS.iter().enumerate() {
            assert_eq!(counts[b], *len, "{name}");
        }
        let mut grown = VR_BLOCKS;
        grown[0].2 = 21;
        assert!(
            !blocks_are_disjoint(&grown),
            "a 21st vehicle parameter must collide"
        );
        assert!(blocks_are_disjoint(&VR_BLOCKS));
    }
}
