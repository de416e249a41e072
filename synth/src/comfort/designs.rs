//! The shipped designs: each minimises the ISO 2631-1 comfort norm on the design's ISO 8608
//! road subject to its own guarantee (`synth/designs/comfort.json`), and is certified by
//! computations independent of its synthesis.
//!
//! Every design tolerates the actuators' unmodelled delay up to `unmodelled_delay` (the
//! input-multiplicative channel of [`ComfortPlant::with_delay_weight`]); the robust ones also:
//! * `robust_sf` / `robust_of`: every sprung mass of `[mass_min, mass_max]` (rank-one channel,
//!   [`mass_channel`]), the guaranteed-cost gain over it, and for `robust_of` (on the car's
//!   sensors, [`crate::comfort::car::robust_design`]) a Kalman filter that trusts its heave
//!   dynamics less (fictitious noise on the mass channel);
//! * `delay_sf`: any known actuator delay up to `delay_max`, by a predictor in the controller
//!   ([`crate::comfort::predictor`]) in front of `hinf_sf`'s gain;
//! * `ft_of`: every actuator effectiveness in `[fault_rho_min, 1]`, by an observer driven by the
//!   measured applied forces and fault accommodation: each actuator's effectiveness estimated
//!   from its load cell and divided out of its command
//!   ([`crate::comfort::car::fault_tolerant_design`]);
//! * `hinf_of_aw`: saturation, by `hinf_of` plus the decoupled anti-windup of thesis Th. 5.3
//!   ([`anti_windup_design`]).
//!
//! Certificates ([`ComfortCertificate`]): the comfort figures predicted on the car as the FMUs
//! run it ([`crate::predict::continuous`], exact wheelbase delay, full weightings) beside the passive
//! car's; robust stability to the unmodelled delay (the small-gain norm by Hamiltonian bisection
//! and the exact delay margin); the design's guaranteed bound over its uncertainty
//! ([`UncertainLoop::bound`], one Lyapunov matrix, checked by eigenvalues, on the car model of
//! [`bound_model`]) checked against that model's exact H2 norms on a dense grid of the
//! uncertainty; predictions over the uncertainty; the limits at `limit_sigmas` standard
//! deviations. A failed check is an error.

use crate::comfort::controllers::{plant_of, realise_state_feedback, state_feedback_sensors};
use crate::comfort::guaranteed::{self, Bound, StateFeedback, UncertainLoop};
use crate::comfort::plant::{fault_channel, force_limits, mass_channel, Channel, ComfortPlant};
use crate::numerics::hinf_norm::{Analysis, Lti};
use crate::numerics::interconnect::{close, ClosedLoop, Plant, Sensors};
use crate::predict::continuous::{predict, Conditions, ControlLaw, Figures, Loop};
use crate::shipping::controller_file::{matrix_rows, AntiWindup, Extensions};
use crate::shipping::design::{ComfortDesign, ComfortRoad, RearWheels};
use crate::thesis::fault::FaultBox;
use nalgebra::DMatrix;
use serde::Serialize;
use vehicle::model::{ACTUATORS, CORNERS, N_ACTUATORS};
use vehicle::VehicleParams;

/// Why a comfort design was not produced.
#[derive(Debug, thiserror::Error)]
pub enum ComfortError {
    #[error("{variant}: synthesis failed: {reason}")]
    Synthesis { variant: String, reason: String },
    #[error("{variant}: certificate failed: {reason}")]
    Certificate { variant: String, reason: String },
}

/// What a design is robust to, beyond the unmodelled delay every design tolerates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Uncertainty {
    None,
    SprungMass,
    InputDelay,
    ActuatorFaults,
    Saturation,
}

impl Uncertainty {
    /// As the summary tables say it (the thesis designs' words).
    pub fn label(self) -> &'static str {
        match self {
            Uncertainty::None => "-",
            Uncertainty::SprungMass => "sprung mass",
            Uncertainty::InputDelay => "input delay",
            Uncertainty::ActuatorFaults => "actuator faults",
            Uncertainty::Saturation => "actuator saturation",
        }
    }
}

/// The comfort figures of a certificate.
#[derive(Debug, Clone, Serialize)]
pub struct Comfort {
    pub road: RoadDescription,
    /// At the nominal car, continuous time (the co-simulation's hold aside).
    pub predicted_wk_rms_seat_m_s2: f64,
    pub passive_wk_rms_seat_m_s2: f64,
    /// The prediction for a nominal design; for a robust one the bound over its uncertainty,
    /// where one is certified and covers every prediction on the exact car (else `null`, and
    /// `uncertainty.bound_failure` says why).
    pub guaranteed_wk_rms_seat_m_s2: Option<f64>,
    pub predicted: Figures,
    pub passive: Figures,
    /// The same on the design model (Padé rear track, weightings without their 100 Hz
    /// band-limit, the road's full band): its exact H2 norms.
    pub design_model_wk_rms_seat_m_s2: f64,
    pub design_model_vibration_total_m_s2: f64,
    /// Over the design's uncertainty, when it has one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub uncertainty: Option<OverUncertainty>,
    /// At the nominal car as a master runs the loop: sampled and held at a communication step.
    pub held: Held,
    /// The loop as a master runs it at other communication steps: stable, and from the design
    /// file's step up what each costs in comfort.
    pub communication_steps: StepStability,
    /// The loop at the nominal car and the design file's step in each order a master may run
    /// it ([`crate::predict::sampled::Order`]).
    pub master_orders: Vec<InOrder>,
}

/// The held loop in one master order (`master_orders`).
#[derive(Debug, Clone, Serialize)]
pub struct InOrder {
    pub order: crate::predict::sampled::Order,
    /// `predicted`, `unstable`, or `not modelled: …` (a loop the sampled prediction does not
    /// model). A predictor is told the order (`synth::predict::sampled`'s `told_the_order`).
    pub verdict: String,
    /// `W_k` seat RMS time-averaged, where predicted.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub predicted_wk_rms_seat_m_s2: Option<f64>,
    /// The same as the master records it (its figure), where predicted.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub recorded_wk_rms_seat_m_s2: Option<f64>,
}

/// `law` at the nominal car and the design file's step in each order a master may run it.
fn master_orders(law: &ControlLaw, nominal: Conditions, d: &ComfortDesign) -> Vec<InOrder> {
    use crate::predict::sampled::{order_check, ORDERS};
    ORDERS
        .iter()
        .map(|&order| {
            let check = order_check(
                Some(law),
                nominal,
                d.communication_step,
                order,
                Some(&d.road),
            );
            let (verdict, seat) = match check {
                Ok(c) => match c.seat {
                    Some(seat) => ("predicted".to_string(), Some(seat)),
                    None => ("unstable".to_string(), None),
                },
                Err(crate::predict::continuous::PredictionError::NotModelled(why)) => {
                    (format!("not modelled: {why}"), None)
                }
                Err(e) => (format!("unstable: {e}"), None),
            };
            InOrder {
                order,
                verdict,
                predicted_wk_rms_seat_m_s2: seat.map(|s| s.predicted_wk_rms_seat_m_s2),
                recorded_wk_rms_seat_m_s2: seat.map(|s| s.recorded_wk_rms_seat_m_s2),
            }
        })
        .collect()
}

/// Communication steps \[s\] at which each certificate checks the nominal loop as a master runs
/// it: the design file's step is one master's choice, and a sample-and-hold destabilises a loop
/// whose fastest closed-loop mode it cannot follow.
pub const CHECKED_STEPS: [f64; 10] = [
    0.25e-3, 0.5e-3, 1e-3, 1.25e-3, 1.5e-3, 2e-3, 3e-3, 5e-3, 7.5e-3, 10e-3,
];

/// The loop as a master runs it at each of [`CHECKED_STEPS`]: the nominal car's, for a robust
/// design also the loops at its uncertainty's conditions, and for a design that compensates a
/// known delay the loops at delays across its interval. Stability at every checked step, and
/// from the design file's step up the held comfort on the design road: a step the loop is
/// stable at can still cost most of the comfort (`delay_sf` with a 50 ms delay at 10 ms).
#[derive(Debug, Clone, Serialize)]
pub struct StepStability {
    /// The conditions checked at every step.
    pub conditions: String,
    pub checked: Vec<CheckedStep>,
    /// The largest checked step up to which every checked step is stable (`null`: not even the
    /// first). Checked on this grid only: between two checked steps nothing is claimed.
    pub stable_up_to_s: Option<f64>,
}

/// One checked step.
#[derive(Debug, Clone, Serialize)]
pub struct CheckedStep {
    pub step_s: f64,
    /// At the sampling instants, the largest over the conditions; below 1 is stable. `null`
    /// where a loop could not be formed (an exponential failed).
    pub spectral_radius: Option<f64>,
    /// From the design file's step up, where every loop is stable: the held `W_k` seat on the
    /// design road ([`crate::predict::sampled::step_check`]). `null` below the design file's step, where
    /// stability alone is checked (the held loop tends to the continuous one as the step
    /// shrinks, and at 0.25 ms a 50 ms delay's loop has 1080 states), and where a loop is
    /// unstable.
    pub comfort: Option<StepComfort>,
}

/// The held `W_k` seat at a checked step.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct StepComfort {
    /// The nominal car's (the first loop checked): time-averaged, and as a master records it.
    pub nominal: crate::predict::sampled::HeldSeat,
    /// The worst time-averaged over every loop checked.
    pub worst_predicted_wk_rms_seat_m_s2: f64,
}

impl CheckedStep {
    pub fn stable(&self) -> bool {
        self.spectral_radius.is_some_and(|r| r < 1.0)
    }
}

impl StepStability {
    /// What the controller FMU warns by (`controller.json`'s `communication_steps`); `None`
    /// when not even the first checked step is stable (no such design is written).
    pub fn for_the_fmu(&self) -> Option<crate::shipping::controller_file::CommunicationSteps> {
        Some(crate::shipping::controller_file::CommunicationSteps {
            stable_up_to_s: self.stable_up_to_s?,
            unstable_at_s: self.first_unstable_s(),
        })
    }

    /// The smallest checked step at which the loop is not stable, if any.
    pub fn first_unstable_s(&self) -> Option<f64> {
        self.checked.iter().find(|c| !c.stable()).map(|c| c.step_s)
    }

    /// Each loop (a law at its conditions; the nominal car's first) at every checked step, the
    /// loops described by `conditions`, with their comfort on `road` from `design_step` up.
    pub fn check(
        loops: &[(ControlLaw, Conditions)],
        conditions: &str,
        road: &ComfortRoad,
        design_step: f64,
    ) -> Self {
        use rayon::prelude::*;
        let checked: Vec<CheckedStep> = CHECKED_STEPS
            .par_iter()
            .map(|&step_s| {
                let seat_on = (step_s >= design_step * (1.0 - 1e-9)).then_some(road);
                let checks: Option<Vec<crate::predict::sampled::StepCheck>> = loops
                    .par_iter()
                    .map(|(law, c)| {
                        crate::predict::sampled::step_check(Some(law), *c, step_s, seat_on).ok()
                    })
                    .collect();
                let radius = checks
                    .as_ref()
                    .map(|c| crate::numerics::eig::max_or_nan(0.0, c.iter().map(|c| c.radius)));
                // A seat only where its loop is stable: all of them or none.
                let seats: Option<Vec<crate::predict::sampled::HeldSeat>> =
                    checks.and_then(|c| c.iter().map(|c| c.seat).collect());
                CheckedStep {
                    step_s,
                    spectral_radius: radius,
                    comfort: seats.and_then(|s| {
                        Some(StepComfort {
                            nominal: *s.first()?,
                            worst_predicted_wk_rms_seat_m_s2: s
                                .iter()
                                .map(|s| s.predicted_wk_rms_seat_m_s2)
                                .fold(0.0, f64::max),
                        })
                    }),
                }
            })
            .collect();
        let stable_up_to_s = checked
            .iter()
            .take_while(|c| c.stable())
            .last()
            .map(|c| c.step_s);
        StepStability {
            conditions: conditions.into(),
            checked,
            stable_up_to_s,
        }
    }
}

