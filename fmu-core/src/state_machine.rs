//! The FMI 2.0 state machines, Co-Simulation (FMI 2.0.4 §4.2.4, fig. 10) and Model Exchange
//! (§3.2.3, fig. 6), with their calling-sequence tables: which function may be called in which
//! state. The two share their first and last states; each mask is the union of the states in
//! which either interface allows the call, which is exact because an instance only ever reaches
//! its own interface's states (a Co-Simulation instance never enters `EventMode`, a Model
//! Exchange instance never `StepComplete`). Functions of one interface only are refused on an
//! instance of the other before their mask is read ([`crate::ffi`]).

/// States of an instance. `StepInProgress` never occurs: our steps are synchronous.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u16)]
pub enum FmiState {
    Instantiated = 1 << 0,
    InitializationMode = 1 << 1,
    StepComplete = 1 << 2,
    StepFailed = 1 << 3,
    StepCanceled = 1 << 4,
    Terminated = 1 << 5,
    Error = 1 << 6,
    Fatal = 1 << 7,
    /// Model Exchange: discrete states may change (after initialisation, at an event).
    EventMode = 1 << 8,
    /// Model Exchange: the integrator sets time and continuous states and reads derivatives.
    ContinuousTimeMode = 1 << 9,
}

impl FmiState {
    pub const ALL: [FmiState; 10] = [
        FmiState::Instantiated,
        FmiState::InitializationMode,
        FmiState::StepComplete,
        FmiState::StepFailed,
        FmiState::StepCanceled,
        FmiState::Terminated,
        FmiState::Error,
        FmiState::Fatal,
        FmiState::EventMode,
        FmiState::ContinuousTimeMode,
    ];

    pub fn name(self) -> &'static str {
        match self {
            FmiState::Instantiated => "Instantiated",
            FmiState::InitializationMode => "InitializationMode",
            FmiState::StepComplete => "StepComplete",
            FmiState::StepFailed => "StepFailed",
            FmiState::StepCanceled => "StepCanceled",
            FmiState::Terminated => "Terminated",
            FmiState::Error => "Error",
            FmiState::Fatal => "Fatal",
            FmiState::EventMode => "EventMode",
            FmiState::ContinuousTimeMode => "ContinuousTimeMode",
        }
    }

    /// The byte an FMU state stores: the bit of the first eight states (as every state saved
    /// before Model Exchange existed has it), 3 and 5 (no bit) for the two Model Exchange
    /// modes.
    /// The state's name in the FMI version `api` speaks: FMI 3.0's Step Mode is FMI 2.0's
    /// stepComplete (and, after a discarded step, its stepFailed).
    pub fn name_in(self, api: crate::instance::Api) -> &'static str {
        match (api, self) {
            (crate::instance::Api::Fmi3, FmiState::StepComplete) => "StepMode",
            (crate::instance::Api::Fmi3, FmiState::StepFailed) => {
                "StepMode (after a discarded step)"
            }
            _ => self.name(),
        }
    }

    pub fn code(self) -> u8 {
        match self {
            FmiState::EventMode => 3,
            FmiState::ContinuousTimeMode => 5,
            s => s as u16 as u8,
        }
    }

    pub fn from_code(v: u8) -> Option<FmiState> {
        FmiState::ALL.into_iter().find(|s| s.code() == v)
    }

    /// Before initialisation has ended: `Instantiated` or `InitializationMode`.
    pub fn initialising(self) -> bool {
        matches!(self, FmiState::Instantiated | FmiState::InitializationMode)
    }

    pub fn is_in(self, mask: Mask) -> bool {
        (self as u16) & mask.states != 0
    }
}

/// The interface an instance was instantiated for (`fmi2Type`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Interface {
    CoSimulation,
    ModelExchange,
}

impl Interface {
    pub fn name(self) -> &'static str {
        match self {
            Interface::CoSimulation => "Co-Simulation",
            Interface::ModelExchange => "Model Exchange",
        }
    }

    /// Whether an instance of this interface can be in `state` (an FMU state restored into it,
    /// say): the shared states, and its own.
    pub fn reaches(self, state: FmiState) -> bool {
        let model_exchange = matches!(state, FmiState::EventMode | FmiState::ContinuousTimeMode);
        let co_simulation = matches!(
            state,
            FmiState::StepComplete | FmiState::StepFailed | FmiState::StepCanceled
        );
        match self {
            Interface::CoSimulation => !model_exchange,
            Interface::ModelExchange => !co_simulation,
        }
    }
}

/// A set of states in which a function may be called, and the interface it belongs to if it
/// belongs to one only.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Mask {
    pub states: u16,
    pub only: Option<Interface>,
}

