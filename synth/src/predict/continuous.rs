//! What a controller will do on an ISO 8608 road, computed from the car and the controller as
//! the FMUs run them, independently of any design model: the certificates' predictions.
//!
//! The car is the `vehicle` crate's 16-state model at the conditions asked for (sprung mass,
//! actuator delay `θ`, actuator effectiveness `ρ`); the controller reads plant outputs by name,
//! exactly as its `controller.json` says; the road is ISO 8608's: white vertical velocity of
//! one-sided PSD `S` on each track ([`vehicle::road::iso_velocity_psd`]), heights its integral,
//! the rear wheels on the front track **exactly** `L/V` later (`e^{−jωT}`, no approximant), over
//! the spatial band of the road FMU ([`vehicle::road::ISO_BAND`]), left and right independent.
//! Every figure is a frequency integral
//! `E y² = ∫ S Σ_track |W(jω) H_y,track(jω)|² df` with the **full** ISO 2631-1 weighting `W`
//! (band limits included) where one applies, on a logarithmic grid of 1001 frequencies
//! (Simpson's rule in `ln f`; within 10⁻⁹ relative of the trapezoid on 16 000 intervals, tested).
//!
//! Per frequency the loop is solved exactly: `U = (I − K G_y E)⁻¹ K G_yr R` with `E = e^{−jωθ}
//! diag(ρ)` the actuators, `G_y`, `G_yr` the car's responses at the controller's inputs to the
//! applied forces and the road, `K` the controller's response (its `A` reduced to Hessenberg
//! form once, so a frequency costs `O(n²)`).

use crate::numerics::hinf_norm::Lti;
use crate::shipping::design::ComfortRoad;
use linsys::expm;
use nalgebra::{Complex, DMatrix, DVector, Hessenberg};
use serde::Serialize;
use std::collections::{BTreeMap, HashMap};
use std::f64::consts::PI;
use std::sync::{Arc, Mutex, OnceLock};
use vehicle::iso2631::{ComfortMeter, METER_OUTPUTS, PITCH_FACTOR, ROLL_FACTOR};
use vehicle::model::{
    OutputRow, StateSpace, CORNERS, N_ACTUATORS, N_DOF, N_ROAD, N_STATES, N_WHEELS,
};
use vehicle::VehicleParams;

type C64 = Complex<f64>;

/// Frequencies of a continuous loop's integration grid (odd: Simpson's rule on pairs of
/// intervals). Simpson's error falls as the fourth power of the spacing: on 1001 points the
/// passive car's figures are within 10⁻⁹ relative of a trapezoid on 16 000 intervals from a
/// quarter of the design speed to twice it (the wheelbase delay's oscillation in the integrand
/// is the hardest part, `the_frequency_grid_is_fine_enough`), where the trapezoid rule on 4000
/// points erred by up to 2·10⁻⁶ at a quarter of the speed. A loop with a delay has no poles to
/// grade the grid around: half as many points put `hinf_sf`'s figure behind 15 ms 2·10⁻⁴ off
/// the figure on 4001 (1001: 5·10⁻⁷). A held loop's grid is [`crate::predict::sampled`]'s.
pub const FREQUENCIES: usize = 1001;

/// A controller as its FMU runs it: `ξ̇ = A ξ + B y`, `u [N] = C ξ + D y`, `y` the plant
/// outputs named in `inputs` (`x[k]` for the states); with a predictor, `lti` is its law without
/// delay and the predictor's says what it does with one.
#[derive(Debug, Clone)]
pub struct ControlLaw {
    pub lti: Lti,
    pub inputs: Vec<String>,
    pub predictor: Option<PredictorLaw>,
    /// Fault accommodation (`controller.json`'s `accommodation`): the least effectiveness the
    /// controller estimates from its measured applied forces and divides its commands by. In
    /// stationary operation (the estimate settled, which is what a prediction describes) an
    /// actuator of effectiveness `ρ` then applies `ρ / max(ρ, rho_min)` of the asked force.
    pub accommodation: Option<f64>,
}

impl ControlLaw {
    /// The controller a `controller.json` describes, as its FMU runs it with the parameter
    /// `tau` (the delay a predictor compensates). The fault-detection and anti-windup blocks
    /// do not act on the commands of a loop in its linear range without a fault, and are left
    /// out. A matrix of the wrong shape is refused by name.
    pub fn from_file(
        file: &crate::shipping::controller_file::ControllerFile,
        tau: f64,
    ) -> Result<ControlLaw, String> {
        use crate::shipping::controller_file::matrix;
        let (n, ny, nu) = (file.a.len(), file.inputs.len(), file.outputs.len());
        let lti = Lti::new(
            matrix("A", &file.a, n, n)?,
            matrix("B", &file.b, n, ny)?,
            matrix("C", &file.c, nu, n)?,
            matrix("D", &file.d, nu, ny)?,
        );
        let predictor = match &file.predictor {
            None => None,
            Some(p) => {
                let (np, m) = (p.a.len(), p.a_xi.len());
                Some(PredictorLaw {
                    a: matrix("predictor.A", &p.a, np, np)?,
                    b: matrix("predictor.B", &p.b, np, nu)?,
                    k: matrix("predictor.K", &p.k, nu, np)?,
                    reconstruction: crate::comfort::controllers::Reconstruction {
                        s_y: matrix("predictor.S_y", &p.s_y, np, ny)?,
                        s_xi: matrix("predictor.S_xi", &p.s_xi, np, m)?,
                        a_xi: matrix("predictor.A_xi", &p.a_xi, m, m)?,
                        b_xi: matrix("predictor.B_xi", &p.b_xi, m, ny)?,
                        b_xiu: matrix("predictor.B_xiu", &p.b_xiu, m, nu)?,
                        d_yu: match &p.d_yu {
                            Some(rows) => matrix("predictor.D_yu", rows, ny, nu)?,
                            None => DMatrix::zeros(ny, nu),
                        },
                    },
                    delay: tau,
                })
            }
        };
        Ok(ControlLaw {
            lti,
            inputs: file.inputs.iter().map(|s| s.name.clone()).collect(),
            predictor,
            accommodation: file.accommodation.as_ref().map(|a| a.rho_min),
        })
    }
}

/// A state feedback `u = K x̂` on the design state predicted over the actuators' known delay `θ`
/// ([`crate::comfort::predictor`]): `x̂ = e^{Aθ} x + ∫_{t−θ}^{t} e^{A(t−s)} B u(s) ds`, `x = S_y y + S_ξ ξ`,
/// `ξ̇ = A_ξ ξ + B_ξ y + B_ξu u(t − θ)`. (Its runtime keeps the rows `B_ξu` drives in
/// controller time, the filter of `u` up to `t`, which is their part of `x̂`: the same law in
/// continuous time, [`crate::predict::sampled`] as stepped.)
#[derive(Debug, Clone)]
pub struct PredictorLaw {
    pub a: DMatrix<f64>,
    pub b: DMatrix<f64>,
    pub k: DMatrix<f64>,
    pub reconstruction: crate::comfort::controllers::Reconstruction,
    /// The delay the predictor compensates \[s\] (the FMU's `tau`).
    pub delay: f64,
}

/// Where the car is evaluated: its parameters (the sprung mass among them), the actuators'
/// delay and effectiveness.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Conditions {
    pub params: VehicleParams,
    /// Transport delay of every actuator \[s\].
    pub delay: f64,
    /// Applied force over commanded force, per actuator.
    pub effectiveness: [f64; N_ACTUATORS],
    /// First-order actuators of this bandwidth \[Hz\], each applied force `ω_a / (s + ω_a)` times
    /// its command (the plant FMU's `actuator_bandwidth`); `None`: ideal actuators.
    pub actuator_bandwidth_hz: Option<f64>,
    /// Stops engaged for good: at each place of [`vehicle::model::ACTUATORS`] (the corners, the
    /// seat) the stiffness and damping of its engaged stop, zero where free. `params` carries
    /// them too (the springs and dampers there stiffened); these make the plant's
    /// `stop_force_*` outputs read them ([`vehicle::model::engaged_stop_row`]).
    pub engaged_stops: [(f64, f64); N_ACTUATORS],
}

impl Conditions {
    pub fn nominal(params: VehicleParams) -> Self {
        Conditions {
            params,
            delay: 0.0,
            effectiveness: [1.0; N_ACTUATORS],
            actuator_bandwidth_hz: None,
            engaged_stops: [(0.0, 0.0); N_ACTUATORS],
        }
    }

    /// The actuators' lag at `ω`: `ω_a / (jω + ω_a)`, 1 for ideal actuators.
    fn lag(&self, omega: f64) -> C64 {
        match self.actuator_bandwidth_hz {
            None => C64::new(1.0, 0.0),
            Some(hz) => {
                let w = 2.0 * PI * hz;
                C64::new(w, 0.0) / C64::new(w, omega)
            }
        }
    }

    /// The plant FMU's parameters that realise these conditions on a car whose defaults are
    /// `nominal`: every car parameter that differs (by its FMU name), `tau` for the delay,
    /// `fault_loss_*` from `fault_time = 0` for the effectiveness. What a co-simulation sets to
    /// measure a prediction.
    pub fn plant_parameters(&self, nominal: &VehicleParams) -> BTreeMap<String, f64> {
        let mut out = BTreeMap::new();
        let (ours, theirs) = (
            serde_json::to_value(self.params).expect("serialisable"),
            serde_json::to_value(nominal).expect("serialisable"),
        );
        if let (Some(ours), Some(theirs)) = (ours.as_object(), theirs.as_object()) {
            for (name, value) in ours {
                if theirs.get(name) != Some(value) {
                    out.insert(name.clone(), value.as_f64().unwrap_or(f64::NAN));
                }
            }
        }
        if self.delay != 0.0 {
            out.insert("tau".into(), self.delay);
        }
        if let Some(hz) = self.actuator_bandwidth_hz {
            out.insert("actuator_bandwidth".into(), hz);
        }
        if self.effectiveness.iter().any(|r| *r != 1.0) {
            out.insert("fault_time".into(), 0.0);
            for (corner, rho) in ACTUATOR_NAMES.iter().zip(self.effectiveness) {
                if rho != 1.0 {
                    out.insert(format!("fault_loss_{corner}"), 1.0 - rho);
                }
            }
        }
        out
    }
}

/// The actuators' suffixes in the plant FMU's names, in the order of `effectiveness`.
const ACTUATOR_NAMES: [&str; N_ACTUATORS] = ["fl", "fr", "rl", "rr", "seat"];