/// The nominal prediction for the sampled-data loop of a co-simulation ([`crate::predict::sampled`]):
/// road and commands held over each step, the controller stepped exactly.
#[derive(Debug, Clone, Serialize)]
pub struct Held {
    pub step_s: f64,
    /// `W_k` seat RMS of the car, time-averaged (what the occupant feels).
    pub predicted_wk_rms_seat_m_s2: f64,
    /// The same as a master measures it (`master compare`'s figure): the plant's weighted
    /// outputs (its vibration meter) sampled at the communication points.
    pub recorded_wk_rms_seat_m_s2: f64,
    pub recorded_we_rms_roll_rad_s2: f64,
    pub recorded_we_rms_pitch_rad_s2: f64,
    pub predicted: Figures,
}

#[derive(Debug, Clone, Serialize)]
pub struct RoadDescription {
    pub iso_class: String,
    pub speed_m_s: f64,
    pub tracks: &'static str,
    pub rear_wheels: String,
    pub band_hz: [f64; 2],
}

/// The car model's comfort behind a predictor that predicts it, `J(θ)`
/// ([`crate::comfort::predictor::comfort_at`]), over the whole of `[0, θ_max]`: its worst on an even grid
/// of `intervals + 1` delays, and a bound that holds between them.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct OverDelays {
    pub delay_max_s: f64,
    /// In the certificate as `bound_model_grid_points` (`intervals + 1`).
    #[serde(skip)]
    pub intervals: usize,
    /// The worst of `J` at the grid's delays (a lower bound on its supremum). In the
    /// certificate as `bound_model_grid_worst_wk_rms_seat`.
    #[serde(skip)]
    pub grid_worst: f64,
    /// An upper bound on `J(θ)` at every `θ` of the interval.
    pub bound: f64,
}

/// Predictions and bounds over the design's uncertainty.
#[derive(Debug, Clone, Serialize)]
pub struct OverUncertainty {
    pub kind: Uncertainty,
    /// `(condition, figures)` at the checked conditions.
    pub predictions: Vec<(String, Figures)>,
    pub worst_predicted_wk_rms_seat_m_s2: f64,
    /// The model the bounds and the check grid are computed on: the car model of
    /// [`bound_model`] (for `delay_sf` with the gain's preview beside it, which its predictor
    /// predicts).
    pub bound_model: String,
    /// The guaranteed bounds on `bound_model`, seat and vibration total.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bound_wk_rms_seat: Option<Bound>,
    /// Why there is no bound, where there is none.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bound_failure: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bound_vibration_total: Option<Bound>,
    /// `bound_model`'s exact H2 norm (seat) at every point of the dense check grid, worst.
    /// With accommodation, the loops without compensation: the frozen loops a fault's
    /// transient passes through while the estimate settles.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bound_model_grid_worst_wk_rms_seat: Option<f64>,
    /// Fault accommodation down to this effectiveness: in stationary operation the loop at
    /// every effectiveness of the box is the nominal loop (each actuator applies the asked
    /// force), so the predictions over the box are the nominal prediction and that is the bound.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub accommodated_down_to: Option<f64>,
    pub bound_model_grid_points: usize,
    /// A delay interval's bound on the car model (`delay_sf`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub over_delays: Option<OverDelays>,
    /// The nominal counterpart at the same conditions (filled by the registry; `None` where it
    /// is unstable).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub nominal_name: Option<String>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub nominal_design: Vec<(String, Option<Figures>)>,
    /// The nominal counterpart as a master runs it at the same conditions and step as `held`
    /// (`None` where it is unstable there).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub nominal_held: Vec<Option<Held>>,
    /// The loop as a master runs it at the design file's communication step, at each condition
    /// of `predictions` (`None` where it is unstable there), and the worst `W_k` seat.
    pub held: Vec<Option<Held>>,
    pub worst_held_wk_rms_seat_m_s2: f64,
    /// The conditions of `predictions`.
    #[serde(skip)]
    pub conditions: Vec<Conditions>,
    /// The same as the plant FMU's parameters (beside its defaults): what a co-simulation sets
    /// to measure each prediction.
    pub plant_parameters: Vec<std::collections::BTreeMap<String, f64>>,
}

impl OverUncertainty {
    /// The predictions at `conditions`, their worst and the plant FMU parameters that realise
    /// each beside the car `nominal`; no bound and no nominal counterpart yet.
    pub fn predicted(
        kind: Uncertainty,
        predictions: Vec<(String, Figures)>,
        conditions: Vec<Conditions>,
        nominal: &VehicleParams,
    ) -> Self {
        OverUncertainty {
            kind,
            worst_predicted_wk_rms_seat_m_s2: worst_seat(&predictions),
            predictions,
            bound_model: String::new(),
            bound_wk_rms_seat: None,
            bound_failure: None,
            bound_vibration_total: None,
            bound_model_grid_worst_wk_rms_seat: None,
            accommodated_down_to: None,
            bound_model_grid_points: 0,
            over_delays: None,
            nominal_name: None,
            nominal_design: Vec::new(),
            nominal_held: Vec::new(),
            held: Vec::new(),
            worst_held_wk_rms_seat_m_s2: f64::NAN,
            plant_parameters: conditions
                .iter()
                .map(|c| c.plant_parameters(nominal))
                .collect(),
            conditions,
        }
    }

    /// `bound` (on `bound_model`) as the guarantee for the car where it covers every
    /// prediction on the car; otherwise none, and `bound_failure` says why (`over` says over
    /// what).
    pub fn claim(&mut self, bound: f64, over: &str) -> Option<f64> {
        let worst = self.worst_predicted_wk_rms_seat_m_s2;
        if bound >= worst {
            return Some(bound);
        }
        self.bound_failure = Some(format!(
            "the bound {bound:.5}{over} on {} does not cover the exact car's worst prediction \
             {worst:.5}: no guarantee claimed",
            self.bound_model
        ));
        None
    }

    /// The held loop at every condition with `law`, evaluated in parallel.
    pub fn predict_held(&mut self, law: &ControlLaw, d: &ComfortDesign) {
        use rayon::prelude::*;
        let held = self
            .conditions
            .par_iter()
            .map(|c| held_at(law, *c, d))
            .collect();
        self.set_held(held);
    }

    /// The held loop's predictions at the conditions, in their order, and their worst.
    pub fn set_held(&mut self, held: Vec<Option<Held>>) {
        assert_eq!(held.len(), self.conditions.len());
        self.worst_held_wk_rms_seat_m_s2 = worst_held(&held);
        self.held = held;
    }
}

/// The worst `W_k` seat of held predictions, infinite where one is unstable (`None`).
pub fn worst_held(held: &[Option<Held>]) -> f64 {
    held.iter()
        .map(|h| {
            h.as_ref()
                .map_or(f64::INFINITY, |h| h.predicted_wk_rms_seat_m_s2)
        })
        .fold(0.0, f64::max)
}

/// Robust stability to the actuators' unmodelled delay.
#[derive(Debug, Clone, Serialize)]
pub struct UnmodelledDelay {
    pub tolerated_delay_s: f64,
    /// `‖q ← p‖∞` of the input-multiplicative channel (Hamiltonian bisection): below 1.
    pub small_gain_norm: f64,
    /// The exact delay margin of the loop broken at the actuators.
    pub delay_margin_s: f64,
}

/// The limits: their standard deviations predicted on the design road, over the limits,
/// times `limit_sigmas` (≤ 1 holds).
#[derive(Debug, Clone, Serialize)]
pub struct Limits {
    pub limit_sigmas: f64,
    pub stroke: [f64; 4],
    /// Where the design limits the seat stroke (`hinf_of`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub seat_stroke: Option<f64>,
    pub tire_load: [f64; 4],
    pub force: [f64; 5],
}

impl Limits {
    /// The limits of `predicted` at the design's `limit_sigmas`, whether they hold or not.
    fn of(predicted: &Figures, d: &ComfortDesign) -> Self {
        let limits = force_limits(d);
        let k = d.limit_sigmas;
        Limits {
            limit_sigmas: k,
            stroke: predicted.rms_stroke_m.map(|s| k * s / d.stroke_max),
            seat_stroke: d
                .seat_stroke_max
                .map(|max| k * predicted.rms_seat_stroke_m / max),
            tire_load: predicted.rms_tire_load_ratio.map(|s| k * s),
            force: std::array::from_fn(|i| k * predicted.rms_force_n[i] / limits[i]),
        }
    }
}

/// The worst-case (H∞) gain of the comfort channel: the road noise to the weighted comfort
/// output on the design model, the design's and the passive car's (Hamiltonian bisection).
#[derive(Debug, Clone, Serialize)]
pub struct HinfComfort {
    pub design: f64,
    pub passive: f64,
    pub design_peak_hz: f64,
    pub passive_peak_hz: f64,
}

/// On a constant grade or crossfall: what the controller reads of a rigid motion of the car
/// ([`crate::predict::continuous::rigid_readings`]), each input with its reading per metre,
/// radian or metre per second, and the steady force it holds in each rigid motion
/// ([`crate::predict::continuous::steady_forces`], from its gain at `s = 0`). Its steady force
/// on a grade is zero (its loop being stable, which the certificate checks) when it reads
/// nothing of a rigid motion, or reads it through a transfer that vanishes there (a state
/// feedback in a frame that follows the road, [`crate::comfort::plant::Frame`]).
#[derive(Debug, Clone, Serialize)]
pub struct Grade {
    pub steady_force_zero: bool,
    pub reads_rigid_motion: Vec<(String, f64)>,
    /// `(steady state, largest force [N])`, for a controller that reads a rigid motion
    /// ([`crate::predict::continuous::STEADY_STATES`]).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub steady_force_n: Vec<(String, f64)>,
}

impl Grade {
    /// The grade check of `law` on the car `p`.
    fn of(
        p: &VehicleParams,
        law: &ControlLaw,
        speed: f64,
    ) -> Result<Grade, crate::predict::continuous::PredictionError> {
        use crate::predict::continuous::{rigid_readings, steady_forces, STEADY_STATES};
        let reads = rigid_readings(p, &law.inputs)?;
        if reads.is_empty() {
            return Ok(Grade {
                steady_force_zero: true,
                reads_rigid_motion: reads,
                steady_force_n: Vec::new(),
            });
        }
        // Zero to round-off: against the force the feedthrough alone would hold.
        let feedthrough: f64 = reads.iter().map(|(_, r)| r).sum::<f64>() * law.lti.d.amax();
        let forces = steady_forces(p, &law.inputs, &law.lti, speed)?;
        let steady_force_zero =
            forces.is_some_and(|f| f.iter().all(|v| *v <= 1e-9 * feedthrough.max(1.0)));
        Ok(Grade {
            steady_force_zero,
            reads_rigid_motion: reads,
            steady_force_n: forces
                .map(|f| STEADY_STATES.iter().map(|m| m.to_string()).zip(f).collect())
                .unwrap_or_default(),
        })
    }
}

/// A loop off the design model checked on the design road: by the rational loop's eigenvalues
/// ([`Loop::new`]) with its continuous-time prediction, or, for a predictor's loop (not
/// rational), at the sampling instants as a master runs it at the design's communication step
/// ([`crate::predict::sampled::SampledLoop`]) with the `W_k` seat a master measures there.
#[derive(Debug, Clone, Serialize)]
pub struct Checked {
    /// `"stable"`, `"unstable"` or `"not checked"`.
    pub verdict: &'static str,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub predicted_wk_rms_seat_m_s2: Option<f64>,
    /// The communication step of a check at the sampling instants \[s\] (`None`: the
    /// continuous loop).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub step_s: Option<f64>,
    #[serde(skip_serializing_if = "String::is_empty")]
    pub why: String,
    /// A stable continuous loop's limits on the design road ([`Limits`]; above 1 its strokes
    /// reach a stop, or its forces a limit, more often than at the design's `limit_sigmas`, and
    /// the linear prediction holds only off them).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub limits: Option<Limits>,
}

