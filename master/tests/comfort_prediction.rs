//! Prediction meets simulation: every comfort design's certificate predicts the ISO 2631-1
//! figures of the car on its design road (`synth::predict::continuous`, a frequency integral on the
//! car's own model, independent of the design's LMIs and Riccati equations); the co-simulation
//! of the shipped FMUs — road FMU on the design road, plant FMU, controller FMU, the master's
//! loop — measures them. They agree within 5 % for every design and the passive car, and for
//! each robust design at the ends of its uncertainty and where its prediction is worst, both
//! continuous and as a master runs it (the plant FMU's parameters its certificate gives for
//! each condition: mass, actuator delay — which `delay_sf`'s predictor gets too, by the same
//! name `tau` — or actuator faults).
//!
//! The measurement: 60 s per road seed (the first 5 s dropped: fade-in and the filters'
//! transient), mean squares averaged over the seeds. A finite window of the road FMU's 400
//! cosines is not their infinite-time mean square: neighbouring cosines (1.4 % apart in
//! frequency) beat with periods near a minute around the body modes, so one window of a
//! lightly damped response is off by several per cent, at random with the phases. Measured: a
//! controller's figures within 1.3 % of the prediction on one seed, the passive car's (narrow
//! seat, roll and pitch resonances) up to 7 % off on one and 5 % on the mean of four; a
//! controlled car with a resonance left (`ft_of` with every actuator at half effectiveness,
//! before it accommodated faults: its seat isolation half lost) spread by 4.7 % per seed, and on
//! the mean of 12 seeds was still 5.5 % off (2.5 % on 32, like the passive car's 2.0 % on 16).
//! So a controller gets 3 seeds, one whose predicted seat figure is over a fifth of the passive
//! car's (a resonance left) 32, the passive car 16. `ft_of`'s faults start at t = 0, where its
//! effectiveness estimate is exact from the first commanded step (no transient to drop).
//!
//! A case that is another's loop run differently — continuous rather than held, in another
//! master order, with the sensor model on — is measured relative to that one on the same road
//! seeds (a ratio estimator, the reference a control variate): its mean square on 2 seeds, over
//! the reference's on those seeds, times the reference's on all of its own. The same road
//! drives both, so the beating that makes one seed's figure several per cent off is common to
//! them: measured on 28 November 2026, the ratio varied per seed by 0.3 % between the
//! continuous and the held loop, 1 % between master orders and 0.3 % with the sensor model, and
//! the estimate on 3 seeds came within 0.33 % of the same case's own mean over its 12 or 32
//! seeds (`lqg` and `skyhook` continuous within 0.01 % of 32 seeds, at a tenth of the runs). On
//! 1 December 2026 the estimate on 2 seeds came within 0.43 % of the one on 3 for every such
//! case (`robust_sf` in the Jacobi order; all others within 0.25 %), at 57 % of the test's time
//! (3 min 52 s → 2 min 11 s run alone), every case's error against its prediction inside
//! −2.7 … +2.6 % either way.
//! Cases whose ratio spreads more run their own seeds: another communication step (up to 3 %
//! per seed, `robust_sf` at 5 ms) and first-order actuators (4 % at 5 Hz).
//!
//! Each controller that reads the car's sensors (`sensor_*`) runs with the plant's sensor model
//! on too (production noise and bias, a noise stream per seed) against its noise-free `held`
//! prediction, and against the same runs without it: the sensor model moves W_k seat by less
//! than 1 % (measured: below 0.1 %), below the predictions' resolution.
//!
//! Each controller with first-order actuators of each bandwidth at which its certificate
//! predicts the loop a master runs (`actuator_lag[].held`, the plant's `actuator_bandwidth`)
//! runs against that prediction at its step.
//!
//! Each controller runs three times. At a 0.1 ms communication step against the certificate's
//! continuous-time prediction (a sample-and-hold acts on a loop like a delay of half a step),
//! at the certificate's own step (1 ms, the scenarios') against `comfort.held`, the
//! prediction of the sampled-data loop a master runs (`synth::predict::sampled`; exact against a
//! sinusoidal road in `tests/tests/sampled_loop.rs`), and at the largest step whose held
//! `W_k` seat the certificate gives (`comfort.communication_steps`) and the road FMU can
//! excite (below), on 12 seeds or more. The passive car has
//! no sampled loop and runs at 1 ms (seed 7: the same figure to 2e-5 relative at both steps).
//! The weighted figures are the plant's own weighted outputs (its vibration meter,
//! `vehicle::iso2631::ComfortMeter`), sampled at the communication points.

