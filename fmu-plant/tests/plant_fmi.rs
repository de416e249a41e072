//! The plant FMU through its exported C functions. Each physical effect of the actuator chain
//! is checked against an independent construction of the same trajectory (a delayed copy, a
//! step split at the breakpoint, a closed form), so the sub-stepping logic cannot hide.

mod common;

use fmi_test_logger::LogCapture;
use fmu_core::types::*;
use fmu_plant::*;
use std::ptr::{null, null_mut};

const OK: i32 = 0;
const DISCARD: i32 = 2;
const ERROR: i32 = 3;

struct Plant<'a> {
    c: Fmi2Component,
    desc: fmu_core::ModelDescription,
    _log: &'a LogCapture,
    _cb: Box<fmi_test_logger::Callbacks>,
}

impl<'a> Plant<'a> {
    fn new(log: &'a LogCapture) -> Self {
        let (c, desc, cb) = common::instantiate(log, FMI2_CO_SIMULATION);
        Plant {
            c,
            desc,
            _log: log,
            _cb: cb,
        }
    }
    fn vr(&self, name: &str) -> u32 {
        self.desc
            .variable(name)
            .unwrap_or_else(|| panic!("no variable {name}"))
            .value_reference
    }
    fn set(&self, name: &str, v: f64) -> i32 {
        let vr = self.vr(name);
        unsafe { fmi2SetReal(self.c, &vr, 1, &v) }
    }
    fn der(&self, name: &str, v: f64) -> i32 {
        let vr = self.vr(name);
        unsafe { fmi2SetRealInputDerivatives(self.c, &vr, 1, &1, &v) }
    }
    fn get(&self, name: &str) -> f64 {
        let vr = self.vr(name);
        let mut v = f64::NAN;
        assert_eq!(
            unsafe { fmi2GetReal(self.c, &vr, 1, &mut v) },
            OK,
            "{name}: {:?}",
            self._log.messages()
        );
        v
    }
    fn states(&self) -> Vec<f64> {
        (1..=16).map(|k| self.get(&format!("x[{k}]"))).collect()
    }
    fn init(&self, t0: f64) {
        unsafe {
            assert_eq!(fmi2SetupExperiment(self.c, 0, 0.0, t0, 0, 0.0), OK);
            assert_eq!(fmi2EnterInitializationMode(self.c), OK);
            assert_eq!(fmi2ExitInitializationMode(self.c), OK);
        }
    }
    fn step(&self, t: f64, h: f64) -> i32 {
        unsafe { fmi2DoStep(self.c, t, h, 1) }
    }
}

impl Drop for Plant<'_> {
    fn drop(&mut self) {
        unsafe { fmi2FreeInstance(self.c) }
    }
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

fn max_abs(a: &[f64]) -> f64 {
    a.iter().map(|x| x.abs()).fold(0.0, f64::max)
}

#[test]
fn checked_in_model_description_is_not_stale() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../modelDescription/plant.xml");
    let on_disk = std::fs::read_to_string(path).expect("modelDescription/plant.xml exists");
    assert!(
        on_disk == fmu_plant::Plant::model_description().to_xml(),
        "modelDescription/plant.xml is stale: run `make descriptions` and commit it"
    );
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../modelDescription/fmi3/plant.xml"
    );
    let on_disk = std::fs::read_to_string(path).expect("modelDescription/fmi3/plant.xml exists");
    assert!(
        on_disk == fmu_plant::Plant::model_description().to_xml3(),
        "modelDescription/fmi3/plant.xml is stale: run `make descriptions` and commit it"
    );
}

#[test]
fn readme_variable_table_is_not_stale() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../README.md");
    let readme = std::fs::read_to_string(path).expect("README.md exists");
    let table = fmu_plant::Plant::model_description().to_markdown_table();
    let expected = fmu_core::ModelDescription::splice_into(&readme, "plant-variables", &table)
        .expect("README has the plant-variables markers");
    assert!(
        readme == expected,
        "README.md's plant variable table is stale: run `make descriptions` and commit it"
    );
}