impl Checked {
    fn of(law: &ControlLaw, conditions: Conditions, d: &ComfortDesign) -> Self {
        use crate::predict::continuous::PredictionError;
        let checked = |verdict, predicted, why: String| Checked {
            verdict,
            predicted_wk_rms_seat_m_s2: predicted,
            step_s: law.predictor.is_some().then_some(d.communication_step),
            why,
            limits: None,
        };
        if law.predictor.is_none() {
            return match Loop::new(Some(law), conditions) {
                Ok(lp) => {
                    let figures = lp.figures(&d.road);
                    Checked {
                        limits: Some(Limits::of(&figures, d)),
                        ..checked("stable", Some(figures.wk_rms_seat_m_s2), String::new())
                    }
                }
                Err(e) => checked("unstable", None, e.to_string()),
            };
        }
        let held = "a predictor's loop is not rational: checked at the sampling instants";
        match crate::predict::sampled::SampledLoop::new(Some(law), conditions, d.communication_step)
        {
            Ok(lp) => checked(
                "stable",
                Some(lp.figures(&d.road).recorded_weighted[0]),
                held.into(),
            ),
            Err(PredictionError::Unstable(e)) => checked("unstable", None, format!("{held}: {e}")),
            Err(e) => checked("not checked", None, e.to_string()),
        }
    }

    fn stable(&self) -> bool {
        self.verdict == "stable"
    }
}

/// The loop with one actuator giving no force (its controller not told), on the design road at
/// the nominal car ([`Checked`]).
#[derive(Debug, Clone, Serialize)]
pub struct LostActuator {
    pub actuator: String,
    #[serde(flatten)]
    pub check: Checked,
}

/// [`LostActuator`] for each actuator in turn.
fn lost_actuators(
    law: &ControlLaw,
    params: &VehicleParams,
    d: &ComfortDesign,
) -> Vec<LostActuator> {
    vehicle::model::ACTUATORS
        .iter()
        .enumerate()
        .map(|(i, a)| {
            let mut conditions = Conditions::nominal(*params);
            conditions.effectiveness[i] = 0.0;
            LostActuator {
                actuator: a.to_string(),
                check: Checked::of(law, conditions, d),
            }
        })
        .collect()
}

/// The loop with end stops engaged for good, on the design road at the nominal car: the stops'
/// stiffness and damping ([`vehicle::contact::ContactParams`]'s defaults, the plant FMU's) added
/// to the seat's spring and damper (`seat`) or to both corners' of an axle (`front`, `rear`;
/// the car's parameters are per axle). On the physical car a stop engages only beyond its free
/// travel, so a loop unstable with it engaged can still be stable on the car, but not where the
/// stop stays engaged long enough for the unstable mode to grow (a rough road: it then bangs
/// between the stops). [`Checked`], and where unstable the stiffest spring at which it still is
/// (a bisection to 1 % of the stop).
#[derive(Debug, Clone, Serialize)]
pub struct EngagedStop {
    pub stop: &'static str,
    /// The element's spring \[N/m\]: nominal, and with the stop engaged.
    pub stiffness_n_m: [f64; 2],
    #[serde(flatten)]
    pub check: Checked,
    /// Where unstable with the stop: the stiffest spring of a stable loop (to 1 % of the
    /// stop's), stiffness and damping added in proportion.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stable_up_to_n_m: Option<f64>,
}

/// [`EngagedStop`] for the seat's stops and each axle's bump stops.
fn engaged_stops(law: &ControlLaw, params: &VehicleParams, d: &ComfortDesign) -> Vec<EngagedStop> {
    let stops = vehicle::contact::ContactParams::default();
    /// A stop: its places among `vehicle::model::ACTUATORS`, the element's spring, the stop's
    /// stiffness and damping, and the car with a stiffness and a damping added to the element.
    struct Element {
        stop: &'static str,
        places: &'static [usize],
        spring: f64,
        stop_kc: [f64; 2],
        stiffen: fn(&VehicleParams, f64, f64) -> VehicleParams,
    }
    let elements = [
        Element {
            stop: "seat",
            places: &[4],
            spring: params.k_seat,
            stop_kc: [stops.seat_stop_stiffness, stops.seat_stop_damping],
            stiffen: |p, k, c| VehicleParams {
                k_seat: p.k_seat + k,
                c_seat: p.c_seat + c,
                ..*p
            },
        },
        Element {
            stop: "front",
            places: &[0, 1],
            spring: params.k_s_f,
            stop_kc: [stops.stop_stiffness, stops.stop_damping],
            stiffen: |p, k, c| VehicleParams {
                k_s_f: p.k_s_f + k,
                c_s_f: p.c_s_f + c,
                ..*p
            },
        },
        Element {
            stop: "rear",
            places: &[2, 3],
            spring: params.k_s_r,
            stop_kc: [stops.stop_stiffness, stops.stop_damping],
            stiffen: |p, k, c| VehicleParams {
                k_s_r: p.k_s_r + k,
                c_s_r: p.c_s_r + c,
                ..*p
            },
        },
    ];
    elements
        .iter()
        .map(|e| {
            let ([k_stop, c_stop], spring) = (e.stop_kc, e.spring);
            // A share of the stop engaged: the car stiffened, its `stop_force_*` reading it.
            let at = |share: f64| {
                let (k, c) = (share * k_stop, share * c_stop);
                let mut conditions = Conditions::nominal((e.stiffen)(params, k, c));
                for &place in e.places {
                    conditions.engaged_stops[place] = (k, c);
                }
                Checked::of(law, conditions, d)
            };
            let check = at(1.0);
            let stable_up_to_n_m = (check.verdict == "unstable")
                .then(|| stable_up_to(|s| at(s).stable()).map(|s| spring + s * k_stop))
                .flatten();
            EngagedStop {
                stop: e.stop,
                stiffness_n_m: [spring, spring + k_stop],
                check,
                stable_up_to_n_m,
            }
        })
        .collect()
}

/// The largest share `s ∈ [0, 1]` with `stable(s)`, by bisection to 1 % (`None` if even the
/// nominal loop, `s = 0`, is not). Assumes one boundary: stable below it, not above.
fn stable_up_to(stable: impl Fn(f64) -> bool) -> Option<f64> {
    if !stable(0.0) {
        return None;
    }
    let (mut lo, mut hi) = (0.0, 1.0);
    while hi - lo > 0.01 {
        let mid = 0.5 * (lo + hi);
        if stable(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some(lo)
}

/// The actuator bandwidths every loop is checked at: a hydraulic unit's 10 Hz, and 5 Hz, the
/// slowest the controllers issue asks a design to tolerate.
pub const CHECKED_ACTUATOR_BANDWIDTHS_HZ: [f64; 2] = [10.0, 5.0];

/// The nominal loop with first-order actuators of `bandwidth_hz` (the plant FMU's
/// `actuator_bandwidth`) instead of ideal ones: `"stable"` or `"unstable"` by its spectral
/// abscissa ([`crate::predict::continuous::abscissa_with_actuator_lag`]), a predictor's loop
/// (not rational) by its spectral radius at the sampling instants of the design's step;
/// where stable, its predicted figures (continuous, and `held` as a master runs it, which
/// `master/tests/comfort_prediction.rs` co-simulates). An accommodating controller is
/// checked as its unaccommodated loop: with its `actuator_bandwidth` set as the plant's, its
/// effectiveness estimate models the lag and stays at 1.
#[derive(Debug, Clone, Serialize)]
pub struct ActuatorLag {
    pub bandwidth_hz: f64,
    pub verdict: &'static str,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub spectral_abscissa: Option<f64>,
    /// Where stable, the figures of that loop on the design road in continuous time (the
    /// actuators' lag exact in the frequency domain); none for a predictor's loop.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub predicted: Option<Figures>,
    /// Where stable there, the loop as a master runs it at the design's communication step
    /// (`synth::predict::sampled`, the lag's forces states of the sampled car): what
    /// `master/tests/comfort_prediction.rs` co-simulates, and a predictor's verdict.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub held: Option<HeldLag>,
    #[serde(skip_serializing_if = "String::is_empty")]
    pub why: String,
}

/// [`ActuatorLag::held`].
#[derive(Debug, Clone, Serialize)]
pub struct HeldLag {
    pub step_s: f64,
    /// Time-averaged over the steps ([`crate::predict::sampled::HeldFigures`]).
    pub predicted: Figures,
}

fn actuator_lags(
    law: &ControlLaw,
    params: &VehicleParams,
    d: &ComfortDesign,
) -> Result<Vec<ActuatorLag>, String> {
    use crate::predict::continuous::PredictionError;
    CHECKED_ACTUATOR_BANDWIDTHS_HZ
        .iter()
        .map(|&bandwidth_hz| {
            let mut lagging = Conditions::nominal(*params);
            lagging.actuator_bandwidth_hz = Some(bandwidth_hz);
            // As a master runs it: stable at the sampling instants, or why not.
            let step = d.communication_step;
            let held = match crate::predict::sampled::SampledLoop::new(Some(law), lagging, step) {
                Ok(lp) => Ok(HeldLag {
                    step_s: step,
                    predicted: lp.figures(&d.road).time_averaged,
                }),
                Err(PredictionError::Unstable(e)) => Err(("unstable", format!(": {e}"))),
                Err(e) => Err(("not checked", format!(": {e}"))),
            };
            if law.predictor.is_some() {
                // Not rational: its verdict is the sampled loop's.
                let (verdict, why) = match &held {
                    Ok(_) => ("stable", String::new()),
                    Err((verdict, why)) => (*verdict, why.clone()),
                };
                return Ok(ActuatorLag {
                    bandwidth_hz,
                    verdict,
                    spectral_abscissa: None,
                    predicted: None,
                    held: held.ok(),
                    why: format!(
                        "a predictor's loop is not rational: checked at the sampling instants \
                         of its {step} s step{why}"
                    ),
                });
            }
            let abscissa = crate::predict::continuous::abscissa_with_actuator_lag(
                law,
                Conditions::nominal(*params),
                bandwidth_hz,
            )
            .map_err(|e| e.to_string())?
            .ok_or("a rational loop has a spectral abscissa")?;
            let predicted = if abscissa < 0.0 {
                Some(
                    Loop::new(Some(law), lagging)
                        .map_err(|e| e.to_string())?
                        .figures(&d.road),
                )
            } else {
                None
            };
            Ok(ActuatorLag {
                bandwidth_hz,
                verdict: if abscissa < 0.0 { "stable" } else { "unstable" },
                spectral_abscissa: Some(abscissa),
                predicted,
                held: held.ok(),
                // The runtime's actuator model (`actuator_bandwidth`) is what the estimate
                // compares the load cells with.
                why: if law.accommodation.is_some() {
                    "with the FMU's actuator_bandwidth set as the plant's, the effectiveness \
                     estimate models the lag and stays at 1: the loop is the unaccommodated one \
                     with it"
                        .into()
                } else {
                    String::new()
                },
            })
        })
        .collect()
}

/// A comfort design's certificate (`dist/<variant>.certificate.json`).
#[derive(Debug, Clone, Serialize)]
pub struct ComfortCertificate {
    pub variant: String,
    /// A design of ours or a baseline it is measured against: what it had to meet
    /// ([`Role::comfort_bound`]).
    pub role: Role,
    pub objective: &'static str,
    pub robust_to: Uncertainty,
    pub comfort: Comfort,
    pub unmodelled_delay: UnmodelledDelay,
    pub limits: Limits,
    pub grade: Grade,
    /// Each actuator lost in turn ([`LostActuator`]).
    pub lost_actuators: Vec<LostActuator>,
    /// The seat's and each axle's end stops engaged ([`EngagedStop`]).
    pub engaged_stops: Vec<EngagedStop>,
    /// The loop at its force limits: the circle criterion of its dead zones
    /// ([`crate::predict::saturation`]; an anti-windup design's own check is in its notes).
    pub saturation: crate::predict::saturation::SaturationCheck,
    /// First-order actuators instead of ideal ones ([`ActuatorLag`]).
    pub actuator_lag: Vec<ActuatorLag>,
    /// The slowest first-order actuators the loop tolerates, a common bandwidth scanned down
    /// from 1 kHz ([`crate::predict::lag`]).
    pub actuator_lag_bound: crate::predict::lag::ActuatorLagBound,
    pub hinf_comfort: HinfComfort,
    pub spectral_abscissa: f64,
    /// The controller on its own (its `A`), open loop: the largest real part of its poles
    /// (negative: stable, so a master that runs it without the car, or a car that stops
    /// answering it, does not see it diverge).
    pub controller_spectral_abscissa: f64,
    pub closed_loop_poles: Vec<[f64; 2]>,
    pub measurements: Vec<String>,
    pub controller: serde_json::Value,
    pub notes: Vec<String>,
}

/// What a controller is to the project, and so what it must at least do on its design road.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Role {
    /// A design of ours: refused unless it halves the passive car's W_k seat (one that does
    /// not is a failed synthesis).
    Design,
    /// A classical baseline the designs are measured against: accepted with whatever comfort
    /// its certificate predicts below the passive car's.
    Baseline,
}

impl Role {
    /// The most predicted W_k seat accepted, as a fraction of the passive car's.
    pub fn comfort_bound(self) -> f64 {
        match self {
            Role::Design => 0.5,
            Role::Baseline => 1.0,
        }
    }
}

/// A synthesised, certified comfort design.
#[derive(Debug, Clone)]
pub struct ComfortDesignResult {
    pub law: ControlLaw,
    /// Extra blocks of `controller.json` (anti-windup, fault detection, predictor).
    pub extensions: Extensions,
    pub certificate: ComfortCertificate,
}

/// Everything a design needs: the car, the design file, the nominal plant.
pub struct Context<'a> {
    pub params: &'a VehicleParams,
    pub design: &'a ComfortDesign,
}

