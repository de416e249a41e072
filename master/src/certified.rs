//! What the controllers' certificates predict for the loop a master runs, set beside what a
//! sweep measured at the same conditions (the sweep report's "Predicted beside measured").
//!
//! `synth` writes each comfort design's certificate beside its FMU
//! (`dist/<variant>.certificate.json`). Its `comfort` object predicts the W_k RMS seat
//! acceleration of the loop as a master runs it (commands held over the communication step) on
//! the design road, at the nominal car (`comfort.held`) and at every checked condition of the
//! design's uncertainty (`comfort.uncertainty.held`, with the plant parameters of each
//! condition in `comfort.uncertainty.plant_parameters`). A sweep run is at a condition when its
//! road is the design road (ISO class and speed, independent tracks), its step is the
//! prediction's, and every plant parameter, the run's or the condition's, has the same value
//! in both (the plant FMU's start value where one does not set it).

use crate::cosim::{err, MasterError, Scenario};
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// One condition a certificate predicts.
#[derive(Debug, Clone, PartialEq)]
pub struct Condition {
    /// How the certificate names it ("nominal car", "m_s = 1200 kg", "delay 10.0 ms" …).
    pub label: String,
    /// The plant parameters that differ from the nominal car.
    pub plant: BTreeMap<String, f64>,
    /// The predicted W_k RMS seat acceleration [m/s²]; `None`: the loop is unstable there.
    pub predicted: Option<f64>,
}

/// A controller's certified predictions for the loop a master runs.
#[derive(Debug, Clone, PartialEq)]
pub struct Certified {
    pub controller: String,
    pub iso_class: i64,
    pub speed: f64,
    /// The communication step of the predictions \[s\].
    pub step: f64,
    pub conditions: Vec<Condition>,
}

/// The certificate beside a controller's FMU: `<dist>/<name>.certificate.json`, or
/// `<path>.certificate.json` for a controller given as `<path>.fmu`.
pub fn certificate_path(dist: &Path, controller: &str) -> PathBuf {
    match controller.strip_suffix(".fmu") {
        Some(stem) => PathBuf::from(format!("{stem}.certificate.json")),
        None => dist.join(format!("{controller}.certificate.json")),
    }
}

/// The role `controller`'s certificate gives it (`design`, or `baseline` for the classical
/// controllers the designs are measured against); `None` without a certificate or a role.
pub fn role(dist: &Path, controller: &str) -> Option<String> {
    let text = std::fs::read_to_string(certificate_path(dist, controller)).ok()?;
    let json: Value = serde_json::from_str(&text).ok()?;
    json.get("role")?.as_str().map(String::from)
}

