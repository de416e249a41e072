//! The plant without FMI: the car of the `vehicle` crate driven through its actuators, stepped
//! exactly (SPEC §2).
//!
//! Actuator chain, per actuator `i` (corners, then seat):
//! `command u_i(t)` → transport delay `τ` → saturation at `±u_max` (`u_max_seat` for the seat)
//! → effectiveness `ρ_i(t)` (`1` before `fault_time`, `1 − fault_loss_i` after; thesis fig. 8.2)
//! → optional first-order lag of bandwidth `f_a` (`ḟ = 2π f_a (v − f)`) → force on the car.
//! Before the start time the command is taken as zero: the car starts at rest in static
//! equilibrium and no actuator has pushed yet.
//!
//! Every input is piecewise linear in time (held, or ramped when the importer gives input
//! derivatives), so the actuator output `v(t)` is piecewise linear too, with breakpoints where
//! a delayed command segment starts, where the fault starts and where a ramp crosses the force
//! limit. The step is cut at those breakpoints and each piece is integrated with the exact
//! triangle-hold discretisation of [`linsys`]; nothing is approximated.
//!
//! The car is the physical one by default ([`ContactParams`]): a tyre leaves the road, a
//! suspension or the seat hits its stop. Between those events it is linear (and affine: a
//! tyre in the air no longer carries its static load), so each piece is still stepped exactly,
//! in the matrices of its [`Mode`]; an event inside a piece is located on that exact
//! trajectory by bisection to [`EVENT_TOLERANCE`] and the piece continues in the new mode
//! from there. The guards are read at the end of each piece: a contact that opens and closes
//! again within one piece (shorter than a communication step) is not seen.
//!
//! The seat's vibration meter ([`vehicle::iso2631::ComfortMeter`]) is part of the linear
//! system: the ISO 2631-1 weighted accelerations are states, stepped exactly with the car.

mod exchange;
pub use exchange::{derivative_dependencies, model_exchange_states, LinearResponse, HYSTERESIS};

use linsys::{discretize, mat_vec_sum, Discretization, ExpError};
use nalgebra::{DMatrix, DVector};
use std::collections::VecDeque;
use vehicle::contact::{self, Contact, ContactParams, Contacts, Mode, Unilateral, N_UNILATERAL};
use vehicle::iso2631::{ComfortMeter, METER_OUTPUTS};
use vehicle::model::{
    physical_outputs_with_accelerations, StateSpace, StaticEquilibrium, N_ACTUATORS, N_DOF, N_ROAD,
    N_STATES, N_WHEELS,
};
use vehicle::VehicleParams;

/// Number of inputs of the linear part: road heights and velocities, then actuator outputs.
const N_INPUTS: usize = N_ROAD + N_ACTUATORS;
/// How many step sizes keep their discretisation.
const CACHE_SIZE: usize = 16;
/// How precisely an event (a contact opening or closing) is located in time \[s\].
pub const EVENT_TOLERANCE: f64 = 1e-13;
/// More events than this within one communication step is an error (a contact that chatters).
pub const MAX_EVENTS_PER_STEP: usize = 10_000;

/// Actuator model parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ActuatorParams {
    /// Force limit of each corner actuator \[N\].
    pub u_max: f64,
    /// Force limit of the seat actuator \[N\].
    pub u_max_seat: f64,
    /// Input transport delay \[s\].
    pub tau: f64,
    /// Bandwidth of the first-order actuator lag \[Hz\]; 0 = ideal actuator.
    pub bandwidth: f64,
    /// Time at which the fault starts \[s\].
    pub fault_time: f64,
    /// Loss of effectiveness after the fault, per actuator (FL, FR, RL, RR, seat) \[1\].
    pub fault_loss: [f64; N_ACTUATORS],
}

impl Default for ActuatorParams {
    fn default() -> Self {
        ActuatorParams {
            u_max: 2500.0,
            u_max_seat: 1000.0,
            tau: 0.0,
            bandwidth: 0.0,
            fault_time: 2.0,
            fault_loss: [0.0; N_ACTUATORS],
        }
    }
}

impl ActuatorParams {
    fn limit(&self, i: usize) -> f64 {
        if i < 4 {
            self.u_max
        } else {
            self.u_max_seat
        }
    }

    fn effectiveness(&self, i: usize, t: f64) -> f64 {
        if t >= self.fault_time {
            1.0 - self.fault_loss[i]
        } else {
            1.0
        }
    }
}

/// A command held or ramped from `start` on: `value + slope (t − start)`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Segment {
    start: f64,
    value: [f64; N_ACTUATORS],
    slope: [f64; N_ACTUATORS],
}

impl Segment {
    const ZERO: Segment = Segment {
        start: f64::NEG_INFINITY,
        value: [0.0; N_ACTUATORS],
        slope: [0.0; N_ACTUATORS],
    };

    fn at(&self, i: usize, t: f64) -> f64 {
        if self.slope[i] == 0.0 {
            self.value[i]
        } else {
            self.value[i] + self.slope[i] * (t - self.start)
        }
    }
}

/// How far apart two times near `now` computed along different paths (the master's `k h`, a
/// delayed command's start `j h + τ`) can be and still be the same instant: 64 ulps of the
/// larger of `now` and the delay `τ`.
fn rounding(now: f64, tau: f64) -> f64 {
    64.0 * f64::EPSILON * now.abs().max(tau)
}

/// Number of weighted comfort outputs.
pub const N_METER: usize = METER_OUTPUTS.len();

/// Number of states before the vibration meter's: the car's 16, and 5 actuator-lag states
/// with a finite bandwidth.
fn car_states(act: &ActuatorParams) -> usize {
    let lag = if act.bandwidth > 0.0 { N_ACTUATORS } else { 0 };
    N_STATES + lag
}

/// Number of states for the actuator parameters: [`car_states`], then the meter's.
fn state_count(act: &ActuatorParams) -> usize {
    car_states(act) + ComfortMeter::order()
}

/// A step's exact discretisation in two row blocks. The car (with its actuator lags) from its
/// own exponential: the meter does not drive it, so it steps exactly as a plant without a meter
/// would, bit for bit, at the cost it had. The meter's rows from the whole system's exponential
/// (they read the car's state and the inputs).
struct StepMatrices {
    car: Discretization,
    meter: Discretization,
}

/// Rows of a matrix with few non-zeros (the physical outputs: strokes, velocities, tyre loads;
/// the meter's outputs, each reading its own weighting's states): row `i` is
/// `terms[start[i]..start[i + 1]]`, (column, coefficient) in column order. Several times
/// cheaper than the dense product; each row sums its non-zero products in the dense order, so
/// the value is the dense product's (up to the sign of an exact zero).
struct SparseRows {
    terms: Vec<(usize, f64)>,
    start: Vec<usize>,
}

