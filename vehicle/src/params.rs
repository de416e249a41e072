//! Vehicle parameters (SPEC.md §1, thesis Table 3.1 with its repairs).
//!
//! The defaults live in `params/default.json`, where every value carries its unit and its
//! source; each repair of the thesis table says why there. [`PARAMETERS`] is the one table of
//! names, units, descriptions and admissible ranges: the plant FMU derives its parameter
//! variables from it, the JSON loader checks against it.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// The documented default parameter file, compiled in.
pub const DEFAULT_PARAMETER_FILE: &str = include_str!("../params/default.json");

/// Physical parameters of the full car with driver seat, SI units.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VehicleParams {
    /// Sprung (body) mass \[kg\].
    pub m_s: f64,
    /// Unsprung mass of each wheel \[kg\].
    pub m_u: f64,
    /// Roll moment of inertia of the body [kg·m²].
    #[serde(rename = "I_x")]
    pub i_x: f64,
    /// Pitch moment of inertia of the body [kg·m²].
    #[serde(rename = "I_y")]
    pub i_y: f64,
    /// Front suspension stiffness [N/m].
    pub k_s_f: f64,
    /// Rear suspension stiffness [N/m].
    pub k_s_r: f64,
    /// Front suspension damping [N·s/m].
    pub c_s_f: f64,
    /// Rear suspension damping [N·s/m].
    pub c_s_r: f64,
    /// Tyre stiffness [N/m].
    pub k_t: f64,
    /// Tyre damping [N·s/m].
    pub c_t: f64,
    /// Distance from the body COG to the rear axle \[m\].
    #[serde(rename = "L1")]
    pub l1: f64,
    /// Distance from the body COG to the front axle \[m\].
    #[serde(rename = "L2")]
    pub l2: f64,
    /// Distance from the body COG to the left wheels \[m\].
    pub w1: f64,
    /// Distance from the body COG to the right wheels \[m\].
    pub w2: f64,
    /// Lateral offset of the seat, to the right of the COG \[m\] (roll lever −s1).
    pub s1: f64,
    /// Longitudinal offset of the seat, ahead of the COG \[m\] (pitch lever +s2).
    pub s2: f64,
    /// Seat plus driver mass \[kg\].
    pub m_seat: f64,
    /// Seat stiffness [N/m].
    pub k_seat: f64,
    /// Seat damping [N·s/m].
    pub c_seat: f64,
    /// Gravitational acceleration [m/s²], used for the static equilibrium only.
    pub g: f64,
}

/// The closed interval of values a parameter admits: its physically plausible range.
///
/// Wide enough for any road vehicle from a small robot to a loaded truck, narrow enough that
/// every admitted car has a positive definite stiffness matrix, finite static equilibrium and
/// a matrix exponential that converges: a tyre of 1e-12 N/m or an inertia of 1e-40 kg·m² is a
/// typing error, and is refused with the parameter's name instead of failing deep inside.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Admissible {
    pub min: f64,
    pub max: f64,
}

impl Admissible {
    /// `Ok(())` if `value` is admissible, else a sentence saying what was expected.
    pub fn check(self, value: f64) -> Result<(), String> {
        if value.is_finite() && self.min <= value && value <= self.max {
            Ok(())
        } else {
            Err(format!("a number in [{:e}, {:e}]", self.min, self.max))
        }
    }
}

/// Name, unit, meaning and admissible range of one parameter, with its accessors.
pub struct ParamSpec {
    pub name: &'static str,
    /// Unit in FMI / SI notation (`N.s/m`, `kg.m2`).
    pub unit: &'static str,
    pub description: &'static str,
    pub admissible: Admissible,
    pub get: fn(&VehicleParams) -> f64,
    pub set: fn(&mut VehicleParams, f64),
}

macro_rules! param {
    ($name:literal, $field:ident, $unit:literal, [$min:expr, $max:expr], $desc:literal) => {
        ParamSpec {
            name: $name,
            unit: $unit,
            description: $desc,
            admissible: Admissible {
                min: $min,
                max: $max,
            },
            get: |p| p.$field,
            set: |p, v| p.$field = v,
        }
    };
}

