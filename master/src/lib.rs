//! The co-simulation master: road, plant and controller FMUs through the `fmi` crate.

pub mod metrics;
pub mod cosim;
pub mod report;
pub mod structure;
