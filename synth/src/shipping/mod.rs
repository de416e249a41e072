//! What the synthesis reads and writes: the design files ([`design`]), the registry of shipped
//! variants that the CLI, the Makefile and the tables derive from ([`registry`]), and the
//! `controller.json` each controller FMU reads ([`controller_file`]).

pub mod controller_file;
pub mod design;
pub mod registry;
