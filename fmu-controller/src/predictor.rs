//! A predictor's runtime ([`crate::spec::Predictor`]): the commands still in flight to the
//! actuators and what they add to the design state `θ` ahead.
//!
//! The controller holds each command over its communication step, as the plant receives it, so
//! the command history is a list of held segments `(duration, u)`, newest first, ages measured
//! back from now. `ξ` has two kinds of rows:
//! * the **command's own filters** (the rows `B_ξu` drives, [`Predictor::own`]: the
//!   unmodelled-delay weight) run in controller time: `φ(t)` filters the commands up to `t`,
//!   which is exactly the design state's part `θ` ahead (those states and the car's do not
//!   drive each other, checked on reading, so `e^{Aθ}` does not mix them);
//! * the **rest** follows the car: driven by `y` held without the force it carries
//!   (`y − D_yu u_r`, `u_r` the command whose force `y` carries: the one sent `θ` ago, with no
//!   delay the previous one, which a master's plant still applies when it is read) and by the
//!   force as the actuators apply it (`B_ξ D_yu u(· − θ)`). Held `y` alone would carry `u_r`'s
//!   force through a step in which the delayed command changes, which it does mid-step when `θ`
//!   is not a whole number of steps: measured, the sampled loop of `delay_sf` then had
//!   spectral radius 1.41 at 1.1 ms (unstable), 1.21 at 1.5 ms.
//!
//! The command is `u = K̃ z + K_φ φ`, `z = e^{Aθ} (S_y y + S_ξ ξ) + I` the design state
//! predicted `θ` ahead, `K̃` the gain without the filters' columns, `I = Σ_j e^{A a_j} G(ℓ_j)
//! u_j` the in-flight integral over the parts `[a_j, a_j + ℓ_j]` of the segments younger than
//! `θ` (`G(ℓ) = ∫₀^ℓ e^{As} ds B`), exact for held segments. Over a step the controller runs
//! the design's loop on its model: the prediction moves on as the model says with the command
//! sent, `ż = A z + B u`, and the filters take the command the design gives at every instant,
//! `φ̇ = A_φ φ + B_φ (K̃ z + K_φ φ)`, so the hold never enters the filters' own loop, which is
//! the gain's fastest (−2000 rad/s in `delay_sf`). Driving the filters by the held commands
//! instead made `delay_sf` unstable at every communication step above 1.1 ms. With
//! `w = [ξ; z]`, `ẇ = Ā w + B̄ [y; u_r; u(· − θ); u]` over the step: one exponential per step
//! length and per part of a segment acting during the step.
//!
//! It predicts over `θ = max(tau, h)`, `tau` the delay it is told and `h` the communication
//! step ([`predicted_delay`]): a master reads the plant before it sets a new command, so below
//! one step the inputs carry the previous command's force, which predicting over one step
//! counts (matched, `θ < h` cost `delay_sf` 15 % of its held comfort at 1 ms with no delay and
//! made it unstable at 10 ms steps). The command at a step's start is computed before the
//! master says the step's length: it is predicted over the last step's (over `tau` before the
//! first), so a master with a constant step gets the rule from its second step.
//!
//! Each term's matrix depends only on the step length and the part's age and length, so it is
//! computed once (Van Loan's exponential, [`linsys::discretize`]) and kept: with a constant
//! communication step every step reuses the same few small matrices; a master that changes its
//! step pays a few exponentials per new part, and stays exact.

use crate::spec::Predictor;
use linsys::predictor::{predicted_delay, PredictionMatrices, PredictorBlocks};
use linsys::{discretize, expm, ExpError};
use nalgebra::{DMatrix, DVector, DVectorView};
use std::collections::{HashMap, VecDeque};

/// The number of cached matrices above which a cache is cleared (a master that varies its
/// step at every call would otherwise grow it without bound).
const CACHE_LIMIT: usize = 4096;

/// `(age, length)` of a part of a held segment, by their bits.
type Key = (u64, u64);

#[derive(Debug, Clone)]
pub struct Runtime {
    spec: Predictor,
    /// The actuators' delay it is told (parameter `tau`) [s].
    tau: f64,
    /// What depends on the delay predicted over.
    at: Prediction,
    /// Held commands `(duration, u)`, newest first, back to age `θ`.
    history: VecDeque<(f64, DVector<f64>)>,
    /// `K̃ I` over the history now.
    in_flight: DVector<f64>,
    /// `ζ`, what the commands' clamping has taken from the design state predicted `θ` ahead:
    /// `ζ̇ = A ζ + B (u − sat u)` ([`Runtime::step`]).
    zeta: DVector<f64>,
    /// `(h, e^{Ah}, G(h))` for `ζ` over the last step length.
    zeta_step: Option<(f64, DMatrix<f64>, DMatrix<f64>)>,
}