impl SparseRows {
    fn new(rows: impl Iterator<Item = Vec<f64>>) -> Self {
        let (mut terms, mut start) = (Vec::new(), vec![0]);
        for row in rows {
            terms.extend(row.into_iter().enumerate().filter(|(_, v)| *v != 0.0));
            start.push(terms.len());
        }
        SparseRows { terms, start }
    }

    /// `out = M z`.
    fn apply(&self, z: &[f64], out: &mut [f64]) {
        for (y, range) in out.iter_mut().zip(self.start.windows(2)) {
            *y = self.terms[range[0]..range[1]]
                .iter()
                .fold(0.0, |acc, &(k, v)| acc + v * z[k]);
        }
    }
}

/// Matrices derived from the parameters.
struct System {
    /// State dimension: `[x (16); f_lag (5, with a finite bandwidth); meter]`.
    n: usize,
    /// Whether the applied forces are the lag states.
    lag: bool,
    /// Where the meter's states start, and its weighted outputs `c w` over them.
    meter_at: usize,
    meter_c: SparseRows,
    a: DMatrix<f64>,
    b: DMatrix<f64>,
    /// Physical outputs `y = C x + D_r r + D_u f` over `[x; r; f]`.
    outputs: SparseRows,
    /// Static deflections and loads under gravity.
    statics: StaticEquilibrium,
    cache: VecDeque<StepMatrices>,
    /// The unilateral elements (tyres, stops), and how each physical output moves per newton
    /// of each one's force (`n_outputs × N_UNILATERAL`).
    contacts: Contacts,
    output_per_contact: DMatrix<f64>,
    /// How each meter signal moves per newton of each contact's force (`3 × N_UNILATERAL`).
    meter_per_contact: DMatrix<f64>,
    meter_gain: DMatrix<f64>,
    /// The modes met so far other than the linear car's, each with its matrices.
    modes: Vec<ModeSystem>,
}

/// The plant in a mode other than the linear car's: `ẋ = A x + B [v; 1]` (the constant input
/// carries the static preload a free tyre no longer holds, or a stop's free travel).
struct ModeSystem {
    mode: Mode,
    a: DMatrix<f64>,
    b: DMatrix<f64>,
    cache: VecDeque<StepMatrices>,
}

/// Split discretisation of `(a, b)` over `h`: the car's first `nc` rows from their own
/// exponential, the meter's from the whole system's (see [`StepMatrices`]).
fn split_discretization(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    nc: usize,
    h: f64,
) -> Result<StepMatrices, ExpError> {
    let n = a.nrows();
    let car = discretize(
        &a.view((0, 0), (nc, nc)).into_owned(),
        &b.rows(0, nc).into_owned(),
        h,
    )?;
    let whole = discretize(a, b, h)?;
    let rows = |m: &DMatrix<f64>| m.rows(nc, n - nc).into_owned();
    let meter = Discretization {
        step: h,
        phi: rows(&whole.phi),
        gamma_hold: rows(&whole.gamma_hold),
        gamma_ramp: rows(&whole.gamma_ramp),
    };
    Ok(StepMatrices { car, meter })
}

/// The cached discretisation of step `h`, or a new one pushed into `cache`.
fn cached(
    cache: &mut VecDeque<StepMatrices>,
    h: f64,
    make: impl FnOnce() -> Result<StepMatrices, ExpError>,
) -> Result<&StepMatrices, ExpError> {
    if let Some(pos) = cache
        .iter()
        .position(|d| d.car.step.to_bits() == h.to_bits())
    {
        return Ok(&cache[pos]);
    }
    let d = make()?;
    if cache.len() == CACHE_SIZE {
        cache.pop_front();
    }
    cache.push_back(d);
    Ok(cache.back().unwrap())
}

/// The first `rows` states after `s` of `ẋ = A x + B v`, `v` going from `w` by `dw` over `s`
/// (with `B`'s constant input, if it has one, held at 1), from `x`. The inputs enter as two
/// columns, `B w` held and `B dw` ramped, so the exponential is of order `rows + 4` instead of
/// `rows + 2 m`: what an event's piece, met once, costs.
#[allow(clippy::too_many_arguments)]
fn response(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    rows: usize,
    x: &[f64],
    w: &[f64],
    dw: &[f64],
    s: f64,
) -> Result<DVector<f64>, ExpError> {
    let mut columns = DMatrix::zeros(rows, 2);
    for j in 0..b.ncols() {
        let (held, ramped) = match j {
            j if j < N_INPUTS => (w[j], dw[j]),
            _ => (1.0, 0.0),
        };
        for i in 0..rows {
            columns[(i, 0)] += b[(i, j)] * held;
            columns[(i, 1)] += b[(i, j)] * ramped;
        }
    }
    let d = discretize(&a.view((0, 0), (rows, rows)).into_owned(), &columns, s)?;
    let mut y = DVector::zeros(rows);
    let (unit, none) = ([1.0, 0.0], [0.0, 1.0]);
    mat_vec_sum(
        y.as_mut_slice(),
        &[
            (&d.phi, &x[..rows]),
            (&d.gamma_hold, &unit),
            (&d.gamma_ramp, &none),
        ],
    );
    Ok(y)
}

/// `y = Φ x + Γ₀ w + Γ₁ dw` for both row blocks (the ramp term only when the inputs move).
fn apply(d: &StepMatrices, x: &[f64], w: &[f64], dw: &[f64], ramp: bool, y: &mut [f64]) {
    let (car, meter) = y.split_at_mut(d.car.phi.nrows());
    for (y, d, x) in [(car, &d.car, &x[..d.car.phi.ncols()]), (meter, &d.meter, x)] {
        if ramp {
            mat_vec_sum(y, &[(&d.phi, x), (&d.gamma_hold, w), (&d.gamma_ramp, dw)]);
        } else {
            mat_vec_sum(y, &[(&d.phi, x), (&d.gamma_hold, w)]);
        }
    }
}

/// Time spent off the road and at a stop, per corner (and the seat for the stops) \[s\].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Dwell {
    pub airborne: [f64; N_WHEELS],
    pub at_stop: [f64; N_WHEELS + 1],
}

impl Dwell {
    fn add(&mut self, mode: Mode, dt: f64) {
        if mode == Mode::LINEAR {
            // Every tyre on the road, no stop touched: nothing to count.
            return;
        }
        for (k, element) in Unilateral::ALL.iter().enumerate() {
            let engaged = mode.engaged(k);
            match *element {
                Unilateral::Tyre(i) if !engaged => self.airborne[i] += dt,
                Unilateral::Bump(i) | Unilateral::Rebound(i) if engaged => self.at_stop[i] += dt,
                Unilateral::SeatBump | Unilateral::SeatRebound if engaged => {
                    self.at_stop[N_WHEELS] += dt
                }
                _ => {}
            }
        }
    }
}

