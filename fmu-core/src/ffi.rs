//! The C ABI: one generic function per FMI 2.0 call. Each converts the C arguments, checks the
//! state machine, calls the safe [`Instance`] method, turns an `Err` into `fmi2Error` plus a
//! log line naming the function and the cause, and never lets a panic cross `extern "C"`.
//! [`crate::export_fmi2!`] instantiates all 44 of them for one model type: the 34 common and
//! Co-Simulation functions and the 10 of Model Exchange (answered with `fmi2Error` on an
//! instance of the other interface).
//!
//! # Safety
//! Every `unsafe fn` here relies on the importer keeping the FMI 2.0 calling contract: the
//! component `c` is NULL or a pointer that this model's `fmi2Instantiate` returned and that is
//! not yet freed, and every pointer argument is NULL or valid for the elements the call announces
//! (`nvr` value references and values, one output slot). NULL is answered with `fmi2Error`.

use crate::instance::{FmuStateBox, Instance, INSTANCE_MAGIC};
use crate::logger::{Category, Logger};
use crate::model::{Model, ModelError};
use crate::state_machine::{self as sm, FmiState, Mask};
use crate::types::*;
use std::cell::{Cell, RefCell};
use std::ffi::CStr;
use std::os::raw::c_char;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::Once;

thread_local! {
    /// How deep this thread is inside our FMI functions.
    static INSIDE: Cell<u32> = const { Cell::new(0) };
    /// Where the last panic inside them happened, for the log.
    static LOCATION: RefCell<Option<String>> = const { RefCell::new(None) };
}

static QUIET_HOOK: Once = Once::new();

/// `catch_unwind`, keeping the panic off the importer's stderr: the message goes to the FMI
/// logger instead (the caller logs it, with the location recorded here). A panic hook belongs
/// to the Rust runtime, one per FMU library (each links its own `std`), so it is installed once;
/// it is silent only for panics inside our FMI calls on the panicking thread and passes any
/// other panic (a Rust importer linking this crate, its tests) to the hook it replaced.
pub(crate) fn catch_quietly<R>(f: impl FnOnce() -> R) -> Result<R, String> {
    QUIET_HOOK.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if INSIDE.with(Cell::get) > 0 {
                let at = info
                    .location()
                    .map(|l| format!("{}:{}", l.file(), l.line()));
                LOCATION.with(|l| *l.borrow_mut() = at);
            } else {
                previous(info)
            }
        }));
    });
    INSIDE.with(|c| c.set(c.get() + 1));
    let result = catch_unwind(AssertUnwindSafe(f));
    INSIDE.with(|c| c.set(c.get() - 1));
    result.map_err(|payload| {
        let message = payload
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown panic".into());
        match LOCATION.with(|l| l.borrow_mut().take()) {
            Some(at) => format!("{message} (at {at})"),
            None => message,
        }
    })
}

/// `n` elements at `ptr`, or an error naming the argument if it is NULL while `n > 0`.
pub(crate) unsafe fn slice<'a, T>(ptr: *const T, n: usize, what: &str) -> Result<&'a [T], String> {
    if n == 0 {
        Ok(&[])
    } else if ptr.is_null() {
        Err(format!(
            "argument '{what}' is NULL but {n} elements were announced"
        ))
    } else {
        Ok(std::slice::from_raw_parts(ptr, n))
    }
}

pub(crate) unsafe fn slice_mut<'a, T>(
    ptr: *mut T,
    n: usize,
    what: &str,
) -> Result<&'a mut [T], String> {
    if n == 0 {
        Ok(&mut [])
    } else if ptr.is_null() {
        Err(format!(
            "argument '{what}' is NULL but {n} elements were announced"
        ))
    } else {
        Ok(std::slice::from_raw_parts_mut(ptr, n))
    }
}

pub(crate) unsafe fn out_ptr<'a, T>(ptr: *mut T, what: &str) -> Result<&'a mut T, String> {
    ptr.as_mut()
        .ok_or_else(|| format!("argument '{what}' is NULL"))
}

/// The instance behind `c`, if `c` points at a live instance of this model.
pub(crate) unsafe fn instance<'a, M: Model>(c: Fmi2Component) -> Option<&'a mut Instance<M>> {
    let inst = (c as *mut Instance<M>).as_mut()?;
    (inst.magic == INSTANCE_MAGIC).then_some(inst)
}

/// Run `body` on the instance if the call is legal in its state; log and enter `Error`
/// otherwise. A panic becomes `fmi2Error` (the instance can still be reset or freed). The
/// runtime's own refusals are messages (`E = String`, `fmi2Error`); a call that forwards a
/// model's failure (`E = ModelError`) answers with the status the model chose.
pub(crate) unsafe fn call<M: Model, E: Into<ModelError>>(
    c: Fmi2Component,
    func: &str,
    mask: Mask,
    body: impl FnOnce(&mut Instance<M>) -> Result<Status, E>,
) -> Fmi2Status {
    let Some(inst) = instance::<M>(c) else {
        return Status::Error as Fmi2Status;
    };
    let wrong_interface = mask.only.filter(|i| *i != inst.interface);
    if let Some(only) = wrong_interface {
        inst.logger.error(&format!(
            "{func}: a function of {} only, and this instance was instantiated for {}",
            only.name(),
            inst.interface.name()
        ));
        if inst.state != FmiState::Fatal {
            inst.state = FmiState::Error;
        }
        return Status::Error as Fmi2Status;
    }
    if !inst.state.is_in(mask) {
        let msg = format!(
            "{func}: illegal call in state {}",
            inst.state.name_in(inst.api)
        );
        inst.logger.error(&msg);
        if inst.state != FmiState::Fatal {
            inst.state = FmiState::Error;
        }
        return Status::Error as Fmi2Status;
    }
    match catch_quietly(|| body(inst).map_err(Into::into)) {
        Ok(Ok(status)) => status as Fmi2Status,
        // The call changed nothing; the instance says where it is (`StepFailed` after a
        // discarded step).
        Ok(Err(e)) if e.status == Status::Discard => {
            inst.logger.log(
                Status::Discard,
                Category::StatusDiscard,
                &format!("{func}: {}", e.message),
            );
            Status::Discard as Fmi2Status
        }
        Ok(Err(e)) => {
            inst.logger.error(&format!("{func}: {}", e.message));
            let (state, status) = match e.status {
                Status::Fatal => (FmiState::Fatal, Status::Fatal),
                _ => (FmiState::Error, Status::Error),
            };
            inst.state = state;
            status as Fmi2Status
        }
        Err(panic) => {
            // The instance may be half-updated: only reset, free or a saved state can help.
            inst.logger
                .error(&format!("{func}: internal error: {panic}"));
            inst.state = FmiState::Error;
            Status::Error as Fmi2Status
        }
    }
}

