//! Scenarios and the co-simulation loop on the `fmi` crate.
//!
//! **Order (Gauss–Seidel, fixed communication step `h`).** At each `t_k`: the road's outputs
//! (at `t_k`) go to the plant's road inputs; the plant's outputs go to the controller's inputs
//! (by name); the controller's commands go to the plant's force inputs, held over the step; then
//! controller, plant and road step over `[t_k, t_k + h)`. The road is the road FMU or the same
//! profile computed in process ([`RoadSource`]). The row recorded for `t_{k+1}` is read
//! after the road's new outputs have reached the plant (tyre loads feed the road through) and the
//! controller has been given the plant's new outputs (its residual and flag use them).
//!
//! A scenario's `order` ([`Order`]) runs the controller in the two other orders masters use:
//! Jacobi (its command read before it is given the plant's outputs; its recorded outputs then
//! too) and Gauss–Seidel with the controller stepped first.

use crate::slave::{Import, Kind, Slave, Var};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

pub use vehicle::model::{FORCE_PORTS as FORCES, ROAD_PORTS as ROAD};
/// The plant outputs every run records (the physical car's clocks of time off the road and at a
/// stop last).
pub const RECORD: [&str; 30] = [
    "a_seat",
    "alpha_roll",
    "alpha_pitch",
    "a_seat_wk",
    "alpha_roll_we",
    "alpha_pitch_we",
    "a_body",
    "stroke_fl",
    "stroke_fr",
    "stroke_rl",
    "stroke_rr",
    "stroke_seat",
    "tire_load_fl",
    "tire_load_fr",
    "tire_load_rl",
    "tire_load_rr",
    "f_fl",
    "f_fr",
    "f_rl",
    "f_rr",
    "f_seat",
    "airborne_time_fl",
    "airborne_time_fr",
    "airborne_time_rl",
    "airborne_time_rr",
    "stop_time_fl",
    "stop_time_fr",
    "stop_time_rl",
    "stop_time_rr",
    "stop_time_seat",
];
/// Controller outputs recorded when the controller has them: a fault detector's, and the
/// effectiveness estimates of fault accommodation.
pub const CONTROLLER_RECORD: [&str; 7] = [
    "residual_norm",
    "fault_detected",
    "rho_hat_fl",
    "rho_hat_fr",
    "rho_hat_rl",
    "rho_hat_rr",
    "rho_hat_seat",
];

#[derive(Debug)]
pub struct MasterError(pub String);

impl std::fmt::Display for MasterError {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for MasterError {}

pub(crate) fn err(msg: impl Into<String>) -> MasterError {
    MasterError(msg.into())
}

/// `"; did you mean 'x'?"` for the candidate closest to a mistyped `name` (if one is close),
/// else `""`.
pub(crate) fn did_you_mean<'a>(name: &str, candidates: impl Iterator<Item = &'a str>) -> String {
    candidates
        .map(|c| (strsim::jaro_winkler(name, c), c))
        .filter(|(score, _)| *score > 0.8)
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .map_or(String::new(), |(_, c)| format!("; did you mean '{c}'?"))
}

/// A failed call `what` to FMU instance `instance`, with what the FMU logged since (an FMI 3.0
/// FMU's messages name no instance: what the run's FMI 3.0 FMUs logged).
fn fmu_err(instance: &str, what: String) -> MasterError {
    use crate::fmu_log::{said, UNNAMED};
    match (said(instance), said(UNNAMED)) {
        (Some(said), _) => err(format!("{what}; {instance} says: {said}")),
        (None, Some(said)) => err(format!("{what}; an FMI 3.0 FMU says: {said}")),
        (None, None) => err(what),
    }
}

/// A JSON file of `what` (a scenario, a sweep), parsed and validated; every error names the
/// file.
pub(crate) fn load_json<T: serde::de::DeserializeOwned>(
    path: &Path,
    what: &str,
    validate: impl Fn(&T) -> Result<(), String>,
) -> Result<T, MasterError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| err(format!("cannot read {what} {}: {e}", path.display())))?;
    let value: T =
        serde_json::from_str(&text).map_err(|e| err(format!("{what} {}: {e}", path.display())))?;
    validate(&value).map_err(|e| err(format!("{what} {}: {e}", path.display())))?;
    Ok(value)
}

