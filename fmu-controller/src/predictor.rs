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
//! Each term's matrix depends only on the step length and the part's age and length, so it is
//! computed once (Van Loan's exponential, [`linsys::discretize`]) and kept: with a constant
//! communication step every step reuses the same few small matrices; a master that changes its
//! step pays a few exponentials per new part, and stays exact.

use crate::spec::Predictor;
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
    /// The delay compensated [s].
    theta: f64,
    /// `K̃`: the gain without the columns of the command's own filters.
    k_tilde: DMatrix<f64>,
    /// `K̃ e^{Aθ} S_y`; `K̃ e^{Aθ} S_ξ` with `K_φ` on the filters' columns.
    k_y: DMatrix<f64>,
    k_xi: DMatrix<f64>,
    /// `e^{Aθ} S_ξ`, `e^{Aθ} S_y`: the prediction `z = e^{Aθ} x + I` of `ξ` and `y`.
    z_xi: DMatrix<f64>,
    z_y: DMatrix<f64>,
    /// `Ā`, and `B̄`'s columns `[y | u_r | u(· − θ) | u]`, over `w = [ξ; z]`.
    a_bar: DMatrix<f64>,
    b_bar: DMatrix<f64>,
    /// Held commands `(duration, u)`, newest first, back to age `θ`.
    history: VecDeque<(f64, DVector<f64>)>,
    /// `K̃ I` over the history now.
    in_flight: DVector<f64>,
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