pub(crate) unsafe fn c_str<'a>(p: Fmi2String) -> Option<Result<&'a str, String>> {
    (!p.is_null()).then(|| {
        CStr::from_ptr(p)
            .to_str()
            .map_err(|_| "string argument is not valid UTF-8".to_string())
    })
}

pub fn types_platform() -> *const c_char {
    c"default".as_ptr()
}

pub fn version() -> *const c_char {
    c"2.0".as_ptr()
}

/// `fmi2Instantiate`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn instantiate<M: Model>(
    instance_name: Fmi2String,
    fmu_type: Fmi2Type,
    guid: Fmi2String,
    resource_location: Fmi2String,
    functions: *const CallbackFunctions,
    _visible: Fmi2Boolean,
    logging_on: Fmi2Boolean,
) -> Fmi2Component {
    let result = catch_quietly(|| {
        // Without callbacks there is nobody to tell; the standard requires them.
        let callbacks = *functions.as_ref()?;
        let fail = |logger: &Logger, msg: &str| {
            logger.error(&format!("fmi2Instantiate: {msg}"));
            None
        };
        let name = match c_str(instance_name) {
            Some(Ok(n)) => n.to_string(),
            Some(Err(e)) => {
                return fail(
                    &Logger::new(&callbacks, "", true),
                    &format!("instanceName: {e}"),
                )
            }
            None => return fail(&Logger::new(&callbacks, "", true), "instanceName is NULL"),
        };
        let texts = (
            c_str(guid).transpose(),
            c_str(resource_location).transpose(),
        );
        let (guid, location) = match texts {
            (Ok(g), Ok(l)) => (g, l),
            (Err(e), _) | (_, Err(e)) => return fail(&Logger::new(&callbacks, &name, true), &e),
        };
        match Instance::<M>::instantiate(
            &name,
            fmu_type,
            guid,
            location,
            &callbacks,
            logging_on != FMI2_FALSE,
        ) {
            Ok(inst) => Some(Box::into_raw(inst) as Fmi2Component),
            Err((logger, msg)) => fail(&logger, &msg),
        }
    });
    result.ok().flatten().unwrap_or(std::ptr::null_mut())
}

/// `fmi2FreeInstance`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn free_instance<M: Model>(c: Fmi2Component) {
    let _ = catch_quietly(|| {
        let Some(inst) = instance::<M>(c) else { return };
        if !inst.state.is_in(sm::FREE_INSTANCE) {
            inst.logger.error(&format!(
                "fmi2FreeInstance: illegal call in state {}",
                inst.state.name()
            ));
        }
        // Free the FMU states the importer did not free: they belong to this instance.
        for addr in inst.fmu_states.drain() {
            drop(Box::from_raw(addr as *mut FmuStateBox));
        }
        inst.magic = 0;
        drop(Box::from_raw(c as *mut Instance<M>));
    });
}

/// `fmi2SetDebugLogging`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn set_debug_logging<M: Model>(
    c: Fmi2Component,
    logging_on: Fmi2Boolean,
    n: usize,
    categories: *const Fmi2String,
) -> Fmi2Status {
    set_debug_logging_named::<M>(
        c,
        "fmi2SetDebugLogging",
        logging_on != FMI2_FALSE,
        n,
        categories,
    )
}

/// `fmi2SetDebugLogging` and `fmi3SetDebugLogging`, under the caller's function name.
pub(crate) unsafe fn set_debug_logging_named<M: Model>(
    c: Fmi2Component,
    func: &str,
    logging_on: bool,
    n: usize,
    categories: *const Fmi2String,
) -> Fmi2Status {
    call::<M, String>(c, func, sm::SET_DEBUG_LOGGING, |inst| {
        let ptrs = slice(categories, n, "categories")?;
        let mut names = Vec::with_capacity(n);
        for p in ptrs {
            names.push(c_str(*p).ok_or("a category is NULL")??);
        }
        inst.set_debug_logging(logging_on, &names)
    })
}

/// `fmi2SetupExperiment`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn setup_experiment<M: Model>(
    c: Fmi2Component,
    tol_defined: Fmi2Boolean,
    tol: f64,
    start: f64,
    stop_defined: Fmi2Boolean,
    stop: f64,
) -> Fmi2Status {
    call::<M, String>(c, "fmi2SetupExperiment", sm::SETUP_EXPERIMENT, |inst| {
        inst.setup_experiment(
            (tol_defined != FMI2_FALSE).then_some(tol),
            start,
            (stop_defined != FMI2_FALSE).then_some(stop),
        )
    })
}