#[test]
fn description_has_every_variable_the_issue_names_with_units() {
    let d = fmu_plant::Plant::model_description();
    d.check().unwrap();
    let unit = |n: &str| {
        d.variable(n)
            .unwrap_or_else(|| panic!("missing {n}"))
            .unit()
            .unwrap()
    };
    for c in ["fl", "fr", "rl", "rr"] {
        assert_eq!(unit(&format!("road_z_{c}")), "m");
        assert_eq!(unit(&format!("road_v_{c}")), "m/s");
        assert_eq!(unit(&format!("u_{c}")), "N");
        assert_eq!(unit(&format!("stroke_{c}")), "m");
        assert_eq!(unit(&format!("tire_defl_{c}")), "m");
        assert_eq!(unit(&format!("tire_load_{c}")), "N");
        assert_eq!(unit(&format!("f_{c}")), "N");
        assert_eq!(unit(&format!("fault_loss_{c}")), "1");
    }
    for (n, u) in [
        ("u_seat", "N"),
        ("a_seat", "m/s2"),
        ("a_body", "m/s2"),
        ("alpha_roll", "rad/s2"),
        ("alpha_pitch", "rad/s2"),
        ("stroke_seat", "m"),
        ("f_seat", "N"),
        ("u_max", "N"),
        ("tau", "s"),
        ("fault_time", "s"),
        ("actuator_bandwidth", "Hz"),
        ("m_s", "kg"),
        ("I_x", "kg.m2"),
        ("k_t", "N/m"),
        ("c_t", "N.s/m"),
        ("x[1]", "m"),
        ("x[2]", "rad"),
        ("x[16]", "m/s"),
    ] {
        assert_eq!(unit(n), u, "{n}");
    }
    // a_seat feeds through from the seat actuator command only, not from the road.
    let a_seat = d.variable("a_seat").unwrap();
    assert_eq!(
        a_seat.depends_on,
        vec![("u_seat".to_string(), fmu_core::DependencyKind::Dependent)]
    );
    assert!(d.variable("x[1]").unwrap().depends_on.is_empty());
}

#[test]
fn flat_road_and_zero_force_nothing_moves() {
    let log = LogCapture::default();
    let p = Plant::new(&log);
    p.init(0.0);
    for k in 0..1000 {
        assert_eq!(p.step(k as f64 * 0.01, 0.01), OK);
    }
    assert!(p.states().iter().all(|&v| v == 0.0));
    assert_eq!(p.get("a_seat"), 0.0);
    // The static values are there for the engineer.
    assert!(p.get("static_stroke_fl") < -0.05 && p.get("static_tire_load_fl") > 3000.0);
}

/// Run the plant with a force-command profile `cmd(t)` applied to the FL actuator, held over
/// each communication step, returning the states after every step.
fn run_fl(setup: &[(&str, f64)], h: f64, steps: usize, cmd: impl Fn(f64) -> f64) -> Vec<Vec<f64>> {
    let log = LogCapture::default();
    let p = Plant::new(&log);
    for (n, v) in setup {
        assert_eq!(p.set(n, *v), OK, "{n}");
    }
    p.init(0.0);
    let mut out = Vec::new();
    for k in 0..steps {
        let t = k as f64 * h;
        p.set("u_fl", cmd(t));
        assert_eq!(p.step(t, h), OK, "{:?}", log.messages());
        out.push(p.states());
    }
    out
}

#[test]
fn delay_shifts_the_response_by_tau() {
    let h = 1e-3;
    let cmd = |t: f64| {
        if t >= 0.05 {
            1500.0 * (1.0 + (7.0 * t).sin())
        } else {
            0.0
        }
    };
    let plain = run_fl(&[], h, 400, cmd);
    // τ a whole number of steps: the trajectory is the plain one, delayed.
    let delayed = run_fl(&[("tau", 0.02)], h, 400, cmd);
    for k in 20..400 {
        assert!(
            max_diff(&delayed[k], &plain[k - 20]) < 1e-12 * max_abs(&plain[k - 20]).max(1e-9),
            "step {k}"
        );
    }
    // τ between steps: cut into two pieces per step. The same physics at half the step, with
    // the command changing only every other half step, is an independent construction.
    let half = run_fl(&[("tau", 0.0205)], h, 400, cmd);
    let fine = run_fl(&[("tau", 0.0205)], h / 2.0, 800, |t| {
        cmd((t / h).floor() * h)
    });
    let scale = max_abs(&fine[799]);
    for k in 0..400 {
        assert!(
            max_diff(&half[k], &fine[2 * k + 1]) < 1e-10 * scale,
            "step {k}: {}",
            max_diff(&half[k], &fine[2 * k + 1])
        );
    }
    assert!(
        max_diff(&half[399], &delayed[399]) > 1e-6 * scale,
        "a half-step more delay must show"
    );
}