/// The predicted figures (RMS values) on the road.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Figures {
    /// `W_k`-weighted seat heave acceleration [m/s²].
    pub wk_rms_seat_m_s2: f64,
    /// `W_e`-weighted roll and pitch acceleration [rad/s²].
    pub we_rms_roll_rad_s2: f64,
    pub we_rms_pitch_rad_s2: f64,
    /// ISO 2631-1 vibration total value `√(a_wz² + (0.63 a_wφ)² + (0.40 a_wθ)²)` [m/s²].
    pub vibration_total_m_s2: f64,
    /// Unweighted body heave, roll and pitch acceleration [m/s², rad/s²].
    pub rms_body_heave_m_s2: f64,
    pub rms_roll_rad_s2: f64,
    pub rms_pitch_rad_s2: f64,
    /// Suspension strokes FL, FR, RL, RR \[m\].
    pub rms_stroke_m: [f64; 4],
    /// Dynamic tyre loads over their static loads, FL … RR.
    pub rms_tire_load_ratio: [f64; 4],
    /// Seat stroke (seat minus the body under it) \[m\].
    pub rms_seat_stroke_m: f64,
    /// Applied forces, four corners and the seat \[N\].
    pub rms_force_n: [f64; 5],
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PredictionError {
    #[error("the controller reads '{0}', which the plant does not output")]
    UnknownInput(String),
    #[error("the closed loop is unstable at these conditions ({0})")]
    Unstable(String),
    #[error("not modelled: {0}")]
    NotModelled(String),
}

/// A plant output row (or a state) by name; a sensor (`sensor_x`) reads its physical output `x`.
fn output_row(rows: &[OutputRow], name: &str) -> Result<OutputRow, PredictionError> {
    if let Some(k) = name
        .strip_prefix("x[")
        .and_then(|s| s.strip_suffix(']'))
        .and_then(|s| s.parse::<usize>().ok())
        .filter(|k| (1..=N_STATES).contains(k))
    {
        let mut c = [0.0; N_STATES];
        c[k - 1] = 1.0;
        return Ok(OutputRow {
            name: name.into(),
            unit: "",
            description: String::new(),
            c,
            d_r: [0.0; N_ROAD],
            d_u: [0.0; N_ACTUATORS],
        });
    }
    let physical = vehicle::sensors::physical_name(name);
    rows.iter()
        .find(|r| r.name == physical)
        .cloned()
        .ok_or_else(|| PredictionError::UnknownInput(name.into()))
}

/// The spectral abscissa of the loop of `law` at `conditions` (no delay) with first-order
/// actuators of `bandwidth_hz` ([`Conditions::actuator_bandwidth_hz`]): negative where that
/// loop is stable. `None` for a predictor's law, whose loop is not rational.
pub fn abscissa_with_actuator_lag(
    law: &ControlLaw,
    conditions: Conditions,
    bandwidth_hz: f64,
) -> Result<Option<f64>, PredictionError> {
    if law.predictor.is_some() {
        return Ok(None);
    }
    let conditions = Conditions {
        actuator_bandwidth_hz: Some(bandwidth_hz),
        ..conditions
    };
    let names: Vec<&str> = law.inputs.iter().map(|s| s.as_str()).collect();
    let sensors = sensor_rows(&plant_outputs_at(&conditions), &names)?;
    let cl = rational_loop(
        law,
        &conditions,
        &StateSpace::new(&conditions.params),
        (&sensors.c, &sensors.d_u),
    )?;
    Ok(Some(crate::numerics::eig::spectral_abscissa(&cl.a)))
}

/// The closed loop of `law` (not a predictor's) on the car `ss` read through `(C_y, D_yu)` at
/// `conditions` without their delay: the car's states, the first-order actuators' applied
/// forces where they lag (`ḟ = ω_a (ρ u − f)`, the plant FMU's lag of the effective command),
/// and the controller's.
fn rational_loop(
    law: &ControlLaw,
    conditions: &Conditions,
    ss: &StateSpace,
    (c_y, d_yu): (&DMatrix<f64>, &DMatrix<f64>),
) -> Result<crate::numerics::interconnect::ClosedLoop, PredictionError> {
    let rho = DMatrix::from_diagonal(&DVector::from_column_slice(&conditions.effectiveness));
    let ny = c_y.nrows();
    let (plant, sensors) = match conditions.actuator_bandwidth_hz {
        None => (
            crate::numerics::interconnect::Plant {
                a: ss.a.clone(),
                b_w: DMatrix::zeros(N_STATES, 0),
                b_u: &ss.b_u * &rho,
            },
            crate::numerics::interconnect::Sensors {
                c: c_y.clone(),
                d_w: DMatrix::zeros(ny, 0),
                d_u: d_yu * &rho,
                names: law.inputs.clone(),
            },
        ),
        Some(hz) => {
            let omega = 2.0 * PI * hz;
            let n = N_STATES + N_ACTUATORS;
            // [x; f]: ẋ = A x + B_u f, ḟ = ω (ρ u − f); y = C x + D_u f.
            let mut a = DMatrix::zeros(n, n);
            a.view_mut((0, 0), (N_STATES, N_STATES)).copy_from(&ss.a);
            a.view_mut((0, N_STATES), (N_STATES, N_ACTUATORS))
                .copy_from(&ss.b_u);
            a.view_mut((N_STATES, N_STATES), (N_ACTUATORS, N_ACTUATORS))
                .copy_from(&(DMatrix::<f64>::identity(N_ACTUATORS, N_ACTUATORS) * -omega));
            let mut b_u = DMatrix::zeros(n, N_ACTUATORS);
            b_u.view_mut((N_STATES, 0), (N_ACTUATORS, N_ACTUATORS))
                .copy_from(&(&rho * omega));
            let mut c = DMatrix::zeros(ny, n);
            c.view_mut((0, 0), (ny, N_STATES)).copy_from(c_y);
            c.view_mut((0, N_STATES), (ny, N_ACTUATORS)).copy_from(d_yu);
            (
                crate::numerics::interconnect::Plant {
                    a,
                    b_w: DMatrix::zeros(n, 0),
                    b_u,
                },
                crate::numerics::interconnect::Sensors {
                    c,
                    d_w: DMatrix::zeros(ny, 0),
                    d_u: DMatrix::zeros(ny, N_ACTUATORS),
                    names: law.inputs.clone(),
                },
            )
        }
    };
    crate::numerics::interconnect::close(&plant, &sensors, &law.lti)
        .map_err(|e| PredictionError::Unstable(e.to_string()))
}

/// The car at rest on a planar road raised by 1 m, rolled by 1 rad and pitched by 1 rad, in
/// turn: `(q, z)`, its configuration (every spring at its static length) and the road heights
/// under its wheels.
pub fn planar_rests(p: &VehicleParams) -> [(DVector<f64>, DVector<f64>); 3] {
    let ss = StateSpace::new(p);
    let stiffness = ss.a.view((N_DOF, 0), (N_DOF, N_DOF)).into_owned();
    let road = ss.b_r.view((N_DOF, 0), (N_DOF, N_WHEELS)).into_owned();
    let lu = stiffness.lu();
    // The car's configuration on the constant road heights `z`: M⁻¹(−K q + K_r z) = 0.
    let on = |z: DVector<f64>| (-lu.solve(&(&road * &z)).expect("K is nonsingular"), z);
    let corners = vehicle::model::corner_positions(p);
    let planar = |h: f64, roll: f64, pitch: f64| {
        DVector::from_iterator(
            N_WHEELS,
            corners.iter().map(|(x, y)| h + y * roll + x * pitch),
        )
    };
    [
        on(planar(1.0, 0.0, 0.0)),
        on(planar(0.0, 1.0, 0.0)),
        on(planar(0.0, 0.0, 1.0)),
    ]
}

/// The states `ẋ = A x + B u` lets `u` reach (through `B`, then `A`'s nonzero entries), in
/// order. `A` is block-triangular on them and the rest: its roots are theirs and the rest's.
fn reached_states(a: &DMatrix<f64>, b: &DMatrix<f64>) -> Vec<usize> {
    let n = a.nrows();
    let mut reached: Vec<bool> = (0..n).map(|i| b.row(i).iter().any(|v| *v != 0.0)).collect();
    let mut frontier: Vec<usize> = (0..n).filter(|i| reached[*i]).collect();
    while let Some(j) = frontier.pop() {
        for i in 0..n {
            if !reached[i] && a[(i, j)] != 0.0 {
                reached[i] = true;
                frontier.push(i);
            }
        }
    }
    (0..n).filter(|i| reached[*i]).collect()
}

/// The states that shape `C (sI − A)⁻¹ B`, in order: those the inputs reach ([`reached_states`])
/// and, of them, those the outputs see (the same closure on the dual). Exact, not a tolerance:
/// a state outside them is decoupled by `A`'s zero entries, so the response of the system kept
/// on them is the same. The predictor's model `A` carries the road it guesses, which its
/// commands never reach: its half of the delay-margin scans of `delay_sf` solves 35 states
/// instead of 70.
fn structural_core(sys: &Lti) -> Vec<usize> {
    let reached = reached_states(&sys.a, &sys.b);
    let a = sys.a.select_rows(&reached).select_columns(&reached);
    let c = sys.c.select_columns(&reached);
    reached_states(&a.transpose(), &c.transpose())
        .into_iter()
        .map(|i| reached[i])
        .collect()
}

/// The rigid motions of a car with a planar road under it, at rest or climbing: the whole car
/// and its road raised by 1 m, rolled or pitched by 1 rad (the static equilibrium on that road,
/// with no force: every spring at its static length), and climbing at 1 m/s.
pub const RIGID_MOTIONS: [&str; 4] = [
    "raised 1 m",
    "rolled 1 rad",
    "pitched 1 rad",
    "climbing 1 m/s",
];

/// What each of `names` (plant outputs a controller reads) reads of each of [`RIGID_MOTIONS`]
/// (`ny × 4`), and the sum of each row's coefficients' magnitudes.
fn rigid_motion_readings(
    p: &VehicleParams,
    names: &[String],
) -> Result<(DMatrix<f64>, Vec<f64>), PredictionError> {
    let rests = planar_rests(p);
    let mut motions: Vec<(DVector<f64>, DVector<f64>)> = Vec::new();
    for (q, z) in &rests {
        let (mut x, mut r) = (DVector::zeros(N_STATES), DVector::zeros(N_ROAD));
        x.rows_mut(0, N_DOF).copy_from(q);
        r.rows_mut(0, N_WHEELS).copy_from(z);
        motions.push((x, r));
    }
    let (up_q, up) = &rests[0];
    let (mut x, mut r) = (DVector::zeros(N_STATES), DVector::zeros(N_ROAD));
    x.rows_mut(N_DOF, N_DOF).copy_from(up_q);
    r.rows_mut(N_WHEELS, N_WHEELS).copy_from(up);
    motions.push((x, r));
    let outputs = plant_outputs(p);
    let mut readings = DMatrix::zeros(names.len(), motions.len());
    let mut scales = Vec::with_capacity(names.len());
    for (i, name) in names.iter().enumerate() {
        let row = output_row(&outputs, name)?;
        scales.push(row.c.iter().chain(&row.d_r).map(|v| v.abs()).sum());
        for (j, (x, r)) in motions.iter().enumerate() {
            let c: f64 = row.c.iter().zip(x.iter()).map(|(a, b)| a * b).sum();
            let d: f64 = row.d_r.iter().zip(r.iter()).map(|(a, b)| a * b).sum();
            readings[(i, j)] = c + d;
        }
    }
    Ok((readings, scales))
}