impl Context<'_> {
    pub fn plant(&self) -> ComfortPlant {
        ComfortPlant::new(self.params, self.design)
    }

    pub fn fail(&self, variant: &str, reason: impl std::fmt::Display) -> ComfortError {
        ComfortError::Synthesis {
            variant: variant.into(),
            reason: reason.to_string(),
        }
    }
}

/// The nominal guaranteed-cost state feedback (the unmodelled delay only): `(plant with the
/// delay weight, gain)`: `hinf_sf`'s and `delay_sf`'s on the ideal road, `hinf_of`'s on the car's
/// design model ([`crate::comfort::car::car_design`]).
pub fn nominal_gain(ctx: &Context) -> Result<(ComfortPlant, StateFeedback), ComfortError> {
    let d = ctx.design;
    let (g, delay) = ctx
        .plant()
        .with_delay_weight(d.unmodelled_delay, &force_limits(d));
    let sf = guaranteed::state_feedback(&g, &[delay], d.limit_sigmas)
        .map_err(|e| ctx.fail("hinf_sf", e))?;
    Ok((g, sf))
}

/// The guaranteed-cost gain over the mass range (and the unmodelled delay), at the range's
/// centre: `robust_sf` and `robust_of`.
pub fn robust_gain(ctx: &Context) -> Result<(ComfortPlant, StateFeedback), ComfortError> {
    let (g, delay, mass) = mass_channel(ctx.params, ctx.design);
    let sf = guaranteed::state_feedback(&g, &[delay, mass], ctx.design.limit_sigmas)
        .map_err(|e| ctx.fail("robust_sf", e))?;
    Ok((g, sf))
}

/// A state-feedback gain as the controller that realises it, reading the car's states, tyre
/// deflections and accelerations ([`realise_state_feedback`]).
fn state_feedback_law((g, sf): &(ComfortPlant, StateFeedback)) -> ControlLaw {
    let (framed, t) = g.with_frame();
    ControlLaw {
        inputs: state_feedback_sensors(g).names,
        lti: realise_state_feedback(&framed, &(&sf.k * t)),
        accommodation: None,
        predictor: None,
    }
}

/// `hinf_sf`, `robust_sf`: the gain as a controller reading the car's states, tyre deflections
/// and accelerations ([`realise_state_feedback`]) and the seat's stop force, from which it
/// recovers ([`crate::comfort::stop_recovery`]), certified.
pub fn state_feedback_design(
    ctx: &Context,
    variant: &str,
    robust_to: Uncertainty,
    gain: &(ComfortPlant, StateFeedback),
    mut notes: Vec<String>,
) -> Result<ComfortDesignResult, ComfortError> {
    let law = crate::comfort::stop_recovery::stop_recovery(ctx.params, &state_feedback_law(gain))
        .map_err(|e| ctx.fail(variant, e))?;
    notes.push(crate::comfort::stop_recovery::note());
    let wiring = recovering_state_feedback_wiring;
    Ok(ComfortDesignResult {
        certificate: certify(ctx, variant, robust_to, &law, &wiring, notes)?,
        law,
        extensions: Extensions::default(),
    })
}

/// The masses a robust design is chosen at: both ends of the range and the nominal car.
fn selection_masses(ctx: &Context) -> [f64; 3] {
    [ctx.design.mass_min, ctx.params.m_s, ctx.design.mass_max]
}

/// The worst predicted W_k seat RMS of `law` at [`selection_masses`] (infinite where unstable).
fn worst_over_masses(ctx: &Context, law: &ControlLaw) -> f64 {
    selection_masses(ctx)
        .iter()
        .map(|m| {
            predict(
                Some(law),
                Conditions::nominal(VehicleParams {
                    m_s: *m,
                    ..*ctx.params
                }),
                &ctx.design.road,
            )
            .map_or(f64::INFINITY, |f| f.wk_rms_seat_m_s2)
        })
        .fold(0.0, f64::max)
}

/// `robust_sf`: of two certified candidates, the guaranteed-cost gain over the mass range
/// (`robust`) and the nominal gain (`nominal`), the one with the least worst predicted seat
/// comfort at both ends of the range and the nominal mass — the criterion `robust_of` picks its
/// filter by. Either is certified over the whole range by the same multiplier bound
/// ([`certify`]). The game Riccati equation fixes its multipliers, so its gain is not the best
/// one over the range: with full state measured, comfort barely depends on the sprung mass, and
/// the nominal gain is measured to win (0.00897 against 0.00925 m/s² worst); the certificate
/// notes both figures. The chosen gain recovers from the seat's end stops
/// ([`crate::comfort::stop_recovery`]) and carries `hinf_of_aw`'s anti-windup compensator
/// ([`anti_windup_design`]), so its loop is certified stable with a seat stop engaged and in
/// saturation; below both it is the gain's loop, whose certificate this is.
pub fn robust_state_feedback_design(
    ctx: &Context,
    (robust, robust_note): (&(ComfortPlant, StateFeedback), String),
    (nominal, nominal_note): (&(ComfortPlant, StateFeedback), String),
) -> Result<ComfortDesignResult, ComfortError> {
    let (w_robust, w_nominal) = (
        worst_over_masses(ctx, &state_feedback_law(robust)),
        worst_over_masses(ctx, &state_feedback_law(nominal)),
    );
    let (chosen, which, note) = if w_nominal < w_robust {
        (nominal, "the nominal (hinf_sf) gain", nominal_note)
    } else {
        (
            robust,
            "the guaranteed-cost gain over the mass range",
            robust_note,
        )
    };
    let notes = vec![
        note,
        format!(
            "Chosen: {which}. Worst predicted W_k seat RMS at m_s = {:?} kg: the guaranteed-cost \
             gain over the range {w_robust:.6}, the nominal gain {w_nominal:.6} m/s2; the \
             certificate's bound and predictions are the chosen gain's.",
            selection_masses(ctx)
        ),
    ];
    let (variant, robust_to) = ("robust_sf", Uncertainty::SprungMass);
    let recovered = state_feedback_design(ctx, variant, robust_to, chosen, notes)?;
    anti_windup_design(ctx, &recovered, variant, robust_to)
}

/// The sprung masses a mass-robust certificate predicts at: five, evenly over the range.
pub fn check_masses(d: &ComfortDesign) -> Vec<f64> {
    (0..5)
        .map(|i| d.mass_min + (d.mass_max - d.mass_min) * i as f64 / 4.0)
        .collect()
}

/// The rows `(C, D)` over the car's 16 states and its five forces (per N) of the plant outputs
/// `inputs` names on the linear car (its road feed-through left out): a state `x[k]` as itself,
/// a sensor as its physical output ([`vehicle::sensors::physical_name`]), a load cell as the
/// force it measures, a stop's force as zero.
pub(crate) fn input_rows(
    p: &VehicleParams,
    inputs: &[String],
) -> Result<(DMatrix<f64>, DMatrix<f64>), String> {
    let names: Vec<&str> = inputs.iter().map(String::as_str).collect();
    let rows = crate::predict::continuous::sensor_rows(
        &crate::predict::continuous::plant_outputs(p),
        &names,
    )
    .map_err(|e| e.to_string())?;
    Ok((rows.c, rows.d_u))
}

/// `variant`: the output feedback `of` (`hinf_of` for `hinf_of_aw`, `robust_of` for itself)
/// plus the decoupled model-recovery anti-windup compensator of thesis Th. 5.3
/// ([`crate::thesis::anti_windup`]): `F` from the sector LMI on the car (performance: the
/// comfort accelerations with their ISO factors), re-checked by the circle criterion. The
/// compensator's model `η̇ = A η + B (u − y_c)` is the nominal car's; the controller reads its
/// inputs less what that model says the saturation did to them, `C η + D (u − y_c)` — `D` the
/// accelerometers' and the load cells' direct feed-through of the forces — so that below and
/// above saturation it sees the loop it was designed in. Its linear behaviour, and so every
/// prediction, is `of`'s; its certificate is `of`'s with `robust_to` and the saturation check
/// (the anti-windup loop's) replaced.
pub fn anti_windup_design(
    ctx: &Context,
    of: &ComfortDesignResult,
    variant: &str,
    robust_to: Uncertainty,
) -> Result<ComfortDesignResult, ComfortError> {
    let ss = vehicle::StateSpace::new(ctx.params);
    let rows = vehicle::model::physical_outputs(ctx.params);
    let perf: Vec<(&str, f64)> = crate::comfort::plant::COMFORT_OUTPUTS.to_vec();
    let row = |name: &str| {
        rows.iter()
            .find(|r| r.name == name)
            .expect("a plant output")
    };
    let c_z = DMatrix::from_fn(perf.len(), vehicle::model::N_STATES, |i, j| {
        row(perf[i].0).c[j] * perf[i].1
    });
    // Forces in kN inside the LMI (its conditioning), as elsewhere in the synthesis.
    let ku = crate::thesis::generalized::FORCE_UNIT;
    let d_zu = DMatrix::from_fn(perf.len(), N_ACTUATORS, |i, j| {
        row(perf[i].0).d_u[j] * perf[i].1 * ku
    });
    let b_u = &ss.b_u * ku;
    let aw = crate::thesis::anti_windup::mraw_for(&ss.a, &b_u, &c_z, &d_zu, 1e-6)
        .map_err(|e| ctx.fail(variant, e))?;
    let check = crate::thesis::anti_windup::circle_check(&ss.a, &b_u, &aw.f, &aw.w);
    if !check.holds() {
        return Err(ComfortError::Certificate {
            variant: variant.into(),
            reason: format!(
                "the anti-windup loop fails its check: A + B_u F spectral abscissa {:e}, circle \
                 margin {:e}",
                check.spectral_abscissa, check.min_margin
            ),
        });
    }
    let compensator = Compensator {
        model: None,
        f: &aw.f * ku,
        saturation: crate::predict::saturation::SaturationCheck::anti_windup(
            aw.w.as_slice(),
            &check,
        ),
        what: format!(
            "the decoupled model-recovery anti-windup of thesis Th. 5.3 (corrected): eta' = (A + \
             B_u F) eta - B_u dz(u_lin), u = sat(u_lin), the controller reads y - C_y eta - D_y \
             (u - u_lin) (D_y: its inputs' feed-through of the forces, the accelerometers' and the \
             load cells'); F from the generalised-sector LMI on the car with the comfort \
             accelerations as performance (L2 gain {:.4}); re-checked: A + B_u F spectral \
             abscissa {:.3}, circle criterion with the LMI's multiplier on {} frequencies (min \
             margin {:.3e})",
            aw.gamma, check.spectral_abscissa, check.frequencies, check.min_margin
        ),
    };
    with_compensator(ctx, of, variant, robust_to, compensator)
}

