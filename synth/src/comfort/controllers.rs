//! The comfort designs as controllers a car can run: what they read (plant outputs by name),
//! their states, their commands.
//!
//! * **State feedback** `u = K x` on the design state `[car; road; weightings; delay weight]`
//!   ([`realise_state_feedback`]): the car's 16 states are read, the road heights as
//!   `z_u − tire_defl`, and the rest are the controller's own states driven by what it reads:
//!   the rear-road Padé states by the front road heights (wheelbase preview), copies of the
//!   ISO weightings by the measured accelerations `a_seat`, `alpha_roll`, `alpha_pitch`, and the
//!   delay weight by its own command.
//! * **Output feedback** ([`observer_based`]): an observer of the design state from the
//!   sensors a car has (a Kalman filter of the road model and sensor noise,
//!   [`crate::comfort::car`]), the same kind of gain on the estimate.
//!
//! Both are plain LTI systems `ξ̇ = A ξ + B y`, `u = C ξ + D y` for the controller FMU.

use crate::comfort::plant::{ComfortPlant, COMFORT_OUTPUTS};
use crate::numerics::hinf_norm::Lti;
use crate::numerics::interconnect::{Plant, Sensors};
use crate::numerics::riccati::{care, RiccatiError};
use nalgebra::DMatrix;
use vehicle::iso2631::Weighting;
use vehicle::model::{coord, CORNERS, N_STATES};

/// The plant the controllers act on: the design plant without the delay weight (which is the
/// controller's own), as `(A, B_w, B_u)`.
pub fn plant_of(g: &ComfortPlant) -> Plant {
    let n = g.layout.weight.as_ref().map_or(g.n(), |w| w.start);
    Plant {
        a: g.a.view((0, 0), (n, n)).into_owned(),
        b_w: g.b_w.rows(0, n).into_owned(),
        b_u: g.b_u.rows(0, n).into_owned(),
    }
}

/// A plant output (or the state `x[k]`, 1-based) as sensor rows of `g`'s plant.
fn sensor_row(g: &ComfortPlant, name: &str, n: usize) -> [DMatrix<f64>; 3] {
    let nw = g.b_w.ncols();
    if let Some(k) = name
        .strip_prefix("x[")
        .and_then(|s| s.strip_suffix(']'))
        .and_then(|s| s.parse::<usize>().ok())
    {
        let mut c = DMatrix::zeros(1, n);
        c[(0, k - 1)] = 1.0;
        return [c, DMatrix::zeros(1, nw), DMatrix::zeros(1, g.b_u.ncols())];
    }
    let (c, d_w, d_u) = g.output(name);
    [c.columns(0, n).into_owned(), d_w, d_u]
}

fn sensors(g: &ComfortPlant, names: Vec<String>) -> Sensors {
    let n = plant_of(g).a.nrows();
    let rows: Vec<[DMatrix<f64>; 3]> = names.iter().map(|s| sensor_row(g, s, n)).collect();
    let stack = |i: usize| {
        DMatrix::from_rows(
            &rows
                .iter()
                .map(|r| r[i].row(0).into_owned())
                .collect::<Vec<_>>(),
        )
    };
    Sensors {
        c: stack(0),
        d_w: stack(1),
        d_u: stack(2),
        names,
    }
}

/// The plant of `g` and the sensors `names` (plant outputs, `sensor_*` as their physical
/// outputs), without noise.
pub fn named_sensors(g: &ComfortPlant, names: Vec<String>) -> (Plant, Sensors) {
    (plant_of(g), sensors(g, names))
}

/// The wheel index of each road height the state holds ([`ComfortPlant::road_height_rows`]).
fn height_wheels(g: &ComfortPlant) -> Vec<(usize, usize)> {
    g.road_height_rows()
}