/// What each of `names` (plant outputs a controller reads) reads of a rigid motion of the car
/// ([`RIGID_MOTIONS`]). Those reading any of them (beyond `1e-9` of the sum of their row's
/// coefficients) are returned with their largest reading. A controller that reads none of
/// them has no steady force on a constant grade or crossfall once its loop is stable: the car
/// moving rigidly along the grade, its controller's state at zero and no force is then a
/// steady state of the loop (every input reads zero), and a stable loop has one.
pub fn rigid_readings(
    p: &VehicleParams,
    names: &[String],
) -> Result<Vec<(String, f64)>, PredictionError> {
    let (readings, scales) = rigid_motion_readings(p, names)?;
    Ok(names
        .iter()
        .enumerate()
        .filter_map(|(i, name)| {
            let reading = readings.row(i).amax();
            (reading > 1e-9 * scales[i]).then(|| (name.clone(), reading))
        })
        .collect())
}

/// What a controller holds in the steady states a road can put the car in: raised by 1 m,
/// rolled by 1 rad (a crossfall), and on a 1 % grade at the design speed.
pub const STEADY_STATES: [&str; 3] = ["raised 1 m", "rolled 1 rad", "on a 1 % grade"];

/// The steady force \[N\] (largest over the actuators) of the controller `k` reading `names`
/// in each of [`STEADY_STATES`], from its gain at `s = 0`: `K(s) = K₀ + K₁ s + …` with
/// `K₀ = D − C A⁻¹ B`, `K₁ = −C A⁻² B`. In a pose `y₀` the force settles at `K₀ y₀`. On a
/// grade `g` at `speed` the car is pitched by `g` and climbs at `g V`: its inputs read
/// `y(t) = g (y_θ + V y_v) + g V y_h t` (`y_θ` the pitched car's reading, `y_v` the climbing
/// one's, `y_h` the raised one's) and the force settles at `g K₀ (y_θ + V y_v) + g V K₁ y_h`
/// (plus `g V K₀ y_h t`, the raised car's force growing). The pitch and the climb go together:
/// a controller that previews the rear road from the front one (the state feedbacks) is right
/// only about a road both axles drive over. A controller that reads rigid motion holds no
/// steady force on a grade or crossfall exactly when these vanish: its loop, stable, then
/// settles with the car in the road's pose and every force zero. `None` where `A` is singular
/// (an integrator: no steady force to speak of).
pub fn steady_forces(
    p: &VehicleParams,
    names: &[String],
    k: &Lti,
    speed: f64,
) -> Result<Option<[f64; 3]>, PredictionError> {
    let (readings, _) = rigid_motion_readings(p, names)?;
    let n = k.a.nrows();
    let (k0, k1) = if n == 0 {
        (k.d.clone(), DMatrix::zeros(k.d.nrows(), k.d.ncols()))
    } else {
        let lu = k.a.clone().lu();
        let Some(ainv_b) = lu.solve(&k.b) else {
            return Ok(None);
        };
        let Some(ainv2_b) = lu.solve(&ainv_b) else {
            return Ok(None);
        };
        (&k.d - &k.c * &ainv_b, -&k.c * ainv2_b)
    };
    let forces = &k0 * &readings;
    let g = 0.01;
    let grade =
        (forces.column(2) + forces.column(3) * speed + &k1 * readings.column(0) * speed) * g;
    Ok(Some([
        forces.column(0).amax(),
        forces.column(1).amax(),
        grade.amax(),
    ]))
}

/// The rows `y = C x + D_r r + D_u f` of the plant outputs a controller reads (`f` the applied
/// forces).
pub(crate) struct SensorRows {
    pub c: DMatrix<f64>,
    pub d_r: DMatrix<f64>,
    pub d_u: DMatrix<f64>,
}

/// The plant's outputs a controller may read on the car `p` ([`vehicle::model::readable_outputs`]).
pub(crate) fn plant_outputs(p: &VehicleParams) -> Vec<OutputRow> {
    vehicle::model::readable_outputs(p)
}

/// [`plant_outputs`] at `conditions`: the `stop_force_*` of each engaged stop reads it
/// ([`vehicle::model::engaged_stop_row`]).
pub(crate) fn plant_outputs_at(conditions: &Conditions) -> Vec<OutputRow> {
    let mut outputs = plant_outputs(&conditions.params);
    for (place, &(k, c)) in conditions.engaged_stops.iter().enumerate() {
        if (k, c) == (0.0, 0.0) {
            continue;
        }
        let row = vehicle::model::engaged_stop_row(&conditions.params, place, k, c);
        let at = outputs
            .iter()
            .position(|r| r.name == row.name)
            .expect("every stop has its force among the outputs");
        outputs[at] = row;
    }
    outputs
}

/// [`SensorRows`] of the named `outputs` (`x[k]` for the states).
pub(crate) fn sensor_rows(
    outputs: &[OutputRow],
    names: &[&str],
) -> Result<SensorRows, PredictionError> {
    let rows = names
        .iter()
        .map(|n| output_row(outputs, n))
        .collect::<Result<Vec<_>, _>>()?;
    let mat = |f: &dyn Fn(&OutputRow) -> Vec<f64>, cols: usize| {
        DMatrix::from_fn(rows.len(), cols, |i, j| f(&rows[i])[j])
    };
    Ok(SensorRows {
        c: mat(&|r| r.c.to_vec(), N_STATES),
        d_r: mat(&|r| r.d_r.to_vec(), N_ROAD),
        d_u: mat(&|r| r.d_u.to_vec(), N_ACTUATORS),
    })
}

/// The plant outputs the figures weight by ISO 2631-1, as the plant's vibration meter does:
/// `W_k` on the seat, `W_e` on roll and pitch ([`Figures`]' first three).
pub(crate) const WEIGHTED_SIGNALS: [&str; 3] =
    [METER_OUTPUTS[0].1, METER_OUTPUTS[1].1, METER_OUTPUTS[2].1];

/// The plant outputs of the unweighted figures, in [`Figures`]' order after the weighted ones
/// and before the forces, each with what it is divided by (a tyre's static load for its load
/// ratio).
pub(crate) fn plain_signals(static_load: &[f64; 4]) -> Vec<(String, f64)> {
    let mut out: Vec<(String, f64)> = ["a_body", "alpha_roll", "alpha_pitch"]
        .iter()
        .map(|s| (s.to_string(), 1.0))
        .collect();
    out.extend(CORNERS.iter().map(|c| (format!("stroke_{c}"), 1.0)));
    out.extend(
        CORNERS
            .iter()
            .zip(static_load)
            .map(|(c, load)| (format!("tire_load_{c}"), *load)),
    );
    out.push(("stroke_seat".into(), 1.0));
    out
}

/// The eigenvalues of a complex matrix: the diagonal of its complex Schur form.
fn eigenvalues(m: DMatrix<C64>) -> Vec<C64> {
    nalgebra::Schur::new(m)
        .eigenvalues()
        .map(|e| e.iter().copied().collect())
        .unwrap_or_default()
}

/// `C (jωI − A)⁻¹ B + D` of an LTI system, on the states its inputs reach and its outputs see
/// ([`structural_core`]), with `A` balanced and reduced to Hessenberg form once: `D⁻¹ A D =
/// Q H Qᵀ`, so `(jωI − A)⁻¹ B = D Q (jωI − H)⁻¹ Qᵀ D⁻¹ B`. Without the balancing the
/// Householder reduction's error is relative to `‖A‖` (10⁹ for the controllers, whose fast
/// weighting and road-filter modes sit beside slow ones), and responses came out 10⁻⁷ off a
/// dense LU solve; balanced they agree to 10⁻¹¹. A system with fewer outputs than inputs is
/// evaluated as its dual `(Bᵀ (jωI − Aᵀ)⁻¹ Cᵀ + Dᵀ)ᵀ`: the solve costs `O(n²)` per column, and
/// the predictor's blocks have 5 outputs for dozens of inputs.
#[derive(Clone)]
pub(crate) struct HessenbergResponse {
    /// `Hᵀ` (rows of `H` contiguous: [`solve_hessenberg`]).
    h_t: DMatrix<f64>,
    /// `Qᵀ B`, `C Q` and `D`, complex once here rather than at every frequency.
    qt_b: DMatrix<C64>,
    c_q: DMatrix<C64>,
    d: DMatrix<C64>,
    /// Whether `h_t`, `qt_b`, `c_q` and `d` are the dual's.
    dual: bool,
}

impl HessenbergResponse {
    pub(crate) fn new(sys: &Lti) -> Self {
        if sys.c.nrows() < sys.b.ncols() {
            let dual = Lti::new(
                sys.a.transpose(),
                sys.c.transpose(),
                sys.b.transpose(),
                sys.d.transpose(),
            );
            return HessenbergResponse {
                dual: true,
                ..Self::primal(&dual)
            };
        }
        Self::primal(sys)
    }

    fn primal(sys: &Lti) -> Self {
        let n = sys.order();
        let core = structural_core(sys);
        if core.len() < n {
            let a = sys.a.select_rows(&core).select_columns(&core);
            let (b, c) = (sys.b.select_rows(&core), sys.c.select_columns(&core));
            return Self::primal(&Lti::new(a, b, c, sys.d.clone()));
        }
        if n == 0 {
            return HessenbergResponse {
                h_t: DMatrix::zeros(0, 0),
                qt_b: DMatrix::zeros(0, sys.b.ncols()),
                c_q: DMatrix::zeros(sys.c.nrows(), 0),
                d: complex(&sys.d),
                dual: false,
            };
        }
        // A matrix with NaN is left to the Hessenberg form, whose responses then carry it.
        let (a, scale) =
            crate::numerics::eig::balance(&sys.a).unwrap_or((sys.a.clone(), vec![1.0; n]));
        let hess = Hessenberg::new(a);
        let (q, h) = (hess.q(), hess.h());
        let b = DMatrix::from_fn(n, sys.b.ncols(), |i, j| sys.b[(i, j)] / scale[i]);
        let c = DMatrix::from_fn(sys.c.nrows(), n, |i, j| sys.c[(i, j)] * scale[j]);
        HessenbergResponse {
            qt_b: complex(&(q.transpose() * b)),
            c_q: complex(&(c * &q)),
            h_t: h.transpose(),
            d: complex(&sys.d),
            dual: false,
        }
    }

    /// Everything its responses depend on, as bits.
    fn fingerprint(&self, out: &mut Vec<u64>) {
        push_bits(out, &self.h_t);
        push_complex_bits(out, &self.qt_b);
        push_complex_bits(out, &self.c_q);
        push_complex_bits(out, &self.d);
        out.push(u64::from(self.dual));
    }

    fn at(&self, omega: f64) -> DMatrix<C64> {
        self.at_s(C64::new(0.0, omega))
    }

    /// `C (sI − A)⁻¹ B + D` at any complex `s` (`e^{jωh}` for a discrete-time system).
    pub(crate) fn at_s(&self, s: C64) -> DMatrix<C64> {
        let mut out = self.d.clone();
        if self.h_t.nrows() > 0 {
            let x = solve_hessenberg(&self.h_t, s, self.qt_b.clone());
            out += &self.c_q * x;
        }
        match self.dual {
            true => out.transpose(),
            false => out,
        }
    }

