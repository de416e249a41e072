//! The variable table of an FMU — the single source of truth — and the `modelDescription.xml`
//! derived from it (FMI 2.0.4 §2.2): Co-Simulation, and Model Exchange where a model declares
//! continuous states.

mod fmi3;

use crate::logger::Category;
use std::collections::BTreeSet;
use std::fmt::Write;

pub type ValueReference = u32;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Causality {
    Parameter,
    CalculatedParameter,
    Input,
    Output,
    /// Model Exchange's continuous states that are not outputs, and the state derivatives.
    Local,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Variability {
    Fixed,
    Tunable,
    Continuous,
    Discrete,
}

/// The value type of a variable, with its start value where it has one.
#[derive(Debug, Clone, PartialEq)]
pub enum VarType {
    Real {
        unit: &'static str,
        start: Option<f64>,
        min: Option<f64>,
        max: Option<f64>,
    },
    Integer {
        start: Option<i32>,
    },
    Boolean {
        start: Option<bool>,
    },
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum BaseType {
    Real,
    Integer,
    Boolean,
}

impl VarType {
    pub fn base(&self) -> BaseType {
        match self {
            VarType::Real { .. } => BaseType::Real,
            VarType::Integer { .. } => BaseType::Integer,
            VarType::Boolean { .. } => BaseType::Boolean,
        }
    }
}

/// How a known enters an unknown (`dependenciesKind`, FMI 2.0.4 §2.2.8): `f(v)` without a
/// particular structure, or `c·v` with `c` a constant, a fixed parameter, a tunable parameter or a
/// discrete variable.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DependencyKind {
    Dependent,
    Constant,
    Fixed,
    Tunable,
    Discrete,
}

impl DependencyKind {
    fn name(self) -> &'static str {
        match self {
            DependencyKind::Dependent => "dependent",
            DependencyKind::Constant => "constant",
            DependencyKind::Fixed => "fixed",
            DependencyKind::Tunable => "tunable",
            DependencyKind::Discrete => "discrete",
        }
    }
}

/// One `ScalarVariable`.
#[derive(Debug, Clone, PartialEq)]
pub struct Variable {
    pub name: String,
    pub value_reference: ValueReference,
    pub description: String,
    pub causality: Causality,
    pub variability: Variability,
    pub kind: VarType,
    /// For outputs: the inputs (by name) the output depends on directly at a communication
    /// point (feed-through), and how.
    pub depends_on: Vec<(String, DependencyKind)>,
    /// For outputs and calculated parameters: the parameters (by name) the value depends on in
    /// Initialization Mode. With the inputs of `depends_on` they are its `InitialUnknowns`
    /// dependencies (the knowns there are the inputs and the `initial="exact"` variables).
    pub initial_parameters: Vec<String>,
    /// For a state derivative (Model Exchange): the continuous state (by name) it is the
    /// derivative of.
    pub derivative_of: Option<String>,
}

impl Variable {
    /// An input or an output: what a terminal groups and a master connects.
    pub fn is_io(&self) -> bool {
        matches!(self.causality, Causality::Input | Causality::Output)
    }

    pub fn real(
        name: impl Into<String>,
        vr: ValueReference,
        causality: Causality,
        unit: &'static str,
        description: impl Into<String>,
    ) -> Self {
        let variability = match causality {
            Causality::Parameter | Causality::CalculatedParameter => Variability::Fixed,
            Causality::Input | Causality::Output | Causality::Local => Variability::Continuous,
        };
        Variable {
            name: name.into(),
            value_reference: vr,
            description: description.into(),
            causality,
            variability,
            kind: VarType::Real {
                unit,
                start: None,
                min: None,
                max: None,
            },
            depends_on: Vec::new(),
            initial_parameters: Vec::new(),
            derivative_of: None,
        }
    }

    /// The derivative of the continuous state `state` (Model Exchange), a local Real.
    pub fn derivative(
        state: &Variable,
        vr: ValueReference,
        unit: &'static str,
        description: impl Into<String>,
    ) -> Self {
        let mut v = Variable::real(
            format!("der({})", state.name),
            vr,
            Causality::Local,
            unit,
            description,
        );
        v.derivative_of = Some(state.name.clone());
        v
    }

    /// A Boolean variable (discrete: a Boolean cannot be continuous).
    pub fn boolean(
        name: impl Into<String>,
        vr: ValueReference,
        causality: Causality,
        description: impl Into<String>,
    ) -> Self {
        let variability = match causality {
            Causality::Parameter | Causality::CalculatedParameter => Variability::Fixed,
            Causality::Input | Causality::Output | Causality::Local => Variability::Discrete,
        };
        Variable {
            name: name.into(),
            value_reference: vr,
            description: description.into(),
            causality,
            variability,
            kind: VarType::Boolean { start: None },
            depends_on: Vec::new(),
            initial_parameters: Vec::new(),
            derivative_of: None,
        }
    }

    /// An Integer variable with its start value (a parameter's, or an input's).
    pub fn integer(
        name: impl Into<String>,
        vr: ValueReference,
        causality: Causality,
        start: i32,
        description: impl Into<String>,
    ) -> Self {
        let variability = match causality {
            Causality::Parameter | Causality::CalculatedParameter => Variability::Fixed,
            Causality::Input | Causality::Output | Causality::Local => Variability::Discrete,
        };
        Variable {
            name: name.into(),
            value_reference: vr,
            description: description.into(),
            causality,
            variability,
            kind: VarType::Integer { start: Some(start) },
            depends_on: Vec::new(),
            initial_parameters: Vec::new(),
            derivative_of: None,
        }
    }

    /// The start value of a Boolean variable.
    pub fn with_boolean_start(mut self, value: bool) -> Self {
        if let VarType::Boolean { start } = &mut self.kind {
            *start = Some(value);
        }
        self
    }

    pub fn with_start(mut self, value: f64) -> Self {
        if let VarType::Real { start, .. } = &mut self.kind {
            *start = Some(value);
        }
        self
    }

    pub fn with_min(mut self, value: f64) -> Self {
        if let VarType::Real { min, .. } = &mut self.kind {
            *min = Some(value);
        }
        self
    }

    pub fn with_max(mut self, value: f64) -> Self {
        if let VarType::Real { max, .. } = &mut self.kind {
            *max = Some(value);
        }
        self
    }

    pub fn with_variability(mut self, variability: Variability) -> Self {
        self.variability = variability;
        self
    }

    /// Add direct dependencies on `inputs`, each entering as `kind`.
    pub fn depending_on(mut self, inputs: Vec<String>, kind: DependencyKind) -> Self {
        self.depends_on
            .extend(inputs.into_iter().map(|i| (i, kind)));
        self
    }

    /// Add dependencies on `parameters` in Initialization Mode.
    pub fn initially_depending_on(mut self, parameters: Vec<String>) -> Self {
        self.initial_parameters.extend(parameters);
        self
    }