/// What a state-feedback design reads: `x[1]…x[16]`, the tyre deflections of the wheels whose
/// road height is a state, and the three accelerations the comfort weightings filter.
pub fn state_feedback_sensors(g: &ComfortPlant) -> Sensors {
    let mut names: Vec<String> = (1..=N_STATES).map(|k| format!("x[{k}]")).collect();
    names.extend(
        height_wheels(g)
            .iter()
            .map(|(_, w)| format!("tire_defl_{}", CORNERS[*w])),
    );
    names.extend(COMFORT_OUTPUTS.iter().map(|(n, _)| n.to_string()));
    sensors(g, names)
}

/// The weighting realisations the design plant uses, in the order of its filter states.
fn weighting(i: usize) -> [DMatrix<f64>; 4] {
    let w = if i == 0 {
        Weighting::wk()
    } else {
        Weighting::we()
    };
    w.without_low_pass().state_space()
}

/// How a state-feedback controller knows the design state: `x = S_y y + S_ξ ξ` from what it
/// reads (`y`, [`state_feedback_sensors`]) and its own states `ξ`, which follow
/// `ξ̇ = A_ξ ξ + B_ξ y + B_ξu u_a` with `u_a` the force the actuators apply (the command, delayed
/// when there is a delay): the rear-road preview states as in the plant (driven by the front
/// road heights), the weighting copies by the measured accelerations, the delay weight by `u_a`.
#[derive(Debug, Clone)]
pub struct Reconstruction {
    pub s_y: DMatrix<f64>,
    pub s_xi: DMatrix<f64>,
    pub a_xi: DMatrix<f64>,
    pub b_xi: DMatrix<f64>,
    pub b_xiu: DMatrix<f64>,
    /// `D_yu`: how the force the actuators apply reaches what it reads at once (the
    /// accelerations). A runtime that holds `y` over a step drives `ξ` by `y − D_yu f(t_k)` held
    /// and `B_ξ D_yu f(t)` as the actuators apply it: exact, where the held `y` would carry the
    /// force of `t_k` across a step in which the (delayed) command changes.
    pub d_yu: DMatrix<f64>,
}

/// The [`Reconstruction`] of `g`'s state (which includes the delay weight).
pub fn reconstruction(g: &ComfortPlant) -> Reconstruction {
    let layout = &g.layout;
    let heights = height_wheels(g);
    let height_states: Vec<usize> = heights.iter().map(|(s, _)| *s).collect();
    // The long waves are not among its states: nothing it reads drives them, so their copy
    // would stay at zero (the gain's feedforward of them is not realised; the design's limits
    // answer for that, `guaranteed::limit_sigmas`).
    let preview: Vec<usize> = layout
        .road
        .clone()
        .filter(|s| !height_states.contains(s) && !layout.waves.contains(s))
        .collect();
    let filters: Vec<usize> = layout.filters.iter().flat_map(|r| r.clone()).collect();
    let weight: Vec<usize> = layout
        .weight
        .clone()
        .map(|r| r.collect())
        .unwrap_or_default();
    let frame: Vec<usize> = layout
        .frame
        .clone()
        .map(|r| r.collect())
        .unwrap_or_default();
    let own: Vec<usize> = preview
        .iter()
        .chain(&filters)
        .chain(&weight)
        .chain(&frame)
        .copied()
        .collect();
    let (n, nc, nu) = (g.n(), own.len(), g.b_u.ncols());
    let ny = N_STATES + heights.len() + COMFORT_OUTPUTS.len();
    let (acc0, defl0) = (N_STATES + heights.len(), N_STATES);
    let mut s_y = DMatrix::zeros(n, ny);
    let mut s_xi = DMatrix::zeros(n, nc);
    for i in 0..N_STATES {
        s_y[(i, i)] = 1.0;
    }
    for (j, (state, wheel)) in heights.iter().enumerate() {
        // z_r = z_u − tire_defl.
        s_y[(*state, coord::WHEEL[*wheel])] = 1.0;
        s_y[(*state, defl0 + j)] = -1.0;
    }
    for (j, state) in own.iter().enumerate() {
        s_xi[(*state, j)] = 1.0;
    }
    let mut a_xi = DMatrix::zeros(nc, nc);
    let mut b_xi = DMatrix::zeros(nc, ny);
    let mut b_xiu = DMatrix::zeros(nc, nu);
    for (j, state) in own.iter().enumerate() {
        // The preview and the frame, driven by the road, as the model drives them.
        if preview.contains(state) || frame.contains(state) {
            let row = g.a.row(*state);
            a_xi.row_mut(j).copy_from(&(row * &s_xi));
            b_xi.row_mut(j).copy_from(&(row * &s_y));
        }
    }
    let mut o = preview.len();
    for (i, range) in layout.filters.iter().enumerate() {
        let [fa, fb, _, _] = weighting(i);
        let m = range.len();
        a_xi.view_mut((o, o), (m, m)).copy_from(&fa);
        b_xi.view_mut((o, acc0 + i), (m, 1)).copy_from(&fb);
        o += m;
    }
    if let Some(range) = &layout.weight {
        for (j, state) in range.clone().enumerate() {
            a_xi[(o + j, o + j)] = g.a[(state, state)];
            b_xiu.row_mut(o + j).copy_from(&g.b_u.row(state));
        }
    }
    Reconstruction {
        s_y,
        s_xi,
        a_xi,
        b_xi,
        b_xiu,
        d_yu: state_feedback_sensors(g).d_u,
    }
}

