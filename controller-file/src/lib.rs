//! `resources/controller.json`: the controller `ẋc = A xc + B y`, `u = C xc + D y` in the
//! plant's units, the plant outputs it reads (`inputs`) and the plant inputs it drives
//! (`outputs`) by name and unit, what its synthesis guarantees, and the optional blocks of the
//! runtime (fault accommodation, anti-windup, fault detection, predictor). `synth` writes it and `fmu-controller`
//! reads it through these types, so the two cannot drift apart.
//!
//! The fields are declared in alphabetical order (upper case first): the order the file has
//! always had, from the sorted maps it was first written with, so files written through these
//! types are byte-identical to the older ones. Shapes and values are checked by the reader
//! (`fmu-controller`'s `Spec`), which knows what each block must match.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// The `format` every file carries.
pub const FORMAT: &str = "suspension-controller/2";

/// A matrix as its rows.
pub type Rows = Vec<Vec<f64>>;

/// Whether `rows` is an `r × c` matrix, an empty dimension written as no rows or as rows of
/// none; if not, what was found instead (for the reader's error message).
pub fn shape_mismatch(rows: &[Vec<f64>], r: usize, c: usize) -> Option<String> {
    let shaped = rows.len() == r && rows.iter().all(|row| row.len() == c)
        || (r == 0 && rows.is_empty())
        || (c == 0 && rows.len() == r && rows.iter().all(|row| row.is_empty()));
    (!shaped).then(|| {
        format!(
            "{} rows of lengths {:?}",
            rows.len(),
            rows.iter().map(|x| x.len()).collect::<Vec<_>>()
        )
    })
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControllerFile {
    #[serde(rename = "A")]
    pub a: Rows,
    #[serde(rename = "B")]
    pub b: Rows,
    #[serde(rename = "C")]
    pub c: Rows,
    #[serde(rename = "D")]
    pub d: Rows,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub accommodation: Option<Accommodation>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub anti_windup: Option<AntiWindup>,
    /// The communication steps its certificate found the loop as a master runs it stable at
    /// (absent: not checked). The FMU warns at a step beyond them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub communication_steps: Option<CommunicationSteps>,
    pub description: String,
    /// The car it was designed for (absent from files written before it was recorded).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub designed_for: Option<DesignedFor>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fault_detection: Option<FaultDetection>,
    /// [`FORMAT`].
    pub format: String,
    pub guarantee: Guarantee,
    /// The plant outputs the controller reads, in the order of `B`'s and `D`'s columns.
    pub inputs: Vec<Signal>,
    /// The plant inputs it drives (`u_*`), in the order of `C`'s and `D`'s rows.
    pub outputs: Vec<Signal>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub predictor: Option<Predictor>,
    /// The FMU's model identifier.
    pub variant: String,
}

/// Where the nominal loop as a master runs it (commands and measurements held over each
/// communication step) was found stable: every checked step up to `stable_up_to_s`, unstable at
/// `unstable_at_s` (absent: stable at every checked step), on the car it was designed for.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CommunicationSteps {
    pub stable_up_to_s: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unstable_at_s: Option<f64>,
}

/// The car a controller was designed for: every vehicle parameter by the plant FMU's name (SI
/// units, as the plant declares them) and, for a design robust to the sprung mass, the range
/// of `m_s` it covers. A master compares them with the plant it runs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DesignedFor {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mass_range_kg: Option<[f64; 2]>,
    pub vehicle: BTreeMap<String, f64>,
}

impl DesignedFor {
    /// Why a plant with these parameters is not the car designed for, one line per parameter
    /// (empty when it is): a sprung mass outside the robust range (or, without a range, other
    /// than the design's), or any other parameter more than 1e-9 relative away. A parameter the
    /// plant does not give is not compared.
    pub fn differences(&self, plant: &BTreeMap<String, f64>) -> Vec<String> {
        let mut out = Vec::new();
        for (name, designed) in &self.vehicle {
            let Some(actual) = plant.get(name) else {
                continue;
            };
            match (name.as_str(), self.mass_range_kg) {
                ("m_s", Some([lo, hi])) => {
                    if !(lo..=hi).contains(actual) {
                        out.push(format!(
                            "m_s = {actual} outside the sprung-mass range [{lo}, {hi}] it is robust to"
                        ));
                    }
                }
                _ => {
                    if (actual - designed).abs() > 1e-9 * designed.abs().max(1e-300) {
                        out.push(format!("{name} = {actual}, designed for {designed}"));
                    }
                }
            }
        }
        out
    }
}