/// A scenario file (`scenarios/*.json`; its JSON Schema, `schemas/scenario.schema.json`, is
/// generated from this type by `master schema scenario`).
#[derive(Debug, Clone, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// The scenario's name: its section of the report, its directory of CSV files.
    pub name: String,
    /// What it shows, one sentence for the report.
    #[serde(default)]
    pub description: String,
    /// Length of the run, in s.
    pub duration: f64,
    /// Communication step, in s.
    pub step: f64,
    /// Road FMU parameters by name (numbers for Real and Integer, true/false for Boolean).
    pub road: BTreeMap<String, serde_json::Value>,
    /// Plant parameter overrides by name (mass, delay, fault, force limits, the sensor model
    /// …): numbers, a whole number for an Integer (`sensor_seed`), 0 or 1 for a Boolean
    /// (`sensor_model`); a controller that has a parameter of the same name (an anti-windup
    /// controller's force limits) gets it too.
    #[serde(default)]
    pub plant: BTreeMap<String, f64>,
    /// Controller parameters by name (numbers, or true/false for Boolean), e.g.
    /// `{"fault_threshold": 10}`; every controller the scenario runs must have them (restrict
    /// it with `controllers`). The passive car ignores them.
    #[serde(default)]
    pub controller: BTreeMap<String, serde_json::Value>,
    /// When present, the controllers this scenario is meant for (the others are skipped).
    #[serde(default)]
    pub controllers: Option<Vec<String>>,
    /// Start of the window the metrics are computed over, in s (e.g. after a fault).
    #[serde(default)]
    pub metrics_from: f64,
    /// The designs whose own scenario this is (the design table of the report).
    #[serde(default)]
    pub showcases: Vec<String>,
    /// Suspension stroke limit, in m: a run whose stroke goes beyond it is flagged.
    #[serde(default = "default_stroke_max")]
    pub stroke_max: f64,
    /// How the master orders the exchange and the steps at each communication point ([`Order`];
    /// default `gauss_seidel`).
    #[serde(default)]
    pub order: Order,
}

/// The order of the exchange and the steps at each communication point `t_k`, as masters run
/// FMUs; each certificate predicts its loop in each (`comfort.master_orders`, the same names,
/// `synth::predict::sampled::Order`). In all three the plant's outputs at `t_k` are read before
/// the new command is set, and the road reaches the plant as in the module's documentation; they
/// differ in the command that drives the plant over `[t_k, t_{k+1})`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Order {
    /// The plant's outputs to the controller, its command read and set on the plant, then
    /// every FMU steps (the module's order; FMPy's fixed-step master).
    #[default]
    GaussSeidel,
    /// Every output read before any input is set, then every FMU steps: the command read is
    /// the one the controller gives with its previous input (libcosim's fixed-step algorithm).
    Jacobi,
    /// Gauss–Seidel with the controller first: given the plant's outputs, stepped to
    /// `t_{k+1}`, and its command there drives the plant over `[t_k, t_{k+1})`.
    ControllerFirst,
}

/// The controller parameter a master tells its order (`fmu_controller::MasterOrder`).
pub const MASTER_ORDER: &str = "master_order";

impl Order {
    /// The value of a controller's `master_order` for this order.
    pub fn code(self) -> i32 {
        match self {
            Order::GaussSeidel => 0,
            Order::Jacobi => 1,
            Order::ControllerFirst => 2,
        }
    }
}

/// The stroke limit of the flags when a scenario does not give one \[m\] (the comfort designs'
/// `stroke_max`, synth/designs/comfort.json).
pub const DEFAULT_STROKE_MAX: f64 = 0.08;

fn default_stroke_max() -> f64 {
    DEFAULT_STROKE_MAX
}

impl Scenario {
    pub fn load(path: &Path) -> Result<Scenario, MasterError> {
        load_json(path, "scenario", Scenario::validate)
    }

    pub fn validate(&self) -> Result<(), String> {
        if !(self.step > 0.0
            && self.step.is_finite()
            && self.duration > 0.0
            && self.duration.is_finite())
        {
            return Err(format!(
                "duration and step must be finite and > 0 (got {} and {})",
                self.duration, self.step
            ));
        }
        if !(self.stroke_max > 0.0 && self.stroke_max.is_finite()) {
            return Err(format!(
                "stroke_max must be finite and > 0, got {}",
                self.stroke_max
            ));
        }
        if self.duration / self.step > 1e8 {
            return Err("more than 1e8 steps".into());
        }
        if !(self.metrics_from >= 0.0 && self.metrics_from < self.duration) {
            return Err(format!(
                "metrics_from must be in [0, duration), got {}",
                self.metrics_from
            ));
        }
        if self.name.is_empty()
            || !self
                .name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
        {
            return Err(format!(
                "name '{}' must be non-empty, letters, digits, - and _ only",
                self.name
            ));
        }
        Ok(())
    }

    pub fn steps(&self) -> usize {
        (self.duration / self.step).round() as usize
    }

