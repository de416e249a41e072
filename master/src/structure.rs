//! The loop of [`crate::cosim::run`] as system descriptions for other tools, written beside the
//! FMUs: an OSP system structure (libcosim and OSP tools) and an SSP 1.0 archive (`.ssp`:
//! `SystemStructure.ssd` plus the three FMUs under `resources/`) for SSP-capable tools. Both
//! connect road, plant and one controller by name and carry the scenario's parameters as
//! initial values; the communication step is the scenario's.

use crate::cosim::{
    check_connections, err, scenario_parameters, Fmu, MasterError, Order, Scenario, Typed, FORCES,
    MASTER_ORDER, RECORD, ROAD,
};
use std::io::Write;
use std::path::Path;

impl Typed {
    /// `<Real value="…"/>` etc., prefixed by `ns` (e.g. `ssv:`).
    fn xml(&self, ns: &str) -> String {
        match self {
            Typed::Real(v) => format!("<{ns}Real value=\"{v:e}\"/>"),
            Typed::Integer(v) => format!("<{ns}Integer value=\"{v}\"/>"),
            Typed::Boolean(v) => format!("<{ns}Boolean value=\"{v}\"/>"),
        }
    }
}

/// Road, plant and controller with their parameters and connections.
pub struct Loop {
    pub scenario: Scenario,
    /// (FMU name, parameters) for road, plant, controller.
    pub components: Vec<(String, Vec<(String, Typed)>)>,
    /// (from, to, variable): every connection, by name.
    pub connections: Vec<(String, String, String)>,
    /// The controller's inputs (plant outputs it reads).
    pub measured: Vec<String>,
    pub controller: String,
    /// The controller has a parameter `master_order` (a predictor) the scenario does not set.
    pub told_the_order: bool,
}

impl Loop {
    /// The loop of `scenario` with `controller`, checked against the FMUs in `dist`.
    pub fn new(dist: &Path, scenario: &Scenario, controller: &str) -> Result<Loop, MasterError> {
        if controller.ends_with(".fmu") {
            return Err(err(format!(
                "a system structure names its FMUs beside it: give the controller by its name in \
                 --dist, not as the path {controller}"
            )));
        }
        let road = Fmu::load(dist, "road")?;
        let plant = Fmu::load(dist, "plant")?;
        let ctrl = Fmu::load(dist, controller)?;
        check_connections(&plant, &ctrl)?;
        let measured = ctrl.names_with_causality("input");
        let [road_values, plant_values, ctrl_values] =
            scenario_parameters(scenario, &road, &plant, Some(&ctrl))?;
        let told_the_order =
            ctrl.has(MASTER_ORDER) && !ctrl_values.iter().any(|(n, _)| n == MASTER_ORDER);
        let mut connections = Vec::new();
        connections.extend(
            ROAD.iter()
                .map(|n| ("road".to_string(), "plant".to_string(), n.to_string())),
        );
        connections.extend(
            measured
                .iter()
                .map(|n| ("plant".to_string(), controller.to_string(), n.clone())),
        );
        connections.extend(
            FORCES
                .iter()
                .map(|n| (controller.to_string(), "plant".to_string(), n.to_string())),
        );
        Ok(Loop {
            scenario: scenario.clone(),
            components: vec![
                ("road".into(), road_values),
                ("plant".into(), plant_values),
                (controller.into(), ctrl_values),
            ],
            connections,
            measured,
            controller: controller.into(),
            told_the_order,
        })
    }

    /// `OspSystemStructure.xml`. libcosim's fixed-step algorithm exchanges the values of all
    /// simulators after each step (Jacobi), not in the master's Gauss-Seidel order: a
    /// controller with a parameter `master_order` (a predictor) is told so (1), unless the
    /// scenario sets it.
    pub fn osp(&self) -> String {
        let h = self.scenario.step;
        let mut x = format!("<?xml version=\"1.0\" encoding=\"utf-8\"?>\n<!-- {}: written by `master osp` from scenario '{}' -->\n<OspSystemStructure xmlns=\"http://opensimulationplatform.com/MSMI/OSPSystemStructure\" version=\"0.1\">\n  <StartTime>0.0</StartTime>\n  <BaseStepSize>{h:e}</BaseStepSize>\n  <Algorithm>fixedStep</Algorithm>\n  <Simulators>\n", self.controller, self.scenario.name);
        for (name, values) in &self.components {
            x += &format!("    <Simulator name=\"{name}\" source=\"{name}.fmu\" stepSize=\"{h:e}\">\n      <InitialValues>\n");
            let jacobi = (name == &self.controller && self.told_the_order).then(|| {
                (
                    MASTER_ORDER.to_string(),
                    Typed::Integer(Order::Jacobi.code()),
                )
            });
            for (k, v) in values.iter().chain(jacobi.as_ref()) {
                x += &format!(
                    "        <InitialValue variable=\"{k}\">{}</InitialValue>\n",
                    v.xml("")
                );
            }
            x += "      </InitialValues>\n    </Simulator>\n";
        }
        x += "  </Simulators>\n  <Connections>\n";
        for (from, to, name) in &self.connections {
            x += &format!("    <VariableConnection>\n      <Variable simulator=\"{from}\" name=\"{name}\"/>\n      <Variable simulator=\"{to}\" name=\"{name}\"/>\n    </VariableConnection>\n");
        }
        x += "  </Connections>\n</OspSystemStructure>\n";
        x
    }

