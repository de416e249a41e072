//! The smallest FMU that panics: `y = u`, and a step with `u = 666` panics. Built for every
//! platform beside the shipped FMUs (`make` cross builds) so that `tests/harness/fmu_harness.c`
//! can check, on Windows under wine and on ARM under qemu too, that a panic inside the FMU comes
//! back to the importer as `fmi2Error` with a log message and leaves an instance that resets.
//! Not shipped.

use fmu_core::fmu_state::{StateReader, StateWriter};
use fmu_core::*;
use std::path::Path;

struct Probe {
    u: f64,
    y: f64,
}

impl Model for Probe {
    fn description(_resources: Option<&Path>) -> Result<ModelDescription, ModelError> {
        Ok(ModelDescription {
            model_name: "panic_probe".into(),
            model_identifier: "panic_probe".into(),
            guid: String::new(),
            description: "y = u; a step with u = 666 panics (the panic barrier's probe)".into(),
            version: "1".into(),
            capabilities: Capabilities::exact_stepping(false),
            model_exchange: None,
            sample_clock: None,
            arrays: Vec::new(),
            terminals: Vec::new(),
            default_experiment: DefaultExperiment {
                start_time: 0.0,
                stop_time: 1.0,
                step_size: 0.1,
                tolerance: 1e-6,
            },
            variables: vec![
                Variable::real("u", 0, Causality::Input, "1", "input; 666 panics").with_start(0.0),
                Variable::real("y", 1, Causality::Output, "1", "u after the last step"),
            ],
        }
        .with_derived_guid())
    }
    fn instantiate(_resources: Option<&Path>) -> Result<Self, ModelError> {
        Ok(Probe { u: 0.0, y: 0.0 })
    }
    fn set_real(&mut self, _vr: u32, value: f64) {
        self.u = value;
    }
    fn get_real(&mut self, vr: u32) -> f64 {
        if vr == 0 {
            self.u
        } else {
            self.y
        }
    }
    fn exit_initialization(&mut self, _t: f64) -> Result<(), ModelError> {
        Ok(())
    }
    fn do_step(&mut self, _t: f64, _h: f64) -> Result<(), ModelError> {
        if self.u == 666.0 {
            panic!("the probe panics on u = 666");
        }
        self.y = self.u;
        Ok(())
    }
    fn save(&self, w: &mut StateWriter) {
        w.f64s(&[self.u, self.y]);
    }
    fn restore(&mut self, r: &mut StateReader) -> Result<(), ModelError> {
        let v = r.f64s_exact(2, "probe state")?;
        r.finish()?;
        (self.u, self.y) = (v[0], v[1]);
        Ok(())
    }
}

fmu_core::export_fmi2!(Probe);
fmu_core::export_fmi3!(Probe);
