//! The FMI 3.0 FMUs (`dist/fmi3/`) imported by the `fmi` crate's FMI 3.0 support: each loads,
//! its description parses and names every variable of the FMI 2.0 FMU under the same value
//! reference; the closed loop over FMI 3.0, in the master's Gauss–Seidel order, is the master's
//! FMI 2.0 loop bit for bit, and so is a controller its sample clock ticks (Event Mode) when it
//! is stepped first; and the FMI 3.0 road FMU gives the road the master computes.

use fmi::fmi3::import::Fmi3Import;
use fmi::fmi3::instance::InstanceCS;
use fmi::fmi3::Fmi3Model;
use fmi::fmi3::{CoSimulation, Common, GetSet};
use fmi::schema::fmi3::{AbstractVariableTrait, VariableType};
use fmi::traits::{FmiEventHandler, FmiImport};
use fmi::EventFlags;
use integration_tests::{bump, dist, load, run_loop};
use std::collections::BTreeMap;

const H: f64 = 1e-3;
const FMUS: [&str; 11] = [
    "road",
    "plant",
    "hinf_sf",
    "hinf_of",
    "hinf_of_aw",
    "robust_sf",
    "robust_of",
    "delay_sf",
    "ft_of",
    "skyhook",
    "lqg",
];
use master::cosim::{FORCES, ROAD};

/// `dist/fmi3/<name>.fmu` through the `fmi` crate, with its variables by name.
struct Fmu3 {
    import: Fmi3Import,
    /// Every variable but the clocks.
    vrs: BTreeMap<String, (u32, String)>,
    /// The clocks, by name.
    clocks: BTreeMap<String, u32>,
}

impl Fmu3 {
    fn load(name: &str) -> Fmu3 {
        let path = dist().join("fmi3").join(format!("{name}.fmu"));
        assert!(path.exists(), "{}: run `make`", path.display());
        let import: Fmi3Import = fmi::import::from_path(&path)
            .unwrap_or_else(|e| panic!("the fmi crate cannot import {}: {e}", path.display()));
        let variables = &import.model_description().model_variables;
        let clock = |v: &&dyn AbstractVariableTrait| v.data_type() == VariableType::FmiClock;
        let vrs = variables
            .iter_abstract()
            .filter(|v| !clock(v))
            .map(|v| {
                let causality = format!("{:?}", v.causality()).to_lowercase();
                (v.name().to_string(), (v.value_reference(), causality))
            })
            .collect();
        let clocks = variables
            .iter_abstract()
            .filter(clock)
            .map(|v| (v.name().to_string(), v.value_reference()))
            .collect();
        Fmu3 {
            import,
            vrs,
            clocks,
        }
    }

    fn vr(&self, names: &[&str]) -> Vec<u32> {
        names.iter().map(|n| self.vrs[*n].0).collect()
    }

    fn with_causality(&self, causality: &str) -> Vec<String> {
        let mut named: Vec<(u32, &String)> = self
            .vrs
            .iter()
            .filter(|(_, (_, c))| c == causality)
            .map(|(n, (vr, _))| (*vr, n))
            .collect();
        named.sort();
        named.into_iter().map(|(_, n)| n.clone()).collect()
    }

    /// Instantiated for Co-Simulation and initialised at t = 0.
    fn start(&self) -> InstanceCS {
        let mut i = self
            .import
            .instantiate_cs("fmi3-test", false, true, false, false, &[])
            .expect("instantiate");
        i.enter_initialization_mode(None, 0.0, None).expect("enter");
        i.exit_initialization_mode().expect("exit");
        i
    }
}

fn step(i: &mut InstanceCS, t: f64) {
    let (mut event, mut terminate, mut early, mut last) = (true, true, true, f64::NAN);
    i.do_step(
        t,
        H,
        true,
        &mut event,
        &mut terminate,
        &mut early,
        &mut last,
    )
    .expect("do_step");
    assert!(!event && !terminate && !early);
    assert!((last - (t + H)).abs() < 1e-12);
}