/// Every physical parameter, in the order of the parameter file.
pub const PARAMETERS: &[ParamSpec] = &[
    param!("m_s", m_s, "kg", [1.0, 1e5], "Sprung (body) mass"),
    param!("m_u", m_u, "kg", [0.1, 1e4], "Unsprung mass of each wheel"),
    param!(
        "I_x",
        i_x,
        "kg.m2",
        [0.01, 1e7],
        "Roll moment of inertia of the body"
    ),
    param!(
        "I_y",
        i_y,
        "kg.m2",
        [0.01, 1e7],
        "Pitch moment of inertia of the body"
    ),
    param!(
        "k_s_f",
        k_s_f,
        "N/m",
        [100.0, 1e8],
        "Front suspension stiffness"
    ),
    param!(
        "k_s_r",
        k_s_r,
        "N/m",
        [100.0, 1e8],
        "Rear suspension stiffness"
    ),
    param!(
        "c_s_f",
        c_s_f,
        "N.s/m",
        [0.0, 1e6],
        "Front suspension damping"
    ),
    param!(
        "c_s_r",
        c_s_r,
        "N.s/m",
        [0.0, 1e6],
        "Rear suspension damping"
    ),
    param!("k_t", k_t, "N/m", [1e3, 1e8], "Tyre stiffness"),
    param!("c_t", c_t, "N.s/m", [0.0, 1e6], "Tyre damping"),
    param!(
        "L1",
        l1,
        "m",
        [0.05, 20.0],
        "Distance from the body COG to the rear axle"
    ),
    param!(
        "L2",
        l2,
        "m",
        [0.05, 20.0],
        "Distance from the body COG to the front axle"
    ),
    param!(
        "w1",
        w1,
        "m",
        [0.05, 5.0],
        "Distance from the body COG to the left wheels"
    ),
    param!(
        "w2",
        w2,
        "m",
        [0.05, 5.0],
        "Distance from the body COG to the right wheels"
    ),
    param!(
        "s1",
        s1,
        "m",
        [-5.0, 5.0],
        "Lateral seat offset to the right of the COG"
    ),
    param!(
        "s2",
        s2,
        "m",
        [-10.0, 10.0],
        "Longitudinal seat offset ahead of the COG"
    ),
    param!("m_seat", m_seat, "kg", [1.0, 1e4], "Seat plus driver mass"),
    param!("k_seat", k_seat, "N/m", [100.0, 1e8], "Seat stiffness"),
    param!("c_seat", c_seat, "N.s/m", [0.0, 1e6], "Seat damping"),
    param!(
        "g",
        g,
        "m/s2",
        [0.0, 100.0],
        "Gravitational acceleration (static equilibrium)"
    ),
];

