//! The dependencies a model actually has, measured by perturbing one known at a time, to check
//! the `<ModelStructure>` it declares (FMI 2.0.4 §2.2.8). An importer such as OMSimulator orders
//! the equations of a coupled system by those lists: an undeclared dependency hides an algebraic
//! loop, a missing list invents one.
//!
//! Perturbation sees a dependency wherever the unknown moves at the point probed, so it can miss
//! one that is flat there (a saturation not reached, a threshold not crossed) but never invents
//! one: [`Mismatch::undeclared`] must be empty; [`Mismatch::unobserved`] is for the caller to
//! explain.

use crate::description::{Causality, ModelDescription, VarType, Variable};
use crate::instance::Instance;
use crate::types::{CallbackFunctions, FMI2_CO_SIMULATION};
use crate::Model;
use std::collections::BTreeSet;

/// For each unknown (by name), the knowns (by name) it was seen to move with.
pub type Dependencies = Vec<(String, BTreeSet<String>)>;

/// What the model did, and what its description says.
#[derive(Debug, Default)]
pub struct Mismatch {
    /// `(unknown, known)` pairs that moved together but are not declared: a wrong description.
    pub undeclared: Vec<(String, String)>,
    /// `(unknown, known)` pairs declared but not seen to move together at the point probed.
    pub unobserved: Vec<(String, String)>,
}

/// Dependencies measured at a communication point (outputs on inputs) and in Initialization
/// Mode (outputs and calculated parameters on inputs and parameters).
#[derive(Debug)]
pub struct Measured {
    pub outputs: Dependencies,
    pub initial: Dependencies,
}

/// The value every input is held at while probing, away from zero so that a product of two
/// inputs or a norm is not flat there.
fn operating_point(index: usize) -> f64 {
    1e-3 * (1.0 + 0.37 * index as f64)
}