    pub fn wants(&self, controller: &str) -> bool {
        self.controllers
            .as_ref()
            .is_none_or(|c| c.iter().any(|n| n == controller))
    }
}

/// A loaded FMU, of FMI 2.0 or 3.0 ([`crate::slave`]).
pub struct Fmu {
    pub name: String,
    pub import: Import,
    variables: Vec<Var>,
}

impl Fmu {
    /// `<dist>/<name>.fmu`, or the file `name` itself when it ends in `.fmu` (the FMU is then
    /// named after the file, without the extension).
    pub fn load(dist: &Path, name: &str) -> Result<Fmu, MasterError> {
        let (path, name) = match name.strip_suffix(".fmu") {
            Some(stem) => (
                PathBuf::from(name),
                Path::new(stem)
                    .file_name()
                    .map_or(stem.into(), |f| f.to_string_lossy().into_owned()),
            ),
            None => (dist.join(format!("{name}.fmu")), name.to_string()),
        };
        if !path.exists() {
            let in_dist: Vec<String> = std::fs::read_dir(dist)
                .map(|d| {
                    d.filter_map(|e| {
                        let n = e.ok()?.file_name().to_string_lossy().into_owned();
                        n.strip_suffix(".fmu").map(String::from)
                    })
                    .collect()
                })
                .unwrap_or_default();
            return Err(err(format!(
                "{} not found{} (run `make` to build the FMUs, or give a path to an .fmu)",
                path.display(),
                did_you_mean(&name, in_dist.iter().map(String::as_str))
            )));
        }
        let import =
            Import::load(&path).map_err(|e| err(format!("cannot load {}: {e}", path.display())))?;
        let variables = import
            .variables()
            .map_err(|e| err(format!("{}: {e}", path.display())))?;
        Ok(Fmu {
            name,
            import,
            variables,
        })
    }

    /// The FMI version of the FMU: 2 or 3.
    pub fn fmi_version(&self) -> u8 {
        self.import.version()
    }

    /// The unit variable `name` declares ("" for none).
    pub fn unit(&self, name: &str) -> &str {
        self.variable(name).map_or("", |v| v.unit.as_str())
    }

    /// The car a controller FMU was designed for (`designed_for` of its
    /// `resources/controller.json`); None for another FMU or a controller that does not say.
    pub fn designed_for(&self) -> Result<Option<controller_file::DesignedFor>, MasterError> {
        // The import has the archive extracted already.
        let path = self.import.resource_path().join("controller.json");
        let text = match std::fs::read_to_string(&path) {
            Ok(text) => text,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(err(format!("{}: {}: {e}", self.name, path.display()))),
        };
        controller_file::ControllerFile::from_json(&text)
            .map(|f| f.designed_for)
            .map_err(|e| err(format!("{}: resources/controller.json: {e}", self.name)))
    }

    pub(crate) fn variable(&self, name: &str) -> Option<&Var> {
        self.variables.iter().find(|v| v.name == name)
    }

    pub fn vr(&self, name: &str) -> Result<u32, MasterError> {
        self.variable(name).map(|v| v.vr).ok_or_else(|| {
            err(format!(
                "{} has no variable '{name}'{}",
                self.name,
                did_you_mean(name, self.variable_names())
            ))
        })
    }

    fn variable_names(&self) -> impl Iterator<Item = &str> {
        self.variables.iter().map(|v| v.name.as_str())
    }

    /// The start value of Real variable `name`, if it has one.
    pub fn start_real(&self, name: &str) -> Option<f64> {
        self.variable(name)?.start
    }

    pub fn has(&self, name: &str) -> bool {
        self.variable(name).is_some()
    }

    pub fn names_with_causality(&self, causality: &str) -> Vec<String> {
        self.variables
            .iter()
            .filter(|v| v.causality.eq_ignore_ascii_case(causality))
            .map(|v| v.name.clone())
            .collect()
    }

