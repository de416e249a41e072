//! Robustness sweeps: one base scenario, parameters swept over grids or drawn from seeded
//! distributions, every point run with every controller; one row per run.
//!
//! A sweep file (README "Robustness sweeps"):
//! ```json
//! {
//!   "name": "mass_delay",
//!   "base": "../scenarios/iso_c.json",
//!   "controllers": ["passive", "hinf_sf", "delay_sf"],
//!   "seed": 1,
//!   "samples": 50,
//!   "latin_hypercube": true,
//!   "parameters": {
//!     "plant.m_s": { "grid": [1200, 1500, 1800] },
//!     "plant.tau": { "uniform": [0.0, 0.02] },
//!     "road.seed": { "integers": [1, 1000] },
//!     "road.speed": { "normal": { "mean": 20.0, "std": 2.0 } },
//!     "road.iso_class": { "choice": [3, 4] }
//!   },
//!   "map": ["plant.m_s", "plant.tau"],
//!   "stroke_max": 0.08
//! }
//! ```
//! * `base` is a scenario file, relative to the sweep file. A parameter is `plant.<name>` (a
//!   plant parameter, given also to a controller that has one of that name, as in scenarios) or
//!   `road.<name>` (a road FMU parameter).
//! * `grid` values form a Cartesian product (parameters in name order). The random
//!   distributions (`uniform [lo, hi]`, `integers [lo, hi]` inclusive, `normal {mean, std}`,
//!   `choice [...]`) are drawn `samples` times from a ChaCha8 generator seeded with `seed`, by
//!   simple random sampling or (`latin_hypercube`) one draw per stratum of `1/samples`
//!   probability for each parameter. The same draws are used at every grid point, and every point
//!   is run with every controller: differences between controllers and between grid points
//!   are not sampling noise.
//! * The run table is a function of the file alone; each run is deterministic, so a sweep
//!   repeated, or split across machines, gives the same rows.

use crate::cosim::{err, load_json, run_loaded, Fmu, MasterError, Run, Scenario};
use crate::report::{figures, Figures};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Deserialize;
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// How a parameter is swept.
#[derive(Debug, Clone, PartialEq, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Distribution {
    /// Every value, in the Cartesian product with the other grids.
    Grid(Vec<Value>),
    /// Uniform on `[lo, hi]`.
    Uniform([f64; 2]),
    /// Uniform on the integers `lo..=hi` (seeds, classes).
    Integers([i64; 2]),
    /// Normal with this mean and standard deviation.
    Normal { mean: f64, std: f64 },
    /// One of the values, each equally likely.
    Choice(Vec<Value>),
}

impl std::fmt::Display for Distribution {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        let list = |v: &[Value]| {
            v.iter()
                .map(|x| x.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        };
        match self {
            Distribution::Grid(v) => write!(f, "grid {}", list(v)),
            Distribution::Uniform([lo, hi]) => write!(f, "uniform on [{lo}, {hi}]"),
            Distribution::Integers([lo, hi]) => write!(f, "integers {lo} to {hi}"),
            Distribution::Normal { mean, std } => write!(f, "normal, mean {mean}, std {std}"),
            Distribution::Choice(v) => write!(f, "one of {}", list(v)),
        }
    }
}

impl Distribution {
    fn is_random(&self) -> bool {
        !matches!(self, Distribution::Grid(_))
    }

    /// The value at probability `u ∈ [0, 1)` (the inverse distribution function).
    fn quantile(&self, u: f64) -> Value {
        match self {
            Distribution::Grid(_) => unreachable!("a grid is not drawn"),
            Distribution::Uniform([lo, hi]) => Value::from(lo + (hi - lo) * u),
            Distribution::Integers([lo, hi]) => {
                let n = (hi - lo + 1) as f64;
                Value::from(lo + ((u * n).floor() as i64).min(hi - lo))
            }
            Distribution::Normal { mean, std } => Value::from(mean + std * normal_quantile(u)),
            Distribution::Choice(v) => v[((u * v.len() as f64) as usize).min(v.len() - 1)].clone(),
        }
    }