/// A variable by name and unit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Signal {
    pub name: String,
    pub unit: String,
}

/// What the synthesis guarantees, reported by the FMU as a calculated parameter of this name
/// (`gamma` for the thesis's H∞ designs, `guaranteed_wk_rms_seat` or `predicted_wk_rms_seat`
/// for the comfort designs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Guarantee {
    pub description: String,
    pub name: String,
    pub unit: String,
    pub value: f64,
}

/// Fault accommodation from the actuators' measured applied forces: each actuator's
/// effectiveness estimated as `ρ̂ᵢ = √(E fᵢ² / E uᵢ²)`, exponentially weighted means over
/// `time_constant` of the applied force (the input named `forces[i]`) and of the command sent
/// the step before (saturated at the actuator's limit), which that force answers; clamped to
/// `[rho_min, 1]`. The command sent is the controller's `yᵢ / ρ̂ᵢ`, so the force applied is the
/// one the controller asked for.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Accommodation {
    /// Per output, the input that measures the force it applies.
    pub forces: Vec<String>,
    /// The least effectiveness compensated \[1\] (the design's effectiveness box).
    pub rho_min: f64,
    /// The estimator's averaging time \[s\].
    pub time_constant: f64,
    /// Default force limit of each output \[N\] (parameters `u_max`, `u_max_seat`).
    pub u_max: Vec<f64>,
    /// Default bandwidth of the actuators' first-order lag \[Hz\] (parameter
    /// `actuator_bandwidth`; 0, the default, an ideal actuator): the force each command is
    /// compared with is that command through the lag, as the plant applies it.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub actuator_bandwidth: f64,
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

/// What drives a fault detector's `B_u`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DetectorInput {
    /// The command sent for the step (the default; thesis ch. 8's parity residual).
    #[default]
    Command,
    /// The force the actuator applies now, as the accommodation's actuator model has it: the
    /// commands sent before, saturated and through the actuators' lag (needs `accommodation`).
    /// Compared with a load cell's reading at the same instant.
    ModelledForce,
}

impl DetectorInput {
    fn is_command(&self) -> bool {
        *self == DetectorInput::Command
    }
}

/// A decoupled anti-windup compensator (thesis Th. 5.3): the plant model
/// `η̇ = A η + B (u − y_c)` with `u = sat(y_c + F η)`; the controller reads
/// `y − C η − D (u − y_c)`. Forces in N.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AntiWindup {
    #[serde(rename = "A")]
    pub a: Rows,
    #[serde(rename = "B")]
    pub b: Rows,
    #[serde(rename = "C")]
    pub c: Rows,
    #[serde(rename = "F")]
    pub f: Rows,
    /// The inputs' direct feed-through of the forces (an accelerometer's, a load cell's);
    /// absent or empty: none.
    #[serde(rename = "D", default, skip_serializing_if = "Vec::is_empty")]
    pub d: Rows,
    /// Default force limit of each output \[N\] (parameters `u_max`, `u_max_seat`).
    pub u_max: Vec<f64>,
}

/// A fault detector (thesis ch. 8): `ξ̇ = A ξ + B y + B_u u` with `u` the command sent (N), or
/// the modelled applied force ([`DetectorInput`]), the residual `r = C ξ + D y` (N);
/// `fault_detected` latches when `‖r‖` exceeds `threshold`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FaultDetection {
    #[serde(rename = "A")]
    pub a: Rows,
    #[serde(rename = "B")]
    pub b: Rows,
    #[serde(rename = "B_u")]
    pub b_u: Rows,
    #[serde(rename = "C")]
    pub c: Rows,
    #[serde(rename = "D")]
    pub d: Rows,
    /// Default threshold \[N\] (parameter `fault_threshold`).
    pub threshold: f64,
    /// What drives `B_u`.
    #[serde(default, skip_serializing_if = "DetectorInput::is_command")]
    pub input: DetectorInput,
}