/// `fmi2EnterInitializationMode`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn enter_initialization_mode<M: Model>(c: Fmi2Component) -> Fmi2Status {
    call::<M, String>(
        c,
        "fmi2EnterInitializationMode",
        sm::ENTER_INITIALIZATION_MODE,
        |inst| inst.enter_initialization_mode(),
    )
}

/// `fmi2ExitInitializationMode`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn exit_initialization_mode<M: Model>(c: Fmi2Component) -> Fmi2Status {
    call::<M, ModelError>(
        c,
        "fmi2ExitInitializationMode",
        sm::EXIT_INITIALIZATION_MODE,
        |inst| inst.exit_initialization_mode(),
    )
}

/// `fmi2Terminate`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn terminate<M: Model>(c: Fmi2Component) -> Fmi2Status {
    call::<M, String>(c, "fmi2Terminate", sm::TERMINATE, |inst| inst.terminate())
}

/// `fmi2Reset`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn reset<M: Model>(c: Fmi2Component) -> Fmi2Status {
    call::<M, ModelError>(c, "fmi2Reset", sm::RESET, |inst| inst.reset())
}

/// `fmi2GetReal`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn get_real<M: Model>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    n: usize,
    value: *mut f64,
) -> Fmi2Status {
    call::<M, String>(c, "fmi2GetReal", sm::GET_VALUES, |inst| {
        inst.get_real(slice(vr, n, "vr")?, slice_mut(value, n, "value")?)
    })
}

/// `fmi2SetReal`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn set_real<M: Model>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    n: usize,
    value: *const f64,
) -> Fmi2Status {
    call::<M, String>(c, "fmi2SetReal", sm::SET_REAL, |inst| {
        inst.set_real(slice(vr, n, "vr")?, slice(value, n, "value")?)
    })
}

/// `fmi2GetInteger`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn get_integer<M: Model>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    n: usize,
    value: *mut Fmi2Integer,
) -> Fmi2Status {
    call::<M, String>(c, "fmi2GetInteger", sm::GET_VALUES, |inst| {
        inst.get_integer(slice(vr, n, "vr")?, slice_mut(value, n, "value")?)
    })
}

/// `fmi2SetInteger`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn set_integer<M: Model>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    n: usize,
    value: *const Fmi2Integer,
) -> Fmi2Status {
    call::<M, String>(c, "fmi2SetInteger", sm::SET_VALUES, |inst| {
        inst.set_integer(slice(vr, n, "vr")?, slice(value, n, "value")?)
    })
}

/// `fmi2GetBoolean`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn get_boolean<M: Model>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    n: usize,
    value: *mut Fmi2Boolean,
) -> Fmi2Status {
    call::<M, String>(c, "fmi2GetBoolean", sm::GET_VALUES, |inst| {
        let vrs = slice(vr, n, "vr")?;
        let out = slice_mut(value, n, "value")?;
        let mut tmp = vec![false; n];
        let status = inst.get_boolean(vrs, &mut tmp)?;
        for (o, b) in out.iter_mut().zip(tmp) {
            *o = if b { FMI2_TRUE } else { FMI2_FALSE };
        }
        Ok(status)
    })
}

/// `fmi2SetBoolean`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn set_boolean<M: Model>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    n: usize,
    value: *const Fmi2Boolean,
) -> Fmi2Status {
    call::<M, String>(c, "fmi2SetBoolean", sm::SET_VALUES, |inst| {
        let values: Vec<bool> = slice(value, n, "value")?
            .iter()
            .map(|v| *v != FMI2_FALSE)
            .collect();
        inst.set_boolean(slice(vr, n, "vr")?, &values)
    })
}

/// `fmi2GetString`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn get_string<M: Model>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    n: usize,
    value: *mut Fmi2String,
) -> Fmi2Status {
    call::<M, String>(c, "fmi2GetString", sm::GET_VALUES, |inst| {
        slice_mut(value, n, "value")?;
        inst.check_string_refs(slice(vr, n, "vr")?)
    })
}

/// `fmi2SetString`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn set_string<M: Model>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    n: usize,
    value: *const Fmi2String,
) -> Fmi2Status {
    call::<M, String>(c, "fmi2SetString", sm::SET_VALUES, |inst| {
        slice(value, n, "value")?;
        inst.check_string_refs(slice(vr, n, "vr")?)
    })
}

/// Is `state` an FMU state this instance handed out and has not freed?
pub(crate) fn owned_state<M: Model>(
    inst: &Instance<M>,
    state: Fmi2FmuState,
) -> Result<&'static mut FmuStateBox, String> {
    if state.is_null() {
        return Err("FMU state is NULL".into());
    }
    if !inst.fmu_states.contains(&(state as usize)) {
        return Err("FMU state was not created by this instance or was already freed".into());
    }
    // SAFETY: the address is one of our live `Box<FmuStateBox>` allocations.
    Ok(unsafe { &mut *(state as *mut FmuStateBox) })
}

pub(crate) fn new_state<M: Model>(inst: &mut Instance<M>, bytes: Vec<u8>) -> Fmi2FmuState {
    let ptr = Box::into_raw(Box::new(FmuStateBox { bytes })) as Fmi2FmuState;
    inst.fmu_states.insert(ptr as usize);
    ptr
}

/// `fmi2GetFMUstate`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn get_fmu_state<M: Model>(c: Fmi2Component, state: *mut Fmi2FmuState) -> Fmi2Status {
    get_fmu_state_named::<M>(c, "fmi2GetFMUstate", state)
}

