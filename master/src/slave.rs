//! One FMU of either FMI version as the master uses it, on the `fmi` crate: its variables by
//! name (value reference, causality, type, start, unit) and a Co-Simulation instance that is
//! set, read and stepped. The version is read from the archive's `modelDescription.xml`
//! (`fmiVersion`), so `--dist dist/fmi3` runs the FMI 3.0 FMUs through the same loop.

use fmi::fmi2::import::Fmi2Import;
use fmi::fmi2::instance::{CoSimulation as _, Common as _, Instance};
use fmi::fmi2::schema::ScalarVariableElement;
use fmi::fmi3::import::Fmi3Import;
use fmi::fmi3::instance::InstanceCS;
use fmi::fmi3::schema::{AbstractVariableTrait, Variable};
use fmi::fmi3::{CoSimulation as _, Common as _, Fmi3Model as _, GetSet as _};
use fmi::traits::FmiImport;
use fmi::CS;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// A variable's type, as far as the master reads and sets it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    Real,
    Integer,
    Boolean,
    Other,
}

/// One variable of the model description.
#[derive(Debug, Clone)]
pub struct Var {
    pub name: String,
    pub vr: u32,
    /// As the XML spells it, lower-cased (`parameter`, `input`, `output`, …).
    pub causality: String,
    pub kind: Kind,
    /// A Real's start value.
    pub start: Option<f64>,
    /// A Real's unit ("" for none).
    pub unit: String,
}

/// An imported FMU of either version.
pub enum Import {
    Fmi2(Fmi2Import),
    Fmi3(Fmi3Import),
}

impl Import {
    pub fn load(path: &Path) -> Result<Import, String> {
        let peek = fmi::import::peek_descr_path(path).map_err(|e| e.to_string())?;
        Ok(match peek.fmi_version.as_str() {
            "2.0" => Import::Fmi2(fmi::import::from_path(path).map_err(|e| e.to_string())?),
            v if v.starts_with("3.") => {
                Import::Fmi3(fmi::import::from_path(path).map_err(|e| e.to_string())?)
            }
            v => return Err(format!("fmiVersion {v}: the master runs FMI 2.0 and 3.0")),
        })
    }

    /// 2 or 3.
    pub fn version(&self) -> u8 {
        match self {
            Import::Fmi2(_) => 2,
            Import::Fmi3(_) => 3,
        }
    }

    pub fn resource_path(&self) -> PathBuf {
        match self {
            Import::Fmi2(i) => i.resource_path(),
            Import::Fmi3(i) => i.resource_path(),
        }
    }

    fn archive_path(&self) -> &Path {
        match self {
            Import::Fmi2(i) => i.archive_path(),
            Import::Fmi3(i) => i.archive_path(),
        }
    }

    /// Every variable, in the order of the description. The `fmi` crate does not read a
    /// variable's unit, so the XML is read for it ([`units`]).
    pub fn variables(&self) -> Result<Vec<Var>, String> {
        let xml = self.archive_path().join("modelDescription.xml");
        let text = std::fs::read_to_string(&xml).map_err(|e| format!("{}: {e}", xml.display()))?;
        let units = units(&text).map_err(|e| format!("{}: {e}", xml.display()))?;
        let unit = |name: &str| units.get(name).cloned().unwrap_or_default();
        Ok(match self {
            Import::Fmi2(i) => i
                .model_description()
                .model_variables
                .variables
                .iter()
                .map(|v| {
                    let (kind, start) = match &v.elem {
                        ScalarVariableElement::Real(r) => (Kind::Real, r.start),
                        ScalarVariableElement::Integer(_) => (Kind::Integer, None),
                        ScalarVariableElement::Boolean(_) => (Kind::Boolean, None),
                        _ => (Kind::Other, None),
                    };
                    Var {
                        name: v.name.clone(),
                        vr: v.value_reference,
                        causality: format!("{:?}", v.causality).to_lowercase(),
                        kind,
                        start,
                        unit: unit(&v.name),
                    }
                })
                .collect(),
            Import::Fmi3(i) => i
                .model_description()
                .model_variables
                .variables
                .iter()
                // A controller's sample clock is not a value the loop exchanges: the master
                // instantiates without Event Mode, where the FMU is sampled at every step.
                .filter(|v| !matches!(v, Variable::Clock(_)))
                .map(|v| {
                    let (kind, start) = match v {
                        Variable::Float64(f) => (
                            Kind::Real,
                            f.start.as_ref().and_then(|s| s.0.first().copied()),
                        ),
                        Variable::Int32(_) => (Kind::Integer, None),
                        Variable::Boolean(_) => (Kind::Boolean, None),
                        _ => (Kind::Other, None),
                    };
                    let a = abstract_variable(v);
                    Var {
                        name: a.name().to_string(),
                        vr: a.value_reference(),
                        causality: format!("{:?}", a.causality()).to_lowercase(),
                        kind,
                        start,
                        unit: unit(a.name()),
                    }
                })
                .collect(),
        })
    }