/// Every FMU imports, and names the FMI 2.0 FMU's variables under the same value references,
/// with FMI 3.0's independent time beside them.
#[test]
fn every_fmi3_fmu_imports_with_the_fmi2_variables() {
    for name in FMUS {
        let three = Fmu3::load(name);
        let two = load(name);
        let names = two.names_with_causality("parameter").into_iter().chain(
            ["input", "output", "local", "calculatedparameter"]
                .iter()
                .flat_map(|c| two.names_with_causality(c)),
        );
        let mut count = 0;
        for n in names {
            assert_eq!(three.vrs[&n].0, two.vr(&n).unwrap(), "{name}: {n}");
            count += 1;
        }
        assert_eq!(three.vrs["time"], (1_000_000_000, "independent".into()));
        let indicators = three
            .vrs
            .keys()
            .filter(|n| n.starts_with("event_indicator["))
            .count();
        // A controller's matrices as FMI 3.0 arrays (9000 to 9003), at least its D_c.
        let arrays = three
            .vrs
            .iter()
            .filter(|(_, (vr, _))| (9000..9004).contains(vr));
        let arrays: Vec<&str> = arrays.map(|(n, _)| n.as_str()).collect();
        let controller = !matches!(name, "road" | "plant");
        assert_eq!(controller, arrays.contains(&"D_c"), "{name}: {arrays:?}");
        assert_eq!(
            three.vrs.len(),
            count + 1 + indicators + arrays.len(),
            "{name}"
        );
        assert_eq!(indicators, if name == "plant" { 14 } else { 0 }, "{name}");
        // A controller's sample clock; the plant and road have none.
        let clocks: Vec<(&str, u32)> = three.clocks.iter().map(|(n, v)| (n.as_str(), *v)).collect();
        assert_eq!(
            clocks,
            if controller {
                vec![("sample", 8000)]
            } else {
                vec![]
            },
            "{name}"
        );
    }
}

const RECORD: [&str; 6] = [
    "a_seat",
    "stroke_fl",
    "stroke_seat",
    "f_fl",
    "f_seat",
    "tire_load_rl",
];

/// The bump loop over FMI 3.0, road computed in-process, its plant outputs recorded: in the
/// master's Gauss–Seidel order (the command read, then every FMU steps), or with the controller
/// ticked by its sample clock (Event Mode, a tick at every communication point), stepped first
/// and its command read *after* its step.
fn fmi3_loop(controller: &str, clocked: bool, steps: usize) -> Vec<Vec<f64>> {
    let road = bump(0.05);
    let plant3 = Fmu3::load("plant");
    let ctrl3 = Fmu3::load(controller);
    let mut p = plant3.start();
    let mut c = if clocked {
        let mut c = ctrl3
            .import
            .instantiate_cs("clocked", false, true, true, false, &[])
            .expect("instantiate with Event Mode");
        c.enter_initialization_mode(None, 0.0, None).unwrap();
        c.exit_initialization_mode().unwrap(); // into Event Mode, at the first tick
        c
    } else {
        ctrl3.start()
    };
    let inputs = ctrl3.with_causality("input");
    let inputs: Vec<&str> = inputs.iter().map(String::as_str).collect();
    let (y_from, y_to) = (plant3.vr(&inputs), ctrl3.vr(&inputs));
    let (road_in, force_in, u_from) = (plant3.vr(&ROAD), plant3.vr(&FORCES), ctrl3.vr(&FORCES));
    let recorded = plant3.vr(&RECORD);
    let (mut y, mut u, mut out) = (vec![0.0; inputs.len()], [0.0; 5], vec![0.0; RECORD.len()]);
    p.set_float64(&road_in, &road.at(0.0)).unwrap();
    p.get_float64(&y_from, &mut y).unwrap();
    let mut log = Vec::new();
    for k in 0..steps {
        let t = k as f64 * H;
        c.set_float64(&y_to, &y).unwrap();
        if clocked {
            c.set_clock(&[ctrl3.clocks["sample"]], &[true]).unwrap();
            let mut flags = EventFlags::default();
            FmiEventHandler::update_discrete_states(&mut c, &mut flags).unwrap();
            let next = flags.next_event_time.expect("the next tick");
            assert!(
                (next - (t + H)).abs() < 1e-12,
                "{controller}: next tick {next}"
            );
            c.enter_step_mode().unwrap();
            let (mut event, mut terminate, mut early, mut last) = (false, true, true, f64::NAN);
            c.do_step(
                t,
                H,
                true,
                &mut event,
                &mut terminate,
                &mut early,
                &mut last,
            )
            .unwrap();
            assert!(
                event && !terminate && !early,
                "{controller}: Event Mode due"
            );
            c.get_float64(&u_from, &mut u).unwrap();
        } else {
            c.get_float64(&u_from, &mut u).unwrap();
            step(&mut c, t);
        }
        p.set_float64(&force_in, &u).unwrap();
        step(&mut p, t);
        p.set_float64(&road_in, &road.at(t + H)).unwrap();
        p.get_float64(&recorded, &mut out).unwrap();
        p.get_float64(&y_from, &mut y).unwrap();
        log.push(out.clone());
        if clocked {
            FmiEventHandler::enter_event_mode(&mut c).unwrap();
        }
    }
    log
}