/// `fmi2SetFMUstate`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn set_fmu_state<M: Model>(c: Fmi2Component, state: Fmi2FmuState) -> Fmi2Status {
    set_fmu_state_named::<M>(c, "fmi2SetFMUstate", state)
}

/// `fmi2FreeFMUstate`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn free_fmu_state<M: Model>(c: Fmi2Component, state: *mut Fmi2FmuState) -> Fmi2Status {
    free_fmu_state_named::<M>(c, "fmi2FreeFMUstate", state)
}

/// `fmi2SerializedFMUstateSize`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn serialized_fmu_state_size<M: Model>(
    c: Fmi2Component,
    state: Fmi2FmuState,
    size: *mut usize,
) -> Fmi2Status {
    serialized_fmu_state_size_named::<M>(c, "fmi2SerializedFMUstateSize", state, size)
}

/// `fmi2SerializeFMUstate`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn serialize_fmu_state<M: Model>(
    c: Fmi2Component,
    state: Fmi2FmuState,
    bytes: *mut Fmi2Byte,
    size: usize,
) -> Fmi2Status {
    serialize_fmu_state_named::<M>(c, "fmi2SerializeFMUstate", state, bytes as *mut u8, size)
}

/// `fmi2DeSerializeFMUstate`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn deserialize_fmu_state<M: Model>(
    c: Fmi2Component,
    bytes: *const Fmi2Byte,
    size: usize,
    state: *mut Fmi2FmuState,
) -> Fmi2Status {
    deserialize_fmu_state_named::<M>(
        c,
        "fmi2DeSerializeFMUstate",
        bytes as *const u8,
        size,
        state,
    )
}

// The FMU state calls of both versions (FMI 3.0 spells them `FMUState`): the same pointers,
// under the calling version's function name.

pub(crate) unsafe fn get_fmu_state_named<M: Model>(
    c: Fmi2Component,
    func: &str,
    state: *mut Fmi2FmuState,
) -> Fmi2Status {
    call::<M, String>(c, func, sm::FMU_STATE, |inst| {
        let out = out_ptr(state, "FMUstate")?;
        let bytes = inst.save_state();
        if out.is_null() {
            *out = new_state(inst, bytes);
        } else {
            // FMI 2.0.4 §2.1.8: a non-NULL *FMUstate is a previous state to be overwritten.
            owned_state(inst, *out)?.bytes = bytes;
        }
        Ok(Status::Ok)
    })
}

pub(crate) unsafe fn set_fmu_state_named<M: Model>(
    c: Fmi2Component,
    func: &str,
    state: Fmi2FmuState,
) -> Fmi2Status {
    call::<M, ModelError>(c, func, sm::FMU_STATE, |inst| {
        let bytes = owned_state(inst, state)?.bytes.clone();
        inst.restore_state(&bytes)
    })
}

pub(crate) unsafe fn free_fmu_state_named<M: Model>(
    c: Fmi2Component,
    func: &str,
    state: *mut Fmi2FmuState,
) -> Fmi2Status {
    call::<M, String>(c, func, sm::FMU_STATE, |inst| {
        // A NULL pointer, like a NULL state, frees nothing (as free(NULL) does).
        if state.is_null() {
            return Ok(Status::Ok);
        }
        let slot = out_ptr(state, "FMUstate")?;
        if slot.is_null() {
            return Ok(Status::Ok);
        }
        owned_state(inst, *slot)?;
        inst.fmu_states.remove(&(*slot as usize));
        drop(Box::from_raw(*slot as *mut FmuStateBox));
        *slot = std::ptr::null_mut();
        Ok(Status::Ok)
    })
}

pub(crate) unsafe fn serialized_fmu_state_size_named<M: Model>(
    c: Fmi2Component,
    func: &str,
    state: Fmi2FmuState,
    size: *mut usize,
) -> Fmi2Status {
    call::<M, String>(c, func, sm::FMU_STATE, |inst| {
        *out_ptr(size, "size")? = owned_state(inst, state)?.bytes.len();
        Ok(Status::Ok)
    })
}

pub(crate) unsafe fn serialize_fmu_state_named<M: Model>(
    c: Fmi2Component,
    func: &str,
    state: Fmi2FmuState,
    bytes: *mut u8,
    size: usize,
) -> Fmi2Status {
    call::<M, String>(c, func, sm::FMU_STATE, |inst| {
        let src = &owned_state(inst, state)?.bytes;
        if size < src.len() {
            return Err(format!(
                "buffer of {size} bytes is smaller than the serialized state ({} bytes)",
                src.len()
            ));
        }
        let dst = slice_mut(bytes, src.len(), "serializedState")?;
        dst.copy_from_slice(src);
        Ok(Status::Ok)
    })
}

pub(crate) unsafe fn deserialize_fmu_state_named<M: Model>(
    c: Fmi2Component,
    func: &str,
    bytes: *const u8,
    size: usize,
    state: *mut Fmi2FmuState,
) -> Fmi2Status {
    call::<M, String>(c, func, sm::FMU_STATE, |inst| {
        let out = out_ptr(state, "FMUstate")?;
        let data = slice(bytes, size, "serializedState")?.to_vec();
        inst.check_state(&data)?;
        if out.is_null() {
            *out = new_state(inst, data);
        } else {
            owned_state(inst, *out)?.bytes = data;
        }
        Ok(Status::Ok)
    })
}

