//! The FMI 3.0 C ABI (`fmi3Functions.h`, FMI 3.0.2) over the same [`Instance`] as FMI 2.0:
//! one generic function per call, with [`crate::ffi`]'s panic barrier, state-machine check and
//! logging. [`crate::export_fmi3!`] instantiates all 75 for one model type, so a library
//! exports FMI 2.0's and FMI 3.0's functions side by side and an importer of either version
//! finds its own.
//!
//! A model with a sample clock (the controllers) has Co-Simulation's Event Mode: with
//! `eventModeUsed = true` its clock ticks it ([`Instance::update_discrete_states3`]).
//!
//! What FMI 3.0 adds over FMI 2.0 and these FMUs do not have is refused with a message, never
//! pretended: the types beyond `Float64`, `Int32`, `Boolean` (a call naming no variable of
//! them succeeds, as it changes nothing), clocks other than a sample clock of constant
//! interval, Scheduled Execution, Configuration Mode, intermediate update, adjoint and output
//! derivatives, and per-element dependencies. Every variable is a scalar: `nValues` must equal
//! `nValueReferences`.
//!
//! # Safety
//! Every `unsafe fn` relies on the importer keeping the FMI 3.0 calling contract: `instance` is
//! NULL or a pointer this model's `fmi3Instantiate*` returned and not yet freed, and every
//! pointer argument is NULL or valid for the elements the call announces.

use crate::ffi::{self, c_str, call, catch_quietly, out_ptr, slice, slice_mut};
use crate::instance::Instance;
use crate::logger::Logger;
use crate::model::{Model, ModelError};
use crate::state_machine::{self as sm, Interface};
use crate::types::fmi3::{self, Boolean, FmiString, InstanceEnvironment, LogMessage};
use crate::types::Status;
use std::os::raw::c_char;

type Fmi3Status = fmi3::Status;
type Vr = fmi3::ValueReference;

pub fn version() -> *const c_char {
    c"3.0".as_ptr()
}

/// The values of a scalar call: `nValues` must be `nValueReferences`.
fn scalars(n_vr: usize, n_values: usize) -> Result<(), String> {
    if n_values == n_vr {
        Ok(())
    } else {
        Err(format!(
            "nValues = {n_values} for nValueReferences = {n_vr}: every variable of this FMU is \
             a scalar"
        ))
    }
}

/// `fmi3InstantiateCoSimulation` and `fmi3InstantiateModelExchange`.
#[allow(clippy::too_many_arguments)]
unsafe fn instantiate<M: Model>(
    interface: Interface,
    func: &str,
    instance_name: FmiString,
    token: FmiString,
    resource_path: FmiString,
    logging_on: Boolean,
    environment: InstanceEnvironment,
    log_message: Option<LogMessage>,
    refuse: Option<String>,
    event_mode_used: bool,
) -> fmi3::Instance {
    let result = catch_quietly(|| {
        let fail = |logger: &Logger, msg: &str| {
            logger.error(&format!("{func}: {msg}"));
            None
        };
        let anonymous = || Logger::fmi3(log_message, environment, "", true);
        let name = match c_str(instance_name) {
            Some(Ok(n)) => n.to_string(),
            Some(Err(e)) => return fail(&anonymous(), &format!("instanceName: {e}")),
            None => return fail(&anonymous(), "instanceName is NULL"),
        };
        let logger = Logger::fmi3(log_message, environment, &name, logging_on);
        if let Some(why) = refuse {
            return fail(&logger, &why);
        }
        let (token, path) = match (c_str(token).transpose(), c_str(resource_path).transpose()) {
            (Ok(t), Ok(p)) => (t, p),
            (Err(e), _) | (_, Err(e)) => return fail(&logger, &e),
        };
        match Instance::<M>::instantiate3(logger, interface, token, path, event_mode_used) {
            Ok(inst) => Some(Box::into_raw(inst) as fmi3::Instance),
            Err((logger, msg)) => fail(&logger, &msg),
        }
    });
    result.ok().flatten().unwrap_or(std::ptr::null_mut())
}

/// `fmi3InstantiateModelExchange`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn instantiate_model_exchange<M: Model>(
    instance_name: FmiString,
    token: FmiString,
    resource_path: FmiString,
    _visible: Boolean,
    logging_on: Boolean,
    environment: InstanceEnvironment,
    log_message: Option<LogMessage>,
) -> fmi3::Instance {
    instantiate::<M>(
        Interface::ModelExchange,
        "fmi3InstantiateModelExchange",
        instance_name,
        token,
        resource_path,
        logging_on,
        environment,
        log_message,
        None,
        false,
    )
}

/// `fmi3InstantiateCoSimulation`. These FMUs step to any communication point exactly; only one
/// with a sample clock has Event Mode (`hasEventMode`), and `eventModeUsed` is refused by the
/// others; early return is never taken and intermediate variables are never updated, so asking
/// for them is harmless.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
#[allow(clippy::too_many_arguments)]
pub unsafe fn instantiate_co_simulation<M: Model>(
    instance_name: FmiString,
    token: FmiString,
    resource_path: FmiString,
    _visible: Boolean,
    logging_on: Boolean,
    event_mode_used: Boolean,
    _early_return_allowed: Boolean,
    _required_intermediate: *const Vr,
    _n_required_intermediate: usize,
    environment: InstanceEnvironment,
    log_message: Option<LogMessage>,
    _intermediate_update: Option<fmi3::IntermediateUpdate>,
) -> fmi3::Instance {
    instantiate::<M>(
        Interface::CoSimulation,
        "fmi3InstantiateCoSimulation",
        instance_name,
        token,
        resource_path,
        logging_on,
        environment,
        log_message,
        None,
        event_mode_used,
    )
}

