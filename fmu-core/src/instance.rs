//! One FMU instance and the FMI 2.0 semantics of every call, Co-Simulation and Model Exchange,
//! in safe Rust.
//! The C ABI layer ([`crate::ffi`]) only converts pointers and catches panics.

use crate::description::{
    settable, ArrayParameter, BaseType, Causality, ModelDescription, ValueReference, VarType,
    Variability, Variable, FMI3_EVENT_INDICATOR_VR, FMI3_TIME_VR,
};
use crate::fmu_state::{self, ClockSnapshot, Snapshot, StateReader, StateWriter};
use crate::logger::{Category, Logger};
use crate::model::{DiscreteUpdate, Model, ModelError};
use crate::state_machine::{FmiState, Interface};
use crate::types::{
    status_kind, CallbackFunctions, Fmi2StatusKind, Fmi2Type, Status, FMI2_CO_SIMULATION,
    FMI2_MODEL_EXCHANGE,
};
use crate::uri;
use std::collections::HashSet;
use std::path::PathBuf;

/// Marks a live instance, so a stray pointer (an FMU state, a freed instance) is caught.
pub(crate) const INSTANCE_MAGIC: u64 = 0x5355_5350_494e_5354;

/// Relative tolerance when comparing the master's communication point with our time.
const TIME_TOLERANCE: f64 = 1e-9;

/// `repr(C)` so that `magic` is the first word whatever the model: a pointer that is not an
/// instance of this FMU (another FMU's, a freed one) is recognised by reading one `u64` at its
/// address, never a field the compiler placed elsewhere.
#[repr(C)]
pub struct Instance<M: Model> {
    pub(crate) magic: u64,
    description: ModelDescription,
    /// Value reference → what the checks of a get or set read about it, per base type.
    index: [Vec<Option<Slot>>; 3],
    model: M,
    pub(crate) state: FmiState,
    /// What the importer instantiated: Co-Simulation, or Model Exchange.
    pub(crate) interface: Interface,
    /// Through which FMI version: the names of its functions in messages.
    pub(crate) api: Api,
    time: f64,
    /// Model Exchange: the last time the integrator accepted (an event, a completed step);
    /// it may evaluate anywhere after it, never before.
    accepted: f64,
    start_time: f64,
    stop_time: Option<f64>,
    resources: Option<PathBuf>,
    pub(crate) logger: Logger,
    /// Addresses of the FMU states this instance handed out and has not freed.
    pub(crate) fmu_states: HashSet<usize>,
    /// FMI 3.0 Co-Simulation with `eventModeUsed = true`: the sample clock that ticks the model.
    clocked: Option<Clocked>,
}

/// A sampled-data model its clock ticks (FMI 3.0 Co-Simulation in Event Mode): at a tick
/// (`fmi3SetClock`, then `fmi3UpdateDiscreteStates`) the outputs are computed from the inputs
/// set and held until the next tick, and the model steps over the clock's interval; in Step
/// Mode `fmi3DoStep` only advances time and may not pass a tick. So the command a master reads
/// is the one computed at the last tick whatever order it steps the FMUs in.
#[derive(Debug, Clone)]
struct Clocked {
    interval: f64,
    /// The outputs, as (type, value reference), in the order of `held`.
    outputs: Vec<(BaseType, ValueReference)>,
    held: Vec<f64>,
    /// Ticks taken: the next is at `start_time + ticks · interval`.
    ticks: u64,
    /// Activated and not yet ticked.
    active: bool,
}

impl Clocked {
    fn new(description: &ModelDescription) -> Option<Self> {
        let clock = description.sample_clock.as_ref()?;
        let outputs = description
            .variables
            .iter()
            .filter(|v| v.causality == Causality::Output)
            .map(|v| (v.kind.base(), v.value_reference))
            .collect();
        Some(Clocked {
            interval: clock.interval,
            outputs,
            held: Vec::new(),
            ticks: 0,
            active: false,
        })
    }

    /// The held value of output `vr` of type `base`, if it is one.
    fn held(&self, base: BaseType, vr: ValueReference) -> Option<f64> {
        let i = self.outputs.iter().position(|o| *o == (base, vr))?;
        self.held.get(i).copied()
    }

    fn snapshot(&self) -> ClockSnapshot {
        ClockSnapshot {
            ticks: self.ticks,
            active: self.active,
            held: self.held.clone(),
        }
    }
}

/// Whether two times are the same communication point (the master's arithmetic may differ
/// from ours in the last digits).
fn same_time(a: f64, b: f64) -> bool {
    (a - b).abs() <= TIME_TOLERANCE * a.abs().max(b.abs()).max(1.0)
}

/// What the per-value checks of a get or set read about a variable, packed beside its index
/// into the variable table: a table entry is large (name, description, dependencies), and these
/// checks run for every value of every call at every communication point. Measured (`perf`,
/// the 10 s bump loop with `hinf_of`): the checks were about a fifth of the time inside the
/// FMUs; reading slots instead of table entries made the loop 7 % faster.
#[derive(Debug, Clone, Copy)]
struct Slot {
    /// Index into `description.variables`.
    variable: usize,
    causality: Causality,
    variability: Variability,
    /// A Real's `min` and `max` (±∞ where it has none).
    min: f64,
    max: f64,
}

impl Slot {
    fn new(variable: usize, v: &Variable) -> Self {
        let (min, max) = match v.kind {
            VarType::Real { min, max, .. } => (
                min.unwrap_or(f64::NEG_INFINITY),
                max.unwrap_or(f64::INFINITY),
            ),
            _ => (f64::NEG_INFINITY, f64::INFINITY),
        };
        Slot {
            variable,
            causality: v.causality,
            variability: v.variability,
            min,
            max,
        }
    }
}

/// The FMI version an instance was created through.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Api {
    Fmi2,
    Fmi3,
}

impl Api {
    /// The C name of the function `name` (`"DoStep"`) in this version (`fmi2DoStep`).
    pub fn name(self, name: &str) -> String {
        match self {
            Api::Fmi2 => format!("fmi2{name}"),
            Api::Fmi3 => format!("fmi3{name}"),
        }
    }
}

/// One of the variables FMI 3.0's description declares beside the model's.
enum Fmi3Variable {
    Time,
    EventIndicator(usize),
}

/// An FMU state as handed to the importer: the serialised instance.
pub struct FmuStateBox {
    pub(crate) bytes: Vec<u8>,
}