/// The output feedback `of` with the plain model-recovery anti-windup: [`anti_windup_design`]'s
/// compensator with no gain, `F = 0` (the internal-model anti-windup; Zaccarian & Teel,
/// *Modern Anti-windup Synthesis*, 2011, §3.3). The compensator is then the nominal car itself,
/// driven by what the clamp takes from the commands; the controller sees the unconstrained car,
/// so the saturated loop is the linear loop plus `η̇ = A η − B dz(u)`, bounded at any force
/// limits because the passive car is stable, and back to the linear loop at the car's own rate
/// once the commands are within them ([`SaturationCheck::model_recovery`]). No LMI: what
/// Th. 5.3's gain adds (`hinf_of_aw`) is a faster way back, not stability.
///
/// [`SaturationCheck::model_recovery`]: crate::predict::saturation::SaturationCheck::model_recovery
pub fn model_recovery_design(
    ctx: &Context,
    of: &ComfortDesignResult,
    variant: &str,
) -> Result<ComfortDesignResult, ComfortError> {
    let ss = vehicle::StateSpace::new(ctx.params);
    // Behind lagging actuators (`car.actuator_bandwidth_hz`) the unconstrained model is the car
    // behind them: the compensator's forces are states, `ḟ_η = ω_a (dz − f_η)`, and the
    // controller's inputs read them where they read the forces.
    let lag_hz = ctx
        .design
        .car
        .as_ref()
        .and_then(|c| c.actuator_bandwidth_hz);
    let model = lag_hz
        .map(|hz| {
            let (c_y, d_y) =
                input_rows(ctx.params, &of.law.inputs).map_err(|e| ctx.fail(variant, e))?;
            Ok::<_, ComfortError>(behind_lagging_actuators(&ss.a, &ss.b_u, &c_y, &d_y, hz))
        })
        .transpose()?;
    let (eta_a, eta_b) = match &model {
        Some(m) => (&m.a, &m.b),
        None => (&ss.a, &ss.b_u),
    };
    let saturation =
        crate::predict::saturation::SaturationCheck::model_recovery(eta_a, eta_b, "its");
    let states = eta_a.nrows();
    if !saturation.holds() {
        return Err(ctx.fail(variant, saturation.why));
    }
    let behind = match lag_hz {
        Some(hz) => format!(
            " behind the design's first-order actuators of {hz} Hz (their forces states of eta, \
             read where the inputs read the forces)"
        ),
        None => String::new(),
    };
    let compensator = Compensator {
        model,
        f: DMatrix::zeros(N_ACTUATORS, states),
        what: format!(
            "the plain model-recovery anti-windup (thesis Th. 5.3's compensator with F = 0, the \
             internal-model anti-windup): eta' = A eta - B_u dz(u_lin), u = sat(u_lin), the \
             controller reads y - C_y eta - D_y (u - u_lin), so it sees the unconstrained car; \
             eta is the passive car{behind} driven by the dead zones, whose spectral abscissa is \
             {:.3} rad/s",
            saturation.recovery_abscissa.unwrap_or(f64::NAN)
        ),
        saturation,
    };
    with_compensator(ctx, of, variant, of.certificate.robust_to, compensator)
}

/// The car `(A, B_u)` whose inputs read `C_y x + D_y f` behind first-order actuators of
/// `bandwidth_hz`: state `[x; f]`, `ḟ = ω_a (v − f)`, the inputs `[C_y D_y] [x; f]` (no
/// feed-through left: the forces are states). A compensator's unconstrained model:
/// `η̇ = A η + B v`, the controller's inputs `C η + D v`.
pub(crate) fn behind_lagging_actuators(
    a: &DMatrix<f64>,
    b_u: &DMatrix<f64>,
    c_y: &DMatrix<f64>,
    d_y: &DMatrix<f64>,
    bandwidth_hz: f64,
) -> Lti {
    let (n, m, p) = (a.nrows(), b_u.ncols(), c_y.nrows());
    let w = 2.0 * std::f64::consts::PI * bandwidth_hz;
    let mut big_a = DMatrix::zeros(n + m, n + m);
    big_a.view_mut((0, 0), (n, n)).copy_from(a);
    big_a.view_mut((0, n), (n, m)).copy_from(b_u);
    let mut big_b = DMatrix::zeros(n + m, m);
    for k in 0..m {
        big_a[(n + k, n + k)] = -w;
        big_b[(n + k, k)] = w;
    }
    let mut c = DMatrix::zeros(p, n + m);
    c.view_mut((0, 0), (p, n)).copy_from(c_y);
    c.view_mut((0, n), (p, m)).copy_from(d_y);
    Lti::new(big_a, big_b, c, DMatrix::zeros(p, m))
}

/// An anti-windup compensator on the nominal car: its gain `F` (N per state), its saturation
/// check, and what it is, for the certificate's notes.
struct Compensator {
    /// The unconstrained model it runs when not the nominal car's ([`behind_lagging_actuators`]).
    model: Option<Lti>,
    f: DMatrix<f64>,
    saturation: crate::predict::saturation::SaturationCheck,
    what: String,
}

/// `of` with the anti-windup `compensator` as `variant` robust to `robust_to`.
fn with_compensator(
    ctx: &Context,
    of: &ComfortDesignResult,
    variant: &str,
    robust_to: Uncertainty,
    compensator: Compensator,
) -> Result<ComfortDesignResult, ComfortError> {
    let nominal = of.certificate.variant.clone();
    let d = ctx.design;
    // The compensator's unconstrained model: its own, or the nominal car read by the inputs.
    let (eta_a, eta_b, c_y, d_y) = match compensator.model {
        Some(m) => (m.a, m.b, m.c, m.d),
        None => {
            let ss = vehicle::StateSpace::new(ctx.params);
            let (c_y, d_y) =
                input_rows(ctx.params, &of.law.inputs).map_err(|e| ctx.fail(variant, e))?;
            (ss.a, ss.b_u, c_y, d_y)
        }
    };
    let feeds_through = d_y.iter().any(|v| *v != 0.0);
    // The runtime forms the command from `y − C η` and only the state sees `D (u − y_c)`: exact
    // where the law's feed-through reads no input the forces feed through to (a state
    // feedback's `D` on its states beside the accelerations only its filters read).
    if (&of.law.lti.d * &d_y).iter().any(|v| *v != 0.0) {
        return Err(ctx.fail(
            variant,
            format!(
                "{nominal}'s direct feed-through reads an input that one of the forces feeds \
                 through to"
            ),
        ));
    }
    let mut certificate = of.certificate.clone();
    certificate.variant = variant.into();
    certificate.robust_to = robust_to;
    certificate.saturation = compensator.saturation;
    let (with, below) = if nominal == variant {
        (
            "With".to_string(),
            "Below saturation it is the loop without it, whose predictions these are; its model \
             and check are the nominal car's"
                .to_string(),
        )
    } else {
        (
            format!("{nominal} plus"),
            format!("Below saturation it is {nominal}: the predictions are {nominal}'s"),
        )
    };
    certificate
        .notes
        .insert(0, format!("{with} {}. {below}.", compensator.what));
    if of.extensions.accommodation.is_some() {
        certificate.notes.insert(
            1,
            "With fault accommodation the compensator takes the design's force the accommodated \
             command makes, u_a = rho_hat sat(u_lin / rho_hat) (an actuator of effectiveness \
             rho_hat saturates at rho_hat times its limit in the design's units): once the \
             estimate has settled the loop is the nominal one plus the same compensator loop, \
             driven by the dead zones at the reduced limits, which the circle criterion covers."
                .into(),
        );
    }
    let extensions = Extensions {
        anti_windup: Some(AntiWindup {
            a: matrix_rows(&eta_a),
            b: matrix_rows(&eta_b),
            c: matrix_rows(&c_y),
            d: if feeds_through {
                matrix_rows(&d_y)
            } else {
                Vec::new()
            },
            f: matrix_rows(&compensator.f),
            u_max: force_limits(d).to_vec(),
        }),
        ..of.extensions.clone()
    };
    Ok(ComfortDesignResult {
        law: of.law.clone(),
        extensions,
        certificate,
    })
}

/// The closed loop of `law` on the design plant at `g0`'s conditions.
fn design_loop(plant: &Plant, sensors: &Sensors, law: &ControlLaw) -> Result<ClosedLoop, String> {
    close(plant, sensors, &law.lti).map_err(|e| e.to_string())
}

fn spectral_abscissa(a: &DMatrix<f64>) -> f64 {
    crate::numerics::eig::spectral_abscissa(a)
}

/// `‖q ← p‖∞` of the unmodelled-delay channel of `law` on the design model wired by `wiring`:
/// what [`certify`] requires below 1.
pub fn delay_channel_norm(ctx: &Context, law: &ControlLaw, wiring: Wiring) -> Result<f64, String> {
    let (plant, sensors) = wiring(&ctx.plant());
    let cl = design_loop(&plant, &sensors, law)?;
    unmodelled_delay_norm(&cl, ctx.design.unmodelled_delay, &force_limits(ctx.design))
}

/// `‖q ← p‖∞` of the unmodelled-delay channel of a closed loop: `W` of
/// [`crate::comfort::plant::delay_cover`] on the command, `p` added to the applied forces, both in
/// units of the force limits.
fn unmodelled_delay_norm(
    cl: &ClosedLoop,
    tau: f64,
    limits: &[f64; N_ACTUATORS],
) -> Result<f64, String> {
    let (c, d) = crate::comfort::plant::delay_cover();
    let (n, m) = (cl.a.nrows(), N_ACTUATORS);
    let lim = DMatrix::from_fn(m, m, |i, j| if i == j { limits[i] } else { 0.0 });
    let inv = DMatrix::from_fn(m, m, |i, j| if i == j { 1.0 / limits[i] } else { 0.0 });
    // States [x_cl; x_w], x_w' = −(d/τ) x_w + (d/τ) u, q = c d (u − x_w)/limit, f = limit p.
    let mut a = DMatrix::zeros(n + m, n + m);
    a.view_mut((0, 0), (n, n)).copy_from(&cl.a);
    a.view_mut((n, 0), (m, n)).copy_from(&(&cl.c_u * (d / tau)));
    for k in 0..m {
        a[(n + k, n + k)] = -d / tau;
    }
    let mut b = DMatrix::zeros(n + m, m);
    b.view_mut((0, 0), (n, m)).copy_from(&(&cl.b_f * &lim));
    b.view_mut((n, 0), (m, m))
        .copy_from(&(&cl.d_uf * &lim * (d / tau)));
    let mut cq = DMatrix::zeros(m, n + m);
    cq.view_mut((0, 0), (m, n))
        .copy_from(&(&inv * &cl.c_u * (c * d)));
    cq.view_mut((0, n), (m, m)).copy_from(&(&inv * (-c * d)));
    let dq = &inv * &cl.d_uf * &lim * (c * d);
    Lti::new(a, b, cq, dq)
        .hinf_norm(1e-6)
        .map(|n| n.upper)
        .map_err(|e| e.to_string())
}