#[test]
fn saturation_clips_the_command_and_ramps_are_cut_where_they_cross_the_limit() {
    let log = LogCapture::default();
    let p = Plant::new(&log);
    p.set("u_max", 2500.0);
    p.init(0.0);
    p.set("u_fl", 5000.0);
    p.set("u_seat", -3000.0);
    assert_eq!(p.get("f_fl"), 2500.0);
    assert_eq!(p.get("f_seat"), -1000.0, "seat limit u_max_seat = 1 kN");

    // One step with a ramp crossing the limit at t = 0.25 s …
    let a = Plant::new(&log);
    a.init(0.0);
    a.set("u_fl", 0.0);
    a.der("u_fl", 10_000.0);
    assert_eq!(a.step(0.0, 0.5), OK);
    // … equals a ramp up to the limit, then the limit held.
    let b = Plant::new(&log);
    b.init(0.0);
    b.set("u_fl", 0.0);
    b.der("u_fl", 10_000.0);
    assert_eq!(b.step(0.0, 0.25), OK);
    b.set("u_fl", 2500.0);
    assert_eq!(b.step(0.25, 0.25), OK);
    let (xa, xb) = (a.states(), b.states());
    assert!(
        max_diff(&xa, &xb) < 1e-13 * max_abs(&xb),
        "{}",
        max_diff(&xa, &xb)
    );
    // Without the cut (an unsaturated ramp to 5 kN) the answer is clearly different.
    let c = Plant::new(&log);
    c.set("u_max", 1e9);
    c.init(0.0);
    c.der("u_fl", 10_000.0);
    c.step(0.0, 0.5);
    assert!(max_diff(&c.states(), &xb) > 1e-3 * max_abs(&xb));
}

#[test]
fn fault_halves_the_force_from_fault_time_even_inside_a_step() {
    let setup = [("fault_time", 0.2), ("fault_loss_fl", 0.5)];
    let log = LogCapture::default();
    let p = Plant::new(&log);
    for (n, v) in setup {
        p.set(n, v);
    }
    p.init(0.0);
    p.set("u_fl", 1000.0);
    assert_eq!(p.get("f_fl"), 1000.0);
    p.step(0.0, 0.15);
    p.step(0.15, 0.15); // crosses t = 0.2
    assert_eq!(p.get("f_fl"), 500.0);
    let across = p.states();
    // Independent construction: stop at the fault time exactly.
    let q = Plant::new(&log);
    for (n, v) in setup {
        q.set(n, v);
    }
    q.init(0.0);
    q.set("u_fl", 1000.0);
    q.step(0.0, 0.15);
    q.step(0.15, 0.05);
    q.step(0.2, 0.1);
    assert!(max_diff(&across, &q.states()) < 1e-13 * max_abs(&across));
}

#[test]
fn actuator_bandwidth_is_a_first_order_lag() {
    let log = LogCapture::default();
    let p = Plant::new(&log);
    let f_a = 5.0;
    p.set("actuator_bandwidth", f_a);
    p.init(0.0);
    p.set("u_seat", 800.0);
    assert_eq!(p.get("f_seat"), 0.0, "a lag starts from rest");
    for k in 0..50 {
        p.step(k as f64 * 0.002, 0.002);
    }
    let expected = 800.0 * (1.0 - (-2.0 * std::f64::consts::PI * f_a * 0.1).exp());
    assert!(
        (p.get("f_seat") - expected).abs() < 1e-9,
        "{} vs {expected}",
        p.get("f_seat")
    );
}

#[test]
fn input_derivatives_ramp_the_road_exactly() {
    let log = LogCapture::default();
    let one = Plant::new(&log);
    one.init(0.0);
    one.der("road_z_fl", 0.1);
    one.der("road_v_fl", 0.0);
    one.set("road_v_fl", 0.1);
    one.step(0.0, 0.2);
    let z = one.get("road_z_fl");
    assert!(
        (z - 0.02).abs() < 1e-15,
        "inputs move to their value at t + h"
    );
    let two = Plant::new(&log);
    two.init(0.0);
    two.set("road_v_fl", 0.1);
    two.der("road_z_fl", 0.1);
    two.step(0.0, 0.1);
    two.der("road_z_fl", 0.1);
    two.step(0.1, 0.1);
    assert!(max_diff(&one.states(), &two.states()) < 1e-13 * max_abs(&one.states()));
    // Derivatives hold for one step only: a third step keeps the road at 2 cm.
    one.step(0.2, 0.1);
    assert_eq!(one.get("road_z_fl"), z);
}

#[test]
fn variable_step_sizes_agree_with_uniform_ones() {
    let cmd = |t: f64| 800.0 * (t * 3.0).cos();
    let uniform = run_fl(&[("tau", 0.013)], 0.01, 100, cmd);
    let log = LogCapture::default();
    let p = Plant::new(&log);
    p.set("tau", 0.013);
    p.init(0.0);
    // Same communication points, each reached in two uneven halves with the same held command.
    for k in 0..100 {
        let t = k as f64 * 0.01;
        p.set("u_fl", cmd(t));
        p.step(t, 0.003);
        p.step(t + 0.003, 0.007);
    }
    let last = p.states();
    assert!(max_diff(&last, &uniform[99]) < 1e-11 * max_abs(&last));
}

