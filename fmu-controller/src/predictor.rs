//! A predictor's runtime ([`crate::spec::Predictor`]): the commands still in flight to the
//! actuators and what they add to the design state `θ` ahead.
//!
//! The controller holds each command over its communication step, as the plant receives it, so
//! the command history is a list of held segments `(duration, u)`, newest first, ages measured
//! back from now. Over `[t, t + h)`:
//! * the command is `u(t) = K e^{Aθ} (S_y y + S_ξ ξ) + Σ_j K e^{A a_j} G(ℓ_j) u_j`, the sum over
//!   the parts `[a_j, a_j + ℓ_j]` of the segments younger than `θ` (`G(ℓ) = ∫₀^ℓ e^{As} ds B`),
//!   exactly the integral of the in-flight commands for held segments;
//! * `ξ` steps exactly with `y` held and the delayed command `u(· − θ)` piecewise constant:
//!   `ξ(t + h) = Φ_ξ ξ + Γ_ξ (y − D_yu u_r) + Σ_j e^{A_ξ b_j} G'_ξ(ℓ_j) u_j` over the parts of
//!   the segments whose commands act during the step, `G'_ξ` with `B_ξu + B_ξ D_yu`. `u_r` is
//!   the command whose force `y` carries (the one sent `θ` ago; with no delay the previous
//!   one, which a master's plant still applies when it is read): `y` holds the inputs' part
//!   that moves with the car, and the force reaches `ξ` as the actuators apply it. Held `y`
//!   alone would carry `u_r`'s force through a step in which the delayed command changes,
//!   which it does mid-step when `θ` is not a whole number of steps: measured, the sampled loop
//!   of `delay_sf` then had spectral radius 1.41 at 1.1 ms (unstable), 1.21 at 1.5 ms.
//!
//! Each term's matrix depends only on the part's age and length, so it is computed once (Van
//! Loan's exponential, [`linsys::discretize`]) and kept: with a constant communication
//! step every step reuses the same `θ / h + 1` small matrices (`K e^{A a} G` is 5×5); a master
//! that changes its step pays a few exponentials per new part, and stays exact.

use crate::spec::Predictor;
use linsys::{discretize, ExpError};
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
    /// `B_ξu + B_ξ D_yu`: how the applied force drives `ξ`.
    b_force: DMatrix<f64>,
    /// The delay compensated [s].
    theta: f64,
    /// `K e^{Aθ} S_y`, `K e^{Aθ} S_ξ` at `theta`.
    k_y: DMatrix<f64>,
    k_xi: DMatrix<f64>,
    /// Held commands `(duration, u)`, newest first, back to age `θ`.
    history: VecDeque<(f64, DVector<f64>)>,
    /// `Σ_j K e^{A a_j} G(ℓ_j) u_j` over the history now.
    in_flight: DVector<f64>,
    prediction: HashMap<Key, DMatrix<f64>>,
    delayed: HashMap<Key, DMatrix<f64>>,
    /// `ξ`'s own matrices at the last step length.
    own: Option<OwnStep>,
}

/// `Φ_ξ`, `Γ_ξ` and `Γ_ξ D_yu` over a step.
#[derive(Debug, Clone)]
struct OwnStep {
    step: f64,
    phi: DMatrix<f64>,
    gamma: DMatrix<f64>,
    gamma_d: DMatrix<f64>,
}

impl Runtime {
    pub fn new(spec: Predictor) -> Result<Self, String> {
        let nu = spec.k.nrows();
        let b_force = &spec.b_xiu + &spec.b_xi * &spec.d_yu;
        let mut r = Runtime {
            b_force,
            k_y: DMatrix::zeros(0, 0),
            k_xi: DMatrix::zeros(0, 0),
            theta: 0.0,
            history: VecDeque::new(),
            in_flight: DVector::zeros(nu),
            prediction: HashMap::new(),
            delayed: HashMap::new(),
            own: None,
            spec,
        };
        r.reset(0.0)?;
        Ok(r)
    }

    pub fn delay_max(&self) -> f64 {
        self.spec.delay_max
    }

