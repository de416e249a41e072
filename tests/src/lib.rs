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
    assert!(path.exists(), "{} not found: run `make` (or `make test`, which builds it first)", path.display());
    path
}

pub fn dist() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..").join("dist")
}

pub fn load(name: &str) -> Fmi2Import {
    fmi::import::from_path(dist_fmu(name)).unwrap_or_else(|e| panic!("cannot load {name}.fmu: {e}"))
}

pub fn vr(import: &Fmi2Import, name: &str) -> Option<u32> {
    import.model_description().model_variables.variables.iter().find(|v| v.name == name).map(|v| v.value_reference)
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

/// The 5 cm, 5 m long 1 − cos bump at 15 m/s on the left wheels.
pub struct Bump {
    pub height: f64,
    pub length: f64,
    pub speed: f64,
    pub start: f64,
    pub wheelbase: f64,
}

impl Default for Bump {
    fn default() -> Self {
        Bump { height: 0.05, length: 5.0, speed: 15.0, start: 0.1, wheelbase: 2.4 }
    }
}

impl Bump {
    fn one(&self, t: f64) -> (f64, f64) {
        let x = self.speed * (t - self.start);
        if (0.0..=self.length).contains(&x) {
            let w = 2.0 * std::f64::consts::PI / self.length;
            (0.5 * self.height * (1.0 - (w * x).cos()), 0.5 * self.height * w * self.speed * (w * x).sin())
        } else {
            (0.0, 0.0)
        }
    }
}

impl Road for Bump {
    fn at(&self, t: f64) -> [f64; 8] {
        let (zf, vf) = self.one(t);
        let (zr, vr) = self.one(t - self.wheelbase / self.speed);
        [zf, 0.0, zr, 0.0, vf, 0.0, vr, 0.0]
    }
}

/// An ISO 8608 random road as a sum of cosines: `G_d(n) = G_d(n0) (n/n0)^-2`, `n0 = 0.1`
/// cycles/m, over 0.011–2.83 cycles/m, left and right tracks independent (seeded), the rear
/// wheels on the front track delayed by the wheelbase. `road_v` is the exact derivative.
pub struct IsoRoad {
    speed: f64,
    wheelbase: f64,
    /// Per track: (amplitude [m], spatial frequency [cycles/m], phase).
    tracks: [Vec<(f64, f64, f64)>; 2],
}

impl IsoRoad {
    pub fn new(g_d_n0: f64, speed: f64, seed: u64) -> Self {
        let mut state = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        let mut rand = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let (n_lo, n_hi, k) = (0.011f64, 2.83f64, 400);
        let mut track = || {
            (0..k)
                .map(|i| {
                    let a = (n_lo.ln() + (n_hi / n_lo).ln() * i as f64 / k as f64).exp();
                    let b = (n_lo.ln() + (n_hi / n_lo).ln() * (i + 1) as f64 / k as f64).exp();
                    let n = (a * b).sqrt();
                    let g = g_d_n0 * (n / 0.1f64).powi(-2);
                    ((2.0 * g * (b - a)).sqrt(), n, 2.0 * std::f64::consts::PI * rand())
                })
                .collect::<Vec<_>>()
        };
        let left = track();
        let right = track();
        IsoRoad { speed, wheelbase: 2.4, tracks: [left, right] }
    }

    fn track(&self, side: usize, x: f64) -> (f64, f64) {
        let two_pi = 2.0 * std::f64::consts::PI;
        self.tracks[side].iter().fold((0.0, 0.0), |(z, v), (a, n, p)| {
            let arg = two_pi * n * x + p;
            (z + a * arg.cos(), v - a * two_pi * n * self.speed * arg.sin())
        })
    }
}

/// Fade-in time of the random road [s]: the car starts in equilibrium on a flat road, so the
/// profile is brought in smoothly (`½(1 − cos)` window) instead of as a step at t = 0.
pub const FADE_IN: f64 = 1.0;

impl Road for IsoRoad {
    fn at(&self, t: f64) -> [f64; 8] {
        let (w, dw) = if t >= FADE_IN {
            (1.0, 0.0)
        } else {
            let a = std::f64::consts::PI / FADE_IN;
            (0.5 * (1.0 - (a * t).cos()), 0.5 * a * (a * t).sin())
        };
        let xf = self.speed * t + self.wheelbase;
        let xr = self.speed * t;
        let tracks = [self.track(0, xf), self.track(1, xf), self.track(0, xr), self.track(1, xr)];
        let mut r = [0.0; 8];
        for (i, (z, v)) in tracks.iter().enumerate() {
            r[i] = w * z;
            r[4 + i] = w * v + dw * z;
        }
        r
    }
}

pub const ROAD_INPUTS: [&str; 8] = ["road_z_fl", "road_z_fr", "road_z_rl", "road_z_rr", "road_v_fl", "road_v_fr", "road_v_rl", "road_v_rr"];
pub const FORCES: [&str; 5] = ["u_fl", "u_fr", "u_rl", "u_rr", "u_seat"];

/// Whether `name` is a Boolean variable of `import`.
pub fn is_boolean(import: &Fmi2Import, name: &str) -> bool {
    import.model_description().model_variables.variables.iter().any(|v| v.name == name && matches!(v.elem, fmi::fmi2::schema::ScalarVariableElement::Boolean(_)))
}

/// Run road → plant → controller (Gauss–Seidel: the controller reads the plant's outputs at
/// `t_k` and its command is applied over `[t_k, t_k+1)`), recording `record` after each step:
/// plant outputs, or, for a name the plant lacks, the controller's variable (a Boolean as 0/1,
/// read when the controller has its inputs of `t_k+1`). `controller = None` is the passive car.
pub fn run_loop(plant: &Fmi2Import, controller: Option<&Fmi2Import>, road: &dyn Road, h: f64, steps: usize, record: &[&str]) -> Vec<Vec<f64>> {
    run_loop_with(plant, controller, road, h, steps, record, &[])
}

/// [`run_loop`] with parameters set before initialisation (e.g. `("m_s", 1800.0)`): on the plant,
/// which must have each, and on the controller where it has one of the same name (the force
/// limits `u_max`, `u_max_seat` of an anti-windup controller).
pub fn run_loop_with(plant: &Fmi2Import, controller: Option<&Fmi2Import>, road: &dyn Road, h: f64, steps: usize, record: &[&str], plant_params: &[(&str, f64)]) -> Vec<Vec<f64>> {
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
    let road_vr: Vec<u32> = ROAD_INPUTS.iter().map(|n| vr(plant, n).expect("plant road input")).collect();
    let force_vr: Vec<u32> = FORCES.iter().map(|n| vr(plant, n).expect("plant force input")).collect();
    // (on the controller?, Boolean?, value reference)
    let rec: Vec<(bool, bool, u32)> = record
        .iter()
        .map(|n| match (vr(plant, n), controller) {
            (Some(r), _) => (false, false, r),
            (None, Some(c)) => (true, is_boolean(c, n), vr(c, n).unwrap_or_else(|| panic!("neither plant nor controller has {n}"))),
            (None, None) => panic!("plant has no output {n}"),
        })
        .collect();
    let mut ctrl = controller.map(|c| {
        let inputs = names_with_causality(c, "input");
        let from: Vec<u32> = inputs.iter().map(|n| vr(plant, n).unwrap_or_else(|| panic!("controller input {n} is not a plant output"))).collect();
        let to: Vec<u32> = inputs.iter().map(|n| vr(c, n).unwrap()).collect();
        let out: Vec<u32> = FORCES.iter().map(|n| vr(c, n).expect("controller output")).collect();
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
