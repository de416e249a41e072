//! The co-simulation master: road, plant and controller FMUs through the `fmi` crate.

pub mod cosim;
pub mod fmu_log;
pub mod metrics;
pub mod report;
pub mod structure;
pub mod sweep;
pub mod sweep_out;