/// A state feedback behind a predictor over the actuators' known delay `θ`: the design state
/// `x = S_y y + S_ξ ξ`, `ξ̇ = A_ξ ξ + B_ξ y + B_ξu u(t − θ)`, and
/// `u(t) = K [e^{Aθ} x(t) + ∫_{t−θ}^{t} e^{A(t−r)} B u(r) dr]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Predictor {
    #[serde(rename = "A")]
    pub a: Rows,
    #[serde(rename = "A_xi")]
    pub a_xi: Rows,
    #[serde(rename = "B")]
    pub b: Rows,
    #[serde(rename = "B_xi")]
    pub b_xi: Rows,
    #[serde(rename = "B_xiu")]
    pub b_xiu: Rows,
    /// How the applied force reaches the inputs at once (ny × nu); absent: not at all.
    #[serde(rename = "D_yu", default, skip_serializing_if = "Option::is_none")]
    pub d_yu: Option<Rows>,
    #[serde(rename = "K")]
    pub k: Rows,
    #[serde(rename = "S_xi")]
    pub s_xi: Rows,
    #[serde(rename = "S_y")]
    pub s_y: Rows,
    /// The largest delay it is certified for \[s\] (the parameter `tau`'s maximum).
    pub delay_max: f64,
    /// The actuators' force limits the commands are clamped to \[N\], one per output
    /// (parameters `u_max`, `u_max_seat`); absent: not clamped.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub u_max: Option<Vec<f64>>,
    /// The synthesis's figures about it, for the reader (the runtime does not use them).
    #[serde(default, skip_serializing_if = "serde_json::Value::is_null")]
    pub facts: serde_json::Value,
}

/// The blocks a controller may carry beyond `A, B, C, D`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Extensions {
    pub accommodation: Option<Accommodation>,
    pub anti_windup: Option<AntiWindup>,
    pub fault_detection: Option<FaultDetection>,
    pub predictor: Option<Predictor>,
}

impl ControllerFile {
    /// Parse a file (shapes and values are the reader's to check).
    pub fn from_json(text: &str) -> Result<ControllerFile, serde_json::Error> {
        serde_json::from_str(text)
    }

