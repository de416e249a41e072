//! Guaranteed-cost comfort: a state feedback that minimises an upper bound of the comfort norm
//! valid for every uncertainty of its channels, and the bound that certifies a closed loop.
//!
//! A channel ([`Channel`]) is a norm-bounded uncertainty `p = Δ q`, `‖Δ‖ ≤ 1`. If `X ⪰ 0` and
//! multipliers `εⱼ > 0` satisfy
//! ```text
//! Aᵀ X + X A + Cᵀ C + Σⱼ C_qjᵀ C_qj / εⱼ + X (Σⱼ εⱼ B_pj B_pjᵀ) X ⪯ 0,
//! ```
//! then with `V = xᵀ X x`, completing the square `2 xᵀ X B_p p ≤ ε xᵀ X B_p B_pᵀ X x + |p|²/ε`,
//! `E V̇ ≤ −E|C x|² + Σⱼ (E|pⱼ|² − E|qⱼ|²)/εⱼ + tr(B_wᵀ X B_w)`. In stationary operation
//! `E V̇ = 0`, and `E|pⱼ|² ≤ E|qⱼ|²` both for a real parameter `|δ| ≤ 1` and for an LTI `Δ` of
//! gain ≤ 1 at every frequency (the power spectrum of `p` is `|Δ|²` times that of `q`); the same
//! inequality is the bounded-real lemma of `ε^{−½} q ← ε^{½} p`, so the loop is stable for every
//! such `Δ` by small gain. Hence `E|C x|² ≤ tr(B_wᵀ X B_w)` for every `Δ`: one Lyapunov matrix
//! certifies robust stability and the comfort bound (Petersen & McFarlane, IEEE TAC 39(9), 1994;
//! Bernstein & Haddad, IEEE TAC 34(3), 1989, for the H2/H∞ form). The stabilising solution of the
//! Riccati *equation* gives the least such `X` for fixed multipliers; we search the multipliers.
//!
//! **Synthesis** (state feedback on the design state): the same inequality for the closed loop
//! `A + B_u K` with the cost `C = [C_z; Λ^½ C_l; …]` is the game Riccati equation of
//! full-information H∞ control ([`crate::numerics::riccati::care`] with an indefinite `R`); its gain
//! minimises the bound.

use crate::comfort::controllers::{plant_of, realise_state_feedback, state_feedback_sensors};
use crate::comfort::plant::{Channel, ComfortPlant};
use crate::numerics::interconnect::close;
use crate::numerics::riccati::{care, lyapunov, RiccatiError};
use nalgebra::{DMatrix, DVector};

/// A closed loop `ẋ = A x + B_w w + Σⱼ B_pj pⱼ`, `qⱼ = C_qj x`, with `pⱼ = Δⱼ qⱼ`.
#[derive(Debug, Clone)]
pub struct UncertainLoop {
    pub a: DMatrix<f64>,
    pub b_w: DMatrix<f64>,
    /// `(B_p, C_q)` per channel.
    pub channels: Vec<(DMatrix<f64>, DMatrix<f64>)>,
}

/// A certified bound: `sup_Δ E|C x|² ≤ value²`.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Bound {
    /// `√tr(B_wᵀ X B_w)`, in the unit of `C x`.
    pub value: f64,
    /// The multipliers `εⱼ`.
    pub multipliers: Vec<f64>,
    /// Largest eigenvalue of the inequality's left side at `X` (≤ 0: checked).
    pub lmi_max_eigenvalue: f64,
}

/// Stack `[M₁ M₂ …]` side by side.
fn hcat(blocks: &[&DMatrix<f64>], rows: usize) -> DMatrix<f64> {
    let cols: usize = blocks.iter().map(|b| b.ncols()).sum();
    let mut m = DMatrix::zeros(rows, cols);
    let mut c = 0;
    for b in blocks {
        m.view_mut((0, c), b.shape()).copy_from(b);
        c += b.ncols();
    }
    m
}