    /// `(C (sI − A)⁻¹ B + D) v`: one solve per column of `v` instead of per input, for a
    /// system with many inputs driven along a few directions (the held loop's eight road
    /// samples by two tracks; at `delay_sf`'s longest delay the solve is most of its
    /// synthesis). Not for a system kept as its dual.
    pub(crate) fn applied(&self, s: C64, v: &DMatrix<C64>) -> DMatrix<C64> {
        assert!(!self.dual, "applied() on a system kept as its dual");
        let mut out = &self.d * v;
        if self.h_t.nrows() > 0 {
            let x = solve_hessenberg(&self.h_t, s, &self.qt_b * v);
            out += &self.c_q * x;
        }
        out
    }
}

/// The bits of a matrix (its shape first), for [`Loop::crossings`]' memo.
fn push_bits(out: &mut Vec<u64>, m: &DMatrix<f64>) {
    out.extend([m.nrows() as u64, m.ncols() as u64]);
    out.extend(m.iter().map(|v| v.to_bits()));
}

fn push_complex_bits(out: &mut Vec<u64>, m: &DMatrix<C64>) {
    out.extend([m.nrows() as u64, m.ncols() as u64]);
    out.extend(m.iter().flat_map(|v| [v.re.to_bits(), v.im.to_bits()]));
}

fn complex(m: &DMatrix<f64>) -> DMatrix<C64> {
    m.map(|v| C64::new(v, 0.0))
}

/// `(sI − H)⁻¹ B` for upper Hessenberg `H`, given as `Hᵀ` (each row of `H` contiguous).
/// Gaussian elimination with partial pivoting between neighbouring rows (the only ones with a
/// sub-diagonal entry), `O(n²)` per column of `B`. Each step changes only the row below the
/// pivot, so the rows of `sI − H` are formed as the elimination reaches them and the finished
/// rows of `U` packed (row `k` from column `k`): half the memory traffic of eliminating a full
/// complex copy, which cost as much as the arithmetic once `H` outgrew the cache (`delay_sf`'s
/// held loops reach 580 states).
fn solve_hessenberg(h_t: &DMatrix<f64>, s: C64, b: DMatrix<C64>) -> DMatrix<C64> {
    let n = h_t.nrows();
    if n == 0 {
        return b;
    }
    // Row `i` of `sI − H` from column `from`.
    let row = |i: usize, from: usize, out: &mut Vec<C64>| {
        out.clear();
        out.extend(
            h_t.column(i).as_slice()[from..]
                .iter()
                .map(|v| C64::new(-v, 0.0)),
        );
        out[i - from] += s;
    };
    let start = |k: usize| k * n - k * k.saturating_sub(1) / 2;
    let mut u: Vec<C64> = Vec::with_capacity(n * (n + 1) / 2);
    let (mut pivot, mut next) = (Vec::with_capacity(n), Vec::with_capacity(n));
    row(0, 0, &mut pivot);
    let mut x = b;
    for k in 0..n - 1 {
        row(k + 1, k, &mut next);
        if next[0].norm() > pivot[0].norm() {
            std::mem::swap(&mut pivot, &mut next);
            x.swap_rows(k, k + 1);
        }
        let f = next[0] / pivot[0];
        if f != C64::new(0.0, 0.0) {
            for (a, b) in next.iter_mut().zip(pivot.iter()) {
                *a -= f * b;
            }
            for j in 0..x.ncols() {
                let v = x[(k, j)];
                x[(k + 1, j)] -= f * v;
            }
        }
        debug_assert_eq!(u.len(), start(k));
        u.extend_from_slice(&pivot);
        // The remaining row, from column k + 1, is the next pivot row.
        pivot.clear();
        pivot.extend_from_slice(&next[1..]);
    }
    u.extend_from_slice(&pivot);
    // Back-substitution, every column in one pass: their sums are independent chains the
    // processor overlaps (one column's is a chain of dependent additions), each summed in the
    // same order as alone.
    let columns = x.ncols();
    let x_all = x.as_mut_slice();
    let mut sums = vec![C64::new(0.0, 0.0); columns];
    for i in (0..n).rev() {
        let row = &u[start(i)..start(i) + n - i];
        for (c, s) in sums.iter_mut().enumerate() {
            *s = x_all[c * n + i];
        }
        for (k, a) in row.iter().enumerate().skip(1) {
            for (c, s) in sums.iter_mut().enumerate() {
                *s -= a * x_all[c * n + i + k];
            }
        }
        for (c, s) in sums.iter().enumerate() {
            x_all[c * n + i] = s / row[0];
        }
    }
    x
}

/// A predictor's frequency response: `U = P₁ Y + (P₂ e^{−jωθ} + P₃) U` with
/// `P₁ = K e^{Aθ} (S_y + S_ξ (jω − A_ξ)⁻¹ B_ξ)`, `P₂ = K e^{Aθ} S_ξ (jω − A_ξ)⁻¹ B_ξu`,
/// `P₃ = K (jωI − A)⁻¹ (I − e^{−jωθ} e^{Aθ}) B` (the Laplace transform of the prediction's
/// integral over the commands still in flight).
#[derive(Clone)]
struct PredictorResponse {
    k_e: DMatrix<f64>,
    s_y: DMatrix<f64>,
    own: HessenbergResponse,
    /// `K (jωI − A)⁻¹ [B, e^{Aθ} B]`: `P₃` from its two halves.
    plant: HessenbergResponse,
    delay: f64,
}

impl PredictorResponse {
    fn new(p: &PredictorLaw) -> Self {
        let e_at =
            expm(&(&p.a * p.delay)).expect("the predictor's delay is within its certified range");
        let r = &p.reconstruction;
        let nxi = r.a_xi.nrows();
        let (ny, nu) = (r.b_xi.ncols(), r.b_xiu.ncols());
        // (jω − A_ξ)⁻¹ [B_ξ B_ξu], read out through K e^{Aθ} S_ξ.
        let mut b_own = DMatrix::zeros(nxi, ny + nu);
        b_own.view_mut((0, 0), (nxi, ny)).copy_from(&r.b_xi);
        b_own.view_mut((0, ny), (nxi, nu)).copy_from(&r.b_xiu);
        let k_e = &p.k * &e_at;
        let own = HessenbergResponse::new(&Lti::new(
            r.a_xi.clone(),
            b_own,
            &k_e * &r.s_xi,
            DMatrix::zeros(p.k.nrows(), ny + nu),
        ));
        // Both halves of `P₃` in one solve with 2 nu columns, not `(jωI − A)⁻¹` whole (n
        // columns): the frequency scans of delay_sf's synthesis spend their time here.
        let n = p.a.nrows();
        let mut b_plant = DMatrix::zeros(n, 2 * nu);
        b_plant.view_mut((0, 0), (n, nu)).copy_from(&p.b);
        b_plant
            .view_mut((0, nu), (n, nu))
            .copy_from(&(&e_at * &p.b));
        let plant = HessenbergResponse::new(&Lti::new(
            p.a.clone(),
            b_plant,
            p.k.clone(),
            DMatrix::zeros(p.k.nrows(), 2 * nu),
        ));
        PredictorResponse {
            s_y: r.s_y.clone(),
            k_e,
            own,
            plant,
            delay: p.delay,
        }
    }

    /// Everything its responses depend on, as bits.
    fn fingerprint(&self, out: &mut Vec<u64>) {
        push_bits(out, &self.k_e);
        push_bits(out, &self.s_y);
        self.own.fingerprint(out);
        self.plant.fingerprint(out);
        out.push(self.delay.to_bits());
    }

    /// `(P₁, I − P₂ e^{−jωθ} − P₃)` at `ω`.
    fn at(&self, omega: f64) -> (DMatrix<C64>, DMatrix<C64>) {
        let c = |x: &DMatrix<f64>| x.map(|v| C64::new(v, 0.0));
        let own = self.own.at(omega);
        let ny = self.s_y.ncols();
        let nu = self.k_e.nrows();
        let p1 = c(&(&self.k_e * &self.s_y)) + own.columns(0, ny);
        let lag = C64::from_polar(1.0, -omega * self.delay);
        let p2 = own.columns(ny, nu).into_owned();
        // K (jωI − A)⁻¹ (I − e^{−jωθ} e^{Aθ}) B.
        let halves = self.plant.at(omega);
        let p3 = halves.columns(0, nu) - halves.columns(nu, nu) * lag;
        let m = DMatrix::<C64>::identity(nu, nu) - p2 * lag - p3;
        (p1, m)
    }
}

/// The car, the controller and the actuators at some conditions, ready to be evaluated at any
/// frequency.
pub struct Loop {
    ss: StateSpace,
    /// Sensor rows `(C_y, D_yr, D_yu)` of the controller's inputs.
    c_y: DMatrix<f64>,
    d_yr: DMatrix<f64>,
    d_yu: DMatrix<f64>,
    /// `G_y(jω) = C_y (jωI − A)⁻¹ B_u + D_yu`: what the controller's inputs see of the forces,
    /// in the loop gain at every frequency of the delay-margin scans (20001 and a bisection per
    /// crossing; a dense complex LU of `jωI − A` at each of them before).
    sensed: HessenbergResponse,
    controller: Option<HessenbergResponse>,
    predictor: Option<PredictorResponse>,
    outputs: Vec<OutputRow>,
    conditions: Conditions,
    static_load: [f64; 4],
    /// The closed loop's eigenvalues where it is rational (no actuator delay, no predictor; the
    /// car's own for the passive car), for the frequency grid ([`continuous_resonances`]);
    /// empty otherwise.
    poles: Vec<C64>,
}

/// The loop's response at one frequency to one input vector.
struct Response {
    /// The car's state.
    x: DVector<C64>,
    /// The applied forces `E U`.
    u_applied: DVector<C64>,
}

impl Loop {
    /// `law = None` is the passive car.
    pub fn new(law: Option<&ControlLaw>, conditions: Conditions) -> Result<Self, PredictionError> {
        let mut conditions = conditions;
        if let Some(rho_min) = law.and_then(|l| l.accommodation) {
            for rho in conditions.effectiveness.iter_mut() {
                *rho /= rho.clamp(rho_min, 1.0);
            }
        }
        let p = &conditions.params;
        let ss = StateSpace::new(p);
        let names: Vec<&str> = law.map_or(Vec::new(), |l| {
            l.inputs.iter().map(|s| s.as_str()).collect()
        });
        let outputs = plant_outputs_at(&conditions);
        let sensors = sensor_rows(&outputs, &names)?;
        let static_load = vehicle::model::StaticEquilibrium::new(p).tire_load;
        let sensed = HessenbergResponse::new(&Lti::new(
            ss.a.clone(),
            ss.b_u.clone(),
            sensors.c.clone(),
            sensors.d_u.clone(),
        ));
        let mut lp = Loop {
            c_y: sensors.c,
            d_yr: sensors.d_r,
            d_yu: sensors.d_u,
            sensed,
            controller: law.map(|l| HessenbergResponse::new(&l.lti)),
            predictor: law
                .and_then(|l| l.predictor.as_ref())
                .map(PredictorResponse::new),
            ss,
            outputs,
            conditions,
            static_load,
            poles: Vec::new(),
        };
        lp.poles = lp.check_stable(law)?;
        Ok(lp)
    }