/// The master's FMI 2.0 loop (`run_loop`) on the same bump.
fn fmi2_loop(controller: &str, steps: usize) -> Vec<Vec<f64>> {
    let two = run_loop(
        &load("plant"),
        Some(&load(controller)),
        &bump(0.05),
        H,
        steps,
        &RECORD,
    );
    let largest = two.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(largest > 1.0, "{controller}: the bump moves the car");
    two
}

/// The master's Gauss–Seidel order over FMI 3.0: the same plant outputs as the master's FMI 2.0
/// loop, bit for bit.
#[test]
fn the_fmi3_closed_loop_is_the_masters_fmi2_loop_bit_for_bit() {
    for controller in ["hinf_of", "delay_sf", "ft_of", "skyhook"] {
        let steps = 1500;
        assert_eq!(
            fmi2_loop(controller, steps),
            fmi3_loop(controller, false, steps),
            "{controller}"
        );
    }
}

/// A controller ticked by its sample clock through the `fmi` crate, stepped first and its
/// command read after its step: still the master's Gauss–Seidel loop bit for bit, the command
/// being the one computed at the tick. (Over FMI 2.0 that order reads a command a step
/// fresher: another loop.)
#[test]
fn a_clocked_controller_stepped_first_is_the_masters_gauss_seidel_loop() {
    for controller in ["hinf_of", "delay_sf"] {
        let steps = 1000;
        assert_eq!(
            fmi2_loop(controller, steps),
            fmi3_loop(controller, true, steps),
            "{controller}"
        );
    }
}

/// The FMI 3.0 road FMU's bump is the road the master computes at the FMU's time, bit for bit,
/// and that time, its independent variable, is the time it was stepped to.
#[test]
fn the_fmi3_road_is_the_road() {
    let road = bump(0.05);
    let fmu = Fmu3::load("road");
    let mut r = fmu
        .import
        .instantiate_cs("road3", false, true, false, false, &[])
        .unwrap();
    r.set_int32(&fmu.vr(&["profile"]), &[1]).unwrap();
    r.set_float64(
        &fmu.vr(&["bump_height", "bump_length", "speed", "start_distance"]),
        &[0.05, 5.0, 15.0, 1.5],
    )
    .unwrap();
    r.enter_initialization_mode(None, 0.0, None).unwrap();
    r.exit_initialization_mode().unwrap();
    let out = fmu.vr(&ROAD);
    let (mut values, mut t) = ([0.0; 8], [0.0]);
    for k in 0..1000 {
        step(&mut r, k as f64 * H);
        r.get_float64(&out, &mut values).unwrap();
        // Its time, the independent variable, is the sum of its steps.
        r.get_float64(&[1_000_000_000], &mut t).unwrap();
        assert!(
            (t[0] - (k + 1) as f64 * H).abs() < 1e-12,
            "step {k}: {}",
            t[0]
        );
        assert_eq!(values, road.at(t[0]), "step {k}");
    }
}
