//! The C types of `fmi2TypesPlatform.h` and `fmi2FunctionTypes.h` (FMI 2.0.4, §2.1).

use std::os::raw::{c_char, c_int, c_uint, c_void};

pub type Fmi2Component = *mut c_void;
pub type Fmi2ComponentEnvironment = *mut c_void;
pub type Fmi2FmuState = *mut c_void;
pub type Fmi2ValueReference = c_uint;
pub type Fmi2Real = f64;
pub type Fmi2Integer = c_int;
pub type Fmi2Boolean = c_int;
pub type Fmi2String = *const c_char;
pub type Fmi2Byte = c_char;
pub type Fmi2Status = c_int;
pub type Fmi2Type = c_int;
pub type Fmi2StatusKind = c_int;

pub const FMI2_TRUE: Fmi2Boolean = 1;
pub const FMI2_FALSE: Fmi2Boolean = 0;
pub const FMI2_MODEL_EXCHANGE: Fmi2Type = 0;
pub const FMI2_CO_SIMULATION: Fmi2Type = 1;

/// `fmi2Status`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
#[repr(i32)]
pub enum Status {
    Ok = 0,
    Warning = 1,
    Discard = 2,
    Error = 3,
    Fatal = 4,
    Pending = 5,
}

/// `fmi2StatusKind`.
pub mod status_kind {
    use super::Fmi2StatusKind;
    pub const DO_STEP_STATUS: Fmi2StatusKind = 0;
    pub const PENDING_STATUS: Fmi2StatusKind = 1;
    pub const LAST_SUCCESSFUL_TIME: Fmi2StatusKind = 2;
    pub const TERMINATED: Fmi2StatusKind = 3;
}

/// `fmi2CallbackLogger`: a C variadic function. We always call it with `"%s"` as the format.
pub type LoggerFn = unsafe extern "C" fn(
    Fmi2ComponentEnvironment,
    Fmi2String,
    Fmi2Status,
    Fmi2String,
    Fmi2String,
    ...
);

/// `fmi2CallbackFunctions`.
#[repr(C)]
#[derive(Clone, Copy)]
pub struct CallbackFunctions {
    pub logger: Option<LoggerFn>,
    pub allocate_memory: Option<unsafe extern "C" fn(usize, usize) -> *mut c_void>,
    pub free_memory: Option<unsafe extern "C" fn(*mut c_void)>,
    pub step_finished: Option<unsafe extern "C" fn(Fmi2ComponentEnvironment, Fmi2Status)>,
    pub component_environment: Fmi2ComponentEnvironment,
}

/// `fmi2EventInfo` (Model Exchange, FMI 2.0.4 §3.2.2).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
pub struct EventInfo {
    pub new_discrete_states_needed: Fmi2Boolean,
    pub terminate_simulation: Fmi2Boolean,
    pub nominals_of_continuous_states_changed: Fmi2Boolean,
    pub values_of_continuous_states_changed: Fmi2Boolean,
    pub next_event_time_defined: Fmi2Boolean,
    pub next_event_time: Fmi2Real,
}

/// The C types of `fmi3PlatformTypes.h` and `fmi3FunctionTypes.h` (FMI 3.0.2, §2.2) that
/// differ from FMI 2.0's: `fmi3Boolean` is C99 `bool`, the instance and its environment are
/// opaque pointers, and `fmi3Status` has the same values as `fmi2Status` without `Pending`.
pub mod fmi3 {
    use std::os::raw::{c_char, c_int, c_void};

    pub type Instance = *mut c_void;
    pub type InstanceEnvironment = *mut c_void;
    pub type FmuState = *mut c_void;
    pub type ValueReference = u32;
    pub type Status = c_int;
    pub type Boolean = bool;
    pub type FmiString = *const c_char;
    pub type Byte = u8;

    /// `fmi3LogMessageCallback`: not variadic; the message is plain text.
    pub type LogMessage = unsafe extern "C" fn(InstanceEnvironment, Status, FmiString, FmiString);

    /// `fmi3IntermediateUpdateCallback`: never called (no intermediate update, no early
    /// return), accepted at instantiation.
    pub type IntermediateUpdate = unsafe extern "C" fn(
        InstanceEnvironment,
        f64,
        Boolean,
        Boolean,
        Boolean,
        Boolean,
        *mut Boolean,
        *mut f64,
    );

    /// `fmi3ClockUpdateCallback` (Scheduled Execution): never called.
    pub type ClockUpdate = unsafe extern "C" fn(InstanceEnvironment);

    /// `fmi3LockPreemptionCallback` and `fmi3UnlockPreemptionCallback`: never called.
    pub type Preemption = unsafe extern "C" fn();
}