    /// `value` as the type of parameter `name` (an Integer must fit an `fmi2Integer`).
    pub fn typed(&self, name: &str, value: &serde_json::Value) -> Result<Typed, MasterError> {
        let v = self.variable(name).ok_or_else(|| {
            let parameters = self.names_with_causality("parameter");
            err(format!(
                "{} has no parameter '{name}'{}",
                self.name,
                did_you_mean(name, parameters.iter().map(String::as_str))
            ))
        })?;
        if v.causality != "parameter" {
            return Err(err(format!(
                "{}: '{name}' is not a parameter (its causality is {})",
                self.name, v.causality
            )));
        }
        let bad = || {
            err(format!(
                "{}: parameter '{name}' cannot take {value}",
                self.name
            ))
        };
        Ok(match v.kind {
            Kind::Real => Typed::Real(value.as_f64().ok_or_else(bad)?),
            // A scenario's plant overrides are numbers: an Integer takes a whole number, a
            // Boolean 0 or 1 (as well as true / false where the file can say so).
            Kind::Integer => Typed::Integer(
                value
                    .as_i64()
                    .or_else(|| {
                        // `as` saturates: out of i32's range stays out of it for try_from.
                        value
                            .as_f64()
                            .filter(|v| v.fract() == 0.0)
                            .map(|v| v as i64)
                    })
                    .and_then(|v| i32::try_from(v).ok())
                    .ok_or_else(bad)?,
            ),
            Kind::Boolean => Typed::Boolean(
                value
                    .as_bool()
                    .or_else(|| {
                        let v = value.as_f64()?;
                        (v == 0.0 || v == 1.0).then_some(v == 1.0)
                    })
                    .ok_or_else(bad)?,
            ),
            Kind::Other => return Err(bad()),
        })
    }

    /// Instantiate, set `params`, initialise.
    fn start(&self, params: &[(String, Typed)]) -> Result<Slave, MasterError> {
        crate::fmu_log::install();
        let fail = |what: String| fmu_err(&self.name, format!("{}: {what}", self.name));
        let mut i = self
            .import
            .instantiate(&self.name)
            .map_err(|e| fail(format!("instantiate: {e}")))?;
        for (name, value) in params {
            let vr = self.vr(name)?;
            let status = match *value {
                Typed::Real(v) => i.set_real(&[vr], &[v]),
                Typed::Integer(v) => i.set_integer(&[vr], &[v]),
                Typed::Boolean(v) => i.set_boolean(&[vr], &[v]),
            };
            status.map_err(|e| fail(format!("setting '{name}' = {value:?}: {e}")))?;
        }
        i.initialise().map_err(fail)?;
        Ok(i)
    }
}

/// A parameter value with its variable's type.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Typed {
    Real(f64),
    Integer(i32),
    Boolean(bool),
}

/// The scenario's parameters of road, plant and controller, typed. A controller parameter of
/// the same name as a plant override (the force limits of an anti-windup controller) gets it
/// too; a controller input of that name does not.
pub fn scenario_parameters(
    scenario: &Scenario,
    road: &Fmu,
    plant: &Fmu,
    controller: Option<&Fmu>,
) -> Result<[Vec<(String, Typed)>; 3], MasterError> {
    let road_values = scenario
        .road
        .iter()
        .map(|(k, v)| Ok((k.clone(), road.typed(k, v)?)))
        .collect::<Result<Vec<_>, MasterError>>()?;
    let plant_values = scenario
        .plant
        .iter()
        .map(|(k, v)| Ok((k.clone(), plant.typed(k, &serde_json::json!(v))?)))
        .collect::<Result<Vec<_>, MasterError>>()?;
    let ctrl_values = match controller {
        Some(c) => {
            let inputs = c.names_with_causality("input");
            let shared = scenario
                .plant
                .iter()
                .filter(|(k, _)| c.has(k) && !inputs.contains(k))
                .map(|(k, v)| (k, serde_json::json!(v)));
            let own = scenario.controller.iter().map(|(k, v)| (k, v.clone()));
            shared
                .chain(own)
                .map(|(k, v)| Ok((k.clone(), c.typed(k, &v)?)))
                .collect::<Result<Vec<_>, MasterError>>()?
        }
        None => Vec::new(),
    };
    Ok([road_values, plant_values, ctrl_values])
}

/// Why a controller designed for `designed` runs off its design in `scenario`: one line per
/// vehicle parameter of the plant (the scenario's override, else the plant FMU's start value)
/// that differs from that car (see [`controller_file::DesignedFor::differences`]).
pub fn off_design(
    scenario: &Scenario,
    plant: &Fmu,
    designed: &controller_file::DesignedFor,
) -> Vec<String> {
    let actual: BTreeMap<String, f64> = designed
        .vehicle
        .keys()
        .filter_map(|name| {
            let value = scenario
                .plant
                .get(name)
                .copied()
                .or_else(|| plant.start_real(name))?;
            Some((name.clone(), value))
        })
        .collect();
    designed.differences(&actual)
}