/// State feedback `u = K x` on `g`'s state (which includes the delay weight) as an LTI controller
/// on [`state_feedback_sensors`]: `C = K S_ξ`, `D = K S_y`, and with `u_a = u`,
/// `A = A_ξ + B_ξu C`, `B = B_ξ + B_ξu D` ([`reconstruction`]).
pub fn realise_state_feedback(g: &ComfortPlant, k: &DMatrix<f64>) -> Lti {
    reconstruction(g).realise(k)
}

impl Reconstruction {
    /// `u = K x` on the state this reconstructs ([`realise_state_feedback`]).
    pub fn realise(&self, k: &DMatrix<f64>) -> Lti {
        let c = k * &self.s_xi;
        let d = k * &self.s_y;
        Lti::new(
            &self.a_xi + &self.b_xiu * &c,
            &self.b_xi + &self.b_xiu * &d,
            c,
            d,
        )
    }
}

/// The sensors `named` (plant outputs, each with its one-sided noise density) of `g`: `y = C x
/// + n`, `n` white, as unit white inputs appended to `w` (two-sided intensity `density²/2`).
/// Returns the plant and sensors with the extended `w`.
pub fn noisy_sensors(g: &ComfortPlant, named: &[(String, f64)]) -> (Plant, Sensors) {
    let (plant, base) = named_sensors(g, named.iter().map(|(n, _)| n.clone()).collect());
    let (n, nw, ny) = (plant.a.nrows(), plant.b_w.ncols(), base.c.nrows());
    let mut b_w = DMatrix::zeros(n, nw + ny);
    b_w.view_mut((0, 0), (n, nw)).copy_from(&plant.b_w);
    let mut d_w = DMatrix::zeros(ny, nw + ny);
    d_w.view_mut((0, 0), (ny, nw)).copy_from(&base.d_w);
    for (k, (_, density)) in named.iter().enumerate() {
        d_w[(k, nw + k)] = density / std::f64::consts::SQRT_2;
    }
    (Plant { b_w, ..plant }, Sensors { d_w, ..base })
}

/// The Kalman filter gain `L` of `plant` from `sensors` (noise in their `D_w`), with
/// `fictitious` extra process noise `B_f B_fᵀ` (a robustness device: the filter then trusts its
/// model less where the model is uncertain).
pub fn kalman_gain(
    plant: &Plant,
    sensors: &Sensors,
    fictitious: Option<&DMatrix<f64>>,
) -> Result<DMatrix<f64>, RiccatiError> {
    let mut w = &plant.b_w * plant.b_w.transpose();
    if let Some(bf) = fictitious {
        w += bf * bf.transpose();
    }
    let v = &sensors.d_w * sensors.d_w.transpose();
    let s = &plant.b_w * sensors.d_w.transpose();
    let r = care(
        &plant.a.transpose(),
        &sensors.c.transpose(),
        &w,
        &v,
        Some(&s),
    )?;
    Ok(r.k.transpose())
}

