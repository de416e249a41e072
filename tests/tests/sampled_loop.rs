//! The sampled-data prediction (`synth::predict::sampled`) against the co-simulation it describes, on a
//! road whose answer is deterministic: a sinusoidal road on one track (the rear wheel the
//! wheelbase later), the shipped plant and controller FMUs run by the master at the scenarios'
//! 1 ms step. Once settled, each recorded output is a sampled sinusoid `Re(A e^{jω t_k})`; its
//! amplitude `A`, fitted by least squares over the last seconds, must be the one the
//! prediction computes from the car's model and the controller's `controller.json` (held road,
//! held and delayed commands, the controller stepped exactly, the force the plant outputs at
//! each communication point). Two different algorithms: a time-domain co-simulation of the
//! FMUs and a frequency-domain solve of the discrete loop.

use integration_tests::*;
use master::cosim::RoadSource;
use nalgebra::Complex;
use synth::predict::continuous::{track_input, Conditions, ControlLaw};
use synth::predict::sampled::{Order, SampledLoop};

const STEP: f64 = 1e-3;
/// Road velocity amplitude [m/s]: small enough that no actuator reaches its force limit.
const AMPLITUDE: f64 = 0.01;

fn law(variant: &str) -> ControlLaw {
    let path = dist().join(variant).join("controller.json");
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("{}: {e} (run `make`)", path.display()));
    let file: synth::shipping::controller_file::ControllerFile =
        serde_json::from_str(&text).unwrap();
    ControlLaw::from_file(&file, 0.0).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// One case: a controller (None: the passive car) at conditions of the car, run by a master
/// in an order.
struct Case {
    variant: Option<&'static str>,
    conditions: Conditions,
    order: Order,
}

impl Case {
    /// `variant` with the actuators delayed by `delay` and of effectiveness `effectiveness`.
    fn new(variant: Option<&'static str>, delay: f64, effectiveness: [f64; 5]) -> Self {
        let nominal = Conditions::nominal(vehicle::VehicleParams::default());
        Case {
            variant,
            conditions: Conditions {
                delay,
                effectiveness,
                ..nominal
            },
            order: Order::GaussSeidel,
        }
    }

    /// The nominal car with `variant` run in `order`.
    fn in_order(variant: &'static str, order: Order) -> Self {
        Case {
            order,
            ..Case::new(Some(variant), 0.0, [1.0; 5])
        }
    }

    /// The master's order of the same name: the certificate's names are the master's.
    fn master_order(&self) -> master::cosim::Order {
        serde_json::from_value(serde_json::to_value(self.order).unwrap())
            .expect("the master runs every order the prediction knows")
    }

    /// The plant FMU's parameters that realise the conditions (`tau` also reaches a
    /// predictor, by the same name).
    fn parameters(&self) -> Vec<(String, f64)> {
        self.conditions
            .plant_parameters(&vehicle::VehicleParams::default())
            .into_iter()
            .collect()
    }
}

/// The plant outputs compared: the accelerations as read, then the vibration meter's weighted
/// ones (what `master compare` measures comfort with).
fn record() -> Vec<&'static str> {
    let meter = vehicle::iso2631::METER_OUTPUTS;
    let signals = meter.iter().map(|(_, signal, _, _)| *signal);
    signals
        .chain(meter.iter().map(|(name, ..)| *name))
        .collect()
}

/// The recorded [`record`] of a run on a road velocity `AMPLITUDE cos ω t` on the left track,
/// fitted as `Re(A e^{jωt})` over the last `fit` seconds (per m/s of road velocity).
fn cosimulated(case: &Case, f: f64, duration: f64, fit: f64) -> [Complex<f64>; 6] {
    let params = vehicle::VehicleParams::default();
    let omega = 2.0 * std::f64::consts::PI * f;
    let lag = (params.l1 + params.l2) / 20.0;
    // Heights and velocities FL, FR, RL, RR: the left track only; zero before t = 0.
    let road = move |t: f64| {
        let track = |t: f64| {
            if t < 0.0 {
                (0.0, 0.0)
            } else {
                (
                    AMPLITUDE * (omega * t).sin() / omega,
                    AMPLITUDE * (omega * t).cos(),
                )
            }
        };
        let (front, rear) = (track(t), track(t - lag));
        [front.0, 0.0, rear.0, 0.0, front.1, 0.0, rear.1, 0.0]
    };
    let plant = load("plant");
    let controller = case.variant.map(load);
    let steps = (duration / STEP).round() as usize;
    let parameters = case.parameters();
    let parameters: Vec<(&str, f64)> = parameters.iter().map(|(n, v)| (n.as_str(), *v)).collect();
    let log = run_in_order(
        RoadSource::InProcess(&road),
        &plant,
        controller.as_ref(),
        (STEP, steps, case.master_order()),
        &record(),
        &parameters,
    );
    // Row k is recorded at t_{k+1}; least squares on cos, sin over the window.
    let first = steps - (fit / STEP).round() as usize;
    std::array::from_fn(|col| {
        let (mut cc, mut cs, mut ss, mut yc, mut ys) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for (k, row) in log.iter().enumerate().skip(first) {
            let t = (k + 1) as f64 * STEP;
            let (c, s) = ((omega * t).cos(), (omega * t).sin());
            let y = row[col];
            cc += c * c;
            cs += c * s;
            ss += s * s;
            yc += y * c;
            ys += y * s;
        }
        let det = cc * ss - cs * cs;
        let a = (yc * ss - ys * cs) / det;
        let b = (ys * cc - yc * cs) / det;
        // y = a cos + b sin = Re((a − j b) e^{jωt}).
        Complex::new(a, -b) / AMPLITUDE
    })
}