    /// Stable at these conditions: the rational closed loop's eigenvalues (no delay), and with a
    /// delay, no characteristic root crosses the imaginary axis for any delay up to it
    /// ([`Loop::delay_margin`]). Returns the rational loop's eigenvalues where they are its
    /// poles: without a delay, and for the passive car.
    fn check_stable(&self, law: Option<&ControlLaw>) -> Result<Vec<C64>, PredictionError> {
        let Some(law) = law else {
            return Ok(crate::numerics::eig::eigenvalues(&self.ss.a));
        };
        if let Some(pred) = &law.predictor {
            if self.conditions.actuator_bandwidth_hz.is_some() {
                return Err(PredictionError::NotModelled(
                    "a predictor with lagging actuators".into(),
                ));
            }
            return self.check_predictor_stable(pred).map(|()| Vec::new());
        }
        let cl = rational_loop(law, &self.conditions, &self.ss, (&self.c_y, &self.d_yu))?;
        let poles = crate::numerics::eig::eigenvalues(&cl.a);
        let abscissa =
            crate::numerics::eig::max_or_nan(f64::NEG_INFINITY, poles.iter().map(|l| l.re));
        if abscissa.is_nan() || abscissa >= 0.0 {
            return Err(PredictionError::Unstable(format!(
                "spectral abscissa {abscissa:e} without delay"
            )));
        }
        if self.conditions.delay > 0.0 {
            let margin = self.delay_margin();
            if margin.is_nan() || margin <= self.conditions.delay {
                return Err(PredictionError::Unstable(format!(
                    "delay margin {margin:e} s at or below the delay {} s",
                    self.conditions.delay
                )));
            }
            // The delay moves the poles: no rational loop to name them.
            return Ok(Vec::new());
        }
        Ok(poles)
    }

    /// `K(jω) G_y(jω) diag(ρ)`: the loop broken at the actuators (positive feedback). With a
    /// predictor, `E (I − P₂ e^{−jωθ} − P₃)⁻¹ P₁ G_y` including the actuators' delay `E`, whose
    /// margins are then the extra delay (or advance) the loop tolerates.
    pub(crate) fn loop_gain(&self, omega: f64) -> DMatrix<C64> {
        let g_y = self.sensed.at(omega);
        if let Some(p) = &self.predictor {
            let (p1, inner) = p.at(omega);
            let u = inner
                .lu()
                .solve(&(p1 * g_y))
                .expect("the predictor loop is well posed");
            return self.actuators(omega) * u;
        }
        let k = self.controller.as_ref().expect("a controller").at(omega);
        let lag = self.conditions.lag(omega);
        let rho = DMatrix::from_diagonal(&DVector::from_iterator(
            N_ACTUATORS,
            self.conditions
                .effectiveness
                .iter()
                .map(|r| C64::new(*r, 0.0) * lag),
        ));
        k * g_y * rho
    }

    /// The smallest delay `τ > 0` at which a root of `det(I − e^{−jωτ} K G_y) = 0` reaches the
    /// imaginary axis: where an eigenvalue `λ` of the loop gain crosses the unit circle (located
    /// on a log grid of 20001 frequencies over 10⁻²…10⁵ rad/s and refined by bisection),
    /// `τ = (arg λ mod 2π)/ω`. Infinite if none crosses.
    pub fn delay_margin(&self) -> f64 {
        self.crossings()
            .iter()
            .map(|(w, phase)| phase / w)
            .fold(f64::INFINITY, f64::min)
    }

    /// `(ω, arg λ mod 2π)` where an eigenvalue `λ` of the loop gain crosses the unit circle.
    ///
    /// Remembered for the process by everything the loop gain reads (the car's sensed response,
    /// the effectiveness, the controller's or the predictor's response and then the delay, all
    /// as bits): a robust design's certificate asks for the same scan at every condition that
    /// differs only in its delay (a controller's loop gain does not depend on it; a
    /// predictor's mismatch margins are those of its matched loop): 20 of a synthesis's 27
    /// scans, a tenth of its CPU.
    fn crossings(&self) -> Vec<(f64, f64)> {
        type Scans = HashMap<Vec<u64>, Arc<OnceLock<Vec<(f64, f64)>>>>;
        static SCANS: OnceLock<Mutex<Scans>> = OnceLock::new();
        let cell = SCANS
            .get_or_init(Default::default)
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .entry(self.loop_gain_fingerprint())
            .or_default()
            .clone();
        cell.get_or_init(|| self.scan_crossings()).clone()
    }

    /// Everything [`Loop::loop_gain`] reads, as bits.
    fn loop_gain_fingerprint(&self) -> Vec<u64> {
        let mut key = Vec::new();
        self.sensed.fingerprint(&mut key);
        key.extend(self.conditions.effectiveness.iter().map(|r| r.to_bits()));
        key.push(
            self.conditions
                .actuator_bandwidth_hz
                .map_or(0, f64::to_bits),
        );
        match (&self.predictor, &self.controller) {
            (Some(p), _) => {
                key.push(1);
                p.fingerprint(&mut key);
                key.push(self.conditions.delay.to_bits());
            }
            (None, Some(k)) => {
                key.push(2);
                k.fingerprint(&mut key);
            }
            (None, None) => key.push(0),
        }
        key
    }

    /// [`Loop::crossings`], computed.
    fn scan_crossings(&self) -> Vec<(f64, f64)> {
        let outside = |w: f64| {
            eigenvalues(self.loop_gain(w))
                .iter()
                .filter(|l| l.norm() > 1.0)
                .count()
        };
        let grid: Vec<f64> = (0..=20000)
            .map(|i| 10f64.powf(-2.0 + 7.0 * i as f64 / 20000.0))
            .collect();
        let counts: Vec<usize> = grid.iter().map(|&w| outside(w)).collect();
        let mut found = Vec::new();
        for i in 0..grid.len() - 1 {
            if counts[i] == counts[i + 1] {
                continue;
            }
            let (mut lo, mut hi) = (grid[i], grid[i + 1]);
            for _ in 0..50 {
                let mid = (lo * hi).sqrt();
                if outside(mid) == counts[i] {
                    lo = mid
                } else {
                    hi = mid
                }
            }
            let w = (lo * hi).sqrt();
            if let Some(l) = eigenvalues(self.loop_gain(w))
                .iter()
                .min_by(|a, b| (a.norm() - 1.0).abs().total_cmp(&(b.norm() - 1.0).abs()))
            {
                found.push((w, l.arg().rem_euclid(2.0 * PI)));
            }
        }
        found
    }

    /// `E = e^{−jωθ} L(jω) diag(ρ)`: the actuators at these conditions (`L` their lag,
    /// [`Conditions::actuator_bandwidth_hz`]).
    fn actuators(&self, omega: f64) -> DMatrix<C64> {
        let lag = self.conditions.lag(omega);
        DMatrix::from_diagonal(&DVector::from_iterator(
            N_ACTUATORS,
            self.conditions
                .effectiveness
                .iter()
                .map(|rho| C64::from_polar(*rho, -omega * self.conditions.delay) * lag),
        ))
    }

    /// A predictor loop is stable when the actuators' delay is the one it predicts over and
    /// they are healthy: its characteristic roots are then those of `A + B K` and of `A`
    /// (finite spectrum assignment; the road and weighting states are the controller's or
    /// exogenous, so the car's loop is the design model's). Otherwise the mismatch must lie
    /// within the matched loop's margins ([`Loop::delay_margins`]).
    fn check_predictor_stable(&self, p: &PredictorLaw) -> Result<(), PredictionError> {
        // On the states the commands reach: the rest (the road the predictor guesses, which
        // may climb for ever, [`crate::comfort::plant::ComfortPlant::prediction_model`]) is
        // exogenous, and predicting it over `θ` is a finite sum, no mode of the loop.
        let reached = reached_states(&p.a, &p.b);
        let on = |m: &DMatrix<f64>| m.select_rows(&reached).select_columns(&reached);
        let closed = crate::numerics::eig::spectral_abscissa(&on(&(&p.a + &p.b * &p.k)));
        let open = crate::numerics::eig::spectral_abscissa(&on(&p.a));
        if !(closed < 0.0 && open < 0.0) {
            return Err(PredictionError::Unstable(format!(
                "the predictor's A + B K (spectral abscissa {closed:e}) or A ({open:e}) is not Hurwitz"
            )));
        }
        let mismatch = self.conditions.delay - p.delay;
        let healthy = self.conditions.effectiveness.iter().all(|r| *r == 1.0);
        if mismatch == 0.0 && healthy {
            return Ok(());
        }
        if !healthy {
            return Err(PredictionError::Unstable(
                "the predictor is only certified for healthy actuators".into(),
            ));
        }
        let matched = Loop {
            conditions: Conditions {
                delay: p.delay,
                ..self.conditions
            },
            ss: self.ss.clone(),
            c_y: self.c_y.clone(),
            d_yr: self.d_yr.clone(),
            d_yu: self.d_yu.clone(),
            sensed: self.sensed.clone(),
            controller: None,
            predictor: self.predictor.clone(),
            outputs: Vec::new(),
            static_load: self.static_load,
            poles: Vec::new(),
        };
        let (lag, lead) = matched.delay_margins();
        if (mismatch > 0.0 && mismatch < lag) || (mismatch < 0.0 && -mismatch < lead) {
            Ok(())
        } else {
            Err(PredictionError::Unstable(format!(
                "the actual delay differs from the predicted one by {mismatch:e} s, beyond the \
                 margins (+{lag:e}, −{lead:e}) s"
            )))
        }
    }

    /// The extra delay and the advance the loop tolerates: where an eigenvalue `λ` of the loop
    /// gain crosses the unit circle, `(arg λ mod 2π)/ω` and `(2π − arg λ mod 2π)/ω`, least over
    /// the crossings (as [`Loop::delay_margin`]).
    pub fn delay_margins(&self) -> (f64, f64) {
        let crossings = self.crossings();
        let lag = crossings
            .iter()
            .map(|(w, phase)| phase / w)
            .fold(f64::INFINITY, f64::min);
        let lead = crossings
            .iter()
            .map(|(w, phase)| (2.0 * PI - phase) / w)
            .fold(f64::INFINITY, f64::min);
        (lag, lead)
    }

    /// `((jωI − A)⁻¹ B_r, (jωI − A)⁻¹ B_u)` of the car.
    fn car_response(&self, omega: f64) -> (DMatrix<C64>, DMatrix<C64>) {
        let mut m: DMatrix<C64> = self.ss.a.map(|v| C64::new(-v, 0.0));
        for i in 0..N_STATES {
            m[(i, i)] += C64::new(0.0, omega);
        }
        let lu = m.lu();
        let c = |x: &DMatrix<f64>| x.map(|v| C64::new(v, 0.0));
        (
            lu.solve(&c(&self.ss.b_r)).expect("jωI − A invertible"),
            lu.solve(&c(&self.ss.b_u)).expect("jωI − A invertible"),
        )
    }