mod common;

use common::{certificates, dist};
use master::cosim::{run, Scenario};
use master::metrics::rms;
use rayon::prelude::*;
use std::collections::BTreeMap;

const DURATION: f64 = 60.0;
const SKIP: f64 = 5.0;
const TOLERANCE: f64 = 0.05;
/// Road seeds of a case measured relative to another.
const RELATIVE_SEEDS: u64 = 2;
/// The label's suffix of a case with the plant's sensor model on.
const NOISY: &str = ", sensor noise and bias";

/// The certificate's ISO class letter and speed as the road FMU's parameters.
fn scenario(
    seed: u64,
    step: f64,
    road: &serde_json::Value,
    plant: &BTreeMap<String, f64>,
    order: &str,
) -> Scenario {
    let class = road["iso_class"].as_str().expect("iso_class");
    let class = 1 + (class.as_bytes()[0] - b'A') as i64;
    let speed = road["speed_m_s"].as_f64().expect("speed");
    assert_eq!(road["tracks"], "independent");
    // With the sensor model on, a noise stream of its own per road seed.
    let mut plant = plant.clone();
    if plant.contains_key("sensor_model") {
        plant.insert("sensor_seed".into(), seed as f64);
    }
    let text = serde_json::json!({
        "name": format!("prediction_{seed}"),
        "duration": DURATION,
        "step": step,
        "road": {"profile": 2, "iso_class": class, "seed": seed, "speed": speed},
        "plant": plant,
        "order": order,
    });
    serde_json::from_value(text).expect("a scenario")
}

/// One co-simulation to compare with a prediction.
struct Case {
    label: String,
    /// None: the passive car.
    controller: Option<String>,
    plant: BTreeMap<String, f64>,
    /// `(W_k seat, W_e roll, W_e pitch)` RMS; NaN where a figure is not predicted.
    predicted: [f64; 3],
    /// Road seeds to average over.
    seeds: u64,
    /// The communication step [s].
    step: f64,
    /// The master's order (`master::cosim::Order`, by its name in the certificate).
    order: String,
    /// The label of the case this one is measured relative to (its first `seeds` seeds), or
    /// `None`: measured on its own seeds.
    relative_to: Option<String>,
}

impl Case {
    fn new(
        label: String,
        controller: Option<String>,
        plant: BTreeMap<String, f64>,
        predicted: [f64; 3],
        passive: f64,
    ) -> Case {
        let seeds = match &controller {
            None => 16,
            Some(_) if predicted[0] > 0.2 * passive => 32,
            Some(_) => 3,
        };
        // The continuous loop's prediction, approached at a fine step; the passive car has
        // no sampled loop.
        let step = match &controller {
            Some(_) => 1e-4,
            None => 1e-3,
        };
        Case {
            label,
            controller,
            plant,
            predicted,
            seeds,
            step,
            order: "gauss_seidel".into(),
            relative_to: None,
        }
    }

    /// The same, measured relative to the case labelled `reference` on its first road seeds
    /// (the module's doc).
    fn relative_to(mut self, reference: &str) -> Case {
        self.relative_to = Some(reference.into());
        self.seeds = RELATIVE_SEEDS;
        self
    }

    /// A certificate's `held` prediction (the loop as a master runs it at its step).
    fn held(
        label: String,
        variant: &str,
        plant: BTreeMap<String, f64>,
        held: &serde_json::Value,
        passive: f64,
    ) -> Case {
        let mut case = Case::new(
            label,
            Some(variant.into()),
            plant,
            figures(&held["predicted"]),
            passive,
        );
        case.step = held["step_s"].as_f64().expect("step_s");
        // Ten times cheaper per run than the fine step: more seeds (3 left `ft_of` 4.0 % off,
        // 16 1.4 %).
        case.seeds = case.seeds.max(12);
        case
    }