fn base_slot(b: BaseType) -> usize {
    match b {
        BaseType::Real => 0,
        BaseType::Integer => 1,
        BaseType::Boolean => 2,
    }
}

impl<M: Model> Instance<M> {
    /// `fmi2Instantiate`. On failure the logger is returned so the caller can report why.
    pub fn instantiate(
        instance_name: &str,
        fmu_type: Fmi2Type,
        guid: Option<&str>,
        resource_location: Option<&str>,
        callbacks: &CallbackFunctions,
        logging_on: bool,
    ) -> Result<Box<Self>, (Logger, String)> {
        let logger = Logger::new(callbacks, instance_name, logging_on);
        let interface = match fmu_type {
            FMI2_CO_SIMULATION => Interface::CoSimulation,
            FMI2_MODEL_EXCHANGE => Interface::ModelExchange,
            _ => {
                let why = format!(
                    "fmuType {fmu_type} is neither Model Exchange (0) nor Co-Simulation (1)"
                );
                return Err((logger, why));
            }
        };
        let resources = match resource_location {
            None => None,
            Some(loc) => match uri::resource_path(loc) {
                Ok(p) => Some(p),
                Err(e) => return Err((logger, e.to_string())),
            },
        };
        Self::create(Api::Fmi2, logger, interface, guid, resources, false)
    }

    /// `fmi3InstantiateCoSimulation` and `fmi3InstantiateModelExchange`: `resource_path` is a
    /// native path (FMI 3.0.2 §2.3.1), not a URI; `logger` the FMI 3.0 one; `event_mode_used`
    /// Co-Simulation's, which only a model with a sample clock accepts.
    pub fn instantiate3(
        logger: Logger,
        interface: Interface,
        token: Option<&str>,
        resource_path: Option<&str>,
        event_mode_used: bool,
    ) -> Result<Box<Self>, (Logger, String)> {
        let resources = resource_path.map(PathBuf::from);
        if let Some(dir) = resources.as_ref().filter(|d| !d.is_dir()) {
            let why = format!("resourcePath '{}' is not a directory", dir.display());
            return Err((logger, why));
        }
        Self::create(
            Api::Fmi3,
            logger,
            interface,
            token,
            resources,
            event_mode_used,
        )
    }

    /// The instance of either version: the description for `resources`, the token checked
    /// against it, the model instantiated.
    fn create(
        api: Api,
        logger: Logger,
        interface: Interface,
        token: Option<&str>,
        resources: Option<PathBuf>,
        event_mode_used: bool,
    ) -> Result<Box<Self>, (Logger, String)> {
        let description = match M::description(resources.as_deref()) {
            Ok(d) => d,
            Err(e) => return Err((logger, e.message)),
        };
        let clocked = match (event_mode_used, Clocked::new(&description)) {
            (false, _) => None,
            (true, Some(c)) => Some(c),
            (true, None) => {
                let why = "eventModeUsed = true, but this FMU has no Event Mode in \
                           Co-Simulation (hasEventMode = false: no clock ticks it)";
                return Err((logger, why.into()));
            }
        };
        let (what, argument) = match api {
            Api::Fmi2 => ("GUID", "fmuGUID"),
            Api::Fmi3 => ("instantiation token", "instantiationToken"),
        };
        match token {
            Some(g) if g == description.guid => {}
            Some(g) => {
                return Err((
                    logger,
                    format!(
                        "{what} mismatch: this binary is {}, the importer passed {g}",
                        description.guid
                    ),
                ))
            }
            None => return Err((logger, format!("{argument} is NULL"))),
        }
        if interface == Interface::ModelExchange && description.model_exchange.is_none() {
            let why = match api {
                Api::Fmi2 => {
                    "fmuType 0 (Model Exchange) requested, but this FMU supports Co-Simulation (1) only"
                }
                Api::Fmi3 => "Model Exchange requested, but this FMU supports Co-Simulation only",
            };
            return Err((logger, why.into()));
        }
        let model = match M::instantiate(resources.as_deref()) {
            Ok(m) => m,
            Err(e) => return Err((logger, e.message)),
        };
        let mut index: [Vec<Option<Slot>>; 3] = Default::default();
        for (i, v) in description.variables.iter().enumerate() {
            let slots = &mut index[base_slot(v.kind.base())];
            let vr = v.value_reference as usize;
            if slots.len() <= vr {
                slots.resize(vr + 1, None);
            }
            slots[vr] = Some(Slot::new(i, v));
        }
        logger.event(&format!(
            "{}: {} instantiated for {}{} (resources: {})",
            api.name("Instantiate"),
            description.model_identifier,
            interface.name(),
            if clocked.is_some() {
                ", ticked by its clock in Event Mode"
            } else {
                ""
            },
            resources
                .as_ref()
                .map(|p| p.display().to_string())
                .unwrap_or_else(|| "none".into())
        ));
        Ok(Box::new(Instance {
            magic: INSTANCE_MAGIC,
            description,
            index,
            model,
            state: FmiState::Instantiated,
            interface,
            api,
            time: 0.0,
            accepted: 0.0,
            start_time: 0.0,
            stop_time: None,
            resources,
            logger,
            fmu_states: HashSet::new(),
            clocked,
        }))
    }

    pub fn state(&self) -> FmiState {
        self.state
    }

    pub fn model(&self) -> &M {
        &self.model
    }

    pub fn time(&self) -> f64 {
        self.time
    }

    pub fn set_debug_logging(
        &mut self,
        logging_on: bool,
        categories: &[&str],
    ) -> Result<Status, String> {
        self.logger.configure(logging_on, categories)?;
        Ok(Status::Ok)
    }

    pub fn setup_experiment(
        &mut self,
        _tolerance: Option<f64>,
        start_time: f64,
        stop_time: Option<f64>,
    ) -> Result<Status, String> {
        if !start_time.is_finite() {
            return Err(format!("startTime must be finite, got {start_time}"));
        }
        if let Some(stop) = stop_time {
            if stop.is_nan() || stop < start_time {
                return Err(format!("stopTime {stop} is before startTime {start_time}"));
            }
        }
        self.start_time = start_time;
        self.time = start_time;
        self.accepted = start_time;
        self.stop_time = stop_time;
        Ok(Status::Ok)
    }

    pub fn enter_initialization_mode(&mut self) -> Result<Status, String> {
        self.state = FmiState::InitializationMode;
        Ok(Status::Ok)
    }

