//! What a model provides to the runtime. The runtime does everything FMI: it checks the
//! state machine, value references, causality, finiteness of inputs, step sizes, and calls
//! the model only with legal, checked arguments.

use crate::description::{ModelDescription, ValueReference};
use crate::fmu_state::{StateReader, StateWriter};
use crate::types::Status;
use std::path::Path;

/// Why a model call did not succeed, and the FMI status the runtime answers it with.
///
/// * `fmi2Discard` ([`ModelError::discard`]): only from [`Model::do_step`], a step that could
///   not be taken but might be in smaller ones (a step too long for the model's stiffness).
///   The model is unchanged; the instance goes to `StepFailed`, where the importer can read
///   `fmi2LastSuccessfulTime` (the step's start), the outputs, and restore a state or reset.
/// * `fmi2Error` ([`ModelError::error`], and every `String` converted with `?`): the call
///   failed and changed nothing; the instance goes to `Error`.
/// * `fmi2Fatal` ([`ModelError::fatal`]): the model is corrupt; only `fmi2FreeInstance` is
///   allowed afterwards.
///
/// A call that succeeds has nothing to say here: the runtime issues its own warnings.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelError {
    pub status: Status,
    pub message: String,
}

impl ModelError {
    pub fn discard(message: impl Into<String>) -> Self {
        ModelError {
            status: Status::Discard,
            message: message.into(),
        }
    }

    pub fn error(message: impl Into<String>) -> Self {
        ModelError {
            status: Status::Error,
            message: message.into(),
        }
    }

    pub fn fatal(message: impl Into<String>) -> Self {
        ModelError {
            status: Status::Fatal,
            message: message.into(),
        }
    }
}

impl From<String> for ModelError {
    fn from(message: String) -> Self {
        ModelError::error(message)
    }
}

impl From<&str> for ModelError {
    fn from(message: &str) -> Self {
        ModelError::error(message)
    }
}

/// The message, for callers that only report it.
impl From<ModelError> for String {
    fn from(e: ModelError) -> Self {
        e.message
    }
}

impl std::fmt::Display for ModelError {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

pub trait Model: Sized + Send + 'static {
    /// The variable table and metadata for the unpacked `resources/` directory (if any).
    /// Called once per instance, before the GUID check: a model whose interface comes from a
    /// resource file (the controllers) derives its description, and so its GUID, from it.
    fn description(resources: Option<&Path>) -> Result<ModelDescription, ModelError>;

    /// A new model with every variable at its start value. `resources` is the unpacked
    /// `resources/` directory, if the importer gave one.
    fn instantiate(resources: Option<&Path>) -> Result<Self, ModelError>;

    /// Check a value for a settable Real variable before anything is changed (e.g. a negative
    /// mass). Finite-ness is already checked by the runtime.
    fn check_real(&self, _vr: ValueReference, _value: f64) -> Result<(), ModelError> {
        Ok(())
    }

    /// Set a settable Real variable; `value` has passed [`Model::check_real`].
    fn set_real(&mut self, vr: ValueReference, value: f64);

    /// The value of any Real variable.
    fn get_real(&mut self, vr: ValueReference) -> f64;

    fn set_integer(&mut self, _vr: ValueReference, _value: i32) {}
    fn get_integer(&mut self, _vr: ValueReference) -> i32 {
        0
    }
    fn set_boolean(&mut self, _vr: ValueReference, _value: bool) {}
    fn get_boolean(&mut self, _vr: ValueReference) -> bool {
        false
    }

    /// First time derivative of a Real input, valid for the next `fmi2DoStep` only
    /// (only called if the description says `canInterpolateInputs`).
    fn set_input_derivative(&mut self, _vr: ValueReference, _value: f64) {}

    /// The rules the parameters obey together (beyond each one's range, which the runtime and
    /// [`Model::check_real`] check), as `exit_initialization` enforces them. The runtime also
    /// calls it on a state restored past initialisation, so a forged state cannot bring in
    /// what initialisation would have refused.
    fn check_parameters(&self) -> Result<(), ModelError> {
        Ok(())
    }