/// `fmi3InstantiateScheduledExecution`: not supported; says so and returns NULL.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn instantiate_scheduled_execution<M: Model>(
    instance_name: FmiString,
    token: FmiString,
    resource_path: FmiString,
    _visible: Boolean,
    logging_on: Boolean,
    environment: InstanceEnvironment,
    log_message: Option<LogMessage>,
) -> fmi3::Instance {
    instantiate::<M>(
        Interface::CoSimulation,
        "fmi3InstantiateScheduledExecution",
        instance_name,
        token,
        resource_path,
        logging_on,
        environment,
        log_message,
        Some("this FMU does not support Scheduled Execution".into()),
        false,
    )
}

/// `fmi3FreeInstance`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn free_instance<M: Model>(c: fmi3::Instance) {
    crate::ffi::free_instance::<M>(c)
}

/// `fmi3SetDebugLogging`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn set_debug_logging<M: Model>(
    c: fmi3::Instance,
    logging_on: Boolean,
    n: usize,
    categories: *const FmiString,
) -> Fmi3Status {
    ffi::set_debug_logging_named::<M>(c, "fmi3SetDebugLogging", logging_on, n, categories)
}

/// `fmi3EnterInitializationMode`: FMI 2.0's `fmi2SetupExperiment` and
/// `fmi2EnterInitializationMode` in one call.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn enter_initialization_mode<M: Model>(
    c: fmi3::Instance,
    tolerance_defined: Boolean,
    tolerance: f64,
    start: f64,
    stop_defined: Boolean,
    stop: f64,
) -> Fmi3Status {
    call::<M, String>(
        c,
        "fmi3EnterInitializationMode",
        sm::ENTER_INITIALIZATION_MODE,
        |inst| {
            inst.setup_experiment(
                tolerance_defined.then_some(tolerance),
                start,
                stop_defined.then_some(stop),
            )?;
            inst.enter_initialization_mode()
        },
    )
}

/// `fmi3ExitInitializationMode`: into Step Mode (Co-Simulation) or Event Mode (Model
/// Exchange).
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn exit_initialization_mode<M: Model>(c: fmi3::Instance) -> Fmi3Status {
    call::<M, ModelError>(
        c,
        "fmi3ExitInitializationMode",
        sm::EXIT_INITIALIZATION_MODE,
        |inst| inst.exit_initialization_mode(),
    )
}

/// `fmi3EnterEventMode`: Model Exchange's, and Co-Simulation's for an instance its clock ticks.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn enter_event_mode<M: Model>(c: fmi3::Instance) -> Fmi3Status {
    call::<M, String>(c, "fmi3EnterEventMode", sm::ENTER_EVENT_MODE3, |inst| {
        inst.enter_event_mode3()
    })
}

/// The clock functions, over the sample clock (if the model has one).
pub enum ClockCall {
    /// `fmi3SetClock` (from the values).
    Set(*const Boolean),
    /// `fmi3GetClock`: refused, the sample clock being an input.
    Get,
    /// `fmi3GetIntervalDecimal` (into the intervals and qualifiers).
    Interval(*mut f64, *mut i32),
    /// `fmi3GetShiftDecimal`: the constant clock's shift, 0.
    Shift(*mut f64),
    /// What an input clock of constant interval does not do, and why.
    Refuse(&'static str),
}

/// `fmi3SetClock`, `fmi3GetClock`, the intervals and the shifts.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn clock<M: Model>(
    c: fmi3::Instance,
    func: &str,
    vr: *const Vr,
    n: usize,
    what: ClockCall,
) -> Fmi3Status {
    let mask = match what {
        ClockCall::Set(_) => sm::SET_VALUES,
        _ => sm::GET_VALUES,
    };
    call::<M, String>(c, func, mask, |inst| {
        let vrs = slice(vr, n, "valueReferences")?;
        match what {
            ClockCall::Set(values) => inst.set_clock(vrs, slice(values, n, "values")?),
            ClockCall::Get => inst.clock_refusal(
                vrs,
                "is an input clock, which the importer activates: fmi3GetClock reads output clocks",
            ),
            ClockCall::Interval(intervals, qualifiers) => {
                inst.clock_intervals(vrs, slice_mut(intervals, n, "intervals")?)?;
                // fmi3IntervalUnchanged: a constant interval.
                slice_mut(qualifiers, n, "qualifiers")?.fill(1);
                Ok(Status::Ok)
            }
            ClockCall::Shift(shifts) => {
                let shifts = slice_mut(shifts, n, "shifts")?;
                inst.clock_intervals(vrs, shifts)?;
                shifts.fill(0.0);
                Ok(Status::Ok)
            }
            ClockCall::Refuse(why) => inst.clock_refusal(vrs, why),
        }
    })
}

/// `fmi3Terminate`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn terminate<M: Model>(c: fmi3::Instance) -> Fmi3Status {
    call::<M, String>(c, "fmi3Terminate", sm::TERMINATE, |inst| inst.terminate())
}

/// `fmi3Reset`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn reset<M: Model>(c: fmi3::Instance) -> Fmi3Status {
    call::<M, ModelError>(c, "fmi3Reset", sm::RESET, |inst| inst.reset())
}

/// `fmi3GetFloat64`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn get_float64<M: Model>(
    c: fmi3::Instance,
    vr: *const Vr,
    n: usize,
    values: *mut f64,
    n_values: usize,
) -> Fmi3Status {
    call::<M, String>(c, "fmi3GetFloat64", sm::GET_VALUES, |inst| {
        let vrs = slice(vr, n, "valueReferences")?;
        inst.check_number_of_values(vrs, n_values)?;
        inst.get_float64(vrs, slice_mut(values, n_values, "values")?)
    })
}

/// `fmi3SetFloat64`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn set_float64<M: Model>(
    c: fmi3::Instance,
    vr: *const Vr,
    n: usize,
    values: *const f64,
    n_values: usize,
) -> Fmi3Status {
    call::<M, String>(c, "fmi3SetFloat64", sm::SET_REAL, |inst| {
        let vrs = slice(vr, n, "valueReferences")?;
        inst.check_number_of_values(vrs, n_values)?;
        inst.set_float64(vrs, slice(values, n_values, "values")?)
    })
}

