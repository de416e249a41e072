//! The FMI 2.0 runtime shared by every FMU of this project: Co-Simulation for every model, and
//! Model Exchange for a model that declares continuous states (the plant).
//!
//! It knows nothing about vehicles. A model implements [`Model`] (variable table, start values,
//! get/set, step, save/restore; states, derivatives and event indicators for Model Exchange) and
//! calls [`export_fmi2!`]; the runtime provides the 44 C functions, the state machines of FMI
//! 2.0.4 §4.2.4 and §3.2.3, value-reference and causality checks,
//! logging through the importer's callback, FMU state by value, and the `modelDescription.xml`
//! derived from the variable table.
//!
//! Where to look: the state machine is [`state_machine`]; the semantics of each call is
//! [`instance::Instance`]; the C ABI and panic barrier is [`ffi`].

pub mod dependencies;
pub mod description;
pub mod ffi;
pub mod ffi3;
pub mod fmu_state;
pub mod instance;
pub mod logger;
pub mod model;
pub mod state_machine;
pub mod types;
pub mod uri;

pub use description::{
    Capabilities, Causality, DefaultExperiment, DependencyKind, ModelDescription, ValueReference,
    VarType, Variability, Variable,
};
pub use model::{DiscreteUpdate, Model, ModelError};