/// The prediction over a delay `θ`: its matrices, and the exponentials cached for it.
#[derive(Debug, Clone)]
struct Prediction {
    /// The delay predicted over [s].
    theta: f64,
    m: PredictionMatrices,
    /// Per part in flight: `K̃ e^{A a} G(ℓ)`.
    prediction: HashMap<Key, DMatrix<f64>>,
    /// Per part in flight at a step's start: what it adds to `ξ` over the step (`h` fixed).
    carried: HashMap<Key, DMatrix<f64>>,
    /// Per part of a segment acting during a step (its end's distance to the step's end, its
    /// length): what its force adds to `ξ`.
    delayed: HashMap<Key, DMatrix<f64>>,
    /// `ξ`'s own matrices at the last step length.
    own: Option<OwnStep>,
}

/// Over a step of `step`, the rows of `ξ`: `e^{Āh}` on `ξ` and on `y` with `z`'s part
/// `e^{Aθ} (S_y y + S_ξ ξ)` folded in, on `z` (for the commands in flight), and the input
/// integrals on `y`, `u_r` and the command sent.
#[derive(Debug, Clone)]
struct OwnStep {
    step: f64,
    phi: DMatrix<f64>,
    phi_i: DMatrix<f64>,
    gamma_y: DMatrix<f64>,
    gamma_r: DMatrix<f64>,
    gamma_u: DMatrix<f64>,
}

impl Prediction {
    fn new(p: &Predictor, theta: f64) -> Result<Self, String> {
        let blocks = PredictorBlocks {
            a: &p.a,
            b: &p.b,
            k: &p.k,
            s_y: &p.s_y,
            s_xi: &p.s_xi,
            a_xi: &p.a_xi,
            b_xi: &p.b_xi,
            b_xiu: &p.b_xiu,
            d_yu: &p.d_yu,
            own: &p.own,
        };
        let m = PredictionMatrices::new(&blocks, theta)
            .map_err(|e| format!("cannot predict the state {theta} s ahead: {e}"))?;
        Ok(Prediction {
            theta,
            m,
            prediction: HashMap::new(),
            carried: HashMap::new(),
            delayed: HashMap::new(),
            own: None,
        })
    }

    /// `K̃ I = Σ_j K̃ e^{A a_j} G(ℓ_j) u_j` over the newest `keep` segments of `history`.
    fn in_flight_of(
        &mut self,
        spec: &Predictor,
        history: &VecDeque<(f64, DVector<f64>)>,
        keep: usize,
    ) -> Result<DVector<f64>, ExpError> {
        let mut sum = DVector::zeros(self.m.k_tilde.nrows());
        let mut age = 0.0f64;
        for (len, uj) in history.iter().take(keep) {
            let (lo, hi) = (age, (age + len).min(self.theta));
            if hi > lo {
                let k = cached(&mut self.prediction, (lo, hi - lo), |a, l| {
                    Ok(&self.m.k_tilde * predicted(spec, a, l)?)
                })?;
                sum.gemv(1.0, k, uj, 1.0);
            }
            age += len;
        }
        Ok(sum)
    }
}

impl Runtime {
    pub fn new(spec: Predictor) -> Result<Self, String> {
        let nu = spec.k.nrows();
        Ok(Runtime {
            tau: 0.0,
            at: Prediction::new(&spec, 0.0)?,
            history: VecDeque::new(),
            in_flight: DVector::zeros(nu),
            zeta: DVector::zeros(spec.a.nrows()),
            zeta_step: None,
            spec,
        })
    }

    pub fn delay_max(&self) -> f64 {
        self.spec.delay_max
    }

    /// The delay it is told.
    pub fn tau(&self) -> f64 {
        self.tau
    }

    /// The delay it predicts over now.
    pub fn theta(&self) -> f64 {
        self.at.theta
    }