    /// Initialization Mode, before an output or calculated parameter is read: make them the
    /// values at `start_time` for the parameters and inputs set so far (what the first step will
    /// start from), or say why the parameters do not make a model yet (the getter then returns
    /// `fmi2Error`). Parameters may be set again afterwards.
    fn prepare_initial_outputs(&mut self, _start_time: f64) -> Result<(), ModelError> {
        self.check_parameters()
    }

    /// End of initialisation: check the parameters together ([`Model::check_parameters`]) and
    /// build what the steps need.
    fn exit_initialization(&mut self, start_time: f64) -> Result<(), ModelError>;

    /// Advance from `time` by `step` (> 0). On error the model must be left unchanged.
    fn do_step(&mut self, time: f64, step: f64) -> Result<(), ModelError>;

    /// After a successful step of `step`: why the master should not use this communication
    /// step, if it should not (the runtime logs it as a warning and the step returns
    /// `fmi2Warning`). Asked at every step; a model says it once per step size, not at every
    /// step.
    fn step_warning(&mut self, _step: f64) -> Option<String> {
        None
    }

    /// Write everything needed to continue bit-identically in another instance.
    fn save(&self, out: &mut StateWriter);

    /// Restore what [`Model::save`] wrote. On error the model must be left unchanged.
    fn restore(&mut self, input: &mut StateReader) -> Result<(), ModelError>;

    /// FMI 3.0 Co-Simulation with the description's sample clock ticking the model
    /// (`eventModeUsed = true`): why the parameters set do not make a model its clock can tick,
    /// if they do not (asked at the end of initialisation). Each tick is then one
    /// [`Model::do_step`] over the clock's interval, the outputs read before it and held until
    /// the next tick.
    fn check_clocked(&self) -> Result<(), ModelError> {
        Ok(())
    }

    // Model Exchange. The runtime calls these only on an instance instantiated for Model
    // Exchange, which only a description with [`crate::description::ModelExchange`] allows;
    // slices have the lengths the description declares (its states, its event indicators).

    /// Why the parameters set do not make a model an integrator can advance (a transport
    /// delay, a sampled noise), if they do not: asked at the end of initialisation.
    fn check_model_exchange(&self) -> Result<(), ModelError> {
        Err("this model has no Model Exchange interface".into())
    }

    /// `fmi2SetTime`: the time of the next derivatives, indicators and outputs.
    fn set_time(&mut self, _time: f64) {}

    /// The continuous states, in the order of the description's derivatives.
    fn continuous_states(&mut self, _x: &mut [f64]) {}

    /// Set the continuous states (finite; checked by the runtime).
    fn set_continuous_states(&mut self, _x: &[f64]) {}

    /// Their time derivatives at the current time, states and inputs.
    fn derivatives(&mut self, _dx: &mut [f64]) {}

    /// The event indicators: an event is due where one changes sign.
    fn event_indicators(&mut self, _z: &mut [f64]) {}

    /// `fmi2NewDiscreteStates`, at `time`: let the discrete states (which contacts are closed,
    /// say) take their new values, and say when the next time event is, if any.
    fn update_discrete_states(&mut self, _time: f64) -> Result<DiscreteUpdate, ModelError> {
        Ok(DiscreteUpdate::default())
    }

    /// `fmi2CompletedIntegratorStep` at `time`: the integrator accepted the step to here.
    fn completed_integrator_step(&mut self, _time: f64) {}

    /// `fmi2GetDirectionalDerivative` (only called if the description's capabilities say it
    /// is provided): `out[i] = Σ_j ∂unknowns[i]/∂knowns[j] · seed[j]` at the current point. The
    /// runtime has checked every reference: unknowns are outputs, state derivatives or (Model
    /// Exchange) states; knowns are inputs or (Model Exchange) continuous states; seeds finite.
    fn directional_derivative(
        &mut self,
        _unknowns: &[ValueReference],
        _knowns: &[ValueReference],
        _seed: &[f64],
        _out: &mut [f64],
    ) {
    }
}

/// What `fmi2NewDiscreteStates` reports (its `fmi2EventInfo`, less what the runtime knows).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DiscreteUpdate {
    /// The continuous states jumped: the integrator must read them again.
    pub states_changed: bool,
    /// The next time event, if there is one.
    pub next_event_time: Option<f64>,
}