    fn validate(&self, name: &str) -> Result<(), String> {
        let bad = |why: &str| Err(format!("parameter '{name}': {why}"));
        match self {
            Distribution::Grid(v) | Distribution::Choice(v) if v.is_empty() => {
                bad("needs at least one value")
            }
            Distribution::Uniform([lo, hi]) if !(lo.is_finite() && hi.is_finite() && lo <= hi) => {
                bad("uniform needs finite lo <= hi")
            }
            Distribution::Integers([lo, hi]) if lo > hi => bad("integers needs lo <= hi"),
            Distribution::Normal { mean, std } if !(mean.is_finite() && *std >= 0.0) => {
                bad("normal needs a finite mean and std >= 0")
            }
            _ => Ok(()),
        }
    }
}

/// `Φ⁻¹(u)` of the standard normal, by bisection on `Φ(x) = (1 + erf(x/√2))/2` (libm's erf):
/// to the last bits, and only drawn once per sample.
fn normal_quantile(u: f64) -> f64 {
    let u = u.clamp(1e-300, 1.0 - 1e-16);
    let (mut lo, mut hi) = (-40.0f64, 40.0f64);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if 0.5 * (1.0 + libm::erf(mid / std::f64::consts::SQRT_2)) < u {
            lo = mid
        } else {
            hi = mid
        }
        if hi - lo <= f64::EPSILON * mid.abs().max(1e-300) {
            break;
        }
    }
    0.5 * (lo + hi)
}

/// A sweep file (`sweeps/*.json`; its JSON Schema, `schemas/sweep.schema.json`, is generated
/// from this type by `master schema sweep`).
#[derive(Debug, Clone, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SweepSpec {
    /// The sweep's name (the report's title).
    pub name: String,
    /// What it studies, for the report.
    #[serde(default)]
    pub description: String,
    /// The base scenario file, relative to the sweep file.
    pub base: PathBuf,
    /// Controller FMU names; `passive` is the car without one.
    pub controllers: Vec<String>,
    /// Seed of the random draws: the run table depends on the file alone.
    #[serde(default)]
    pub seed: u64,
    /// Draws of the random parameters (required when there is one).
    #[serde(default)]
    pub samples: Option<usize>,
    /// Draw the random parameters as a Latin hypercube instead of independently.
    #[serde(default)]
    pub latin_hypercube: bool,
    /// The swept parameters, `plant.<name>` or `road.<name>`, and how each is swept.
    pub parameters: BTreeMap<String, Distribution>,
    /// The two parameters of the worst-case map (default: the first two).
    #[serde(default)]
    pub map: Option<[String; 2]>,
    /// Stroke limit of the limit flags, in m, instead of the base scenario's `stroke_max`.
    #[serde(default)]
    pub stroke_max: Option<f64>,
}

impl SweepSpec {
    pub fn validate(&self) -> Result<(), String> {
        if self.controllers.is_empty() {
            return Err("no controllers".into());
        }
        if self.parameters.is_empty() {
            return Err("no parameters to sweep".into());
        }
        for (name, d) in &self.parameters {
            match name.split_once('.') {
                Some(("plant" | "road", p)) if !p.is_empty() => {}
                _ => {
                    return Err(format!(
                        "parameter '{name}' must be plant.<name> or road.<name>"
                    ))
                }
            }
            d.validate(name)?;
        }
        let random = self.parameters.values().any(Distribution::is_random);
        match (random, self.samples) {
            (true, None | Some(0)) => {
                return Err("random parameters need \"samples\" >= 1".into());
            }
            (false, Some(_)) => {
                return Err("\"samples\" given but no parameter is random".into());
            }
            _ => {}
        }
        if let Some(m) = &self.map {
            if let Some(bad) = m.iter().find(|n| !self.parameters.contains_key(*n)) {
                return Err(format!("map parameter '{bad}' is not swept"));
            }
        }
        if let Some(m) = self.stroke_max.filter(|m| !(*m > 0.0 && m.is_finite())) {
            return Err(format!("stroke_max must be finite and > 0, got {m}"));
        }
        Ok(())
    }
}