/// `fmi2GetDirectionalDerivative`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn get_directional_derivative<M: Model>(
    c: Fmi2Component,
    unknowns: *const Fmi2ValueReference,
    n_unknown: usize,
    knowns: *const Fmi2ValueReference,
    n_known: usize,
    seed: *const f64,
    out: *mut f64,
) -> Fmi2Status {
    call::<M, String>(
        c,
        "fmi2GetDirectionalDerivative",
        sm::DIRECTIONAL_DERIVATIVE,
        |inst| {
            inst.get_directional_derivative(
                slice(unknowns, n_unknown, "vUnknown_ref")?,
                slice(knowns, n_known, "vKnown_ref")?,
                slice(seed, n_known, "dvKnown")?,
                slice_mut(out, n_unknown, "dvUnknown")?,
            )
        },
    )
}

/// `fmi2SetRealInputDerivatives`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn set_real_input_derivatives<M: Model>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    n: usize,
    order: *const Fmi2Integer,
    value: *const f64,
) -> Fmi2Status {
    call::<M, String>(
        c,
        "fmi2SetRealInputDerivatives",
        sm::SET_REAL_INPUT_DERIVATIVES,
        |inst| {
            inst.set_real_input_derivatives(
                slice(vr, n, "vr")?,
                slice(order, n, "order")?,
                slice(value, n, "value")?,
            )
        },
    )
}

/// `fmi2GetRealOutputDerivatives`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn get_real_output_derivatives<M: Model>(c: Fmi2Component) -> Fmi2Status {
    call::<M, String>(
        c,
        "fmi2GetRealOutputDerivatives",
        sm::GET_REAL_OUTPUT_DERIVATIVES,
        |_| Err("not provided (maxOutputDerivativeOrder = 0)".into()),
    )
}

/// `fmi2DoStep`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn do_step<M: Model>(
    c: Fmi2Component,
    current: f64,
    step: f64,
    _no_prior: Fmi2Boolean,
) -> Fmi2Status {
    call::<M, ModelError>(c, "fmi2DoStep", sm::DO_STEP, |inst| {
        inst.do_step(current, step)
    })
}

/// `fmi2CancelStep`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn cancel_step<M: Model>(c: Fmi2Component) -> Fmi2Status {
    call::<M, String>(c, "fmi2CancelStep", sm::CANCEL_STEP, |_| Ok(Status::Ok))
}

/// `fmi2GetStatus`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn get_status<M: Model>(
    c: Fmi2Component,
    kind: Fmi2StatusKind,
    value: *mut Fmi2Status,
) -> Fmi2Status {
    call::<M, String>(c, "fmi2GetStatus", sm::GET_STATUS, |inst| {
        let out = out_ptr(value, "value")?;
        let (status, v) = inst.get_status(kind);
        *out = v as Fmi2Status;
        Ok(status)
    })
}

/// `fmi2GetRealStatus`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn get_real_status<M: Model>(
    c: Fmi2Component,
    kind: Fmi2StatusKind,
    value: *mut f64,
) -> Fmi2Status {
    call::<M, String>(c, "fmi2GetRealStatus", sm::GET_STATUS, |inst| {
        let out = out_ptr(value, "value")?;
        let (status, v) = inst.get_real_status(kind);
        *out = v;
        Ok(status)
    })
}

/// `fmi2GetIntegerStatus`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn get_integer_status<M: Model>(
    c: Fmi2Component,
    kind: Fmi2StatusKind,
    value: *mut Fmi2Integer,
) -> Fmi2Status {
    call::<M, String>(c, "fmi2GetIntegerStatus", sm::GET_STATUS, |inst| {
        out_ptr(value, "value")?;
        Ok(inst.status_unavailable("fmi2GetIntegerStatus", kind))
    })
}

/// `fmi2GetBooleanStatus`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn get_boolean_status<M: Model>(
    c: Fmi2Component,
    kind: Fmi2StatusKind,
    value: *mut Fmi2Boolean,
) -> Fmi2Status {
    call::<M, String>(c, "fmi2GetBooleanStatus", sm::GET_STATUS, |inst| {
        let out = out_ptr(value, "value")?;
        let (status, v) = inst.get_boolean_status(kind);
        *out = if v { FMI2_TRUE } else { FMI2_FALSE };
        Ok(status)
    })
}

/// `fmi2GetStringStatus`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn get_string_status<M: Model>(
    c: Fmi2Component,
    kind: Fmi2StatusKind,
    value: *mut Fmi2String,
) -> Fmi2Status {
    call::<M, String>(c, "fmi2GetStringStatus", sm::GET_STATUS, |inst| {
        let out = out_ptr(value, "value")?;
        *out = c"".as_ptr();
        Ok(inst.status_unavailable("fmi2GetStringStatus", kind))
    })
}

/// `fmi2EnterEventMode`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn enter_event_mode<M: Model>(c: Fmi2Component) -> Fmi2Status {
    call::<M, String>(c, "fmi2EnterEventMode", sm::ENTER_EVENT_MODE, |inst| {
        inst.enter_event_mode()
    })
}

/// `fmi2NewDiscreteStates`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn new_discrete_states<M: Model>(c: Fmi2Component, info: *mut EventInfo) -> Fmi2Status {
    call::<M, ModelError>(
        c,
        "fmi2NewDiscreteStates",
        sm::NEW_DISCRETE_STATES,
        |inst| {
            let out = out_ptr(info, "fmi2eventInfo")?;
            let update = inst.new_discrete_states()?;
            let flag = |b: bool| if b { FMI2_TRUE } else { FMI2_FALSE };
            *out = EventInfo {
                new_discrete_states_needed: FMI2_FALSE,
                terminate_simulation: FMI2_FALSE,
                nominals_of_continuous_states_changed: FMI2_FALSE,
                values_of_continuous_states_changed: flag(update.states_changed),
                next_event_time_defined: flag(update.next_event_time.is_some()),
                next_event_time: update.next_event_time.unwrap_or(0.0),
            };
            Ok(Status::Ok)
        },
    )
}

