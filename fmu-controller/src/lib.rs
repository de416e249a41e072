//! The controller FMUs (`dist/hinf_sf.fmu`, …): one generic runtime on `fmu-core`. Each variant
//! is this library packaged with its own `resources/controller.json` (from `synth`), under its
//! own `modelIdentifier`; the variable table, and so the GUID, derive from that file, so a
//! missing, corrupt or mismatched `controller.json` makes `fmi2Instantiate` fail with a message.
//!
//! Inputs have exactly the names of the plant outputs the controller reads; outputs are
//! `u_fl … u_seat`: a master connects any controller FMU by name and swaps one for another.
//! A dynamic controller is stepped exactly (matrix exponential, measurements held over the
//! communication step, which is what a sampled-data implementation does).

pub mod spec;

use fmu_core::fmu_state::{StateReader, StateWriter};
use fmu_core::{Capabilities, Causality, DefaultExperiment, Model, ModelDescription, ValueReference, Variable};
use nalgebra::DVector;
use spec::Spec;
use std::path::Path;
use vehicle::exact::{discretize, Discretization};

/// Value references: inputs from 0, outputs from 1000, `gamma` at 2000.
pub mod vr {
    pub const INPUT: u32 = 0;
    pub const OUTPUT: u32 = 1000;
    pub const GAMMA: u32 = 2000;
}

pub const RESOURCE_FILE: &str = "controller.json";

/// Read and check `resources/controller.json`.
pub fn load_spec(resources: Option<&Path>) -> Result<Spec, String> {
    let dir = resources.ok_or("this controller FMU needs its resources/controller.json, but the importer passed no resource location")?;
    let path = dir.join(RESOURCE_FILE);
    let text = std::fs::read_to_string(&path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    Spec::from_json(&text).map_err(|e| format!("{}: {e}", path.display()))
}

/// The variable table of a controller FMU.
pub fn description_for(spec: &Spec) -> ModelDescription {
    let mut vars = Vec::new();
    for (i, s) in spec.inputs.iter().enumerate() {
        vars.push(Variable::real(s.name.clone(), vr::INPUT + i as u32, Causality::Input, unit(&s.unit), format!("Plant output {} read by the controller", s.name)).with_start(0.0));
    }
    for (i, s) in spec.outputs.iter().enumerate() {
        let deps: Vec<String> = (0..spec.inputs.len()).filter(|&j| spec.d[(i, j)] != 0.0).map(|j| spec.inputs[j].name.clone()).collect();
        vars.push(Variable::real(s.name.clone(), vr::OUTPUT + i as u32, Causality::Output, unit(&s.unit), format!("Force command for plant input {}", s.name)).depending_on(deps));
    }
    vars.push(Variable::real("gamma", vr::GAMMA, Causality::CalculatedParameter, "1", "H-infinity level the synthesis guarantees (scaled w to z, see the certificate)"));
    ModelDescription {
        model_name: spec.variant.clone(),
        model_identifier: spec.variant.clone(),
        guid: String::new(),
        description: spec.description.clone(),
        version: format!("{}+{:016x}", env!("CARGO_PKG_VERSION"), spec.content_hash),
        capabilities: Capabilities::exact_stepping(false),
        default_experiment: DefaultExperiment { start_time: 0.0, stop_time: 10.0, step_size: 1e-3 },
        variables: vars,
    }
    .with_derived_guid()
}

/// Units the runtime knows, as `'static` strings.
fn unit(u: &str) -> &'static str {
    match u {
        "m" => "m",
        "m/s" => "m/s",
        "m/s2" => "m/s2",
        "rad" => "rad",
        "rad/s" => "rad/s",
        "rad/s2" => "rad/s2",
        "N" => "N",
        _ => "",
    }
}

pub struct Controller {
    spec: Spec,
    xc: DVector<f64>,
    y: DVector<f64>,
    cache: Option<Discretization>,
}

impl Controller {
    fn output(&self, i: usize) -> f64 {
        (self.spec.c.row(i) * &self.xc)[(0, 0)] + (self.spec.d.row(i) * &self.y)[(0, 0)]
    }
}

impl Model for Controller {
    fn description(resources: Option<&Path>) -> Result<ModelDescription, String> {
        Ok(description_for(&load_spec(resources)?))
    }

    fn instantiate(resources: Option<&Path>) -> Result<Self, String> {
        let spec = load_spec(resources)?;
        Ok(Controller { xc: DVector::zeros(spec.order()), y: DVector::zeros(spec.inputs.len()), spec, cache: None })
    }

    fn set_real(&mut self, vr: ValueReference, value: f64) {
        if let Some(slot) = self.y.get_mut((vr - vr::INPUT) as usize) {
            *slot = value;
        }
    }

    fn get_real(&mut self, vr: ValueReference) -> f64 {
        match vr {
            vr::GAMMA => self.spec.gamma,
            v if v >= vr::OUTPUT => self.output((v - vr::OUTPUT) as usize),
            v => self.y[(v - vr::INPUT) as usize],
        }
    }

    fn exit_initialization(&mut self, _start_time: f64) -> Result<(), String> {
        self.xc.fill(0.0);
        Ok(())
    }

    fn do_step(&mut self, _time: f64, step: f64) -> Result<(), String> {
        if self.spec.order() == 0 {
            return Ok(());
        }
        if self.cache.as_ref().map(|d| d.step.to_bits()) != Some(step.to_bits()) {
            self.cache = Some(discretize(&self.spec.a, &self.spec.b, step));
        }
        let d = self.cache.as_ref().unwrap();
        let next = &d.phi * &self.xc + &d.gamma_hold * &self.y;
        if !next.iter().all(|v| v.is_finite()) {
            return Err("controller state became non-finite; the step was discarded".into());
        }
        self.xc = next;
        Ok(())
    }

    fn save(&self, out: &mut StateWriter) {
        out.u64(self.spec.content_hash);
        out.f64s(self.xc.as_slice());
        out.f64s(self.y.as_slice());
    }

    fn restore(&mut self, input: &mut StateReader) -> Result<(), String> {
        let hash = input.u64()?;
        if hash != self.spec.content_hash {
            return Err("FMU state was saved with a different controller.json".into());
        }
        let xc = input.f64s_exact(self.spec.order(), "controller states")?;
        let y = input.f64s_exact(self.spec.inputs.len(), "controller inputs")?;
        input.finish()?;
        self.xc = DVector::from_vec(xc);
        self.y = DVector::from_vec(y);
        Ok(())
    }
}

fmu_core::export_fmi2!(Controller);