/// A sweep file with its base scenario.
#[derive(Debug, Clone)]
pub struct Sweep {
    pub spec: SweepSpec,
    pub base: Scenario,
}

/// One run of the table.
#[derive(Debug, Clone)]
pub struct Job {
    pub run: usize,
    /// The parameter point (shared by every controller).
    pub point: usize,
    /// `None`: the passive car.
    pub controller: Option<String>,
    /// The swept values, in [`Sweep::parameter_names`] order.
    pub values: Vec<Value>,
    pub scenario: Scenario,
}

impl Job {
    pub fn controller_name(&self) -> &str {
        self.controller.as_deref().unwrap_or("passive")
    }
}

impl Sweep {
    pub fn load(path: &Path) -> Result<Sweep, MasterError> {
        let spec: SweepSpec = load_json(path, "sweep", SweepSpec::validate)?;
        let mut base = Scenario::load(&path.parent().unwrap_or(Path::new(".")).join(&spec.base))?;
        if let Some(m) = spec.stroke_max {
            base.stroke_max = m;
        }
        Ok(Sweep { spec, base })
    }

    pub fn parameter_names(&self) -> Vec<String> {
        self.spec.parameters.keys().cloned().collect()
    }

    /// The parameter points: the grids' product times the random draws.
    pub fn points(&self) -> Vec<Vec<Value>> {
        let s = &self.spec;
        let names = self.parameter_names();
        // Random draws first (one row per sample), from one generator in name order.
        let random: Vec<&String> = names
            .iter()
            .filter(|n| s.parameters[*n].is_random())
            .collect();
        let samples = if random.is_empty() {
            1
        } else {
            s.samples.unwrap_or(1)
        };
        let mut rng = ChaCha8Rng::seed_from_u64(s.seed);
        let mut draws: Vec<BTreeMap<&String, Value>> = vec![BTreeMap::new(); samples];
        for name in &random {
            let d = &s.parameters[*name];
            let us: Vec<f64> = if s.latin_hypercube {
                let mut strata: Vec<usize> = (0..samples).collect();
                for i in (1..samples).rev() {
                    strata.swap(i, rng.gen_range(0..=i));
                }
                strata
                    .iter()
                    .map(|k| (*k as f64 + rng.gen::<f64>()) / samples as f64)
                    .collect()
            } else {
                (0..samples).map(|_| rng.gen::<f64>()).collect()
            };
            for (draw, u) in draws.iter_mut().zip(us) {
                draw.insert(name, d.quantile(u));
            }
        }
        let mut points: Vec<BTreeMap<&String, Value>> = vec![BTreeMap::new()];
        for name in names.iter().filter(|n| !s.parameters[*n].is_random()) {
            let Distribution::Grid(values) = &s.parameters[name] else {
                unreachable!("filtered to grids")
            };
            points = points
                .into_iter()
                .flat_map(|p| {
                    values.iter().map(move |v| {
                        let mut q = p.clone();
                        q.insert(name, v.clone());
                        q
                    })
                })
                .collect();
        }
        points
            .iter()
            .flat_map(|p| {
                let names = &names;
                draws.iter().map(move |d| {
                    names
                        .iter()
                        .map(|n| p.get(n).or_else(|| d.get(n)).cloned().unwrap_or_default())
                        .collect()
                })
            })
            .collect()
    }

    /// The scenario of a point: the base with the point's values.
    pub fn scenario_at(&self, point: usize, values: &[Value]) -> Result<Scenario, String> {
        let mut sc = self.base.clone();
        sc.name = format!("{}_{point}", self.spec.name);
        for (name, v) in self.parameter_names().iter().zip(values) {
            match name.split_once('.') {
                Some(("plant", p)) => {
                    let x = v
                        .as_f64()
                        .ok_or_else(|| format!("{name} = {v} is not a number"))?;
                    sc.plant.insert(p.into(), x);
                }
                Some(("road", p)) => {
                    sc.road.insert(p.into(), v.clone());
                }
                _ => unreachable!("validated"),
            }
        }
        Ok(sc)
    }