    pub fn unit(&self) -> Option<&'static str> {
        match &self.kind {
            VarType::Real { unit, .. } if !unit.is_empty() => Some(unit),
            _ => None,
        }
    }

    /// May this variable be set in state `initialising` (Instantiated / InitializationMode)
    /// or, if false, in StepComplete? (FMI 2.0.4 §4.2.4 and the variability rules of §2.2.7.)
    /// Its `causality`, `variability` and `initial` attributes as the XML writes them (the
    /// last with its leading space and name, or empty).
    fn attributes(&self) -> (&'static str, &'static str, &'static str) {
        let causality = match self.causality {
            Causality::Parameter => "parameter",
            Causality::CalculatedParameter => "calculatedParameter",
            Causality::Input => "input",
            Causality::Output => "output",
            Causality::Local => "local",
        };
        let variability = match self.variability {
            Variability::Fixed => "fixed",
            Variability::Tunable => "tunable",
            Variability::Continuous => "continuous",
            Variability::Discrete => "discrete",
        };
        let initial = match self.causality {
            Causality::Parameter => r#" initial="exact""#,
            Causality::CalculatedParameter | Causality::Output | Causality::Local => {
                r#" initial="calculated""#
            }
            Causality::Input => "",
        };
        (causality, variability, initial)
    }

    pub fn settable(&self, initialising: bool) -> bool {
        settable(self.causality, self.variability, initialising)
    }
}

/// Whether a variable of this causality and variability may be set, in Initialization Mode or
/// after it.
pub fn settable(causality: Causality, variability: Variability, initialising: bool) -> bool {
    match causality {
        Causality::Input => true,
        Causality::Parameter => initialising || variability == Variability::Tunable,
        Causality::CalculatedParameter | Causality::Output | Causality::Local => false,
    }
}

/// FMI 3.0 declares variables FMI 2.0 has no place for: the independent variable `time`, and
/// (Model Exchange) one variable per event indicator. They get value references above every
/// model variable's ([`ModelDescription::check`] holds the models below it); the runtime
/// answers them ([`crate::instance::Instance::get_float64`]).
pub const FMI3_TIME_VR: ValueReference = 1_000_000_000;
/// The first event indicator's value reference in FMI 3.0 (the `i`-th is this plus `i`).
pub const FMI3_EVENT_INDICATOR_VR: ValueReference = FMI3_TIME_VR + 1;

/// Capability flags of `<CoSimulation>`. They must tell the truth.
#[derive(Debug, Clone, PartialEq)]
pub struct Capabilities {
    pub can_handle_variable_communication_step_size: bool,
    pub can_interpolate_inputs: bool,
    pub max_output_derivative_order: u32,
    pub can_get_and_set_fmu_state: bool,
    pub can_serialize_fmu_state: bool,
    /// `fmi2GetDirectionalDerivative` answers (the model's [`crate::Model::directional_derivative`]).
    pub provides_directional_derivative: bool,
}

impl Capabilities {
    /// What every FMU of this project can do: variable step sizes, FMU state get/set and
    /// serialisation; no output derivatives. Input interpolation as given.
    pub fn exact_stepping(can_interpolate_inputs: bool) -> Self {
        Capabilities {
            can_handle_variable_communication_step_size: true,
            can_interpolate_inputs,
            max_output_derivative_order: 0,
            can_get_and_set_fmu_state: true,
            can_serialize_fmu_state: true,
            provides_directional_derivative: false,
        }
    }

    /// The same, with directional derivatives.
    pub fn with_directional_derivatives(mut self) -> Self {
        self.provides_directional_derivative = true;
        self
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct DefaultExperiment {
    pub start_time: f64,
    pub stop_time: f64,
    pub step_size: f64,
    /// The relative tolerance an importer passes to `fmi2SetupExperiment`. Our FMUs step
    /// exactly (matrix exponentials, no error control), so it documents their accuracy rather
    /// than tuning it.
    pub tolerance: f64,
}

/// The `<ModelExchange>` interface: a model whose continuous states an integrator advances.
/// The states are the variables the derivatives (`Variable::derivative_of`) name, in the order
/// of the derivatives in the table.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelExchange {
    pub number_of_event_indicators: usize,
    /// `completedIntegratorStepNotNeeded`.
    pub completed_integrator_step_not_needed: bool,
}

/// A periodic input clock of constant interval (FMI 3.0 §2.4.7.5, `intervalVariability =
/// "constant"`) that ticks a sampled-data model: at each tick, in Co-Simulation's Event Mode,
/// the model samples its inputs, computes its outputs and holds them until the next tick
/// ([`crate::instance::Instance::update_discrete_states3`]). FMI 2.0 has no clocks: its
/// description leaves it out, and the model is stepped at every communication point, which is
/// also what an FMI 3.0 importer gets with `eventModeUsed = false`.
#[derive(Debug, Clone, PartialEq)]
pub struct SampleClock {
    pub name: String,
    pub value_reference: ValueReference,
    /// The sample period, in seconds: the ticks are at `startTime + k · interval`.
    pub interval: f64,
    pub description: String,
}

/// An FMI 3.0 array the model is made of (a controller's matrices): a `calculatedParameter`
/// of fixed variability, computed from the resources, which the runtime answers
/// (`fmi3GetFloat64`) without the model. FMI 2.0 has no arrays: its description leaves it out.
#[derive(Debug, Clone, PartialEq)]
pub struct ArrayParameter {
    pub name: String,
    pub value_reference: ValueReference,
    pub description: String,
    /// The size of each dimension (every one ≥ 1).
    pub dimensions: Vec<usize>,
    /// The elements in row-major order, FMI 3.0's serialisation of an array.
    pub values: Vec<f64>,
}

/// An FMI 3.0 terminal (`terminalsAndIcons/terminalsAndIcons.xml`, FMI 3.0.2 §2.4.9): input
/// and output variables grouped under member names, so a tool that connects FMUs by terminals
/// (a suspension corner to a controller's corner) makes the connections a master makes by name.
#[derive(Debug, Clone, PartialEq)]
pub struct Terminal {
    pub name: String,
    pub description: String,
    /// `(variable, member name)`: the member names are the variable names less the terminal's
    /// suffix, so the members of two terminals match by name (`matchingRule="bus"`).
    pub members: Vec<(String, String)>,
}

impl Terminal {
    /// The inputs and outputs among `variables` whose names end in `_{suffix}`, each the member
    /// its name less the suffix; `None` if there is none.
    pub fn by_suffix(
        variables: &[Variable],
        name: &str,
        suffix: &str,
        description: &str,
    ) -> Option<Terminal> {
        let tail = format!("_{suffix}");
        let members: Vec<(String, String)> = variables
            .iter()
            .filter(|v| v.is_io())
            .filter_map(|v| {
                let member = v.name.strip_suffix(&tail)?;
                Some((v.name.clone(), member.to_string()))
            })
            .collect();
        (!members.is_empty()).then(|| Terminal {
            name: name.into(),
            description: description.into(),
            members,
        })
    }