/// What the contacts do now: each a corner's, then the seat's.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ContactState {
    /// Whether each tyre is on the road.
    pub on_road: [bool; N_WHEELS],
    /// Each tyre's whole load on the road (static part included; 0 in the air) \[N\].
    pub tyre_force: [f64; N_WHEELS],
    /// Each corner's and the seat's stop force: positive pushing back in bump, negative in
    /// rebound, 0 between the stops \[N\].
    pub stop_force: [f64; N_WHEELS + 1],
    pub dwell: Dwell,
}

impl ContactState {
    /// The contacts in `mode`, each engaged element pushing with `force(k)` (`k` its index in
    /// [`Unilateral::ALL`]), with the times `dwell`.
    fn in_mode(mode: Mode, dwell: Dwell, force: impl Fn(usize) -> f64) -> Self {
        let mut state = ContactState {
            on_road: [true; N_WHEELS],
            tyre_force: [0.0; N_WHEELS],
            stop_force: [0.0; N_WHEELS + 1],
            dwell,
        };
        for (k, element) in Unilateral::ALL.iter().enumerate() {
            if !mode.engaged(k) {
                if let Unilateral::Tyre(i) = *element {
                    state.on_road[i] = false;
                }
                continue;
            }
            let force = force(k);
            match *element {
                Unilateral::Tyre(i) => state.tyre_force[i] = force,
                Unilateral::Bump(i) => state.stop_force[i] += force,
                Unilateral::Rebound(i) => state.stop_force[i] -= force,
                Unilateral::SeatBump => state.stop_force[N_WHEELS] += force,
                Unilateral::SeatRebound => state.stop_force[N_WHEELS] -= force,
            }
        }
        state
    }
}

impl System {
    fn new(p: &VehicleParams, act: &ActuatorParams, contact: &ContactParams) -> Self {
        let ss = StateSpace::new(p);
        let lag = act.bandwidth > 0.0;
        let (n, meter_at) = (state_count(act), car_states(act));
        let mut a = DMatrix::zeros(n, n);
        let mut b = DMatrix::zeros(n, N_INPUTS);
        // The forces: the lag states, or the actuator outputs themselves.
        let forces = ss.place(&mut a, &mut b, lag.then_some((N_STATES, act.bandwidth)));
        let weighted = physical_outputs_with_accelerations(p);
        let outputs: Vec<_> = weighted.iter().map(|(row, _)| row.clone()).collect();
        let meter = ComfortMeter::new(&outputs);
        meter.place(&mut a, &mut b, meter_at, forces);
        let contacts = contact::contacts(p, contact);
        // An output moves by its accelerations' share of a contact's force, and a tyre's load
        // by the whole correction of its force.
        let per_newton = |w: &[f64; N_DOF], c: &Contact| -> f64 {
            (0..N_DOF).map(|j| w[j] * c.acceleration[N_DOF + j]).sum()
        };
        let output_per_contact = DMatrix::from_fn(outputs.len(), N_UNILATERAL, |o, k| {
            let c = &contacts.elements[k];
            let load = match c.kind {
                Unilateral::Tyre(i) => {
                    outputs[o].name == format!("tire_load_{}", vehicle::model::CORNERS[i])
                }
                _ => false,
            };
            per_newton(&weighted[o].1, c) + if load { 1.0 } else { 0.0 }
        });
        let meter_per_contact = DMatrix::from_fn(METER_OUTPUTS.len(), N_UNILATERAL, |l, k| {
            let signal = METER_OUTPUTS[l].1;
            let (_, w) = weighted
                .iter()
                .find(|(row, _)| row.name == signal)
                .expect("the meter weights outputs of the car");
            per_newton(w, &contacts.elements[k])
        });
        System {
            n,
            lag,
            meter_at,
            meter_c: SparseRows::new(meter.c.row_iter().map(|r| r.iter().copied().collect())),
            a,
            b,
            outputs: SparseRows::new(outputs.iter().map(|r| r.coefficients().copied().collect())),
            statics: StaticEquilibrium::new(p),
            cache: VecDeque::with_capacity(CACHE_SIZE),
            contacts,
            output_per_contact,
            meter_per_contact,
            meter_gain: meter.gain,
            modes: Vec::new(),
        }
    }

    /// The matrices of `mode` (not the linear car's), built at its first use.
    fn mode_system(&mut self, mode: Mode) -> &mut ModeSystem {
        if let Some(k) = self.modes.iter().position(|m| m.mode == mode) {
            return &mut self.modes[k];
        }
        let mut a = self.a.clone();
        let mut b = DMatrix::zeros(self.n, N_INPUTS + 1);
        b.columns_mut(0, N_INPUTS).copy_from(&self.b);
        let meter_n = self.n - self.meter_at;
        for (k, sign) in contact::corrections(mode) {
            let c = &self.contacts.elements[k];
            // ẋ gains sign · F · (c.acceleration on the car's rows; the meter's signals' share
            // through its filters' gains on the meter's rows), F = c.force · [x; r] + offset.
            let mut column = DVector::zeros(self.n);
            for i in 0..N_STATES {
                column[i] = sign * c.acceleration[i];
            }
            let meter_rows = &self.meter_gain * self.meter_per_contact.column(k) * sign;
            column
                .rows_mut(self.meter_at, meter_n)
                .copy_from(&meter_rows);
            for j in 0..N_STATES {
                if c.force[j] != 0.0 {
                    a.column_mut(j).axpy(c.force[j], &column, 1.0);
                }
            }
            for j in 0..N_ROAD {
                if c.force[N_STATES + j] != 0.0 {
                    b.column_mut(j).axpy(c.force[N_STATES + j], &column, 1.0);
                }
            }
            b.column_mut(N_INPUTS).axpy(c.force_offset, &column, 1.0);
        }
        self.modes.push(ModeSystem {
            mode,
            a,
            b,
            cache: VecDeque::with_capacity(CACHE_SIZE),
        });
        self.modes.last_mut().unwrap()
    }

    /// `(A, B)` of `mode`: the linear car's, or the mode's with its constant input last.
    fn matrices(&mut self, mode: Mode) -> (&DMatrix<f64>, &DMatrix<f64>) {
        if mode == Mode::LINEAR {
            (&self.a, &self.b)
        } else {
            let ms = self.mode_system(mode);
            (&ms.a, &ms.b)
        }
    }