/// The rows of the delay weight's states `ẋ_d = A_d x_d + B_d u`, `u = K_p x̂ + K_d x_d`, in an
/// observer-based controller's `A` (state `[x̂; x_d]`).
fn delay_weight_rows(g: &ComfortPlant, kp: &DMatrix<f64>, kd: &DMatrix<f64>, a: &mut DMatrix<f64>) {
    let (n, nd) = (kp.ncols(), kd.ncols());
    if nd > 0 {
        let ad = g.a.view((n, n), (nd, nd)).into_owned();
        let bd = g.b_u.rows(n, nd).into_owned();
        a.view_mut((n, 0), (nd, n)).copy_from(&(&bd * kp));
        a.view_mut((n, n), (nd, nd)).copy_from(&(ad + &bd * kd));
    }
}

/// What drives an observer's model of the actuators.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ObserverInput {
    /// Its own command `u`: inputs `y`.
    Command,
    /// The forces the actuators apply, measured (`f_*`): inputs `[y; f]`. The estimation error
    /// `ẋ − x̂̇ = (A − L C)(x − x̂)` then does not depend on what happens between command and
    /// force — delay, saturation, a loss of effectiveness — so the loop at effectiveness `ρ` is
    /// stable exactly when `A + B_u diag(ρ) K` and `A − L C` are (separation for every `ρ`).
    MeasuredForce,
}

/// The observer-based controller: `x̂̇ = A x̂ + B_u v + L (y − C x̂ − D_u v)` with `v` the
/// command `u` or the measured applied force `f` ([`ObserverInput`]; `sensors` are the `y` only,
/// whose `D_u` is zero for the command-driven one), the delay weight `ẋ_d = A_d x_d + B_d u`
/// (`g` holds it), `u = K [x̂; x_d]` with `K` a gain on `g`'s state.
pub fn observer_based(
    g: &ComfortPlant,
    k: &DMatrix<f64>,
    sensors: &Sensors,
    l: &DMatrix<f64>,
    input: ObserverInput,
) -> Lti {
    observer_of(&plant_of(g), g, k, sensors, l, input)
}

/// [`observer_based`] observing `plant`, the controller's own states those of `g` after
/// `plant`'s (the delay weight; behind lagging actuators the forces too,
/// [`ComfortPlant::with_actuator_lag`]), driven by the command alone; `k` a gain on
/// `[x; own states]`. Driven by its command ([`ObserverInput::Command`]) the observer takes it
/// for `plant`'s input, which behind lagging actuators it is not: measure the forces there.
pub fn observer_of(
    plant: &Plant,
    g: &ComfortPlant,
    k: &DMatrix<f64>,
    sensors: &Sensors,
    l: &DMatrix<f64>,
    input: ObserverInput,
) -> Lti {
    let n = plant.a.nrows();
    let nd = g.n() - n;
    let (kp, kd) = (k.columns(0, n).into_owned(), k.columns(n, nd).into_owned());
    let ny = sensors.c.nrows();
    let nv = match input {
        ObserverInput::Command => 0,
        ObserverInput::MeasuredForce => plant.b_u.ncols(),
    };
    let mut a = DMatrix::zeros(n + nd, n + nd);
    match input {
        ObserverInput::Command => {
            a.view_mut((0, 0), (n, n))
                .copy_from(&(&plant.a - l * &sensors.c + &plant.b_u * &kp));
            a.view_mut((0, n), (n, nd)).copy_from(&(&plant.b_u * &kd));
        }
        ObserverInput::MeasuredForce => a
            .view_mut((0, 0), (n, n))
            .copy_from(&(&plant.a - l * &sensors.c)),
    }
    delay_weight_rows(g, &kp, &kd, &mut a);
    let mut b = DMatrix::zeros(n + nd, ny + nv);
    b.view_mut((0, 0), (n, ny)).copy_from(l);
    if nv > 0 {
        b.view_mut((0, ny), (n, nv))
            .copy_from(&(&plant.b_u - l * &sensors.d_u));
    }
    Lti::new(a, b, k.clone(), DMatrix::zeros(k.nrows(), ny + nv))
}