/// The predictions of `controller`'s certificate: `Ok(None)` if it has no certificate or the
/// certificate predicts no held loop (a thesis design); an error for a file that is not a
/// certificate.
pub fn load(dist: &Path, controller: &str) -> Result<Option<Certified>, MasterError> {
    let path = certificate_path(dist, controller);
    let text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(err(format!("{}: {e}", path.display()))),
    };
    let fail = |what: &str| err(format!("{}: {what}", path.display()));
    let json: Value = serde_json::from_str(&text).map_err(|e| fail(&e.to_string()))?;
    let Some(held) = json.pointer("/comfort/held") else {
        return Ok(None);
    };
    let number = |v: &Value, at: &str| {
        v.pointer(at)
            .and_then(Value::as_f64)
            .ok_or_else(|| fail(&format!("no number at {at}")))
    };
    let road = json
        .pointer("/comfort/road")
        .ok_or_else(|| fail("no comfort.road"))?;
    if road.get("tracks").and_then(Value::as_str) != Some("independent") {
        return Ok(None);
    }
    let iso_class = road
        .pointer("/iso_class")
        .and_then(Value::as_str)
        .and_then(|c| c.bytes().next())
        .filter(u8::is_ascii_uppercase)
        .map(|c| (c - b'A' + 1) as i64)
        .ok_or_else(|| fail("comfort.road.iso_class is not a class letter"))?;
    let step = number(held, "/step_s")?;
    let mut conditions = vec![Condition {
        label: "nominal car".into(),
        plant: BTreeMap::new(),
        predicted: Some(number(held, "/predicted_wk_rms_seat_m_s2")?),
    }];
    if let Some(u) = json.pointer("/comfort/uncertainty") {
        let list = |key: &str| {
            u.get(key)
                .and_then(Value::as_array)
                .ok_or_else(|| fail(&format!("comfort.uncertainty.{key} is not a list")))
        };
        let (plants, helds, labels) = (
            list("plant_parameters")?,
            list("held")?,
            list("predictions")?,
        );
        if plants.len() != helds.len() || plants.len() != labels.len() {
            return Err(fail("comfort.uncertainty's lists differ in length"));
        }
        for ((plant, held), label) in plants.iter().zip(helds).zip(labels) {
            let plant: BTreeMap<String, f64> = serde_json::from_value(plant.clone())
                .map_err(|e| fail(&format!("comfort.uncertainty.plant_parameters: {e}")))?;
            if held.is_object() && held.get("step_s").and_then(Value::as_f64) != Some(step) {
                return Err(fail(
                    "comfort.uncertainty.held: another step than comfort.held's",
                ));
            }
            let condition = Condition {
                label: label
                    .pointer("/0")
                    .and_then(Value::as_str)
                    .unwrap_or("?")
                    .to_string(),
                predicted: held
                    .pointer("/predicted_wk_rms_seat_m_s2")
                    .and_then(Value::as_f64),
                plant,
            };
            // The nominal car once (the uncertainty's lists hold it too).
            if !condition.plant.is_empty() {
                conditions.push(condition);
            }
        }
    }
    Ok(Some(Certified {
        controller: controller.to_string(),
        iso_class,
        speed: number(&json, "/comfort/road/speed_m_s")?,
        step,
        conditions,
    }))
}

impl Certified {
    /// The index in [`Self::conditions`] of the condition `scenario` runs at, if any (see the
    /// module's documentation); `start(name)` is the plant's start value of a parameter
    /// neither sets ([`crate::cosim::Fmu::start_real`] of the plant FMU).
    pub fn condition_of(
        &self,
        scenario: &Scenario,
        start: impl Fn(&str) -> Option<f64>,
    ) -> Option<usize> {
        let road = |k: &str| scenario.road.get(k);
        let on_design_road = road("profile").and_then(Value::as_i64) == Some(2)
            && road("iso_class").and_then(Value::as_i64) == Some(self.iso_class)
            && road("speed").and_then(Value::as_f64) == Some(self.speed)
            && !road("identical_tracks").is_some_and(|v| v.as_bool() == Some(true) || v == 1);
        if !on_design_road || scenario.step != self.step {
            return None;
        }
        self.conditions.iter().position(|c| {
            let value =
                |p: &str, of: &BTreeMap<String, f64>| of.get(p).copied().or_else(|| start(p));
            scenario
                .plant
                .keys()
                .chain(c.plant.keys())
                .all(|p| value(p, &scenario.plant) == value(p, &c.plant))
        })
    }
}