/// Why a parameter set or parameter file was rejected.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ParamError {
    #[error("parameter file is not valid JSON of the expected shape: {0}")]
    Syntax(String),
    #[error("unknown parameter '{0}'")]
    Unknown(String),
    #[error("parameter '{0}' is missing")]
    Missing(&'static str),
    #[error("parameter '{name}' has unit '{found}', expected '{expected}'")]
    Unit {
        name: String,
        expected: &'static str,
        found: String,
    },
    #[error("parameter '{name}' must be {expected}, got {value}")]
    Value {
        name: &'static str,
        expected: String,
        value: f64,
    },
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ParameterFile {
    #[allow(dead_code)]
    description: Option<String>,
    parameters: BTreeMap<String, ParameterEntry>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ParameterEntry {
    value: f64,
    unit: String,
    #[allow(dead_code)]
    source: Option<String>,
}

impl Default for VehicleParams {
    /// The documented defaults of `params/default.json`.
    fn default() -> Self {
        Self::from_parameter_file(DEFAULT_PARAMETER_FILE)
            .expect("the compiled-in default parameter file is valid (tested)")
    }
}

impl VehicleParams {
    /// Parse a documented parameter file (`{"parameters": {"m_s": {"value", "unit", "source"}}}`).
    /// Every parameter must be present with the expected unit and an admissible value.
    pub fn from_parameter_file(json: &str) -> Result<Self, ParamError> {
        let file: ParameterFile =
            serde_json::from_str(json).map_err(|e| ParamError::Syntax(e.to_string()))?;
        if let Some(unknown) = file.parameters.keys().find(|k| spec(k).is_none()) {
            return Err(ParamError::Unknown(unknown.clone()));
        }
        let mut params = Self::zeroed();
        for spec in PARAMETERS {
            let entry = file
                .parameters
                .get(spec.name)
                .ok_or(ParamError::Missing(spec.name))?;
            if entry.unit != spec.unit {
                return Err(ParamError::Unit {
                    name: spec.name.to_string(),
                    expected: spec.unit,
                    found: entry.unit.clone(),
                });
            }
            (spec.set)(&mut params, entry.value);
        }
        params.validate()?;
        Ok(params)
    }

    /// Apply a flat JSON object of overrides (`{"m_s": 1800, "c_t": 0}`) to these parameters.
    /// Unknown names and inadmissible values are rejected and leave `self` unchanged.
    pub fn with_overrides(&self, json: &str) -> Result<Self, ParamError> {
        let overrides: BTreeMap<String, f64> =
            serde_json::from_str(json).map_err(|e| ParamError::Syntax(e.to_string()))?;
        let mut params = *self;
        for (name, value) in overrides {
            params.set(&name, value)?;
        }
        params.validate()?;
        Ok(params)
    }

    /// Set one parameter by name, checking that the value is admissible.
    pub fn set(&mut self, name: &str, value: f64) -> Result<(), ParamError> {
        let spec = spec(name).ok_or_else(|| ParamError::Unknown(name.to_string()))?;
        check(spec, value)?;
        (spec.set)(self, value);
        Ok(())
    }

    /// Get one parameter by name.
    pub fn get(&self, name: &str) -> Option<f64> {
        spec(name).map(|s| (s.get)(self))
    }

    /// Check every parameter against its admissible range.
    pub fn validate(&self) -> Result<(), ParamError> {
        PARAMETERS
            .iter()
            .try_for_each(|spec| check(spec, (spec.get)(self)))
    }

    /// Wheelbase `L1 + L2` \[m\].
    pub fn wheelbase(&self) -> f64 {
        self.l1 + self.l2
    }

    fn zeroed() -> Self {
        VehicleParams {
            m_s: 0.0,
            m_u: 0.0,
            i_x: 0.0,
            i_y: 0.0,
            k_s_f: 0.0,
            k_s_r: 0.0,
            c_s_f: 0.0,
            c_s_r: 0.0,
            k_t: 0.0,
            c_t: 0.0,
            l1: 0.0,
            l2: 0.0,
            w1: 0.0,
            w2: 0.0,
            s1: 0.0,
            s2: 0.0,
            m_seat: 0.0,
            k_seat: 0.0,
            c_seat: 0.0,
            g: 0.0,
        }
    }
}

fn spec(name: &str) -> Option<&'static ParamSpec> {
    PARAMETERS.iter().find(|s| s.name == name)
}

fn check(spec: &ParamSpec, value: f64) -> Result<(), ParamError> {
    spec.admissible
        .check(value)
        .map_err(|expected| ParamError::Value {
            name: spec.name,
            expected,
            value,
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_file_parses_with_spec_values_and_repairs() {
        let p = VehicleParams::default();
        assert_eq!(p.m_s, 1500.0);
        assert_eq!(p.w1, 0.71, "w1 repaired to a symmetric track");
        assert_eq!(p.m_seat, 90.0, "m_seat repaired");
        assert_eq!(p.k_seat, 15000.0, "k_seat repaired");
        assert_eq!(p.c_t, 100.0, "c_t added");
        assert_eq!(p.wheelbase(), 2.4);
    }

    #[test]
    fn every_parameter_has_a_documented_source_in_the_default_file() {
        let raw: serde_json::Value = serde_json::from_str(DEFAULT_PARAMETER_FILE).unwrap();
        for spec in PARAMETERS {
            let source = raw["parameters"][spec.name]["source"]
                .as_str()
                .unwrap_or("");
            assert!(!source.is_empty(), "{} has no source", spec.name);
        }
    }

    #[test]
    fn negative_mass_and_zero_stiffness_are_rejected_with_their_name() {
        let bad = DEFAULT_PARAMETER_FILE.replace("\"value\": 1500.0", "\"value\": -1500.0");
        let err = VehicleParams::from_parameter_file(&bad).unwrap_err();
        assert_eq!(
            err,
            ParamError::Value {
                name: "m_s",
                expected: "a number in [1e0, 1e5]".into(),
                value: -1500.0
            }
        );
        let bad = DEFAULT_PARAMETER_FILE.replace("\"value\": 190000.0", "\"value\": 0.0");
        assert!(matches!(
            VehicleParams::from_parameter_file(&bad),
            Err(ParamError::Value { name: "k_t", .. })
        ));
    }

    #[test]
    fn malformed_unknown_missing_and_wrong_unit_files_are_rejected() {
        assert!(matches!(
            VehicleParams::from_parameter_file("{"),
            Err(ParamError::Syntax(_))
        ));
        let unknown = DEFAULT_PARAMETER_FILE.replace("\"m_u\":", "\"m_wheel\":");
        assert_eq!(
            VehicleParams::from_parameter_file(&unknown),
            Err(ParamError::Unknown("m_wheel".into()))
        );
        let wrong_unit = DEFAULT_PARAMETER_FILE.replace("\"unit\": \"kg.m2\"", "\"unit\": \"kg\"");
        assert!(matches!(
            VehicleParams::from_parameter_file(&wrong_unit),
            Err(ParamError::Unit { .. })
        ));
        let missing = r#"{"parameters": {"m_s": {"value": 1500.0, "unit": "kg"}}}"#;
        assert_eq!(
            VehicleParams::from_parameter_file(missing),
            Err(ParamError::Missing("m_u"))
        );
    }

    #[test]
    fn overrides_apply_or_leave_parameters_unchanged() {
        let p = VehicleParams::default();
        let heavy = p.with_overrides(r#"{"m_s": 1800}"#).unwrap();
        assert_eq!(heavy.m_s, 1800.0);
        assert!(p.with_overrides(r#"{"m_s": "heavy"}"#).is_err());
        assert!(p.with_overrides(r#"{"k_s_f": NaN}"#).is_err());
        assert_eq!(
            p.with_overrides(r#"{"c_seat": -1}"#),
            Err(ParamError::Value {
                name: "c_seat",
                expected: "a number in [0e0, 1e6]".into(),
                value: -1.0
            })
        );
        let mut q = p;
        assert!(q.set("k_s_r", f64::INFINITY).is_err());
        assert_eq!(q, p, "a rejected set leaves the parameters unchanged");
    }
}