/// `fmi3GetInt32`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn get_int32<M: Model>(
    c: fmi3::Instance,
    vr: *const Vr,
    n: usize,
    values: *mut i32,
    n_values: usize,
) -> Fmi3Status {
    call::<M, String>(c, "fmi3GetInt32", sm::GET_VALUES, |inst| {
        scalars(n, n_values)?;
        inst.get_integer(
            slice(vr, n, "valueReferences")?,
            slice_mut(values, n, "values")?,
        )
    })
}

/// `fmi3SetInt32`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn set_int32<M: Model>(
    c: fmi3::Instance,
    vr: *const Vr,
    n: usize,
    values: *const i32,
    n_values: usize,
) -> Fmi3Status {
    call::<M, String>(c, "fmi3SetInt32", sm::SET_VALUES, |inst| {
        scalars(n, n_values)?;
        inst.set_integer(
            slice(vr, n, "valueReferences")?,
            slice(values, n, "values")?,
        )
    })
}

/// `fmi3GetBoolean` (C99 `bool`).
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn get_boolean<M: Model>(
    c: fmi3::Instance,
    vr: *const Vr,
    n: usize,
    values: *mut Boolean,
    n_values: usize,
) -> Fmi3Status {
    call::<M, String>(c, "fmi3GetBoolean", sm::GET_VALUES, |inst| {
        scalars(n, n_values)?;
        inst.get_boolean(
            slice(vr, n, "valueReferences")?,
            slice_mut(values, n, "values")?,
        )
    })
}

/// `fmi3SetBoolean`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn set_boolean<M: Model>(
    c: fmi3::Instance,
    vr: *const Vr,
    n: usize,
    values: *const Boolean,
    n_values: usize,
) -> Fmi3Status {
    call::<M, String>(c, "fmi3SetBoolean", sm::SET_VALUES, |inst| {
        scalars(n, n_values)?;
        inst.set_boolean(
            slice(vr, n, "valueReferences")?,
            slice(values, n, "values")?,
        )
    })
}

/// `fmi3GetString` and `fmi3SetString`: these FMUs have no String variable.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn string_values<M: Model>(
    c: fmi3::Instance,
    func: &str,
    get: bool,
    vr: *const Vr,
    n: usize,
    n_values: usize,
) -> Fmi3Status {
    let mask = if get { sm::GET_VALUES } else { sm::SET_VALUES };
    call::<M, String>(c, func, mask, |inst| {
        scalars(n, n_values)?;
        inst.check_string_refs(slice(vr, n, "valueReferences")?)
    })
}

/// A get or set of a type these FMUs have no variable of (`Float32`, the 8-, 16- and 64-bit
/// integers, `UInt32`, `Binary`, `Clock`): fine for no value reference, an error naming the
/// first one otherwise.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn absent_type<M: Model>(
    c: fmi3::Instance,
    func: &str,
    type_name: &str,
    get: bool,
    vr: *const Vr,
    n: usize,
) -> Fmi3Status {
    let mask = if get { sm::GET_VALUES } else { sm::SET_VALUES };
    call::<M, String>(c, func, mask, |_| {
        match slice(vr, n, "valueReferences")?.first() {
            None => Ok(Status::Ok),
            Some(v) => Err(format!(
                "unknown value reference {v} for type {type_name}: this FMU has no {type_name} \
             variable"
            )),
        }
    })
}

/// A function of a capability these FMUs declare they do not have: always `fmi3Error`, with
/// why, in any state but Fatal.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn not_provided<M: Model>(c: fmi3::Instance, func: &str, why: &str) -> Fmi3Status {
    call::<M, String>(c, func, sm::ANY_BUT_FATAL, |_| Err(why.to_string()))
}

/// `fmi3GetFMUState`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn get_fmu_state<M: Model>(c: fmi3::Instance, state: *mut fmi3::FmuState) -> Fmi3Status {
    ffi::get_fmu_state_named::<M>(c, "fmi3GetFMUState", state)
}

/// `fmi3SetFMUState`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn set_fmu_state<M: Model>(c: fmi3::Instance, state: fmi3::FmuState) -> Fmi3Status {
    ffi::set_fmu_state_named::<M>(c, "fmi3SetFMUState", state)
}

/// `fmi3FreeFMUState`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn free_fmu_state<M: Model>(
    c: fmi3::Instance,
    state: *mut fmi3::FmuState,
) -> Fmi3Status {
    ffi::free_fmu_state_named::<M>(c, "fmi3FreeFMUState", state)
}

/// `fmi3SerializedFMUStateSize`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn serialized_fmu_state_size<M: Model>(
    c: fmi3::Instance,
    state: fmi3::FmuState,
    size: *mut usize,
) -> Fmi3Status {
    ffi::serialized_fmu_state_size_named::<M>(c, "fmi3SerializedFMUStateSize", state, size)
}

/// `fmi3SerializeFMUState`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn serialize_fmu_state<M: Model>(
    c: fmi3::Instance,
    state: fmi3::FmuState,
    bytes: *mut fmi3::Byte,
    size: usize,
) -> Fmi3Status {
    ffi::serialize_fmu_state_named::<M>(c, "fmi3SerializeFMUState", state, bytes, size)
}

/// `fmi3DeserializeFMUState`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn deserialize_fmu_state<M: Model>(
    c: fmi3::Instance,
    bytes: *const fmi3::Byte,
    size: usize,
    state: *mut fmi3::FmuState,
) -> Fmi3Status {
    ffi::deserialize_fmu_state_named::<M>(c, "fmi3DeserializeFMUState", bytes, size, state)
}