#[test]
fn inadmissible_parameters_are_refused_with_a_message() {
    let log = LogCapture::default();
    for (name, value, msg) in [
        (
            "m_s",
            -1500.0,
            "fmi2SetReal: value -1500 of 'm_s' is below its minimum 1",
        ),
        // Values the FMU once accepted and then failed on (a panic in the static equilibrium,
        // or a matrix exponential that never returned): out of their physical range.
        (
            "k_t",
            1e-12,
            "value 1e-12 of 'k_t' is below its minimum 1000",
        ),
        (
            "I_x",
            1e-40,
            "value 1e-40 of 'I_x' is below its minimum 0.01",
        ),
        ("m_u", 1e-40, "below its minimum 0.1"),
        (
            "c_s_f",
            1e44,
            "value 1e44 of 'c_s_f' is above its maximum 1000000",
        ),
        ("L1", 1e20, "above its maximum 20"),
        ("I_y", 0.0, "below its minimum 0.01"),
        ("c_seat", -1.0, "below its minimum 0"),
        ("actuator_bandwidth", 1e40, "above its maximum"),
        ("u_max", -1.0, "-1 of 'u_max' is below its minimum 0"),
        ("tau", -0.01, "value -0.01 of 'tau' is below its minimum 0"),
        (
            "fault_loss_rr",
            1.5,
            "value 1.5 of 'fault_loss_rr' is above its maximum 1",
        ),
        (
            "bump_travel",
            -0.01,
            "value -0.01 of 'bump_travel' is below its minimum 0",
        ),
        (
            "seat_travel",
            2.0,
            "value 2 of 'seat_travel' is above its maximum 1",
        ),
        (
            "stop_stiffness",
            1e12,
            "'stop_stiffness' is above its maximum",
        ),
        (
            "seat_stop_damping",
            -5.0,
            "'seat_stop_damping' is below its minimum 0",
        ),
        ("rebound_travel", f64::NAN, "'rebound_travel'"),
    ] {
        let p = Plant::new(&log);
        let default = match p.desc.variable(name).unwrap().kind {
            fmu_core::VarType::Real { start, .. } => start.unwrap(),
            _ => unreachable!(),
        };
        assert_eq!(p.set(name, value), ERROR, "{name}");
        assert!(log.contains(msg), "{name}: {:?}", log.messages());
        // The instance is now in Error, where GetReal is legal: the parameter is unchanged.
        assert_eq!(p.get(name), default, "{name} unchanged");
    }
}

/// FMI's bounds are inclusive: the declared minimum 0 of a force limit is accepted, and an
/// actuator limited to 0 N gives no force whatever it is commanded (a lost actuator).
#[test]
fn a_force_limit_of_zero_is_accepted_and_the_actuator_gives_no_force() {
    let log = LogCapture::default();
    let p = Plant::new(&log);
    assert_eq!(p.set("u_max_seat", 0.0), OK, "{:?}", log.messages());
    assert_eq!(p.set("u_max", 0.0), OK, "{:?}", log.messages());
    p.init(0.0);
    for k in 0..50 {
        p.set("u_seat", 800.0);
        p.set("u_fl", -1500.0);
        assert_eq!(p.step(k as f64 * 1e-3, 1e-3), OK);
    }
    assert_eq!(p.get("f_seat"), 0.0);
    assert_eq!(p.get("f_fl"), 0.0);
    assert_eq!(
        max_abs(&p.states()),
        0.0,
        "a flat road and no force: nothing moves"
    );
}