/// `blkdiag(−I/ε₁, −I/ε₂, …)` for channels of the given widths.
fn worst_case_weights(widths: &[usize], eps: &[f64]) -> DMatrix<f64> {
    let total: usize = widths.iter().sum();
    let mut r = DMatrix::zeros(total, total);
    let mut i = 0;
    for (w, e) in widths.iter().zip(eps) {
        for k in 0..*w {
            r[(i + k, i + k)] = -1.0 / e;
        }
        i += w;
    }
    r
}

impl UncertainLoop {
    /// The bound of `E|c x|²` at fixed multipliers, verified: `X ⪰ 0` and the inequality's
    /// largest eigenvalue ≤ 0 up to rounding (a billionth of the scale of its terms). The
    /// Riccati equation is solved with `(1 + 10⁻⁹) Q`, so that `X` satisfies the inequality
    /// with margin wherever `Q` acts. (A margin `δI` would be wrong here: it weights every state,
    /// controller states in large units included, and closes the bounded-real gap for no reason.)
    pub fn bound_at(&self, c: &DMatrix<f64>, eps: &[f64]) -> Option<Bound> {
        let n = self.a.nrows();
        let mut q = c.transpose() * c;
        for ((_, c_q), e) in self.channels.iter().zip(eps) {
            q += c_q.transpose() * c_q / *e;
        }
        let q_exact = q.clone();
        q *= 1.0 + 1e-9;
        let b_ps: Vec<&DMatrix<f64>> = self.channels.iter().map(|(b, _)| b).collect();
        let b = hcat(&b_ps, n);
        let widths: Vec<usize> = self.channels.iter().map(|(b, _)| b.ncols()).collect();
        let r = worst_case_weights(&widths, eps);
        let s = care(&self.a, &b, &q, &r, None).ok()?;
        let x = s.x;
        let sym = |m: DMatrix<f64>| (&m + m.transpose()) * 0.5;
        let min_x = sym(x.clone()).symmetric_eigenvalues().min();
        if min_x < -1e-9 * x.norm() {
            return None;
        }
        let mut spread = DMatrix::zeros(n, n);
        for ((b_p, _), e) in self.channels.iter().zip(eps) {
            spread += b_p * b_p.transpose() * *e;
        }
        let xa = &x * &self.a;
        let quadratic = &x * spread * &x;
        let scale = 2.0 * xa.norm() + q_exact.norm() + quadratic.norm();
        let lhs = sym(xa.transpose() + &xa + &q_exact + quadratic);
        let max_eig = lhs.symmetric_eigenvalues().max();
        if max_eig.is_nan() || max_eig > 1e-9 * scale {
            return None;
        }
        let value = (self.b_w.transpose() * &x * &self.b_w)
            .trace()
            .max(0.0)
            .sqrt();
        Some(Bound {
            value,
            multipliers: eps.to_vec(),
            lmi_max_eigenvalue: max_eig,
        })
    }

    /// The least bound over the multipliers ([`minimise_multipliers`]).
    pub fn bound(&self, c: &DMatrix<f64>) -> Option<Bound> {
        let (eps, _) = minimise_multipliers(self.channels.len(), |e| {
            self.bound_at(c, e).map(|b| b.value)
        })?;
        self.bound_at(c, &eps)
    }
}