    /// The run table: every point with every controller.
    pub fn jobs(&self) -> Result<Vec<Job>, MasterError> {
        let mut jobs = Vec::new();
        for (point, values) in self.points().into_iter().enumerate() {
            let scenario = self.scenario_at(point, &values).map_err(err)?;
            for c in &self.spec.controllers {
                jobs.push(Job {
                    run: jobs.len(),
                    point,
                    controller: (c != "passive").then(|| c.clone()),
                    values: values.clone(),
                    scenario: scenario.clone(),
                });
            }
        }
        Ok(jobs)
    }
}

/// What a run gave: its figures (with the limit flags), or why it failed.
#[derive(Debug, Clone)]
pub enum Outcome {
    Ok(Figures),
    Failed(String),
}

impl Outcome {
    /// The figures of a run that finished; `None` if it failed.
    pub fn finished(&self) -> Option<&Figures> {
        match self {
            Outcome::Ok(f) => Some(f),
            Outcome::Failed(_) => None,
        }
    }
}

/// Figures of a run that finished; a non-finite or exploding output (strokes beyond 1 m, which
/// no suspension has) is a failure (instability).
pub fn outcome(run: &Run, scenario: &Scenario) -> Outcome {
    if let Some(k) = run.data.iter().position(|v| !v.is_finite()) {
        let row = k / run.columns.len();
        return Outcome::Failed(format!(
            "unstable: {} is not finite at t = {} s",
            run.columns[k % run.columns.len()],
            run.time[row]
        ));
    }
    let f = figures(run, scenario);
    if f.max_stroke > 1.0 {
        return Outcome::Failed(format!(
            "unstable: a stroke of {:.3} m (over 1 m)",
            f.max_stroke
        ));
    }
    Outcome::Ok(f)
}

/// One row of the result table.
#[derive(Debug, Clone)]
pub struct Row {
    pub job: Job,
    pub outcome: Outcome,
    pub loop_seconds: f64,
    /// What the FMUs warned of in a run that went through ([`Run::warnings`]: a controller
    /// stepped beyond the communication steps its loop is stable at).
    pub warnings: Vec<String>,
}

/// The FMUs of a sweep, loaded once and shared by every run.
pub struct Fmus {
    road: Fmu,
    plant: Fmu,
    controllers: BTreeMap<String, Fmu>,
}

impl Fmus {
    pub fn load(dist: &Path, controllers: &[String]) -> Result<Fmus, MasterError> {
        Ok(Fmus {
            road: Fmu::load(dist, "road")?,
            plant: Fmu::load(dist, "plant")?,
            controllers: controllers
                .iter()
                .filter(|c| *c != "passive")
                .map(|c| Ok((c.clone(), Fmu::load(dist, c)?)))
                .collect::<Result<_, MasterError>>()?,
        })
    }

    /// The plant FMU (its start values are the car's nominal parameters).
    pub fn plant(&self) -> &Fmu {
        &self.plant
    }

    /// Run one job; an FMU error or an instability is the row's outcome, not an error.
    pub fn run(&self, job: &Job) -> Row {
        let ctrl = job.controller.as_ref().map(|c| &self.controllers[c]);
        match run_loaded(&self.road, &self.plant, ctrl, &job.scenario) {
            Ok(r) => Row {
                outcome: outcome(&r, &job.scenario),
                loop_seconds: r.loop_seconds,
                job: job.clone(),
                warnings: r.warnings,
            },
            Err(e) => Row {
                outcome: Outcome::Failed(e.0),
                loop_seconds: 0.0,
                job: job.clone(),
                warnings: Vec::new(),
            },
        }
    }
}

