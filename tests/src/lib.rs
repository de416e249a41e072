//! Helpers for the integration tests: locate the FMUs `make` built into `dist/` (and the thesis's
//! H∞ designs `make thesis` builds into `dist/thesis/`), road profiles, and the master's
//! co-simulation loop with the tests' parameters and records.

use master::cosim::{simulate, Participant, Setup, Typed};
pub use master::cosim::{Fmu, RoadSource};
use std::path::PathBuf;

/// `dist/<name>.fmu`, or a panic that says how to build it.
pub fn dist_fmu(name: &str) -> PathBuf {
    fmu_in(&dist(), name)
}

fn fmu_in(dir: &std::path::Path, name: &str) -> PathBuf {
    let path = dir.join(format!("{name}.fmu"));
    assert!(
        path.exists(),
        "{} not found: run `make` and `make thesis` (or `make test`, which builds both first)",
        path.display()
    );
    path
}

/// The shipped FMUs (`make`).
pub fn dist() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join("dist")
}

/// The thesis's H∞ designs with copies of the road and plant FMUs (`make thesis`).
pub fn thesis() -> PathBuf {
    dist().join("thesis")
}

/// `dist/<name>.fmu`, loaded as the master loads it.
pub fn load(name: &str) -> Fmu {
    load_from(&dist(), name)
}

/// `<dir>/<name>.fmu`, loaded as the master loads it.
pub fn load_from(dir: &std::path::Path, name: &str) -> Fmu {
    fmu_in(dir, name);
    Fmu::load(dir, name).unwrap_or_else(|e| panic!("cannot load {name}.fmu: {e}"))
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

/// Run road → plant → controller through the master's loop ([`master::cosim::simulate`]),
/// recording `record` after each step as rows: plant outputs, or, for a name the plant lacks,
/// the controller's variable (a Boolean as 0/1). `controller = None` is the passive car.
pub fn run_loop(
    plant: &Fmu,
    controller: Option<&Fmu>,
    road: &vehicle::road::Road,
    h: f64,
    steps: usize,
    record: &[&str],
) -> Vec<Vec<f64>> {
    run_loop_with(plant, controller, road, h, steps, record, &[])
}

/// [`run_loop`] with parameters set before initialisation (e.g. `("m_s", 1800.0)`): on the plant,
/// which must have each, and on the controller where it has a parameter of the same name (the
/// force limits `u_max`, `u_max_seat` of an anti-windup controller), as a scenario's are.
pub fn run_loop_with(
    plant: &Fmu,
    controller: Option<&Fmu>,
    road: &vehicle::road::Road,
    h: f64,
    steps: usize,
    record: &[&str],
    plant_params: &[(&str, f64)],
) -> Vec<Vec<f64>> {
    let at = |t: f64| road.at(t);
    run_on(
        RoadSource::InProcess(&at),
        plant,
        controller,
        h,
        steps,
        record,
        plant_params,
    )
}

/// [`run_loop_with`] on any road source (the road FMU among them).
pub fn run_on(
    road: RoadSource,
    plant: &Fmu,
    controller: Option<&Fmu>,
    h: f64,
    steps: usize,
    record: &[&str],
    plant_params: &[(&str, f64)],
) -> Vec<Vec<f64>> {
    run_in_order(
        road,
        plant,
        controller,
        (h, steps, master::cosim::Order::GaussSeidel),
        record,
        plant_params,
    )
}

/// [`run_on`] with the master in `order`, at `(h, steps, order)`.
pub fn run_in_order(
    road: RoadSource,
    plant: &Fmu,
    controller: Option<&Fmu>,
    (h, steps, order): (f64, usize, master::cosim::Order),
    record: &[&str],
    plant_params: &[(&str, f64)],
) -> Vec<Vec<f64>> {
    let typed = |fmu: &Fmu, only_parameters: bool| -> Vec<(String, Typed)> {
        let inputs = fmu.names_with_causality("input");
        plant_params
            .iter()
            .filter(|(n, _)| !only_parameters || (fmu.has(n) && !inputs.iter().any(|i| i == n)))
            .map(|(n, v)| {
                let t = fmu
                    .typed(n, &serde_json::json!(v))
                    .unwrap_or_else(|e| panic!("{e}"));
                (n.to_string(), t)
            })
            .collect()
    };
    let plant_values = typed(plant, false);
    let ctrl_values = controller.map(|c| typed(c, true)).unwrap_or_default();
    let record: Vec<String> = record.iter().map(|s| s.to_string()).collect();
    let run = simulate(&Setup {
        road,
        plant: Participant {
            fmu: plant,
            params: &plant_values,
        },
        controller: controller.map(|fmu| Participant {
            fmu,
            params: &ctrl_values,
        }),
        step: h,
        steps,
        record: &record,
        order,
    })
    .unwrap_or_else(|e| panic!("co-simulation failed: {e}"));
    run.rows().map(|r| r.to_vec()).collect()
}

pub fn rms(log: &[Vec<f64>], col: usize) -> f64 {
    (log.iter().map(|r| r[col] * r[col]).sum::<f64>() / log.len() as f64).sqrt()
}

pub fn peak(log: &[Vec<f64>], col: usize) -> f64 {
    log.iter().map(|r| r[col].abs()).fold(0.0, f64::max)
}