/// Minimise `f(ε)` over positive multipliers, one coordinate at a time in `log₁₀ ε`: a scan of
/// `[−8, 4]` by half decades for the best feasible value, then golden section to 0.02 decade
/// around it; two sweeps when there are several channels. `None` if nothing is feasible.
pub fn minimise_multipliers(
    count: usize,
    f: impl Fn(&[f64]) -> Option<f64>,
) -> Option<(Vec<f64>, f64)> {
    if count == 0 {
        return f(&[]).map(|v| (Vec::new(), v));
    }
    let mut log_eps = vec![0.0f64; count];
    let eval = |l: &[f64]| {
        let e: Vec<f64> = l.iter().map(|v| 10f64.powf(*v)).collect();
        f(&e).unwrap_or(f64::INFINITY)
    };
    let mut best = f64::INFINITY;
    for _sweep in 0..if count > 1 { 2 } else { 1 } {
        for i in 0..count {
            let at = |v: f64, l: &mut Vec<f64>| {
                l[i] = v;
                eval(l)
            };
            let mut l = log_eps.clone();
            let (mut arg, mut val) = (log_eps[i], eval(&l));
            for k in 0..=24 {
                let v = -8.0 + 0.5 * k as f64;
                let fv = at(v, &mut l);
                if fv < val {
                    (arg, val) = (v, fv);
                }
            }
            if !val.is_finite() {
                continue;
            }
            let r = (5f64.sqrt() - 1.0) / 2.0;
            let (mut a, mut b) = (arg - 0.5, arg + 0.5);
            let (mut c, mut d) = (b - r * (b - a), a + r * (b - a));
            let (mut fc, mut fd) = (at(c, &mut l), at(d, &mut l));
            while b - a > 0.02 {
                if fc <= fd {
                    b = d;
                    (d, fd) = (c, fc);
                    c = b - r * (b - a);
                    fc = at(c, &mut l);
                } else {
                    a = c;
                    (c, fc) = (d, fd);
                    d = a + r * (b - a);
                    fd = at(d, &mut l);
                }
            }
            for (v, fv) in [(c, fc), (d, fd)] {
                if fv < val {
                    (arg, val) = (v, fv);
                }
            }
            log_eps[i] = arg;
            best = val;
        }
    }
    best.is_finite()
        .then(|| (log_eps.iter().map(|v| 10f64.powf(*v)).collect(), best))
}

/// A guaranteed-cost state feedback `u [N] = K x` on a design plant's state.
#[derive(Debug, Clone)]
pub struct StateFeedback {
    pub k: DMatrix<f64>,
    /// The synthesis bound `√tr(B_wᵀ X B_w)` of the whole cost (comfort, weighted limits,
    /// channel terms) for every uncertainty of the channels.
    pub cost_bound: f64,
    pub multipliers: Vec<f64>,
    /// The weights of the limit rows in the cost (0 where the limit holds without one).
    pub limit_weights: Vec<f64>,
}

/// The guaranteed-cost gain at fixed multipliers and limit weights.
fn state_feedback_at(
    g: &ComfortPlant,
    channels: &[Channel],
    eps: &[f64],
    limit_weights: &[f64],
) -> Result<StateFeedback, RiccatiError> {
    let (n, m) = (g.n(), g.b_u.ncols());
    let lam = DMatrix::from_diagonal(&DVector::from_column_slice(limit_weights));
    let mut q = g.c_z.transpose() * &g.c_z + g.c_lim.transpose() * &lam * &g.c_lim;
    let mut r = g.d_lim_u.transpose() * &lam * &g.d_lim_u;
    let mut nx = g.c_lim.transpose() * &lam * &g.d_lim_u;
    for (ch, e) in channels.iter().zip(eps) {
        q += ch.c_q.transpose() * &ch.c_q / *e;
        r += ch.d_q.transpose() * &ch.d_q / *e;
        nx += ch.c_q.transpose() * &ch.d_q / *e;
    }
    let widths: Vec<usize> = channels.iter().map(|c| c.b_p.ncols()).collect();
    let np: usize = widths.iter().sum();
    let mut blocks: Vec<&DMatrix<f64>> = vec![&g.b_u];
    blocks.extend(channels.iter().map(|c| &c.b_p));
    let b = hcat(&blocks, n);
    let mut r_all = DMatrix::zeros(m + np, m + np);
    r_all.view_mut((0, 0), (m, m)).copy_from(&r);
    r_all
        .view_mut((m, m), (np, np))
        .copy_from(&worst_case_weights(&widths, eps));
    let mut n_all = DMatrix::zeros(n, m + np);
    n_all.view_mut((0, 0), (n, m)).copy_from(&nx);
    let s = care(&g.a, &b, &q, &r_all, Some(&n_all))?;
    // The game's solution bounds the cost only if X ⪰ 0, and the design needs A + B_u K stable
    // on its own (the worst-case p is not part of it).
    let k = -s.k.rows(0, m).into_owned();
    let min_x = ((&s.x + s.x.transpose()) * 0.5)
        .symmetric_eigenvalues()
        .min();
    let abscissa = crate::numerics::eig::spectral_abscissa(&(&g.a + &g.b_u * &k));
    if min_x < -1e-9 * s.x.norm() || abscissa.is_nan() || abscissa >= 0.0 {
        return Err(RiccatiError::NoStabilisingSolution(format!(
            "X has eigenvalue {min_x:e}, A + B_u K spectral abscissa {abscissa:e}"
        )));
    }
    Ok(StateFeedback {
        k,
        cost_bound: (g.b_w.transpose() * &s.x * &g.b_w).trace().max(0.0).sqrt(),
        multipliers: eps.to_vec(),
        limit_weights: limit_weights.to_vec(),
    })
}