/// A value of `v` other than `current` that its `min`/`max` admit.
fn perturbed(v: &Variable, current: Value) -> Value {
    match (current, &v.kind) {
        (Value::Real(x), VarType::Real { min, max, .. }) => {
            let delta = 1e-2 * x.abs().max(0.1);
            if max.is_some_and(|m| x + delta > m) && min.is_none_or(|m| x - delta >= m) {
                Value::Real(x - delta)
            } else {
                Value::Real(x + delta)
            }
        }
        (Value::Integer(i), _) => Value::Integer(if i == i32::MAX { i - 1 } else { i + 1 }),
        (Value::Boolean(b), _) => Value::Boolean(!b),
        (other, _) => other,
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Value {
    Real(f64),
    Integer(i32),
    Boolean(bool),
}

struct Probe<M: Model> {
    instance: Box<Instance<M>>,
}

impl<M: Model> Probe<M> {
    fn new(
        guid: &str,
        resource_uri: Option<&str>,
        callbacks: &CallbackFunctions,
    ) -> Result<Self, String> {
        let instance = Instance::<M>::instantiate(
            "probe",
            FMI2_CO_SIMULATION,
            Some(guid),
            resource_uri,
            callbacks,
            false,
        )
        .map_err(|(_, e)| e)?;
        Ok(Probe { instance })
    }

    fn get(&mut self, v: &Variable) -> Result<Value, String> {
        let vr = [v.value_reference];
        Ok(match v.kind {
            VarType::Real { .. } => {
                let mut x = [0.0];
                self.instance.get_real(&vr, &mut x)?;
                Value::Real(x[0])
            }
            VarType::Integer { .. } => {
                let mut x = [0];
                self.instance.get_integer(&vr, &mut x)?;
                Value::Integer(x[0])
            }
            VarType::Boolean { .. } => {
                let mut x = [false];
                self.instance.get_boolean(&vr, &mut x)?;
                Value::Boolean(x[0])
            }
        })
    }

    fn set(&mut self, v: &Variable, value: Value) -> Result<(), String> {
        let vr = [v.value_reference];
        match value {
            Value::Real(x) => self.instance.set_real(&vr, &[x]),
            Value::Integer(x) => self.instance.set_integer(&vr, &[x]),
            Value::Boolean(x) => self.instance.set_boolean(&vr, &[x]),
        }
        .map(|_| ())
        .map_err(|e| format!("setting '{}': {e}", v.name))
    }

    /// The values of `unknowns`, compared bit for bit.
    fn read(&mut self, unknowns: &[Variable]) -> Result<Vec<u64>, String> {
        unknowns
            .iter()
            .map(|v| {
                Ok(match self.get(v)? {
                    Value::Real(x) => x.to_bits(),
                    Value::Integer(i) => i as u64,
                    Value::Boolean(b) => b as u64,
                })
            })
            .collect()
    }

    /// Set every input to its operating point.
    fn hold_inputs(&mut self, inputs: &[Variable]) -> Result<(), String> {
        for (j, v) in inputs.iter().enumerate() {
            if let VarType::Real { .. } = v.kind {
                self.set(v, Value::Real(operating_point(j)))?;
            }
        }
        Ok(())
    }
}

fn of(d: &ModelDescription, causalities: &[Causality]) -> Vec<Variable> {
    d.variables
        .iter()
        .filter(|v| causalities.contains(&v.causality))
        .cloned()
        .collect()
}

/// Move each known in turn and record which unknowns move.
fn record(
    unknowns: &[Variable],
    knowns: &[Variable],
    mut moved: impl FnMut(&Variable) -> Result<Vec<bool>, String>,
) -> Result<Dependencies, String> {
    let mut deps: Dependencies = unknowns
        .iter()
        .map(|u| (u.name.clone(), BTreeSet::new()))
        .collect();
    for k in knowns {
        for (i, changed) in moved(k)?.into_iter().enumerate() {
            if changed {
                deps[i].1.insert(k.name.clone());
            }
        }
    }
    Ok(deps)
}

/// Measure a model's dependencies through the runtime (the same calls as the C functions make).
/// The point probed: every input at its operating point, the Real parameters of `at` at their
/// values, the others at their start values. Initial unknowns are probed in Initialization Mode
/// (one fresh instance per known), outputs at the communication point after two steps.
pub fn measure<M: Model>(
    resource_uri: Option<&str>,
    callbacks: &CallbackFunctions,
    at: &[(&str, f64)],
) -> Result<Measured, String> {
    let resources = resource_uri
        .map(crate::uri::resource_path)
        .transpose()
        .map_err(|e| e.to_string())?;
    let d = M::description(resources.as_deref())?;
    let mut probe = Probe::<M>::new(&d.guid, resource_uri, callbacks)?;
    let inputs = of(&d, &[Causality::Input]);
    let parameters = of(&d, &[Causality::Parameter]);
    let outputs = of(&d, &[Causality::Output]);
    let initial_unknowns = of(&d, &[Causality::Output, Causality::CalculatedParameter]);

    let initial_state = |probe: &mut Probe<M>| -> Result<(), String> {
        probe.instance.setup_experiment(None, 0.0, None)?;
        probe.instance.enter_initialization_mode()?;
        for (name, value) in at {
            let v = d
                .variable(name)
                .ok_or_else(|| format!("no variable '{name}' to probe at"))?;
            probe.set(v, Value::Real(*value))?;
        }
        probe.hold_inputs(&inputs)
    };
    initial_state(&mut probe)?;
    let base = probe.read(&initial_unknowns)?;
    let knowns: Vec<Variable> = inputs.iter().chain(&parameters).cloned().collect();
    let initial = record(&initial_unknowns, &knowns, |k| {
        let mut p = Probe::<M>::new(&d.guid, resource_uri, callbacks)?;
        initial_state(&mut p)?;
        let now = p.get(k)?;
        p.set(k, perturbed(k, now))?;
        let after = p.read(&initial_unknowns)?;
        Ok(after.iter().zip(&base).map(|(a, b)| a != b).collect())
    })?;

    probe.instance.exit_initialization_mode()?;
    for n in 0..2 {
        probe.instance.do_step(n as f64 * 1e-3, 1e-3)?;
    }
    let base = probe.read(&outputs)?;
    let outputs = record(&outputs, &inputs, |k| {
        let now = probe.get(k)?;
        probe.set(k, perturbed(k, now))?;
        let after = probe.read(&outputs)?;
        probe.set(k, now)?;
        Ok(after.iter().zip(&base).map(|(a, b)| a != b).collect())
    })?;
    Ok(Measured { outputs, initial })
}

impl Measured {
    /// Compare with what `d` declares: `Outputs` dependencies, then `InitialUnknowns` ones (the
    /// inputs of an output's `depends_on` and its `initial_parameters`).
    pub fn compare(&self, d: &ModelDescription) -> Mismatch {
        let mut m = Mismatch::default();
        let mut diff = |seen: &Dependencies, declared: &dyn Fn(&Variable) -> BTreeSet<String>| {
            for (name, seen) in seen {
                let v = d.variable(name).expect("measured from this description");
                let declared = declared(v);
                for k in seen.difference(&declared) {
                    m.undeclared.push((name.clone(), k.clone()));
                }
                for k in declared.difference(seen) {
                    m.unobserved.push((name.clone(), k.clone()));
                }
            }
        };
        let inputs = |v: &Variable| v.depends_on.iter().map(|(k, _)| k.clone()).collect();
        diff(&self.outputs, &inputs);
        diff(&self.initial, &|v| {
            let mut all: BTreeSet<String> = inputs(v);
            all.extend(v.initial_parameters.iter().cloned());
            all
        });
        m
    }
}
