//! What the master's co-simulation tests of the shipped FMUs share: where they are, their
//! certificates, one run on the design road, and how a run is judged. Each test crate compiles
//! its own copy and uses a part of it.
#![allow(dead_code)]

use master::cosim::{run, Run, Scenario};
use master::metrics::{peak, rms};
use std::path::PathBuf;

/// Where the shipped comfort designs' FMUs and certificates are (`make`), or, to judge a
/// candidate design before it ships, the directory `CANDIDATE_DIST` names.
pub fn dist() -> PathBuf {
    std::env::var_os("CANDIDATE_DIST").map_or_else(
        || PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../dist"),
        PathBuf::from,
    )
}

/// The applied forces, in the order of [`Run::force_limits`] (corners, seat).
pub const FORCES: [&str; 5] = ["f_fl", "f_fr", "f_rl", "f_rr", "f_seat"];

/// Every certificate in `dist/` as `(variant, certificate)`, sorted by variant.
pub fn certificates() -> Vec<(String, serde_json::Value)> {
    let mut out: Vec<(String, serde_json::Value)> = std::fs::read_dir(dist())
        .unwrap_or_else(|e| panic!("{}: {e}: run `make`", dist().display()))
        .filter_map(|e| {
            let path = e.ok()?.path();
            let variant = path
                .file_name()?
                .to_str()?
                .strip_suffix(".certificate.json")?
                .to_string();
            let text = std::fs::read_to_string(&path).ok()?;
            Some((variant, serde_json::from_str(&text).expect("a certificate")))
        })
        .collect();
    out.sort_by(|a, b| a.0.cmp(&b.0));
    out
}

/// How calm a stable run of a certified controller must be, in W_k seat [m/s²]: what its role
/// had to reach on its design road (the certificate's `role`: a design half the passive car,
/// a baseline the passive car itself; `synth::comfort::designs::Role::comfort_bound`).
pub fn calm_bound(certificate: &serde_json::Value) -> f64 {
    let passive = certificate["comfort"]["passive_wk_rms_seat_m_s2"]
        .as_f64()
        .expect("passive");
    match certificate["role"].as_str() {
        Some("design") => 0.5 * passive,
        Some("baseline") => passive,
        other => panic!("a certificate's role is design or baseline, got {other:?}"),
    }
}

/// `duration` s on the design road (ISO C, 20 m/s, `seed`) at `step` with the plant's
/// parameters `plant`.
pub fn road_run(
    controller: &str,
    duration: f64,
    step: f64,
    seed: u64,
    plant: &serde_json::Value,
) -> Result<Run, String> {
    let scenario: Scenario = serde_json::from_value(serde_json::json!({
        "name": "design_road",
        "duration": duration,
        "step": step,
        "road": {"profile": 2, "iso_class": 3, "seed": seed, "speed": 20.0},
        "plant": plant,
    }))
    .expect("a scenario");
    run(&dist(), &scenario, Some(controller)).map_err(|e| e.to_string())
}

/// W_k seat RMS over the second half of the run, and whether an actuator reached its limit.
pub fn judge(r: &Run) -> (f64, bool) {
    let seat = r.column("a_seat_wk").expect("recorded");
    let saturated = FORCES
        .iter()
        .zip(r.force_limits)
        .any(|(name, limit)| peak(&r.column(name).expect("recorded")) >= 0.999 * limit);
    (rms(&seat[seat.len() / 2..]), saturated)
}

/// The share of the run's time at a limit: the largest over the forces (their samples within
/// 0.1 % of the limit) and the end stops (the plant's `stop_time_*`, the time on each stop)
/// but `except` (`fl` … `rr`, `seat`).
pub fn contact_share(r: &Run, except: Option<&str>) -> f64 {
    // The runs start at 0.
    let duration = r.time.last().copied().unwrap_or(0.0);
    let forces = FORCES.iter().zip(r.force_limits).map(|(name, limit)| {
        let f = r.column(name).expect("recorded");
        f.iter().filter(|v| v.abs() >= 0.999 * limit).count() as f64 / f.len().max(1) as f64
    });
    let stops = vehicle::model::ACTUATORS
        .iter()
        .filter(|s| Some(**s) != except)
        .map(|s| {
            let on = r.column(&format!("stop_time_{s}")).expect("recorded");
            on.last().copied().unwrap_or(0.0) / duration.max(f64::MIN_POSITIVE)
        });
    forces.chain(stops).fold(0.0, f64::max)
}