    /// A suspension's terminals: one per corner (`corner_fl` … `corner_rr`: the variables
    /// ending in `_fl` … `_rr`), the seat's (`seat`, in `_seat`), and `body` for the other inputs
    /// and outputs (their names the members); those with members. Connected terminal to
    /// terminal, FMUs get the connections a master makes by variable name.
    pub fn suspension(variables: &[Variable]) -> Vec<Terminal> {
        let groups = [
            ("corner_fl", "fl", "front left corner"),
            ("corner_fr", "fr", "front right corner"),
            ("corner_rl", "rl", "rear left corner"),
            ("corner_rr", "rr", "rear right corner"),
            ("seat", "seat", "driver's seat"),
        ];
        let mut terminals: Vec<Terminal> = groups
            .iter()
            .filter_map(|(name, suffix, what)| {
                let description = format!(
                    "The {what}: this FMU's inputs and outputs named *_{suffix}, each the \
                     member its name less the suffix"
                );
                Terminal::by_suffix(variables, name, suffix, &description)
            })
            .collect();
        let grouped: BTreeSet<&str> = terminals
            .iter()
            .flat_map(|t| t.members.iter().map(|(v, _)| v.as_str()))
            .collect();
        let body: Vec<(String, String)> = variables
            .iter()
            .filter(|v| v.is_io())
            .filter(|v| !grouped.contains(v.name.as_str()))
            .map(|v| (v.name.clone(), v.name.clone()))
            .collect();
        if !body.is_empty() {
            terminals.push(Terminal {
                name: "body".into(),
                description: "The body and the rest: this FMU's other inputs and outputs, each \
                              the member of its own name"
                    .into(),
                members: body,
            });
        }
        terminals
    }
}

/// Everything `modelDescription.xml` says.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelDescription {
    pub model_name: String,
    pub model_identifier: String,
    pub guid: String,
    pub description: String,
    pub version: String,
    pub capabilities: Capabilities,
    pub default_experiment: DefaultExperiment,
    pub variables: Vec<Variable>,
    /// Model Exchange beside Co-Simulation, if the model has it.
    pub model_exchange: Option<ModelExchange>,
    /// FMI 3.0's input clock that ticks the model, if it is a sampled-data one; every output is
    /// then clocked by it.
    pub sample_clock: Option<SampleClock>,
    /// FMI 3.0's array parameters.
    pub arrays: Vec<ArrayParameter>,
    /// FMI 3.0's terminals.
    pub terminals: Vec<Terminal>,
}

/// Units declared by name alone: a noise density's `√Hz` has no integer base-unit exponents,
/// and FMI 2.0's `<BaseUnit>` is optional.
const NAMED_UNITS: [&str; 2] = ["m/s2/sqrt(Hz)", "rad/s/sqrt(Hz)"];

/// Base-unit exponents (kg, m, s, A, K, mol, cd, rad) of every unit our FMUs use (all zero for
/// the [`NAMED_UNITS`]).
fn base_unit(unit: &str) -> Option<[i32; 8]> {
    if NAMED_UNITS.contains(&unit) {
        return Some([0; 8]);
    }
    Some(match unit {
        "m" => [0, 1, 0, 0, 0, 0, 0, 0],
        "m/s" => [0, 1, -1, 0, 0, 0, 0, 0],
        "m/s2" => [0, 1, -2, 0, 0, 0, 0, 0],
        "rad" => [0, 0, 0, 0, 0, 0, 0, 1],
        "rad/s" => [0, 0, -1, 0, 0, 0, 0, 1],
        "rad/s2" => [0, 0, -2, 0, 0, 0, 0, 1],
        "kg" => [1, 0, 0, 0, 0, 0, 0, 0],
        "kg.m2" => [1, 2, 0, 0, 0, 0, 0, 0],
        "N" => [1, 1, -2, 0, 0, 0, 0, 0],
        "N/m" => [1, 0, -2, 0, 0, 0, 0, 0],
        "N/s" => [1, 1, -3, 0, 0, 0, 0, 0],
        "N.s/m" => [1, 0, -1, 0, 0, 0, 0, 0],
        "s" => [0, 0, 1, 0, 0, 0, 0, 0],
        "Hz" => [0, 0, -1, 0, 0, 0, 0, 0],
        "1" => [0; 8],
        _ => return None,
    })
}

/// Why a description is not a valid FMI 2.0 description.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DescriptionError(pub String);

impl std::fmt::Display for DescriptionError {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl ModelDescription {
    /// Set the GUID to a hash of everything else the description says, so the GUID changes
    /// exactly when the interface (or a default) changes, and a binary refuses a
    /// `modelDescription.xml` it was not built with.
    /// With a suspension's terminals ([`Terminal::suspension`]) from its variables.
    pub fn with_suspension_terminals(mut self) -> Self {
        self.terminals = Terminal::suspension(&self.variables);
        self
    }

    pub fn with_derived_guid(mut self) -> Self {
        self.guid = String::new();
        let xml = self.to_xml();
        let h = |seed: u64| crate::fmu_state::fnv1a(seed, xml.bytes());
        let (a, b) = (h(crate::fmu_state::FNV_OFFSET), h(0x8422_2325_cbf2_9ce4));
        self.guid = format!(
            "{{{:08x}-{:04x}-{:04x}-{:04x}-{:012x}}}",
            a >> 32,
            (a >> 16) & 0xffff,
            a & 0xffff,
            b >> 48,
            b & 0xffff_ffff_ffff
        );
        self
    }

    pub fn variable(&self, name: &str) -> Option<&Variable> {
        self.variables.iter().find(|v| v.name == name)
    }

    /// Model Exchange's continuous states as (state, its derivative), in the derivatives'
    /// order: the order of `fmi2GetContinuousStates` and `fmi2GetDerivatives`.
    pub fn continuous_states(&self) -> Vec<(&Variable, &Variable)> {
        self.variables
            .iter()
            .filter_map(|d| {
                let state = self.variable(d.derivative_of.as_deref()?)?;
                Some((state, d))
            })
            .collect()
    }

    /// Number of continuous states (0 without Model Exchange).
    pub fn number_of_states(&self) -> usize {
        self.variables
            .iter()
            .filter(|v| v.derivative_of.is_some())
            .count()
    }