/// The names of the actuators' applied forces, the plant outputs `f_*`.
pub fn applied_force_names() -> Vec<String> {
    vehicle::model::applied_force_rows()
        .into_iter()
        .map(|r| r.name)
        .collect()
}

/// `(plant, sensors)` of `g` followed by the actuators' applied forces `f_*` (noise-free: a
/// load cell's noise is far below the road's forces), which [`observer_based`] with
/// [`ObserverInput::MeasuredForce`] takes as its input.
pub fn with_load_cells(g: &ComfortPlant, (plant, base): (Plant, Sensors)) -> (Plant, Sensors) {
    let forces = sensors(g, applied_force_names());
    let (ny, nf, nw) = (base.c.nrows(), forces.c.nrows(), base.d_w.ncols());
    let stack = |top: &DMatrix<f64>, bottom: &DMatrix<f64>| {
        let mut m = DMatrix::zeros(ny + nf, top.ncols());
        m.rows_mut(0, ny).copy_from(top);
        m.view_mut((ny, 0), (nf, bottom.ncols())).copy_from(bottom);
        m
    };
    let mut d_w_forces = DMatrix::zeros(nf, nw);
    d_w_forces
        .columns_mut(0, forces.d_w.ncols())
        .copy_from(&forces.d_w);
    let sensors = Sensors {
        c: stack(&base.c, &forces.c),
        d_w: stack(&base.d_w, &d_w_forces),
        d_u: stack(&base.d_u, &forces.d_u),
        names: base.names.iter().chain(&forces.names).cloned().collect(),
    };
    (plant, sensors)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::comfort::guaranteed::state_feedback;
    use crate::numerics::hinf_norm::Analysis;
    use crate::numerics::interconnect::close;
    use crate::shipping::design::ComfortDesign;
    use vehicle::VehicleParams;

    fn design() -> ComfortDesign {
        ComfortDesign::from_json(include_str!("../../designs/comfort.json")).unwrap()
    }

    /// The realised state feedback, reading plant outputs, closes the same loop as `A + B_u K` on
    /// the design state: the same comfort covariance (its own copies track the plant's states).
    #[test]
    fn realised_state_feedback_closes_the_design_loop() {
        let d = design();
        let p = VehicleParams::default();
        let g0 = ComfortPlant::new(&p, &d);
        let limits = [d.u_max, d.u_max, d.u_max, d.u_max, d.u_max_seat];
        let (g, delay) = g0.with_delay_weight(d.unmodelled_delay, &limits);
        let t = std::time::Instant::now();
        let sf = state_feedback(&g, &[delay], d.limit_sigmas).unwrap();
        eprintln!(
            "synthesis {:?}, multipliers {:?}",
            t.elapsed(),
            sf.multipliers
        );
        let direct = Lti::new(
            &g.a + &g.b_u * &sf.k,
            g.b_w.clone(),
            g.c_z.clone(),
            DMatrix::zeros(3, 2),
        );
        let k = realise_state_feedback(&g, &sf.k);
        let cl = close(&plant_of(&g), &state_feedback_sensors(&g0), &k).unwrap();
        let n = plant_of(&g).a.nrows();
        let realised = cl.from_w(&g0.c_z, &DMatrix::zeros(3, 2), &DMatrix::zeros(3, 5));
        let (a, b) = (direct.h2_norm().unwrap(), realised.h2_norm().unwrap());
        let seat = realised.select_outputs(&[0]).h2_norm().unwrap();
        eprintln!(
            "a_v direct {a:.5}, realised {b:.5}, seat {seat:.5}; controller order {}",
            k.order()
        );
        // Equal up to the Lyapunov solutions' rounding on the 59-state loop (a few 1e-6).
        assert!((a - b).abs() <= 1e-5 * a, "direct {a}, realised {b}");
        assert_eq!(cl.plant_order, n);
    }
}