/// `fmi2EnterContinuousTimeMode`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn enter_continuous_time_mode<M: Model>(c: Fmi2Component) -> Fmi2Status {
    call::<M, String>(
        c,
        "fmi2EnterContinuousTimeMode",
        sm::ENTER_CONTINUOUS_TIME_MODE,
        |inst| inst.enter_continuous_time_mode(),
    )
}

/// `fmi2CompletedIntegratorStep`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn completed_integrator_step<M: Model>(
    c: Fmi2Component,
    _no_prior: Fmi2Boolean,
    enter_event_mode: *mut Fmi2Boolean,
    terminate_simulation: *mut Fmi2Boolean,
) -> Fmi2Status {
    call::<M, String>(
        c,
        "fmi2CompletedIntegratorStep",
        sm::COMPLETED_INTEGRATOR_STEP,
        |inst| {
            let event = out_ptr(enter_event_mode, "enterEventMode")?;
            let terminate = out_ptr(terminate_simulation, "terminateSimulation")?;
            let status = inst.completed_integrator_step()?;
            (*event, *terminate) = (FMI2_FALSE, FMI2_FALSE);
            Ok(status)
        },
    )
}

/// `fmi2SetTime`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn set_time<M: Model>(c: Fmi2Component, time: f64) -> Fmi2Status {
    call::<M, String>(c, "fmi2SetTime", sm::SET_TIME, |inst| inst.set_time(time))
}

/// `fmi2SetContinuousStates`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn set_continuous_states<M: Model>(
    c: Fmi2Component,
    x: *const f64,
    nx: usize,
) -> Fmi2Status {
    call::<M, String>(
        c,
        "fmi2SetContinuousStates",
        sm::SET_CONTINUOUS_STATES,
        |inst| inst.set_continuous_states(slice(x, nx, "x")?),
    )
}

/// `fmi2GetDerivatives`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn get_derivatives<M: Model>(c: Fmi2Component, dx: *mut f64, nx: usize) -> Fmi2Status {
    call::<M, String>(c, "fmi2GetDerivatives", sm::GET_DERIVATIVES, |inst| {
        inst.get_derivatives(slice_mut(dx, nx, "derivatives")?)
    })
}

/// `fmi2GetEventIndicators`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn get_event_indicators<M: Model>(
    c: Fmi2Component,
    z: *mut f64,
    ni: usize,
) -> Fmi2Status {
    call::<M, String>(
        c,
        "fmi2GetEventIndicators",
        sm::GET_EVENT_INDICATORS,
        |inst| inst.get_event_indicators(slice_mut(z, ni, "eventIndicators")?),
    )
}

/// `fmi2GetContinuousStates`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn get_continuous_states<M: Model>(
    c: Fmi2Component,
    x: *mut f64,
    nx: usize,
) -> Fmi2Status {
    call::<M, String>(
        c,
        "fmi2GetContinuousStates",
        sm::GET_CONTINUOUS_STATES,
        |inst| inst.get_continuous_states(slice_mut(x, nx, "x")?),
    )
}

/// `fmi2GetNominalsOfContinuousStates`.
///
/// # Safety
/// The FMI calling contract of [the module](self#safety).
pub unsafe fn get_nominals_of_continuous_states<M: Model>(
    c: Fmi2Component,
    x: *mut f64,
    nx: usize,
) -> Fmi2Status {
    call::<M, String>(
        c,
        "fmi2GetNominalsOfContinuousStates",
        sm::GET_NOMINALS_OF_CONTINUOUS_STATES,
        |inst| inst.get_nominals(slice_mut(x, nx, "x_nominal")?),
    )
}

/// The model's description document for a resource directory (NULL = none): `format` 0 gives
/// FMI 2.0's `modelDescription.xml`, 1 the Markdown variable table, 2 FMI 3.0's
/// `modelDescription.xml`, 3 FMI 3.0's `terminalsAndIcons.xml` (empty without terminals). The packager loads the built library
/// and calls this, so the XML in an FMU always comes from the binary beside it. The string is
/// freed with [`free_string`]; NULL on error (message on stderr: this is a build-time tool call).
///
/// # Safety
/// `resources` is NULL or a NUL-terminated string.
pub unsafe fn description_document<M: Model>(
    resources: *const c_char,
    format: std::os::raw::c_int,
) -> *mut c_char {
    let result = catch_quietly(|| {
        let dir = match c_str(resources) {
            None => None,
            Some(Ok(p)) => Some(std::path::PathBuf::from(p)),
            Some(Err(e)) => return Err(e),
        };
        let d = M::description(dir.as_deref())?;
        d.check().map_err(|e| e.to_string())?;
        Ok(match format {
            1 => d.to_markdown_table(),
            2 => d.to_xml3(),
            3 => d.to_terminals_xml().unwrap_or_default(),
            _ => d.to_xml(),
        })
    });
    match result {
        Ok(Ok(text)) => crate::logger::to_cstring(&text).into_raw(),
        Ok(Err(e)) => {
            eprintln!("fmuCoreDescription: {e}");
            std::ptr::null_mut()
        }
        Err(panic) => {
            eprintln!("fmuCoreDescription: internal error: {panic}");
            std::ptr::null_mut()
        }
    }
}