/// The sensor model through the C API: off, every `sensor_*` output is its physical output to
/// the last bit; on, the readings differ from the truth by a bias within its bound plus noise,
/// repeat from the seed, and a state saved mid-run continues bit-identically in a fresh
/// instance.
#[test]
fn sensors_read_the_truth_when_off_and_repeat_their_noise_from_the_seed_and_a_state() {
    let log = LogCapture::default();
    let sensors: Vec<&str> = fmu_plant::sensors::SENSORS.iter().map(|s| s.0).collect();
    let drive = |p: &Plant, k: usize| {
        let t = k as f64 * 1e-3;
        p.set("road_z_fl", 0.01 * (7.0 * t).sin());
        p.set("road_z_rr", 0.01 * (5.0 * t).cos() - 0.01);
        p.set("u_seat", 200.0 * (3.0 * t).sin());
        assert_eq!(p.step(t, 1e-3), OK);
    };
    let readings = |p: &Plant| -> Vec<f64> {
        sensors
            .iter()
            .map(|n| p.get(&format!("sensor_{n}")))
            .collect()
    };
    let truth = |p: &Plant| -> Vec<f64> { sensors.iter().map(|n| p.get(n)).collect() };
    let off = Plant::new(&log);
    off.init(0.0);
    for k in 0..200 {
        drive(&off, k);
        let (r, t) = (readings(&off), truth(&off));
        assert!(
            r.iter().zip(&t).all(|(a, b)| a.to_bits() == b.to_bits()),
            "step {k}"
        );
    }
    let switched_on = |seed: i32| {
        let p = Plant::new(&log);
        let (vb, vi) = (p.vr("sensor_model"), p.vr("sensor_seed"));
        assert_eq!(unsafe { fmi2SetBoolean(p.c, &vb, 1, &1) }, OK);
        assert_eq!(unsafe { fmi2SetInteger(p.c, &vi, 1, &seed) }, OK);
        p.init(0.0);
        p
    };
    let (a, b, other) = (switched_on(11), switched_on(11), switched_on(12));
    let mut error_sum = vec![0.0; sensors.len()];
    for k in 0..300 {
        for p in [&a, &b, &other] {
            drive(p, k);
        }
        let (ra, rb) = (readings(&a), readings(&b));
        assert!(
            ra.iter().zip(&rb).all(|(x, y)| x.to_bits() == y.to_bits()),
            "step {k}"
        );
        assert_ne!(ra, readings(&other), "another seed, other readings");
        for (e, (r, t)) in error_sum.iter_mut().zip(ra.iter().zip(truth(&a))) {
            *e += r - t;
        }
    }
    // The mean error is the bias (within the noise's 4 σ / √300), itself within its bound.
    let defaults = fmu_plant::sensors::SensorParams::default();
    for (i, (name, kind)) in fmu_plant::sensors::SENSORS.iter().enumerate() {
        let bound = match kind {
            fmu_plant::sensors::Kind::Height => 0.0,
            fmu_plant::sensors::Kind::Accelerometer => defaults.bias_acceleration,
            fmu_plant::sensors::Kind::Gyro => defaults.bias_rate,
        };
        let sigma = defaults.sigma(*kind, 1e-3);
        let mean = error_sum[i] / 300.0;
        assert!(
            mean.abs() <= bound + 4.0 * sigma / 300f64.sqrt(),
            "{name}: {mean}"
        );
    }
    let bytes = serialized(&a);
    let c = Plant::new(&log);
    assert_eq!(restore_serialized(&c, &bytes), OK, "{:?}", log.messages());
    for k in 300..400 {
        drive(&a, k);
        drive(&c, k);
        let (ra, rc) = (readings(&a), readings(&c));
        assert!(
            ra.iter().zip(&rc).all(|(x, y)| x.to_bits() == y.to_bits()),
            "step {k}"
        );
    }
}

/// The state as a byte string, from `fmi2GetFMUstate` and `fmi2SerializeFMUstate`.
fn serialized(p: &Plant) -> Vec<Fmi2Byte> {
    let mut s: Fmi2FmuState = null_mut();
    assert_eq!(unsafe { fmi2GetFMUstate(p.c, &mut s) }, OK);
    let mut size = 0;
    assert_eq!(unsafe { fmi2SerializedFMUstateSize(p.c, s, &mut size) }, OK);
    let mut bytes = vec![0 as Fmi2Byte; size];
    assert_eq!(
        unsafe { fmi2SerializeFMUstate(p.c, s, bytes.as_mut_ptr(), size) },
        OK
    );
    unsafe { fmi2FreeFMUstate(p.c, &mut s) };
    bytes
}

/// Restore `bytes` into `p` (deserialise, set, free).
fn restore_serialized(p: &Plant, bytes: &[Fmi2Byte]) -> i32 {
    let mut s: Fmi2FmuState = null_mut();
    let status = unsafe { fmi2DeSerializeFMUstate(p.c, bytes.as_ptr(), bytes.len(), &mut s) };
    if status != OK {
        return status;
    }
    let status = unsafe { fmi2SetFMUstate(p.c, s) };
    unsafe { fmi2FreeFMUstate(p.c, &mut s) };
    status
}