    /// The file's text, as `synth` writes it.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a controller file serialises")
    }

    /// This file with `extensions`' blocks set (those it lacks kept as they are).
    pub fn with(mut self, extensions: Extensions) -> ControllerFile {
        self.accommodation = extensions.accommodation.or(self.accommodation);
        self.anti_windup = extensions.anti_windup.or(self.anti_windup);
        self.fault_detection = extensions.fault_detection.or(self.fault_detection);
        self.predictor = extensions.predictor.or(self.predictor);
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every number `synth` writes reads back to its bits: serde_json's default float parser
    /// is fast but not always correctly rounded (off by one unit in the last place for some
    /// numbers), so the workspace enables its `float_roundtrip`. Without it a CI machine's
    /// synthesis once gave an FMU whose `A_c` differed from its `controller.json`.
    #[test]
    fn every_number_written_reads_back_to_its_bits() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut misses = 0;
        for _ in 0..200_000 {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            // Finite values over the whole range, and the matrices' typical magnitudes.
            let v = f64::from_bits(seed & !(0x7ff << 52) | ((seed % 0x7fe) << 52)) * 0.5;
            let w = (seed % 2001) as f64 * 1e-3 - 1.0 + v.fract();
            for x in [v, w] {
                if !x.is_finite() {
                    continue;
                }
                let text = serde_json::to_string(&x).unwrap();
                let back: f64 = serde_json::from_str(&text).unwrap();
                if back.to_bits() != x.to_bits() {
                    misses += 1;
                }
            }
        }
        assert_eq!(
            misses, 0,
            "{misses} numbers did not read back to their bits"
        );
    }

    /// The shape rule both readers share: `r × c`, an empty dimension as no rows or rows of
    /// none; anything else named by what was found.
    #[test]
    fn shapes_are_checked_with_empty_dimensions_written_either_way() {
        assert_eq!(
            shape_mismatch(&[vec![1.0, 2.0], vec![3.0, 4.0]], 2, 2),
            None
        );
        assert_eq!(shape_mismatch(&[], 0, 3), None);
        assert_eq!(shape_mismatch(&[vec![], vec![]], 2, 0), None);
        assert_eq!(
            shape_mismatch(&[vec![1.0, 2.0], vec![3.0]], 2, 2).as_deref(),
            Some("2 rows of lengths [2, 1]")
        );
        assert!(shape_mismatch(&[], 2, 0).is_some());
        assert!(shape_mismatch(&[vec![1.0]], 2, 1).is_some());
    }

    fn file() -> ControllerFile {
        ControllerFile {
            a: vec![vec![-1.0]],
            b: vec![vec![2.0, 0.5]],
            c: vec![vec![3.0]],
            d: vec![vec![0.25, -4.0]],
            accommodation: None,
            anti_windup: None,
            communication_steps: Some(CommunicationSteps {
                stable_up_to_s: 0.001,
                unstable_at_s: Some(0.00125),
            }),
            description: "test".into(),
            designed_for: Some(DesignedFor {
                mass_range_kg: Some([1200.0, 1800.0]),
                vehicle: [("m_s", 1500.0), ("k_t", 190000.0)]
                    .map(|(n, v)| (n.to_string(), v))
                    .into(),
            }),
            fault_detection: Some(FaultDetection {
                a: vec![],
                b: vec![],
                b_u: vec![],
                c: vec![],
                d: vec![],
                threshold: 50.0,
                input: DetectorInput::Command,
            }),
            format: FORMAT.into(),
            guarantee: Guarantee {
                description: "γ".into(),
                name: "gamma".into(),
                unit: "1".into(),
                value: 1.5,
            },
            inputs: vec![
                Signal {
                    name: "stroke_fl".into(),
                    unit: "m".into(),
                },
                Signal {
                    name: "a_seat".into(),
                    unit: "m/s2".into(),
                },
            ],
            outputs: vec![Signal {
                name: "u_fl".into(),
                unit: "N".into(),
            }],
            predictor: None,
            variant: "x".into(),
        }
    }

    /// The typed file writes exactly what a JSON object with sorted keys (how the file was
    /// written before these types) writes, and reads back to itself.
    #[test]
    fn the_typed_file_is_the_sorted_json_object_and_round_trips() {
        let f = file();
        let as_value = serde_json::to_value(&f).unwrap();
        assert_eq!(
            f.to_json(),
            serde_json::to_string_pretty(&as_value).unwrap()
        );
        assert_eq!(ControllerFile::from_json(&f.to_json()).unwrap(), f);
    }

    #[test]
    fn unknown_and_missing_fields_are_refused_by_name() {
        let text = file().to_json();
        let extra = text.replacen("\"variant\"", "\"varaint\": 1, \"variant\"", 1);
        assert!(ControllerFile::from_json(&extra)
            .unwrap_err()
            .to_string()
            .contains("varaint"));
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        let mut m = v.as_object().unwrap().clone();
        m.remove("guarantee");
        let e = ControllerFile::from_json(&serde_json::Value::Object(m).to_string()).unwrap_err();
        assert!(e.to_string().contains("guarantee"), "{e}");
    }

    #[test]
    fn a_plant_differs_from_the_design_outside_the_mass_range_or_in_another_parameter() {
        let mut designed = file().designed_for.unwrap();
        let plant = |m_s: f64, k_t: f64| -> BTreeMap<String, f64> {
            [("m_s", m_s), ("k_t", k_t), ("c_t", 7.0)]
                .map(|(n, v)| (n.to_string(), v))
                .into()
        };
        assert!(designed.differences(&plant(1800.0, 190000.0)).is_empty());
        assert_eq!(
            designed.differences(&plant(1900.0, 190000.0)),
            ["m_s = 1900 outside the sprung-mass range [1200, 1800] it is robust to"]
        );
        assert_eq!(
            designed.differences(&plant(1500.0, 200000.0)),
            ["k_t = 200000, designed for 190000"]
        );
        // Without a range, the mass is a parameter like the others.
        designed.mass_range_kg = None;
        assert_eq!(
            designed.differences(&plant(1800.0, 190000.0)),
            ["m_s = 1800, designed for 1500"]
        );
        assert!(designed.differences(&plant(1500.0, 190000.0)).is_empty());
    }

    /// A file written before the design's car was recorded still reads.
    #[test]
    fn a_file_without_the_designed_car_reads() {
        let mut f = file();
        f.designed_for = None;
        assert!(!f.to_json().contains("designed_for"));
        assert_eq!(ControllerFile::from_json(&f.to_json()).unwrap(), f);
    }

    #[test]
    fn extensions_are_set_and_absent_ones_kept() {
        let aw = AntiWindup {
            a: vec![],
            b: vec![],
            c: vec![],
            f: vec![],
            d: vec![],
            u_max: vec![1.0],
        };
        let f = file().with(Extensions {
            anti_windup: Some(aw.clone()),
            ..Extensions::default()
        });
        assert_eq!(f.anti_windup, Some(aw));
        assert!(f.fault_detection.is_some());
    }
}