    pub fn exit_initialization_mode(&mut self) -> Result<Status, ModelError> {
        // Checked first: a refusal leaves the model as initialisation left it.
        if self.interface == Interface::ModelExchange {
            self.model.check_model_exchange()?;
        }
        if self.clocked.is_some() {
            self.model.check_clocked()?;
        }
        self.model.exit_initialization(self.start_time)?;
        self.state = match self.interface {
            Interface::CoSimulation if self.clocked.is_none() => FmiState::StepComplete,
            // FMI 3.0 Co-Simulation with Event Mode, as Model Exchange: into Event Mode, where
            // the clock's first tick (at the start time) is due.
            _ => FmiState::EventMode,
        };
        if let Some(mut c) = self.clocked.take() {
            c.held = self.read_outputs(&c.outputs);
            (c.ticks, c.active) = (0, false);
            self.clocked = Some(c);
        }
        self.logger.event(&format!(
            "{}: initialised at t = {}",
            self.api.name("ExitInitializationMode"),
            self.time
        ));
        Ok(Status::Ok)
    }

    pub fn terminate(&mut self) -> Result<Status, String> {
        self.state = FmiState::Terminated;
        Ok(Status::Ok)
    }

    /// `fmi2Reset`: back to the state right after `fmi2Instantiate`, start values included.
    pub fn reset(&mut self) -> Result<Status, ModelError> {
        self.model = M::instantiate(self.resources.as_deref())?;
        self.state = FmiState::Instantiated;
        self.time = 0.0;
        self.accepted = 0.0;
        self.start_time = 0.0;
        self.stop_time = None;
        if let Some(c) = &mut self.clocked {
            (c.held, c.ticks, c.active) = (Vec::new(), 0, false);
        }
        Ok(Status::Ok)
    }

    fn slot(&self, base: BaseType, vr: ValueReference) -> Result<&Slot, String> {
        self.index[base_slot(base)]
            .get(vr as usize)
            .and_then(Option::as_ref)
            .ok_or_else(|| format!("unknown value reference {vr} for type {base:?}"))
    }

    fn variable(&self, base: BaseType, vr: ValueReference) -> Result<&Variable, String> {
        let slot = self.slot(base, vr)?;
        Ok(&self.description.variables[slot.variable])
    }

    fn initialising(&self) -> bool {
        self.state.initialising()
    }

    /// Check that every `vr` is known and, in Initialization Mode, that the outputs and
    /// calculated parameters among them can be computed for the parameters set so far.
    fn check_gettable(&mut self, base: BaseType, vrs: &[ValueReference]) -> Result<(), String> {
        // The first computed variable's reference, named only in an error: this runs on every
        // get of every communication step.
        let mut computed = None;
        for &vr in vrs {
            let slot = self.slot(base, vr)?;
            if matches!(
                slot.causality,
                Causality::Output | Causality::CalculatedParameter
            ) {
                computed.get_or_insert(vr);
            }
        }
        match computed {
            Some(vr) if self.initialising() => {
                let prepared = self.model.prepare_initial_outputs(self.start_time);
                prepared.map_err(|e| {
                    let name = self.variable(base, vr).map(|v| v.name.as_str());
                    format!(
                        "'{}' cannot be computed for the parameters set: {e}",
                        name.unwrap_or_default()
                    )
                })
            }
            _ => Ok(()),
        }
    }

    /// Check that every `vr` may be set now; nothing is changed if one may not.
    fn check_settable(&self, base: BaseType, vrs: &[ValueReference]) -> Result<(), String> {
        let initialising = self.initialising();
        for &vr in vrs {
            let v = self.variable(base, vr)?;
            if !v.settable(initialising) {
                let when = if initialising {
                    ""
                } else {
                    " after initialisation"
                };
                return Err(format!(
                    "variable '{}' ({:?}, {:?}) cannot be set{when}",
                    v.name, v.causality, v.variability
                ));
            }
        }
        Ok(())
    }

    pub fn get_real(
        &mut self,
        vrs: &[ValueReference],
        values: &mut [f64],
    ) -> Result<Status, String> {
        if self.initialising() {
            self.check_gettable(BaseType::Real, vrs)?;
        } else {
            // Every known variable can be read now: one pass checks that each is known.
            for &vr in vrs {
                self.slot(BaseType::Real, vr)?;
            }
        }
        for (vr, out) in vrs.iter().zip(values.iter_mut()) {
            *out = match self.held(BaseType::Real, *vr) {
                Some(h) => h,
                None => self.model.get_real(*vr),
            };
        }
        Ok(Status::Ok)
    }

    /// The value output `vr` holds since its clock's last tick, if the clock ticks this
    /// instance and `vr` is an output.
    fn held(&self, base: BaseType, vr: ValueReference) -> Option<f64> {
        self.clocked.as_ref()?.held(base, vr)
    }

    /// The outputs' values now, computed by the model (a tick's, before it steps).
    fn read_outputs(&mut self, outputs: &[(BaseType, ValueReference)]) -> Vec<f64> {
        outputs
            .iter()
            .map(|&(base, vr)| match base {
                BaseType::Real => self.model.get_real(vr),
                BaseType::Integer => f64::from(self.model.get_integer(vr)),
                BaseType::Boolean => f64::from(u8::from(self.model.get_boolean(vr))),
            })
            .collect()
    }

    /// Which of FMI 3.0's own variables `vr` (at or above [`FMI3_TIME_VR`]) is: the
    /// independent time, the `i`-th event indicator, or none of this FMU's.
    fn fmi3_variable(&self, vr: ValueReference) -> Result<Fmi3Variable, String> {
        if vr == FMI3_TIME_VR {
            return Ok(Fmi3Variable::Time);
        }
        let i = vr.wrapping_sub(FMI3_EVENT_INDICATOR_VR) as usize;
        if vr > FMI3_TIME_VR && i < self.number_of_event_indicators() {
            Ok(Fmi3Variable::EventIndicator(i))
        } else {
            Err(format!("unknown value reference {vr} for type Float64"))
        }
    }

    /// The FMI 3.0 array parameter `vr` names, if any.
    fn array(&self, vr: ValueReference) -> Option<&ArrayParameter> {
        self.description
            .arrays
            .iter()
            .find(|a| a.value_reference == vr)
    }

