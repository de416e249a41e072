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
//! The seat's vibration meter ([`vehicle::iso2631::ComfortMeter`]) is part of the linear
//! system: the ISO 2631-1 weighted accelerations are states, stepped exactly with the car.

use linsys::{discretize, mat_vec_sum, Discretization, ExpError};
use nalgebra::{DMatrix, DVector};
use std::collections::VecDeque;
use vehicle::iso2631::{ComfortMeter, Forces, METER_OUTPUTS};
use vehicle::model::{
    physical_outputs, StateSpace, StaticEquilibrium, N_ACTUATORS, N_ROAD, N_STATES,
};
use vehicle::VehicleParams;

/// Number of inputs of the linear part: road heights and velocities, then actuator outputs.
const N_INPUTS: usize = N_ROAD + N_ACTUATORS;
/// How many step sizes keep their discretisation.
const CACHE_SIZE: usize = 16;

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
}

impl System {
    fn new(p: &VehicleParams, act: &ActuatorParams) -> Self {
        let ss = StateSpace::new(p);
        let lag = act.bandwidth > 0.0;
        let (n, meter_at) = (state_count(act), car_states(act));
        let mut a = DMatrix::zeros(n, n);
        let mut b = DMatrix::zeros(n, N_INPUTS);
        a.view_mut((0, 0), (N_STATES, N_STATES)).copy_from(&ss.a);
        b.view_mut((0, 0), (N_STATES, N_ROAD)).copy_from(&ss.b_r);
        // The forces: the lag states, or the actuator outputs themselves.
        let forces = if lag {
            let w = 2.0 * std::f64::consts::PI * act.bandwidth;
            a.view_mut((0, N_STATES), (N_STATES, N_ACTUATORS))
                .copy_from(&ss.b_u);
            for i in 0..N_ACTUATORS {
                a[(N_STATES + i, N_STATES + i)] = -w;
                b[(N_STATES + i, N_ROAD + i)] = w;
            }
            Forces::States(N_STATES)
        } else {
            b.view_mut((0, N_ROAD), (N_STATES, N_ACTUATORS))
                .copy_from(&ss.b_u);
            Forces::Inputs(N_ROAD)
        };
        let outputs = physical_outputs(p);
        let meter = ComfortMeter::new(&outputs);
        meter.place(&mut a, &mut b, meter_at, forces);
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
        }
    }

    /// The discretisation for step `h`, from the cache or computed (matrix exponentials).
    fn discretization(&mut self, h: f64) -> Result<&StepMatrices, ExpError> {
        if let Some(pos) = self
            .cache
            .iter()
            .position(|d| d.car.step.to_bits() == h.to_bits())
        {
            return Ok(&self.cache[pos]);
        }
        let nc = self.meter_at;
        let car = discretize(
            &self.a.view((0, 0), (nc, nc)).into_owned(),
            &self.b.rows(0, nc).into_owned(),
            h,
        )?;
        let whole = discretize(&self.a, &self.b, h)?;
        let rows = |m: &DMatrix<f64>| m.rows(nc, self.n - nc).into_owned();
        let meter = Discretization {
            step: h,
            phi: rows(&whole.phi),
            gamma_hold: rows(&whole.gamma_hold),
            gamma_ramp: rows(&whole.gamma_ramp),
        };
        let d = StepMatrices { car, meter };
        if self.cache.len() == CACHE_SIZE {
            self.cache.pop_front();
        }
        self.cache.push_back(d);
        Ok(self.cache.back().unwrap())
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
        self.system = Some(System::new(&self.params, &self.actuator));
        self.xi = DVector::zeros(self.system.as_ref().unwrap().n);
        self.history.clear();
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
            let sys = System::new(&self.params, &self.actuator);
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
        // With no delay the current (just set) command acts at once.
        let seg = if self.actuator.tau == 0.0 {
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
        };
        std::array::from_fn(|i| self.actuator_output(&seg, i, now, now))
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

    /// Physical outputs (the rows of [`vehicle::model::physical_outputs`]) now, and the applied
    /// forces they were computed with.
    pub fn physical_outputs(&mut self, out: &mut [f64]) -> [f64; N_ACTUATORS] {
        let f = self.applied_force();
        let mut z = [0.0; N_STATES + N_ROAD + N_ACTUATORS];
        z[..N_STATES].copy_from_slice(self.state());
        z[N_STATES..N_STATES + N_ROAD].copy_from_slice(&self.road);
        z[N_STATES + N_ROAD..].copy_from_slice(&f);
        let sys = self
            .system
            .as_ref()
            .expect("applied_force built the system");
        sys.outputs.apply(&z, out);
        f
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

        let [mut xi, mut next] = std::mem::take(&mut self.work);
        if xi.len() != self.xi.len() {
            xi = DVector::zeros(self.xi.len());
            next = DVector::zeros(self.xi.len());
        }
        xi.copy_from(&self.xi);
        let (mut wa, mut dw) = (std::mem::take(&mut self.wa), std::mem::take(&mut self.dw));
        let mut failure = None;
        for k in 0..breaks.len() - 1 {
            let (a, b) = (breaks[k], breaks[k + 1]);
            // A step in one piece is `h` long, not `(t + h) − t`: that is `h` rounded to `t`'s
            // ulp, six values over 10 s at 1 kHz (a new one in some binades of `t`), each its
            // own pair of matrix exponentials (0.4 ms) for a change in the 13th digit.
            let len = if breaks.len() == 2 { h } else { b - a };
            let mid = 0.5 * (a + b);
            let seg = self.segment_at(mid - tau);
            let mut ramp = false;
            for j in 0..N_ROAD {
                wa[j] = self.road[j] + self.road_slope[j] * (a - t);
                dw[j] = self.road_slope[j] * len;
                ramp |= dw[j] != 0.0;
            }
            for i in 0..N_ACTUATORS {
                let va = self.actuator_output(&seg, i, a, mid);
                let vb = self.actuator_output(&seg, i, b, mid);
                wa[N_ROAD + i] = va;
                dw[N_ROAD + i] = vb - va;
                ramp |= vb != va;
            }
            let d = match self.system.as_mut().unwrap().discretization(len) {
                Ok(d) => d,
                Err(error) => {
                    failure = Some(StepError::Exponential { step: len, error });
                    break;
                }
            };
            let (x, wa, dw) = (xi.as_slice(), wa.as_slice(), dw.as_slice());
            let (car, meter) = next.as_mut_slice().split_at_mut(d.car.phi.nrows());
            for (y, d, x) in [(car, &d.car, &x[..d.car.phi.ncols()]), (meter, &d.meter, x)] {
                if ramp {
                    mat_vec_sum(y, &[(&d.phi, x), (&d.gamma_hold, wa), (&d.gamma_ramp, dw)]);
                } else {
                    mat_vec_sum(y, &[(&d.phi, x), (&d.gamma_hold, wa)]);
                }
            }
            std::mem::swap(&mut xi, &mut next);
        }
        self.breaks = breaks;
        (self.wa, self.dw) = (wa, dw);
        if failure.is_none() && !xi.iter().all(|v| v.is_finite()) {
            failure = Some(StepError::NonFinite(end));
        }
        if failure.is_none() {
            std::mem::swap(&mut self.xi, &mut xi);
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

    /// The vibration meter weights what the car does: driven by a sinusoidal road on the left
    /// track (ramped between steps) and a sinusoidal seat force, each weighted output is its
    /// signal times the weighting's `W(j ω)` (the standard's cascade, `vehicle::iso2631`), once
    /// the transients have died out (measured: within 1.2·10⁻⁶, the least-squares fit of a
    /// finite window).
    #[test]
    fn the_meter_outputs_are_the_weighted_accelerations() {
        let p = VehicleParams::default();
        let rows = physical_outputs(&p);
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
