//! The FMI 3.0 `modelDescription.xml` (FMI 3.0.2 §2.4) of the same variable table: typed
//! variables (`Float64`, `Int32`, `Boolean`), dependencies by value reference, the independent
//! variable `time`, `instantiationToken` for the GUID, and, for Model Exchange, one variable per
//! event indicator ([`FMI3_TIME_VR`], [`FMI3_EVENT_INDICATOR_VR`]).

use super::{
    dependency_lists, esc, flag, real_attributes, BaseType, Causality, DependencyKind,
    ModelDescription, SampleClock, VarType, Variable, FMI3_EVENT_INDICATOR_VR, FMI3_TIME_VR,
};
use std::fmt::Write;

impl ModelDescription {
    /// The FMI 3.0 `modelDescription.xml` text. Deterministic, like [`Self::to_xml`].
    pub fn to_xml3(&self) -> String {
        let mut x = String::new();
        writeln!(x, r#"<?xml version="1.0" encoding="UTF-8"?>"#).unwrap();
        writeln!(x, "<!-- Generated from the variable table in Rust; do not edit. Regenerate with `make descriptions`. -->").unwrap();
        writeln!(
            x,
            r#"<fmiModelDescription fmiVersion="3.0" modelName="{}" instantiationToken="{}" description="{}" version="{}" generationTool="suspension-fmus {} (fmu-core)" variableNamingConvention="structured">"#,
            esc(&self.model_name),
            esc(&self.guid),
            esc(&self.description),
            esc(&self.version),
            env!("CARGO_PKG_VERSION"),
        )
        .unwrap();
        self.write_interfaces3(&mut x);
        self.write_units(&mut x, &["s"]);
        self.write_types3(&mut x);
        self.write_categories_and_experiment(&mut x);
        writeln!(x, "  <ModelVariables>").unwrap();
        writeln!(
            x,
            r#"    <Float64 name="time" valueReference="{FMI3_TIME_VR}" description="Simulation time" causality="independent" variability="continuous" declaredType="s"/>"#
        )
        .unwrap();
        if let Some(c) = &self.sample_clock {
            writeln!(
                x,
                r#"    <Clock name="{}" valueReference="{}" description="{}" causality="input" variability="discrete" intervalVariability="constant" intervalDecimal="{}"/>"#,
                esc(&c.name),
                c.value_reference,
                esc(&c.description),
                super::num(c.interval)
            )
            .unwrap();
        }
        for v in &self.variables {
            self.write_variable3(&mut x, v);
        }
        for a in &self.arrays {
            writeln!(
                x,
                r#"    <Float64 name="{}" valueReference="{}" description="{}" causality="calculatedParameter" variability="fixed" initial="calculated">"#,
                esc(&a.name),
                a.value_reference,
                esc(&a.description)
            )
            .unwrap();
            for d in &a.dimensions {
                writeln!(x, r#"      <Dimension start="{d}"/>"#).unwrap();
            }
            writeln!(x, "    </Float64>").unwrap();
        }
        for i in 0..self.number_of_event_indicators() {
            writeln!(
                x,
                r#"    <Float64 name="event_indicator[{}]" valueReference="{}" description="Event indicator {}: an event where it changes sign" causality="local" variability="continuous" initial="calculated"/>"#,
                i + 1,
                FMI3_EVENT_INDICATOR_VR + i as u32,
                i + 1
            )
            .unwrap();
        }
        writeln!(x, "  </ModelVariables>").unwrap();
        self.write_structure3(&mut x);
        writeln!(x, "</fmiModelDescription>").unwrap();
        x
    }

    /// FMI 3.0's `terminalsAndIcons/terminalsAndIcons.xml` (FMI 3.0.2 §2.4.9), if the model
    /// has terminals: each a `bus` of signals whose members match another FMU's by name.
    pub fn to_terminals_xml(&self) -> Option<String> {
        if self.terminals.is_empty() {
            return None;
        }
        let mut x = String::new();
        writeln!(x, r#"<?xml version="1.0" encoding="UTF-8"?>"#).unwrap();
        writeln!(
            x,
            "<!-- Generated from the variable table in Rust; do not edit. -->"
        )
        .unwrap();
        writeln!(x, r#"<fmiTerminalsAndIcons fmiVersion="3.0">"#).unwrap();
        writeln!(x, "  <Terminals>").unwrap();
        for t in &self.terminals {
            writeln!(
                x,
                r#"    <Terminal name="{}" matchingRule="bus" terminalKind="suspension" description="{}">"#,
                esc(&t.name),
                esc(&t.description)
            )
            .unwrap();
            for (variable, member) in &t.members {
                writeln!(
                    x,
                    r#"      <TerminalMemberVariable variableName="{}" memberName="{}" variableKind="signal"/>"#,
                    esc(variable),
                    esc(member)
                )
                .unwrap();
            }
            writeln!(x, "    </Terminal>").unwrap();
        }
        writeln!(x, "  </Terminals>").unwrap();
        writeln!(x, "</fmiTerminalsAndIcons>").unwrap();
        Some(x)
    }

    /// The value reference of the variable named `name` (checked to exist).
    fn vr_of(&self, name: &str) -> u32 {
        self.variable(name).expect("checked").value_reference
    }

    /// `<ModelExchange>` where the model has it, and `<CoSimulation>`: exact steps to any
    /// communication point, no early return, no intermediate update, and Event Mode for a model
    /// its clock ticks.
    fn write_interfaces3(&self, x: &mut String) {
        let c = &self.capabilities;
        let common = format!(
            r#"modelIdentifier="{}" needsExecutionTool="false" canBeInstantiatedOnlyOncePerProcess="false" canGetAndSetFMUState="{}" canSerializeFMUState="{}" providesDirectionalDerivatives="{}" providesAdjointDerivatives="false" providesPerElementDependencies="false""#,
            esc(&self.model_identifier),
            flag(c.can_get_and_set_fmu_state),
            flag(c.can_serialize_fmu_state),
            flag(c.provides_directional_derivative)
        );
        if let Some(me) = &self.model_exchange {
            writeln!(
                x,
                r#"  <ModelExchange {common} needsCompletedIntegratorStep="{}" providesEvaluateDiscreteStates="false"/>"#,
                flag(!me.completed_integrator_step_not_needed)
            )
            .unwrap();
        }
        writeln!(
            x,
            r#"  <CoSimulation {common} canHandleVariableCommunicationStepSize="{}" maxOutputDerivativeOrder="{}" providesIntermediateUpdate="false" mightReturnEarlyFromDoStep="false" canReturnEarlyAfterIntermediateUpdate="false" hasEventMode="{}" providesEvaluateDiscreteStates="false"/>"#,
            flag(c.can_handle_variable_communication_step_size),
            c.max_output_derivative_order,
            flag(self.sample_clock.is_some())
        )
        .unwrap();
    }

    /// `<TypeDefinitions>`: one `Float64Type` per unit, named after it, which each variable of
    /// that unit declares (`declaredType`). FMI 3.0 takes `unit` on the variable too; the
    /// declared type is the form every importer parses (the `fmi` crate's strict schema rejects
    /// the variable's own `unit`, and so its import of the FMU).
    fn write_types3(&self, x: &mut String) {
        writeln!(x, "  <TypeDefinitions>").unwrap();
        for u in self.units(&["s"]) {
            writeln!(x, r#"    <Float64Type name="{0}" unit="{0}"/>"#, esc(u)).unwrap();
        }
        writeln!(x, "  </TypeDefinitions>").unwrap();
    }

    /// One typed variable. With a sample clock every output is a discrete variable of it.
    fn write_variable3(&self, x: &mut String, v: &Variable) {
        let (causality, mut variability, initial) = v.attributes();
        let mut clocks = String::new();
        if let Some(c) = self.clock_of(v) {
            variability = "discrete";
            clocks = format!(r#" clocks="{}""#, c.value_reference);
        }
        let tag = match v.kind.base() {
            BaseType::Real => "Float64",
            BaseType::Integer => "Int32",
            BaseType::Boolean => "Boolean",
        };
        let mut attrs = String::new();
        match &v.kind {
            VarType::Real {
                unit,
                start,
                min,
                max,
            } => {
                let derivative = v.derivative_of.as_ref().map(|s| self.vr_of(s) as usize);
                attrs = real_attributes("declaredType", unit, [min, max, start], derivative);
            }
            VarType::Integer { start } => {
                if let Some(s) = start {
                    write!(attrs, r#" start="{s}""#).unwrap();
                }
            }
            VarType::Boolean { start } => {
                if let Some(s) = start {
                    write!(attrs, r#" start="{}""#, flag(*s)).unwrap();
                }
            }
        }
        writeln!(
            x,
            r#"    <{tag} name="{}" valueReference="{}" description="{}" causality="{causality}" variability="{variability}"{clocks}{initial}{attrs}/>"#,
            esc(&v.name),
            v.value_reference,
            esc(&v.description)
        )
        .unwrap();
    }

    /// The clock `v` is a variable of: the sample clock for an output.
    fn clock_of(&self, v: &Variable) -> Option<&SampleClock> {
        self.sample_clock
            .as_ref()
            .filter(|_| v.causality == Causality::Output)
    }

    /// `<ModelStructure>` as FMI 2.0's, by value reference: the outputs, the continuous-state
    /// derivatives and the initial unknowns with their dependencies, then the event indicators
    /// (no dependencies given: on every known).
    fn write_structure3(&self, x: &mut String) {
        let element = |x: &mut String, tag: &str, v: &Variable, deps| {
            let (refs, kinds) = dependency_lists(deps);
            writeln!(
                x,
                r#"    <{tag} valueReference="{}" dependencies="{refs}" dependenciesKind="{kinds}"/>"#,
                v.value_reference,
            )
            .unwrap();
        };
        let own = |v: &Variable| -> Vec<(usize, DependencyKind)> {
            v.depends_on
                .iter()
                .map(|(d, k)| (self.vr_of(d) as usize, *k))
                .collect()
        };
        writeln!(x, "  <ModelStructure>").unwrap();
        for v in self
            .variables
            .iter()
            .filter(|v| v.causality == Causality::Output)
        {
            element(x, "Output", v, own(v));
        }
        for v in self.variables.iter().filter(|v| v.derivative_of.is_some()) {
            element(x, "ContinuousStateDerivative", v, own(v));
        }
        for v in self
            .variables
            .iter()
            // A clocked variable has no value before its clock's first tick to compute.
            .filter(|v| Self::is_initial_unknown(v) && self.clock_of(v).is_none())
        {
            let deps = self
                .initial_dependencies(v)
                .map(|d| (self.vr_of(d) as usize, DependencyKind::Dependent))
                .collect();
            element(x, "InitialUnknown", v, deps);
        }
        // The arrays, computed from the resources: on nothing.
        for a in &self.arrays {
            writeln!(
                x,
                r#"    <InitialUnknown valueReference="{}" dependencies="" dependenciesKind=""/>"#,
                a.value_reference
            )
            .unwrap();
        }
        for i in 0..self.number_of_event_indicators() {
            writeln!(
                x,
                r#"    <EventIndicator valueReference="{}"/>"#,
                FMI3_EVENT_INDICATOR_VR + i as u32
            )
            .unwrap();
        }
        writeln!(x, "  </ModelStructure>").unwrap();
    }
}