    /// FMI 3.0's `nValues` for `vrs`, or why `n_values` is not it: one value per scalar, every
    /// element of an array.
    pub fn check_number_of_values(
        &self,
        vrs: &[ValueReference],
        n_values: usize,
    ) -> Result<(), String> {
        if self.description.arrays.is_empty() {
            if n_values == vrs.len() {
                return Ok(());
            }
            return Err(format!(
                "nValues = {n_values} for nValueReferences = {}: every variable of this FMU is \
                 a scalar",
                vrs.len()
            ));
        }
        let expected: usize = vrs
            .iter()
            .map(|vr| self.array(*vr).map_or(1, |a| a.values.len()))
            .sum();
        if n_values == expected {
            Ok(())
        } else {
            Err(format!(
                "nValues = {n_values}, where the {} value references name {expected} values (an \
                 array counts its elements)",
                vrs.len()
            ))
        }
    }

    /// `fmi3GetFloat64`: the model's Real variables, the arrays of the description, and the
    /// variables only FMI 3.0's description declares, the independent `time` and the event
    /// indicators ([`crate::description::FMI3_TIME_VR`]). `values` holds every element of an
    /// array, in order ([`Self::check_number_of_values`]).
    pub fn get_float64(
        &mut self,
        vrs: &[ValueReference],
        values: &mut [f64],
    ) -> Result<Status, String> {
        if vrs.iter().any(|vr| self.array(*vr).is_some()) {
            let mut at = 0;
            for vr in vrs {
                if let Some(a) = self.array(*vr) {
                    let n = a.values.len();
                    values[at..at + n].copy_from_slice(&a.values);
                    at += n;
                } else {
                    self.get_float64(std::slice::from_ref(vr), &mut values[at..at + 1])?;
                    at += 1;
                }
            }
            return Ok(Status::Ok);
        }
        if vrs.iter().all(|vr| *vr < FMI3_TIME_VR) {
            return self.get_real(vrs, values);
        }
        let mut indicators = Vec::new();
        for (vr, out) in vrs.iter().zip(values.iter_mut()) {
            if *vr < FMI3_TIME_VR {
                self.get_real(std::slice::from_ref(vr), std::slice::from_mut(out))?;
                continue;
            }
            *out = match self.fmi3_variable(*vr)? {
                Fmi3Variable::Time => self.time,
                Fmi3Variable::EventIndicator(i) => {
                    if indicators.is_empty() {
                        indicators = vec![0.0; self.number_of_event_indicators()];
                        self.get_event_indicators(&mut indicators)?;
                    }
                    indicators[i]
                }
            };
        }
        Ok(Status::Ok)
    }

    /// `fmi3SetFloat64`: the model's Real variables; FMI 3.0's own are computed.
    pub fn set_float64(
        &mut self,
        vrs: &[ValueReference],
        values: &[f64],
    ) -> Result<Status, String> {
        if let Some(a) = vrs.iter().find_map(|vr| self.array(*vr)) {
            return Err(format!(
                "'{}' is a calculated parameter (the model's, from its resources): it cannot be \
                 set",
                a.name
            ));
        }
        if let Some(vr) = vrs.iter().find(|vr| **vr >= FMI3_TIME_VR) {
            return Err(match self.fmi3_variable(*vr)? {
                Fmi3Variable::Time => "'time' is the independent variable: it cannot be set \
                                       (fmi3SetTime in Model Exchange, fmi3DoStep in \
                                       Co-Simulation)"
                    .into(),
                Fmi3Variable::EventIndicator(i) => format!(
                    "value reference {vr} is event_indicator[{}]: it cannot be set",
                    i + 1
                ),
            });
        }
        self.set_real(vrs, values)
    }

    /// The number of event indicators (0 without Model Exchange).
    pub fn number_of_event_indicators(&self) -> usize {
        self.description.number_of_event_indicators()
    }

    /// The number of continuous states (0 without Model Exchange).
    pub fn number_of_continuous_states(&self) -> usize {
        self.description.number_of_states()
    }

    pub fn set_real(&mut self, vrs: &[ValueReference], values: &[f64]) -> Result<Status, String> {
        // Every value is checked before any is set (an error changes nothing).
        let initialising = self.initialising();
        for (&vr, &value) in vrs.iter().zip(values) {
            // The common case from the packed slot; the variable's entry for a message.
            let slot = self.slot(BaseType::Real, vr)?;
            if self.state == FmiState::ContinuousTimeMode
                && !(slot.causality == Causality::Input
                    && slot.variability == Variability::Continuous)
            {
                let name = &self.description.variables[slot.variable].name;
                return Err(format!(
                    "variable '{name}' cannot be set in ContinuousTimeMode (only continuous inputs can; enter Event Mode first)"
                ));
            }
            let fine = settable(slot.causality, slot.variability, initialising)
                && value.is_finite()
                && value >= slot.min
                && value <= slot.max;
            if fine && self.model.check_real(vr, value).is_ok() {
                continue;
            }
            let v = &self.description.variables[slot.variable];
            let name = &v.name;
            if !v.settable(initialising) {
                let when = if initialising {
                    ""
                } else {
                    " after initialisation"
                };
                return Err(format!(
                    "variable '{name}' ({:?}, {:?}) cannot be set{when}",
                    v.causality, v.variability
                ));
            }
            self.check_real_value(v, value)?;
        }
        for (&vr, &value) in vrs.iter().zip(values) {
            self.model.set_real(vr, value);
        }
        Ok(Status::Ok)
    }

    /// The setter's rules for one value of a Real variable: finite, within the variable's
    /// `min`/`max`, accepted by the model.
    fn check_real_value(&self, v: &Variable, value: f64) -> Result<(), String> {
        let name = &v.name;
        if !value.is_finite() {
            return Err(format!("value of '{name}' must be finite, got {value}"));
        }
        if let VarType::Real { min, max, .. } = &v.kind {
            if let Some(m) = min.filter(|m| value < *m) {
                return Err(format!(
                    "value {} of '{name}' is below its minimum {}",
                    number(value),
                    number(m)
                ));
            }
            if let Some(m) = max.filter(|m| value > *m) {
                return Err(format!(
                    "value {} of '{name}' is above its maximum {}",
                    number(value),
                    number(m)
                ));
            }
        }
        self.model
            .check_real(v.value_reference, value)
            .map_err(|e| format!("rejected value for '{name}': {e}"))
    }