/// A run's log: one row per communication point `t_1 … t_N`.
pub struct Run {
    pub columns: Vec<String>,
    /// The unit of each column as its FMU declares it (empty for none).
    pub units: Vec<String>,
    pub time: Vec<f64>,
    /// The rows, one after the other (`columns.len()` values each).
    pub data: Vec<f64>,
    /// Static tyre loads of the plant, FL … RR \[N\].
    pub static_tire_load: [f64; 4],
    /// The plant's force limits, FL … RR and seat (`u_max`, `u_max_seat`) \[N\].
    pub force_limits: [f64; 5],
    /// The plant's actuator delay `tau` \[s\].
    pub delay: f64,
    /// The force commands the plant was given, one per step, held over it (FL … RR, seat) \[N\].
    pub commands: Vec<[f64; 5]>,
    /// Wall time of the stepping loop alone (FMUs loaded and initialised) \[s\].
    pub loop_seconds: f64,
    /// What the FMUs said in a run that went through (their warnings: a controller stepped
    /// beyond the communication steps its loop is stable at says so), as `instance: message`.
    pub warnings: Vec<String>,
}

impl Run {
    pub fn rows(&self) -> std::slice::ChunksExact<'_, f64> {
        self.data.chunks_exact(self.columns.len())
    }

    pub fn column(&self, name: &str) -> Option<Vec<f64>> {
        let k = self.columns.iter().position(|c| c == name)?;
        Some(self.rows().map(|r| r[k]).collect())
    }

    pub fn write_csv(&self, path: &Path) -> Result<(), MasterError> {
        use std::fmt::Write;
        // `name [unit]`, the unit as the FMU declares it.
        let header: Vec<String> = self
            .columns
            .iter()
            .zip(&self.units)
            .map(|(c, u)| match u.as_str() {
                "" => c.clone(),
                u => format!("{c} [{u}]"),
            })
            .collect();
        let mut s = format!("time [s],{}\n", header.join(","));
        for (t, r) in self.time.iter().zip(self.rows()) {
            write!(s, "{t}").unwrap();
            for v in r {
                write!(s, ",{v:e}").unwrap();
            }
            s.push('\n');
        }
        std::fs::write(path, s).map_err(|e| err(format!("cannot write {}: {e}", path.display())))
    }
}

/// Check that every input of `controller` is an output of `plant`.
pub fn check_connections(plant: &Fmu, controller: &Fmu) -> Result<(), MasterError> {
    let outputs = plant.names_with_causality("output");
    let missing: Vec<String> = controller
        .names_with_causality("input")
        .into_iter()
        .filter(|n| !outputs.contains(n))
        .collect();
    if !missing.is_empty() {
        return Err(err(format!(
            "controller {} reads {} which the plant does not output",
            controller.name,
            missing.join(", ")
        )));
    }
    for f in FORCES {
        controller.vr(f)?;
    }
    Ok(())
}

/// Where the plant's road inputs come from.
pub enum RoadSource<'a> {
    /// A road FMU, started with its parameters and stepped with the loop.
    Fmu(Participant<'a>),
    /// The road computed in process: `[z_fl, z_fr, z_rl, z_rr, v_fl, v_fr, v_rl, v_rr]` at `t`
    /// (e.g. `vehicle::road::Road::at`, the code the road FMU runs).
    InProcess(&'a dyn Fn(f64) -> [f64; 8]),
}

/// An FMU of the loop with the parameters it is started with.
#[derive(Clone, Copy)]
pub struct Participant<'a> {
    pub fmu: &'a Fmu,
    pub params: &'a [(String, Typed)],
}

/// One co-simulation: who takes part, the communication step, how many steps, what is recorded.
pub struct Setup<'a> {
    pub road: RoadSource<'a>,
    pub plant: Participant<'a>,
    /// `None`: the passive car.
    pub controller: Option<Participant<'a>>,
    /// \[s\]
    pub step: f64,
    pub steps: usize,
    /// Plant outputs, or, for a name the plant lacks, the controller's variable (Real, or
    /// Boolean recorded as 0/1).
    pub record: &'a [String],
    pub order: Order,
}

/// Run `scenario` with `controller` (None: the passive car), recording [`RECORD`] and the
/// [`CONTROLLER_RECORD`] variables the controller has.
pub fn run(dist: &Path, scenario: &Scenario, controller: Option<&str>) -> Result<Run, MasterError> {
    let road = Fmu::load(dist, "road")?;
    let plant = Fmu::load(dist, "plant")?;
    let ctrl = controller.map(|c| Fmu::load(dist, c)).transpose()?;
    run_loaded(&road, &plant, ctrl.as_ref(), scenario)
}