    /// Advance `x` by `h` in `mode` with inputs `w` changing by `dw` over the step, into `y`.
    /// `keep`: a whole communication step, whose discretisation is cached and split as
    /// [`StepMatrices`] says; otherwise a piece cut at an event, of a length met once, stepped
    /// in one exponential of the whole system with the inputs folded into two columns
    /// ([`response`]).
    #[allow(clippy::too_many_arguments)]
    fn propagate(
        &mut self,
        mode: Mode,
        h: f64,
        keep: bool,
        x: &[f64],
        w: &[f64],
        dw: &[f64],
        y: &mut [f64],
    ) -> Result<(), ExpError> {
        if !keep {
            let n = self.n;
            let (a, b) = self.matrices(mode);
            let next = response(a, b, n, x, w, dw, h)?;
            y.copy_from_slice(next.as_slice());
            return Ok(());
        }
        let ramp = dw.iter().any(|&v| v != 0.0);
        let nc = self.meter_at;
        if mode == Mode::LINEAR {
            let d = self.discretization(h)?;
            apply(d, x, w, dw, ramp, y);
            return Ok(());
        }
        let mut we = [0.0; N_INPUTS + 1];
        let mut dwe = [0.0; N_INPUTS + 1];
        we[..N_INPUTS].copy_from_slice(w);
        we[N_INPUTS] = 1.0;
        dwe[..N_INPUTS].copy_from_slice(dw);
        let ms = self.mode_system(mode);
        let (a, b) = (&ms.a, &ms.b);
        let d = cached(&mut ms.cache, h, || split_discretization(a, b, nc, h))?;
        apply(d, x, &we, &dwe, ramp, y);
        Ok(())
    }

    /// The car's state (its first 16 states) after `s` in `mode` from `x` with inputs `w`
    /// changing by `dw · s / h` (the piece's inputs, `h` long, cut at `s`).
    #[allow(clippy::too_many_arguments)]
    fn car_at(
        &mut self,
        mode: Mode,
        s: f64,
        h: f64,
        x: &[f64],
        w: &[f64],
        dw: &[f64],
    ) -> Result<[f64; N_STATES], ExpError> {
        let nc = self.meter_at;
        let (a, b) = self.matrices(mode);
        let cut: [f64; N_INPUTS] = std::array::from_fn(|j| dw[j] * (s / h));
        let y = response(a, b, nc, x, w, &cut, s)?;
        Ok(std::array::from_fn(|i| y[i]))
    }

    /// The first time in `(0, h]` at which a contact switches, within [`EVENT_TOLERANCE`]
    /// after it, and the mode there; `(0, mode)` when one is already past zero at the start
    /// (rounding). On the exact trajectory: the earliest zero of `φ(s)`, the least of the
    /// guards of the elements found switched at `h` (each signed so that it falls through zero
    /// where its element switches), by regula falsi with the Illinois modification, a
    /// bisection whenever the bracket fails to halve.
    #[allow(clippy::too_many_arguments)]
    fn locate(
        &mut self,
        mode: Mode,
        h: f64,
        x: &[f64],
        w: &[f64],
        dw: &[f64],
        at_end: Mode,
    ) -> Result<(f64, Mode), ExpError> {
        let switching: Vec<(usize, f64)> = (0..N_UNILATERAL)
            .filter(|&k| at_end.engaged(k) != mode.engaged(k))
            .map(|k| (k, if mode.engaged(k) { 1.0 } else { -1.0 }))
            .collect();
        let road = |s: f64| -> [f64; N_ROAD] { std::array::from_fn(|j| w[j] + dw[j] * (s / h)) };
        let phi = |contacts: &Contacts, z: &contact::Point| -> f64 {
            switching
                .iter()
                .map(|&(k, sign)| sign * contacts.guard(k, z))
                .fold(f64::INFINITY, f64::min)
        };
        let z0 = contact::point(x, &road(0.0));
        let f0 = phi(&self.contacts, &z0);
        if f0 < 0.0 {
            return Ok((0.0, self.contacts.reconcile(mode, &z0)));
        }
        let (mut lo, mut hi, mut flo, mut fhi) = (0.0, h, f0, -1.0);
        let mut hi_mode = at_end;
        // Until the first evaluation inside the piece, the value at h is not the guard's
        // (the end state came from another discretisation): bisect first.
        let (mut side, mut width, mut bisect) = (0, h, true);
        while hi - lo > EVENT_TOLERANCE {
            let secant = lo + (hi - lo) * flo / (flo - fhi);
            let mid = if bisect || !(secant > lo && secant < hi) {
                0.5 * (lo + hi)
            } else {
                secant
            };
            if mid <= lo || mid >= hi {
                break;
            }
            let car = self.car_at(mode, mid, h, x, w, dw)?;
            let z = contact::point(&car, &road(mid));
            let f = phi(&self.contacts, &z);
            if f < 0.0 {
                (hi, fhi) = (mid, f);
                hi_mode = self.contacts.reconcile(mode, &z);
                if side == -1 {
                    flo *= 0.5;
                }
                side = -1;
            } else {
                (lo, flo) = (mid, f);
                if side == 1 {
                    fhi *= 0.5;
                }
                side = 1;
            }
            // Every other evaluation must have halved the bracket; if not, bisect.
            bisect = !bisect && hi - lo > 0.5 * width;
            if !bisect {
                width = hi - lo;
            }
        }
        Ok((hi, hi_mode))
    }

    /// The discretisation for step `h`, from the cache or computed (matrix exponentials).
    fn discretization(&mut self, h: f64) -> Result<&StepMatrices, ExpError> {
        let (a, b, nc) = (&self.a, &self.b, self.meter_at);
        cached(&mut self.cache, h, || split_discretization(a, b, nc, h))
    }
}

/// Advance `xi` over one piece of a step, `len` long, with inputs `wa` changing by `dw`: in one
/// go while no contact switches; else to each switch ([`System::locate`]), switching the mode
/// there, and on. On return `xi` holds the state at the piece's end (`next` is work space);
/// `wa`, `dw` may have been cut.
#[allow(clippy::too_many_arguments)]
fn advance_piece(
    sys: &mut System,
    physical: bool,
    mode: &mut Mode,
    dwell: &mut Dwell,
    len: f64,
    xi: &mut DVector<f64>,
    next: &mut DVector<f64>,
    wa: &mut DVector<f64>,
    dw: &mut DVector<f64>,
    events: &mut usize,
) -> Result<(), StepError> {
    let exponential = |step| move |error| StepError::Exponential { step, error };
    let (mut rest, mut whole) = (len, true);
    loop {
        sys.propagate(
            *mode,
            rest,
            whole,
            xi.as_slice(),
            wa.as_slice(),
            dw.as_slice(),
            next.as_mut_slice(),
        )
        .map_err(exponential(rest))?;
        let at_end = if physical {
            let road_end: [f64; N_ROAD] = std::array::from_fn(|j| wa[j] + dw[j]);
            sys.contacts
                .reconcile(*mode, &contact::point(next.as_slice(), &road_end))
        } else {
            *mode
        };
        if at_end == *mode {
            std::mem::swap(xi, next);
            dwell.add(*mode, rest);
            return Ok(());
        }
        *events += 1;
        if *events > MAX_EVENTS_PER_STEP {
            return Err(StepError::Chattering(MAX_EVENTS_PER_STEP));
        }
        let (s, switched) = sys
            .locate(
                *mode,
                rest,
                xi.as_slice(),
                wa.as_slice(),
                dw.as_slice(),
                at_end,
            )
            .map_err(exponential(rest))?;
        if s > 0.0 {
            // To the switch: the inputs' change cut at s.
            let cut: [f64; N_INPUTS] = std::array::from_fn(|j| dw[j] * (s / rest));
            sys.propagate(
                *mode,
                s,
                false,
                xi.as_slice(),
                wa.as_slice(),
                &cut,
                next.as_mut_slice(),
            )
            .map_err(exponential(s))?;
            std::mem::swap(xi, next);
            dwell.add(*mode, s);
            for j in 0..N_INPUTS {
                wa[j] += cut[j];
                dw[j] -= cut[j];
            }
        }
        *mode = switched;
        rest -= s;
        whole = false;
        if rest <= 0.0 {
            return Ok(());
        }
    }
}