    /// Rules of FMI 2.0.4 §2.2.7 that a table could break: unique names and value references
    /// per type, start values where required and forbidden, known units, dependencies on
    /// existing inputs.
    pub fn check(&self) -> Result<(), DescriptionError> {
        let mut names = BTreeSet::new();
        let mut refs = BTreeSet::new();
        for v in &self.variables {
            self.check_variable(v, &mut names, &mut refs)?;
        }
        self.check_fmi3_parts(&mut names, &mut refs)
    }

    /// One variable of the table, its name and value reference unique among those seen.
    fn check_variable<'a>(
        &self,
        v: &'a Variable,
        names: &mut BTreeSet<&'a str>,
        refs: &mut BTreeSet<ValueReference>,
    ) -> Result<(), DescriptionError> {
        let err = |s: String| Err(DescriptionError(s));
        if !names.insert(v.name.as_str()) {
            return err(format!("duplicate variable name '{}'", v.name));
        }
        // Unique across the types, as FMI 3.0 requires (FMI 2.0 only within a type), and
        // below the references FMI 3.0's own variables take.
        if !refs.insert(v.value_reference) {
            return err(format!(
                "duplicate value reference {} ({:?})",
                v.value_reference,
                v.kind.base()
            ));
        }
        if v.value_reference >= FMI3_TIME_VR {
            return err(format!(
                "value reference {} of '{}' is not below {FMI3_TIME_VR}, where FMI 3.0's \
                 time and event indicators are",
                v.value_reference, v.name
            ));
        }
        if v.name == "time" || v.name.starts_with("event_indicator[") {
            return err(format!(
                "variable name '{}' is FMI 3.0's time or an event indicator",
                v.name
            ));
        }
        let has_start = match &v.kind {
            VarType::Real { start, unit, .. } => {
                if !unit.is_empty() && base_unit(unit).is_none() {
                    return err(format!("variable '{}' has unknown unit '{unit}'", v.name));
                }
                start.is_some()
            }
            VarType::Integer { start } => start.is_some(),
            VarType::Boolean { start } => start.is_some(),
        };
        if let Some(state) = &v.derivative_of {
            let fine = v.causality == Causality::Local
                && self.variable(state).is_some_and(|s| {
                    matches!(s.causality, Causality::Output | Causality::Local)
                        && s.variability == Variability::Continuous
                        && s.kind.base() == BaseType::Real
                        && s.derivative_of.is_none()
                });
            if !fine {
                return err(format!(
                    "'{}' must be a local derivative of a continuous Real state, '{state}'",
                    v.name
                ));
            }
            if self.model_exchange.is_none() {
                return err(format!(
                    "'{}' is a state derivative, but there is no Model Exchange",
                    v.name
                ));
            }
        }
        if v.causality == Causality::Local
            && v.derivative_of.is_none()
            && !self
                .variables
                .iter()
                .any(|d| d.derivative_of.as_ref() == Some(&v.name))
        {
            return err(format!(
                "local '{}' is neither a continuous state nor a derivative",
                v.name
            ));
        }
        let needs_start = matches!(v.causality, Causality::Parameter | Causality::Input);
        if needs_start != has_start {
            return err(format!(
                "variable '{}' ({:?}) must {}have a start value",
                v.name,
                v.causality,
                if needs_start { "" } else { "not " }
            ));
        }
        let derivative = v.derivative_of.is_some();
        if !v.depends_on.is_empty() && v.causality != Causality::Output && !derivative {
            return err(format!(
                "'{}' has dependencies but is neither an output nor a state derivative",
                v.name
            ));
        }
        for (d, kind) in &v.depends_on {
            // An output's knowns are inputs; a derivative's, inputs and continuous states.
            let state = derivative
                && self
                    .variables
                    .iter()
                    .any(|x| x.derivative_of.as_ref() == Some(d));
            let Some(known) = self
                .variable(d)
                .filter(|k| k.causality == Causality::Input || state)
            else {
                return err(format!(
                    "'{}' depends on '{d}', which is not an input{}",
                    v.name,
                    if derivative { " or a state" } else { "" }
                ));
            };
            let linear = !matches!(kind, DependencyKind::Dependent);
            if linear && known.kind.base() != BaseType::Real {
                return err(format!(
                    "'{}' depends on '{d}' as {:?}, which only a Real can",
                    v.name, kind
                ));
            }
        }
        if !v.initial_parameters.is_empty()
            && !matches!(
                v.causality,
                Causality::Output | Causality::CalculatedParameter
            )
            && !derivative
        {
            return err(format!(
                "'{}' has initial dependencies but is not an initial unknown",
                v.name
            ));
        }
        for d in &v.initial_parameters {
            if self.variable(d).map(|k| k.causality) != Some(Causality::Parameter) {
                return err(format!(
                    "'{}' initially depends on '{d}', which is not a parameter",
                    v.name
                ));
            }
        }
        Ok(())
    }