/// How a design's controller is wired to a design plant: `(plant, sensors)` (the output-feedback
/// designs' sensors add their noise to `w`).
pub type Wiring<'a> = &'a dyn Fn(&ComfortPlant) -> (Plant, Sensors);

/// The state-feedback designs' wiring.
pub fn state_feedback_wiring(g: &ComfortPlant) -> (Plant, Sensors) {
    (plant_of(g), state_feedback_sensors(g))
}

/// [`state_feedback_wiring`] with the seat's stop force read too
/// ([`crate::comfort::stop_recovery`]; zero on the design model, which has no stops).
pub(crate) fn recovering_state_feedback_wiring(g: &ComfortPlant) -> (Plant, Sensors) {
    let mut names = state_feedback_sensors(g).names;
    names.push(crate::comfort::stop_recovery::STOP_FORCE.into());
    crate::comfort::controllers::named_sensors(g, names)
}

/// The loop at `conditions` as a master runs it at the design file's communication step;
/// `None` where it is unstable there (a design's uncertainty reports it; see
/// [`OverUncertainty::held`]).
pub fn held_at(law: &ControlLaw, conditions: Conditions, d: &ComfortDesign) -> Option<Held> {
    held_prediction(law, conditions, d).ok()
}

/// The nominal loop as a master runs it at the design file's communication step; unstable
/// there is a refusal.
fn held_prediction(
    law: &ControlLaw,
    nominal: Conditions,
    d: &ComfortDesign,
) -> Result<Held, String> {
    let lp = crate::predict::sampled::SampledLoop::new(Some(law), nominal, d.communication_step)
        .map_err(|e| {
            format!(
                "run by a master at a step of {} s: {e}",
                d.communication_step
            )
        })?;
    let held = lp.figures(&d.road);
    let (predicted, [seat, roll, pitch]) = (held.time_averaged, held.recorded_weighted);
    Ok(Held {
        step_s: d.communication_step,
        predicted_wk_rms_seat_m_s2: predicted.wk_rms_seat_m_s2,
        recorded_wk_rms_seat_m_s2: seat,
        recorded_we_rms_roll_rad_s2: roll,
        recorded_we_rms_pitch_rad_s2: pitch,
        predicted,
    })
}

/// Certify a comfort design; an error is never an FMU.
pub fn certify(
    ctx: &Context,
    variant: &str,
    robust_to: Uncertainty,
    law: &ControlLaw,
    wiring: Wiring,
    notes: Vec<String>,
) -> Result<ComfortCertificate, ComfortError> {
    let fail = |reason: String| ComfortError::Certificate {
        variant: variant.into(),
        reason,
    };
    let d = ctx.design;
    let model = design_model_facts(ctx, law, wiring).map_err(&fail)?;
    let nominal = Conditions::nominal(*ctx.params);
    let lp = Loop::new(Some(law), nominal).map_err(|e| fail(e.to_string()))?;
    let delay_margin = lp.delay_margin();
    if delay_margin.is_nan() || delay_margin <= d.unmodelled_delay {
        return Err(fail(format!(
            "delay margin {delay_margin} s is not above the unmodelled delay {} s",
            d.unmodelled_delay
        )));
    }
    let saturation = crate::predict::saturation::saturation_check(&lp);
    let actuator_lag_bound = crate::predict::lag::lag_bound(law, ctx.params);
    // Predictions, design and passive.
    let predicted = lp.figures(&d.road);
    let held = held_prediction(law, nominal, d).map_err(&fail)?;
    let passive = predict(None, nominal, &d.road).map_err(|e| fail(e.to_string()))?;
    let seat = predicted.wk_rms_seat_m_s2;
    // A design must do better (`Role::comfort_bound`, applied by the registry, which knows
    // the role); no controller, not even a baseline, may do worse.
    if seat.is_nan() || seat >= passive.wk_rms_seat_m_s2 {
        return Err(fail(format!(
            "predicted W_k seat {:.4} m/s² is not below the passive car's {:.4}",
            predicted.wk_rms_seat_m_s2, passive.wk_rms_seat_m_s2
        )));
    }
    let lim = limits_at(&predicted, d, law.accommodation).map_err(&fail)?;
    let mut uncertainty = over_uncertainty(ctx, robust_to, law, wiring).map_err(&fail)?;
    if let Some(u) = uncertainty.as_mut() {
        u.predict_held(law, d);
    }
    let communication_steps = communication_steps(law, nominal, uncertainty.as_ref(), d);
    let guaranteed = guarantee(uncertainty.as_mut(), &predicted).map_err(&fail)?;
    Ok(ComfortCertificate {
        variant: variant.into(),
        role: Role::Design,
        objective: "comfort",
        robust_to,
        comfort: Comfort {
            road: road_description(ctx),
            predicted_wk_rms_seat_m_s2: predicted.wk_rms_seat_m_s2,
            passive_wk_rms_seat_m_s2: passive.wk_rms_seat_m_s2,
            guaranteed_wk_rms_seat_m_s2: guaranteed,
            predicted,
            passive,
            design_model_wk_rms_seat_m_s2: model.seat,
            design_model_vibration_total_m_s2: model.total,
            uncertainty,
            master_orders: master_orders(law, nominal, d),
            held,
            communication_steps,
        },
        unmodelled_delay: UnmodelledDelay {
            tolerated_delay_s: d.unmodelled_delay,
            small_gain_norm: model.small_gain,
            delay_margin_s: delay_margin,
        },
        limits: lim,
        grade: Grade::of(ctx.params, law, d.road.speed).map_err(|e| fail(e.to_string()))?,
        lost_actuators: lost_actuators(law, ctx.params, d),
        engaged_stops: engaged_stops(law, ctx.params, d),
        saturation,
        actuator_lag: actuator_lags(law, ctx.params, d).map_err(&fail)?,
        actuator_lag_bound,
        hinf_comfort: model.hinf,
        spectral_abscissa: model.abscissa,
        controller_spectral_abscissa: crate::numerics::eig::spectral_abscissa(&law.lti.a),
        closed_loop_poles: model.poles,
        measurements: law.inputs.clone(),
        controller: serde_json::json!({
            "A": crate::thesis::certificate::matrix_json(&law.lti.a),
            "B": crate::thesis::certificate::matrix_json(&law.lti.b),
            "C": crate::thesis::certificate::matrix_json(&law.lti.c),
            "D": crate::thesis::certificate::matrix_json(&law.lti.d),
        }),
        notes,
    })
}

/// What the design model says of a law's closed loop ([`design_model_facts`]).
struct DesignModelFacts {
    /// Its spectral abscissa (< 0, checked) and poles, sorted.
    abscissa: f64,
    poles: Vec<[f64; 2]>,
    /// Its exact comfort H2 norms: W_k seat, and the vibration total.
    seat: f64,
    total: f64,
    /// The comfort channel's worst-case gain, the design's and the passive car's.
    hinf: HinfComfort,
    /// The unmodelled-delay channel's norm (< 1, checked).
    small_gain: f64,
}

/// The design model's closed loop of `law` wired by `wiring`: stable, its exact comfort norms,
/// its worst-case gain beside the passive car's, and robust stability to the unmodelled delay.
fn design_model_facts(
    ctx: &Context,
    law: &ControlLaw,
    wiring: Wiring,
) -> Result<DesignModelFacts, String> {
    let d = ctx.design;
    let g0 = ctx.plant();
    let (plant, sensors) = wiring(&g0);
    let cl = design_loop(&plant, &sensors, law)?;
    let abscissa = spectral_abscissa(&cl.a);
    if abscissa.is_nan() || abscissa >= 0.0 {
        return Err(format!(
            "closed loop unstable (spectral abscissa {abscissa:e})"
        ));
    }
    let nw = plant.b_w.ncols();
    let cz = DMatrix::from_fn(g0.c_z.nrows(), plant.a.nrows(), |i, j| g0.c_z[(i, j)]);
    let comfort_sys = cl.from_w(
        &cz,
        &DMatrix::zeros(cz.nrows(), nw),
        &DMatrix::zeros(cz.nrows(), N_ACTUATORS),
    );
    let h2 = |rows: &[usize]| {
        comfort_sys
            .select_outputs(rows)
            .h2_norm()
            .map_err(|e| e.to_string())
    };
    let (seat, total) = (h2(&[0])?, h2(&[0, 1, 2])?);
    let small_gain = unmodelled_delay_norm(&cl, d.unmodelled_delay, &force_limits(d))?;
    if small_gain.is_nan() || small_gain >= 1.0 {
        return Err(format!(
            "the unmodelled-delay channel's norm {small_gain:.4} is not below 1"
        ));
    }
    let passive_sys = Lti::new(
        plant.a.clone(),
        plant.b_w.clone(),
        cz.clone(),
        DMatrix::zeros(cz.nrows(), nw),
    );
    let hd = comfort_sys.hinf_norm(1e-6).map_err(|e| e.to_string())?;
    let hp = passive_sys.hinf_norm(1e-6).map_err(|e| e.to_string())?;
    let hz = |w: f64| w / (2.0 * std::f64::consts::PI);
    let mut poles: Vec<[f64; 2]> = crate::numerics::eig::eigenvalues(&cl.a)
        .iter()
        .map(|l| [l.re, l.im])
        .collect();
    poles.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    Ok(DesignModelFacts {
        abscissa,
        poles,
        seat,
        total,
        hinf: HinfComfort {
            design: hd.upper,
            passive: hp.upper,
            design_peak_hz: hz(hd.peak_frequency),
            passive_peak_hz: hz(hp.peak_frequency),
        },
        small_gain,
    })
}

/// The figure a certificate guarantees: the prediction for a nominal design; for a robust one
/// the car model's bound, claimed only where it covers every prediction on the exact car (the
/// car model's Padé rear track and band-unlimited weightings differ from the car; a bound that
/// does not cover is no guarantee of the car, and is reported as such).
fn guarantee(
    uncertainty: Option<&mut OverUncertainty>,
    predicted: &Figures,
) -> Result<Option<f64>, String> {
    Ok(match uncertainty {
        // Accommodated: every stationary loop of the box is the nominal one, checked here on
        // the predictions (computed with the estimate settled, not assumed equal).
        Some(u) if u.accommodated_down_to.is_some() => {
            let seat = predicted.wk_rms_seat_m_s2;
            if let Some((label, f)) = u
                .predictions
                .iter()
                .find(|(_, f)| (f.wk_rms_seat_m_s2 - seat).abs() > 1e-12 * seat)
            {
                return Err(format!(
                    "accommodated, yet the prediction at {label} ({:.6}) differs from the \
                     nominal one ({seat:.6})",
                    f.wk_rms_seat_m_s2
                ));
            }
            Some(u.worst_predicted_wk_rms_seat_m_s2.max(seat))
        }
        Some(u) => u
            .bound_wk_rms_seat
            .as_ref()
            .map(|b| b.value)
            .and_then(|b| u.claim(b, "")),
        None => Some(predicted.wk_rms_seat_m_s2),
    })
}

/// The design road as a certificate describes it.
fn road_description(ctx: &Context) -> RoadDescription {
    let road = &ctx.design.road;
    let band = road.band_hz();
    RoadDescription {
        iso_class: String::from(road.iso_class),
        speed_m_s: road.speed,
        tracks: "independent",
        rear_wheels: format!(
            "the front track {:.4} s later (exact; the design model: {})",
            (ctx.params.l1 + ctx.params.l2) / road.speed,
            road.rear_wheels
        ),
        band_hz: [band.0, band.1],
    }
}