/// The plant's complete dynamic state and inputs.
pub struct Simulator {
    pub params: VehicleParams,
    pub actuator: ActuatorParams,
    /// Road heights then velocities, as set at the last communication point.
    pub road: [f64; N_ROAD],
    pub road_slope: [f64; N_ROAD],
    /// Actuator commands (FL, FR, RL, RR, seat) \[N\].
    pub command: [f64; N_ACTUATORS],
    pub command_slope: [f64; N_ACTUATORS],
    /// Tyre contact and stops (the physical car), or the linear car.
    pub contact: ContactParams,
    /// Which tyres touch the road and which stops are engaged, and for how long so far.
    mode: Mode,
    dwell: Dwell,
    /// `[x; f_lag]` (the lag states only with a finite bandwidth).
    xi: DVector<f64>,
    history: VecDeque<Segment>,
    time: f64,
    system: Option<System>,
    breaks: Vec<f64>,
    /// Work vectors of a step (a step allocates nothing): the state being advanced and the
    /// next, the inputs at a piece's start and their change over it.
    work: [DVector<f64>; 2],
    wa: DVector<f64>,
    dw: DVector<f64>,
}

/// Why a step could not be taken.
#[derive(Debug, Clone, PartialEq)]
pub enum StepError {
    NonFinite(f64),
    /// More contact events in one step than [`MAX_EVENTS_PER_STEP`].
    Chattering(usize),
    /// The step's matrix exponential was refused (a step far too long for the parameters).
    Exponential {
        step: f64,
        error: ExpError,
    },
}

impl std::fmt::Display for StepError {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        match self {
            StepError::NonFinite(t) => write!(
                f,
                "the state became non-finite at t = {t}; the step was discarded"
            ),
            StepError::Chattering(n) => write!(
                f,
                "more than {n} contact events (a tyre leaving or touching the road, a stop) \
                 within one step; the step was discarded"
            ),
            StepError::Exponential { step, error } => write!(
                f,
                "cannot discretise the car over {step} s: {error}; the step was discarded, \
                 take shorter ones"
            ),
        }
    }
}

impl Simulator {
    pub fn new(params: VehicleParams, actuator: ActuatorParams) -> Self {
        Simulator {
            params,
            actuator,
            road: [0.0; N_ROAD],
            road_slope: [0.0; N_ROAD],
            command: [0.0; N_ACTUATORS],
            command_slope: [0.0; N_ACTUATORS],
            contact: ContactParams::default(),
            mode: Mode::LINEAR,
            dwell: Dwell::default(),
            xi: DVector::zeros(state_count(&actuator)),
            history: VecDeque::new(),
            time: 0.0,
            system: None,
            breaks: Vec::with_capacity(16),
            work: [DVector::zeros(N_STATES), DVector::zeros(N_STATES)],
            wa: DVector::zeros(N_INPUTS),
            dw: DVector::zeros(N_INPUTS),
        }
    }

    /// Start at `t0` in static equilibrium (all dynamic states zero).
    pub fn start(&mut self, t0: f64) {
        self.time = t0;
        self.system = Some(System::new(&self.params, &self.actuator, &self.contact));
        self.xi = DVector::zeros(self.system.as_ref().unwrap().n);
        self.history.clear();
        self.mode = Mode::LINEAR;
        self.dwell = Dwell::default();
    }

    /// Parameters changed (before the start): rebuild the matrices before the next use, and
    /// size the state for them, so that a state saved now restores into an instance with the
    /// same parameters.
    pub fn invalidate(&mut self) {
        self.system = None;
        let n = state_count(&self.actuator);
        if self.xi.len() != n {
            self.xi = DVector::zeros(n);
        }
    }

    fn system(&mut self) -> &mut System {
        if self.system.is_none() {
            let sys = System::new(&self.params, &self.actuator, &self.contact);
            if self.xi.len() != sys.n {
                self.xi = DVector::zeros(sys.n);
            }
            self.system = Some(sys);
        }
        self.system.as_mut().unwrap()
    }

    pub fn time(&self) -> f64 {
        self.time
    }

    /// Static values under gravity for the current parameters (computed with the matrices).
    pub fn static_equilibrium(&mut self) -> &StaticEquilibrium {
        &self.system().statics
    }

    /// Take `other`'s derived matrices and cache (same parameters assumed by the caller).
    pub fn adopt_system(&mut self, other: &mut Simulator) {
        if self.system.is_none() {
            self.system = other.system.take();
        }
    }

    /// The 16 vehicle states.
    pub fn state(&self) -> &[f64] {
        &self.xi.as_slice()[..N_STATES]
    }

    /// The command segment in force at time `s` (zero before the first step).
    fn segment_at(&self, s: f64) -> Segment {
        self.history
            .iter()
            .rev()
            .find(|g| g.start <= s)
            .copied()
            .unwrap_or(Segment::ZERO)
    }

    /// Actuator output before the lag, from the command segment `seg`, at time `t`.
    fn actuator_output(&self, seg: &Segment, i: usize, t: f64, rho_time: f64) -> f64 {
        let lim = self.actuator.limit(i);
        self.actuator.effectiveness(i, rho_time) * seg.at(i, t - self.actuator.tau).clamp(-lim, lim)
    }

    /// The force each actuator applies now \[N\].
    pub fn applied_force(&mut self) -> [f64; N_ACTUATORS] {
        if self.system().lag {
            return std::array::from_fn(|i| self.xi[N_STATES + i]);
        }
        let now = self.time;
        let seg = self.segment_now();
        std::array::from_fn(|i| self.actuator_output(&seg, i, now, now))
    }

