//! Helpers for the integration tests: locate the FMUs `make` built into `dist/`, road profiles,
//! and a small Gauss–Seidel master on the `fmi` crate that connects FMUs by variable name.

use fmi::fmi2::import::Fmi2Import;
use fmi::fmi2::instance::{CoSimulation, Common, Instance};
use fmi::traits::FmiImport;
use fmi::CS;
use std::path::PathBuf;

/// `dist/<name>.fmu`, or a panic that says how to build it.
pub fn dist_fmu(name: &str) -> PathBuf {
    let path = dist().join(format!("{name}.fmu"));
    assert!(
        path.exists(),
        "{} not found: run `make` (or `make test`, which builds it first)",
        path.display()
    );
    path
}

pub fn dist() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join("dist")
}

pub fn load(name: &str) -> Fmi2Import {
    fmi::import::from_path(dist_fmu(name)).unwrap_or_else(|e| panic!("cannot load {name}.fmu: {e}"))
}

pub fn vr(import: &Fmi2Import, name: &str) -> Option<u32> {
    import
        .model_description()
        .model_variables
        .variables
        .iter()
        .find(|v| v.name == name)
        .map(|v| v.value_reference)
}

pub fn names_with_causality(import: &Fmi2Import, causality: &str) -> Vec<String> {
    import
        .model_description()
        .model_variables
        .variables
        .iter()
        .filter(|v| format!("{:?}", v.causality).eq_ignore_ascii_case(causality))
        .map(|v| v.name.clone())
        .collect()
}

/// Road heights and velocities at the four wheels (FL, FR, RL, RR), rear delayed by the wheelbase.
pub trait Road {
    /// `[z_fl, z_fr, z_rl, z_rr, v_fl, v_fr, v_rl, v_rr]` at time `t`.
    fn at(&self, t: f64) -> [f64; 8];
}

impl Road for vehicle::road::Road {
    fn at(&self, t: f64) -> [f64; 8] {
        vehicle::road::Road::at(self, t)
    }
}

/// A `height` m, 5 m long 1 − cos bump at 15 m/s on the left wheels, reached at t = 0.1 s (the
/// road FMU's bump profile).
pub fn bump(height: f64) -> vehicle::road::Road {
    vehicle::road::Road::new(
        vehicle::road::Profile::Bump {
            height,
            length: 5.0,
            side: vehicle::road::Side::Left,
        },
        15.0,
        2.4,
        1.5,
    )
    .expect("valid bump")
}

/// An ISO 8608 road of class 1 (A) … 8 (H) (the road FMU's profile), tracks independent,
/// faded in over 1 s, the front wheels one wheelbase into the profile at t = 0.
pub fn iso_road(class: u8, speed: f64, seed: u64) -> vehicle::road::Road {
    vehicle::road::Road::new(
        vehicle::road::Profile::Iso {
            class,
            seed,
            identical_tracks: false,
            fade_in: 1.0,
        },
        speed,
        2.4,
        -2.4,
    )
    .expect("valid ISO road")
}

/// `dist/road.fmu` as a [`Road`], through the `fmi` crate: stepped forward to each time asked
/// for (times must not decrease; within 1 ns of the last is the same point).
pub struct RoadFmu {
    instance: std::cell::RefCell<Instance<CS>>,
    time: std::cell::Cell<f64>,
    outputs: Vec<u32>,
}

impl RoadFmu {
    /// Instantiate and initialise the road FMU of `import` (leaked: it must outlive the
    /// instance, and a test process loads it once) with Integer and Real parameters.
    pub fn new(integers: &[(&str, i32)], reals: &[(&str, f64)]) -> RoadFmu {
        let import: &'static Fmi2Import = Box::leak(Box::new(load("road")));
        let mut i: Instance<CS> = import
            .instantiate_cs("road", false, false)
            .expect("instantiate road");
        for (n, v) in integers {
            i.set_integer(
                &[vr(import, n).unwrap_or_else(|| panic!("road has no {n}"))],
                &[*v],
            )
            .unwrap();
        }
        for (n, v) in reals {
            i.set_real(
                &[vr(import, n).unwrap_or_else(|| panic!("road has no {n}"))],
                &[*v],
            )
            .unwrap();
        }
        i.setup_experiment(None, 0.0, None).unwrap();
        Common::enter_initialization_mode(&mut i).unwrap();
        Common::exit_initialization_mode(&mut i).unwrap();
        let outputs = ROAD_INPUTS
            .iter()
            .map(|n| vr(import, n).expect("road output"))
            .collect();
        RoadFmu {
            instance: std::cell::RefCell::new(i),
            time: std::cell::Cell::new(0.0),
            outputs,
        }
    }
}

impl Road for RoadFmu {
    fn at(&self, t: f64) -> [f64; 8] {
        let mut i = self.instance.borrow_mut();
        let now = self.time.get();
        // k h + h and (k + 1) h differ in the last bits: that is the same communication point.
        assert!(
            t >= now - 1e-9,
            "the road FMU cannot go back from {now} to {t}"
        );
        if t > now + 1e-9 {
            i.do_step(now, t - now, true).unwrap();
            self.time.set(t);
        }
        let mut out = [0.0; 8];
        i.get_real(&self.outputs, &mut out).unwrap();
        out
    }
}

pub const ROAD_INPUTS: [&str; 8] = [
    "road_z_fl",
    "road_z_fr",
    "road_z_rl",
    "road_z_rr",
    "road_v_fl",
    "road_v_fr",
    "road_v_rl",
    "road_v_rr",
];
pub const FORCES: [&str; 5] = ["u_fl", "u_fr", "u_rl", "u_rr", "u_seat"];