    pub fn get_integer(
        &mut self,
        vrs: &[ValueReference],
        values: &mut [i32],
    ) -> Result<Status, String> {
        self.check_gettable(BaseType::Integer, vrs)?;
        for (vr, out) in vrs.iter().zip(values.iter_mut()) {
            *out = match self.held(BaseType::Integer, *vr) {
                Some(h) => h as i32,
                None => self.model.get_integer(*vr),
            };
        }
        Ok(Status::Ok)
    }

    pub fn set_integer(
        &mut self,
        vrs: &[ValueReference],
        values: &[i32],
    ) -> Result<Status, String> {
        self.check_settable(BaseType::Integer, vrs)?;
        for (&vr, &value) in vrs.iter().zip(values) {
            self.model.set_integer(vr, value);
        }
        Ok(Status::Ok)
    }

    pub fn get_boolean(
        &mut self,
        vrs: &[ValueReference],
        values: &mut [bool],
    ) -> Result<Status, String> {
        self.check_gettable(BaseType::Boolean, vrs)?;
        for (vr, out) in vrs.iter().zip(values.iter_mut()) {
            *out = match self.held(BaseType::Boolean, *vr) {
                Some(h) => h != 0.0,
                None => self.model.get_boolean(*vr),
            };
        }
        Ok(Status::Ok)
    }

    pub fn set_boolean(
        &mut self,
        vrs: &[ValueReference],
        values: &[bool],
    ) -> Result<Status, String> {
        self.check_settable(BaseType::Boolean, vrs)?;
        for (&vr, &value) in vrs.iter().zip(values) {
            self.model.set_boolean(vr, value);
        }
        Ok(Status::Ok)
    }

    /// Our FMUs have no String variables: any value reference is unknown.
    pub fn check_string_refs(&self, vrs: &[ValueReference]) -> Result<Status, String> {
        match vrs.first() {
            Some(vr) => Err(format!(
                "unknown value reference {vr} for type String (this FMU has no String variables)"
            )),
            None => Ok(Status::Ok),
        }
    }

    pub fn set_real_input_derivatives(
        &mut self,
        vrs: &[ValueReference],
        orders: &[i32],
        values: &[f64],
    ) -> Result<Status, String> {
        if !self.description.capabilities.can_interpolate_inputs {
            return Err("this FMU cannot interpolate inputs (canInterpolateInputs = false)".into());
        }
        let mut ignored = Vec::new();
        for ((&vr, &order), &value) in vrs.iter().zip(orders).zip(values) {
            let v = self.variable(BaseType::Real, vr)?;
            if v.causality != Causality::Input {
                return Err(format!("variable '{}' is not an input", v.name));
            }
            if order < 1 {
                return Err(format!(
                    "derivative order {order} for '{}': orders start at 1",
                    v.name
                ));
            }
            if !value.is_finite() {
                return Err(format!(
                    "derivative of '{}' must be finite, got {value}",
                    v.name
                ));
            }
            // The inputs are interpolated linearly: higher derivatives (legal, the standard
            // forbids only order 0) are ignored with a warning.
            if order > 1 {
                ignored.push(format!("order {order} of '{}'", v.name));
            }
        }
        for ((&vr, &order), &value) in vrs.iter().zip(orders).zip(values) {
            if order == 1 {
                self.model.set_input_derivative(vr, value);
            }
        }
        if ignored.is_empty() {
            return Ok(Status::Ok);
        }
        self.logger.log(
            Status::Warning,
            Category::StatusWarning,
            &format!(
                "fmi2SetRealInputDerivatives: inputs are interpolated linearly, ignored {}",
                ignored.join(", ")
            ),
        );
        Ok(Status::Warning)
    }

    pub fn do_step(&mut self, current: f64, step: f64) -> Result<Status, ModelError> {
        if !(step.is_finite() && step > 0.0) {
            return Err(
                format!("communicationStepSize must be a finite number > 0, got {step}").into(),
            );
        }
        if !current.is_finite()
            || (current - self.time).abs() > TIME_TOLERANCE * current.abs().max(1.0)
        {
            return Err(format!(
                "currentCommunicationPoint {current} does not match the FMU's time {}",
                self.time
            )
            .into());
        }
        if let Some(stop) = self.stop_time {
            if current + step > stop + TIME_TOLERANCE * stop.abs().max(1.0) {
                return Err(
                    format!("step to {} goes beyond stopTime {stop}", current + step).into(),
                );
            }
        }
        if self.clocked.is_some() {
            return self.step_between_ticks(current, step).map_err(Into::into);
        }
        if let Err(e) = self.model.do_step(current, step) {
            if e.status == Status::Discard {
                // Nothing computed: the last successful time is the step's start.
                self.state = FmiState::StepFailed;
            }
            return Err(e);
        }
        self.time = current + step;
        if let Some(why) = self.model.step_warning(step) {
            self.logger.log(
                Status::Warning,
                Category::StatusWarning,
                &format!("{}: {why}", self.api.name("DoStep")),
            );
            return Ok(Status::Warning);
        }
        Ok(Status::Ok)
    }

    /// The time of the sample clock's next tick (an instance its clock ticks).
    pub fn next_tick(&self) -> Option<f64> {
        let c = self.clocked.as_ref()?;
        Some(self.start_time + c.ticks as f64 * c.interval)
    }

    /// The sample clock's name, for messages.
    fn clock_name(&self) -> &str {
        self.description
            .sample_clock
            .as_ref()
            .map_or("", |c| c.name.as_str())
    }

    /// Step Mode of an instance its clock ticks: time advances, the held outputs stay; a step
    /// may end at the next tick, not start at a tick not taken nor pass one.
    fn step_between_ticks(&mut self, current: f64, step: f64) -> Result<Status, String> {
        let next = self.next_tick().expect("a clocked instance");
        let name = self.clock_name();
        if same_time(current, next) {
            return Err(format!(
                "clock '{name}' ticks at t = {next} s and has not ticked: in Event Mode \
                 (fmi3EnterEventMode), activate it (fmi3SetClock) and let it tick \
                 (fmi3UpdateDiscreteStates) before stepping on"
            ));
        }
        let end = current + step;
        if end > next && !same_time(end, next) {
            return Err(format!(
                "the step from {current} s to {end} s passes the tick of clock '{name}' at \
                 {next} s: with eventModeUsed = true the communication points include every \
                 tick (every {} s from the start time)",
                self.clocked.as_ref().map_or(0.0, |c| c.interval)
            ));
        }
        self.time = end;
        Ok(Status::Ok)
    }