    /// The command segment the actuators act on now.
    fn segment_now(&self) -> Segment {
        let now = self.time;
        // With no delay the current (just set) command acts at once.
        if self.actuator.tau == 0.0 {
            Segment {
                start: now,
                value: self.command,
                slope: [0.0; N_ACTUATORS],
            }
        } else {
            // A delayed command takes over at its start + τ. With the delay a whole number of
            // communication steps (the common case) `now − τ` lands on a command's start up to
            // rounding (the master's `k h`, our `(k − 1) h + h`): within [`rounding`] the start
            // counts as reached, so an output reads the same command at every step instead of
            // the new one at some and the previous one at others.
            let tau = self.actuator.tau;
            self.segment_at(now - tau + rounding(now, tau))
        }
    }

    /// The vibration meter's weighted accelerations now, in the order of
    /// [`vehicle::iso2631::METER_OUTPUTS`] (states only: no input reaches them at once).
    pub fn meter(&mut self) -> [f64; N_METER] {
        self.system();
        let sys = self.system.as_ref().expect("built above");
        let mut out = [0.0; N_METER];
        sys.meter_c
            .apply(&self.xi.as_slice()[sys.meter_at..], &mut out);
        out
    }

    /// Physical outputs (the rows of [`vehicle::model::physical_outputs`]) now, the applied
    /// forces they were computed with, and the tyres' and stops' state: the mode is reconciled
    /// once for all of them.
    pub fn physical_outputs(&mut self, out: &mut [f64]) -> ([f64; N_ACTUATORS], ContactState) {
        let f = self.applied_force();
        let mut z = [0.0; N_STATES + N_ROAD + N_ACTUATORS];
        z[..N_STATES].copy_from_slice(self.state());
        z[N_STATES..N_STATES + N_ROAD].copy_from_slice(&self.road);
        z[N_STATES + N_ROAD..].copy_from_slice(&f);
        let at = contact::point(&z[..N_STATES], &self.road);
        let mode = self.mode_at(&at);
        let sys = self
            .system
            .as_ref()
            .expect("applied_force built the system");
        sys.outputs.apply(&z, out);
        if mode != Mode::LINEAR {
            for (k, sign) in contact::corrections(mode) {
                let force = sign * sys.contacts.force(k, &at);
                for (y, per) in out.iter_mut().zip(sys.output_per_contact.column(k).iter()) {
                    *y += per * force;
                }
            }
        }
        (f, self.contact_state_at(mode, &at))
    }

    /// The mode at the current state and inputs: the stored one, where the road has moved
    /// since (a held road jumps at every communication point) the tyres switched. The stops
    /// read the state alone, which is where the last step left it and checked it.
    fn mode_now(&mut self) -> Mode {
        let z = contact::point(self.state(), &self.road);
        self.mode_at(&z)
    }

    /// [`Self::mode_now`] at `z`, the current state and road as a [`contact::point`].
    fn mode_at(&mut self, z: &contact::Point) -> Mode {
        if !self.contact.physical {
            return Mode::LINEAR;
        }
        self.system();
        let sys = self.system.as_ref().expect("built above");
        sys.contacts.reconcile_tyres(self.mode, z)
    }

    /// For each physical output, whether a tyre leaving the road changes how the road enters it
    /// (its feed-through is then not fixed: a tyre's load reads the road only on the road).
    pub fn outputs_switched_by_tyres(&mut self) -> Vec<bool> {
        let sys = self.system();
        (0..sys.output_per_contact.nrows())
            .map(|o| {
                Unilateral::ALL.iter().enumerate().any(|(k, e)| {
                    matches!(e, Unilateral::Tyre(_)) && sys.output_per_contact[(o, k)] != 0.0
                })
            })
            .collect()
    }

    /// The tyres' and the stops' forces now, and the time spent off the road and at a stop.
    pub fn contact_state(&mut self) -> ContactState {
        let z = contact::point(self.state(), &self.road);
        let mode = self.mode_at(&z);
        self.contact_state_at(mode, &z)
    }

    /// [`Self::contact_state`] in `mode` at the point `z` ([`contact::point`]).
    fn contact_state_at(&self, mode: Mode, z: &contact::Point) -> ContactState {
        let sys = self.system.as_ref().expect("mode_now built the system");
        ContactState::in_mode(mode, self.dwell, |k| sys.contacts.force(k, z))
    }

    /// `h`, or the step of a discretisation already made that `h` from `t` is to the rounding
    /// of its time points ([`linsys::same_step`]): the step as an importer that keeps time in
    /// integer nanoseconds hands it over, a little different at each step.
    fn usual_step(&self, t: f64, h: f64) -> f64 {
        self.system
            .as_ref()
            .and_then(|s| {
                s.cache
                    .iter()
                    .map(|d| d.car.step)
                    .find(|&c| linsys::same_step(c, h, t))
            })
            .unwrap_or(h)
    }