    /// An instance for Co-Simulation, not yet initialised.
    pub fn instantiate(&self, name: &str) -> Result<Slave, String> {
        Ok(match self {
            Import::Fmi2(i) => Slave::Fmi2(
                i.instantiate_cs(name, false, false)
                    .map_err(|e| e.to_string())?,
            ),
            Import::Fmi3(i) => Slave::Fmi3(
                i.instantiate_cs(name, false, false, false, false, &[])
                    .map_err(|e| e.to_string())?,
            ),
        })
    }
}

/// The abstract view of an FMI 3.0 variable of any type.
fn abstract_variable(v: &Variable) -> &dyn AbstractVariableTrait {
    match v {
        Variable::Int8(x) => x,
        Variable::UInt8(x) => x,
        Variable::Int16(x) => x,
        Variable::UInt16(x) => x,
        Variable::Int32(x) => x,
        Variable::UInt32(x) => x,
        Variable::Int64(x) => x,
        Variable::UInt64(x) => x,
        Variable::Float32(x) => x,
        Variable::Float64(x) => x,
        Variable::Boolean(x) => x,
        Variable::String(x) => x,
        Variable::Binary(x) => x,
        Variable::Clock(x) => x,
    }
}

/// The unit of each Real variable that declares one, by name: FMI 2.0's `<Real unit=…>`, FMI
/// 3.0's `<Float64 unit=…>` or its `declaredType`'s `<Float64Type unit=…>`. Read with the
/// tokenizer the `fmi` crate's parser is built on.
pub fn units(xml: &str) -> Result<BTreeMap<String, String>, String> {
    use xmlparser::{ElementEnd, Token, Tokenizer};
    let mut units = BTreeMap::new();
    let mut declared: Vec<(String, String)> = Vec::new();
    let mut types: BTreeMap<String, String> = BTreeMap::new();
    let (mut element, mut variable, mut type_name) =
        (String::new(), None::<String>, None::<String>);
    for token in Tokenizer::from(xml) {
        match token.map_err(|e| e.to_string())? {
            Token::ElementStart { local, .. } => {
                element = local.to_string();
                if element == "Float64" {
                    variable = None;
                }
            }
            Token::Attribute { local, value, .. } => match (element.as_str(), local.as_str()) {
                ("ScalarVariable" | "Float64", "name") => variable = Some(value.to_string()),
                ("Real" | "Float64", "unit") => {
                    if let Some(v) = &variable {
                        units.insert(v.clone(), value.to_string());
                    }
                }
                ("Float64", "declaredType") => {
                    if let Some(v) = &variable {
                        declared.push((v.clone(), value.to_string()));
                    }
                }
                ("Float64Type", "name") => type_name = Some(value.to_string()),
                ("Float64Type", "unit") => {
                    if let Some(t) = &type_name {
                        types.insert(t.clone(), value.to_string());
                    }
                }
                _ => {}
            },
            Token::ElementEnd {
                end: ElementEnd::Close(_, local),
                ..
            } if local.as_str() == "ScalarVariable" => variable = None,
            _ => {}
        }
    }
    for (v, t) in declared {
        if let (Some(u), false) = (types.get(&t), units.contains_key(&v)) {
            units.insert(v, u.clone());
        }
    }
    Ok(units)
}

/// A Co-Simulation instance of either version. Every call answers `Err` with the `fmi` crate's
/// description of the failure. (Its variants differ in size; a run holds three, made once and
/// never moved in the loop, so boxing would only add an indirection to every call.)
#[allow(clippy::large_enum_variant)]
pub enum Slave {
    Fmi2(Instance<CS>),
    Fmi3(InstanceCS),
}

impl Slave {
    /// `fmi2SetupExperiment` and the initialisation, or `fmi3EnterInitializationMode` and its
    /// exit, at t = 0; `Err` names the step that failed.
    pub fn initialise(&mut self) -> Result<(), String> {
        match self {
            Slave::Fmi2(i) => {
                i.setup_experiment(None, 0.0, None)
                    .map_err(|e| e.to_string())?;
                fmi::fmi2::instance::Common::enter_initialization_mode(i)
                    .map_err(|e| e.to_string())?;
                fmi::fmi2::instance::Common::exit_initialization_mode(i)
                    .map_err(|e| format!("initialisation failed ({e})"))?;
            }
            Slave::Fmi3(i) => {
                i.enter_initialization_mode(None, 0.0, None)
                    .map_err(|e| e.to_string())?;
                i.exit_initialization_mode()
                    .map_err(|e| format!("initialisation failed ({e})"))?;
            }
        }
        Ok(())
    }

