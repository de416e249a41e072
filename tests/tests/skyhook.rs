//! The skyhook baseline (`dist/skyhook.fmu`, `synth::comfort::skyhook`) off its design model,
//! as a control engineer tries a controller before trusting it: on a constant grade and with
//! the accelerometers' bias (no steady force), with each actuator lost (no worse than the
//! passive car), and driven hard into its force limits (back to the unsaturated loop after).

use integration_tests::*;
use vehicle::road::{Profile, Road, Side};
use vehicle::terrain::Terrain;

const H: f64 = 1e-3;
const FORCES: [&str; 5] = ["f_fl", "f_fr", "f_rl", "f_rr", "f_seat"];

/// A level road at 20 m/s that rises `rise` m over `length` m from the front wheels' position
/// at t = 0, nothing else on it.
fn grade(rise: f64, length: f64) -> Road {
    Road::new(
        Profile::Bump {
            height: 0.0,
            length: 5.0,
            side: Side::Left,
        },
        20.0,
        2.4,
        0.0,
    )
    .and_then(|r| {
        r.with_terrain(Terrain {
            ramp_rise: rise,
            ramp_length: length,
            ..Terrain::default()
        })
    })
    .expect("a valid road")
}

fn mean(log: &[Vec<f64>], col: usize) -> f64 {
    log.iter().map(|r| r[col]).sum::<f64>() / log.len() as f64
}

/// 2 m over 800 m (a 0.25 % grade for 40 s at 20 m/s): after the kink at its start, every
/// force of the loop dies out on the grade, with ideal sensors and with the plant's sensor
/// model on (each accelerometer with a bias of up to 0.2 m/s², which an integrator would turn
/// into a drifting velocity: the estimator's zero gain at s = 0 takes it out).
#[test]
fn skyhook_leaves_no_steady_force_on_a_grade_nor_from_an_accelerometers_bias() {
    let plant = load("plant");
    let ctrl = load("skyhook");
    let road = grade(2.0, 800.0);
    let steps = (40.0 / H) as usize;
    let from = (25.0 / H) as usize;
    for sensor_model in [0.0, 1.0] {
        let log = run_loop_with(
            &plant,
            Some(&ctrl),
            &road,
            H,
            steps,
            &FORCES,
            &[("sensor_model", sensor_model)],
        );
        let early = (0..5).map(|k| peak(&log, k)).fold(0.0, f64::max);
        let tail = &log[from..];
        for (k, name) in FORCES.iter().enumerate() {
            let (m, p) = (mean(tail, k), peak(tail, k));
            eprintln!("sensor model {sensor_model}: {name} mean {m:.3e} N, peak {p:.3e} N over 25–40 s (peak of the run {early:.1} N)");
            if sensor_model == 0.0 {
                // No noise: the force itself decays (the slowest mode, the estimator's double
                // pole at 0.3 Hz, is e^{-1.9 t}: gone 20 s after the kink).
                assert!(p < 1e-3, "{name}: {p} N on the grade");
            } else {
                // Noise stays (a few newtons, the noise density through the estimator); the
                // bias leaves no mean force.
                assert!(m.abs() < 0.5, "{name}: mean force {m} N from the bias");
                assert!(p < 50.0, "{name}: peak {p} N");
            }
        }
        assert!(
            early > 1.0,
            "the kink must excite the loop (peak {early} N)"
        );
    }
}

/// With each actuator giving no force (its controller not told), and with every corner's or the
/// seat's lost, the car on the class C road is no worse than the passive car: the skyhook is
/// stable on its own and adds damping wherever an actuator still works.
#[test]
fn skyhook_is_no_worse_than_the_passive_car_with_any_actuator_lost() {
    let plant = load("plant");
    let ctrl = load("skyhook");
    let road = iso_road(3, 20.0, 7);
    let steps = (10.0 / H) as usize;
    let record = [
        "a_seat_wk",
        "stroke_fl",
        "stroke_fr",
        "stroke_rl",
        "stroke_rr",
    ];
    let seat = |log: &[Vec<f64>]| rms(&log[(2.0 / H) as usize..], 0);
    let passive = seat(&run_loop(&plant, None, &road, H, steps, &record));
    let mut losses: Vec<(String, Vec<&str>)> = vehicle::model::ACTUATORS
        .iter()
        .map(|a| (format!("{a} lost"), vec![*a]))
        .collect();
    losses.push(("every corner lost".into(), vec!["fl", "fr", "rl", "rr"]));
    for (label, lost) in &losses {
        let names: Vec<String> = lost.iter().map(|a| format!("fault_loss_{a}")).collect();
        let mut params = vec![("fault_time", 0.0)];
        params.extend(names.iter().map(|n| (n.as_str(), 1.0)));
        let log = run_loop_with(&plant, Some(&ctrl), &road, H, steps, &record, &params);
        let (active, stroke) = (
            seat(&log),
            (1..5).map(|k| peak(&log, k)).fold(0.0, f64::max),
        );
        eprintln!(
            "{label}: W_k seat {active:.4} m/s² (passive {passive:.4}), max stroke {stroke:.4} m"
        );
        assert!(
            active < passive,
            "{label}: {active} not below passive {passive}"
        );
        assert!(stroke < 0.08, "{label}: stroke {stroke} m");
    }
}

/// A 10 cm bump with the force limits cut to 150 N (corners) and 60 N (seat): the commands sit
/// at their limits through the bump; 6 s later the loop is the unsaturated one again (every
/// signal within 1e-3 of its run without limits' peak), because the controller's own states
/// are open-loop stable filters of the measurements, which no limit winds up.
#[test]
fn skyhook_comes_back_from_saturation() {
    let plant = load("plant");
    let ctrl = load("skyhook");
    let road = bump(0.10);
    let steps = (12.0 / H) as usize;
    let record = ["a_seat", "stroke_fl", "f_fl", "f_seat"];
    let free = run_loop(&plant, Some(&ctrl), &road, H, steps, &record);
    let limited = run_loop_with(
        &plant,
        Some(&ctrl),
        &road,
        H,
        steps,
        &record,
        &[("u_max", 150.0), ("u_max_seat", 60.0)],
    );
    let at_limit = limited
        .iter()
        .filter(|r| r[2].abs() >= 150.0 - 1e-9 || r[3].abs() >= 60.0 - 1e-9)
        .count();
    assert!(
        at_limit as f64 * H > 0.1,
        "the limits must bite: {} s at a limit",
        at_limit as f64 * H
    );
    // The largest difference between the runs over `[a, b]` s, relative to the free run's peak.
    let gap = |k: usize, a: f64, b: f64| {
        let (a, b) = ((a / H) as usize, (b / H) as usize);
        let d = free[a..b]
            .iter()
            .zip(&limited[a..b])
            .map(|(x, y)| (x[k] - y[k]).abs())
            .fold(0.0, f64::max);
        d / peak(&free, k)
    };
    for (k, name) in record.iter().enumerate() {
        let (mid, late) = (gap(k, 4.0, 8.0), gap(k, 8.0, 12.0));
        eprintln!(
            "{name}: {:.2} s at a limit; the runs differ by {mid:.2e} of the peak over 4–8 s, \
             {late:.2e} over 8–12 s",
            at_limit as f64 * H
        );
        assert!(late < 1e-3 && late < 0.1 * mid, "{name}: {mid} then {late}");
    }
}