/// FMI 2.0.4 allows getting and setting the state once instantiated and in Initialization
/// Mode. A state taken there, with or without parameters that change the state's size
/// (`actuator_bandwidth` adds five lag states), restores into the same instance and into a
/// fresh one, which then runs bit-identically with one that was never restored.
#[test]
fn a_state_saved_before_initialisation_restores_and_runs_as_the_original() {
    let log = LogCapture::default();
    let setups: [&[(&str, f64)]; 3] = [
        &[],
        &[("m_s", 1650.0)],
        &[("m_s", 1650.0), ("actuator_bandwidth", 8.0), ("tau", 0.004)],
    ];
    for setup in setups {
        for in_init_mode in [false, true] {
            let reference = Plant::new(&log);
            let saved = Plant::new(&log);
            for (n, v) in setup {
                assert_eq!(reference.set(n, *v), OK);
                assert_eq!(saved.set(n, *v), OK);
            }
            if in_init_mode {
                unsafe {
                    assert_eq!(fmi2SetupExperiment(saved.c, 0, 0.0, 0.0, 0, 0.0), OK);
                    assert_eq!(fmi2EnterInitializationMode(saved.c), OK);
                }
            }
            let bytes = serialized(&saved);
            let what = format!("{setup:?}, in initialization mode: {in_init_mode}");
            assert_eq!(
                restore_serialized(&saved, &bytes),
                OK,
                "{what}: {:?}",
                log.messages()
            );
            let fresh = Plant::new(&log);
            assert_eq!(
                restore_serialized(&fresh, &bytes),
                OK,
                "{what}: {:?}",
                log.messages()
            );
            reference.init(0.0);
            if in_init_mode {
                // The state carries the FMI state it was taken in: Initialization Mode.
                assert_eq!(unsafe { fmi2ExitInitializationMode(fresh.c) }, OK, "{what}");
            } else {
                fresh.init(0.0);
            }
            for (n, v) in setup {
                assert_eq!(fresh.get(n), *v, "{what}: {n} restored");
            }
            for k in 0..300 {
                let t = k as f64 * 1e-3;
                for p in [&reference, &fresh] {
                    p.set("u_seat", 500.0 * (9.0 * t).sin());
                    p.set("road_z_fl", 0.02 * (3.0 * t).sin());
                    assert_eq!(p.step(t, 1e-3), OK, "{what}");
                }
            }
            let (a, b) = (reference.states(), fresh.states());
            assert!(max_abs(&a) > 0.0);
            assert!(
                a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()),
                "{what}: the restored instance diverged"
            );
        }
    }
}

#[test]
fn serialized_state_with_delay_history_continues_bit_identically_in_another_instance() {
    let log = LogCapture::default();
    let setup = [
        ("tau", 0.0237),
        ("actuator_bandwidth", 12.0),
        ("fault_time", 0.3),
        ("fault_loss_seat", 0.7),
        ("m_s", 1650.0),
    ];
    let a = Plant::new(&log);
    for (n, v) in setup {
        a.set(n, v);
    }
    a.init(0.0);
    let cmd = |t: f64| 900.0 * (11.0 * t).sin();
    for k in 0..137 {
        let t = k as f64 * 1e-3;
        a.set("u_fl", cmd(t));
        a.set("u_seat", -cmd(t));
        a.set("road_z_rl", 0.01 * t);
        a.step(t, 1e-3);
    }
    let bytes = serialized(&a);

    // A fresh instance with default parameters takes the whole state, parameters included.
    let b = Plant::new(&log);
    assert_eq!(restore_serialized(&b, &bytes), OK);
    assert_eq!(b.get("m_s"), 1650.0);
    for k in 137..400 {
        let t = k as f64 * 1e-3;
        for p in [&a, &b] {
            p.set("u_fl", cmd(t));
            p.set("u_seat", -cmd(t));
            p.set("road_z_rl", 0.01 * t);
            assert_eq!(p.step(t, 1e-3), OK);
        }
        let (xa, xb) = (a.states(), b.states());
        assert!(
            xa.iter().zip(&xb).all(|(x, y)| x.to_bits() == y.to_bits()),
            "diverged at step {k}"
        );
        assert_eq!(a.get("f_seat").to_bits(), b.get("f_seat").to_bits());
    }
    assert!(max_abs(&a.states()) > 0.0);
}

#[test]
fn nan_road_input_is_refused_and_the_state_is_unchanged() {
    let log = LogCapture::default();
    let p = Plant::new(&log);
    p.init(0.0);
    p.set("road_z_fl", 0.01);
    p.step(0.0, 0.01);
    let before = p.states();
    assert_eq!(p.set("road_z_fl", f64::NAN), ERROR);
    assert!(log.contains("fmi2SetReal: value of 'road_z_fl' must be finite, got NaN"));
    assert_eq!(p.get("road_z_fl"), 0.01);
    assert_eq!(p.states(), before);
    assert_eq!(p.der("u_fl", f64::INFINITY), ERROR);
}

#[test]
fn two_instances_on_two_threads_give_identical_results() {
    let run = || {
        let log = LogCapture::default();
        let p = Plant::new(&log);
        p.set("tau", 0.005);
        p.init(0.0);
        for k in 0..3000 {
            let t = k as f64 * 1e-3;
            p.set("road_z_fl", 0.02 * (8.0 * t).sin());
            p.set("road_v_fl", 0.16 * (8.0 * t).cos());
            p.set("u_seat", 300.0 * (3.0 * t).sin());
            assert_eq!(p.step(t, 1e-3), OK);
        }
        p.states()
    };
    let (a, b) = std::thread::scope(|s| {
        let a = s.spawn(run);
        let b = s.spawn(run);
        (a.join().unwrap(), b.join().unwrap())
    });
    assert_eq!(a, b);
    assert_eq!(a, run(), "same as on the main thread");
    assert!(max_abs(&a) > 1e-4);
}