    /// `fmi3EnterEventMode`: Model Exchange's, or Co-Simulation's from Step Mode, which only an
    /// instance its clock ticks has.
    pub fn enter_event_mode3(&mut self) -> Result<Status, String> {
        if self.interface == Interface::CoSimulation {
            if self.clocked.is_none() {
                return Err("Co-Simulation's Event Mode needs eventModeUsed = true at \
                            instantiation, and a clock to tick (hasEventMode)"
                    .into());
            }
            if self.state != FmiState::StepComplete {
                return Err(format!(
                    "illegal call in state {}: Co-Simulation enters Event Mode from Step Mode",
                    self.state.name_in(self.api)
                ));
            }
        }
        self.enter_event_mode()
    }

    /// `fmi3EnterStepMode`: out of Co-Simulation's Event Mode.
    pub fn enter_step_mode(&mut self) -> Result<Status, String> {
        if self.clocked.as_ref().is_some_and(|c| c.active) {
            return Err(format!(
                "clock '{}' is active and has not ticked: fmi3UpdateDiscreteStates first",
                self.clock_name()
            ));
        }
        self.state = FmiState::StepComplete;
        Ok(Status::Ok)
    }

    /// `fmi3SetClock`: activate (or deactivate) the sample clock, at its tick only.
    pub fn set_clock(&mut self, vrs: &[ValueReference], values: &[bool]) -> Result<Status, String> {
        for &vr in vrs {
            self.check_clock_ref(vr)?;
        }
        let Some(active) = values.iter().copied().reduce(|a, b| a || b) else {
            return Ok(Status::Ok);
        };
        if self.state != FmiState::EventMode {
            return Err(format!(
                "a clock is set in Event Mode, not in {}",
                self.state.name_in(self.api)
            ));
        }
        let next = self.next_tick();
        let name = self.clock_name().to_string();
        let c = self.clocked.as_mut().ok_or_else(|| {
            format!(
                "clock '{name}' ticks this FMU only in Event Mode: instantiate it with \
                 eventModeUsed = true"
            )
        })?;
        let next = next.expect("a clocked instance");
        if active && !same_time(self.time, next) {
            return Err(format!(
                "clock '{name}' ticks every {} s from the start time: t = {} s is not its next \
                 tick, {next} s",
                c.interval, self.time
            ));
        }
        c.active = active;
        Ok(Status::Ok)
    }

    /// The sample clock's value reference, or why `vr` is not it.
    fn check_clock_ref(&self, vr: ValueReference) -> Result<(), String> {
        match &self.description.sample_clock {
            Some(c) if c.value_reference == vr => Ok(()),
            Some(c) => Err(format!(
                "unknown value reference {vr} for type Clock (this FMU's clock is '{}', {})",
                c.name, c.value_reference
            )),
            None => Err(format!(
                "unknown value reference {vr} for type Clock: this FMU has no Clock variable"
            )),
        }
    }

    /// `fmi3GetIntervalDecimal`: the constant interval, never changed (`fmi3IntervalUnchanged`).
    pub fn clock_intervals(
        &self,
        vrs: &[ValueReference],
        out: &mut [f64],
    ) -> Result<Status, String> {
        for (&vr, o) in vrs.iter().zip(out.iter_mut()) {
            self.check_clock_ref(vr)?;
            *o = self
                .description
                .sample_clock
                .as_ref()
                .map_or(0.0, |c| c.interval);
        }
        Ok(Status::Ok)
    }

    /// The clock functions that do not apply to an input clock of constant interval: the
    /// reason, naming the clock if `vrs` names it.
    pub fn clock_refusal(&self, vrs: &[ValueReference], why: &str) -> Result<Status, String> {
        match vrs.first() {
            None => Ok(Status::Ok),
            Some(&vr) => {
                self.check_clock_ref(vr)?;
                Err(format!("clock '{}' {why}", self.clock_name()))
            }
        }
    }

    /// A tick of the sample clock: the outputs for the inputs set now, held, then the model's
    /// step over the interval. On error nothing changes.
    fn tick(&mut self) -> Result<(), ModelError> {
        let c = self.clocked.take().expect("a clocked instance");
        let held = self.read_outputs(&c.outputs);
        let stepped = self.model.do_step(self.time, c.interval);
        let mut c = c;
        if let Err(e) = stepped {
            self.clocked = Some(c);
            // No step to discard in Event Mode: the tick failed.
            return Err(ModelError::error(format!(
                "the tick at t = {} s failed: {}",
                self.time, e.message
            )));
        }
        (c.held, c.ticks, c.active) = (held, c.ticks + 1, false);
        let interval = c.interval;
        self.clocked = Some(c);
        if let Some(why) = self.model.step_warning(interval) {
            self.logger.log(
                Status::Warning,
                Category::StatusWarning,
                &format!("fmi3UpdateDiscreteStates: {why}"),
            );
        }
        Ok(())
    }

    /// `fmi3UpdateDiscreteStates`: Model Exchange's event iteration, or in Co-Simulation the
    /// sample clock's tick if it was activated; either way the next time event (the next tick).
    pub fn update_discrete_states3(&mut self) -> Result<DiscreteUpdate, ModelError> {
        if self.interface == Interface::ModelExchange {
            return self.new_discrete_states();
        }
        if self.clocked.as_ref().is_some_and(|c| c.active) {
            self.tick()?;
        }
        Ok(DiscreteUpdate {
            states_changed: false,
            next_event_time: self.next_tick(),
        })
    }

    /// `fmi2Discard`, logged, for a status kind this FMU has no value for.
    pub fn status_unavailable(&self, func: &str, kind: Fmi2StatusKind) -> Status {
        self.logger.log(
            Status::Discard,
            Category::StatusDiscard,
            &format!("{func}: status kind {kind} is not available (steps are synchronous)"),
        );
        Status::Discard
    }

    pub fn get_status(&self, kind: Fmi2StatusKind) -> (Status, Status) {
        match kind {
            status_kind::DO_STEP_STATUS => {
                let last = if self.state == FmiState::StepFailed {
                    Status::Discard
                } else {
                    Status::Ok
                };
                (Status::Ok, last)
            }
            _ => (self.status_unavailable("fmi2GetStatus", kind), Status::Ok),
        }
    }

    pub fn get_real_status(&self, kind: Fmi2StatusKind) -> (Status, f64) {
        match kind {
            status_kind::LAST_SUCCESSFUL_TIME => (Status::Ok, self.time),
            _ => (self.status_unavailable("fmi2GetRealStatus", kind), 0.0),
        }
    }