/// `fmi3GetDirectionalDerivative`: scalars, so `nSeed = nKnowns` and
/// `nSensitivity = nUnknowns`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
#[allow(clippy::too_many_arguments)]
pub unsafe fn get_directional_derivative<M: Model>(
    c: fmi3::Instance,
    unknowns: *const Vr,
    n_unknowns: usize,
    knowns: *const Vr,
    n_knowns: usize,
    seed: *const f64,
    n_seed: usize,
    sensitivity: *mut f64,
    n_sensitivity: usize,
) -> Fmi3Status {
    call::<M, String>(
        c,
        "fmi3GetDirectionalDerivative",
        sm::DIRECTIONAL_DERIVATIVE,
        |inst| {
            if n_seed != n_knowns || n_sensitivity != n_unknowns {
                return Err(format!(
                    "nSeed = {n_seed} for {n_knowns} knowns and nSensitivity = {n_sensitivity} \
                     for {n_unknowns} unknowns: every variable of this FMU is a scalar"
                ));
            }
            inst.get_directional_derivative(
                slice(unknowns, n_unknowns, "unknowns")?,
                slice(knowns, n_knowns, "knowns")?,
                slice(seed, n_seed, "seed")?,
                slice_mut(sensitivity, n_sensitivity, "sensitivity")?,
            )
        },
    )
}

/// `fmi3DoStep`: exact to the communication point, so no early return; event handling is
/// needed where a step ends at the sample clock's tick (an instance its clock ticks);
/// `lastSuccessfulTime` is the instance's time after the call (the step's start when the
/// step was discarded).
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
#[allow(clippy::too_many_arguments)]
pub unsafe fn do_step<M: Model>(
    c: fmi3::Instance,
    current: f64,
    step: f64,
    _no_prior: Boolean,
    event_handling_needed: *mut Boolean,
    terminate_simulation: *mut Boolean,
    early_return: *mut Boolean,
    last_successful_time: *mut f64,
) -> Fmi3Status {
    call::<M, ModelError>(c, "fmi3DoStep", sm::DO_STEP, |inst| {
        let event = out_ptr(event_handling_needed, "eventHandlingNeeded")?;
        let terminate = out_ptr(terminate_simulation, "terminateSimulation")?;
        let early = out_ptr(early_return, "earlyReturn")?;
        let last = out_ptr(last_successful_time, "lastSuccessfulTime")?;
        let result = inst.do_step(current, step);
        // At the clock's next tick: Event Mode is due.
        let tick = inst.next_tick().is_some_and(|t| {
            t == inst.time() || { (t - inst.time()).abs() <= 1e-9 * t.abs().max(1.0) }
        });
        (*event, *terminate, *early) = (tick && result.is_ok(), false, false);
        *last = inst.time();
        result
    })
}

/// `fmi3UpdateDiscreteStates`: Model Exchange's event iteration, or Co-Simulation's tick.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
#[allow(clippy::too_many_arguments)]
pub unsafe fn update_discrete_states<M: Model>(
    c: fmi3::Instance,
    discrete_states_need_update: *mut Boolean,
    terminate_simulation: *mut Boolean,
    nominals_changed: *mut Boolean,
    values_changed: *mut Boolean,
    next_event_time_defined: *mut Boolean,
    next_event_time: *mut f64,
) -> Fmi3Status {
    call::<M, ModelError>(
        c,
        "fmi3UpdateDiscreteStates",
        sm::UPDATE_DISCRETE_STATES3,
        |inst| {
            let need = out_ptr(discrete_states_need_update, "discreteStatesNeedUpdate")?;
            let terminate = out_ptr(terminate_simulation, "terminateSimulation")?;
            let nominals = out_ptr(nominals_changed, "nominalsOfContinuousStatesChanged")?;
            let values = out_ptr(values_changed, "valuesOfContinuousStatesChanged")?;
            let defined = out_ptr(next_event_time_defined, "nextEventTimeDefined")?;
            let next = out_ptr(next_event_time, "nextEventTime")?;
            let update = inst.update_discrete_states3()?;
            (*need, *terminate, *nominals) = (false, false, false);
            *values = update.states_changed;
            *defined = update.next_event_time.is_some();
            *next = update.next_event_time.unwrap_or(0.0);
            Ok(Status::Ok)
        },
    )
}

/// `fmi3EnterContinuousTimeMode`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn enter_continuous_time_mode<M: Model>(c: fmi3::Instance) -> Fmi3Status {
    call::<M, String>(
        c,
        "fmi3EnterContinuousTimeMode",
        sm::ENTER_CONTINUOUS_TIME_MODE,
        |inst| inst.enter_continuous_time_mode(),
    )
}

/// `fmi3CompletedIntegratorStep`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn completed_integrator_step<M: Model>(
    c: fmi3::Instance,
    _no_prior: Boolean,
    enter_event_mode: *mut Boolean,
    terminate_simulation: *mut Boolean,
) -> Fmi3Status {
    call::<M, String>(
        c,
        "fmi3CompletedIntegratorStep",
        sm::COMPLETED_INTEGRATOR_STEP,
        |inst| {
            let event = out_ptr(enter_event_mode, "enterEventMode")?;
            let terminate = out_ptr(terminate_simulation, "terminateSimulation")?;
            let status = inst.completed_integrator_step()?;
            (*event, *terminate) = (false, false);
            Ok(status)
        },
    )
}

/// `fmi3SetTime`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn set_time<M: Model>(c: fmi3::Instance, time: f64) -> Fmi3Status {
    call::<M, String>(c, "fmi3SetTime", sm::SET_TIME, |inst| inst.set_time(time))
}

/// `fmi3SetContinuousStates`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn set_continuous_states<M: Model>(
    c: fmi3::Instance,
    x: *const f64,
    nx: usize,
) -> Fmi3Status {
    call::<M, String>(
        c,
        "fmi3SetContinuousStates",
        sm::SET_CONTINUOUS_STATES,
        |inst| inst.set_continuous_states(slice(x, nx, "continuousStates")?),
    )
}