    /// Why `theta` cannot be compensated, if it cannot.
    pub fn check(&self, theta: f64) -> Result<(), String> {
        if theta >= 0.0 && theta <= self.spec.delay_max {
            Ok(())
        } else {
            Err(format!(
                "tau must be in [0, {}] s (the delays this predictor is certified for), got {theta}",
                self.spec.delay_max
            ))
        }
    }

    /// Told the delay `tau` from now on, with no command in flight (the start of a run). Until
    /// a step is taken it predicts over `tau` (no step length is known yet).
    pub fn reset(&mut self, tau: f64) -> Result<(), String> {
        if tau.to_bits() != self.at.theta.to_bits() {
            self.at = Prediction::new(&self.spec, tau)?;
        }
        self.tau = tau;
        self.history.clear();
        self.in_flight.fill(0.0);
        self.zeta.fill(0.0);
        Ok(())
    }

    /// Told the delay `tau` from now on, the commands in flight kept: the next command is
    /// predicted over `tau` (the Jacobi order's `tau + h`, whose `h` is known only at a step).
    /// Nothing changes when it fails.
    pub fn retarget(&mut self, tau: f64) -> Result<(), String> {
        self.check(tau)?;
        if tau.to_bits() != self.at.theta.to_bits() {
            let mut at = Prediction::new(&self.spec, tau)?;
            let in_flight = at
                .in_flight_of(&self.spec, &self.history, self.history.len())
                .map_err(|e| format!("cannot predict the state {tau} s ahead: {e}"))?;
            (self.at, self.in_flight) = (at, in_flight);
        }
        self.tau = tau;
        Ok(())
    }

    /// The command for inputs `y` and own states `xi`: the design's for the state it would
    /// have had, had no command been clamped (`z + ζ`).
    pub fn command(&self, y: &DVector<f64>, xi: &[f64], u: &mut DVector<f64>) {
        u.copy_from(&self.in_flight);
        u.gemv(1.0, &self.at.m.k_tilde, &self.zeta, 1.0);
        u.gemv(1.0, &self.at.m.k_y, y, 1.0);
        u.gemv(
            1.0,
            &self.at.m.k_xi,
            &DVectorView::from_slice(xi, xi.len()),
            1.0,
        );
    }

