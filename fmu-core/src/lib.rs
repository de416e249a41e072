//! The FMI 2.0 Co-Simulation slave runtime shared by every FMU of this project.
//!
//! It knows nothing about vehicles. A model implements [`Model`] (variable table, start values,
//! get/set, step, save/restore) and calls [`export_fmi2!`]; the runtime provides the 34 C
//! functions, the state machine of FMI 2.0.4 §4.2.4, value-reference and causality checks,
//! logging through the importer's callback, FMU state by value, and the `modelDescription.xml`
//! derived from the variable table.
//!
//! Where to look: the state machine is [`state_machine`]; the semantics of each call is
//! [`instance::Instance`]; the C ABI and panic barrier is [`ffi`].

pub mod dependencies;
pub mod description;
pub mod ffi;
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
pub use model::{Model, ModelError};