impl Mask {
    /// The same states, for instances of `interface` only.
    const fn only(self, interface: Interface) -> Mask {
        Mask {
            states: self.states,
            only: Some(interface),
        }
    }
}

use Interface::{CoSimulation as CS, ModelExchange as ME};

use FmiState as S;

const fn m(states: &[FmiState]) -> Mask {
    let mut bits = 0u16;
    let mut i = 0;
    while i < states.len() {
        bits |= states[i] as u16;
        i += 1;
    }
    Mask {
        states: bits,
        only: None,
    }
}

/// Every state except `Fatal`: free, reset and FMU-state functions.
pub const ANY_BUT_FATAL: Mask = m(&[
    S::Instantiated,
    S::InitializationMode,
    S::StepComplete,
    S::StepFailed,
    S::StepCanceled,
    S::Terminated,
    S::Error,
    S::EventMode,
    S::ContinuousTimeMode,
]);
pub const SET_DEBUG_LOGGING: Mask = ANY_BUT_FATAL;
pub const FREE_INSTANCE: Mask = ANY_BUT_FATAL;
pub const RESET: Mask = ANY_BUT_FATAL;
pub const FMU_STATE: Mask = ANY_BUT_FATAL;
pub const SETUP_EXPERIMENT: Mask = m(&[S::Instantiated]);
pub const ENTER_INITIALIZATION_MODE: Mask = m(&[S::Instantiated]);
pub const EXIT_INITIALIZATION_MODE: Mask = m(&[S::InitializationMode]);
/// The FMI 2.0.4 table: not after a canceled step (only `fmi2CancelStep` leads there, which
/// this FMU never allows), as the Reference FMUs have it.
pub const TERMINATE: Mask = m(&[
    S::StepComplete,
    S::StepFailed,
    S::EventMode,
    S::ContinuousTimeMode,
]);
pub const GET_VALUES: Mask = m(&[
    S::InitializationMode,
    S::StepComplete,
    S::StepFailed,
    S::StepCanceled,
    S::Terminated,
    S::Error,
    S::EventMode,
    S::ContinuousTimeMode,
]);
/// `fmi2SetReal`; in `ContinuousTimeMode` only continuous inputs ([`crate::instance`]).
pub const SET_REAL: Mask = m(&[
    S::Instantiated,
    S::InitializationMode,
    S::StepComplete,
    S::EventMode,
    S::ContinuousTimeMode,
]);
/// `fmi2SetInteger`, `fmi2SetBoolean`, `fmi2SetString`: never in `ContinuousTimeMode`.
pub const SET_VALUES: Mask = m(&[
    S::Instantiated,
    S::InitializationMode,
    S::StepComplete,
    S::EventMode,
]);
pub const DIRECTIONAL_DERIVATIVE: Mask = GET_VALUES;
pub const SET_REAL_INPUT_DERIVATIVES: Mask =
    m(&[S::Instantiated, S::InitializationMode, S::StepComplete]).only(CS);
pub const GET_REAL_OUTPUT_DERIVATIVES: Mask = m(&[
    S::StepComplete,
    S::StepFailed,
    S::StepCanceled,
    S::Terminated,
    S::Error,
])
.only(CS);
pub const DO_STEP: Mask = m(&[S::StepComplete]).only(CS);
/// Only legal while an asynchronous step is in progress, which never happens here.
pub const CANCEL_STEP: Mask = m(&[]).only(CS);
pub const GET_STATUS: Mask = m(&[S::StepComplete, S::StepFailed, S::Terminated]).only(CS);

// FMI 3.0's Event Mode, which Co-Simulation has too (for an instance a clock ticks): the
// instance checks the interface's own rules ([`crate::instance::Instance::enter_event_mode3`]).
/// `fmi3EnterEventMode`: Model Exchange's, and Co-Simulation's from Step Mode.
pub const ENTER_EVENT_MODE3: Mask = m(&[S::EventMode, S::ContinuousTimeMode, S::StepComplete]);
/// `fmi3UpdateDiscreteStates`: in Event Mode of either interface.
pub const UPDATE_DISCRETE_STATES3: Mask = m(&[S::EventMode]);
/// `fmi3EnterStepMode`: out of Co-Simulation's Event Mode.
pub const ENTER_STEP_MODE: Mask = m(&[S::EventMode]).only(CS);