    /// A certificate's held `W_k` seat at another communication step
    /// (`comfort.communication_steps`), as a master records it, at the nominal car.
    fn at_step(variant: &str, checked: &serde_json::Value, passive: f64) -> Case {
        let step = checked["step_s"].as_f64().expect("step_s");
        let seat = checked["comfort"]["nominal"]["recorded_wk_rms_seat_m_s2"]
            .as_f64()
            .expect("a held W_k seat");
        let label = format!("{variant} at {} ms", step * 1e3);
        let mut case = Case::held_seat(label, variant, seat, step, passive);
        // The linear loop the figure is about: near its largest step a design's commands grow
        // (`delay_sf` at 10 ms held its seat actuator at 1000 N 4.6 % of the time on road seed
        // 3, measuring 0.123 against 0.060 without the limits, the prediction 0.061). The
        // saturated loop is the certificate's `saturation` check's. Likewise the strokes grow
        // past the travel the physical car has (`hinf_sf` and `robust_sf` at 5 ms, `delay_sf`
        // at 10 ms, measured 5 % or more off with the stops and tyre contact on): the linear car.
        case.plant = BTreeMap::from([
            ("u_max".into(), 1e6),
            ("u_max_seat".into(), 1e6),
            ("contact_model".into(), 0.0),
        ]);
        case
    }

    /// A certificate's held `W_k` seat in a master order (`comfort.master_orders`), as that
    /// master records it, at the nominal car and the certificate's step.
    fn in_order(variant: &str, order: &str, seat: f64, step: f64, passive: f64) -> Case {
        let label = format!("{variant} {order}");
        let mut case = Case::held_seat(label, variant, seat, step, passive);
        case.order = order.into();
        case
    }

    /// A held `W_k` seat as a master records it at `step`, the nominal car.
    fn held_seat(label: String, variant: &str, seat: f64, step: f64, passive: f64) -> Case {
        let mut case = Case::new(
            label,
            Some(variant.into()),
            BTreeMap::new(),
            [seat, f64::NAN, f64::NAN],
            passive,
        );
        case.step = step;
        case.seeds = case.seeds.max(12);
        case
    }
}

/// `(W_k seat, W_e roll, W_e pitch)` RMS of a certificate's figures.
fn figures(f: &serde_json::Value) -> [f64; 3] {
    [
        f["wk_rms_seat_m_s2"].as_f64().unwrap(),
        f["we_rms_roll_rad_s2"].as_f64().unwrap(),
        f["we_rms_pitch_rad_s2"].as_f64().unwrap(),
    ]
}

/// Measured `(W_k seat, W_e roll, W_e pitch)` RMS of every case: its mean squares averaged over
/// its seeds, or for a case relative to another their ratio on its seeds times the other's
/// average; every run of every case in parallel.
fn measure(cases: &[Case], road: &serde_json::Value) -> Vec<[f64; 3]> {
    let jobs: Vec<(usize, u64)> = cases
        .iter()
        .enumerate()
        .flat_map(|(i, c)| (1..=c.seeds).map(move |seed| (i, seed)))
        .collect();
    let squares: Vec<(usize, [f64; 3])> = jobs
        .into_par_iter()
        .map(|(i, seed)| {
            let case = &cases[i];
            let step = case.step;
            let scenario = scenario(seed, step, road, &case.plant, &case.order);
            let r = run(&dist(), &scenario, case.controller.as_deref())
                .unwrap_or_else(|e| panic!("{}, seed {seed}: {e}", case.label));
            // The plant's vibration meter: the weighted accelerations integrated with the car.
            let mean_square = |name: &str| -> f64 {
                let y = r.column(name).expect("recorded");
                rms(&y[(SKIP / step).round() as usize..]).powi(2)
            };
            (
                i,
                vehicle::iso2631::METER_OUTPUTS.map(|(name, ..)| mean_square(name)),
            )
        })
        .collect();
    // Each case's mean squares per seed, in the order of its seeds.
    let per_seed: Vec<Vec<[f64; 3]>> = (0..cases.len())
        .map(|i| {
            squares
                .iter()
                .filter(|(j, _)| *j == i)
                .map(|(_, m)| *m)
                .collect()
        })
        .collect();
    let mean = |i: usize, seeds: usize, k: usize| {
        per_seed[i][..seeds].iter().map(|m| m[k]).sum::<f64>() / seeds as f64
    };
    cases
        .iter()
        .enumerate()
        .map(|(i, case)| {
            let n = per_seed[i].len();
            let Some(label) = &case.relative_to else {
                return std::array::from_fn(|k| mean(i, n, k).sqrt());
            };
            let r = cases
                .iter()
                .position(|c| &c.label == label)
                .unwrap_or_else(|| panic!("{}: no case '{label}'", case.label));
            let all = per_seed[r].len();
            assert!(
                cases[r].relative_to.is_none() && n <= all,
                "{}: '{label}' must be measured on its own and on these seeds",
                case.label
            );
            std::array::from_fn(|k| (mean(i, n, k) / mean(r, n, k) * mean(r, all, k)).sqrt())
        })
        .collect()
}