/// The limits at `limit_sigmas` standard deviations of `predicted` over their bounds, each
/// at most 1 (accommodated down to `ρ_min`, the forces over `ρ_min` too), or which is not.
fn limits_at(
    predicted: &Figures,
    d: &ComfortDesign,
    accommodation: Option<f64>,
) -> Result<Limits, String> {
    let k = d.limit_sigmas;
    let lim = Limits::of(predicted, d);
    let names = CORNERS
        .iter()
        .map(|c| format!("stroke_{c}"))
        .chain(ACTUATORS.iter().map(|a| format!("force_{a}")))
        .chain(["stroke_seat".to_string()]);
    if let Some((name, bad)) = names
        .zip(lim.stroke.iter().chain(&lim.force).chain(&lim.seat_stroke))
        .find(|(_, v)| **v > 1.0)
    {
        return Err(format!(
            "{name} exceeds its limit at {k} standard deviations ({bad:.3} of it)"
        ));
    }
    // Accommodated, an actuator of effectiveness ρ_min is sent the asked force over ρ_min: it
    // must fit its limit too, or the stationary loop is not the nominal one.
    if let Some(rho_min) = accommodation {
        if let Some(bad) = lim.force.iter().map(|f| f / rho_min).find(|v| *v > 1.0) {
            return Err(format!(
                "accommodated down to ρ = {rho_min}, a command exceeds its limit at {k} \
                 standard deviations ({bad:.3} of it)"
            ));
        }
    }
    Ok(lim)
}

/// The communication steps at the nominal car and at every condition of the uncertainty: the
/// hold's effect on a loop moves with the car it closes.
fn communication_steps(
    law: &ControlLaw,
    nominal: Conditions,
    uncertainty: Option<&OverUncertainty>,
    d: &ComfortDesign,
) -> StepStability {
    match uncertainty {
        None => StepStability::check(
            &[(law.clone(), nominal)],
            "the nominal car",
            &d.road,
            d.communication_step,
        ),
        Some(u) => {
            let loops: Vec<(ControlLaw, Conditions)> = std::iter::once(nominal)
                .chain(u.conditions.iter().copied())
                .map(|c| (law.clone(), c))
                .collect();
            let labels: Vec<&str> = u.predictions.iter().map(|(l, _)| l.as_str()).collect();
            StepStability::check(
                &loops,
                &format!("the nominal car and {}", labels.join(", ")),
                &d.road,
                d.communication_step,
            )
        }
    }
}

/// The rear track of the model the mass and fault bounds are computed on: the front track
/// through a Padé approximant of the wheelbase delay of this order.
///
/// The design model's rear track (order 2 for the state feedbacks, independent for the output
/// feedbacks) is a synthesis choice, and a bound on it is no bound on the car: with order 2 the
/// state feedback's preview states *are* the rear road, a perfect preview the car does not
/// have. Here the car's rear track is its own, the controller's preview states still its
/// order-2 copy. Measured on `hinf_sf`'s loop (nominal H2 of the seat, m/s²): order 2 0.00813,
/// 4 0.00894, 6 0.00866, 7, 8 and 10 0.00867, the car's exact-delay prediction 0.00876 (which
/// also has the road FMU's band and the weightings' band limits); the order-8 approximant is
/// within 2e-4 of `e^{−jωT}` up to `ωT = 8` (10.6 Hz at 20 m/s).
pub const BOUND_MODEL_PADE_ORDER: usize = 8;

/// The design `d` as the model its mass and fault bounds are computed on: the same car, road
/// and weightings, the rear wheels on the front track through [`BOUND_MODEL_PADE_ORDER`], and a
/// description of it for the certificate.
pub fn bound_model(d: &ComfortDesign, p: &VehicleParams) -> (ComfortDesign, String) {
    let mut model = d.clone();
    model.road.rear_wheels = RearWheels::Pade {
        order: BOUND_MODEL_PADE_ORDER,
    };
    let description = format!(
        "the car model with its rear wheels on the front track through a Padé approximant of \
         order {BOUND_MODEL_PADE_ORDER} of the {:.4} s wheelbase delay (the design model's rear \
         wheels: {})",
        (p.l1 + p.l2) / d.road.speed,
        d.road.rear_wheels
    );
    (model, description)
}

/// Predictions and bounds over the design's uncertainty; the bounds and the check grid on the
/// car model of [`bound_model`].
fn over_uncertainty(
    ctx: &Context,
    kind: Uncertainty,
    law: &ControlLaw,
    wiring: Wiring,
) -> Result<Option<OverUncertainty>, String> {
    let (model, bound_model) = bound_model(ctx.design, ctx.params);
    let g0 = &ComfortPlant::new(ctx.params, &model);
    let d = &model;
    let Some(cases) = uncertainty_cases(ctx, kind, g0, d) else {
        return Ok(None);
    };
    let predictions = cases
        .labels
        .into_iter()
        .zip(cases.conditions.iter().copied())
        .map(|(label, c)| {
            predict(Some(law), c, &ctx.design.road)
                .map(|f| (label.clone(), f))
                .map_err(|e| format!("at {label}: {e}"))
        })
        .collect::<Result<Vec<_>, _>>()?;
    // Fault accommodation that covers the box makes every stationary loop the nominal one
    // (`certify` checks the predictions say so); the grid below is then the frozen loops of a
    // fault's transient, uncompensated.
    let accommodated = law
        .accommodation
        .filter(|r| kind == Uncertainty::ActuatorFaults && *r <= d.fault_rho_min);
    // Otherwise the guaranteed bound at the uncertainty's centre, and the car model's exact
    // H2 norm at every grid point, which the bound must cover.
    let (seat, bound_failure, total) = if accommodated.is_some() {
        (None, None, None)
    } else {
        let (centre, channel) = cases.channel;
        let (plant, sensors) = wiring(&centre);
        let cl = design_loop(&plant, &sensors, law)?;
        let uncertain = uncertain_loop(&cl, &channel, plant.a.nrows())?;
        let seat_rows = comfort_rows(g0, &cl, &[0]);
        let all_rows = comfort_rows(g0, &cl, &[0, 1, 2]);
        // A multiplier bound, or (only for the effectiveness box, whose five independent real
        // parameters the one-Lyapunov-matrix bound over-covers as complex blocks) none, said so.
        let seat = uncertain.bound(&seat_rows);
        let bound_failure = match (&seat, kind) {
            (Some(_), _) => None,
            (None, Uncertainty::ActuatorFaults) => Some(
                "no multipliers certify a bound over the whole box: the guarantee is the design \
                 model's worst case over the box's vertices and the predictions, not a certificate"
                    .to_string(),
            ),
            (None, _) => {
                return Err(
                    "no multiplier gives a guaranteed bound: the loop is not robustly stable \
                            on its channel"
                        .into(),
                )
            }
        };
        (seat, bound_failure, uncertain.bound(&all_rows))
    };
    let grid_worst = grid_worst(g0, &cases.grid, law, wiring)?;
    if let Some(seat) = &seat {
        if grid_worst > seat.value * (1.0 + 1e-6) {
            return Err(format!(
                "the car model's seat comfort {grid_worst} on the check grid exceeds the \
                 guaranteed bound {}",
                seat.value
            ));
        }
    }
    Ok(Some(OverUncertainty {
        bound_model,
        bound_wk_rms_seat: seat,
        bound_failure,
        bound_vibration_total: total,
        bound_model_grid_worst_wk_rms_seat: Some(grid_worst),
        accommodated_down_to: accommodated,
        bound_model_grid_points: cases.grid.len(),
        ..OverUncertainty::predicted(kind, predictions, cases.conditions, ctx.params)
    }))
}

/// What a design's uncertainty is checked on ([`uncertainty_cases`]).
struct UncertaintyCases {
    /// The conditions its predictions are made at, labelled.
    labels: Vec<String>,
    conditions: Vec<Conditions>,
    /// The car model at the uncertainty's centre, and its channel (the multiplier bound's).
    channel: (ComfortPlant, Vec<Channel>),
    /// The car model at every point of the dense check grid.
    grid: Vec<ComfortPlant>,
}

/// The cases of `kind` on the car model `g0` of the design `d`; none for a design robust to
/// nothing the car model carries (none, saturation, a known delay: their own checks).
fn uncertainty_cases(
    ctx: &Context,
    kind: Uncertainty,
    g0: &ComfortPlant,
    d: &ComfortDesign,
) -> Option<UncertaintyCases> {
    match kind {
        Uncertainty::None | Uncertainty::Saturation | Uncertainty::InputDelay => None,
        Uncertainty::SprungMass => {
            let masses = check_masses(d);
            let (centre, _, mass) = mass_channel(ctx.params, d);
            // The dense check grid: the car model at every mass of the file's grid.
            let grid = (0..d.mass_grid_points)
                .map(|i| {
                    let m = d.mass_min
                        + (d.mass_max - d.mass_min) * i as f64 / (d.mass_grid_points - 1) as f64;
                    ComfortPlant::at_mass(ctx.params, d, m)
                })
                .collect();
            Some(UncertaintyCases {
                labels: masses.iter().map(|m| format!("m_s = {m} kg")).collect(),
                conditions: masses
                    .iter()
                    .map(|m| {
                        Conditions::nominal(VehicleParams {
                            m_s: *m,
                            ..*ctx.params
                        })
                    })
                    .collect(),
                channel: (centre, vec![mass]),
                grid,
            })
        }
        Uncertainty::ActuatorFaults => {
            let (mut labels, mut conditions): (Vec<_>, Vec<_>) =
                single_faults(ctx).into_iter().unzip();
            labels.push(format!("all at {}", d.fault_rho_min));
            conditions.push(Conditions {
                effectiveness: [d.fault_rho_min; N_ACTUATORS],
                ..Conditions::nominal(*ctx.params)
            });
            let (centre, _, faults) = fault_channel(g0, d);
            // The dense check: every vertex of the effectiveness box.
            let grid = FaultBox {
                rho_min: d.fault_rho_min,
            }
            .vertices()
            .iter()
            .map(|rho| g0.with_effectiveness(rho))
            .collect();
            Some(UncertaintyCases {
                labels,
                conditions,
                channel: (centre, faults.split()),
                grid,
            })
        }
    }
}

/// The car model's exact W_k seat H2 norm, worst over `grid`, each loop checked stable.
fn grid_worst(
    g0: &ComfortPlant,
    grid: &[ComfortPlant],
    law: &ControlLaw,
    wiring: Wiring,
) -> Result<f64, String> {
    let mut worst: f64 = 0.0;
    for g in grid {
        let (plant, sensors) = wiring(g);
        let cl = design_loop(&plant, &sensors, law)?;
        if !crate::numerics::eig::is_hurwitz(&cl.a) {
            return Err("the car model is unstable at a point of the check grid".into());
        }
        let rows = comfort_rows(g0, &cl, &[0]);
        let h2 = Lti::new(
            cl.a.clone(),
            cl.b_w.clone(),
            rows,
            DMatrix::zeros(1, cl.b_w.ncols()),
        )
        .h2_norm()
        .map_err(|e| format!("car model on the check grid: {e}"))?;
        worst = worst.max(h2);
    }
    Ok(worst)
}

/// Each actuator alone at `fault_rho_min`, labelled by the actuator.
fn single_faults(ctx: &Context) -> Vec<(String, Conditions)> {
    let rho_min = ctx.design.fault_rho_min;
    vehicle::model::ACTUATORS
        .iter()
        .enumerate()
        .map(|(i, a)| {
            let mut rho = [1.0; N_ACTUATORS];
            rho[i] = rho_min;
            let c = Conditions {
                effectiveness: rho,
                ..Conditions::nominal(*ctx.params)
            };
            (format!("{a} at {rho_min}"), c)
        })
        .collect()
}

