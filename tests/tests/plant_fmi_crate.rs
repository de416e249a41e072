//! `dist/plant.fmu` loaded by the `fmi` crate, as a Rust importer would: a 5 cm, 5 m long
//! 1 − cos bump at 15 m/s on the left wheels, stepped on two threads at once from one loaded
//! library, with FMU state rewind.

use fmi::fmi2::import::Fmi2Import;
use fmi::fmi2::instance::{CoSimulation, Common, Instance};
use fmi::traits::{FmiImport, FmiStatus};
use fmi::CS;
use integration_tests::dist_fmu;

const SPEED: f64 = 15.0;
const HEIGHT: f64 = 0.05;
const LENGTH: f64 = 5.0;
const BUMP_START: f64 = 0.1;

/// Road height and velocity of the bump at time `t` for a wheel reaching it `delay` s later.
fn bump(t: f64, delay: f64) -> (f64, f64) {
    let x = SPEED * (t - BUMP_START - delay);
    if (0.0..=LENGTH).contains(&x) {
        let w = 2.0 * std::f64::consts::PI / LENGTH;
        (
            0.5 * HEIGHT * (1.0 - (w * x).cos()),
            0.5 * HEIGHT * w * SPEED * (w * x).sin(),
        )
    } else {
        (0.0, 0.0)
    }
}

fn vr(import: &Fmi2Import, name: &str) -> u32 {
    import
        .model_description()
        .model_variables
        .variables
        .iter()
        .find(|v| v.name == name)
        .unwrap_or_else(|| panic!("no variable {name}"))
        .value_reference
}

struct Bump {
    inputs: Vec<u32>,
    outputs: Vec<u32>,
    wheelbase_delay: f64,
}

impl Bump {
    fn new(import: &Fmi2Import) -> Self {
        let inputs = ["road_z_fl", "road_z_rl", "road_v_fl", "road_v_rl"]
            .iter()
            .map(|n| vr(import, n))
            .collect();
        let mut outputs: Vec<u32> = (1..=16).map(|k| vr(import, &format!("x[{k}]"))).collect();
        outputs.extend(
            ["a_seat", "stroke_fl", "tire_load_rl"]
                .iter()
                .map(|n| vr(import, n)),
        );
        Bump {
            inputs,
            outputs,
            wheelbase_delay: 2.4 / SPEED,
        }
    }

    fn set_road(&self, inst: &mut Instance<CS>, t: f64) {
        let (zf, vf) = bump(t, 0.0);
        let (zr, vr) = bump(t, self.wheelbase_delay);
        inst.set_real(&self.inputs, &[zf, zr, vf, vr])
            .expect("set_real");
    }

    fn read(&self, inst: &mut Instance<CS>) -> Vec<f64> {
        let mut y = vec![0.0; self.outputs.len()];
        inst.get_real(&self.outputs, &mut y).expect("get_real");
        y
    }

    /// Run `steps` steps of `h` from t = 0, returning the outputs after each step.
    fn run(&self, import: &Fmi2Import, name: &str, h: f64, steps: usize) -> Vec<Vec<f64>> {
        let mut inst = import
            .instantiate_cs(name, false, false)
            .expect("instantiate");
        inst.setup_experiment(None, 0.0, None).unwrap();
        Common::enter_initialization_mode(&mut inst).unwrap();
        Common::exit_initialization_mode(&mut inst).unwrap();
        let mut out = Vec::with_capacity(steps);
        for k in 0..steps {
            let t = k as f64 * h;
            self.set_road(&mut inst, t);
            inst.do_step(t, h, true).expect("do_step");
            self.set_road(&mut inst, t + h);
            out.push(self.read(&mut inst));
        }
        out
    }
}

#[test]
fn bump_response_is_physical_and_identical_on_two_threads() {
    let import: Fmi2Import = fmi::import::from_path(dist_fmu("plant")).expect("load plant.fmu");
    assert_eq!(import.model_description().model_name, "plant");
    let bump = Bump::new(&import);
    let h = 1e-3;
    let steps = 8000;
    let (a, b) = std::thread::scope(|s| {
        let a = s.spawn(|| bump.run(&import, "left", h, steps));
        let b = s.spawn(|| bump.run(&import, "right", h, steps));
        (a.join().unwrap(), b.join().unwrap())
    });
    assert_eq!(
        a, b,
        "two instances of one library on two threads must agree exactly"
    );

    // Physics: the left wheels go over, so the body rolls left side up (φ > 0) first, heaves
    // up, and everything settles back to static equilibrium after the bump.
    let heave: Vec<f64> = a.iter().map(|y| y[0]).collect();
    let roll: Vec<f64> = a.iter().map(|y| y[1]).collect();
    let peak_heave = heave.iter().cloned().fold(f64::MIN, f64::max);
    assert!(
        peak_heave > 0.005 && peak_heave < HEIGHT,
        "peak body heave {peak_heave} m"
    );
    let first_roll = roll.iter().find(|r| r.abs() > 1e-4).unwrap();
    assert!(*first_roll > 0.0, "left side must go up first");
    let last = a.last().unwrap();
    // Passive damping ratio ≈ 0.18 at ≈ 1 Hz: the free motion after the bump decays, by more
    // than 100× over 8 s and monotonically from one 2 s window to the next.
    assert!(
        last[..8].iter().all(|v| v.abs() < 1e-2 * peak_heave),
        "not settled after 8 s: {last:?}"
    );
    let window_peak = |from: usize| {
        a[from..from + 2000]
            .iter()
            .map(|y| y[0].abs())
            .fold(0.0, f64::max)
    };
    assert!(
        window_peak(2000) < 0.5 * window_peak(0) && window_peak(4000) < 0.5 * window_peak(2000)
    );
    let peak_seat = a.iter().map(|y| y[16].abs()).fold(0.0, f64::max);
    assert!(
        peak_seat > 0.5 && peak_seat < 20.0,
        "peak seat acceleration {peak_seat} m/s²"
    );
}

#[test]
fn fmu_state_rewinds_through_the_fmi_crate() {
    let import: Fmi2Import = fmi::import::from_path(dist_fmu("plant")).expect("load plant.fmu");
    let bump = Bump::new(&import);
    let mut inst = import.instantiate_cs("rewind", false, false).unwrap();
    inst.setup_experiment(None, 0.0, None).unwrap();
    Common::enter_initialization_mode(&mut inst).unwrap();
    Common::exit_initialization_mode(&mut inst).unwrap();
    let h = 1e-3;
    for k in 0..150 {
        bump.set_road(&mut inst, k as f64 * h);
        inst.do_step(k as f64 * h, h, true).unwrap();
    }
    let saved = inst.get_fmu_state().expect("get_fmu_state");
    let mut first = Vec::new();
    for k in 150..300 {
        bump.set_road(&mut inst, k as f64 * h);
        inst.do_step(k as f64 * h, h, true).unwrap();
        first.push(bump.read(&mut inst));
    }
    inst.set_fmu_state(&saved).ok().expect("set_fmu_state");
    for (i, k) in (150..300).enumerate() {
        bump.set_road(&mut inst, k as f64 * h);
        inst.do_step(k as f64 * h, h, true).unwrap();
        assert_eq!(bump.read(&mut inst), first[i], "replay differs at step {k}");
    }
    let bytes = inst.serialize_fmu_state(&saved).expect("serialize");
    assert!(
        inst.deserialize_fmu_state(&bytes[..bytes.len() - 3])
            .is_err(),
        "truncated state must be refused"
    );
}