/// Whether `name` is a Boolean variable of `import`.
pub fn is_boolean(import: &Fmi2Import, name: &str) -> bool {
    import
        .model_description()
        .model_variables
        .variables
        .iter()
        .any(|v| {
            v.name == name && matches!(v.elem, fmi::fmi2::schema::ScalarVariableElement::Boolean(_))
        })
}

/// Run road → plant → controller (Gauss–Seidel: the controller reads the plant's outputs at
/// `t_k` and its command is applied over `[t_k, t_k+1)`), recording `record` after each step:
/// plant outputs, or, for a name the plant lacks, the controller's variable (a Boolean as 0/1,
/// read when the controller has its inputs of `t_k+1`). `controller = None` is the passive car.
pub fn run_loop(
    plant: &Fmi2Import,
    controller: Option<&Fmi2Import>,
    road: &dyn Road,
    h: f64,
    steps: usize,
    record: &[&str],
) -> Vec<Vec<f64>> {
    run_loop_with(plant, controller, road, h, steps, record, &[])
}

/// [`run_loop`] with parameters set before initialisation (e.g. `("m_s", 1800.0)`): on the plant,
/// which must have each, and on the controller where it has one of the same name (the force
/// limits `u_max`, `u_max_seat` of an anti-windup controller).
pub fn run_loop_with(
    plant: &Fmi2Import,
    controller: Option<&Fmi2Import>,
    road: &dyn Road,
    h: f64,
    steps: usize,
    record: &[&str],
    plant_params: &[(&str, f64)],
) -> Vec<Vec<f64>> {
    let start = |imp: &Fmi2Import, name: &str| {
        let mut i: Instance<CS> = imp.instantiate_cs(name, false, false).expect("instantiate");
        for (param, value) in plant_params {
            match vr(imp, param) {
                Some(r) => {
                    i.set_real(&[r], &[*value]).unwrap();
                }
                None => assert!(name != "plant", "plant has no parameter {param}"),
            };
        }
        i.setup_experiment(None, 0.0, None).unwrap();
        Common::enter_initialization_mode(&mut i).unwrap();
        Common::exit_initialization_mode(&mut i).unwrap();
        i
    };
    let mut p = start(plant, "plant");
    let road_vr: Vec<u32> = ROAD_INPUTS
        .iter()
        .map(|n| vr(plant, n).expect("plant road input"))
        .collect();
    let force_vr: Vec<u32> = FORCES
        .iter()
        .map(|n| vr(plant, n).expect("plant force input"))
        .collect();
    // (on the controller?, Boolean?, value reference)
    let rec: Vec<(bool, bool, u32)> = record
        .iter()
        .map(|n| match (vr(plant, n), controller) {
            (Some(r), _) => (false, false, r),
            (None, Some(c)) => (
                true,
                is_boolean(c, n),
                vr(c, n).unwrap_or_else(|| panic!("neither plant nor controller has {n}")),
            ),
            (None, None) => panic!("plant has no output {n}"),
        })
        .collect();
    let mut ctrl = controller.map(|c| {
        let inputs = names_with_causality(c, "input");
        let from: Vec<u32> = inputs
            .iter()
            .map(|n| {
                vr(plant, n).unwrap_or_else(|| panic!("controller input {n} is not a plant output"))
            })
            .collect();
        let to: Vec<u32> = inputs.iter().map(|n| vr(c, n).unwrap()).collect();
        let out: Vec<u32> = FORCES
            .iter()
            .map(|n| vr(c, n).expect("controller output"))
            .collect();
        (start(c, "controller"), from, to, out)
    });
    let mut log = Vec::with_capacity(steps);
    for k in 0..steps {
        let t = k as f64 * h;
        p.set_real(&road_vr, &road.at(t)).unwrap();
        if let Some((c, from, to, out)) = ctrl.as_mut() {
            let mut y = vec![0.0; from.len()];
            p.get_real(from, &mut y).unwrap();
            c.set_real(to, &y).unwrap();
            let mut u = vec![0.0; out.len()];
            c.get_real(out, &mut u).unwrap();
            p.set_real(&force_vr, &u).unwrap();
            c.do_step(t, h, true).unwrap();
        }
        p.do_step(t, h, true).unwrap();
        p.set_real(&road_vr, &road.at(t + h)).unwrap();
        if let Some((c, from, to, _)) = ctrl.as_mut() {
            if rec.iter().any(|r| r.0) {
                let mut y = vec![0.0; from.len()];
                p.get_real(from, &mut y).unwrap();
                c.set_real(to, &y).unwrap();
            }
        }
        let mut row = vec![0.0; rec.len()];
        for (value, (on_controller, boolean, r)) in row.iter_mut().zip(&rec) {
            let mut v = [0.0];
            match (on_controller, ctrl.as_mut()) {
                (false, _) => {
                    p.get_real(&[*r], &mut v).unwrap();
                }
                (true, Some((c, ..))) if *boolean => {
                    let mut b = [0];
                    c.get_boolean(&[*r], &mut b).unwrap();
                    v[0] = b[0] as f64;
                }
                (true, Some((c, ..))) => {
                    c.get_real(&[*r], &mut v).unwrap();
                }
                (true, None) => unreachable!("resolved against the controller above"),
            }
            *value = v[0];
        }
        log.push(row);
    }
    log
}

pub fn rms(log: &[Vec<f64>], col: usize) -> f64 {
    (log.iter().map(|r| r[col] * r[col]).sum::<f64>() / log.len() as f64).sqrt()
}

pub fn peak(log: &[Vec<f64>], col: usize) -> f64 {
    log.iter().map(|r| r[col].abs()).fold(0.0, f64::max)
}