fn worst_seat(predictions: &[(String, Figures)]) -> f64 {
    predictions
        .iter()
        .map(|(_, f)| f.wk_rms_seat_m_s2)
        .fold(0.0, f64::max)
}

/// The uncertain closed loop of a channel for the bound: `p` entering as `ΔA x + ΔB_u u_a` (the
/// channel's `B_p` on the plant's rows, or through the loop's force input when `p` is an applied
/// force, which the accelerometers feel) and `q = C_q x + D_q u`. `q` must not feel `p` directly
/// (the bound has no `D_qp`): an error if the controller passes a force straight to its command.
pub fn uncertain_loop(
    cl: &ClosedLoop,
    channels: &[Channel],
    plant_rows: usize,
) -> Result<UncertainLoop, String> {
    let n = cl.a.nrows();
    let mut loop_channels = Vec::new();
    for channel in channels {
        let np = channel.b_p.ncols();
        let b_p = match &channel.applied_force {
            Some(f) => {
                let d_qp = &channel.d_q * &cl.d_uf * f;
                if d_qp.amax() > 0.0 {
                    return Err(format!(
                        "the {} channel's q feels p directly through the controller's feedthrough",
                        channel.name
                    ));
                }
                &cl.b_f * f
            }
            None => {
                let mut b_p = DMatrix::zeros(n, np);
                b_p.view_mut((0, 0), (plant_rows, np))
                    .copy_from(&channel.b_p.rows(0, plant_rows));
                b_p
            }
        };
        let mut c_q = DMatrix::zeros(channel.c_q.nrows(), n);
        c_q.view_mut((0, 0), (channel.c_q.nrows(), plant_rows))
            .copy_from(&channel.c_q.columns(0, plant_rows));
        c_q += &channel.d_q * &cl.c_u;
        loop_channels.push((b_p, c_q));
    }
    Ok(UncertainLoop {
        a: cl.a.clone(),
        b_w: cl.b_w.clone(),
        channels: loop_channels,
    })
}

/// The comfort output rows (`C_z` of the design plant) on a closed loop's state.
pub fn comfort_rows(g0: &ComfortPlant, cl: &ClosedLoop, rows: &[usize]) -> DMatrix<f64> {
    let n = cl.a.nrows();
    let mut c = DMatrix::zeros(rows.len(), n);
    for (i, r) in rows.iter().enumerate() {
        c.view_mut((i, 0), (1, cl.plant_order))
            .copy_from(&g0.c_z.view((*r, 0), (1, cl.plant_order)));
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The compensator's model behind lagging actuators answers each input with the car's
    /// response times the lag `ω_a / (s + ω_a)` (checked at `s = 0`, `s = j ω_a` and
    /// `s = 3 + 40 j` against the car's own transfer matrix), on the car and the inputs
    /// `hinf_of` reads.
    #[test]
    fn a_compensator_behind_lagging_actuators_is_the_car_times_the_lag() {
        use nalgebra::Complex;
        let p = VehicleParams::default();
        let ss = vehicle::StateSpace::new(&p);
        let inputs: Vec<String> = [
            "sensor_a_body_fl",
            "sensor_a_seat",
            "f_fl",
            "f_seat",
            "sensor_stroke_rr",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        let (c_y, d_y) = input_rows(&p, &inputs).unwrap();
        assert!(
            d_y.iter().any(|v| *v != 0.0),
            "the inputs feel the forces at once"
        );
        let hz = 10.0;
        let m = behind_lagging_actuators(&ss.a, &ss.b_u, &c_y, &d_y, hz);
        assert_eq!(m.d, DMatrix::zeros(inputs.len(), N_ACTUATORS));
        let w = 2.0 * std::f64::consts::PI * hz;
        let lagged_sys = [m.a.clone(), m.b.clone(), m.c.clone(), m.d.clone()];
        let car_sys = [ss.a.clone(), ss.b_u.clone(), c_y, d_y];
        for s in [
            Complex::new(0.0, 0.0),
            Complex::new(0.0, w),
            Complex::new(3.0, 40.0),
        ] {
            let lagged = crate::comfort::plant::transfer_at(&lagged_sys, s);
            let car =
                crate::comfort::plant::transfer_at(&car_sys, s) * (Complex::new(w, 0.0) / (s + w));
            let err = (&lagged - &car).map(|z| z.norm()).max();
            let scale = car.map(|z| z.norm()).max();
            assert!(err <= 1e-9 * scale, "at s = {s}: {err} against {scale}");
        }
    }

    /// The bisection of [`engaged_stops`] finds a stability boundary to 1 % of the stop and
    /// never reports a share at which the loop is unstable.
    #[test]
    fn the_stiffest_stable_spring_is_bisected_from_below() {
        for edge in [0.0, 0.004, 0.37, 0.999] {
            let s = stable_up_to(|x| x <= edge).unwrap();
            assert!(s <= edge && edge - s <= 0.01, "{edge}: {s}");
        }
        assert_eq!(stable_up_to(|_| false), None);
    }

    /// A limit broken at 3 σ is named in the refusal, so a designer knows which to relax.
    #[test]
    fn a_broken_limit_is_named() {
        let d = ComfortDesign::from_json(include_str!("../../designs/comfort.json")).unwrap();
        let mut f = Figures {
            wk_rms_seat_m_s2: 0.02,
            we_rms_roll_rad_s2: 0.0,
            we_rms_pitch_rad_s2: 0.0,
            vibration_total_m_s2: 0.02,
            rms_body_heave_m_s2: 0.0,
            rms_roll_rad_s2: 0.0,
            rms_pitch_rad_s2: 0.0,
            rms_stroke_m: [0.01; 4],
            rms_tire_load_ratio: [0.1; 4],
            rms_seat_stroke_m: 0.01,
            rms_force_n: [100.0; 5],
        };
        assert!(limits_at(&f, &d, None).is_ok());
        f.rms_stroke_m[2] = 0.03;
        let e = limits_at(&f, &d, None).unwrap_err();
        assert!(e.starts_with("stroke_rl exceeds its limit"), "{e}");
        f.rms_stroke_m[2] = 0.01;
        f.rms_force_n[4] = 400.0;
        let e = limits_at(&f, &d, None).unwrap_err();
        assert!(e.starts_with("force_seat exceeds its limit"), "{e}");
    }

    /// The state feedback in its frame ([`crate::comfort::plant::Frame`]) holds no force on a
    /// grade: its gain at `s = 0` on the raised, rolled and climbing car is zero to round-off,
    /// where without the frame it held kilonewtons. And the frame, a filter of the road alone,
    /// moves no pole of the loop: the loop's roots are the frameless loop's and the frame's own
    /// (three per axis).
    #[test]
    fn the_state_feedback_in_its_frame_holds_no_force_on_a_grade_and_keeps_its_poles() {
        let framed = ComfortDesign::from_json(include_str!("../../designs/comfort.json")).unwrap();
        let bare = ComfortDesign {
            state_feedback_frame_hz: None,
            ..framed.clone()
        };
        let p = VehicleParams::default();
        let law = |d: &ComfortDesign| {
            let gain = nominal_gain(&Context {
                params: &p,
                design: d,
            })
            .unwrap();
            (state_feedback_law(&gain), gain.0)
        };
        let ((with, g), (without, _)) = (law(&framed), law(&bare));
        let grade = |l: &ControlLaw| Grade::of(&p, l, framed.road.speed).unwrap();
        let (a, b) = (grade(&with), grade(&without));
        eprintln!(
            "in the frame {:?}; without {:?}",
            a.steady_force_n, b.steady_force_n
        );
        assert!(a.steady_force_zero && !b.steady_force_zero);
        assert!(a.steady_force_n.iter().all(|(_, f)| *f < 1e-6), "{a:?}");
        assert!(b.steady_force_n.iter().all(|(_, f)| *f > 100.0), "{b:?}");
        let (plant, sensors) = state_feedback_wiring(&g);
        let roots = |l: &ControlLaw| {
            crate::numerics::eig::eigenvalues(&design_loop(&plant, &sensors, l).unwrap().a)
        };
        let (mut left, bare_roots) = (roots(&with), roots(&without));
        let frame = g.frame.as_ref().unwrap();
        assert_eq!(
            left.len(),
            bare_roots.len() + 3 * crate::comfort::plant::FRAME_ORDER
        );
        let nearest = |left: &[nalgebra::Complex<f64>], r: nalgebra::Complex<f64>| {
            (0..left.len())
                .min_by(|i, j| (left[*i] - r).norm().total_cmp(&(left[*j] - r).norm()))
                .unwrap()
        };
        for r in bare_roots {
            let i = nearest(&left, r);
            assert!(
                (left[i] - r).norm() < 1e-6 * (1.0 + r.norm()),
                "{r} moved to {}",
                left[i]
            );
            left.swap_remove(i);
        }
        // (s² + 2ζω s + ω²)(s + ω).
        let (w, z) = (frame.omega, frame.zeta);
        let own = [
            nalgebra::Complex::new(-w, 0.0),
            nalgebra::Complex::new(-z * w, w * (1.0 - z * z).sqrt()),
            nalgebra::Complex::new(-z * w, -w * (1.0 - z * z).sqrt()),
        ];
        for r in left {
            let d = own
                .iter()
                .map(|o| (o - r).norm())
                .fold(f64::INFINITY, f64::min);
            assert!(d < 1e-6 * w, "{r} is no root of the frame");
        }
    }

    /// The bound model is the car up to its band limits: on `hinf_sf`'s loop its nominal seat
    /// H2 has converged in the Padé order (8 against 10) and is within 2 % of the certificate's
    /// exact-delay prediction (a frequency integral on the car, with the road FMU's band and the
    /// weightings' band limits), where the design model's perfect preview is 7 % optimistic.
    ///
    /// The state feedback without its frame ([`crate::comfort::plant::Frame`]): in it the loop
    /// follows the road's long waves, which the car's road has more of than the design model's
    /// first-order one, and the bound model is 5 % below the car there.
    #[test]
    fn the_bound_model_is_the_car_up_to_its_band_limits() {
        let design = ComfortDesign {
            state_feedback_frame_hz: None,
            ..ComfortDesign::from_json(include_str!("../../designs/comfort.json")).unwrap()
        };
        let p = VehicleParams::default();
        let ctx = Context {
            params: &p,
            design: &design,
        };
        let law = state_feedback_law(&nominal_gain(&ctx).unwrap());
        let car = predict(Some(&law), Conditions::nominal(p), &design.road)
            .unwrap()
            .wk_rms_seat_m_s2;
        let seat_h2 = |d: &ComfortDesign| {
            let g = ComfortPlant::new(&p, d);
            let (plant, sensors) = state_feedback_wiring(&g);
            let cl = design_loop(&plant, &sensors, &law).unwrap();
            let rows = comfort_rows(&g, &cl, &[0]);
            Lti::new(
                cl.a.clone(),
                cl.b_w.clone(),
                rows,
                DMatrix::zeros(1, cl.b_w.ncols()),
            )
            .h2_norm()
            .unwrap()
        };
        let (model, description) = bound_model(&design, &p);
        assert!(description.contains("order 8"), "{description}");
        let mut finer = model.clone();
        finer.road.rear_wheels = RearWheels::Pade { order: 10 };
        let (bound_model, finer, design_model) =
            (seat_h2(&model), seat_h2(&finer), seat_h2(&design));
        assert!(
            (bound_model / finer - 1.0).abs() < 1e-3,
            "{bound_model} vs {finer}"
        );
        assert!(
            (bound_model / car - 1.0).abs() < 0.02,
            "{bound_model} vs the car's {car}"
        );
        assert!(
            design_model < 0.95 * car,
            "{design_model} vs the car's {car}"
        );
    }
}