    /// The loop's response to each road vector of `rs` at `ω` (a road's two tracks), the car's,
    /// the controller's and the loop's matrices formed and factored once for all.
    fn respond_each<const N: usize>(&self, omega: f64, rs: [&DVector<C64>; N]) -> [Response; N] {
        let (g_r, g_u) = self.car_response(omega);
        let e = self.actuators(omega);
        let c = |x: &DMatrix<f64>| x.map(|v| C64::new(v, 0.0));
        let (c_y, d_yr) = (c(&self.c_y), c(&self.d_yr));
        // The loop `u = M⁻¹ P g_yr` with `g_yr` the sensors' response to the road alone.
        let g_y = || &c_y * &g_u + c(&self.d_yu);
        let closed = match (&self.predictor, &self.controller) {
            (Some(p), _) => {
                let (p1, inner) = p.at(omega);
                let m = inner - &p1 * g_y() * &e;
                Some((m.lu(), p1))
            }
            (None, None) => None,
            (None, Some(k)) => {
                let k = k.at(omega);
                let m = DMatrix::<C64>::identity(N_ACTUATORS, N_ACTUATORS) - &k * g_y() * &e;
                Some((m.lu(), k))
            }
        };
        rs.map(|r| {
            let x_road = &g_r * r;
            let u_applied = match &closed {
                None => DVector::zeros(N_ACTUATORS),
                Some((lu, p)) => {
                    let g_yr = &c_y * &x_road + &d_yr * r;
                    &e * lu.solve(&(p * g_yr)).expect("the loop is well posed")
                }
            };
            Response {
                x: x_road + &g_u * &u_applied,
                u_applied,
            }
        })
    }

    /// An output's response `c x + d_r r + d_u u_a`.
    fn output(&self, row: &OutputRow, r: &DVector<C64>, resp: &Response) -> C64 {
        let c = DVector::from_iterator(N_STATES, row.c.iter().map(|v| C64::new(*v, 0.0)));
        let dr = DVector::from_iterator(N_ROAD, row.d_r.iter().map(|v| C64::new(*v, 0.0)));
        let du = DVector::from_iterator(N_ACTUATORS, row.d_u.iter().map(|v| C64::new(*v, 0.0)));
        c.dot(&resp.x) + dr.dot(r) + du.dot(&resp.u_applied)
    }

    fn row(&self, name: &str) -> &OutputRow {
        self.outputs
            .iter()
            .find(|r| r.name == name)
            .expect("a physical output")
    }

    /// The predicted figures on `road`: `Self::density` over the road's band, the grid graded
    /// around the loop's narrow resonances where it is rational (`continuous_resonances`).
    pub fn figures(&self, road: &ComfortRoad) -> Figures {
        let peaks = continuous_resonances(&self.poles, road.band_hz().1);
        Figures::from_mean_squares(road_integral(road, FREQUENCIES, &peaks, self.density(road)))
    }

    /// `(ω, f) ↦ Σ_track |H|²` of every figure (in [`N_CHANNELS`]' order) at `ω` (`f` in Hz)
    /// for a unit road velocity on each track, the rear wheels `wheelbase / V` behind.
    pub(crate) fn density<'a>(
        &'a self,
        road: &ComfortRoad,
    ) -> impl Fn(f64, f64) -> [f64; N_CHANNELS] + 'a {
        let delay = (self.conditions.params.l1 + self.conditions.params.l2) / road.speed;
        let weightings = ComfortMeter::weightings();
        let weighted: Vec<&OutputRow> = WEIGHTED_SIGNALS.iter().map(|n| self.row(n)).collect();
        let plain: Vec<(&OutputRow, f64)> = plain_signals(&self.static_load)
            .iter()
            .map(|(n, divisor)| (self.row(n), *divisor))
            .collect();
        move |omega, f| {
            let mut density = [0.0f64; N_CHANNELS];
            let r = [0, 1].map(|track| track_input(track, omega, delay));
            let responses = self.respond_each(omega, [&r[0], &r[1]]);
            for (r, resp) in r.iter().zip(&responses) {
                let mut k = 0;
                for (row, w) in weighted.iter().zip(&weightings) {
                    density[k] += (w.response(f) * self.output(row, r, resp)).norm_sqr();
                    k += 1;
                }
                for (row, divisor) in &plain {
                    density[k] += (self.output(row, r, resp) / *divisor).norm_sqr();
                    k += 1;
                }
                for a in 0..N_ACTUATORS {
                    density[k] += resp.u_applied[a].norm_sqr();
                    k += 1;
                }
            }
            density
        }
    }
}

/// The number of figures: `W_k` seat, `W_e` roll and pitch, unweighted body heave, roll and
/// pitch, four strokes, four tyre-load ratios, the seat stroke, five forces ([`Figures`]'
/// order).
pub(crate) const N_CHANNELS: usize = 3 + 3 + 4 + 4 + 1 + 5;

impl Figures {
    /// The figures from their mean squares, in [`N_CHANNELS`]' order.
    pub(crate) fn from_mean_squares(mean_squares: [f64; N_CHANNELS]) -> Figures {
        let rms = mean_squares.map(|v| v.max(0.0).sqrt());
        Figures {
            wk_rms_seat_m_s2: rms[0],
            we_rms_roll_rad_s2: rms[1],
            we_rms_pitch_rad_s2: rms[2],
            vibration_total_m_s2: (rms[0].powi(2)
                + (ROLL_FACTOR * rms[1]).powi(2)
                + (PITCH_FACTOR * rms[2]).powi(2))
            .sqrt(),
            rms_body_heave_m_s2: rms[3],
            rms_roll_rad_s2: rms[4],
            rms_pitch_rad_s2: rms[5],
            rms_stroke_m: [rms[6], rms[7], rms[8], rms[9]],
            rms_tire_load_ratio: [rms[10], rms[11], rms[12], rms[13]],
            rms_seat_stroke_m: rms[14],
            rms_force_n: [rms[15], rms[16], rms[17], rms[18], rms[19]],
        }
    }
}

/// `∫ S Σ_track |H|² df` over the road FMU's band: `density(ω, f)` is `Σ_track |H|²` per
/// figure at a unit road velocity, integrated by Simpson's rule in `ln f` on `even` evenly
/// spaced points (an odd number: [`FREQUENCIES`] for a continuous loop) and weighted by the
/// road's velocity PSD `S`. `peaks` are the loop's resonances
/// `(f [Hz], half-width [Hz])` ([`resonances`]): around each one narrower than the grid
/// resolves, the nodes are graded down to a sixteenth of its half-width ([`nodes`]).
pub(crate) fn road_integral<const N: usize>(
    road: &ComfortRoad,
    even: usize,
    peaks: &[(f64, f64)],
    mut density: impl FnMut(f64, f64) -> [f64; N],
) -> [f64; N] {
    let (f_lo, f_hi) = road.band_hz();
    let psd = vehicle::road::iso_velocity_psd(road.iso_class.0, road.speed);
    let x = nodes(f_lo.ln(), f_hi.ln(), even, peaks);
    // ∫ S |H|² df = ∫ S |H|² f d(ln f).
    let values: Vec<[f64; N]> = x
        .iter()
        .map(|&x| {
            let f = x.exp();
            density(2.0 * PI * f, f).map(|d| d * psd * f)
        })
        .collect();
    let mut acc = [0.0f64; N];
    for (x, v) in x.windows(3).step_by(2).zip(values.windows(3).step_by(2)) {
        // Simpson's rule on two intervals of any lengths (exact for a quadratic).
        let (h0, h1) = (x[1] - x[0], x[2] - x[1]);
        let w = [
            (2.0 - h1 / h0),
            (h0 + h1) * (h0 + h1) / (h0 * h1),
            (2.0 - h0 / h1),
        ]
        .map(|w| w * (h0 + h1) / 6.0);
        for k in 0..N {
            acc[k] += w[0] * v[0][k] + w[1] * v[1][k] + w[2] * v[2][k];
        }
    }
    acc
}

/// The integration nodes in `ln f` over `[lo, hi]`: `even` evenly spaced, and around
/// each of `peaks` inside the band whose relative half-width `d = δ / f` is below four
/// spacings, nodes `d / 16` apart within `2d` of it, then growing by 5 % per node until they
/// are as far apart as the even ones (which they replace there; about 330 nodes for a peak
/// 90 times narrower than the spacing). An odd count, so that
/// Simpson's pairs of intervals cover the band. A loop's response near a pole `δ` from the
/// axis is a Lorentzian of half-width `δ`: the even grid alone missed `ft_of`'s hold mode at
/// 7.5 ms (half-width 6·10⁻⁵ relative, 90 times narrower than the spacing): 0.058 m/s² on
/// the even grid, 0.105 on four times as many nodes, 0.175 graded, 0.175 (10⁻⁴ apart) by
/// brute force (nodes `d / 16` apart over 200 half-widths).
fn nodes(lo: f64, hi: f64, even: usize, peaks: &[(f64, f64)]) -> Vec<f64> {
    let spacing = (hi - lo) / (even - 1) as f64;
    let mut refined: Vec<(f64, f64, Vec<f64>)> = Vec::new();
    for &(f, width) in peaks {
        let d = width / f;
        if !(f > 0.0 && d > 0.0 && d < 4.0 * spacing) {
            continue;
        }
        let centre = f.ln();
        let mut offsets = vec![0.0];
        let (mut at, mut gap) = (0.0, d / 16.0);
        while gap < spacing {
            at += gap;
            offsets.push(at);
            if at >= 2.0 * d {
                gap *= 1.05;
            }
        }
        // The even nodes give way half a spacing beyond the graded ones, so that no interval
        // is much shorter than its neighbour.
        let reach = at + 0.5 * spacing;
        if centre + reach < lo || centre - reach > hi {
            continue;
        }
        let xs: Vec<f64> = offsets
            .iter()
            .rev()
            .map(|o| centre - o)
            .chain(offsets.iter().skip(1).map(|o| centre + o))
            .filter(|x| (lo..=hi).contains(x))
            .collect();
        refined.push((centre - reach, centre + reach, xs));
    }
    let mut x: Vec<f64> = (0..even)
        .map(|i| lo + spacing * i as f64)
        .filter(|x| !refined.iter().any(|(a, b, _)| (a..=b).contains(&x)))
        .collect();
    for (_, _, xs) in refined {
        x.extend(xs);
    }
    x.push(lo);
    x.push(hi);
    x.sort_by(f64::total_cmp);
    // Where graded regions overlap, a node closer to the last kept one than half the gap
    // before it goes (intervals shrink by at most a half from one to the next).
    let mut kept: Vec<f64> = Vec::with_capacity(x.len());
    for v in x {
        let keep = match kept[..] {
            [] => true,
            [a] => v - a > 1e-12 * spacing,
            [.., a, b] => v - b >= 0.5 * (b - a),
        };
        if keep {
            kept.push(v);
        }
    }
    let mut x = kept;
    if x.last() != Some(&hi) {
        // `hi` itself fell to the rule: it ends the band.
        *x.last_mut().expect("nodes") = hi;
    }
    if x.len().is_multiple_of(2) {
        // Halve the widest interval.
        let k = (0..x.len() - 1)
            .max_by(|&a, &b| (x[a + 1] - x[a]).total_cmp(&(x[b + 1] - x[b])))
            .expect("two nodes");
        x.insert(k + 1, 0.5 * (x[k] + x[k + 1]));
    }
    x
}