/// `fmi3GetContinuousStateDerivatives`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn get_derivatives<M: Model>(c: fmi3::Instance, dx: *mut f64, nx: usize) -> Fmi3Status {
    call::<M, String>(
        c,
        "fmi3GetContinuousStateDerivatives",
        sm::GET_DERIVATIVES,
        |inst| inst.get_derivatives(slice_mut(dx, nx, "derivatives")?),
    )
}

/// `fmi3GetEventIndicators`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn get_event_indicators<M: Model>(
    c: fmi3::Instance,
    z: *mut f64,
    ni: usize,
) -> Fmi3Status {
    call::<M, String>(
        c,
        "fmi3GetEventIndicators",
        sm::GET_EVENT_INDICATORS,
        |inst| inst.get_event_indicators(slice_mut(z, ni, "eventIndicators")?),
    )
}

/// `fmi3GetContinuousStates`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn get_continuous_states<M: Model>(
    c: fmi3::Instance,
    x: *mut f64,
    nx: usize,
) -> Fmi3Status {
    call::<M, String>(
        c,
        "fmi3GetContinuousStates",
        sm::GET_CONTINUOUS_STATES,
        |inst| inst.get_continuous_states(slice_mut(x, nx, "continuousStates")?),
    )
}

/// `fmi3GetNominalsOfContinuousStates`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn get_nominals<M: Model>(c: fmi3::Instance, x: *mut f64, nx: usize) -> Fmi3Status {
    call::<M, String>(
        c,
        "fmi3GetNominalsOfContinuousStates",
        sm::GET_NOMINALS_OF_CONTINUOUS_STATES,
        |inst| inst.get_nominals(slice_mut(x, nx, "nominals")?),
    )
}

/// `fmi3GetNumberOfEventIndicators` and `fmi3GetNumberOfContinuousStates`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn number_of<M: Model>(
    c: fmi3::Instance,
    func: &str,
    states: bool,
    out: *mut usize,
) -> Fmi3Status {
    call::<M, String>(c, func, sm::NUMBER_OF, |inst| {
        *out_ptr(out, "the count")? = if states {
            inst.number_of_continuous_states()
        } else {
            inst.number_of_event_indicators()
        };
        Ok(Status::Ok)
    })
}

/// `fmi3EnterStepMode`: out of Co-Simulation's Event Mode.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn enter_step_mode<M: Model>(c: fmi3::Instance) -> Fmi3Status {
    call::<M, String>(c, "fmi3EnterStepMode", sm::ENTER_STEP_MODE, |inst| {
        inst.enter_step_mode()
    })
}

/// The functions of `fmi3Functions.h` (FMI 3.0.2) that [`crate::export_fmi3!`] exports, for
/// the packager's check of a library built for any platform.
pub const EXPORTED_FUNCTIONS: [&str; 75] = [
    "fmi3ActivateModelPartition",
    "fmi3CompletedIntegratorStep",
    "fmi3DeserializeFMUState",
    "fmi3DoStep",
    "fmi3EnterConfigurationMode",
    "fmi3EnterContinuousTimeMode",
    "fmi3EnterEventMode",
    "fmi3EnterInitializationMode",
    "fmi3EnterStepMode",
    "fmi3EvaluateDiscreteStates",
    "fmi3ExitConfigurationMode",
    "fmi3ExitInitializationMode",
    "fmi3FreeFMUState",
    "fmi3FreeInstance",
    "fmi3GetAdjointDerivative",
    "fmi3GetBinary",
    "fmi3GetBoolean",
    "fmi3GetClock",
    "fmi3GetContinuousStateDerivatives",
    "fmi3GetContinuousStates",
    "fmi3GetDirectionalDerivative",
    "fmi3GetEventIndicators",
    "fmi3GetFMUState",
    "fmi3GetFloat32",
    "fmi3GetFloat64",
    "fmi3GetInt16",
    "fmi3GetInt32",
    "fmi3GetInt64",
    "fmi3GetInt8",
    "fmi3GetIntervalDecimal",
    "fmi3GetIntervalFraction",
    "fmi3GetNominalsOfContinuousStates",
    "fmi3GetNumberOfContinuousStates",
    "fmi3GetNumberOfEventIndicators",
    "fmi3GetNumberOfVariableDependencies",
    "fmi3GetOutputDerivatives",
    "fmi3GetShiftDecimal",
    "fmi3GetShiftFraction",
    "fmi3GetString",
    "fmi3GetUInt16",
    "fmi3GetUInt32",
    "fmi3GetUInt64",
    "fmi3GetUInt8",
    "fmi3GetVariableDependencies",
    "fmi3GetVersion",
    "fmi3InstantiateCoSimulation",
    "fmi3InstantiateModelExchange",
    "fmi3InstantiateScheduledExecution",
    "fmi3Reset",
    "fmi3SerializeFMUState",
    "fmi3SerializedFMUStateSize",
    "fmi3SetBinary",
    "fmi3SetBoolean",
    "fmi3SetClock",
    "fmi3SetContinuousStates",
    "fmi3SetDebugLogging",
    "fmi3SetFMUState",
    "fmi3SetFloat32",
    "fmi3SetFloat64",
    "fmi3SetInt16",
    "fmi3SetInt32",
    "fmi3SetInt64",
    "fmi3SetInt8",
    "fmi3SetIntervalDecimal",
    "fmi3SetIntervalFraction",
    "fmi3SetShiftDecimal",
    "fmi3SetShiftFraction",
    "fmi3SetString",
    "fmi3SetTime",
    "fmi3SetUInt16",
    "fmi3SetUInt32",
    "fmi3SetUInt64",
    "fmi3SetUInt8",
    "fmi3Terminate",
    "fmi3UpdateDiscreteStates",
];