/// [`run`] with the FMUs already loaded (a sweep loads each once for all its runs).
pub fn run_loaded(
    road: &Fmu,
    plant: &Fmu,
    ctrl: Option<&Fmu>,
    scenario: &Scenario,
) -> Result<Run, MasterError> {
    let [road_params, plant_params, ctrl_params] =
        scenario_parameters(scenario, road, plant, ctrl)?;
    let mut record: Vec<String> = RECORD.iter().map(|s| s.to_string()).collect();
    if let Some(c) = ctrl {
        record.extend(
            CONTROLLER_RECORD
                .iter()
                .filter(|n| c.has(n))
                .map(|s| s.to_string()),
        );
    }
    simulate(&Setup {
        road: RoadSource::Fmu(Participant {
            fmu: road,
            params: &road_params,
        }),
        plant: Participant {
            fmu: plant,
            params: &plant_params,
        },
        controller: ctrl.map(|fmu| Participant {
            fmu,
            params: &ctrl_params,
        }),
        step: scenario.step,
        steps: scenario.steps(),
        record: &record,
        order: scenario.order,
    })
}

/// Where a recorded column is read: the plant's Reals, the controller's Reals or its Booleans.
#[derive(Clone, Copy)]
enum Batch {
    Plant,
    ControllerReal,
    ControllerBoolean,
}

/// The recorded variables, read in one FMI call per batch and step (a call per variable cost
/// more than the plant's step): each batch's value references, and per column its batch and
/// index there.
struct Recording {
    plant: Vec<u32>,
    controller_real: Vec<u32>,
    controller_boolean: Vec<u32>,
    columns: Vec<(Batch, usize)>,
}

impl Recording {
    fn add(&mut self, batch: Batch, vr: u32) {
        let refs = match batch {
            Batch::Plant => &mut self.plant,
            Batch::ControllerReal => &mut self.controller_real,
            Batch::ControllerBoolean => &mut self.controller_boolean,
        };
        self.columns.push((batch, refs.len()));
        refs.push(vr);
    }

    /// What `record` names, in batches by FMU and type: a plant variable, or else the
    /// controller's (a name neither has is refused).
    fn of(record: &[String], plant: &Fmu, ctrl: Option<&Fmu>) -> Result<Self, MasterError> {
        let mut recording = Recording {
            plant: vec![],
            controller_real: vec![],
            controller_boolean: vec![],
            columns: vec![],
        };
        for n in record {
            match (plant.has(n), ctrl) {
                (true, _) => recording.add(Batch::Plant, plant.vr(n)?),
                (false, Some(cf)) => {
                    let boolean = cf.variable(n).map(|v| v.kind) == Some(Kind::Boolean);
                    let batch = match boolean {
                        true => Batch::ControllerBoolean,
                        false => Batch::ControllerReal,
                    };
                    recording.add(batch, cf.vr(n)?)
                }
                (false, None) => return Err(err(format!("plant has no variable '{n}' to record"))),
            }
        }
        Ok(recording)
    }

    fn on_controller(&self) -> bool {
        !(self.controller_real.is_empty() && self.controller_boolean.is_empty())
    }
}

/// Instantiate and initialise the controller with its parameters. One with a parameter
/// `master_order` (a predictor, whose commands in flight depend on it) is told the order it runs
/// in, unless its parameters say.
fn start_controller(c: &Participant, order: Order) -> Result<Slave, MasterError> {
    let mut params = c.params.to_vec();
    if c.fmu.has(MASTER_ORDER) && !params.iter().any(|(n, _)| n == MASTER_ORDER) {
        params.push((MASTER_ORDER.to_string(), Typed::Integer(order.code())));
    }
    c.fmu.start(&params)
}

/// The value references of `names` in `f`.
fn vrs(f: &Fmu, names: &[&str]) -> Result<Vec<u32>, MasterError> {
    names.iter().map(|n| f.vr(n)).collect()
}

/// Who is connected to whom in a run, by value reference, and what is recorded.
struct Wiring {
    road_in: Vec<u32>,
    force_in: Vec<u32>,
    /// The controller's inputs: where they are read on the plant, where they are set.
    y_from: Vec<u32>,
    y_to: Vec<u32>,
    /// The controller's commands.
    u_from: Vec<u32>,
    recording: Recording,
    /// What is read from the plant once per communication point: the recorded outputs, then
    /// the controller's inputs not among them, whose places there are `y_at`.
    plant_reads: Vec<u32>,
    y_at: Vec<usize>,
    /// The unit of each recorded column.
    units: Vec<String>,
}