/// The stiffest car the parameter ranges admit, stepped over an absurdly long step: the
/// matrix exponential is refused (it once never returned) and the step discarded with
/// `fmi2Discard` and the reason, the state unchanged. The instance is then in `StepFailed`, as
/// FMI 2.0.4 §4.2.4 has it: its last successful time is the step's start, `fmi2DoStep` is
/// illegal there, the outputs can be read, and the state saved before the step restores it, from
/// where sensible steps of that car work.
#[test]
fn an_absurd_step_is_discarded_with_a_message_and_loses_nothing() {
    let log = LogCapture::default();
    let p = Plant::new(&log);
    for (name, value) in [("k_t", 1e8), ("m_u", 0.1), ("c_s_f", 1e6)] {
        assert_eq!(p.set(name, value), OK, "{name}");
    }
    p.init(0.0);
    assert_eq!(p.set("road_z_fl", 0.01), OK);
    assert_eq!(p.step(0.0, 1e-4), OK);
    let before = p.states();
    assert!(before.iter().all(|v| v.is_finite()) && before.iter().any(|v| *v != 0.0));
    let mut saved: Fmi2FmuState = null_mut();
    assert_eq!(unsafe { fmi2GetFMUstate(p.c, &mut saved) }, OK);
    assert_eq!(p.step(1e-4, 1e15), DISCARD);
    assert!(
        log.contains("cannot discretise the car over") && log.contains("exceeds 1e20"),
        "{:?}",
        log.messages()
    );
    assert_eq!(p.states(), before);
    unsafe {
        let (mut last, mut status) = (f64::NAN, -1);
        assert_eq!(fmi2GetRealStatus(p.c, 2, &mut last), OK);
        assert_eq!(last, 1e-4, "fmi2LastSuccessfulTime");
        assert_eq!(fmi2GetStatus(p.c, 0, &mut status), OK);
        assert_eq!(status, DISCARD, "fmi2DoStepStatus");
        assert_eq!(p.step(1e-4, 1e-4), ERROR, "no step from StepFailed");
        assert!(log.contains("fmi2DoStep: illegal call in state StepFailed"));
    }
    // The illegal call put the instance in Error; the saved state brings it back.
    assert_eq!(unsafe { fmi2SetFMUstate(p.c, saved) }, OK);
    assert_eq!(p.step(1e-4, 1e-4), OK);
    assert!(p.states().iter().all(|v| v.is_finite()));
    unsafe { fmi2FreeFMUstate(p.c, &mut saved) };
}

/// States whose checksum matches but whose values the setters refuse (an actuator limit of
/// NaN or 0, a tyre of 1e-12 N/m, a fault loss of 1.5, a NaN road input) are refused with the
/// reason and change nothing; the untouched state is still accepted.
#[test]
fn forged_states_are_refused_and_change_nothing() {
    let log = LogCapture::default();
    let a = Plant::new(&log);
    for (n, v) in [
        ("u_max", 1234.5),
        ("k_t", 191234.0),
        ("fault_loss_rl", 0.375),
    ] {
        assert_eq!(a.set(n, v), OK);
    }
    a.init(0.0);
    a.set("road_z_fl", 0.0123);
    assert_eq!(a.step(0.0, 1e-3), OK);
    let state = |p: &Plant| -> Vec<u8> {
        let mut s: Fmi2FmuState = null_mut();
        assert_eq!(unsafe { fmi2GetFMUstate(p.c, &mut s) }, OK);
        let mut size = 0;
        unsafe { fmi2SerializedFMUstateSize(p.c, s, &mut size) };
        let mut bytes = vec![0 as Fmi2Byte; size];
        unsafe { fmi2SerializeFMUstate(p.c, s, bytes.as_mut_ptr(), size) };
        unsafe { fmi2FreeFMUstate(p.c, &mut s) };
        bytes.into_iter().map(|b| b as u8).collect()
    };
    let restore = |p: &Plant, bytes: &[u8]| -> i32 {
        let mut s: Fmi2FmuState = null_mut();
        let st = unsafe {
            fmi2DeSerializeFMUstate(p.c, bytes.as_ptr() as *const Fmi2Byte, bytes.len(), &mut s)
        };
        if st != OK {
            return st;
        }
        let st = unsafe { fmi2SetFMUstate(p.c, s) };
        unsafe { fmi2FreeFMUstate(p.c, &mut s) };
        st
    };
    let good = state(&a);
    let b = Plant::new(&log);
    b.init(0.0);
    b.set("road_z_fr", 0.02);
    assert_eq!(b.step(0.0, 2e-3), OK);
    let before = b.states();
    for (old, new, why) in [
        (1234.5, f64::NAN, "must be finite"),
        (1234.5, -1.0, "value -1 of 'u_max' is below its minimum 0"),
        (191234.0, 1e-12, "k_t"),
        (0.375, 1.5, "above its maximum 1"),
        (0.0123, f64::INFINITY, "finite"),
    ] {
        log.clear();
        let forged = fmi_test_logger::forge_state(&good, old, new);
        assert_ne!(restore(&b, &forged), OK, "{old} -> {new} accepted");
        assert!(log.contains(why), "{old} -> {new}: {:?}", log.messages());
        assert_eq!(b.states(), before);
        assert_eq!(b.get("u_max"), 2500.0, "b's own parameters");
    }
    assert_eq!(restore(&b, &good), OK, "{:?}", log.messages());
    assert_eq!(b.states(), a.states());
    assert_eq!(b.get("u_max"), 1234.5);
}