    #[inline]
    pub fn get_real(&mut self, vrs: &[u32], values: &mut [f64]) -> Result<(), String> {
        match self {
            Slave::Fmi2(i) => i
                .get_real(vrs, values)
                .map(|_| ())
                .map_err(|e| e.to_string()),
            Slave::Fmi3(i) => i
                .get_float64(vrs, values)
                .map(|_| ())
                .map_err(|e| e.to_string()),
        }
    }

    #[inline]
    pub fn set_real(&mut self, vrs: &[u32], values: &[f64]) -> Result<(), String> {
        match self {
            Slave::Fmi2(i) => i
                .set_real(vrs, values)
                .map(|_| ())
                .map_err(|e| e.to_string()),
            Slave::Fmi3(i) => i
                .set_float64(vrs, values)
                .map(|_| ())
                .map_err(|e| e.to_string()),
        }
    }

    pub fn set_integer(&mut self, vrs: &[u32], values: &[i32]) -> Result<(), String> {
        match self {
            Slave::Fmi2(i) => i
                .set_integer(vrs, values)
                .map(|_| ())
                .map_err(|e| e.to_string()),
            Slave::Fmi3(i) => i
                .set_int32(vrs, values)
                .map(|_| ())
                .map_err(|e| e.to_string()),
        }
    }

    pub fn set_boolean(&mut self, vrs: &[u32], values: &[bool]) -> Result<(), String> {
        match self {
            Slave::Fmi2(i) => {
                let ints: Vec<i32> = values.iter().map(|b| *b as i32).collect();
                i.set_boolean(vrs, &ints)
                    .map(|_| ())
                    .map_err(|e| e.to_string())
            }
            Slave::Fmi3(i) => i
                .set_boolean(vrs, values)
                .map(|_| ())
                .map_err(|e| e.to_string()),
        }
    }

    /// Booleans as 0 / 1.
    pub fn get_boolean(&mut self, vrs: &[u32], values: &mut [i32]) -> Result<(), String> {
        match self {
            Slave::Fmi2(i) => i
                .get_boolean(vrs, values)
                .map(|_| ())
                .map_err(|e| e.to_string()),
            Slave::Fmi3(i) => {
                let mut b = vec![false; vrs.len()];
                i.get_boolean(vrs, &mut b).map_err(|e| e.to_string())?;
                for (v, b) in values.iter_mut().zip(b) {
                    *v = b as i32;
                }
                Ok(())
            }
        }
    }

    /// A communication step from `t` over `h`; `Err` names the version's function.
    #[inline]
    pub fn do_step(&mut self, t: f64, h: f64) -> Result<(), String> {
        match self {
            Slave::Fmi2(i) => i
                .do_step(t, h, true)
                .map(|_| ())
                .map_err(|e| format!("fmi2DoStep at t = {t}: {e}")),
            Slave::Fmi3(i) => {
                let (mut event, mut terminate, mut early, mut last) = (false, false, false, t);
                i.do_step(
                    t,
                    h,
                    true,
                    &mut event,
                    &mut terminate,
                    &mut early,
                    &mut last,
                )
                .map(|_| ())
                .map_err(|e| format!("fmi3DoStep at t = {t}: {e}"))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// FMI 2.0's unit on `<Real>`, FMI 3.0's on `<Float64>` or through its declared type.
    #[test]
    fn units_are_read_from_either_version() {
        let two = r#"<fmiModelDescription fmiVersion="2.0"><ModelVariables>
            <ScalarVariable name="a"><Real unit="m/s2"/></ScalarVariable>
            <ScalarVariable name="n"><Integer/></ScalarVariable>
            <ScalarVariable name="b"><Real/></ScalarVariable></ModelVariables></fmiModelDescription>"#;
        let u = units(two).unwrap();
        assert_eq!(u.get("a").map(String::as_str), Some("m/s2"));
        assert!(!u.contains_key("b") && !u.contains_key("n"));
        let three = r#"<fmiModelDescription fmiVersion="3.0">
            <TypeDefinitions><Float64Type name="Force" unit="N"/></TypeDefinitions>
            <ModelVariables><Float64 name="f" declaredType="Force"/><Float64 name="x" unit="m"/>
            <Float64 name="y"/><Int32 name="k"/></ModelVariables></fmiModelDescription>"#;
        let u = units(three).unwrap();
        assert_eq!(u.get("f").map(String::as_str), Some("N"));
        assert_eq!(u.get("x").map(String::as_str), Some("m"));
        assert!(!u.contains_key("y") && !u.contains_key("k"));
    }
}
