//! The FMI 2.0 Co-Simulation state machine (FMI 2.0.4 §4.2.4, fig. 10 and the calling-sequence
//! table): which function may be called in which state.

/// States of a Co-Simulation slave. `StepInProgress` never occurs: our steps are synchronous.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum FmiState {
    Instantiated = 1 << 0,
    InitializationMode = 1 << 1,
    StepComplete = 1 << 2,
    StepFailed = 1 << 3,
    StepCanceled = 1 << 4,
    Terminated = 1 << 5,
    Error = 1 << 6,
    Fatal = 1 << 7,
}

impl FmiState {
    pub const ALL: [FmiState; 8] = [
        FmiState::Instantiated,
        FmiState::InitializationMode,
        FmiState::StepComplete,
        FmiState::StepFailed,
        FmiState::StepCanceled,
        FmiState::Terminated,
        FmiState::Error,
        FmiState::Fatal,
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
        }
    }

    pub fn from_u8(v: u8) -> Option<FmiState> {
        FmiState::ALL.into_iter().find(|s| *s as u8 == v)
    }

    /// Before initialisation has ended: `Instantiated` or `InitializationMode`.
    pub fn initialising(self) -> bool {
        matches!(self, FmiState::Instantiated | FmiState::InitializationMode)
    }

    pub fn is_in(self, mask: Mask) -> bool {
        (self as u8) & mask.0 != 0
    }
}

/// A set of states in which a function may be called.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Mask(pub u8);

use FmiState as S;

const fn m(states: &[FmiState]) -> Mask {
    let mut bits = 0u8;
    let mut i = 0;
    while i < states.len() {
        bits |= states[i] as u8;
        i += 1;
    }
    Mask(bits)
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
pub const TERMINATE: Mask = m(&[S::StepComplete, S::StepFailed]);
pub const GET_VALUES: Mask = m(&[
    S::InitializationMode,
    S::StepComplete,
    S::StepFailed,
    S::StepCanceled,
    S::Terminated,
    S::Error,
]);
pub const SET_VALUES: Mask = m(&[S::Instantiated, S::InitializationMode, S::StepComplete]);
pub const DIRECTIONAL_DERIVATIVE: Mask = GET_VALUES;
pub const SET_REAL_INPUT_DERIVATIVES: Mask =
    m(&[S::Instantiated, S::InitializationMode, S::StepComplete]);
pub const GET_REAL_OUTPUT_DERIVATIVES: Mask = m(&[
    S::StepComplete,
    S::StepFailed,
    S::StepCanceled,
    S::Terminated,
    S::Error,
]);
pub const DO_STEP: Mask = m(&[S::StepComplete]);
/// Only legal while an asynchronous step is in progress, which never happens here.
pub const CANCEL_STEP: Mask = Mask(0);
pub const GET_STATUS: Mask = m(&[S::StepComplete, S::StepFailed, S::Terminated]);

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
        assert_eq!(terminate, [&S::StepComplete, &S::StepFailed]);
    }
}