/// A discrete-time loop's resonances over road frequencies, from its poles `z` at a step `h`:
/// `(f, δ)` [Hz] for each alias `f = (arg z + 2πk) / (2πh) > 0` (the response at the sampling
/// instants repeats every `1/h`), half-width `δ = −ln|z| / (2πh)`. Up to `f_max`.
pub(crate) fn resonances(poles: &[C64], h: f64, f_max: f64) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    for z in poles {
        let (r, phi) = (z.norm(), z.arg());
        if !(r > 0.0 && r < 1.0) {
            continue;
        }
        let width = -r.ln() / (2.0 * PI * h);
        let mut f = phi / (2.0 * PI * h);
        while f <= f_max + 1.0 / h {
            if f > 0.0 {
                out.push((f, width));
            }
            f += 1.0 / h;
        }
    }
    out
}

/// A continuous-time loop's resonances over road frequencies, from its poles `s`: `(f, δ)` [Hz]
/// with `f = Im s / 2π > 0` up to `f_max`, half-width `δ = −Re s / 2π` (the response near the
/// pole is a Lorentzian of that half-width in `f`). Unstable poles name nothing.
pub(crate) fn continuous_resonances(poles: &[C64], f_max: f64) -> Vec<(f64, f64)> {
    poles
        .iter()
        .filter(|s| s.im > 0.0 && s.re < 0.0)
        .map(|s| (s.im / (2.0 * PI), -s.re / (2.0 * PI)))
        .filter(|(f, _)| *f <= f_max)
        .collect()
}

/// The predicted figures of `law` (`None`: the passive car) at `conditions` on `road`.
pub fn predict(
    law: Option<&ControlLaw>,
    conditions: Conditions,
    road: &ComfortRoad,
) -> Result<Figures, PredictionError> {
    Ok(Loop::new(law, conditions)?.figures(road))
}