/// The metric columns of a row, in table order, named with their unit.
pub const METRICS: [&str; 10] = [
    "wk_rms_seat_m_s2",
    "vdv_seat_m_s1_75",
    "peak_seat_m_s2",
    "rms_roll_rad_s2",
    "rms_pitch_rad_s2",
    "we_rms_roll_rad_s2",
    "we_rms_pitch_rad_s2",
    "max_stroke_m",
    "max_tyre_load_ratio",
    "peak_force_n",
];

pub fn metric_values(f: &Figures) -> [f64; 10] {
    [
        f.wk_rms_seat,
        f.vdv_seat,
        f.peak_seat,
        f.rms_roll,
        f.rms_pitch,
        f.we_rms_roll,
        f.we_rms_pitch,
        f.max_stroke,
        f.max_tyre_ratio,
        f.peak_force,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sweep(parameters: &str, extra: &str) -> Sweep {
        let spec: SweepSpec = serde_json::from_str(&format!(
            r#"{{"name": "t", "base": "x.json", "controllers": ["passive", "hinf_sf"],
                "parameters": {parameters} {extra}}}"#
        ))
        .unwrap();
        let base: Scenario = serde_json::from_str(
            r#"{"name": "b", "duration": 1.0, "step": 0.001, "road": {"profile": 2}}"#,
        )
        .unwrap();
        Sweep { spec, base }
    }

    #[test]
    fn grids_form_a_product_and_draws_repeat_at_every_grid_point() {
        let s = sweep(
            r#"{"plant.m_s": {"grid": [1200, 1800]}, "road.speed": {"grid": [10, 20, 30]},
                "plant.tau": {"uniform": [0.0, 0.02]}}"#,
            r#", "samples": 4, "seed": 3"#,
        );
        s.spec.validate().unwrap();
        let p = s.points();
        assert_eq!(p.len(), 2 * 3 * 4);
        // Names in order: plant.m_s, plant.tau, road.speed.
        let taus: Vec<f64> = p[..4].iter().map(|v| v[1].as_f64().unwrap()).collect();
        for (k, point) in p.iter().enumerate() {
            assert_eq!(point[1].as_f64().unwrap(), taus[k % 4], "the same draws");
            assert!((0.0..=0.02).contains(&point[1].as_f64().unwrap()));
        }
        let grid: Vec<(f64, f64)> = p
            .iter()
            .step_by(4)
            .map(|v| (v[0].as_f64().unwrap(), v[2].as_f64().unwrap()))
            .collect();
        assert_eq!(
            grid,
            [
                (1200., 10.),
                (1200., 20.),
                (1200., 30.),
                (1800., 10.),
                (1800., 20.),
                (1800., 30.)
            ]
        );
        assert_eq!(s.jobs().unwrap().len(), 48);
        // Deterministic for the seed, different for another.
        assert_eq!(s.points(), p);
        let mut other = s.clone();
        other.spec.seed = 4;
        assert_ne!(other.points(), p);
    }

    #[test]
    fn a_latin_hypercube_puts_one_draw_in_each_stratum() {
        let s = sweep(
            r#"{"plant.tau": {"uniform": [0.0, 1.0]}, "road.seed": {"integers": [1, 10]},
                "road.speed": {"normal": {"mean": 20.0, "std": 2.0}}}"#,
            r#", "samples": 10, "latin_hypercube": true"#,
        );
        let p = s.points();
        let mut strata: Vec<usize> = p
            .iter()
            .map(|v| (v[0].as_f64().unwrap() * 10.0) as usize)
            .collect();
        strata.sort();
        assert_eq!(strata, (0..10).collect::<Vec<_>>());
        let mut seeds: Vec<i64> = p.iter().map(|v| v[1].as_i64().unwrap()).collect();
        seeds.sort();
        assert_eq!(
            seeds,
            (1..=10).collect::<Vec<_>>(),
            "integers keep their type"
        );
        // Normal strata: Φ((x − 20)/2) has one draw per tenth.
        let mut z: Vec<usize> = p
            .iter()
            .map(|v| {
                let x = (v[2].as_f64().unwrap() - 20.0) / 2.0;
                (5.0 * (1.0 + libm::erf(x / std::f64::consts::SQRT_2))) as usize
            })
            .collect();
        z.sort();
        assert_eq!(z, (0..10).collect::<Vec<_>>());
    }

    /// A run of `n` steps of 1 ms, zeros over the recorded columns with `set(column, row)`
    /// changed, the default car's limits, no delay and no command.
    fn run_with(n: usize, set: &[(&str, usize, f64)]) -> Run {
        let columns: Vec<String> = crate::cosim::RECORD.iter().map(|s| s.to_string()).collect();
        let mut data = vec![0.0; n * columns.len()];
        for (c, k, v) in set {
            let j = columns.iter().position(|x| x == c).unwrap();
            data[k * columns.len() + j] = *v;
        }
        Run {
            units: vec![String::new(); columns.len()],
            columns,
            time: (1..=n).map(|k| k as f64 * 1e-3).collect(),
            data,
            static_tire_load: [4000.0; 4],
            force_limits: [2500.0, 2500.0, 2500.0, 2500.0, 1000.0],
            delay: 0.0,
            commands: vec![[0.0; 5]; n],
            loop_seconds: 0.0,
            warnings: Vec::new(),
        }
    }

    #[test]
    fn non_finite_or_exploding_runs_fail_and_limits_are_flagged() {
        let s = sweep(r#"{"plant.m_s": {"grid": [1500]}}"#, "").base;
        let failed = |o: Outcome| match o {
            Outcome::Failed(m) => m,
            Outcome::Ok(..) => panic!("not failed"),
        };
        let m = failed(outcome(&run_with(10, &[("a_seat", 4, f64::NAN)]), &s));
        assert!(m.contains("a_seat is not finite at t = 0.005 s"), "{m}");
        let m = failed(outcome(&run_with(10, &[("stroke_rl", 2, 3.0)]), &s));
        assert!(m.contains("a stroke of 3.000 m"), "{m}");
        let mut r = run_with(10, &[("stroke_fl", 1, -0.09), ("tire_load_rr", 6, -3999.0)]);
        // Two steps at or beyond a limit (the seat's, and a corner's); one just under it.
        r.commands[3][4] = -1000.0;
        r.commands[4][1] = 2600.0;
        r.commands[5][1] = 2499.0;
        let Outcome::Ok(f) = outcome(&r, &s) else {
            panic!("failed")
        };
        assert_eq!(f.max_stroke, 0.09);
        assert!(f.flags.stroke_exceeded && !f.flags.tyre_lift_off);
        assert!(
            (f.flags.saturated_share - 0.2).abs() < 1e-12,
            "{:?}",
            f.flags
        );
        // A load up to the static one is a lift-off; a compression as large is not.
        let r = run_with(10, &[("tire_load_rr", 6, -4000.0)]);
        let Outcome::Ok(f) = outcome(&r, &s) else {
            panic!("failed")
        };
        assert!(f.flags.tyre_lift_off && !f.flags.stroke_exceeded);
        let r = run_with(10, &[("tire_load_rr", 6, 4000.0)]);
        let f = outcome(&r, &s).finished().unwrap().flags;
        assert!(!f.tyre_lift_off);
        // The physical car's clocks: 2 ms off the road at RL and 5 ms at the seat's stop over
        // the 10 ms run (metrics from the start), whatever the loads say.
        let mut set: Vec<(&str, usize, f64)> =
            (6..10).map(|k| ("airborne_time_rl", k, 0.002)).collect();
        set.extend((5..10).map(|k| ("stop_time_seat", k, (k as f64 - 4.0) * 1e-3)));
        let f = outcome(&run_with(10, &set), &s).finished().unwrap().flags;
        assert!(f.tyre_lift_off);
        assert_eq!(f.airborne, [0.0, 0.0, 0.2, 0.0]);
        assert!((f.at_stop[4] - 0.5).abs() < 1e-12 && f.at_stop[..4] == [0.0; 4]);
        assert_eq!(
            f.describe(0.08),
            [
                "wheel lift-off (RL 20.0 % of the time)",
                "on a stop (seat 50.0 % of the time)"
            ]
        );
        // Never at a limit is +0 (the report prints no "-0.00 %").
        assert!(f.saturated_share == 0.0 && f.saturated_share.is_sign_positive());
        // The sweep's stroke limit replaces the base scenario's.
        let mut s = s;
        s.stroke_max = 0.1;
        let r = run_with(10, &[("stroke_fl", 1, -0.09)]);
        assert!(!outcome(&r, &s).finished().unwrap().flags.stroke_exceeded);
    }

    #[test]
    fn clamped_time_follows_the_commands_through_the_delay() {
        let mut s = sweep(r#"{"plant.m_s": {"grid": [1500]}}"#, "").base;
        // Steps 0 and 1 commanded beyond the limit, applied 1.5 steps later: [1.5, 3.5] ms of
        // the 10 ms run.
        let mut r = run_with(10, &[]);
        r.delay = 1.5e-3;
        r.commands[0][0] = 3000.0;
        r.commands[1][2] = -3000.0;
        let share = |r: &Run, s: &Scenario| outcome(r, s).finished().unwrap().flags.saturated_share;
        assert!((share(&r, &s) - 0.2).abs() < 1e-12);
        // Over a window from 2.5 ms: 1 ms of 7.5.
        s.metrics_from = 2.5e-3;
        assert!((share(&r, &s) - 1.0 / 7.5).abs() < 1e-12);
        // A command still in flight at the end is not applied within the run.
        let mut r = run_with(10, &[]);
        r.delay = 1.5e-3;
        r.commands[9][4] = 2000.0;
        s.metrics_from = 0.0;
        assert_eq!(share(&r, &s), 0.0);
    }

    #[test]
    fn the_normal_quantile_inverts_the_distribution_function() {
        // Reference values of Φ⁻¹ (Abramowitz & Stegun, table 26.5).
        for (u, x) in [
            (0.5, 0.0),
            (0.975, 1.959963984540054),
            (0.05, -1.6448536269514729),
        ] {
            assert!((normal_quantile(u) - x).abs() < 1e-12, "{u}");
        }
    }

    #[test]
    fn bad_sweeps_are_refused_with_the_reason() {
        let cases = [
            (
                r#"{"wheel.m": {"grid": [1]}}"#,
                "",
                "plant.<name> or road.<name>",
            ),
            (r#"{"plant.m_s": {"grid": []}}"#, "", "at least one value"),
            (
                r#"{"plant.tau": {"uniform": [0.02, 0.0]}}"#,
                r#", "samples": 2"#,
                "lo <= hi",
            ),
            (r#"{"plant.tau": {"uniform": [0.0, 0.02]}}"#, "", "samples"),
            (
                r#"{"plant.m_s": {"grid": [1]}}"#,
                r#", "samples": 3"#,
                "no parameter is random",
            ),
            (
                r#"{"plant.m_s": {"grid": [1]}}"#,
                r#", "map": ["plant.m_s", "road.x"]"#,
                "not swept",
            ),
        ];
        for (p, extra, why) in cases {
            let e = sweep(p, extra).spec.validate().unwrap_err();
            assert!(e.contains(why), "{p}: {e}");
        }
        let plant_string = sweep(r#"{"plant.m_s": {"grid": ["heavy"]}}"#, "");
        let e = plant_string.jobs().unwrap_err().0;
        assert!(e.contains("not a number"), "{e}");
        assert!(serde_json::from_str::<SweepSpec>(
            r#"{"name": "t", "base": "x", "controllers": ["a"], "parameters": {"plant.m_s": {"lognormal": 1}}}"#
        )
        .is_err());
    }
}