/// Free a string [`description_document`] returned.
///
/// # Safety
/// `s` is NULL or a string [`description_document`] returned and not yet freed.
pub unsafe fn free_string(s: *mut c_char) {
    if !s.is_null() {
        drop(std::ffi::CString::from_raw(s));
    }
}

/// Export the 34 FMI 2.0 common and Co-Simulation functions for one [`Model`] type.
/// Use once per `cdylib`: `fmu_core::export_fmi2!(MyModel);`.
#[macro_export]
macro_rules! export_fmi2 {
    ($model:ty) => {
        mod fmi2_exports {
            use super::*;
            use std::os::raw::c_char;
            use $crate::ffi;
            use $crate::types::*;
            type M = $model;

            #[no_mangle]
            pub extern "C" fn fmi2GetTypesPlatform() -> *const c_char {
                ffi::types_platform()
            }
            #[no_mangle]
            pub extern "C" fn fmi2GetVersion() -> *const c_char {
                ffi::version()
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetDebugLogging(
                c: Fmi2Component,
                on: Fmi2Boolean,
                n: usize,
                cats: *const Fmi2String,
            ) -> Fmi2Status {
                ffi::set_debug_logging::<M>(c, on, n, cats)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2Instantiate(
                name: Fmi2String,
                ty: Fmi2Type,
                guid: Fmi2String,
                res: Fmi2String,
                f: *const CallbackFunctions,
                visible: Fmi2Boolean,
                log: Fmi2Boolean,
            ) -> Fmi2Component {
                ffi::instantiate::<M>(name, ty, guid, res, f, visible, log)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2FreeInstance(c: Fmi2Component) {
                ffi::free_instance::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetupExperiment(
                c: Fmi2Component,
                td: Fmi2Boolean,
                tol: f64,
                start: f64,
                sd: Fmi2Boolean,
                stop: f64,
            ) -> Fmi2Status {
                ffi::setup_experiment::<M>(c, td, tol, start, sd, stop)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2EnterInitializationMode(c: Fmi2Component) -> Fmi2Status {
                ffi::enter_initialization_mode::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2ExitInitializationMode(c: Fmi2Component) -> Fmi2Status {
                ffi::exit_initialization_mode::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2Terminate(c: Fmi2Component) -> Fmi2Status {
                ffi::terminate::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2Reset(c: Fmi2Component) -> Fmi2Status {
                ffi::reset::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetReal(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                n: usize,
                v: *mut f64,
            ) -> Fmi2Status {
                ffi::get_real::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetInteger(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                n: usize,
                v: *mut Fmi2Integer,
            ) -> Fmi2Status {
                ffi::get_integer::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetBoolean(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                n: usize,
                v: *mut Fmi2Boolean,
            ) -> Fmi2Status {
                ffi::get_boolean::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetString(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                n: usize,
                v: *mut Fmi2String,
            ) -> Fmi2Status {
                ffi::get_string::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetReal(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                n: usize,
                v: *const f64,
            ) -> Fmi2Status {
                ffi::set_real::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetInteger(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                n: usize,
                v: *const Fmi2Integer,
            ) -> Fmi2Status {
                ffi::set_integer::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetBoolean(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                n: usize,
                v: *const Fmi2Boolean,
            ) -> Fmi2Status {
                ffi::set_boolean::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetString(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                n: usize,
                v: *const Fmi2String,
            ) -> Fmi2Status {
                ffi::set_string::<M>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetFMUstate(
                c: Fmi2Component,
                s: *mut Fmi2FmuState,
            ) -> Fmi2Status {
                ffi::get_fmu_state::<M>(c, s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetFMUstate(
                c: Fmi2Component,
                s: Fmi2FmuState,
            ) -> Fmi2Status {
                ffi::set_fmu_state::<M>(c, s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2FreeFMUstate(
                c: Fmi2Component,
                s: *mut Fmi2FmuState,
            ) -> Fmi2Status {
                ffi::free_fmu_state::<M>(c, s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SerializedFMUstateSize(
                c: Fmi2Component,
                s: Fmi2FmuState,
                size: *mut usize,
            ) -> Fmi2Status {
                ffi::serialized_fmu_state_size::<M>(c, s, size)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SerializeFMUstate(
                c: Fmi2Component,
                s: Fmi2FmuState,
                b: *mut Fmi2Byte,
                size: usize,
            ) -> Fmi2Status {
                ffi::serialize_fmu_state::<M>(c, s, b, size)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2DeSerializeFMUstate(
                c: Fmi2Component,
                b: *const Fmi2Byte,
                size: usize,
                s: *mut Fmi2FmuState,
            ) -> Fmi2Status {
                ffi::deserialize_fmu_state::<M>(c, b, size, s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetDirectionalDerivative(
                c: Fmi2Component,
                unknowns: *const Fmi2ValueReference,
                n_unknown: usize,
                knowns: *const Fmi2ValueReference,
                n_known: usize,
                seed: *const f64,
                out: *mut f64,
            ) -> Fmi2Status {
                ffi::get_directional_derivative::<M>(
                    c, unknowns, n_unknown, knowns, n_known, seed, out,
                )
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetRealInputDerivatives(
                c: Fmi2Component,
                vr: *const Fmi2ValueReference,
                n: usize,
                o: *const Fmi2Integer,
                v: *const f64,
            ) -> Fmi2Status {
                ffi::set_real_input_derivatives::<M>(c, vr, n, o, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetRealOutputDerivatives(
                c: Fmi2Component,
                _vr: *const Fmi2ValueReference,
                _n: usize,
                _o: *const Fmi2Integer,
                _v: *mut f64,
            ) -> Fmi2Status {
                ffi::get_real_output_derivatives::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2DoStep(
                c: Fmi2Component,
                t: f64,
                h: f64,
                np: Fmi2Boolean,
            ) -> Fmi2Status {
                ffi::do_step::<M>(c, t, h, np)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2CancelStep(c: Fmi2Component) -> Fmi2Status {
                ffi::cancel_step::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetStatus(
                c: Fmi2Component,
                k: Fmi2StatusKind,
                v: *mut Fmi2Status,
            ) -> Fmi2Status {
                ffi::get_status::<M>(c, k, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetRealStatus(
                c: Fmi2Component,
                k: Fmi2StatusKind,
                v: *mut f64,
            ) -> Fmi2Status {
                ffi::get_real_status::<M>(c, k, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetIntegerStatus(
                c: Fmi2Component,
                k: Fmi2StatusKind,
                v: *mut Fmi2Integer,
            ) -> Fmi2Status {
                ffi::get_integer_status::<M>(c, k, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetBooleanStatus(
                c: Fmi2Component,
                k: Fmi2StatusKind,
                v: *mut Fmi2Boolean,
            ) -> Fmi2Status {
                ffi::get_boolean_status::<M>(c, k, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmuCoreDescription(
                resources: *const c_char,
                format: std::os::raw::c_int,
            ) -> *mut c_char {
                ffi::description_document::<M>(resources, format)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmuCoreFreeString(s: *mut c_char) {
                ffi::free_string(s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetStringStatus(
                c: Fmi2Component,
                k: Fmi2StatusKind,
                v: *mut Fmi2String,
            ) -> Fmi2Status {
                ffi::get_string_status::<M>(c, k, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2EnterEventMode(c: Fmi2Component) -> Fmi2Status {
                ffi::enter_event_mode::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2NewDiscreteStates(
                c: Fmi2Component,
                info: *mut EventInfo,
            ) -> Fmi2Status {
                ffi::new_discrete_states::<M>(c, info)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2EnterContinuousTimeMode(c: Fmi2Component) -> Fmi2Status {
                ffi::enter_continuous_time_mode::<M>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2CompletedIntegratorStep(
                c: Fmi2Component,
                no_prior: Fmi2Boolean,
                enter_event_mode: *mut Fmi2Boolean,
                terminate: *mut Fmi2Boolean,
            ) -> Fmi2Status {
                ffi::completed_integrator_step::<M>(c, no_prior, enter_event_mode, terminate)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetTime(c: Fmi2Component, time: f64) -> Fmi2Status {
                ffi::set_time::<M>(c, time)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetContinuousStates(
                c: Fmi2Component,
                x: *const f64,
                nx: usize,
            ) -> Fmi2Status {
                ffi::set_continuous_states::<M>(c, x, nx)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetDerivatives(
                c: Fmi2Component,
                dx: *mut f64,
                nx: usize,
            ) -> Fmi2Status {
                ffi::get_derivatives::<M>(c, dx, nx)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetEventIndicators(
                c: Fmi2Component,
                z: *mut f64,
                ni: usize,
            ) -> Fmi2Status {
                ffi::get_event_indicators::<M>(c, z, ni)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetContinuousStates(
                c: Fmi2Component,
                x: *mut f64,
                nx: usize,
            ) -> Fmi2Status {
                ffi::get_continuous_states::<M>(c, x, nx)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetNominalsOfContinuousStates(
                c: Fmi2Component,
                x: *mut f64,
                nx: usize,
            ) -> Fmi2Status {
                ffi::get_nominals_of_continuous_states::<M>(c, x, nx)
            }
        }
        pub use fmi2_exports::*;
    };
}

/// The 44 FMI 2.0 function names every FMU of ours exports (checked against the `.so`): the
/// 34 common and Co-Simulation ones, then Model Exchange's 10.
pub const EXPORTED_FUNCTIONS: [&str; 44] = [
    "fmi2GetTypesPlatform",
    "fmi2GetVersion",
    "fmi2SetDebugLogging",
    "fmi2Instantiate",
    "fmi2FreeInstance",
    "fmi2SetupExperiment",
    "fmi2EnterInitializationMode",
    "fmi2ExitInitializationMode",
    "fmi2Terminate",
    "fmi2Reset",
    "fmi2GetReal",
    "fmi2GetInteger",
    "fmi2GetBoolean",
    "fmi2GetString",
    "fmi2SetReal",
    "fmi2SetInteger",
    "fmi2SetBoolean",
    "fmi2SetString",
    "fmi2GetFMUstate",
    "fmi2SetFMUstate",
    "fmi2FreeFMUstate",
    "fmi2SerializedFMUstateSize",
    "fmi2SerializeFMUstate",
    "fmi2DeSerializeFMUstate",
    "fmi2GetDirectionalDerivative",
    "fmi2SetRealInputDerivatives",
    "fmi2GetRealOutputDerivatives",
    "fmi2DoStep",
    "fmi2CancelStep",
    "fmi2GetStatus",
    "fmi2GetRealStatus",
    "fmi2GetIntegerStatus",
    "fmi2GetBooleanStatus",
    "fmi2GetStringStatus",
    "fmi2EnterEventMode",
    "fmi2NewDiscreteStates",
    "fmi2EnterContinuousTimeMode",
    "fmi2CompletedIntegratorStep",
    "fmi2SetTime",
    "fmi2SetContinuousStates",
    "fmi2GetDerivatives",
    "fmi2GetEventIndicators",
    "fmi2GetContinuousStates",
    "fmi2GetNominalsOfContinuousStates",
];