/// The road input `[z_r; ż_r]` of a unit road velocity on `track`'s front wheel at `ω`: the
/// heights its integral, the rear wheel the same `delay` later (exactly, `e^{−jω delay}`).
pub fn track_input(track: usize, omega: f64, delay: f64) -> DVector<C64> {
    let s = C64::new(0.0, omega);
    let rear = C64::from_polar(1.0, -omega * delay);
    let mut r = DVector::<C64>::zeros(N_ROAD);
    r[N_WHEELS + track] = C64::new(1.0, 0.0);
    r[N_WHEELS + 2 + track] = rear;
    r[track] = C64::new(1.0, 0.0) / s;
    r[2 + track] = rear / s;
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A car's sensors read nothing of a rigid motion; an absolute height, an absolute velocity
    /// or a tyre deflection's road part does.
    #[test]
    fn only_absolute_signals_read_a_rigid_motion() {
        let p = VehicleParams::default();
        let car: Vec<String> = vehicle::sensors::SENSORS
            .iter()
            .map(|(n, _)| format!("sensor_{n}"))
            .chain([
                "f_fl".to_string(),
                "stroke_fl".to_string(),
                "a_seat".to_string(),
            ])
            .collect();
        assert_eq!(rigid_readings(&p, &car).unwrap(), vec![]);
        let absolute: Vec<String> = ["x[1]", "x[2]", "x[3]", "x[4]", "x[9]", "v_body"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        let read = rigid_readings(&p, &absolute).unwrap();
        assert_eq!(
            read.iter().map(|(n, _)| n.as_str()).collect::<Vec<_>>(),
            ["x[1]", "x[2]", "x[3]", "x[4]", "x[9]", "v_body"]
        );
        // The body's height reads the heave; its velocity the climb.
        assert!((read[0].1 - 1.0).abs() < 1e-9, "{read:?}");
        assert!((read[5].1 - 1.0).abs() < 1e-9, "{read:?}");
    }
    use crate::shipping::design::ComfortDesign;
    use vehicle::iso2631::Weighting;

    fn design() -> ComfortDesign {
        ComfortDesign::from_json(include_str!("../../designs/comfort.json")).unwrap()
    }

    /// The delay-margin scans are remembered by what the loop gain reads: loops of one
    /// controller that differ only in their delay share one (their gain does not depend on it),
    /// a loop with an actuator at half its force does not, and a remembered scan is the one
    /// computed afresh.
    #[test]
    fn loops_share_a_delay_margin_scan_only_when_their_gain_is_the_same() {
        let mut c = DMatrix::zeros(N_ACTUATORS, 1);
        for i in 0..4 {
            c[(i, 0)] = -3000.0;
        }
        let law = ControlLaw {
            lti: Lti::new(
                DMatrix::from_element(1, 1, -60.0),
                DMatrix::from_row_slice(1, 2, &[60.0, 0.0]),
                c,
                DMatrix::zeros(N_ACTUATORS, 2),
            ),
            inputs: vec!["x[9]".into(), "x[12]".into()],
            predictor: None,
            accommodation: None,
        };
        let nominal = Conditions::nominal(VehicleParams::default());
        let at = |delay: f64, effectiveness: [f64; N_ACTUATORS]| {
            // Set field by field: `Conditions { delay, effectiveness, ..nominal }` in this
            // closure is an internal compiler error of rustc 1.95 ("broken MIR").
            let mut conditions = nominal;
            conditions.delay = delay;
            conditions.effectiveness = effectiveness;
            Loop::new(Some(&law), conditions).unwrap()
        };
        let healthy = [1.0; N_ACTUATORS];
        let (a, b) = (at(1e-3, healthy), at(2e-3, healthy));
        let weak = at(1e-3, [0.5, 1.0, 1.0, 1.0, 1.0]);
        assert_eq!(a.loop_gain_fingerprint(), b.loop_gain_fingerprint());
        assert_ne!(a.loop_gain_fingerprint(), weak.loop_gain_fingerprint());
        for lp in [&a, &b, &weak] {
            assert_eq!(lp.crossings(), lp.scan_crossings());
        }
        assert_ne!(a.crossings(), weak.crossings());
    }

    /// `C (jωI − A)⁻¹ B + D` by a dense LU solve of the unreduced system: the reference.
    fn dense_response(sys: &Lti, omega: f64) -> DMatrix<C64> {
        let c = |x: &DMatrix<f64>| x.map(|v| C64::new(v, 0.0));
        let mut m = c(&sys.a).map(|v| -v);
        for i in 0..sys.order() {
            m[(i, i)] += C64::new(0.0, omega);
        }
        c(&sys.c) * m.lu().solve(&c(&sys.b)).unwrap() + c(&sys.d)
    }

    /// The Hessenberg responses, primal and dual, equal a dense solve on `hinf_sf`'s controller
    /// (`‖A‖` ≈ 10⁹: the sensors' fast filters beside the car's modes) from 0.01 Hz to 10 kHz.
    /// Unbalanced, the same responses were 10⁻⁷ off; the bound is 10⁻¹⁰.
    #[test]
    fn hessenberg_responses_equal_a_dense_solve_on_a_badly_scaled_controller() {
        let p = VehicleParams::default();
        let d = design();
        let (g, sf) = crate::comfort::designs::nominal_gain(&crate::comfort::designs::Context {
            params: &p,
            design: &d,
        })
        .unwrap();
        let k = crate::comfort::controllers::realise_state_feedback(&g, &sf.k);
        assert!(k.a.norm() > 1e8, "not badly scaled: {:e}", k.a.norm());
        // More inputs than outputs (the dual), and fewer (the primal).
        let few = Lti::new(
            k.a.clone(),
            k.b.columns(0, 2).into_owned(),
            k.c.clone(),
            k.d.columns(0, 2).into_owned(),
        );
        assert!(k.b.ncols() > k.c.nrows() && few.b.ncols() < few.c.nrows());
        for sys in [k, few] {
            let fast = HessenbergResponse::new(&sys);
            for i in 0..=300 {
                let omega = 2.0 * PI * 0.01 * 1e6f64.powf(i as f64 / 300.0);
                let reference = dense_response(&sys, omega);
                let error = (fast.at(omega) - &reference).norm() / reference.norm();
                assert!(error < 1e-10, "at {omega} rad/s: relative error {error:e}");
            }
        }
    }

    /// A system with states its inputs never reach (feeding the rest) and states its outputs
    /// never see (fed by the rest): its response is its core's, and equals a dense solve of
    /// the whole system.
    #[test]
    fn states_the_inputs_never_reach_or_the_outputs_never_see_are_left_out() {
        // Core 0..4, unreached 4..7, unseen 7..9; entries from a fixed pseudo-random sequence.
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed % 2000) as f64 / 1000.0 - 1.0
        };
        let (core, unreached, n) = (4, 7, 9);
        let a = DMatrix::from_fn(n, n, |i, j| {
            let diagonal = if i == j { -3.0 } else { 0.0 };
            // Nothing reaches the unreached states from the core, nothing the unseen ones
            // drive reaches the rest.
            let unreached_row = (core..unreached).contains(&i);
            let zero = (unreached_row && j < core) || (i < unreached && j >= unreached);
            if zero {
                0.0
            } else {
                diagonal + next()
            }
        });
        let b = DMatrix::from_fn(n, 3, |i, _| if i < core { next() } else { 0.0 });
        let c = DMatrix::from_fn(2, n, |_, j| if j < unreached { next() } else { 0.0 });
        let sys = Lti::new(a, b, c, DMatrix::from_element(2, 3, 0.5));
        assert_eq!(structural_core(&sys), vec![0, 1, 2, 3]);
        let fast = HessenbergResponse::new(&sys);
        assert_eq!(fast.h_t.nrows(), core);
        for omega in [0.01, 0.3, 1.0, 7.0, 100.0] {
            let reference = dense_response(&sys, omega);
            let error = (fast.at(omega) - &reference).norm() / reference.norm();
            assert!(error < 1e-12, "at {omega} rad/s: relative error {error:e}");
        }
    }

    /// The integral is what the road FMU realises: the mean square of the passive car's
    /// weighted seat acceleration under the road's own cosines (each contributes
    /// `½ |W H(f_k)|² (2π n_k V a_k)²` in steady state) equals the predicted one.
    #[test]
    fn prediction_equals_the_mean_square_under_the_road_fmus_cosines() {
        let d = design();
        let p = VehicleParams::default();
        let lp = Loop::new(None, Conditions::nominal(p)).unwrap();
        let figures = lp.figures(&d.road);
        let road = vehicle::road::Road::new(
            vehicle::road::Profile::Iso {
                class: d.road.iso_class.0,
                seed: 5,
                identical_tracks: false,
                fade_in: 0.0,
            },
            d.road.speed,
            p.l1 + p.l2,
            0.0,
        )
        .unwrap();
        let wk = Weighting::wk();
        let delay = (p.l1 + p.l2) / d.road.speed;
        let mut mean_square = 0.0;
        for track in 0..2 {
            for (a, n, _) in road.iso_components(track) {
                let f = n * d.road.speed;
                let omega = 2.0 * PI * f;
                let r = track_input(track, omega, delay);
                let [resp] = lp.respond_each(omega, [&r]);
                let h = wk.response(f) * lp.output(lp.row("a_seat"), &r, &resp);
                mean_square += 0.5 * h.norm_sqr() * (a * omega).powi(2);
            }
        }
        let discrete = mean_square.sqrt();
        eprintln!(
            "passive W_k seat: predicted {:.6}, cosines {discrete:.6}",
            figures.wk_rms_seat_m_s2
        );
        assert!((figures.wk_rms_seat_m_s2 - discrete).abs() < 2e-3 * discrete);
    }

    /// A condition as the plant FMU's parameters: only what differs from the defaults, under
    /// the FMU's names.
    #[test]
    fn conditions_name_the_plant_parameters_that_realise_them() {
        let p = VehicleParams::default();
        assert!(Conditions::nominal(p).plant_parameters(&p).is_empty());
        let heavy = Conditions::nominal(VehicleParams {
            m_s: 1800.0,
            i_x: 600.0,
            ..p
        });
        assert_eq!(
            heavy.plant_parameters(&p),
            BTreeMap::from([("m_s".to_string(), 1800.0), ("I_x".to_string(), 600.0)])
        );
        let late = Conditions {
            delay: 0.02,
            ..Conditions::nominal(p)
        };
        assert_eq!(
            late.plant_parameters(&p),
            BTreeMap::from([("tau".to_string(), 0.02)])
        );
        let faulty = Conditions {
            effectiveness: [1.0, 0.5, 1.0, 1.0, 0.25],
            ..Conditions::nominal(p)
        };
        assert_eq!(
            faulty.plant_parameters(&p),
            BTreeMap::from([
                ("fault_time".to_string(), 0.0),
                ("fault_loss_fr".to_string(), 0.5),
                ("fault_loss_seat".to_string(), 0.75)
            ])
        );
    }

    /// A resonance 90 times narrower than the grid's spacing (`ft_of`'s hold mode at 7.5 ms:
    /// a Lorentzian of relative half-width 6·10⁻⁵ at 30.77 Hz, on a smooth background) is
    /// integrated to 10⁻⁶ of its closed form when the loop names it, and missed without;
    /// resonances outside the band or broad enough for the grid change nothing.
    #[test]
    fn a_sharp_resonance_is_integrated_where_the_loop_names_it() {
        let road = design().road;
        let (f_lo, f_hi) = road.band_hz();
        let psd = vehicle::road::iso_velocity_psd(road.iso_class.0, road.speed);
        let (fp, width) = (30.77, 30.77 * 6e-5);
        let g = |f: f64| width * width / ((f - fp).powi(2) + width * width) + 1e-6 * f;
        let exact = width * (((f_hi - fp) / width).atan() - ((f_lo - fp) / width).atan())
            + 0.5e-6 * (f_hi * f_hi - f_lo * f_lo);
        let integral =
            |peaks: &[(f64, f64)]| road_integral(&road, FREQUENCIES, peaks, |_, f| [g(f) / psd])[0];
        let named = integral(&[(fp, width), (2.0 * f_hi, 1e-3), (5.0, 1.0)]);
        let missed = integral(&[]);
        println!("exact {exact:e}, named {named:e}, missed {missed:e}");
        assert!((named - exact).abs() < 1e-6 * exact, "{named} vs {exact}");
        assert!((missed - exact).abs() > 0.05 * exact, "{missed} vs {exact}");
        let broad = |f: f64| 1e-3 * f;
        let plain = road_integral(&road, FREQUENCIES, &[], |_, f| [broad(f) / psd])[0];
        let hinted = road_integral(
            &road,
            FREQUENCIES,
            &[(2.0 * f_hi, 1e-3), (5.0, 1.0)],
            |_, f| [broad(f) / psd],
        )[0];
        assert_eq!(plain, hinted);
    }

    /// Adaptive Simpson of `g` over `[a, b]` to an absolute `tol` (the reference below).
    fn adaptive_simpson(g: &dyn Fn(f64) -> f64, a: f64, b: f64, tol: f64) -> f64 {
        /// `[a, m, b]` and `g` there; `whole` Simpson's rule on them.
        fn rec(
            g: &dyn Fn(f64) -> f64,
            x: [f64; 3],
            y: [f64; 3],
            whole: f64,
            tol: f64,
            depth: u32,
        ) -> f64 {
            let (lm, rm) = (0.5 * (x[0] + x[1]), 0.5 * (x[1] + x[2]));
            let (flm, frm) = (g(lm), g(rm));
            let left = (x[1] - x[0]) / 6.0 * (y[0] + 4.0 * flm + y[1]);
            let right = (x[2] - x[1]) / 6.0 * (y[1] + 4.0 * frm + y[2]);
            if depth == 0 || (left + right - whole).abs() <= 15.0 * tol {
                return left + right + (left + right - whole) / 15.0;
            }
            rec(
                g,
                [x[0], lm, x[1]],
                [y[0], flm, y[1]],
                left,
                0.5 * tol,
                depth - 1,
            ) + rec(
                g,
                [x[1], rm, x[2]],
                [y[1], frm, y[2]],
                right,
                0.5 * tol,
                depth - 1,
            )
        }
        let x = [a, 0.5 * (a + b), b];
        let y = x.map(g);
        rec(g, x, y, (b - a) / 6.0 * (y[0] + 4.0 * y[1] + y[2]), tol, 40)
    }

    /// A continuous loop with a narrow mode (a controller's resonator at 4 Hz, damping ratio
    /// 5·10⁻⁵, driven by the front left tyre's deflection and pushing the seat, so that the loop
    /// barely damps it: the closed loop's mode is 3.6·10⁻⁵ wide, 155 times narrower than the
    /// grid's spacing): its prediction grades the grid around the closed loop's pole and equals
    /// adaptive Simpson on the same density (the band split 200 half-widths either side of the
    /// pole, so that no first sample can miss it; 10⁻¹⁰ relative) to 10⁻⁶ (2.3·10⁻⁷ measured);
    /// the even grid alone is 34 % low.
    #[test]
    fn a_narrow_continuous_mode_is_integrated_where_the_loop_names_it() {
        let (w, zeta, gain) = (2.0 * PI * 4.0, 5e-5, 300.0);
        let mut c = DMatrix::zeros(N_ACTUATORS, 2);
        c[(4, 1)] = gain;
        let law = ControlLaw {
            lti: Lti::new(
                DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -w * w, -2.0 * zeta * w]),
                DMatrix::from_row_slice(2, 1, &[0.0, w]),
                c,
                DMatrix::zeros(N_ACTUATORS, 1),
            ),
            inputs: vec!["tire_defl_fl".into()],
            predictor: None,
            accommodation: None,
        };
        let road = design().road;
        let lp = Loop::new(Some(&law), Conditions::nominal(VehicleParams::default())).unwrap();
        let (f_lo, f_hi) = road.band_hz();
        let peaks = continuous_resonances(&lp.poles, f_hi);
        let &(fp, width) = peaks
            .iter()
            .min_by(|a, b| (a.1 / a.0).total_cmp(&(b.1 / b.0)))
            .unwrap();
        let spacing = (f_hi / f_lo).ln() / (FREQUENCIES - 1) as f64;
        println!("sharpest closed-loop mode {fp:.4} Hz, relative half-width {:e} ({:.0} times narrower than the spacing)", width / fp, spacing * fp / width);
        assert!(
            (fp - 4.0).abs() < 0.5 && width / fp < spacing / 20.0,
            "{fp} Hz, {width} Hz"
        );
        let density = lp.density(&road);
        let graded = lp.figures(&road).wk_rms_seat_m_s2.powi(2);
        let even = road_integral(&road, FREQUENCIES, &[], &density)[0];
        let psd = vehicle::road::iso_velocity_psd(road.iso_class.0, road.speed);
        let g = |f: f64| density(2.0 * PI * f, f)[0] * psd;
        let (a, b) = (fp - 200.0 * width, fp + 200.0 * width);
        let tol = 1e-10 * graded;
        let reference = adaptive_simpson(&g, f_lo, a, tol)
            + adaptive_simpson(&g, a, b, tol)
            + adaptive_simpson(&g, b, f_hi, tol);
        println!("W_k seat mean square: graded {graded:e}, adaptive Simpson {reference:e}, even grid {even:e}");
        assert!(
            (graded - reference).abs() < 1e-6 * reference,
            "{graded} vs {reference}"
        );
        assert!(
            (even - reference).abs() > 0.05 * reference,
            "{even} vs {reference}"
        );
    }

    /// Simpson's rule on [`FREQUENCIES`] points against an independent rule, the trapezoid on
    /// 16 000 intervals (its own error below 10⁻⁹ at these speeds), at a quarter of the design
    /// speed to twice it: the slower the car, the faster the wheelbase delay's oscillation
    /// across the band and the larger Simpson's error (measured: 8.5·10⁻¹⁰ at 5 m/s, 2·10⁻¹²
    /// at 20 m/s).
    #[test]
    fn the_frequency_grid_is_fine_enough() {
        let p = VehicleParams::default();
        let lp = Loop::new(None, Conditions::nominal(p)).unwrap();
        let wk = Weighting::wk();
        for speed in [5.0, 10.0, 20.0, 40.0] {
            let mut road = design().road;
            road.speed = speed;
            let simpson = lp.figures(&road).wk_rms_seat_m_s2;
            let (f_lo, f_hi) = road.band_hz();
            let psd = vehicle::road::iso_velocity_psd(road.iso_class.0, speed);
            let delay = (p.l1 + p.l2) / speed;
            let density = |f: f64| {
                let omega = 2.0 * PI * f;
                (0..2)
                    .map(|track| {
                        let r = track_input(track, omega, delay);
                        let [resp] = lp.respond_each(omega, [&r]);
                        (wk.response(f) * lp.output(lp.row("a_seat"), &r, &resp)).norm_sqr()
                    })
                    .sum::<f64>()
                    * psd
                    * f
            };
            let n = 16_000;
            let h = (f_hi / f_lo).ln() / n as f64;
            let values: Vec<f64> = (0..=n)
                .map(|i| density(f_lo * (h * i as f64).exp()))
                .collect();
            let trapezoid: f64 = values.windows(2).map(|w| 0.5 * (w[0] + w[1]) * h).sum();
            let rel = (trapezoid.sqrt() - simpson).abs() / trapezoid.sqrt();
            println!(
                "{speed} m/s: Simpson on {FREQUENCIES} points against the trapezoid on {n} \
                 intervals: {rel:e}"
            );
            assert!(rel < 1e-8, "{speed} m/s: {rel:e}");
        }
    }
}