impl Runtime {
    pub fn new(spec: Predictor) -> Result<Self, String> {
        let nu = spec.k.nrows();
        let mut r = Runtime {
            k_tilde: DMatrix::zeros(0, 0),
            k_y: DMatrix::zeros(0, 0),
            k_xi: DMatrix::zeros(0, 0),
            z_xi: DMatrix::zeros(0, 0),
            z_y: DMatrix::zeros(0, 0),
            a_bar: DMatrix::zeros(0, 0),
            b_bar: DMatrix::zeros(0, 0),
            theta: 0.0,
            history: VecDeque::new(),
            in_flight: DVector::zeros(nu),
            prediction: HashMap::new(),
            carried: HashMap::new(),
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
            let p = &self.spec;
            let e = expm(&(&p.a * theta))
                .map_err(|e| format!("cannot predict the state {theta} s ahead: {e}"))?;
            let (nxi, n, ny, nu) = (p.a_xi.nrows(), p.a.nrows(), p.b_xi.ncols(), p.k.nrows());
            let (mut k_tilde, mut k_own) = (p.k.clone(), DMatrix::zeros(nu, nxi));
            for &(j, i, s) in &p.own {
                k_own.column_mut(j).copy_from(&(p.k.column(i) * s));
                k_tilde.column_mut(i).fill(0.0);
            }
            let (z_xi, z_y) = (&e * &p.s_xi, &e * &p.s_y);
            let (k_xi, k_y) = (&k_tilde * &z_xi + &k_own, &k_tilde * &z_y);
            // The applied force reaches the car's rows through what they read.
            let mut b_applied = &p.b_xi * &p.d_yu;
            for &(j, _, _) in &p.own {
                b_applied.row_mut(j).fill(0.0);
            }
            let mut a_bar = DMatrix::zeros(nxi + n, nxi + n);
            a_bar
                .view_mut((0, 0), (nxi, nxi))
                .copy_from(&(&p.a_xi + &p.b_xiu * &k_own));
            a_bar
                .view_mut((0, nxi), (nxi, n))
                .copy_from(&(&p.b_xiu * &k_tilde));
            a_bar.view_mut((nxi, nxi), (n, n)).copy_from(&p.a);
            let mut b_bar = DMatrix::zeros(nxi + n, ny + 3 * nu);
            b_bar.view_mut((0, 0), (nxi, ny)).copy_from(&p.b_xi);
            b_bar
                .view_mut((0, ny), (nxi, nu))
                .copy_from(&(-&p.b_xi * &p.d_yu));
            b_bar
                .view_mut((0, ny + nu), (nxi, nu))
                .copy_from(&b_applied);
            b_bar.view_mut((nxi, ny + 2 * nu), (n, nu)).copy_from(&p.b);
            self.theta = theta;
            (self.z_xi, self.z_y) = (z_xi, z_y);
            (self.k_tilde, self.k_y, self.k_xi) = (k_tilde, k_y, k_xi);
            (self.a_bar, self.b_bar) = (a_bar, b_bar);
            self.prediction.clear();
            self.carried.clear();
            self.delayed.clear();
            self.own = None;
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
        let (nxi, ny, nu) = (xi.len(), y.len(), u.len());
        if self.own.as_ref().map(|o| o.step.to_bits()) != Some(h.to_bits()) {
            let d = discretize(&self.a_bar, &self.b_bar, h).map_err(failed)?;
            let rows =
                |c0: usize, cols: usize| d.gamma_hold.view((0, c0), (nxi, cols)).into_owned();
            // `z` at the step's start: `e^{Aθ} (S_y y + S_ξ ξ)` here, the commands in flight
            // below (`carried`).
            let phi_z = d
                .phi
                .view((0, nxi), (nxi, d.phi.ncols() - nxi))
                .into_owned();
            self.own = Some(OwnStep {
                step: h,
                phi: d.phi.view((0, 0), (nxi, nxi)) + &phi_z * &self.z_xi,
                gamma_y: rows(0, ny) + &phi_z * &self.z_y,
                phi_i: phi_z,
                gamma_r: rows(ny, nu),
                gamma_u: rows(ny + 2 * nu, nu),
            });
            self.carried.clear();
        }
        let own = self.own.as_ref().expect("set above");
        let mut next = &own.phi * DVectorView::from_slice(xi, xi.len());
        next.gemv(1.0, &own.gamma_y, y, 1.0);
        next.gemv(1.0, &own.gamma_u, u, 1.0);
        if let Some(u_r) = self.read_command(h) {
            next.gemv(1.0, &own.gamma_r, u_r, 1.0);
        }
        let theta = self.theta;
        let mut result = Ok(());
        // The commands in flight at the step's start (their part of `z`), ages from now:
        // `Φ̄_ξz e^{Aa} G(ℓ) u_j`.
        let mut age = 0.0f64;
        for (len, uj) in &self.history {
            let (lo, hi) = (age, (age + len).min(theta));
            if hi > lo {
                let m = cached(&mut self.carried, (lo, hi - lo), |a, l| {
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
        self.history.push_front((h, u.clone()));
        // The delayed command acts during the step with ages (from its end) in [θ, θ + h].
        let mut age = 0.0f64;
        for (len, uj) in &self.history {
            if result.is_err() {
                break;
            }
            let (lo, hi) = (age.max(theta), (age + len).min(theta + h));
            if hi > lo {
                let m = cached(&mut self.delayed, (lo - theta, hi - lo), |b, l| {
                    let g = discretize(
                        &self.a_bar,
                        &self.b_bar.columns(ny + nu, nu).into_owned(),
                        l,
                    )?
                    .gamma_hold;
                    Ok((expm(&(&self.a_bar * b))? * g).rows(0, nxi).into_owned())
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

    /// `K̃ I = Σ_j K̃ e^{A a_j} G(ℓ_j) u_j` over the newest `keep` segments of the history.
    fn in_flight_of(&mut self, keep: usize) -> Result<DVector<f64>, ExpError> {
        let mut sum = DVector::zeros(self.in_flight.len());
        let theta = self.theta;
        let mut age = 0.0f64;
        for (len, uj) in self.history.iter().take(keep) {
            let (lo, hi) = (age, (age + len).min(theta));
            if hi > lo {
                let k = cached(&mut self.prediction, (lo, hi - lo), |a, l| {
                    Ok(&self.k_tilde * predicted(&self.spec, a, l)?)
                })?;
                sum.gemv(1.0, k, uj, 1.0);
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