/// Second derivatives are legal (the standard forbids only order 0): ignored with `fmi2Warning`
/// and a message, the instance alive, the first derivatives of the same call used. Order 0 is
/// refused with `fmi2Error`.
#[test]
fn higher_input_derivatives_are_ignored_with_a_warning_and_order_zero_refused() {
    let log = LogCapture::default();
    let reference = Plant::new(&log);
    reference.init(0.0);
    reference.der("road_z_fl", 0.1);
    assert_eq!(reference.step(0.0, 0.2), OK);
    let p = Plant::new(&log);
    p.init(0.0);
    let vrs = [p.vr("road_z_fl"), p.vr("road_z_fl")];
    let (orders, values) = ([1, 2], [0.1, 5.0]);
    // Warnings are logged when logging is on (errors always are).
    assert_eq!(unsafe { fmi2SetDebugLogging(p.c, 1, 0, null()) }, OK);
    log.clear();
    let status = unsafe {
        fmi2SetRealInputDerivatives(p.c, vrs.as_ptr(), 2, orders.as_ptr(), values.as_ptr())
    };
    assert_eq!(status, 1, "fmi2Warning");
    assert!(
        log.contains("ignored order 2 of 'road_z_fl'"),
        "{:?}",
        log.messages()
    );
    assert_eq!(p.step(0.0, 0.2), OK, "the instance goes on");
    assert_eq!(p.states(), reference.states());
    assert_eq!(p.get("road_z_fl"), reference.get("road_z_fl"));
    let q = Plant::new(&log);
    q.init(0.0);
    let status = unsafe { fmi2SetRealInputDerivatives(q.c, &vrs[0], 1, &0, &1.0) };
    assert_eq!(status, ERROR);
    assert!(log.contains("orders start at 1"), "{:?}", log.messages());
}

/// The `<ModelStructure>` tells the truth: every dependency the plant has, measured by
/// perturbing one known at a time, is declared; every declared input dependency is seen; and a
/// declared parameter dependency not seen is one that is flat at the probed point (no command
/// saturates, the fault lies in the future, the tyre presses on the road), a flag (which moves
/// only past a threshold) or a static-equilibrium value (a static value, a tyre's whole load)
/// declared on every stiffness, mass and lever rather than on the subset its corner happens to
/// read.
#[test]
fn declared_dependencies_are_the_measured_ones() {
    let log = LogCapture::default();
    let cb = log.callbacks();
    let callbacks = unsafe { &*(&cb as *const _ as *const CallbackFunctions) };
    let measured = fmu_core::dependencies::measure::<fmu_plant::Plant>(None, callbacks, &[])
        .expect("measured");
    let d = fmu_plant::Plant::model_description();
    let m = measured.compare(&d);
    assert!(m.undeclared.is_empty(), "undeclared: {:?}", m.undeclared);
    let unexplained: Vec<&(String, String)> = m
        .unobserved
        .iter()
        .filter(|(unknown, known)| {
            // A tyre pressing on the road is the same in the physical and the linear car.
            let flat_here = known.starts_with("u_max")
                || known.starts_with("fault_")
                || known == "contact_model";
            // A Boolean changes only past a threshold: no perturbation small enough to be a
            // derivative sees it.
            let flag = unknown.starts_with("on_road_");
            let statics = unknown.starts_with("static_") || unknown.starts_with("tire_force_");
            !(flat_here || flag || statics)
        })
        .collect();
    assert!(
        unexplained.is_empty(),
        "declared, not seen: {unexplained:?}"
    );
    // The seat acceleration moves with the seat command and the seat mass, not with the road.
    let (_, a_seat) = measured
        .initial
        .iter()
        .find(|(n, _)| n == "a_seat")
        .unwrap();
    assert!(
        a_seat.contains("u_seat") && a_seat.contains("m_seat"),
        "{a_seat:?}"
    );
    assert!(!a_seat.iter().any(|k| k.starts_with("road_")), "{a_seat:?}");
    // The states start at the equilibrium, whatever the knowns.
    let (_, x1) = measured.initial.iter().find(|(n, _)| n == "x[1]").unwrap();
    assert!(x1.is_empty(), "{x1:?}");
}