    pub fn theta(&self) -> f64 {
        self.theta
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

    /// Compensate `theta` from now on, with no command in flight (the start of a run).
    pub fn reset(&mut self, theta: f64) -> Result<(), String> {
        if theta != self.theta || self.k_y.is_empty() {
            let e = discretize(&self.spec.a, &DMatrix::zeros(self.spec.a.nrows(), 0), theta)
                .map_err(|e| format!("cannot predict the state {theta} s ahead: {e}"))?
                .phi;
            self.theta = theta;
            let ke = &self.spec.k * e;
            self.k_y = &ke * &self.spec.s_y;
            self.k_xi = &ke * &self.spec.s_xi;
            self.prediction.clear();
            self.delayed.clear();
        }
        self.history.clear();
        self.in_flight.fill(0.0);
        Ok(())
    }

    /// The command for inputs `y` and own states `xi`.
    pub fn command(&self, y: &DVector<f64>, xi: &[f64], u: &mut DVector<f64>) {
        u.copy_from(&self.in_flight);
        u.gemv(1.0, &self.k_y, y, 1.0);
        u.gemv(1.0, &self.k_xi, &DVectorView::from_slice(xi, xi.len()), 1.0);
    }

    /// `ξ` after a step of `h` with `y` held and `u` sent (held over the step); the history
    /// and the in-flight sum move on. Returns the new `ξ` without changing anything when it is
    /// not finite (the caller discards the step).
    pub fn step(
        &mut self,
        xi: &[f64],
        y: &DVector<f64>,
        u: &DVector<f64>,
        h: f64,
    ) -> Result<DVector<f64>, String> {
        let failed = |e: ExpError| crate::step_refused(h, e);
        if self.own.as_ref().map(|o| o.step.to_bits()) != Some(h.to_bits()) {
            let d = discretize(&self.spec.a_xi, &self.spec.b_xi, h).map_err(failed)?;
            self.own = Some(OwnStep {
                step: h,
                gamma_d: &d.gamma_hold * &self.spec.d_yu,
                phi: d.phi,
                gamma: d.gamma_hold,
            });
        }
        let OwnStep {
            phi,
            gamma,
            gamma_d,
            ..
        } = self.own.as_ref().expect("set above");
        let mut next = phi * DVectorView::from_slice(xi, xi.len());
        next.gemv(1.0, gamma, y, 1.0);
        if let Some(u_r) = self.read_command(h) {
            next.gemv(-1.0, gamma_d, u_r, 1.0);
        }
        // The history with this step's command, ages from the end of the step (taken back out
        // if the step fails).
        self.history.push_front((h, u.clone()));
        // The delayed command acts during the step with ages (from its end) in [θ, θ + h].
        let theta = self.theta;
        let mut age = 0.0f64;
        let mut result = Ok(());
        for (len, uj) in &self.history {
            let (lo, hi) = (age.max(theta), (age + len).min(theta + h));
            if hi > lo {
                let m = cached(&mut self.delayed, (lo - theta, hi - lo), |b, l| {
                    let g = discretize(&self.spec.a_xi, &self.b_force, l)?.gamma_hold;
                    Ok(discretize(&self.spec.a_xi, &DMatrix::zeros(g.nrows(), 0), b)?.phi * g)
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
        if result.is_ok() && !next.iter().all(|v| v.is_finite()) {
            result = Err("controller state became non-finite; the step was discarded".into());
        }
        // Keep what the next steps need: the segments younger than θ, and the one sent θ ago
        // (at θ = 0 the command just sent, whose force the next inputs carry).
        let mut age = 0.0f64;
        let mut keep = 0;
        for (len, _) in &self.history {
            if age > theta {
                break;
            }
            keep += 1;
            age += len;
        }
        let in_flight = result.and_then(|()| self.in_flight_of(keep).map_err(failed));
        match in_flight {
            Ok(v) => {
                self.history.truncate(keep);
                self.in_flight = v;
                Ok(next)
            }
            Err(e) => {
                self.history.pop_front();
                Err(e)
            }
        }
    }

    /// The command whose force the inputs read at the start of a step carry: the newest
    /// segment reaching back to `θ` (at a whole number of steps, the one taking over now, as the
    /// plant counts a command's start as reached within rounding; at `θ = 0` the previous one).
    /// `None` before the first step (no force yet).
    fn read_command(&self, h: f64) -> Option<&DVector<f64>> {
        let reach = self.theta - 1e-9 * h;
        let mut age = 0.0f64;
        self.history.iter().find_map(|(len, u)| {
            age += len;
            (age >= reach).then_some(u)
        })
    }

    /// `Σ_j K e^{A a_j} G(ℓ_j) u_j` over the newest `keep` segments of the history.
    fn in_flight_of(&mut self, keep: usize) -> Result<DVector<f64>, ExpError> {
        let mut sum = DVector::zeros(self.in_flight.len());
        let theta = self.theta;
        let mut age = 0.0f64;
        for (len, uj) in self.history.iter().take(keep) {
            let (lo, hi) = (age, (age + len).min(theta));
            if hi > lo {
                let m = cached(&mut self.prediction, (lo, hi - lo), |a, l| {
                    let g = discretize(&self.spec.a, &self.spec.b, l)?.gamma_hold;
                    let e = discretize(&self.spec.a, &DMatrix::zeros(g.nrows(), 0), a)?.phi;
                    Ok(&self.spec.k * e * g)
                })?;
                sum.gemv(1.0, m, uj, 1.0);
            }
            age += len;
        }
        Ok(sum)
    }

    /// The state the runtime carries between steps: `θ`, then per segment its duration and
    /// command.
    pub fn save(&self) -> Vec<f64> {
        let mut out = vec![self.theta];
        for (len, u) in &self.history {
            out.push(*len);
            out.extend(u.iter());
        }
        out
    }

    /// Restore what [`Runtime::save`] wrote, checked like a parameter and an input.
    pub fn restore(&mut self, saved: &[f64]) -> Result<(), String> {
        let nu = self.in_flight.len();
        let (&theta, rest) = saved
            .split_first()
            .ok_or("predictor state: empty".to_string())?;
        self.check(theta)?;
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
        let mut candidate = self.clone();
        candidate.reset(theta)?;
        candidate.history = history;
        let keep = candidate.history.len();
        candidate.in_flight = candidate
            .in_flight_of(keep)
            .map_err(|e| format!("predictor state: {e}"))?;
        *self = candidate;
        Ok(())
    }
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