    /// FMI 3.0's parts beside the variables: the arrays, the terminals and the sample clock.
    fn check_fmi3_parts<'a>(
        &'a self,
        names: &mut BTreeSet<&'a str>,
        refs: &mut BTreeSet<ValueReference>,
    ) -> Result<(), DescriptionError> {
        let err = |s: String| Err(DescriptionError(s));
        for a in &self.arrays {
            if !names.insert(a.name.as_str()) || !refs.insert(a.value_reference) {
                return err(format!(
                    "array '{}' (value reference {}) repeats a name or a value reference",
                    a.name, a.value_reference
                ));
            }
            let size: usize = a.dimensions.iter().product();
            if a.value_reference >= FMI3_TIME_VR
                || a.dimensions.contains(&0)
                || size != a.values.len()
                || a.values.iter().any(|v| !v.is_finite())
            {
                return err(format!(
                    "array '{}': value reference {} not below {FMI3_TIME_VR}, or dimensions {:?} \
                     not all ≥ 1 and not holding its {} finite values",
                    a.name,
                    a.value_reference,
                    a.dimensions,
                    a.values.len()
                ));
            }
        }
        for t in &self.terminals {
            let mut members = BTreeSet::new();
            for (variable, member) in &t.members {
                let io = self.variable(variable).is_some_and(Variable::is_io);
                if !io || !members.insert(member.as_str()) {
                    return err(format!(
                        "terminal '{}': '{variable}' is not an input or output, or member \
                         '{member}' repeats",
                        t.name
                    ));
                }
            }
        }
        if let Some(c) = &self.sample_clock {
            if refs.contains(&c.value_reference) || c.value_reference >= FMI3_TIME_VR {
                return err(format!(
                    "clock '{}' has value reference {}, which a variable has or which is not \
                     below {FMI3_TIME_VR}",
                    c.name, c.value_reference
                ));
            }
            if names.contains(c.name.as_str()) {
                return err(format!("clock '{}' has a variable's name", c.name));
            }
            if !(c.interval.is_finite() && c.interval > 0.0) {
                return err(format!(
                    "clock '{}' has interval {}: it must be finite and > 0",
                    c.name, c.interval
                ));
            }
        }
        Ok(())
    }

    /// The `modelDescription.xml` text. Deterministic (no date), so the checked-in copy in
    /// `modelDescription/` can be compared byte for byte.
    pub fn to_xml(&self) -> String {
        let mut x = String::new();
        writeln!(x, r#"<?xml version="1.0" encoding="UTF-8"?>"#).unwrap();
        writeln!(x, "<!-- Generated from the variable table in Rust; do not edit. Regenerate with `make descriptions`. -->").unwrap();
        writeln!(
            x,
            r#"<fmiModelDescription fmiVersion="2.0" modelName="{}" guid="{}" description="{}" version="{}" generationTool="suspension-fmus {} (fmu-core)" variableNamingConvention="structured" numberOfEventIndicators="{}">"#,
            esc(&self.model_name), esc(&self.guid), esc(&self.description), esc(&self.version), env!("CARGO_PKG_VERSION"),
            self.number_of_event_indicators()
        )
        .unwrap();
        self.write_interfaces(&mut x);
        self.write_units(&mut x, &[]);
        self.write_categories_and_experiment(&mut x);
        writeln!(x, "  <ModelVariables>").unwrap();
        for (i, v) in self.variables.iter().enumerate() {
            self.write_variable(&mut x, i, v);
        }
        writeln!(x, "  </ModelVariables>").unwrap();
        self.write_structure(&mut x);
        writeln!(x, "</fmiModelDescription>").unwrap();
        x
    }

    /// `<LogCategories>` and `<DefaultExperiment>`, alike in both versions.
    fn write_categories_and_experiment(&self, x: &mut String) {
        writeln!(x, "  <LogCategories>").unwrap();
        for cat in Category::ALL {
            writeln!(
                x,
                r#"    <Category name="{}" description="{}"/>"#,
                cat.name(),
                esc(cat.description())
            )
            .unwrap();
        }
        writeln!(x, "  </LogCategories>").unwrap();
        let e = &self.default_experiment;
        writeln!(
            x,
            r#"  <DefaultExperiment startTime="{}" stopTime="{}" tolerance="{}" stepSize="{}"/>"#,
            num(e.start_time),
            num(e.stop_time),
            num(e.tolerance),
            num(e.step_size)
        )
        .unwrap();
    }

    /// The variable named `name`'s index in `<ModelVariables>` (1-based).
    fn index_of(&self, name: &str) -> usize {
        self.variables
            .iter()
            .position(|v| v.name == name)
            .expect("checked")
            + 1
    }

    /// `<ModelExchange>` where the model has it, and `<CoSimulation>`.
    fn write_interfaces(&self, x: &mut String) {
        let c = &self.capabilities;
        if let Some(me) = &self.model_exchange {
            writeln!(
                x,
                r#"  <ModelExchange modelIdentifier="{}" needsExecutionTool="false" completedIntegratorStepNotNeeded="{}" canBeInstantiatedOnlyOncePerProcess="false" canNotUseMemoryManagementFunctions="true" canGetAndSetFMUstate="{}" canSerializeFMUstate="{}" providesDirectionalDerivative="{}"/>"#,
                esc(&self.model_identifier),
                flag(me.completed_integrator_step_not_needed),
                flag(c.can_get_and_set_fmu_state),
                flag(c.can_serialize_fmu_state),
                flag(c.provides_directional_derivative)
            )
            .unwrap();
        }
        writeln!(
            x,
            r#"  <CoSimulation modelIdentifier="{}" needsExecutionTool="false" canHandleVariableCommunicationStepSize="{}" canInterpolateInputs="{}" maxOutputDerivativeOrder="{}" canRunAsynchronuously="false" canBeInstantiatedOnlyOncePerProcess="false" canNotUseMemoryManagementFunctions="true" canGetAndSetFMUstate="{}" canSerializeFMUstate="{}" providesDirectionalDerivative="{}"/>"#,
            esc(&self.model_identifier),
            flag(c.can_handle_variable_communication_step_size),
            flag(c.can_interpolate_inputs),
            c.max_output_derivative_order,
            flag(c.can_get_and_set_fmu_state),
            flag(c.can_serialize_fmu_state),
            flag(c.provides_directional_derivative)
        )
        .unwrap();
    }

    /// The number of event indicators (0 without Model Exchange).
    pub fn number_of_event_indicators(&self) -> usize {
        self.model_exchange
            .as_ref()
            .map_or(0, |me| me.number_of_event_indicators)
    }

    /// Every unit a variable uses, and `extra`, sorted.
    fn units(&self, extra: &[&'static str]) -> BTreeSet<&str> {
        self.variables
            .iter()
            .filter_map(|v| v.unit())
            .chain(extra.iter().copied())
            .collect()
    }

    /// Whether `v` is an initial unknown: an output, a calculated parameter, a state or a
    /// derivative (the locals).
    fn is_initial_unknown(v: &Variable) -> bool {
        matches!(
            v.causality,
            Causality::Output | Causality::CalculatedParameter | Causality::Local
        )
    }

    /// An initial unknown's dependencies, by name: the inputs it depends on and its parameters
    /// (a derivative's states are unknowns themselves at initialisation: they start at the
    /// equilibrium). Only `dependent` and `constant` are kinds there, and no factor is constant
    /// once the parameters are knowns, so every one is `dependent`.
    fn initial_dependencies<'a>(&'a self, v: &'a Variable) -> impl Iterator<Item = &'a str> + 'a {
        v.depends_on
            .iter()
            .map(|(d, _)| d)
            .filter(|d| self.variable(d).map(|k| k.causality) == Some(Causality::Input))
            .chain(&v.initial_parameters)
            .map(String::as_str)
    }

    /// `<UnitDefinitions>`: every unit a variable uses, and `extra`, with its base-unit
    /// exponents.
    fn write_units(&self, x: &mut String, extra: &[&'static str]) {
        let units = self.units(extra);
        if units.is_empty() {
            return;
        }
        writeln!(x, "  <UnitDefinitions>").unwrap();
        for u in units {
            let exps = base_unit(u).expect("units are checked");
            let attrs: String = ["kg", "m", "s", "A", "K", "mol", "cd", "rad"]
                .iter()
                .zip(exps)
                .filter(|(_, e)| *e != 0)
                .map(|(n, e)| format!(r#" {n}="{e}""#))
                .collect();
            if NAMED_UNITS.contains(&u) {
                writeln!(x, r#"    <Unit name="{}"/>"#, esc(u)).unwrap();
            } else {
                writeln!(
                    x,
                    r#"    <Unit name="{}"><BaseUnit{attrs}/></Unit>"#,
                    esc(u)
                )
                .unwrap();
            }
        }
        writeln!(x, "  </UnitDefinitions>").unwrap();
    }

    /// One `<ScalarVariable>`, the `i`-th.
    fn write_variable(&self, x: &mut String, i: usize, v: &Variable) {
        let (causality, variability, initial) = v.attributes();
        writeln!(x, "    <!-- index {} -->", i + 1).unwrap();
        writeln!(
            x,
            r#"    <ScalarVariable name="{}" valueReference="{}" description="{}" causality="{causality}" variability="{variability}"{initial}>"#,
            esc(&v.name), v.value_reference, esc(&v.description)
        )
        .unwrap();
        match &v.kind {
            VarType::Real {
                unit,
                start,
                min,
                max,
            } => {
                let derivative = v.derivative_of.as_ref().map(|s| self.index_of(s));
                let attrs = real_attributes("unit", unit, [min, max, start], derivative);
                writeln!(x, "      <Real{attrs}/>").unwrap();
            }
            VarType::Integer { start } => match start {
                Some(s) => writeln!(x, r#"      <Integer start="{s}"/>"#).unwrap(),
                None => writeln!(x, "      <Integer/>").unwrap(),
            },
            VarType::Boolean { start } => match start {
                Some(s) => writeln!(x, r#"      <Boolean start="{}"/>"#, flag(*s)).unwrap(),
                None => writeln!(x, "      <Boolean/>").unwrap(),
            },
        }
        writeln!(x, "    </ScalarVariable>").unwrap();
    }

    /// `<ModelStructure>`: the outputs, the derivatives and the initial unknowns, each with
    /// its dependencies by index, sorted as the standard requires, and their kinds.
    fn write_structure(&self, x: &mut String) {
        let unknown = |i: usize, deps: Vec<(usize, DependencyKind)>| {
            let (refs, kinds) = dependency_lists(deps);
            format!(
                r#"      <Unknown index="{i}" dependencies="{refs}" dependenciesKind="{kinds}"/>"#
            )
        };
        // A section of the unknowns `which` picks, each depending on what `deps` names.
        let section =
            |x: &mut String,
             tag: &str,
             which: &dyn Fn(&Variable) -> bool,
             deps: &dyn Fn(&Variable) -> Vec<(usize, DependencyKind)>| {
                let picked: Vec<(usize, &Variable)> = self
                    .variables
                    .iter()
                    .enumerate()
                    .filter(|(_, v)| which(v))
                    .collect();
                if picked.is_empty() {
                    return;
                }
                writeln!(x, "    <{tag}>").unwrap();
                for (i, v) in picked {
                    writeln!(x, "{}", unknown(i + 1, deps(v))).unwrap();
                }
                writeln!(x, "    </{tag}>").unwrap();
            };
        let own = |v: &Variable| -> Vec<(usize, DependencyKind)> {
            v.depends_on
                .iter()
                .map(|(d, k)| (self.index_of(d), *k))
                .collect()
        };
        writeln!(x, "  <ModelStructure>").unwrap();
        section(x, "Outputs", &|v| v.causality == Causality::Output, &own);
        // A derivative depends on continuous states and inputs.
        section(x, "Derivatives", &|v| v.derivative_of.is_some(), &own);
        section(x, "InitialUnknowns", &Self::is_initial_unknown, &|v| {
            self.initial_dependencies(v)
                .map(|d| (self.index_of(d), DependencyKind::Dependent))
                .collect()
        });
        writeln!(x, "  </ModelStructure>").unwrap();
    }
}

/// A model structure element's `dependencies` and `dependenciesKind`, sorted by the known
/// (an index in FMI 2.0, a value reference in FMI 3.0) and each known once.
fn dependency_lists(mut deps: Vec<(usize, DependencyKind)>) -> (String, String) {
    deps.sort_unstable_by_key(|(d, _)| *d);
    deps.dedup_by_key(|(d, _)| *d);
    let refs: Vec<String> = deps.iter().map(|(d, _)| d.to_string()).collect();
    let kinds: Vec<&str> = deps.iter().map(|(_, k)| k.name()).collect();
    (refs.join(" "), kinds.join(" "))
}

/// A Real's attributes as both versions write them: its unit (as `unit_attribute`, FMI 3.0's
/// `declaredType`), `min`, `max`, `start`, and `derivative` (the state's index in FMI 2.0, its
/// value reference in FMI 3.0).
fn real_attributes(
    unit_attribute: &str,
    unit: &str,
    [min, max, start]: [&Option<f64>; 3],
    derivative: Option<usize>,
) -> String {
    let mut attrs = String::new();
    if !unit.is_empty() {
        write!(attrs, r#" {unit_attribute}="{}""#, esc(unit)).unwrap();
    }
    for (name, value) in [("min", min), ("max", max), ("start", start)] {
        if let Some(v) = value {
            write!(attrs, r#" {name}="{}""#, num(*v)).unwrap();
        }
    }
    if let Some(d) = derivative {
        write!(attrs, r#" derivative="{d}""#).unwrap();
    }
    attrs
}

/// An XML Boolean.
fn flag(v: bool) -> &'static str {
    if v {
        "true"
    } else {
        "false"
    }
}

impl ModelDescription {
    /// The variable table as Markdown (for the README): name, causality, unit, start, meaning.
    pub fn to_markdown_table(&self) -> String {
        let mut t = String::from(
            "| variable | causality | unit | default | description |\n|---|---|---|---|---|\n",
        );
        for v in &self.variables {
            let causality = match v.causality {
                Causality::Parameter => "parameter",
                Causality::CalculatedParameter => "calculated parameter",
                Causality::Input => "input",
                Causality::Output => "output",
                Causality::Local => "local",
            };
            let start = match &v.kind {
                VarType::Real { start: Some(s), .. } => num(*s),
                VarType::Integer { start: Some(s) } => s.to_string(),
                VarType::Boolean { start: Some(s) } => s.to_string(),
                _ => String::new(),
            };
            let desc = v.description.replace('|', "\\|");
            writeln!(
                t,
                "| `{}` | {causality} | {} | {start} | {desc} |",
                v.name,
                v.unit().unwrap_or("")
            )
            .unwrap();
        }
        t
    }

    /// Replace the text between `<!-- {tag}:begin -->` and `<!-- {tag}:end -->` in `doc`.
    pub fn splice_into(doc: &str, tag: &str, content: &str) -> Result<String, DescriptionError> {
        let begin = format!("<!-- {tag}:begin -->\n");
        let end = format!("<!-- {tag}:end -->");
        let i = doc
            .find(&begin)
            .ok_or_else(|| DescriptionError(format!("marker '{begin}' not found")))?
            + begin.len();
        let j = doc[i..]
            .find(&end)
            .ok_or_else(|| DescriptionError(format!("marker '{end}' not found")))?
            + i;
        Ok(format!("{}{}{}", &doc[..i], content, &doc[j..]))
    }
}

/// Shortest decimal that round-trips (Rust's `{}` for f64), with an exponent kept XML-friendly.
fn num(v: f64) -> String {
    let s = format!("{v:?}");
    s.replace("e", "E")
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> ModelDescription {
        ModelDescription {
            model_name: "sample".into(),
            model_identifier: "sample".into(),
            guid: "{x}".into(),
            description: "a <test> & \"quotes\"".into(),
            version: "1".into(),
            capabilities: Capabilities::exact_stepping(false),
            model_exchange: None,
            sample_clock: None,
            arrays: Vec::new(),
            terminals: Vec::new(),
            default_experiment: DefaultExperiment {
                start_time: 0.0,
                stop_time: 1.0,
                step_size: 1e-3,
                tolerance: 1e-6,
            },
            variables: vec![
                Variable::real("k", 0, Causality::Parameter, "N/m", "gain").with_start(2.5),
                Variable::real("u", 1, Causality::Input, "N", "force").with_start(0.0),
                Variable::real("y", 2, Causality::Output, "m", "position"),
                Variable::real("a", 3, Causality::Output, "m/s2", "acceleration")
                    .depending_on(vec!["u".into()], DependencyKind::Fixed)
                    .initially_depending_on(vec!["k".into()]),
            ],
        }
    }

    #[test]
    fn xml_lists_outputs_with_their_input_dependencies_by_index() {
        let xml = sample().to_xml();
        assert!(
            xml.contains(r#"<Unknown index="3" dependencies="" dependenciesKind=""/>"#),
            "{xml}"
        );
        let (outputs, initial) = xml.split_once("<InitialUnknowns>").unwrap();
        assert!(
            outputs.contains(r#"<Unknown index="4" dependencies="2" dependenciesKind="fixed"/>"#),
            "{xml}"
        );
        assert!(
            initial.contains(
                r#"<Unknown index="4" dependencies="1 2" dependenciesKind="dependent dependent"/>"#
            ),
            "{xml}"
        );
        assert!(xml.contains(r#"tolerance="1E-6""#), "{xml}");
        assert!(
            xml.contains(r#"<Unit name="N/m"><BaseUnit kg="1" s="-2"/></Unit>"#),
            "{xml}"
        );
        assert!(xml.contains("a &lt;test&gt; &amp; &quot;quotes&quot;"));
        assert!(xml.contains(r#"start="2.5""#));
        assert!(xml.contains(r#"stepSize="0.001""#));
    }

    /// FMI 3.0.2 §2.4: typed variables, the independent `time`, dependencies by value
    /// reference, the GUID as `instantiationToken`; with Model Exchange, the derivative's
    /// `derivative` names the state's value reference and each event indicator is a variable
    /// the model structure lists.
    #[test]
    fn fmi3_xml_types_its_variables_and_lists_dependencies_by_value_reference() {
        let xml = sample().to_xml3();
        assert!(xml.contains(r#"fmiVersion="3.0""#) && xml.contains(r#"instantiationToken="{x}""#));
        assert!(
            xml.contains(r#"<Float64 name="time" valueReference="1000000000" description="Simulation time" causality="independent" variability="continuous" declaredType="s"/>"#),
            "{xml}"
        );
        assert!(
            xml.contains(r#"<Unit name="s"><BaseUnit s="1"/></Unit>"#),
            "{xml}"
        );
        assert!(
            xml.contains(r#"<Float64 name="k" valueReference="0" description="gain" causality="parameter" variability="fixed" initial="exact" declaredType="N/m" start="2.5"/>"#),
            "{xml}"
        );
        assert!(
            xml.contains(
                r#"<Output valueReference="3" dependencies="1" dependenciesKind="fixed"/>"#
            ),
            "{xml}"
        );
        assert!(
            xml.contains(r#"<InitialUnknown valueReference="3" dependencies="0 1" dependenciesKind="dependent dependent"/>"#),
            "{xml}"
        );
        assert!(!xml.contains("<ModelExchange") && !xml.contains("EventIndicator"));
        let xml = with_model_exchange().to_xml3();
        assert!(
            xml.contains(r#"<ModelExchange modelIdentifier="sample""#),
            "{xml}"
        );
        assert!(
            xml.contains(r#"needsCompletedIntegratorStep="true""#),
            "{xml}"
        );
        assert!(
            xml.contains(r#"declaredType="m/s" derivative="2"/>"#),
            "{xml}"
        );
        assert!(
            xml.contains(r#"<ContinuousStateDerivative valueReference="4" dependencies="1 2" dependenciesKind="dependent dependent"/>"#),
            "{xml}"
        );
        for i in 0..2 {
            let vr = FMI3_EVENT_INDICATOR_VR + i;
            assert!(xml.contains(&format!(r#"<EventIndicator valueReference="{vr}"/>"#)));
            assert!(xml.contains(&format!(
                r#"name="event_indicator[{}]" valueReference="{vr}""#,
                i + 1
            )));
        }
    }

    /// FMI 3.0's value references are unique across the types and below its own variables'.
    #[test]
    fn check_holds_value_references_unique_across_types_and_below_fmi3_time() {
        let mut d = sample();
        d.variables.push(
            Variable::boolean("on", 2, Causality::Parameter, "a switch").with_boolean_start(true),
        );
        assert!(d
            .check()
            .unwrap_err()
            .0
            .contains("duplicate value reference 2"));
        let mut d = sample();
        d.variables[0].value_reference = FMI3_TIME_VR;
        assert!(d.check().unwrap_err().0.contains("not below 1000000000"));
        let mut d = sample();
        d.variables[0].name = "time".into();
        assert!(d.check().unwrap_err().0.contains("FMI 3.0's time"));
    }

    /// The sample with Model Exchange: `y` a state, its derivative a local.
    fn with_model_exchange() -> ModelDescription {
        let mut d = sample();
        d.model_exchange = Some(ModelExchange {
            number_of_event_indicators: 2,
            completed_integrator_step_not_needed: false,
        });
        let y = d.variables[2].clone();
        d.variables.push(
            Variable::derivative(&y, 4, "m/s", "velocity")
                .depending_on(vec!["y".into(), "u".into()], DependencyKind::Dependent)
                .initially_depending_on(vec!["k".into()]),
        );
        d
    }

    /// FMI 2.0.4 §2.2: the interface element, the event indicators' number, the derivative's
    /// `derivative` attribute (the state's index), and the derivatives among the model
    /// structure's `Derivatives` and `InitialUnknowns`.
    #[test]
    fn xml_declares_model_exchange_states_and_derivatives() {
        let d = with_model_exchange();
        assert!(d.check().is_ok(), "{:?}", d.check());
        let xml = d.to_xml();
        assert!(xml.contains(r#"numberOfEventIndicators="2""#), "{xml}");
        assert!(
            xml.contains(r#"<ModelExchange modelIdentifier="sample""#),
            "{xml}"
        );
        assert!(xml.contains(r#"name="der(y)""#) && xml.contains(r#"causality="local""#));
        assert!(xml.contains(r#"derivative="3""#), "{xml}");
        // Along the state and the input; at initialisation the input and the parameter (the
        // state is an unknown there).
        let structure = xml.split_once("<Derivatives>").unwrap().1;
        let along =
            r#"<Unknown index="5" dependencies="2 3" dependenciesKind="dependent dependent"/>"#;
        assert!(structure.trim_start().starts_with(along), "{xml}");
        let initial = xml.split_once("<InitialUnknowns>").unwrap().1;
        let at_start =
            r#"<Unknown index="5" dependencies="1 2" dependenciesKind="dependent dependent"/>"#;
        assert!(initial.contains(at_start), "{xml}");
        assert_eq!(d.number_of_states(), 1);
        assert_eq!(d.continuous_states()[0].0.name, "y");
        assert!(sample().to_xml().contains(r#"numberOfEventIndicators="0""#));
        assert!(!sample().to_xml().contains("<ModelExchange"));
    }

    #[test]
    fn check_rejects_broken_model_exchange_tables() {
        let mut d = with_model_exchange();
        d.variables[4].derivative_of = Some("k".into());
        assert!(d.check().unwrap_err().0.contains("continuous Real state"));
        let mut d = with_model_exchange();
        d.variables[4].depends_on[0].0 = "k".into();
        assert!(d.check().unwrap_err().0.contains("not an input or a state"));
        let mut d = with_model_exchange();
        d.model_exchange = None;
        assert!(d.check().unwrap_err().0.contains("no Model Exchange"));
        let mut d = sample();
        d.variables
            .push(Variable::real("z", 9, Causality::Local, "m", "loose"));
        assert!(d
            .check()
            .unwrap_err()
            .0
            .contains("neither a continuous state nor a derivative"));
    }

    #[test]
    fn check_rejects_broken_tables() {
        assert!(sample().check().is_ok());
        let mut d = sample();
        d.variables[1].value_reference = 0;
        assert!(d
            .check()
            .unwrap_err()
            .0
            .contains("duplicate value reference"));
        let mut d = sample();
        d.variables[2] = Variable::real("y", 2, Causality::Output, "m", "").with_start(1.0);
        assert!(d.check().unwrap_err().0.contains("must not have a start"));
        let mut d = sample();
        d.variables[3].depends_on = vec![("k".into(), DependencyKind::Dependent)];
        assert!(d.check().unwrap_err().0.contains("not an input"));
        let mut d = sample();
        d.variables[3].initial_parameters = vec!["u".into()];
        assert!(d.check().unwrap_err().0.contains("not a parameter"));
        let mut d = sample();
        d.variables[0] =
            Variable::real("k", 0, Causality::Parameter, "furlong", "").with_start(1.0);
        assert!(d.check().unwrap_err().0.contains("unknown unit"));
    }

    /// FMI 3.0's additions to a table: a sample clock, arrays and terminals, each checked.
    fn with_fmi3_parts() -> ModelDescription {
        let mut d = sample();
        d.variables
            .push(Variable::real("u_fl", 4, Causality::Input, "N", "").with_start(0.0));
        d.variables
            .push(Variable::real("stroke_fl", 5, Causality::Output, "m", ""));
        d.sample_clock = Some(SampleClock {
            name: "tick".into(),
            value_reference: 10,
            interval: 1e-3,
            description: "the sample clock".into(),
        });
        d.arrays = vec![ArrayParameter {
            name: "M".into(),
            value_reference: 11,
            description: "a 2 × 3 matrix".into(),
            dimensions: vec![2, 3],
            values: vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0],
        }];
        d.with_suspension_terminals()
    }

    #[test]
    fn fmi3_clocks_arrays_and_terminals_are_written_and_checked() {
        let d = with_fmi3_parts();
        d.check().unwrap();
        // Terminals by suffix, the rest in `body`; parameters in none.
        let t: Vec<(&str, Vec<(&str, &str)>)> = d
            .terminals
            .iter()
            .map(|t| {
                let m = t.members.iter().map(|(v, m)| (v.as_str(), m.as_str()));
                (t.name.as_str(), m.collect())
            })
            .collect();
        assert_eq!(
            t,
            [
                ("corner_fl", vec![("u_fl", "u"), ("stroke_fl", "stroke")]),
                ("body", vec![("u", "u"), ("y", "y"), ("a", "a")]),
            ]
        );
        let xml = d.to_xml3();
        assert!(xml.contains(r#"intervalVariability="constant" intervalDecimal="0.001""#));
        assert!(xml.contains(r#"hasEventMode="true""#));
        // Every output clocked, discrete, and no initial unknown.
        assert!(xml.contains(r#"name="y" valueReference="2" description="position" causality="output" variability="discrete" clocks="10""#), "{xml}");
        assert!(!xml.contains(r#"<InitialUnknown valueReference="2""#));
        assert!(xml.contains("<Dimension start=\"2\"/>\n      <Dimension start=\"3\"/>"));
        assert!(xml.contains(r#"<InitialUnknown valueReference="11" dependencies="""#));
        // FMI 2.0 has none of them: its description, and so the GUID, are the plain table's.
        assert_eq!(d.to_xml(), {
            let mut plain = d.clone();
            (plain.sample_clock, plain.arrays, plain.terminals) = (None, vec![], vec![]);
            plain.to_xml()
        });
        let terminals = d.to_terminals_xml().unwrap();
        assert!(terminals.contains(r#"<TerminalMemberVariable variableName="stroke_fl" memberName="stroke" variableKind="signal"/>"#));
        assert_eq!(sample().to_terminals_xml(), None);

        type Breaks = fn(&mut ModelDescription);
        let broken: [(Breaks, &str); 6] = [
            (
                |d| d.arrays[0].value_reference = 2,
                "repeats a name or a value reference",
            ),
            (
                |d| d.sample_clock.as_mut().unwrap().value_reference = 2,
                "clock 'tick' has value reference 2",
            ),
            (
                |d| d.sample_clock.as_mut().unwrap().interval = 0.0,
                "interval 0",
            ),
            (
                |d| d.arrays[0].values.pop().map(|_| ()).unwrap(),
                "array 'M'",
            ),
            (
                |d| d.arrays[0].value_reference = 10,
                "has value reference 10, which a variable has",
            ),
            (
                |d| d.terminals[1].members.push(("k".into(), "k".into())),
                "'k' is not an input or output",
            ),
        ];
        for (breaks, why) in broken {
            let mut d = with_fmi3_parts();
            breaks(&mut d);
            let e = d.check().unwrap_err().0;
            assert!(e.contains(why), "{e}");
        }
    }
}