    /// `SystemStructure.ssd` (SSP 1.0): components `resources/<name>.fmu`, their connectors
    /// (connected variables, and the plant outputs the master records), the scenario's
    /// parameters as inline parameter sets, the duration as default experiment and the
    /// communication step and stepping order as an annotation.
    pub fn ssd(&self) -> String {
        let s = &self.scenario;
        let mut x = format!(
            "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<!-- {}: written by `master ssp` from scenario '{}' -->\n<ssd:SystemStructureDescription xmlns:ssd=\"http://ssp-standard.org/SSP1/SystemStructureDescription\" xmlns:ssc=\"http://ssp-standard.org/SSP1/SystemStructureCommon\" xmlns:ssv=\"http://ssp-standard.org/SSP1/SystemStructureParameterValues\" version=\"1.0\" name=\"{}_{}\">\n  <ssd:System name=\"car\" description=\"{}\">\n    <ssd:Elements>\n",
            self.controller, s.name, s.name, self.controller, xml_escape(&format!("Road, 8-DOF car with seat and {} (scenario {}: {})", self.controller, s.name, s.description))
        );
        for (name, values) in &self.components {
            x += &format!("      <ssd:Component name=\"{name}\" source=\"resources/{name}.fmu\" type=\"application/x-fmu-sharedlibrary\">\n        <ssd:Connectors>\n");
            for (n, kind) in self.connectors(name) {
                x += &format!("          <ssd:Connector name=\"{n}\" kind=\"{kind}\"><ssc:Real/></ssd:Connector>\n");
            }
            x += "        </ssd:Connectors>\n";
            if !values.is_empty() {
                x += &format!("        <ssd:ParameterBindings>\n          <ssd:ParameterBinding>\n            <ssd:ParameterValues>\n              <ssv:ParameterSet version=\"1.0\" name=\"{}\">\n                <ssv:Parameters>\n", s.name);
                for (k, v) in values {
                    x += &format!(
                        "                  <ssv:Parameter name=\"{k}\">{}</ssv:Parameter>\n",
                        v.xml("ssv:")
                    );
                }
                x += "                </ssv:Parameters>\n              </ssv:ParameterSet>\n            </ssd:ParameterValues>\n          </ssd:ParameterBinding>\n        </ssd:ParameterBindings>\n";
            }
            x += "      </ssd:Component>\n";
        }
        x += "    </ssd:Elements>\n    <ssd:Connections>\n";
        for (from, to, name) in &self.connections {
            x += &format!("      <ssd:Connection startElement=\"{from}\" startConnector=\"{name}\" endElement=\"{to}\" endConnector=\"{name}\"/>\n");
        }
        x += &format!(
            "    </ssd:Connections>\n  </ssd:System>\n  <ssd:DefaultExperiment startTime=\"0\" stopTime=\"{:e}\">\n    <ssd:Annotations>\n      <ssc:Annotation type=\"org.suspension-hinf.master\">\n        <master:Stepping xmlns:master=\"urn:suspension-hinf:master\" communicationStepSize=\"{:e}\" order=\"road plant {}\" algorithm=\"Gauss-Seidel\"/>\n      </ssc:Annotation>\n    </ssd:Annotations>\n  </ssd:DefaultExperiment>\n</ssd:SystemStructureDescription>\n",
            s.duration, s.step, self.controller
        );
        x
    }

    /// (variable, kind) of the connectors of component `name`.
    fn connectors(&self, name: &str) -> Vec<(String, &'static str)> {
        let mut out: Vec<(String, &'static str)> = Vec::new();
        for (from, to, n) in &self.connections {
            let kind = if from == name {
                "output"
            } else if to == name {
                "input"
            } else {
                continue;
            };
            if !out.iter().any(|(m, _)| m == n) {
                out.push((n.clone(), kind));
            }
        }
        if name == "plant" {
            for n in RECORD {
                if !out.iter().any(|(m, _)| m == n) {
                    out.push((n.to_string(), "output"));
                }
            }
        }
        out
    }

    /// The `.ssp` archive: `SystemStructure.ssd` and the FMUs of `dist` under `resources/`.
    pub fn write_ssp(&self, dist: &Path, out: &Path) -> Result<(), MasterError> {
        let io = |e: &dyn std::fmt::Display| err(format!("cannot write {}: {e}", out.display()));
        let file = std::fs::File::create(out).map_err(|e| io(&e))?;
        let mut zip = zip::ZipWriter::new(file);
        let options = zip::write::SimpleFileOptions::default()
            .compression_method(zip::CompressionMethod::Deflated);
        zip.start_file("SystemStructure.ssd", options)
            .map_err(|e| io(&e))?;
        zip.write_all(self.ssd().as_bytes()).map_err(|e| io(&e))?;
        for (name, _) in &self.components {
            let bytes = std::fs::read(dist.join(format!("{name}.fmu")))
                .map_err(|e| err(format!("cannot read {name}.fmu: {e}")))?;
            // FMUs are zip archives already: store them as they are.
            zip.start_file(
                format!("resources/{name}.fmu"),
                zip::write::SimpleFileOptions::default()
                    .compression_method(zip::CompressionMethod::Stored),
            )
            .map_err(|e| io(&e))?;
            zip.write_all(&bytes).map_err(|e| io(&e))?;
        }
        zip.finish().map_err(|e| io(&e))?;
        Ok(())
    }
}

fn xml_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}
