//! Each comfort certificate says at which communication steps its nominal loop, as a master
//! runs it (commands and measurements held over each step), is stable
//! (`comfort.communication_steps`: the spectral radius at the sampling instants,
//! `synth::predict::sampled`). The co-simulation of the shipped FMUs checks it from outside: at the
//! largest step the certificate calls stable the car on the design road stays controlled (no
//! actuator reaches its force limit, the W_k seat RMS well below the passive car's), and at the
//! first step it calls unstable the loop grows until the actuators saturate (or an FMU refuses a
//! non-finite value), at several times the stable step's W_k seat RMS, and the controller FMU
//! warns (`fmi2Warning`, from its `controller.json`'s `communication_steps`). A robust design's
//! range is checked at every condition of its uncertainty, and co-simulated at both ends of it.
//!
//! Measured (ISO C at 20 m/s, seed 7, W_k seat RMS over the second half of the run, m/s²;
//! `cargo test --release -p master --test communication_steps -- --nocapture`, 2 December
//! 2026): `hinf_sf` 0.082 at 7.5 ms, 4.1 at 10 ms; `robust_of` 0.080 at 7.5 ms, 5.4 at 10 ms;
//! `hinf_of` and `ft_of` 0.088 at 10 ms, stable at every checked step since they are designed
//! behind 30 Hz actuators; `delay_sf` 0.074 at 10 ms with no delay, 0.17 with 50 ms: stable at
//! every checked step since it predicts over at least one step (`docs/comfort-designs.md`).

mod common;

use common::{calm_bound, certificates, judge};
use master::cosim::Run;
use rayon::prelude::*;

/// 30 s on the design road (ISO C, 20 m/s, seed 7) at `step`, the nominal car.
fn road_run(controller: &str, step: f64) -> Result<Run, String> {
    road_run_at(controller, step, &serde_json::json!({}))
}

/// [`road_run`] with the plant's parameters `plant` (a certificate's condition).
fn road_run_at(controller: &str, step: f64, plant: &serde_json::Value) -> Result<Run, String> {
    common::road_run(controller, 30.0, step, 7, plant)
}