    pub fn get_boolean_status(&self, kind: Fmi2StatusKind) -> (Status, bool) {
        match kind {
            status_kind::TERMINATED => (Status::Ok, false),
            _ => (self.status_unavailable("fmi2GetBooleanStatus", kind), false),
        }
    }

    /// The whole instance as bytes (FMU state by value).
    pub fn save_state(&self) -> Vec<u8> {
        let mut w = StateWriter::default();
        self.model.save(&mut w);
        fmu_state::encode(
            &self.description.guid,
            &Snapshot {
                state: self.state,
                time: self.time,
                start_time: self.start_time,
                stop_time: self.stop_time,
                payload: w.into_bytes(),
                clock: self.clocked.as_ref().map(Clocked::snapshot),
            },
        )
    }

    /// Check bytes without changing anything.
    pub fn check_state(&self, bytes: &[u8]) -> Result<(), String> {
        fmu_state::decode(&self.description.guid, bytes).map(|_| ())
    }

    /// Restore from bytes; on error nothing changes. The restored values obey the setters'
    /// rules (every parameter and input), and past initialisation the parameters' joint rules:
    /// a state whose checksum matches may still have been forged or written by a buggy tool.
    pub fn restore_state(&mut self, bytes: &[u8]) -> Result<Status, ModelError> {
        let snap = fmu_state::decode(&self.description.guid, bytes)?;
        let event_mode = self.interface == Interface::CoSimulation
            && self.clocked.is_some()
            && snap.state == FmiState::EventMode;
        if !(self.interface.reaches(snap.state) || event_mode) {
            return Err(format!(
                "FMU state refused: it was taken in {}, which a {} instance never reaches{}",
                snap.state.name(),
                self.interface.name(),
                if self.interface == Interface::CoSimulation {
                    " without eventModeUsed"
                } else {
                    ""
                }
            )
            .into());
        }
        let clock = self.restored_clock(&snap)?;
        let mut backup = StateWriter::default();
        self.model.save(&mut backup);
        self.model.restore(&mut StateReader::new(&snap.payload))?;
        if let Err(e) = self.check_restored(!snap.state.initialising()) {
            self.model
                .restore(&mut StateReader::new(&backup.into_bytes()))
                .map_err(|b| format!("{e}; restoring the previous state failed too: {b}"))?;
            return Err(format!("FMU state refused: {e}").into());
        }
        self.state = snap.state;
        self.time = snap.time;
        self.accepted = snap.time;
        self.start_time = snap.start_time;
        self.stop_time = snap.stop_time;
        if let (Some(c), Some(restored)) = (&mut self.clocked, clock) {
            (c.ticks, c.active, c.held) = (restored.ticks, restored.active, restored.held);
        }
        self.logger.event(&format!(
            "{}: restored state at t = {}",
            match self.api {
                Api::Fmi2 => "fmi2SetFMUstate",
                Api::Fmi3 => "fmi3SetFMUState",
            },
            self.time
        ));
        Ok(Status::Ok)
    }

    /// The clock's state a snapshot brings into this instance: its own if both are ticked by
    /// the clock, none before the clock has ticked; a state taken with the clock ticking (or
    /// not) past initialisation cannot continue in an instance without it (or with it).
    fn restored_clock(&self, snap: &Snapshot) -> Result<Option<ClockSnapshot>, String> {
        let initial = ClockSnapshot {
            ticks: 0,
            active: false,
            held: Vec::new(),
        };
        match (&self.clocked, &snap.clock) {
            (None, None) => Ok(None),
            _ if snap.state.initialising() => Ok(Some(initial)),
            (Some(c), Some(s)) if s.held.len() == c.outputs.len() => {
                // The time lies between the last tick taken and the next.
                let next = snap.start_time + s.ticks as f64 * c.interval;
                let after_last = s.ticks == 0 || snap.time >= next - c.interval * (1.0 + 1e-9);
                if !(after_last && (snap.time <= next || same_time(snap.time, next))) {
                    return Err(format!(
                        "FMU state refused: its clock has ticked {} times, which does not \
                         bring it to t = {} s",
                        s.ticks, snap.time
                    ));
                }
                Ok(Some(s.clone()))
            }
            (Some(c), Some(s)) => Err(format!(
                "FMU state refused: it holds {} outputs, this FMU has {}",
                s.held.len(),
                c.outputs.len()
            )),
            (mine, _) => {
                Err(format!(
                "FMU state refused: it was taken {} its clock ticking it (eventModeUsed = {}), \
                 and this instance runs {} (eventModeUsed = {})",
                if mine.is_some() { "without" } else { "with" },
                mine.is_none(),
                if mine.is_some() { "with it" } else { "without it" },
                mine.is_some()
            ))
            }
        }
    }

    /// Every settable Real variable of the restored model, by the setters' rules.
    fn check_restored(&mut self, initialised: bool) -> Result<(), String> {
        for i in 0..self.description.variables.len() {
            let v = &self.description.variables[i];
            if !matches!(v.causality, Causality::Parameter | Causality::Input)
                || !matches!(v.kind, VarType::Real { .. })
            {
                continue;
            }
            let vr = v.value_reference;
            let value = self.model.get_real(vr);
            self.check_real_value(&self.description.variables[i], value)?;
        }
        if initialised {
            self.model.check_parameters()?;
        }
        Ok(())
    }
}

/// Model Exchange (FMI 2.0.4 §3.2): the runtime checks lengths, finiteness and time; the model
/// computes.
impl<M: Model> Instance<M> {
    /// `nx`, checked against the description's number of states.
    fn check_states_len(&self, n: usize, what: &str) -> Result<(), String> {
        let nx = self.description.number_of_states();
        if n != nx {
            return Err(format!("{what}: {n} values for the {nx} continuous states"));
        }
        Ok(())
    }

    pub fn set_time(&mut self, time: f64) -> Result<Status, String> {
        if !time.is_finite() {
            return Err(format!("time must be finite, got {time}"));
        }
        let accepted = self.accepted;
        if time < accepted - TIME_TOLERANCE * accepted.abs().max(1.0) {
            return Err(format!(
                "time {time} is before {accepted}, the last time accepted (an event or a completed integrator step): an integrator goes back by restoring an FMU state",
            ));
        }
        self.time = time;
        self.model.set_time(time);
        Ok(Status::Ok)
    }