// Model Exchange only (the Reference FMUs' masks, from the FMI 2.0.4 table of §3.2.3).
/// FMI 3.0's `fmi3GetNumberOfContinuousStates` and `fmi3GetNumberOfEventIndicators`: any
/// state of a Model Exchange instance.
pub const NUMBER_OF: Mask = ANY_BUT_FATAL.only(ME);
pub const ENTER_EVENT_MODE: Mask = m(&[S::EventMode, S::ContinuousTimeMode]).only(ME);
pub const NEW_DISCRETE_STATES: Mask = m(&[S::EventMode]).only(ME);
pub const ENTER_CONTINUOUS_TIME_MODE: Mask = m(&[S::EventMode]).only(ME);
pub const COMPLETED_INTEGRATOR_STEP: Mask = m(&[S::ContinuousTimeMode]).only(ME);
pub const SET_TIME: Mask = m(&[S::EventMode, S::ContinuousTimeMode]).only(ME);
pub const SET_CONTINUOUS_STATES: Mask = m(&[S::ContinuousTimeMode]).only(ME);
pub const GET_EVENT_INDICATORS: Mask = m(&[
    S::InitializationMode,
    S::EventMode,
    S::ContinuousTimeMode,
    S::Terminated,
    S::Error,
])
.only(ME);
pub const GET_CONTINUOUS_STATES: Mask = GET_EVENT_INDICATORS;
pub const GET_DERIVATIVES: Mask =
    m(&[S::EventMode, S::ContinuousTimeMode, S::Terminated, S::Error]).only(ME);
pub const GET_NOMINALS_OF_CONTINUOUS_STATES: Mask = m(&[
    S::Instantiated,
    S::EventMode,
    S::ContinuousTimeMode,
    S::Terminated,
    S::Error,
])
.only(ME);

#[cfg(test)]
mod tests {
    use super::*;

    /// The `stepCanceled` column of the FMI 2.0.4 Co-Simulation table (section 4.2.4, as the
    /// Reference FMUs implement it): getters, output derivatives, free/reset, logging and FMU
    /// states only; in particular not `fmi2Terminate` and not `fmi2Get*Status`.
    #[test]
    fn step_canceled_allows_what_the_standard_table_allows() {
        let allowed = [
            GET_VALUES,
            GET_REAL_OUTPUT_DERIVATIVES,
            DIRECTIONAL_DERIVATIVE,
            FREE_INSTANCE,
            RESET,
            SET_DEBUG_LOGGING,
            FMU_STATE,
        ];
        let refused = [
            TERMINATE,
            GET_STATUS,
            DO_STEP,
            CANCEL_STEP,
            SET_VALUES,
            SET_REAL_INPUT_DERIVATIVES,
            SETUP_EXPERIMENT,
            ENTER_INITIALIZATION_MODE,
            EXIT_INITIALIZATION_MODE,
        ];
        for (i, m) in allowed.iter().enumerate() {
            assert!(S::StepCanceled.is_in(*m), "allowed mask {i}");
        }
        for (i, m) in refused.iter().enumerate() {
            assert!(!S::StepCanceled.is_in(*m), "refused mask {i}");
        }
        // fmi2Terminate: after a completed or failed step only.
        let terminate: Vec<_> = FmiState::ALL
            .iter()
            .filter(|s| s.is_in(TERMINATE))
            .collect();
        assert_eq!(
            terminate,
            [
                &S::StepComplete,
                &S::StepFailed,
                &S::EventMode,
                &S::ContinuousTimeMode
            ]
        );
    }

    /// FMI 2.0.4 §3.2.3: in Continuous-Time Mode only Reals may be set, the integrator's calls
    /// are refused in Event Mode and the reverse, and a state's code is one byte both ways.
    #[test]
    fn model_exchange_masks_follow_the_standard_table() {
        assert!(S::ContinuousTimeMode.is_in(SET_REAL));
        assert!(!S::ContinuousTimeMode.is_in(SET_VALUES));
        assert!(S::EventMode.is_in(SET_VALUES));
        for mask in [SET_CONTINUOUS_STATES, COMPLETED_INTEGRATOR_STEP] {
            assert!(S::ContinuousTimeMode.is_in(mask) && !S::EventMode.is_in(mask));
        }
        for mask in [NEW_DISCRETE_STATES, ENTER_CONTINUOUS_TIME_MODE] {
            assert!(S::EventMode.is_in(mask) && !S::ContinuousTimeMode.is_in(mask));
        }
        assert!(!S::InitializationMode.is_in(GET_DERIVATIVES));
        assert!(S::Instantiated.is_in(GET_NOMINALS_OF_CONTINUOUS_STATES));
        assert_eq!(SET_TIME.only, Some(ME));
        assert_eq!(DO_STEP.only, Some(CS));
        assert_eq!(GET_VALUES.only, None);
        for s in FmiState::ALL {
            assert_eq!(FmiState::from_code(s.code()), Some(s));
            // A Co-Simulation step is never legal in a Model Exchange mode.
            let me = matches!(s, S::EventMode | S::ContinuousTimeMode);
            assert!(!(me && s.is_in(DO_STEP)));
        }
    }
}