    /// `ξ` after a step of `h` with `y` held and `sent` sent (held over the step, predicted
    /// over the delay it was computed with), `u` the command [`Runtime::command`] gave before
    /// the clamp; the history and the in-flight sum move on, and the next command is predicted
    /// over `max(tau, h)` ([`predicted_delay`]). Returns the new `ξ` without changing anything
    /// when it is not finite (the caller discards the step).
    ///
    /// Model-recovery anti-windup (thesis Th. 5.3 with no gain on its state): the design state
    /// predicted `θ` ahead is what the commands sent make it, and the commands are clamped to
    /// the actuators' limits; what the clamp took, `u − sat u`, would have moved it by `ζ`,
    /// `ζ̇ = A ζ + B (u − sat u)`, with no delay (a command's force and its prediction are both
    /// `θ` late). The command is the design's for `z + ζ`, and the command's own filters see
    /// `z + ζ` move with `u`: the design's loop runs as if nothing were clamped, and `ζ`, the
    /// model's stable response to bounded inputs, stays bounded, whatever the limits.
    pub fn step(
        &mut self,
        xi: &[f64],
        y: &DVector<f64>,
        u: &DVector<f64>,
        sent: &DVector<f64>,
        h: f64,
    ) -> Result<DVector<f64>, String> {
        let failed = |e: ExpError| crate::step_refused(h, e);
        if self.zeta_step.as_ref().map(|z| z.0.to_bits()) != Some(h.to_bits()) {
            let d = discretize(&self.spec.a, &self.spec.b, h).map_err(failed)?;
            self.zeta_step = Some((h, d.phi, d.gamma_hold));
        }
        let (nxi, ny, nu) = (xi.len(), y.len(), u.len());
        let (cy, cr, ca, cu) = PredictionMatrices::columns(ny, nu);
        let at = &mut self.at;
        if at.own.as_ref().map(|o| o.step.to_bits()) != Some(h.to_bits()) {
            let d = discretize(&at.m.a_bar, &at.m.b_bar, h).map_err(failed)?;
            let rows =
                |c0: usize, cols: usize| d.gamma_hold.view((0, c0), (nxi, cols)).into_owned();
            // `z` at the step's start: `e^{Aθ} (S_y y + S_ξ ξ)` here, the commands in flight
            // below (`carried`).
            let phi_z = d
                .phi
                .view((0, nxi), (nxi, d.phi.ncols() - nxi))
                .into_owned();
            at.own = Some(OwnStep {
                step: h,
                phi: d.phi.view((0, 0), (nxi, nxi)) + &phi_z * &at.m.z_xi,
                gamma_y: rows(cy, ny) + &phi_z * &at.m.z_y,
                phi_i: phi_z,
                gamma_r: rows(cr, nu),
                gamma_u: rows(cu, nu),
            });
            at.carried.clear();
        }
        let own = at.own.as_ref().expect("set above");
        let mut next = &own.phi * DVectorView::from_slice(xi, xi.len());
        next.gemv(1.0, &own.gamma_y, y, 1.0);
        next.gemv(1.0, &own.gamma_u, u, 1.0);
        next.gemv(1.0, &own.phi_i, &self.zeta, 1.0);
        let theta = at.theta;
        if let Some(u_r) = read_command(&self.history, theta, h) {
            next.gemv(1.0, &own.gamma_r, u_r, 1.0);
        }
        let mut result = Ok(());
        // The commands in flight at the step's start (their part of `z`), ages from now:
        // `Φ̄_ξz e^{Aa} G(ℓ) u_j`.
        let mut age = 0.0f64;
        for (len, uj) in &self.history {
            let (lo, hi) = (age, (age + len).min(theta));
            if hi > lo {
                let m = cached(&mut at.carried, (lo, hi - lo), |a, l| {
                    Ok(&own.phi_i * predicted(&self.spec, a, l)?)
                });
                match m {
                    Ok(m) => next.gemv(1.0, m, uj, 1.0),
                    Err(e) => {
                        result = Err(failed(e));
                        break;
                    }
                }
            }
            age += len;
        }
        // The history with this step's command, ages from the end of the step (taken back out
        // if the step fails).
        self.history.push_front((h, sent.clone()));
        // The delayed command acts during the step with ages (from its end) in [θ, θ + h].
        let mut age = 0.0f64;
        for (len, uj) in &self.history {
            if result.is_err() {
                break;
            }
            let (lo, hi) = (age.max(theta), (age + len).min(theta + h));
            if hi > lo {
                let m = cached(&mut at.delayed, (lo - theta, hi - lo), |b, l| {
                    let g = discretize(&at.m.a_bar, &at.m.b_bar.columns(ca, nu).into_owned(), l)?
                        .gamma_hold;
                    Ok((expm(&(&at.m.a_bar * b))? * g).rows(0, nxi).into_owned())
                });
                match m {
                    Ok(m) => next.gemv(1.0, m, uj, 1.0),
                    Err(e) => result = Err(failed(e)),
                }
            }
            age += len;
        }
        if result.is_ok() && !next.iter().all(|v| v.is_finite()) {
            result = Err("controller state became non-finite; the step was discarded".into());
        }
        // The next command's prediction, over a new delay when this step's length sets one.
        let target = predicted_delay(self.tau, h);
        let mut moved = None;
        if result.is_ok() && target.to_bits() != theta.to_bits() {
            match Prediction::new(&self.spec, target) {
                Ok(p) => moved = Some(p),
                Err(e) => result = Err(format!("the step of {h} s was refused: {e}")),
            }
        }
        // Keep what the next steps need: the segments younger than the delay predicted over,
        // and the one sent that long ago (with no delay the command just sent, whose force the
        // next inputs carry).
        let next_theta = moved.as_ref().map_or(theta, |p| p.theta);
        let mut age = 0.0f64;
        let mut keep = 0;
        for (len, _) in &self.history {
            if age > next_theta {
                break;
            }
            keep += 1;
            age += len;
        }
        let in_flight = result.and_then(|()| {
            moved
                .as_mut()
                .unwrap_or(&mut self.at)
                .in_flight_of(&self.spec, &self.history, keep)
                .map_err(failed)
        });
        match in_flight {
            Ok(v) => {
                if let Some(p) = moved {
                    self.at = p;
                }
                self.history.truncate(keep);
                self.in_flight = v;
                let (_, e, g) = self.zeta_step.as_ref().expect("set above");
                self.zeta = e * &self.zeta + g * (u - sent);
                Ok(next)
            }
            Err(e) => {
                self.history.pop_front();
                Err(e)
            }
        }
    }