impl Wiring {
    fn of(setup: &Setup) -> Result<Wiring, MasterError> {
        let plant = setup.plant.fmu;
        let ctrl = setup.controller.map(|c| c.fmu);
        let recording = Recording::of(setup.record, plant, ctrl)?;
        let (y_from, y_to, u_from) = match ctrl {
            Some(cf) => {
                let inputs = cf.names_with_causality("input");
                let names: Vec<&str> = inputs.iter().map(|s| s.as_str()).collect();
                (vrs(plant, &names)?, vrs(cf, &names)?, vrs(cf, &FORCES)?)
            }
            None => (vec![], vec![], vec![]),
        };
        // The plant is read once per communication point. Nothing is set between the end of
        // one step and the start of the next, so the values read at the end of a step are
        // those the next one starts from (one FMI call a step fewer, same values).
        let mut plant_reads = recording.plant.clone();
        let y_at: Vec<usize> = y_from
            .iter()
            .map(|vr| match plant_reads.iter().position(|r| r == vr) {
                Some(i) => i,
                None => {
                    plant_reads.push(*vr);
                    plant_reads.len() - 1
                }
            })
            .collect();
        let units = setup
            .record
            .iter()
            .zip(&recording.columns)
            .map(|(n, (batch, _))| match (batch, ctrl) {
                (Batch::Plant, _) | (_, None) => plant.unit(n).to_string(),
                (_, Some(c)) => c.unit(n).to_string(),
            })
            .collect();
        Ok(Wiring {
            road_in: vrs(plant, &ROAD)?,
            force_in: vrs(plant, &FORCES)?,
            y_from,
            y_to,
            u_from,
            recording,
            plant_reads,
            y_at,
            units,
        })
    }
}

/// The co-simulation loop of this module's order (see the module's documentation), the one
/// every run and every closed-loop test goes through.
pub fn simulate(setup: &Setup) -> Result<Run, MasterError> {
    crate::fmu_log::clear();
    let plant = setup.plant.fmu;
    let ctrl = setup.controller.map(|c| c.fmu);
    if let Some(c) = ctrl {
        check_connections(plant, c)?;
    }
    let mut road = match &setup.road {
        RoadSource::Fmu(r) => Some((r.fmu.start(r.params)?, vrs(r.fmu, &ROAD)?)),
        RoadSource::InProcess(_) => None,
    };
    let mut p = plant.start(setup.plant.params)?;
    let mut c = setup
        .controller
        .map(|c| start_controller(&c, setup.order))
        .transpose()?;
    let Wiring {
        road_in,
        force_in,
        y_from,
        y_to,
        u_from,
        recording,
        plant_reads,
        y_at,
        units,
    } = Wiring::of(setup)?;
    let on_controller = recording.on_controller();
    let (static_tire_load, [u_max, u_max_seat, delay]) = plant_facts(&mut p, plant)?;
    // The instance names the FMUs log under, by role.
    let instance = |who: &str| match (who, &setup.road, ctrl) {
        ("road", RoadSource::Fmu(r), _) => r.fmu.name.clone(),
        ("controller", _, Some(c)) => c.name.clone(),
        _ => plant.name.clone(),
    };
    let fail = |who: &str, e: String| fmu_err(&instance(who), format!("{who}: {e}"));
    let (h, steps) = (setup.step, setup.steps);
    // The log's memory written once before the clock starts: its first touch (the kernel's page
    // faults, a few hundred microseconds) is allocation, not stepping.
    let mut time = prefaulted(steps);
    let mut data = prefaulted(steps * recording.columns.len());
    let mut plant_values = vec![0.0; plant_reads.len()];
    let mut controller_reals = vec![0.0; recording.controller_real.len()];
    let mut controller_booleans = vec![0; recording.controller_boolean.len()];
    let mut commands = prefaulted(steps);
    let mut road_values = [0.0; 8];
    let mut y = vec![0.0; y_from.len()];
    let mut u = [0.0; 5];
    let started = std::time::Instant::now();
    // The road at t + h, the FMU stepped from t over h first (not for h = 0).
    let mut road_at = |t: f64, h: f64, values: &mut [f64; 8]| match (&setup.road, road.as_mut()) {
        (RoadSource::InProcess(f), _) => {
            *values = f(t + h);
            Ok(())
        }
        (RoadSource::Fmu(_), Some((r, out))) => {
            if h > 0.0 {
                r.do_step(t, h).map_err(|e| fail("road", e))?;
            }
            r.get_real(out, values).map_err(|e| fail("road", e))
        }
        (RoadSource::Fmu(_), None) => unreachable!("the road FMU is started above"),
    };
    // The road at t_0; afterwards each iteration leaves the road at t_{k+1} in the plant.
    road_at(0.0, 0.0, &mut road_values)?;
    p.set_real(&road_in, &road_values)
        .map_err(|e| fail("plant", e))?;
    let read_plant = |p: &mut Slave, values: &mut [f64], y: &mut [f64]| {
        if !plant_reads.is_empty() {
            p.get_real(&plant_reads, values)
                .map_err(|e| fail("plant", e))?;
        }
        for (y, &at) in y.iter_mut().zip(&y_at) {
            *y = values[at];
        }
        Ok::<(), MasterError>(())
    };
    read_plant(&mut p, &mut plant_values, &mut y)?;
    for k in 0..steps {
        let t = k as f64 * h;
        if let Some(c) = c.as_mut() {
            let set_y = |c: &mut Slave| c.set_real(&y_to, &y).map_err(|e| fail("controller", e));
            let mut get_u = |c: &mut Slave| {
                c.get_real(&u_from, &mut u)
                    .map_err(|e| fail("controller", e))
            };
            let step = |c: &mut Slave| c.do_step(t, h).map_err(|e| fail("controller", e));
            match setup.order {
                Order::GaussSeidel => {
                    set_y(c)?;
                    get_u(c)?;
                    step(c)?;
                }
                Order::Jacobi => {
                    get_u(c)?;
                    set_y(c)?;
                    step(c)?;
                }
                Order::ControllerFirst => {
                    set_y(c)?;
                    step(c)?;
                    get_u(c)?;
                }
            }
            p.set_real(&force_in, &u).map_err(|e| fail("plant", e))?;
        }
        commands.push(u);
        p.do_step(t, h).map_err(|e| fail("plant", e))?;
        road_at(t, h, &mut road_values)?;
        p.set_real(&road_in, &road_values)
            .map_err(|e| fail("plant", e))?;
        read_plant(&mut p, &mut plant_values, &mut y)?;
        if let (Some(c), true) = (c.as_mut(), on_controller) {
            // Its outputs with the plant's new values, except in Jacobi, where the controller
            // holds its previous input until the next exchange.
            if setup.order != Order::Jacobi {
                c.set_real(&y_to, &y).map_err(|e| fail("controller", e))?;
            }
            if !recording.controller_real.is_empty() {
                c.get_real(&recording.controller_real, &mut controller_reals)
                    .map_err(|e| fail("controller", e))?;
            }
            if !recording.controller_boolean.is_empty() {
                c.get_boolean(&recording.controller_boolean, &mut controller_booleans)
                    .map_err(|e| fail("controller", e))?;
            }
        }
        data.extend(recording.columns.iter().map(|&(batch, i)| match batch {
            Batch::Plant => plant_values[i],
            Batch::ControllerReal => controller_reals[i],
            Batch::ControllerBoolean => controller_booleans[i] as f64,
        }));
        time.push(t + h);
    }
    let loop_seconds = started.elapsed().as_secs_f64();
    let warnings = warnings_of(&[instance("road"), instance("plant"), instance("controller")]);
    Ok(Run {
        columns: setup.record.to_vec(),
        units,
        time,
        data,
        static_tire_load,
        force_limits: [u_max, u_max, u_max, u_max, u_max_seat],
        delay,
        commands,
        loop_seconds,
        warnings,
    })
}