#[test]
fn each_certificate_says_at_which_communication_steps_its_loop_is_stable() {
    let certificates = certificates();
    assert!(
        certificates.len() >= 7,
        "the comfort designs' certificates in dist/"
    );
    let lines: Vec<String> = certificates
        .par_iter()
        .map(|(variant, c)| {
            let comfort = &c["comfort"];
            let steps = &comfort["communication_steps"];
            let passive = comfort["passive_wk_rms_seat_m_s2"].as_f64().unwrap();
            let held_step = comfort["held"]["step_s"].as_f64().unwrap();
            let stable = steps["stable_up_to_s"]
                .as_f64()
                .unwrap_or_else(|| panic!("{variant}: stable at no checked step"));
            assert!(
                stable >= held_step,
                "{variant}: its own communication step {held_step} s is not among the stable"
            );
            let r = road_run(variant, stable)
                .unwrap_or_else(|e| panic!("{variant} at {stable} s: {e}"));
            let (calm, saturated) = judge(&r);
            assert!(
                r.warnings.is_empty(),
                "{variant} at {stable} s: {:?}",
                r.warnings
            );
            // As calm as its certificate predicts the held loop there (one 30 s seed is not the
            // road's mean: within a few per cent), and well below the passive car.
            let predicted = steps["checked"]
                .as_array()
                .unwrap()
                .iter()
                .find(|s| s["step_s"].as_f64() == Some(stable))
                .and_then(|s| s["comfort"]["nominal"]["recorded_wk_rms_seat_m_s2"].as_f64())
                .unwrap_or_else(|| panic!("{variant}: no held prediction at {stable} s"));
            assert!(
                !saturated && calm < 1.5 * predicted && calm < calm_bound(c),
                "{variant} at {stable} s (certified stable): W_k seat {calm} (predicted \
                 {predicted}, passive {passive}), saturated {saturated}"
            );
            let mut line = format!("{variant}: stable at {stable} s, W_k seat {calm:.4}");
            // A robust design's range holds at the ends of its uncertainty too (first and last
            // condition: the extreme masses, a corner's fault and all at once, no delay and
            // the largest). Stable, not as calm: the range certifies stability, and the hold
            // costs comfort. `delay_sf` with a 50 ms delay at its 10 ms step measures 0.38,
            // 86 % of the passive car (0.054 at 1 ms, 0.134 at 7.5 ms), as the nominal
            // designs lose several times their 1 ms comfort at 10 ms (`hinf_sf` 0.0103 → 0.046).
            let ends = comfort["uncertainty"]["plant_parameters"]
                .as_array()
                .map(|c| vec![&c[0], &c[c.len() - 1]])
                .unwrap_or_default();
            for plant in ends {
                let r = road_run_at(variant, stable, plant)
                    .unwrap_or_else(|e| panic!("{variant} at {stable} s, {plant}: {e}"));
                let (seat, saturated) = judge(&r);
                assert!(
                    r.warnings.is_empty() && !saturated && seat < passive,
                    "{variant} at {stable} s, {plant} (certified stable): W_k seat {seat}, \
                     saturated {saturated}, warnings {:?}",
                    r.warnings
                );
                line += &format!("; at {plant}: {seat:.4}");
            }
            let unstable = steps["checked"]
                .as_array()
                .unwrap()
                .iter()
                .find(|s| !s["spectral_radius"].as_f64().is_some_and(|r| r < 1.0));
            if let Some(s) = unstable {
                let (h, radius) = (s["step_s"].as_f64().unwrap(), s["spectral_radius"].as_f64());
                // A radius barely above 1 grows too slowly to show in 30 s: only one that
                // multiplies the state by 10⁶ within the run is checked.
                let grows = radius.is_none_or(|r| r.powf(30.0 / h) > 1e6);
                if grows {
                    match road_run(variant, h) {
                        Err(e) => line += &format!("; at {h} s refused: {e}"),
                        Ok(r) => {
                            assert!(
                                r.warnings.iter().any(|w| w.contains(&format!(
                                    "communication step {h} s: {variant}'s loop"
                                ))),
                                "{variant} at {h} s: the FMU did not warn: {:?}",
                                r.warnings
                            );
                            let (wild, saturated) = judge(&r);
                            assert!(
                                saturated && wild > 5.0 * calm,
                                "{variant} at {h} s (certified unstable, radius {radius:?}): \
                                 W_k seat {wild} against {calm} at {stable} s, saturated \
                                 {saturated}"
                            );
                            line += &format!("; unstable at {h} s: W_k seat {wild:.4}, saturated");
                        }
                    }
                }
            }
            line
        })
        .collect();
    for line in lines {
        println!("{line}");
    }
}

/// `master compare` of a scenario at a step beyond `robust_of`'s stable range (7.5 ms) and within
/// `skyhook`'s (10 ms) lists `robust_of`'s warning in its report, and no other.
#[test]
fn master_compare_reports_a_controller_stepped_beyond_its_stable_steps() {
    let dir = std::env::temp_dir().join(format!("master-compare-warn-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("scenarios")).unwrap();
    std::fs::write(
        dir.join("scenarios/coarse.json"),
        r#"{"name": "coarse", "duration": 2.0, "step": 0.01,
            "road": {"profile": 1, "bump_height": 0.05, "bump_length": 5.0, "side": 0,
                     "speed": 15.0, "start_distance": 1.5}}"#,
    )
    .unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_master"))
        .arg("--dist")
        .arg(common::dist())
        .args([
            "compare",
            "--controllers",
            "skyhook,robust_of",
            "--scenarios",
        ])
        .arg(dir.join("scenarios"))
        .arg("--out")
        .arg(dir.join("out"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report = std::fs::read_to_string(dir.join("out/report.md")).unwrap();
    let section = report
        .split("## Warnings of the FMUs")
        .nth(1)
        .and_then(|s| s.split("\n## ").next())
        .unwrap_or_else(|| panic!("no warnings section: {report}"));
    let rows: Vec<&str> = section
        .lines()
        .filter(|l| l.starts_with("| coarse |"))
        .collect();
    assert_eq!(rows.len(), 1, "{section}");
    assert!(
        rows[0].starts_with(
            "| coarse | `robust_of` | robust_of: fmi2DoStep: communication step 0.01 s"
        ),
        "{}",
        rows[0]
    );
    let _ = std::fs::remove_dir_all(&dir);
}