    /// Advance from `t` by `h` with the current inputs and slopes. Afterwards the inputs hold
    /// their values at `t + h` and the slopes are zero. On error nothing changes.
    pub fn step(&mut self, t: f64, h: f64) -> Result<(), StepError> {
        self.system();
        let tau = self.actuator.tau;
        let end = t + h;
        self.history.push_back(Segment {
            start: t,
            value: self.command,
            slope: self.command_slope,
        });

        // Breakpoints: delayed segment starts, the fault, then limit crossings inside pieces.
        let mut breaks = std::mem::take(&mut self.breaks);
        breaks.clear();
        breaks.extend([t, end]);
        if tau > 0.0 {
            // A delayed start within [`rounding`] of the step's ends is at that end (as
            // `applied_force` reads it), not a piece a few ulps long: with the delay a whole
            // number of steps every start lands there.
            let near = rounding(end, tau);
            breaks.extend(
                self.history
                    .iter()
                    .map(|g| g.start + tau)
                    .filter(|&s| s > t + near && s < end - near),
            );
        }
        if self.actuator.fault_time > t && self.actuator.fault_time < end {
            breaks.push(self.actuator.fault_time);
        }
        breaks.sort_by(f64::total_cmp);
        let pieces = breaks.len() - 1;
        for k in 0..pieces {
            let (a, b) = (breaks[k], breaks[k + 1]);
            let seg = self.segment_at(0.5 * (a + b) - tau);
            for i in 0..N_ACTUATORS {
                if seg.slope[i] == 0.0 {
                    continue;
                }
                let lim = self.actuator.limit(i);
                for level in [-lim, lim] {
                    // seg.at(i, s − τ) = level
                    let s = seg.start + tau + (level - seg.value[i]) / seg.slope[i];
                    if s > a && s < b {
                        breaks.push(s);
                    }
                }
            }
        }
        if breaks.len() > pieces + 1 {
            breaks.sort_by(f64::total_cmp);
        }
        breaks.dedup();

        let whole = self.usual_step(t, h);
        let [mut xi, mut next] = std::mem::take(&mut self.work);
        if xi.len() != self.xi.len() {
            xi = DVector::zeros(self.xi.len());
            next = DVector::zeros(self.xi.len());
        }
        xi.copy_from(&self.xi);
        let (mut wa, mut dw) = (std::mem::take(&mut self.wa), std::mem::take(&mut self.dw));
        let mut failure = None;
        // The mode and the dwell times advance on copies: a failed step changes nothing.
        let physical = self.contact.physical;
        let mut mode = self.mode_now();
        let mut dwell = self.dwell;
        let mut events = 0;
        for k in 0..breaks.len() - 1 {
            let (a, b) = (breaks[k], breaks[k + 1]);
            // A step in one piece is `h` long, not `(t + h) − t`: that is `h` rounded to `t`'s
            // ulp, six values over 10 s at 1 kHz (a new one in some binades of `t`), each its
            // own pair of matrix exponentials (0.4 ms) for a change in the 13th digit. Likewise
            // an `h` that is such a difference (`usual_step`).
            let len = if breaks.len() == 2 { whole } else { b - a };
            let mid = 0.5 * (a + b);
            let seg = self.segment_at(mid - tau);
            for j in 0..N_ROAD {
                wa[j] = self.road[j] + self.road_slope[j] * (a - t);
                dw[j] = self.road_slope[j] * len;
            }
            for i in 0..N_ACTUATORS {
                let va = self.actuator_output(&seg, i, a, mid);
                let vb = self.actuator_output(&seg, i, b, mid);
                wa[N_ROAD + i] = va;
                dw[N_ROAD + i] = vb - va;
            }
            let sys = self.system.as_mut().unwrap();
            if let Err(e) = advance_piece(
                sys,
                physical,
                &mut mode,
                &mut dwell,
                len,
                &mut xi,
                &mut next,
                &mut wa,
                &mut dw,
                &mut events,
            ) {
                failure = Some(e);
                break;
            }
        }
        self.breaks = breaks;
        (self.wa, self.dw) = (wa, dw);
        if failure.is_none() && !xi.iter().all(|v| v.is_finite()) {
            failure = Some(StepError::NonFinite(end));
        }
        if failure.is_none() {
            std::mem::swap(&mut self.xi, &mut xi);
            self.mode = mode;
            self.dwell = dwell;
        }
        self.work = [xi, next];
        if let Some(e) = failure {
            self.history.pop_back();
            return Err(e);
        }

        self.time = end;
        for j in 0..N_ROAD {
            self.road[j] += self.road_slope[j] * h;
        }
        for i in 0..N_ACTUATORS {
            self.command[i] += self.command_slope[i] * h;
        }
        self.road_slope = [0.0; N_ROAD];
        self.command_slope = [0.0; N_ACTUATORS];
        // Forget segments that no future step can reach: the next step needs times ≥ end − τ.
        while self.history.len() > 1 && self.history[1].start <= end - tau {
            self.history.pop_front();
        }
        Ok(())
    }

    /// Everything needed to continue bit-identically, as numbers.
    pub fn save(&self) -> Vec<f64> {
        let mut v = Vec::with_capacity(64 + 11 * self.history.len());
        v.push(self.time);
        v.extend_from_slice(&self.road);
        v.extend_from_slice(&self.road_slope);
        v.extend_from_slice(&self.command);
        v.extend_from_slice(&self.command_slope);
        v.push(self.xi.len() as f64);
        v.extend(self.xi.iter());
        v.push(self.history.len() as f64);
        for g in &self.history {
            v.push(g.start);
            v.extend_from_slice(&g.value);
            v.extend_from_slice(&g.slope);
        }
        v.push(self.mode.0 as f64);
        v.extend_from_slice(&self.dwell.airborne);
        v.extend_from_slice(&self.dwell.at_stop);
        v
    }