/// The plant's values after initialisation (its own, or the scenario's overrides) a run
/// reports: the static tyre loads, and `[u_max, u_max_seat, tau]`.
fn plant_facts(p: &mut Slave, plant: &Fmu) -> Result<([f64; 4], [f64; 3]), MasterError> {
    let mut plant_reals = |names: &[&str], values: &mut [f64]| {
        p.get_real(&vrs(plant, names)?, values)
            .map_err(|e| fmu_err(&plant.name, format!("plant: {e}")))
    };
    let mut static_tire_load = [0.0; 4];
    plant_reals(
        &[
            "static_tire_load_fl",
            "static_tire_load_fr",
            "static_tire_load_rl",
            "static_tire_load_rr",
        ],
        &mut static_tire_load,
    )?;
    let mut actuator = [0.0; 3];
    plant_reals(&["u_max", "u_max_seat", "tau"], &mut actuator)?;
    Ok((static_tire_load, actuator))
}

/// What each FMU instance said during the run ([`crate::fmu_log::said`]; an instance named twice
/// in a row counts once), and what FMI 3.0 FMUs said (their logger names no instance).
fn warnings_of(instances: &[String]) -> Vec<String> {
    let mut instances = instances.to_vec();
    instances.dedup();
    instances
        .iter()
        .filter_map(|i| crate::fmu_log::said(i).map(|m| format!("{i}: {m}")))
        .chain(crate::fmu_log::said(crate::fmu_log::UNNAMED).map(|m| format!("FMI 3.0 FMU: {m}")))
        .collect()
}

/// An empty vector with room for `n` values whose memory has been written (so that filling it
/// does not take page faults).
fn prefaulted<T: Copy + Default>(n: usize) -> Vec<T> {
    let mut v = Vec::with_capacity(n);
    v.resize(n, T::default());
    v.clear();
    v
}

/// `dist/` beside the executable's workspace, or as given.
pub fn default_dist() -> PathBuf {
    PathBuf::from("dist")
}