    /// The state the runtime carries between steps: the delay predicted over, `ζ` (the
    /// clamp's part of the predicted state), then per segment its duration and command.
    pub fn save(&self) -> Vec<f64> {
        let mut out = vec![self.at.theta];
        out.extend(self.zeta.iter());
        for (len, u) in &self.history {
            out.push(*len);
            out.extend(u.iter());
        }
        out
    }

    /// Restore what [`Runtime::save`] wrote, told `tau` (the controller's parameter, saved
    /// beside it and checked as one), the rest checked like an input.
    pub fn restore(&mut self, tau: f64, saved: &[f64]) -> Result<(), String> {
        self.check(tau)?;
        let nu = self.in_flight.len();
        let (&theta, rest) = saved
            .split_first()
            .ok_or("predictor state: empty".to_string())?;
        let n = self.zeta.len();
        if rest.len() < n || !rest[..n].iter().all(|v| v.is_finite()) {
            return Err(format!(
                "predictor state: the clamp's {n} values of the predicted state (anti-windup) \
                 are missing or not finite"
            ));
        }
        let (zeta, rest) = (DVector::from_column_slice(&rest[..n]), &rest[n..]);
        // Over `tau`, or over a step longer than `tau` (`max(tau, h)`).
        if !(theta.is_finite() && theta >= tau) {
            return Err(format!(
                "predictor state: the delay predicted over, {theta} s, is not a finite delay of \
                 at least tau = {tau} s"
            ));
        }
        if rest.len() % (nu + 1) != 0 {
            return Err(format!(
                "predictor state: {} values are not segments of {} values",
                rest.len(),
                nu + 1
            ));
        }
        let history: VecDeque<(f64, DVector<f64>)> = rest
            .chunks_exact(nu + 1)
            .map(|c| (c[0], DVector::from_column_slice(&c[1..])))
            .collect();
        if history
            .iter()
            .any(|(len, u)| !(*len > 0.0 && len.is_finite() && u.iter().all(|v| v.is_finite())))
        {
            return Err(
                "predictor state: segment durations must be finite and > 0, commands finite".into(),
            );
        }
        let mut at = if theta.to_bits() == self.at.theta.to_bits() {
            self.at.clone()
        } else {
            Prediction::new(&self.spec, theta)?
        };
        let in_flight = at
            .in_flight_of(&self.spec, &history, history.len())
            .map_err(|e| format!("predictor state: {e}"))?;
        (self.tau, self.at, self.history, self.in_flight, self.zeta) =
            (tau, at, history, in_flight, zeta);
        Ok(())
    }
}

/// The command whose force the inputs read at the start of a step carry: the newest segment
/// of `history` reaching back to `theta` (at a whole number of steps, the one taking over now,
/// as the plant counts a command's start as reached within rounding; at `θ = 0` the previous
/// one). `None` before the first step (no force yet).
fn read_command(
    history: &VecDeque<(f64, DVector<f64>)>,
    theta: f64,
    h: f64,
) -> Option<&DVector<f64>> {
    let reach = theta - 1e-9 * h;
    let mut age = 0.0f64;
    history.iter().find_map(|(len, u)| {
        age += len;
        (age >= reach).then_some(u)
    })
}

/// `e^{A a} G(ℓ)`: a command held for `ℓ`, `a` before now, in the prediction.
fn predicted(p: &Predictor, a: f64, l: f64) -> Result<DMatrix<f64>, ExpError> {
    Ok(expm(&(&p.a * a))? * discretize(&p.a, &p.b, l)?.gamma_hold)
}