#[test]
fn cosimulated_comfort_is_the_certificates_prediction() {
    let certificates: Vec<(String, serde_json::Value)> = certificates()
        .into_iter()
        .filter(|(_, c)| c["objective"] == "comfort")
        .collect();
    assert!(
        certificates.len() >= 5,
        "expected the comfort designs in {}",
        dist().display()
    );
    // The road every prediction is for (the designs' models of it may differ: rear_wheels).
    let predicted_road = |c: &serde_json::Value| {
        ["iso_class", "speed_m_s", "tracks", "band_hz"].map(|k| c["comfort"]["road"][k].clone())
    };
    let road = predicted_road(&certificates[0].1);
    let passive = figures(&certificates[0].1["comfort"]["passive"]);
    let mut cases = vec![Case::new(
        "passive".into(),
        None,
        BTreeMap::new(),
        passive,
        passive[0],
    )];
    for (variant, c) in &certificates {
        let comfort = &c["comfort"];
        assert_eq!(predicted_road(c), road, "{variant}: another design road");
        // The continuous loop, relative to the held one (below).
        let held_label = format!("{variant} held");
        cases.push(
            Case::new(
                variant.clone(),
                Some(variant.clone()),
                BTreeMap::new(),
                figures(&comfort["predicted"]),
                passive[0],
            )
            .relative_to(&held_label),
        );
        // As a master runs it, at the certificate's communication step.
        cases.push(Case::held(
            held_label.clone(),
            variant,
            BTreeMap::new(),
            &comfort["held"],
            passive[0],
        ));
        // At the largest communication step whose comfort it predicts and the road FMU can
        // excite: its sharpest resonance over the band at least 5 % wide. The road's cosines
        // are 1.4 % apart, so a narrower peak falls between them (`ft_of` at 7.5 ms: a hold
        // mode at 30.8 Hz 6·10⁻⁵ wide, predicted 0.175 on the continuous spectrum the
        // certificate assumes, measured 0.040), and a run of 55 s does not settle it.
        let largest = comfort["communication_steps"]["checked"]
            .as_array()
            .expect("checked steps")
            .iter()
            .rfind(|s| {
                s["comfort"]["nominal"]["sharpest_resonance"]["relative_half_width"]
                    .as_f64()
                    .is_some_and(|w| w >= 0.05)
            })
            .expect("a step with its comfort");
        if largest["step_s"] != comfort["held"]["step_s"] {
            cases.push(Case::at_step(variant, largest, passive[0]));
        }
        // In each master order: the default one is `held` (measured above), the others are
        // measured each in its own order. A predictor's commands in flight are kept for the
        // default order only, and the certificate says so.
        let held_step = comfort["held"]["step_s"].as_f64().expect("step_s");
        for o in comfort["master_orders"].as_array().expect("master_orders") {
            let order = o["order"].as_str().expect("order");
            let seat = o["recorded_wk_rms_seat_m_s2"].as_f64();
            match (order, seat) {
                ("gauss_seidel", Some(seat)) => assert_eq!(
                    seat.to_bits(),
                    comfort["held"]["recorded_wk_rms_seat_m_s2"]
                        .as_f64()
                        .unwrap()
                        .to_bits(),
                    "{variant}: the default order's figure is `held`'s"
                ),
                (_, Some(seat)) => cases.push(
                    Case::in_order(variant, order, seat, held_step, passive[0])
                        .relative_to(&held_label),
                ),
                (_, None) => assert!(
                    order != "gauss_seidel"
                        && o["verdict"]
                            .as_str()
                            .is_some_and(|v| v.starts_with("not modelled")),
                    "{variant} in {order}: no figure ({})",
                    o["verdict"]
                ),
            }
        }
        // A controller on the car's sensors (`sensor_*`) with the plant's sensor model on (each
        // sensor's production noise and bias): as a master runs it, against the noise-free
        // prediction. The noise is in none of the predictions: this holds it to below their
        // resolution.
        if c["measurements"]
            .as_array()
            .expect("measurements")
            .iter()
            .any(|m| m.as_str().is_some_and(|m| m.starts_with("sensor_")))
        {
            cases.push(
                Case::held(
                    format!("{held_label}{NOISY}"),
                    variant,
                    BTreeMap::from([("sensor_model".to_string(), 1.0)]),
                    &comfort["held"],
                    passive[0],
                )
                .relative_to(&held_label),
            );
        }
        // With first-order actuators (`actuator_lag`), where its loop is stable as a master
        // runs it: its held prediction (the lag's forces states of the sampled car), at its
        // step. The continuous prediction with the lag, which the held one tends to as the
        // step shrinks (`synth::predict::sampled`'s test), is not run: at 0.1 ms these cases
        // were half of this test's time.
        for lag in c["actuator_lag"].as_array().expect("actuator_lag") {
            let Some(held) = lag.get("held") else {
                continue;
            };
            let hz = lag["bandwidth_hz"].as_f64().expect("bandwidth_hz");
            // The lag leaves a resonance less damped: 3 seeds left `hinf_sf` at 10 Hz 5.6 %
            // below its prediction (single seeds spread 0.0389…0.0456), 16 seeds 2.4 %;
            // `Case::held` runs 12 or more.
            cases.push(Case::held(
                format!("{variant} {hz} Hz actuators"),
                variant,
                BTreeMap::from([("actuator_bandwidth".to_string(), hz)]),
                held,
                passive[0],
            ));
        }
        // Over its uncertainty: the first and last conditions and the worst.
        let Some(u) = comfort.get("uncertainty") else {
            continue;
        };
        let predictions = u["predictions"].as_array().expect("predictions");
        let plants = u["plant_parameters"].as_array().expect("plant parameters");
        assert_eq!(predictions.len(), plants.len());
        let seat = |k: usize| predictions[k][1]["wk_rms_seat_m_s2"].as_f64().unwrap();
        let worst = (0..predictions.len())
            .max_by(|a, b| seat(*a).total_cmp(&seat(*b)))
            .expect("predictions");
        let mut picked = vec![0, predictions.len() - 1, worst];
        picked.sort_unstable();
        picked.dedup();
        for k in picked {
            let plant: BTreeMap<String, f64> =
                serde_json::from_value(plants[k].clone()).expect("parameters");
            if plant.is_empty() {
                continue; // the nominal car, measured above
            }
            let label = format!("{variant} at {}", predictions[k][0].as_str().unwrap());
            let held_label = format!("{label} held");
            cases.push(
                Case::new(
                    label.clone(),
                    Some(variant.clone()),
                    plant.clone(),
                    figures(&predictions[k][1]),
                    passive[0],
                )
                .relative_to(&held_label),
            );
            // And as a master runs it there.
            let held = &u["held"][k];
            assert!(held.is_object(), "{label}: no held prediction: {held}");
            cases.push(Case::held(held_label, variant, plant, held, passive[0]));
        }
    }
    let mut failures = Vec::new();
    let road = &certificates[0].1["comfort"]["road"];
    let all = measure(&cases, road);
    // The sensor model's own effect, run against run on the same roads: under 1 % of W_k seat.
    let seat_of = |label: &str| {
        cases
            .iter()
            .position(|c| c.label == label)
            .map(|i| all[i][0])
    };
    for case in cases
        .iter()
        .filter(|c| c.plant.contains_key("sensor_model"))
    {
        let clean = case
            .label
            .strip_suffix(NOISY)
            .and_then(seat_of)
            .expect("the same case without the sensor model");
        let effect = seat_of(&case.label).unwrap() / clean - 1.0;
        println!(
            "{}: the sensor model moves W_k seat by {:+.2} %",
            case.label,
            100.0 * effect
        );
        if effect.abs() > 0.01 {
            failures.push(format!("{} (the sensor model's effect)", case.label));
        }
    }
    for (case, measured) in cases.iter().zip(all.iter().copied()) {
        let (name, predicted) = (&case.label, &case.predicted);
        let errors: Vec<Option<f64>> = (0..3)
            .map(|k| (!predicted[k].is_nan()).then(|| measured[k] / predicted[k] - 1.0))
            .collect();
        let shown: Vec<String> = ["W_k seat", "W_e roll", "W_e pitch"]
            .iter()
            .enumerate()
            .map(|(k, figure)| match errors[k] {
                Some(e) => format!(
                    "{figure} {:.5} (predicted {:.5}, {:+.1} %)",
                    measured[k],
                    predicted[k],
                    100.0 * e
                ),
                None => format!("{figure} {:.5}", measured[k]),
            })
            .collect();
        println!("{name:>24}: {}", shown.join(", "));
        if errors
            .iter()
            .flatten()
            .any(|e| e.is_nan() || e.abs() > TOLERANCE)
        {
            failures.push(name.clone());
        }
    }
    assert!(
        failures.is_empty(),
        "measured comfort off its prediction by more than {} %: {failures:?}",
        100.0 * TOLERANCE
    );
}