fn predicted(case: &Case, f: f64) -> [Complex<f64>; 6] {
    let conditions = case.conditions;
    let law = case.variant.map(|v| {
        let mut law = law(v);
        if let Some(p) = law.predictor.as_mut() {
            p.delay = conditions.delay;
        }
        law
    });
    let lp = SampledLoop::in_order(law.as_ref(), conditions, STEP, case.order).unwrap();
    let omega = 2.0 * std::f64::consts::PI * f;
    let p = &conditions.params;
    lp.recorded(omega, &track_input(0, omega, (p.l1 + p.l2) / 20.0))
}

/// Every kind of controller runtime (state feedback, observer, predictor, accommodation) and
/// of actuator (ideal; delayed by whole steps, which a predictor compensates; delayed by a
/// fraction of a step, with and without a predictor, whose delayed command then changes
/// mid-step, below one step among them, where the predictor predicts over the step; at half
/// force with the fault accommodated), and the master's other orders (Jacobi; the controller
/// stepped first) for a state feedback, an observer (`hinf_of`) and a predictor told the order
/// (`delay_sf`'s `master_order`, which the master sets; in the Jacobi order with no delay and
/// with one of a fraction of a step), at a body-mode and a
/// wheel-hop-side frequency: the amplitudes agree to 10⁻⁶. Measured (2 December 2026): at
/// most 5.4·10⁻⁹ for every controller stepped in its balanced Schur basis
/// (`fmu_controller::schur`), at most 5.3·10⁻⁸ for `delay_sf`'s predictor. Before the runtime
/// balanced the controller's realisation (whose `A` has a 1-norm of about 10⁹ against
/// eigenvalues of at most 1.7·10³) the Schur form's rounding was the whole difference: the
/// `hinf_of` designed behind ideal actuators measured 4.9·10⁻⁶ to 6.2·10⁻⁶ on the seat at
/// 1.3 Hz in every order, moving with the synthesis run, and the one designed behind 30 Hz
/// actuators 1.4·10⁻⁵ to 1.6·10⁻⁵, the same at 150 s, at 1/100 of the amplitude and under a
/// diagonal similarity of the controller's prediction — a bound of 10⁻⁵ then held by luck
/// alone. (`delay_sf`'s unweighted seat with no delay was held to 10⁻⁴ while
/// it predicted over no delay, 6.4·10⁻⁶ and 1.9·10⁻⁵ measured: the force correction then closed
/// the seat command's loop within the step. Predicting over one step, there is no correction
/// and it is 4.5·10⁻¹⁰.)
#[test]
fn the_sampled_prediction_is_the_cosimulation_of_a_sinusoidal_road() {
    let healthy = [1.0; 5];
    let cases = [
        Case::new(None, 0.0, healthy),
        Case::new(Some("hinf_sf"), 0.0, healthy),
        Case::new(Some("hinf_of"), 0.0, healthy),
        Case::new(Some("hinf_of"), 0.0055, healthy),
        Case::new(Some("delay_sf"), 0.0, healthy),
        Case::new(Some("delay_sf"), 0.0005, healthy),
        Case::new(Some("delay_sf"), 0.02, healthy),
        Case::new(Some("delay_sf"), 0.0015, healthy),
        Case::new(Some("delay_sf"), 0.0205, healthy),
        Case::new(Some("ft_of"), 0.0, [1.0, 1.0, 0.5, 1.0, 1.0]),
        Case::in_order("hinf_sf", Order::Jacobi),
        Case::in_order("hinf_sf", Order::ControllerFirst),
        Case::in_order("hinf_of", Order::Jacobi),
        Case::in_order("hinf_of", Order::ControllerFirst),
        Case::in_order("delay_sf", Order::Jacobi),
        Case::in_order("delay_sf", Order::ControllerFirst),
        Case {
            order: Order::Jacobi,
            ..Case::new(Some("delay_sf"), 0.0205, healthy)
        },
    ];
    let mut worst = 0.0f64;
    for case in &cases {
        for f in [1.3, 7.0] {
            let measured = cosimulated(case, f, 60.0, 10.0);
            let model = predicted(case, f);
            for (k, (m, p)) in measured.iter().zip(&model).enumerate() {
                let err = (m - p).norm() / p.norm();
                println!(
                    "{:?} {:?} {:?} {f} Hz, {}: |A| predicted {:.6e}, co-simulated {:.6e}, \
                     relative difference {err:.1e}",
                    case.variant,
                    case.order,
                    case.parameters(),
                    record()[k],
                    p.norm(),
                    m.norm()
                );
                assert!(
                    err < 1e-6,
                    "{:?} {:?} {:?} at {f} Hz, {}: predicted {p}, co-simulated {m}",
                    case.variant,
                    case.order,
                    case.parameters(),
                    record()[k]
                );
                worst = worst.max(err);
            }
        }
    }
    println!("largest relative difference {worst:.1e}");
}