    pub fn set_continuous_states(&mut self, x: &[f64]) -> Result<Status, String> {
        self.check_states_len(x.len(), "nx")?;
        if let Some(i) = x.iter().position(|v| !v.is_finite()) {
            let (state, _) = self.description.continuous_states()[i];
            return Err(format!(
                "state '{}' must be finite, got {}",
                state.name, x[i]
            ));
        }
        self.model.set_continuous_states(x);
        Ok(Status::Ok)
    }

    pub fn get_continuous_states(&mut self, x: &mut [f64]) -> Result<Status, String> {
        self.check_states_len(x.len(), "nx")?;
        self.model.continuous_states(x);
        Ok(Status::Ok)
    }

    pub fn get_derivatives(&mut self, dx: &mut [f64]) -> Result<Status, String> {
        self.check_states_len(dx.len(), "nx")?;
        self.model.derivatives(dx);
        if let Some(i) = dx.iter().position(|v| !v.is_finite()) {
            let (_, der) = self.description.continuous_states()[i];
            return Err(format!("'{}' is not finite at t = {}", der.name, self.time));
        }
        Ok(Status::Ok)
    }

    pub fn get_nominals(&mut self, nominals: &mut [f64]) -> Result<Status, String> {
        self.check_states_len(nominals.len(), "nx")?;
        nominals.fill(1.0);
        Ok(Status::Ok)
    }

    pub fn get_event_indicators(&mut self, z: &mut [f64]) -> Result<Status, String> {
        let nz = self.number_of_event_indicators();
        if z.len() != nz {
            return Err(format!(
                "ni: {} values for the {nz} event indicators",
                z.len()
            ));
        }
        self.model.event_indicators(z);
        Ok(Status::Ok)
    }

    pub fn enter_event_mode(&mut self) -> Result<Status, String> {
        self.state = FmiState::EventMode;
        Ok(Status::Ok)
    }

    pub fn enter_continuous_time_mode(&mut self) -> Result<Status, String> {
        self.state = FmiState::ContinuousTimeMode;
        Ok(Status::Ok)
    }

    /// `fmi2NewDiscreteStates`: one event iteration; ours converge in one.
    pub fn new_discrete_states(&mut self) -> Result<DiscreteUpdate, ModelError> {
        let update = self.model.update_discrete_states(self.time)?;
        self.accepted = self.time;
        if let Some(t) = update.next_event_time.filter(|t| !t.is_finite()) {
            return Err(ModelError::error(format!(
                "next event time {t} is not finite"
            )));
        }
        Ok(update)
    }

    /// `fmi2CompletedIntegratorStep`: never asks for an event (ours are all state or time
    /// events) nor to terminate.
    pub fn completed_integrator_step(&mut self) -> Result<Status, String> {
        self.model.completed_integrator_step(self.time);
        self.accepted = self.time;
        Ok(Status::Ok)
    }
}

impl<M: Model> Instance<M> {
    /// `fmi2GetDirectionalDerivative` (FMI 2.0.4 §2.1.9): the unknowns along the knowns'
    /// seed. Unknowns are outputs or state derivatives (and, in Model Exchange, states); knowns
    /// are inputs (and, in Model Exchange, continuous states).
    pub fn get_directional_derivative(
        &mut self,
        unknowns: &[ValueReference],
        knowns: &[ValueReference],
        seed: &[f64],
        out: &mut [f64],
    ) -> Result<Status, String> {
        if !self
            .description
            .capabilities
            .provides_directional_derivative
        {
            return Err("not provided (providesDirectionalDerivative = false)".into());
        }
        let exchange = self.interface == Interface::ModelExchange;
        let states: Vec<&str> = self
            .description
            .continuous_states()
            .iter()
            .map(|(s, _)| s.name.as_str())
            .collect();
        for &vr in unknowns {
            let v = self.variable(BaseType::Real, vr)?;
            let state = exchange && states.contains(&v.name.as_str());
            if !(v.causality == Causality::Output || v.derivative_of.is_some() || state) {
                return Err(format!(
                    "unknown '{}' is not an output{}",
                    v.name,
                    if exchange {
                        ", a state or a state derivative"
                    } else {
                        ""
                    }
                ));
            }
        }
        for (&vr, &s) in knowns.iter().zip(seed) {
            let v = self.variable(BaseType::Real, vr)?;
            let state = exchange && states.contains(&v.name.as_str());
            if !(v.causality == Causality::Input || state) {
                return Err(format!(
                    "known '{}' is not an input{}",
                    v.name,
                    if exchange {
                        " or a continuous state"
                    } else {
                        ""
                    }
                ));
            }
            if !s.is_finite() {
                return Err(format!("the seed of '{}' must be finite, got {s}", v.name));
            }
        }
        self.model
            .directional_derivative(unknowns, knowns, seed, out);
        if let Some(i) = out.iter().position(|v| !v.is_finite()) {
            let name = self.variable(BaseType::Real, unknowns[i])?.name.clone();
            return Err(format!("the derivative of '{name}' is not finite"));
        }
        Ok(Status::Ok)
    }
}

/// A number as people write it: `1e-12` and `1e44`, not forty zeros; `1500` and `0.01` as is.
fn number(v: f64) -> String {
    if v != 0.0 && (v.abs() < 1e-4 || v.abs() >= 1e7) {
        format!("{v:e}")
    } else {
        v.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The smallest model, for the layout check.
    struct Nothing;

    impl Model for Nothing {
        fn description(_: Option<&std::path::Path>) -> Result<ModelDescription, ModelError> {
            Err("unused".into())
        }
        fn instantiate(_: Option<&std::path::Path>) -> Result<Self, ModelError> {
            Ok(Nothing)
        }
        fn set_real(&mut self, _: ValueReference, _: f64) {}
        fn get_real(&mut self, _: ValueReference) -> f64 {
            0.0
        }
        fn exit_initialization(&mut self, _: f64) -> Result<(), ModelError> {
            Ok(())
        }
        fn do_step(&mut self, _: f64, _: f64) -> Result<(), ModelError> {
            Ok(())
        }
        fn save(&self, _: &mut StateWriter) {}
        fn restore(&mut self, _: &mut StateReader) -> Result<(), ModelError> {
            Ok(())
        }
    }

    #[test]
    fn the_magic_is_the_first_word_of_every_instance() {
        assert_eq!(std::mem::offset_of!(Instance<Nothing>, magic), 0);
    }
}