/// The report's section: per controller with a certificate and per condition some run is at,
/// the prediction beside the runs' measured W_k RMS seat (mean, range, mean / predicted).
/// `at(c, row)` is [`Certified::condition_of`] `row`'s scenario.
pub fn section(
    certified: &[Certified],
    rows: &[crate::sweep::Row],
    at: impl Fn(&Certified, &crate::sweep::Row) -> Option<usize>,
) -> String {
    use std::fmt::Write as _;
    let mut t = String::from("\n## Predicted beside measured\n\n");
    if certified.is_empty() {
        t +=
            "No controller of this sweep has a certificate that predicts the loop a master runs.\n";
        return t;
    }
    let mut table = String::new();
    for c in certified {
        let mine: Vec<(usize, &crate::sweep::Row)> = rows
            .iter()
            .filter(|r| r.job.controller_name() == c.controller)
            .filter_map(|r| at(c, r).map(|k| (k, r)))
            .collect();
        for (k, condition) in c.conditions.iter().enumerate() {
            let runs: Vec<&crate::sweep::Row> = mine
                .iter()
                .filter(|(i, _)| *i == k)
                .map(|(_, r)| *r)
                .collect();
            if runs.is_empty() {
                continue;
            }
            let measured: Vec<f64> = runs
                .iter()
                .filter_map(|r| r.outcome.finished().map(|f| f.wk_rms_seat))
                .collect();
            let failed = runs.len() - measured.len();
            let mean = measured.iter().sum::<f64>() / measured.len().max(1) as f64;
            let (lo, hi) = measured
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                    (a.min(v), b.max(v))
                });
            let predicted = condition
                .predicted
                .map_or("unstable".to_string(), |p| format!("{p:.4}"));
            let figures = match measured.is_empty() {
                true => "- | -".to_string(),
                false => format!("{mean:.4} | {lo:.4} … {hi:.4}"),
            };
            let ratio = match (measured.is_empty(), condition.predicted) {
                (false, Some(p)) => format!("{:.3}", mean / p),
                _ => "-".to_string(),
            };
            let failed = match failed {
                0 => String::new(),
                n => format!(" ({n} failed)"),
            };
            writeln!(
                table,
                "| `{}` | {} | {predicted} | {}{failed} | {figures} | {ratio} |",
                c.controller,
                condition.label,
                runs.len()
            )
            .unwrap();
        }
    }
    let roads: Vec<String> = certified
        .iter()
        .map(|c| {
            format!(
                "class {} at {} m/s, step {} ms",
                (b'A' + (c.iso_class - 1).clamp(0, 25) as u8) as char,
                c.speed,
                c.step * 1e3
            )
        })
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .collect();
    t += &format!(
        "The W_k RMS seat acceleration [m/s²] each controller's certificate predicts for the loop a master runs (commands held over the step; stationary, on its design road: {}), at the nominal car and at each checked condition of its uncertainty, beside the runs of this sweep at that condition (same road class and speed, same step, same plant parameters; every seed). A run measures over its metrics window only, from a road faded in from rest, so its figure scatters around the prediction with the seed.\n\n",
        roads.join("; ")
    );
    if table.is_empty() {
        t += "No run of this sweep is at a condition a certificate predicts.\n";
        return t;
    }
    t += "| controller | condition | predicted | runs | measured mean | measured range | mean / predicted |\n|---|---|---|---|---|---|---|\n";
    t + &table
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A certificate's `comfort` as `synth` writes it: the nominal held loop and two mass
    /// conditions (the nominal one again among them, as the uncertainty's lists hold it), one
    /// of them unstable at the step.
    const CERTIFICATE: &str = r#"{"comfort": {
        "road": {"iso_class": "C", "speed_m_s": 20.0, "tracks": "independent"},
        "held": {"predicted_wk_rms_seat_m_s2": 0.0088, "step_s": 0.001},
        "uncertainty": {
            "plant_parameters": [{"m_s": 1200.0}, {}, {"m_s": 1800.0}],
            "held": [{"predicted_wk_rms_seat_m_s2": 0.0094, "step_s": 0.001},
                     {"predicted_wk_rms_seat_m_s2": 0.0088, "step_s": 0.001},
                     null],
            "predictions": [["m_s = 1200 kg", {}], ["m_s = 1500 kg", {}], ["m_s = 1800 kg", {}]]
        }}}"#;

    fn dist(tag: &str, text: Option<&str>) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("certified-{tag}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        if let Some(text) = text {
            std::fs::write(dir.join("k.certificate.json"), text).unwrap();
        }
        dir
    }

    fn scenario(road: &str, plant: &str) -> Scenario {
        serde_json::from_str(&format!(
            r#"{{"name": "s", "duration": 10, "step": 0.001, "road": {road}, "plant": {plant}}}"#
        ))
        .unwrap()
    }

    const DESIGN_ROAD: &str = r#"{"profile": 2, "iso_class": 3, "speed": 20, "seed": 4}"#;

    fn start(p: &str) -> Option<f64> {
        [("m_s", 1500.0), ("tau", 0.0)]
            .iter()
            .find(|(n, _)| *n == p)
            .map(|(_, v)| *v)
    }

    #[test]
    fn a_certificate_gives_the_nominal_car_then_each_other_condition() {
        let c = load(&dist("ok", Some(CERTIFICATE)), "k").unwrap().unwrap();
        assert_eq!((c.iso_class, c.speed, c.step), (3, 20.0, 0.001));
        let labels: Vec<&str> = c.conditions.iter().map(|k| k.label.as_str()).collect();
        assert_eq!(labels, ["nominal car", "m_s = 1200 kg", "m_s = 1800 kg"]);
        assert_eq!(c.conditions[1].predicted, Some(0.0094));
        assert_eq!(c.conditions[2].predicted, None);
        // Beside an FMU given by path.
        assert_eq!(
            certificate_path(Path::new("dist"), "/x/k.fmu"),
            PathBuf::from("/x/k.certificate.json")
        );
    }

    #[test]
    fn a_run_is_at_a_condition_only_on_its_road_step_and_car() {
        let c = load(&dist("match", Some(CERTIFICATE)), "k")
            .unwrap()
            .unwrap();
        let at = |road: &str, plant: &str| {
            c.condition_of(&scenario(road, plant), start)
                .map(|k| c.conditions[k].label.clone())
        };
        assert_eq!(at(DESIGN_ROAD, "{}").as_deref(), Some("nominal car"));
        // The start value written out is the nominal car too.
        assert_eq!(
            at(DESIGN_ROAD, r#"{"m_s": 1500, "tau": 0}"#).as_deref(),
            Some("nominal car")
        );
        assert_eq!(
            at(DESIGN_ROAD, r#"{"m_s": 1200}"#).as_deref(),
            Some("m_s = 1200 kg")
        );
        // A parameter the condition does not change, changed: no condition.
        assert_eq!(at(DESIGN_ROAD, r#"{"m_s": 1200, "tau": 0.01}"#), None);
        assert_eq!(at(DESIGN_ROAD, r#"{"m_s": 1300}"#), None);
        // Another class, speed, profile, identical tracks, step.
        for road in [
            r#"{"profile": 2, "iso_class": 4, "speed": 20}"#,
            r#"{"profile": 2, "iso_class": 3, "speed": 25}"#,
            r#"{"profile": 1, "iso_class": 3, "speed": 20}"#,
            r#"{"profile": 2, "iso_class": 3, "speed": 20, "identical_tracks": true}"#,
        ] {
            assert_eq!(at(road, "{}"), None, "{road}");
        }
        let mut coarse = scenario(DESIGN_ROAD, "{}");
        coarse.step = 0.002;
        assert!(c.condition_of(&coarse, start).is_none());
    }

    #[test]
    fn no_certificate_is_none_and_a_broken_one_is_an_error_naming_the_file() {
        assert_eq!(load(&dist("none", None), "k").unwrap(), None);
        // A thesis design's certificate predicts no held loop.
        let thesis = dist("thesis", Some(r#"{"gamma": 13.2}"#));
        assert_eq!(load(&thesis, "k").unwrap(), None);
        for (tag, text, says) in [
            ("json", "{not json", "key must be a string"),
            (
                "class",
                &CERTIFICATE.replace(r#""iso_class": "C""#, r#""iso_class": 3"#),
                "class letter",
            ),
            (
                "lists",
                &CERTIFICATE.replace(r#"[{"m_s": 1200.0}, {}, "#, "["),
                "differ in length",
            ),
            (
                "step",
                &CERTIFICATE.replace("0.0094, \"step_s\": 0.001", "0.0094, \"step_s\": 0.002"),
                "another step",
            ),
        ] {
            let e = load(&dist(tag, Some(text)), "k").unwrap_err().0;
            assert!(
                e.contains("k.certificate.json") && e.contains(says),
                "{tag}: {e}"
            );
        }
    }
}