/// The limit signals' standard deviations on the design road, each over its limit: of the
/// closed loop `A + B_u K`, or, on a plant with a frame ([`ComfortPlant::with_frame`]), of the
/// controller that realises `K` in it ([`realise_state_feedback`]) closed on the sensors it
/// reads. The two differ where the design road has long waves ([`ComfortPlant::new`]): the
/// realised controller takes the road height it measures for the roughness state and has no
/// estimate of the waves' own states, so the gain's feedforward of them is not realised. The
/// weights must then answer for the loop that ships (on 1 m hills over 200 m the gain chosen on
/// its own loop let the realised one ride the seat on its stops).
pub fn limit_sigmas(g: &ComfortPlant, k: &DMatrix<f64>) -> Option<Vec<f64>> {
    let (a, b_w, c) = if g.frame.is_some() {
        let (framed, t) = g.with_frame();
        let (plant, sensors) = (plant_of(g), state_feedback_sensors(g));
        let cl = close(&plant, &sensors, &realise_state_feedback(&framed, &(k * t))).ok()?;
        let n = plant.a.nrows();
        let mut c = &g.d_lim_u * &cl.c_u;
        let mut plant_part = c.columns_mut(0, n);
        plant_part += g.c_lim.columns(0, n);
        (cl.a, cl.b_w, c)
    } else {
        (&g.a + &g.b_u * k, g.b_w.clone(), &g.c_lim + &g.d_lim_u * k)
    };
    let p = lyapunov(&a, &(&b_w * b_w.transpose())).ok()?;
    Some(
        (0..c.nrows())
            .map(|i| {
                (c.row(i) * &p * c.row(i).transpose())[(0, 0)]
                    .max(0.0)
                    .sqrt()
            })
            .collect(),
    )
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GuaranteedError {
    #[error("no multipliers make the guaranteed-cost Riccati equation solvable: the uncertainty is too large for any state feedback")]
    Infeasible,
    #[error("the limit {name} stays at {sigmas:.3} of its limit per standard deviation, above 1/{limit_sigmas}, whatever its weight")]
    Limit {
        name: String,
        sigmas: f64,
        limit_sigmas: f64,
    },
}

/// The weight of each force row (`u/u_max`) in every design's cost: a force at its limit costs
/// as much as 0.01 m/s² of comfort. It removes the delay weight's zero at `s = 0` (its `q`
/// vanishes for a constant command, which would put an eigenvalue of the Hamiltonian at 0 and
/// leave no stabilising solution) without changing the designs measurably.
pub const FORCE_REGULARISATION: f64 = 1e-4;

/// Guaranteed-cost state feedback for the channels: multipliers minimising the bound, then, if
/// a limit's `limit_sigmas` standard deviations exceed the limit on the design road, that limit
/// weighted into the cost (×4 per round) until all hold.
pub fn state_feedback(
    g: &ComfortPlant,
    channels: &[Channel],
    limit_sigmas_required: f64,
) -> Result<StateFeedback, GuaranteedError> {
    state_feedback_weighted(g, channels, limit_sigmas_required, FORCE_REGULARISATION)
}

/// [`state_feedback`] with each force row weighted `force_weight` from the start (an LQR's
/// control weight, when there is no channel).
pub fn state_feedback_weighted(
    g: &ComfortPlant,
    channels: &[Channel],
    limit_sigmas_required: f64,
    force_weight: f64,
) -> Result<StateFeedback, GuaranteedError> {
    let nl = g.c_lim.nrows();
    let mut weights: Vec<f64> = g
        .limit_names
        .iter()
        .map(|n| {
            if n.starts_with("force_") {
                force_weight
            } else {
                0.0
            }
        })
        .collect();
    let base = weights.clone();
    for _round in 0..16 {
        let (eps, _) = minimise_multipliers(channels.len(), |e| {
            state_feedback_at(g, channels, e, &weights)
                .ok()
                .map(|s| s.cost_bound)
        })
        .ok_or(GuaranteedError::Infeasible)?;
        let sf = state_feedback_at(g, channels, &eps, &weights)
            .map_err(|_| GuaranteedError::Infeasible)?;
        let sigmas = limit_sigmas(g, &sf.k).ok_or(GuaranteedError::Infeasible)?;
        let over: Vec<usize> = (0..nl)
            .filter(|&i| sigmas[i] * limit_sigmas_required > 1.0)
            .collect();
        if over.is_empty() {
            return Ok(sf);
        }
        // Start a violated limit's weight at the comfort cost per unit of its variance.
        let comfort = {
            let a = &g.a + &g.b_u * &sf.k;
            let p = lyapunov(&a, &(&g.b_w * g.b_w.transpose()))
                .map_err(|_| GuaranteedError::Infeasible)?;
            (&g.c_z * p * g.c_z.transpose()).trace()
        };
        for i in over {
            weights[i] = if weights[i] <= base[i] {
                comfort / sigmas[i].powi(2)
            } else {
                weights[i] * 4.0
            };
        }
    }
    let sf = state_feedback_at(g, channels, &vec![1.0; channels.len()], &weights)
        .map_err(|_| GuaranteedError::Infeasible)?;
    let sigmas = limit_sigmas(g, &sf.k).unwrap_or_default();
    let (i, worst) = sigmas
        .iter()
        .enumerate()
        .fold((0, 0.0), |a, (i, s)| if *s > a.1 { (i, *s) } else { a });
    Err(GuaranteedError::Limit {
        name: g.limit_names.get(i).cloned().unwrap_or_default(),
        sigmas: worst,
        limit_sigmas: limit_sigmas_required,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::numerics::hinf_norm::{Analysis, Lti};

    /// On the state feedbacks' design (a frame, the car's long waves) the limits are the
    /// realised controller's. The gain whose weights answered for its own loop (the plant
    /// without its frame, whose limits are `A + B_u K`'s) holds every limit there but not as
    /// the controller that realises it, which has no estimate of the long waves (their
    /// feedforward lost: the rear strokes and the seat force beyond their limits at 3 σ); the
    /// synthesis on the framed plant holds them as realised.
    #[test]
    fn the_limits_are_checked_on_the_controller_that_realises_the_gain() {
        use crate::comfort::designs::Context;
        use crate::shipping::design::ComfortDesign;
        let d = ComfortDesign::from_json(include_str!("../../designs/comfort.json"))
            .unwrap()
            .for_state_feedback();
        let p = vehicle::VehicleParams::default();
        let ctx = Context {
            params: &p,
            design: &d,
        };
        let (g, delay) = ctx
            .plant()
            .with_delay_weight(d.unmodelled_delay, &crate::comfort::plant::force_limits(&d));
        assert!(g.frame.is_some() && !g.layout.waves.is_empty());
        let holds = |sigmas: &[f64]| sigmas.iter().all(|s| s * d.limit_sigmas <= 1.0 + 1e-9);
        let unframed = ComfortPlant {
            frame: None,
            ..g.clone()
        };
        let own = state_feedback(&unframed, std::slice::from_ref(&delay), d.limit_sigmas).unwrap();
        assert!(holds(&limit_sigmas(&unframed, &own.k).unwrap()));
        let realised = limit_sigmas(&g, &own.k).unwrap();
        assert!(!holds(&realised), "{realised:?}");
        let sf = state_feedback(&g, &[delay], d.limit_sigmas).unwrap();
        let realised = limit_sigmas(&g, &sf.k).unwrap();
        assert!(holds(&realised), "{realised:?}");
    }

    /// A scalar loop `ẋ = −a x + b w + h p`, `q = e x`, `z = x`, `p = δ q`: the bound at the
    /// best multiplier matches the worst real δ (the closed form `b²/(2(a − h e δ))` at
    /// `δ = 1`) within the S-procedure's slack, and every δ in [−1, 1] stays below it.
    #[test]
    fn the_bound_covers_every_uncertainty_and_is_tight_for_a_scalar_loop() {
        let m = |v: f64| DMatrix::from_element(1, 1, v);
        let (a, b, h, e) = (2.0, 1.0, 0.5, 1.0);
        let sys = UncertainLoop {
            a: m(-a),
            b_w: m(b),
            channels: vec![(m(h), m(e))],
        };
        let bound = sys.bound(&m(1.0)).unwrap();
        assert!(bound.lmi_max_eigenvalue <= 0.0);
        for delta in [-1.0, -0.5, 0.0, 0.5, 1.0] {
            let exact = (b * b / (2.0 * (a - h * e * delta))).sqrt();
            assert!(
                exact <= bound.value,
                "δ = {delta}: {exact} > {}",
                bound.value
            );
        }
        let worst = (b * b / (2.0 * (a - h * e))).sqrt();
        assert!(
            bound.value <= worst * 1.05,
            "{} vs the worst {worst}",
            bound.value
        );
        // A channel too strong for any multiplier (h e > a) has no bound.
        let unstable = UncertainLoop {
            channels: vec![(m(3.0), m(1.0))],
            ..sys
        };
        assert!(unstable.bound(&m(1.0)).is_none());
    }

    /// On a 4-state mass–spring loop with a real parameter in the stiffness, the bound holds at
    /// a dense grid of parameter values (H2 norms by the Gramian, a second computation).
    #[test]
    fn the_bound_holds_on_a_dense_parameter_grid() {
        let a0 = DMatrix::from_row_slice(
            4,
            4,
            &[
                0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, -20.0, 10.0, -1.0, 0.5, 10.0, -15.0, 0.5,
                -0.8,
            ],
        );
        // δ scales the coupling spring by ±30 %: ΔA = H δ E.
        let h = DMatrix::from_column_slice(4, 1, &[0.0, 0.0, -1.0, 1.0]);
        let e = DMatrix::from_row_slice(1, 4, &[3.0, -3.0, 0.0, 0.0]);
        let bw = DMatrix::from_column_slice(4, 1, &[0.0, 0.0, 1.0, 0.0]);
        let c = DMatrix::from_row_slice(1, 4, &[0.0, 1.0, 0.0, 0.0]);
        let sys = UncertainLoop {
            a: a0.clone(),
            b_w: bw.clone(),
            channels: vec![(h.clone(), e.clone())],
        };
        let bound = sys.bound(&c).unwrap();
        let mut worst: f64 = 0.0;
        for k in 0..=100 {
            let delta = -1.0 + 0.02 * k as f64;
            let lti = Lti::new(
                &a0 + &h * delta * &e,
                bw.clone(),
                c.clone(),
                DMatrix::zeros(1, 1),
            );
            worst = worst.max(lti.h2_norm().unwrap());
        }
        assert!(worst <= bound.value, "{worst} > {}", bound.value);
    }
}