    /// Restore what [`Simulator::save`] wrote, for the current parameters.
    pub fn restore(&mut self, v: &[f64]) -> Result<(), String> {
        let mut it = v.iter().copied();
        let mut next = || {
            it.next()
                .ok_or_else(|| "plant state is truncated".to_string())
        };
        let time = next()?;
        let mut arr = |n: usize| -> Result<Vec<f64>, String> { (0..n).map(|_| next()).collect() };
        let road = arr(N_ROAD)?;
        let road_slope = arr(N_ROAD)?;
        let command = arr(N_ACTUATORS)?;
        let command_slope = arr(N_ACTUATORS)?;
        let n = arr(1)?[0];
        let expected = state_count(&self.actuator);
        if n != expected as f64 {
            return Err(format!(
                "plant state has {n} states, the parameters need {expected}"
            ));
        }
        let xi = arr(expected)?;
        let count = arr(1)?[0];
        if !(count >= 0.0 && count.fract() == 0.0 && count * 11.0 <= v.len() as f64) {
            return Err(format!("plant state has an invalid history length {count}"));
        }
        let mut history = VecDeque::with_capacity(count as usize);
        for _ in 0..count as usize {
            let g = arr(11)?;
            history.push_back(Segment {
                start: g[0],
                value: std::array::from_fn(|i| g[1 + i]),
                slope: std::array::from_fn(|i| g[6 + i]),
            });
        }
        let bits = arr(1)?[0];
        let mode = Mode::from_bits(bits)
            .ok_or_else(|| format!("plant state has an invalid contact mode {bits}"))?;
        let airborne = arr(N_WHEELS)?;
        let at_stop = arr(N_WHEELS + 1)?;
        if airborne.iter().chain(&at_stop).any(|&t| t < 0.0) {
            return Err("plant state has a negative time off the road or at a stop".into());
        }
        if next().is_ok() {
            return Err("plant state has trailing values".into());
        }
        if !v.iter().all(|x| x.is_finite()) {
            return Err("plant state contains non-finite values".into());
        }
        self.time = time;
        self.road.copy_from_slice(&road);
        self.road_slope.copy_from_slice(&road_slope);
        self.command.copy_from_slice(&command);
        self.command_slope.copy_from_slice(&command_slope);
        self.xi = DVector::from_vec(xi);
        self.history = history;
        self.mode = mode;
        self.dwell = Dwell {
            airborne: std::array::from_fn(|i| airborne[i]),
            at_stop: std::array::from_fn(|i| at_stop[i]),
        };
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The default car with an actuator delay `tau`, started at rest at t = 0.
    fn started_with_delay(tau: f64) -> Simulator {
        let actuator = ActuatorParams {
            tau,
            ..ActuatorParams::default()
        };
        let mut sim = Simulator::new(VehicleParams::default(), actuator);
        sim.start(0.0);
        sim
    }

    /// With the delay a whole number of steps, the force applied at each communication point
    /// is the command sent exactly that many steps earlier, at every step: the times `k h` the
    /// master passes and the plant's own `t + h` differ by rounding, and before the tolerance
    /// the output read the previous command at some steps (found by the sampled-data
    /// prediction, `tests/tests/sampled_loop.rs`, 20 % off with `delay_sf` at 20 ms).
    #[test]
    fn a_whole_step_delay_applies_the_command_of_that_many_steps_ago_at_every_step() {
        for (tau, h) in [(0.02, 1e-3), (0.01, 1e-4), (0.03, 1e-3)] {
            let mut sim = started_with_delay(tau);
            let lag = (tau / h).round() as usize;
            let command = |k: usize| (k % 7) as f64 + 1.0;
            for k in 0..3000 {
                let expected = if k >= lag { command(k - lag) } else { 0.0 };
                assert_eq!(
                    sim.applied_force()[4],
                    expected,
                    "τ = {tau}, h = {h}: at step {k} the seat force is not the command of step {}",
                    k as i64 - lag as i64
                );
                sim.command = [command(k); N_ACTUATORS];
                sim.step(k as f64 * h, h).unwrap();
            }
        }
    }

    /// Over 200 000 steps `(k h, h)` of a master without a delay or with one of whole steps,
    /// the plant computes one pair of exponentials, over `h` (before: one per value
    /// `(k h + h) − k h` rounds to, six over 10 s at 1 kHz and ten over 200 s, each 0.4 ms: the
    /// five extra were 1.6 ms of a 13.6 ms closed loop; with the delay, pieces a few ulps long
    /// too).
    #[test]
    fn a_run_at_a_constant_step_discretises_once() {
        for (tau, h) in [(0.0, 1e-3), (0.02, 1e-3), (0.0, 1e-4)] {
            let mut sim = started_with_delay(tau);
            for k in 0..200_000 {
                sim.command = [(k % 5) as f64; N_ACTUATORS];
                sim.step(k as f64 * h, h).unwrap();
            }
            let cache = &sim.system.as_ref().unwrap().cache;
            let steps: Vec<f64> = cache.iter().map(|d| d.car.step).collect();
            assert_eq!(steps, [h], "τ = {tau}, h = {h}");
        }
    }

    /// A master that keeps time in integer nanoseconds (libcosim) hands 1 ms over as the
    /// difference of two doubles, a little different at each step: the plant takes each as the
    /// step it has discretised (one pair of exponentials, as at a constant step; before, one at
    /// nearly every step), and its state is the constant step's to the bit.
    #[test]
    fn a_run_in_nanosecond_time_is_the_constant_step_run() {
        for tau in [0.0, 0.02] {
            let (mut constant, mut nanoseconds) =
                (started_with_delay(tau), started_with_delay(tau));
            let seconds = |ns: i64| ns as f64 / 1e9;
            let mut differed = 0;
            for k in 0..5000i64 {
                let command = [(k % 5) as f64 * 100.0; N_ACTUATORS];
                (constant.command, nanoseconds.command) = (command, command);
                constant.step(k as f64 * 1e-3, 1e-3).unwrap();
                let t = seconds(k * 1_000_000);
                let h = seconds((k + 1) * 1_000_000) - t;
                differed += (h != 1e-3) as usize;
                nanoseconds.step(t, h).unwrap();
            }
            assert!(differed > 1000, "the nanosecond steps were 1 ms");
            let steps: Vec<f64> = nanoseconds
                .system
                .as_ref()
                .unwrap()
                .cache
                .iter()
                .map(|d| d.car.step)
                .collect();
            assert_eq!(steps, [1e-3], "τ = {tau}");
            let bits = |s: &Simulator| s.state().iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&constant), bits(&nanoseconds), "τ = {tau}");
        }
    }

    /// The vibration meter weights what the car does: driven by a sinusoidal road on the left
    /// track (ramped between steps) and a sinusoidal seat force, each weighted output is its
    /// signal times the weighting's `W(j ω)` (the standard's cascade, `vehicle::iso2631`), once
    /// the transients have died out (measured: within 1.2·10⁻⁶, the least-squares fit of a
    /// finite window).
    #[test]
    fn the_meter_outputs_are_the_weighted_accelerations() {
        let p = VehicleParams::default();
        let rows = vehicle::model::physical_outputs(&p);
        let index = |n: &str| rows.iter().position(|r| r.name == n).unwrap();
        let signals = METER_OUTPUTS.map(|(_, signal, _, _)| index(signal));
        let weightings = ComfortMeter::weightings();
        for (f, seat_force, road) in [(1.7, 0.0, 0.01), (6.3, 300.0, 0.0)] {
            let omega = 2.0 * std::f64::consts::PI * f;
            let mut sim = Simulator::new(p, ActuatorParams::default());
            sim.start(0.0);
            let h = 1e-4;
            let (steps, fit) = (150_000, 30_000);
            let inputs = |t: f64| {
                let (z, v) = ((omega * t).sin() / omega, (omega * t).cos());
                (
                    [road * z, 0.0, 0.0, 0.0, road * v, 0.0, 0.0, 0.0],
                    seat_force * (omega * t).sin(),
                )
            };
            let mut out = vec![0.0; rows.len()];
            // Least squares of each signal and its weighted output on cos, sin.
            let mut sums = vec![[0.0; 5]; 6];
            for k in 0..steps {
                let t = k as f64 * h;
                let ((r0, u0), (r1, u1)) = (inputs(t), inputs(t + h));
                sim.road = r0;
                sim.road_slope = std::array::from_fn(|j| (r1[j] - r0[j]) / h);
                sim.command[4] = u0;
                sim.command_slope[4] = (u1 - u0) / h;
                if k >= steps - fit {
                    sim.physical_outputs(&mut out);
                    let meter = sim.meter();
                    let (c, s) = ((omega * t).cos(), (omega * t).sin());
                    for (j, y) in signals.iter().map(|&i| out[i]).chain(meter).enumerate() {
                        let acc = &mut sums[j];
                        *acc = [
                            acc[0] + c * c,
                            acc[1] + c * s,
                            acc[2] + s * s,
                            acc[3] + y * c,
                            acc[4] + y * s,
                        ];
                    }
                }
                sim.step(t, h).unwrap();
            }
            let amplitude = |a: &[f64; 5]| {
                let det = a[0] * a[2] - a[1] * a[1];
                let (x, y) = (
                    (a[3] * a[2] - a[4] * a[1]) / det,
                    (a[4] * a[0] - a[3] * a[1]) / det,
                );
                nalgebra::Complex::new(x, -y)
            };
            for (k, weighting) in weightings.iter().enumerate() {
                let (signal, weighted) = (amplitude(&sums[k]), amplitude(&sums[3 + k]));
                let expected = weighting.response(f) * signal;
                let err = (weighted - expected).norm() / expected.norm();
                println!(
                    "{} at {f} Hz: relative difference {err:.1e}",
                    METER_OUTPUTS[k].0
                );
                assert!(
                    err < 1e-5,
                    "{} at {f} Hz: {weighted} against {expected} ({err:e})",
                    METER_OUTPUTS[k].0
                );
            }
        }
    }
}