/// `cache[key]`, computed by `make(age, length)` on a miss (a failure is not cached).
fn cached(
    cache: &mut HashMap<Key, DMatrix<f64>>,
    (age, len): (f64, f64),
    make: impl FnOnce(f64, f64) -> Result<DMatrix<f64>, ExpError>,
) -> Result<&DMatrix<f64>, ExpError> {
    if cache.len() >= CACHE_LIMIT {
        cache.clear();
    }
    match cache.entry((age.to_bits(), len.to_bits())) {
        std::collections::hash_map::Entry::Occupied(e) => Ok(e.into_mut()),
        std::collections::hash_map::Entry::Vacant(e) => Ok(e.insert(make(age, len)?)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The scalar predictor of `tests/controller_fmi.rs` (`PRED_SPEC`).
    fn runtime() -> Runtime {
        let m = |r: usize, c: usize, v: &[f64]| DMatrix::from_row_slice(r, c, v);
        Runtime::new(Predictor {
            a: m(2, 2, &[-2.0, 0.0, 0.0, -5.0]),
            b: m(2, 1, &[1.5, 1.0]),
            k: m(1, 2, &[-0.8, -2.0]),
            s_y: m(2, 1, &[1.0, 0.0]),
            s_xi: m(2, 2, &[0.7, 0.0, 0.0, 1.0]),
            a_xi: m(2, 2, &[-3.0, 0.0, 0.0, -5.0]),
            b_xi: m(2, 1, &[0.3, 0.0]),
            b_xiu: m(2, 1, &[0.0, 1.0]),
            d_yu: m(1, 1, &[0.4]),
            own: vec![(1, 1, 1.0)],
            delay_max: 0.3,
            u_max: None,
        })
        .unwrap()
    }

    /// What the clamp takes is counted as if it had been sent (model-recovery anti-windup): a
    /// runtime whose command was sent as nothing carries the design's force in `ζ` where one
    /// whose command was sent whole carries it in flight, and the next command of both is the
    /// same (predicted over the step just taken, in which the whole command is in flight).
    #[test]
    fn a_clamped_command_counts_for_the_design_as_if_sent() {
        let (y, h) = (DVector::from_element(1, 0.5), 0.05);
        let xi = DVector::zeros(2);
        let mut commands = Vec::new();
        for clamped in [false, true] {
            let mut r = runtime();
            r.reset(0.0).unwrap();
            let mut u = DVector::zeros(1);
            r.command(&y, xi.as_slice(), &mut u);
            let sent = if clamped {
                DVector::zeros(1)
            } else {
                u.clone()
            };
            r.step(xi.as_slice(), &y, &u, &sent, h).unwrap();
            assert_eq!(r.zeta.iter().any(|v| *v != 0.0), clamped);
            let mut next = DVector::zeros(1);
            r.command(&y, xi.as_slice(), &mut next);
            commands.push(next[0]);
        }
        assert!(commands[0] != 0.0);
        assert!(
            (commands[0] - commands[1]).abs() <= 1e-12 * commands[0].abs(),
            "{commands:?}"
        );
    }

    /// Told no delay, it predicts over `tau` until the first step and over each step's length
    /// after it; a saved state restores whole (the delay predicted over included), and a
    /// corrupt one is refused with its reason and changes nothing.
    #[test]
    fn it_predicts_over_the_last_step_and_refuses_a_corrupt_state() {
        let mut r = runtime();
        r.reset(0.0).unwrap();
        assert_eq!(r.theta(), 0.0);
        let (y, mut u) = (DVector::from_element(1, 0.5), DVector::zeros(1));
        let mut xi = DVector::zeros(2);
        for h in [0.1, 0.05] {
            r.command(&y, xi.as_slice(), &mut u);
            xi = r.step(xi.as_slice(), &y, &u, &u, h).unwrap();
            assert_eq!(r.theta(), h);
        }
        let saved = r.save();
        let command = |r: &Runtime| {
            let mut u = DVector::zeros(1);
            r.command(&y, xi.as_slice(), &mut u);
            u[0]
        };
        let before = command(&r);
        let mut fresh = runtime();
        fresh.restore(0.0, &saved).unwrap();
        assert_eq!((fresh.theta(), command(&fresh)), (0.05, before));
        for (tau, state, reason) in [
            (0.0, vec![], "empty"),
            (0.1, saved.clone(), "at least tau"),
            (0.0, [&[f64::NAN][..], &saved[1..]].concat(), "finite delay"),
            (
                0.0,
                [&saved[..1], &[f64::NAN], &saved[2..]].concat(),
                "anti-windup",
            ),
            (0.0, saved[..2].to_vec(), "anti-windup"),
            (0.31, saved.clone(), "[0, 0.3]"),
            (0.0, saved[..saved.len() - 1].to_vec(), "not segments"),
            (0.0, [&saved[..], &[0.0, 1.0]].concat(), "durations"),
            (0.0, [&saved[..], &[0.1, f64::INFINITY]].concat(), "finite"),
        ] {
            let err = fresh.restore(tau, &state).unwrap_err();
            assert!(err.contains(reason), "{tau}, {state:?}: {err}");
            assert_eq!(fresh.save(), saved);
            assert_eq!(command(&fresh), before);
        }
    }
}