/// Export the 75 FMI 3.0 functions of `fmi3Functions.h` for one [`Model`] type, beside
/// [`crate::export_fmi2!`]'s: `fmu_core::export_fmi3!(MyModel);`.
#[macro_export]
macro_rules! export_fmi3 {
    ($model:ty) => {
        #[allow(clippy::missing_safety_doc)]
        mod fmi3_exports {
            use super::*;
            use std::os::raw::c_char;
            use $crate::ffi3;
            use $crate::types::fmi3::{
                Boolean, Byte, ClockUpdate, FmiString, FmuState, Instance, InstanceEnvironment,
                IntermediateUpdate, LogMessage, Preemption, Status, ValueReference as Vr,
            };
            type M = $model;

            /// The absent types' getters and setters: `fmi3{Get,Set}<Type>` with
            /// `(instance, vr, n, values, nValues)`.
            macro_rules! absent {
                ($get:ident, $set:ident, $t:ty, $name:literal) => {
                    #[no_mangle]
                    pub unsafe extern "C" fn $get(
                        c: Instance,
                        vr: *const Vr,
                        n: usize,
                        _v: *mut $t,
                        _nv: usize,
                    ) -> Status {
                        ffi3::absent_type::<M>(c, stringify!($get), $name, true, vr, n)
                    }
                    #[no_mangle]
                    pub unsafe extern "C" fn $set(
                        c: Instance,
                        vr: *const Vr,
                        n: usize,
                        _v: *const $t,
                        _nv: usize,
                    ) -> Status {
                        ffi3::absent_type::<M>(c, stringify!($set), $name, false, vr, n)
                    }
                };
            }
            absent!(fmi3GetFloat32, fmi3SetFloat32, f32, "Float32");
            absent!(fmi3GetInt8, fmi3SetInt8, i8, "Int8");
            absent!(fmi3GetUInt8, fmi3SetUInt8, u8, "UInt8");
            absent!(fmi3GetInt16, fmi3SetInt16, i16, "Int16");
            absent!(fmi3GetUInt16, fmi3SetUInt16, u16, "UInt16");
            absent!(fmi3GetUInt32, fmi3SetUInt32, u32, "UInt32");
            absent!(fmi3GetInt64, fmi3SetInt64, i64, "Int64");
            absent!(fmi3GetUInt64, fmi3SetUInt64, u64, "UInt64");

            #[no_mangle]
            pub extern "C" fn fmi3GetVersion() -> *const c_char {
                ffi3::version()
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetDebugLogging(
                c: Instance,
                on: Boolean,
                n: usize,
                cats: *const FmiString,
            ) -> Status {
                ffi3::set_debug_logging::<M>(c, on, n, cats)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3InstantiateModelExchange(
                name: FmiString,
                token: FmiString,
                path: FmiString,
                visible: Boolean,
                log: Boolean,
                env: InstanceEnvironment,
                logger: Option<LogMessage>,
            ) -> Instance {
                ffi3::instantiate_model_exchange::<M>(name, token, path, visible, log, env, logger)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3InstantiateCoSimulation(
                name: FmiString,
                token: FmiString,
                path: FmiString,
                visible: Boolean,
                log: Boolean,
                event_mode_used: Boolean,
                early_return_allowed: Boolean,
                required: *const Vr,
                n_required: usize,
                env: InstanceEnvironment,
                logger: Option<LogMessage>,
                update: Option<IntermediateUpdate>,
            ) -> Instance {
                ffi3::instantiate_co_simulation::<M>(
                    name,
                    token,
                    path,
                    visible,
                    log,
                    event_mode_used,
                    early_return_allowed,
                    required,
                    n_required,
                    env,
                    logger,
                    update,
                )
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3InstantiateScheduledExecution(
                name: FmiString,
                token: FmiString,
                path: FmiString,
                visible: Boolean,
                log: Boolean,
                env: InstanceEnvironment,
                logger: Option<LogMessage>,
                _clock_update: Option<ClockUpdate>,
                _lock: Option<Preemption>,
                _unlock: Option<Preemption>,
            ) -> Instance {
                ffi3::instantiate_scheduled_execution::<M>(
                    name, token, path, visible, log, env, logger,
                )
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3FreeInstance(c: Instance) {
                ffi3::free_instance::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3EnterInitializationMode(
                c: Instance,
                tolerance_defined: Boolean,
                tolerance: f64,
                start: f64,
                stop_defined: Boolean,
                stop: f64,
            ) -> Status {
                ffi3::enter_initialization_mode::<M>(
                    c,
                    tolerance_defined,
                    tolerance,
                    start,
                    stop_defined,
                    stop,
                )
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3ExitInitializationMode(c: Instance) -> Status {
                ffi3::exit_initialization_mode::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3EnterEventMode(c: Instance) -> Status {
                ffi3::enter_event_mode::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3Terminate(c: Instance) -> Status {
                ffi3::terminate::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3Reset(c: Instance) -> Status {
                ffi3::reset::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetFloat64(
                c: Instance,
                vr: *const Vr,
                n: usize,
                v: *mut f64,
                nv: usize,
            ) -> Status {
                ffi3::get_float64::<M>(c, vr, n, v, nv)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetFloat64(
                c: Instance,
                vr: *const Vr,
                n: usize,
                v: *const f64,
                nv: usize,
            ) -> Status {
                ffi3::set_float64::<M>(c, vr, n, v, nv)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetInt32(
                c: Instance,
                vr: *const Vr,
                n: usize,
                v: *mut i32,
                nv: usize,
            ) -> Status {
                ffi3::get_int32::<M>(c, vr, n, v, nv)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetInt32(
                c: Instance,
                vr: *const Vr,
                n: usize,
                v: *const i32,
                nv: usize,
            ) -> Status {
                ffi3::set_int32::<M>(c, vr, n, v, nv)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetBoolean(
                c: Instance,
                vr: *const Vr,
                n: usize,
                v: *mut Boolean,
                nv: usize,
            ) -> Status {
                ffi3::get_boolean::<M>(c, vr, n, v, nv)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetBoolean(
                c: Instance,
                vr: *const Vr,
                n: usize,
                v: *const Boolean,
                nv: usize,
            ) -> Status {
                ffi3::set_boolean::<M>(c, vr, n, v, nv)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetString(
                c: Instance,
                vr: *const Vr,
                n: usize,
                _v: *mut FmiString,
                nv: usize,
            ) -> Status {
                ffi3::string_values::<M>(c, "fmi3GetString", true, vr, n, nv)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetString(
                c: Instance,
                vr: *const Vr,
                n: usize,
                _v: *const FmiString,
                nv: usize,
            ) -> Status {
                ffi3::string_values::<M>(c, "fmi3SetString", false, vr, n, nv)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetBinary(
                c: Instance,
                vr: *const Vr,
                n: usize,
                _sizes: *mut usize,
                _v: *mut *const Byte,
                _nv: usize,
            ) -> Status {
                ffi3::absent_type::<M>(c, "fmi3GetBinary", "Binary", true, vr, n)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetBinary(
                c: Instance,
                vr: *const Vr,
                n: usize,
                _sizes: *const usize,
                _v: *const *const Byte,
                _nv: usize,
            ) -> Status {
                ffi3::absent_type::<M>(c, "fmi3SetBinary", "Binary", false, vr, n)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetClock(
                c: Instance,
                vr: *const Vr,
                n: usize,
                _v: *mut Boolean,
            ) -> Status {
                ffi3::clock::<M>(c, "fmi3GetClock", vr, n, ffi3::ClockCall::Get)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetClock(
                c: Instance,
                vr: *const Vr,
                n: usize,
                _v: *const Boolean,
            ) -> Status {
                ffi3::clock::<M>(c, "fmi3SetClock", vr, n, ffi3::ClockCall::Set(_v))
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetNumberOfVariableDependencies(
                c: Instance,
                _vr: Vr,
                _n: *mut usize,
            ) -> Status {
                ffi3::not_provided::<M>(
                    c,
                    "fmi3GetNumberOfVariableDependencies",
                    "not provided (providesPerElementDependencies = false): the dependencies \
                     are in modelDescription.xml",
                )
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetVariableDependencies(
                c: Instance,
                _dependent: Vr,
                _element: *mut usize,
                _independents: *mut Vr,
                _elements: *mut usize,
                _kinds: *mut i32,
                _n: usize,
            ) -> Status {
                ffi3::not_provided::<M>(
                    c,
                    "fmi3GetVariableDependencies",
                    "not provided (providesPerElementDependencies = false): the dependencies \
                     are in modelDescription.xml",
                )
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetFMUState(c: Instance, s: *mut FmuState) -> Status {
                ffi3::get_fmu_state::<M>(c, s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetFMUState(c: Instance, s: FmuState) -> Status {
                ffi3::set_fmu_state::<M>(c, s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3FreeFMUState(c: Instance, s: *mut FmuState) -> Status {
                ffi3::free_fmu_state::<M>(c, s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SerializedFMUStateSize(
                c: Instance,
                s: FmuState,
                size: *mut usize,
            ) -> Status {
                ffi3::serialized_fmu_state_size::<M>(c, s, size)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SerializeFMUState(
                c: Instance,
                s: FmuState,
                bytes: *mut Byte,
                size: usize,
            ) -> Status {
                ffi3::serialize_fmu_state::<M>(c, s, bytes, size)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3DeserializeFMUState(
                c: Instance,
                bytes: *const Byte,
                size: usize,
                s: *mut FmuState,
            ) -> Status {
                ffi3::deserialize_fmu_state::<M>(c, bytes, size, s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetDirectionalDerivative(
                c: Instance,
                unknowns: *const Vr,
                n_unknowns: usize,
                knowns: *const Vr,
                n_knowns: usize,
                seed: *const f64,
                n_seed: usize,
                sensitivity: *mut f64,
                n_sensitivity: usize,
            ) -> Status {
                ffi3::get_directional_derivative::<M>(
                    c,
                    unknowns,
                    n_unknowns,
                    knowns,
                    n_knowns,
                    seed,
                    n_seed,
                    sensitivity,
                    n_sensitivity,
                )
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetAdjointDerivative(
                c: Instance,
                _unknowns: *const Vr,
                _n_unknowns: usize,
                _knowns: *const Vr,
                _n_knowns: usize,
                _seed: *const f64,
                _n_seed: usize,
                _sensitivity: *mut f64,
                _n_sensitivity: usize,
            ) -> Status {
                ffi3::not_provided::<M>(
                    c,
                    "fmi3GetAdjointDerivative",
                    "not provided (providesAdjointDerivatives = false)",
                )
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3EnterConfigurationMode(c: Instance) -> Status {
                ffi3::not_provided::<M>(
                    c,
                    "fmi3EnterConfigurationMode",
                    "this FMU has no structural parameters",
                )
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3ExitConfigurationMode(c: Instance) -> Status {
                ffi3::not_provided::<M>(
                    c,
                    "fmi3ExitConfigurationMode",
                    "this FMU has no structural parameters, so no Configuration Mode",
                )
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetIntervalDecimal(
                c: Instance,
                vr: *const Vr,
                n: usize,
                _intervals: *mut f64,
                _qualifiers: *mut i32,
            ) -> Status {
                ffi3::clock::<M>(c, "fmi3GetIntervalDecimal", vr, n, ffi3::ClockCall::Interval(_intervals, _qualifiers))
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetIntervalFraction(
                c: Instance,
                vr: *const Vr,
                n: usize,
                _counters: *mut u64,
                _resolutions: *mut u64,
                _qualifiers: *mut i32,
            ) -> Status {
                ffi3::clock::<M>(c, "fmi3GetIntervalFraction", vr, n, ffi3::ClockCall::Refuse("supports no fractions (supportsFraction = false): fmi3GetIntervalDecimal"))
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetShiftDecimal(
                c: Instance,
                vr: *const Vr,
                n: usize,
                _shifts: *mut f64,
            ) -> Status {
                ffi3::clock::<M>(c, "fmi3GetShiftDecimal", vr, n, ffi3::ClockCall::Shift(_shifts))
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetShiftFraction(
                c: Instance,
                vr: *const Vr,
                n: usize,
                _counters: *mut u64,
                _resolutions: *mut u64,
            ) -> Status {
                ffi3::clock::<M>(c, "fmi3GetShiftFraction", vr, n, ffi3::ClockCall::Refuse("supports no fractions (supportsFraction = false): fmi3GetShiftDecimal"))
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetIntervalDecimal(
                c: Instance,
                vr: *const Vr,
                n: usize,
                _intervals: *const f64,
            ) -> Status {
                ffi3::clock::<M>(c, "fmi3SetIntervalDecimal", vr, n, ffi3::ClockCall::Refuse("has a constant interval (intervalDecimal in modelDescription.xml): it cannot be set"))
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetIntervalFraction(
                c: Instance,
                vr: *const Vr,
                n: usize,
                _counters: *const u64,
                _resolutions: *const u64,
            ) -> Status {
                ffi3::clock::<M>(c, "fmi3SetIntervalFraction", vr, n, ffi3::ClockCall::Refuse("has a constant interval (intervalDecimal in modelDescription.xml): it cannot be set"))
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetShiftDecimal(
                c: Instance,
                vr: *const Vr,
                n: usize,
                _shifts: *const f64,
            ) -> Status {
                ffi3::clock::<M>(c, "fmi3SetShiftDecimal", vr, n, ffi3::ClockCall::Refuse("has a constant shift of 0: it cannot be set"))
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetShiftFraction(
                c: Instance,
                vr: *const Vr,
                n: usize,
                _counters: *const u64,
                _resolutions: *const u64,
            ) -> Status {
                ffi3::clock::<M>(c, "fmi3SetShiftFraction", vr, n, ffi3::ClockCall::Refuse("has a constant shift of 0: it cannot be set"))
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3EvaluateDiscreteStates(c: Instance) -> Status {
                ffi3::not_provided::<M>(
                    c,
                    "fmi3EvaluateDiscreteStates",
                    "not provided (providesEvaluateDiscreteStates = false)",
                )
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3UpdateDiscreteStates(
                c: Instance,
                need: *mut Boolean,
                terminate: *mut Boolean,
                nominals: *mut Boolean,
                values: *mut Boolean,
                defined: *mut Boolean,
                next: *mut f64,
            ) -> Status {
                ffi3::update_discrete_states::<M>(
                    c, need, terminate, nominals, values, defined, next,
                )
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3EnterContinuousTimeMode(c: Instance) -> Status {
                ffi3::enter_continuous_time_mode::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3CompletedIntegratorStep(
                c: Instance,
                no_prior: Boolean,
                event: *mut Boolean,
                terminate: *mut Boolean,
            ) -> Status {
                ffi3::completed_integrator_step::<M>(c, no_prior, event, terminate)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetTime(c: Instance, t: f64) -> Status {
                ffi3::set_time::<M>(c, t)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3SetContinuousStates(
                c: Instance,
                x: *const f64,
                nx: usize,
            ) -> Status {
                ffi3::set_continuous_states::<M>(c, x, nx)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetContinuousStateDerivatives(
                c: Instance,
                dx: *mut f64,
                nx: usize,
            ) -> Status {
                ffi3::get_derivatives::<M>(c, dx, nx)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetEventIndicators(
                c: Instance,
                z: *mut f64,
                nz: usize,
            ) -> Status {
                ffi3::get_event_indicators::<M>(c, z, nz)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetContinuousStates(
                c: Instance,
                x: *mut f64,
                nx: usize,
            ) -> Status {
                ffi3::get_continuous_states::<M>(c, x, nx)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetNominalsOfContinuousStates(
                c: Instance,
                x: *mut f64,
                nx: usize,
            ) -> Status {
                ffi3::get_nominals::<M>(c, x, nx)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetNumberOfEventIndicators(
                c: Instance,
                n: *mut usize,
            ) -> Status {
                ffi3::number_of::<M>(c, "fmi3GetNumberOfEventIndicators", false, n)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetNumberOfContinuousStates(
                c: Instance,
                n: *mut usize,
            ) -> Status {
                ffi3::number_of::<M>(c, "fmi3GetNumberOfContinuousStates", true, n)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3EnterStepMode(c: Instance) -> Status {
                ffi3::enter_step_mode::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3GetOutputDerivatives(
                c: Instance,
                _vr: *const Vr,
                _n: usize,
                _orders: *const i32,
                _v: *mut f64,
                _nv: usize,
            ) -> Status {
                ffi3::not_provided::<M>(
                    c,
                    "fmi3GetOutputDerivatives",
                    "not provided (maxOutputDerivativeOrder = 0)",
                )
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3DoStep(
                c: Instance,
                t: f64,
                h: f64,
                no_prior: Boolean,
                event: *mut Boolean,
                terminate: *mut Boolean,
                early: *mut Boolean,
                last: *mut f64,
            ) -> Status {
                ffi3::do_step::<M>(c, t, h, no_prior, event, terminate, early, last)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi3ActivateModelPartition(
                c: Instance,
                _clock: Vr,
                _time: f64,
            ) -> Status {
                ffi3::not_provided::<M>(
                    c,
                    "fmi3ActivateModelPartition",
                    "a function of Scheduled Execution, which this FMU does not support",
                )
            }
        }
        pub use fmi3_exports::*;
    };
}
