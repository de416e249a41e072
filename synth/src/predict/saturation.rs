//! The actuators' force limits as a sector nonlinearity: is the saturated loop stable, from any
//! state and for any road, and back to the linear loop once the commands are within the limits?
//!
//! Each actuator applies `sat(u_i) = u_i − dz(u_i)`: its dead zone `dz` lies in the sector
//! `[0, 1]` (`dz(u) (u − dz(u)) ≥ 0`), one per actuator. Broken at the actuators, the loop is
//! `u = L f` with the applied forces `f` (`Loop::loop_gain`, positive feedback, the road
//! aside), so the saturated loop is `u = −(I − L)⁻¹ L dz(u)`. With the linear loop stable it is
//! absolutely stable — for every dead zone in the sector, any limits in any combination, an
//! actuator lost among them (slope 1: no force) — when, for a diagonal `M ≻ 0` and every `ω`,
//!
//! `He(M (I − L(jω))⁻¹) ≻ 0`, equivalently `2M − He(M L(jω)) ≻ 0`
//!
//! (the multivariable circle criterion; `M` the multiplier of the decoupled sector's quadratic
//! constraint `dz(u)ᵀ M (u − dz(u)) ≥ 0`: Khalil, *Nonlinear Systems*, 3rd ed., Th. 7.1 and its
//! multivariable form §7.1; Zames & Falb's constant multipliers). It implies a finite gain from
//! the road to every signal, so once the road lets the commands back within the limits the
//! loop is the linear one again. The diagonal entries alone need `Re L_ii(jω) < 1` (in
//! negative-feedback terms, each actuator's loop right of `−1`): where one is not, no diagonal
//! multiplier exists, and the check says which actuator and where.
//!
//! `M` is the best of a small SDP ([`crate::numerics::lmi`]) on a coarse grid of frequencies, the
//! largest `t` with `2M − He(M L(jω_k)) ⪰ t I`, `M ⪯ I`; the certificate is that `M` checked
//! on a fine grid, as the delay margins are ([`Loop::delay_margin`]): between grid points nothing
//! is claimed beyond the margin's continuity. Where no diagonal `M` exists (the H∞ designs' seat
//! loop), a Popov multiplier `M + jωQ` found none either (tried; `docs/comfort-designs.md`).

use crate::numerics::lmi::{Affine, Problem};
use crate::predict::continuous::Loop;
use nalgebra::{Complex, DMatrix};
use serde::Serialize;
use std::f64::consts::PI;

/// Frequencies of the multiplier's SDP \[rad/s\]: 241 log-spaced over 10⁻³…10⁵ (and 0).
const SDP_FREQUENCIES: usize = 241;
/// Frequencies the multiplier is checked at: 4000 log-spaced over 10⁻³…10⁵ rad/s (about 500 a
/// decade, 0.5 % apart), and 0: twice the anti-windup check's ([`crate::thesis::anti_windup`]).
const CHECKED_FREQUENCIES: usize = 4001;

/// The circle criterion of a loop's force limits (`saturation` in a comfort certificate).
#[derive(Debug, Clone, Serialize)]
pub struct SaturationCheck {
    /// `"circle criterion"`: the loop absolutely stable for any dead zone of the actuators;
    /// `"not certified"`, with why.
    pub verdict: &'static str,
    /// The diagonal multiplier `M` (its largest entry 1 or less), where one was found.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub multiplier: Vec<f64>,
    /// The least eigenvalue of `2M − He(M L(jω))` over the checked frequencies, over the largest
    /// entry of `M` (> 0 holds), where a multiplier was found.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub margin: Option<f64>,
    /// Where the margin is least (or the diagonal condition fails worst) \[Hz\], where known.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub worst_frequency_hz: Option<f64>,
    /// The frequencies checked (none for model recovery).
    pub frequencies: usize,
    /// Model recovery: the spectral abscissa \[rad/s\] of the prediction model on the states
    /// the clamped commands reach, and how many they are.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub recovery_abscissa: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub recovery_states: Option<usize>,
    #[serde(skip_serializing_if = "String::is_empty")]
    pub why: String,
}

impl SaturationCheck {
    /// Proven stable at any force limits: by the circle criterion, or by model recovery.
    pub fn holds(&self) -> bool {
        matches!(self.verdict, "circle criterion" | "model recovery")
    }

    /// A predictor's model-recovery anti-windup with no gain on its state
    /// (`fmu-controller/src/predictor.rs`): what the clamp takes from the commands, `dz(u)`,
    /// drives `ζ̇ = A ζ + B dz(u)` in the prediction model `(A, B)`, and the command is the
    /// design's for the predicted state plus `ζ`. On the model `x + ζ` obeys
    /// `ẋ + ζ̇ = A (x + ζ) + B u`: the unconstrained car, so the design's loop on it is the
    /// linear loop (stable, and bounded for a bounded road), and the saturated loop is that loop
    /// plus `ζ` driven by a bounded `dz`. `ζ` starts at zero and stays in the states `B`
    /// reaches through `A` (a coordinate block no other state or input outside it moves, so
    /// its spectrum is part of `A`'s): if `A` is Hurwitz there, `ζ` is bounded whatever the
    /// limits and decays at that rate once the commands are back within them (Teel & Kapoor's
    /// L2 anti-windup for exponentially stable plants; Zaccarian & Teel, *Modern Anti-windup
    /// Synthesis*, 2011, §3.3, with no gain on the anti-windup state). This is a proof on the
    /// prediction model, the delay matched; off it, the co-simulations say what happens.
    ///
    /// `whose` names the compensator in the certificate's `why` (e.g. "the predictor's").
    pub fn model_recovery(a: &DMatrix<f64>, b: &DMatrix<f64>, whose: &str) -> Self {
        let n = a.nrows();
        let mut reached: Vec<bool> = (0..n).map(|i| b.row(i).iter().any(|v| *v != 0.0)).collect();
        let mut grown = true;
        while grown {
            grown = false;
            for j in 0..n {
                if !reached[j] && (0..n).any(|i| reached[i] && a[(j, i)] != 0.0) {
                    (reached[j], grown) = (true, true);
                }
            }
        }
        let states: Vec<usize> = (0..n).filter(|&i| reached[i]).collect();
        let block = DMatrix::from_fn(states.len(), states.len(), |i, j| a[(states[i], states[j])]);
        let abscissa = crate::numerics::eig::spectral_abscissa(&block);
        let holds = abscissa < 0.0;
        SaturationCheck {
            verdict: if holds {
                "model recovery"
            } else {
                "not certified"
            },
            multiplier: Vec::new(),
            margin: None,
            worst_frequency_hz: None,
            frequencies: 0,
            recovery_abscissa: Some(abscissa),
            recovery_states: Some(states.len()),
            why: format!(
                "{whose} model-recovery anti-windup: the saturated loop is the linear one on the \
                 unconstrained model plus zeta' = A zeta + B dz(u), whose {} states reached by the \
                 commands have the spectral abscissa {abscissa:.4} rad/s{}",
                states.len(),
                if holds {
                    ": bounded at any force limits, and back to the linear loop once the \
                     commands are within them"
                } else {
                    ", not below 0: no bound"
                }
            ),
        }
    }

    /// An anti-windup design's: its decoupled loop's own circle criterion (thesis Th. 5.3, the
    /// multiplier `w` of its sector LMI, re-checked on `check.frequencies` frequencies).
    pub fn anti_windup(w: &[f64], check: &crate::thesis::anti_windup::CircleCheck) -> Self {
        let scale = w.iter().cloned().fold(0.0, f64::max);
        SaturationCheck {
            verdict: if check.holds() {
                "circle criterion"
            } else {
                "not certified"
            },
            multiplier: w.iter().map(|v| v / scale).collect(),
            margin: Some(check.min_margin),
            worst_frequency_hz: None,
            frequencies: check.frequencies,
            recovery_abscissa: None,
            recovery_states: None,
            why: "of the anti-windup compensator's loop (thesis Th. 5.3): the saturated loop is \
                  the linear one plus that loop driven by the dead zones"
                .into(),
        }
    }
}

/// `0` and `n − 1` log-spaced frequencies over 10⁻³…10⁵ rad/s.
fn grid(n: usize) -> Vec<f64> {
    std::iter::once(0.0)
        .chain((0..n - 1).map(|k| 10f64.powf(-3.0 + 8.0 * k as f64 / (n - 2) as f64)))
        .collect()
}

/// `2M − He(M L)` for the diagonal `m`, as a real symmetric matrix `[[Re, −Im], [Im, Re]]` (its
/// eigenvalues are the Hermitian matrix's, each twice).
fn embedded(m: &[f64], l: &DMatrix<Complex<f64>>) -> DMatrix<f64> {
    let n = m.len();
    let ml = DMatrix::from_fn(n, n, |i, j| l[(i, j)] * m[i]);
    let mut h = -(&ml + ml.adjoint());
    for (i, mi) in m.iter().enumerate() {
        h[(i, i)] += 2.0 * mi;
    }
    let mut e = DMatrix::zeros(2 * n, 2 * n);
    e.view_mut((0, 0), (n, n)).copy_from(&h.map(|c| c.re));
    e.view_mut((n, n), (n, n)).copy_from(&h.map(|c| c.re));
    e.view_mut((n, 0), (n, n)).copy_from(&h.map(|c| c.im));
    e.view_mut((0, n), (n, n)).copy_from(&h.map(|c| -c.im));
    e
}

fn least_eigenvalue(m: DMatrix<f64>) -> f64 {
    m.symmetric_eigenvalues().min()
}

/// The best diagonal multiplier on these loop gains (`max M = 1`), or why none.
fn multiplier(gains: &[DMatrix<Complex<f64>>]) -> Result<Vec<f64>, String> {
    let n = gains[0].nrows();
    let mut p = Problem::new();
    let m: Vec<_> = (0..n).map(|_| p.scalar()).collect();
    let t = p.scalar();
    // Every constraint strict by a small margin: the solver's point is checked strictly.
    const EPS: f64 = 1e-7;
    for (k, l) in gains.iter().enumerate() {
        let unit = |i: usize| {
            let mut e = vec![0.0; n];
            e[i] = 1.0;
            embedded(&e, l)
        };
        let f = Affine::combination(&m, unit)
            .sub(&t.expr().map_scalar(&DMatrix::identity(2 * n, 2 * n)));
        p.positive_definite(&format!("circle at frequency {k}"), f, EPS);
    }
    let one = Affine::constant(DMatrix::from_element(1, 1, 1.0));
    for mi in &m {
        p.positive_definite("M > 0", mi.expr(), EPS);
        p.positive_definite("M <= I", one.sub(&mi.expr()), EPS);
    }
    p.minimise(&t, -1.0);
    let solution = p.solve().map_err(|e| e.to_string())?;
    let least = t.value(&solution.x)[(0, 0)];
    if least.is_nan() || least <= 0.0 {
        return Err(format!(
            "the least eigenvalue of 2M - He(M L) is at most {least:.3e} on the SDP's frequencies"
        ));
    }
    Ok(m.iter().map(|v| v.value(&solution.x)[(0, 0)]).collect())
}

/// The circle criterion of `lp`'s force limits (its linear loop stable: [`Loop::new`]).
pub fn saturation_check(lp: &Loop) -> SaturationCheck {
    let fine = grid(CHECKED_FREQUENCIES);
    let gains: Vec<_> = fine.iter().map(|&w| lp.loop_gain(w)).collect();
    let hz = |w: f64| w / (2.0 * PI);
    // The necessary diagonal condition: Re L_ii < 1 everywhere.
    let (mut worst, mut at, mut which) = (f64::NEG_INFINITY, 0.0, 0);
    for (w, l) in fine.iter().zip(&gains) {
        for i in 0..l.nrows() {
            if l[(i, i)].re > worst {
                (worst, at, which) = (l[(i, i)].re, *w, i);
            }
        }
    }
    let refused = |why: String| SaturationCheck {
        verdict: "not certified",
        multiplier: Vec::new(),
        margin: None,
        worst_frequency_hz: Some(hz(at)),
        frequencies: fine.len(),
        recovery_abscissa: None,
        recovery_states: None,
        why,
    };
    if worst >= 1.0 {
        return refused(format!(
            "actuator {}'s own loop reaches Re L = {worst:.3} >= 1 at {:.3} Hz: no diagonal \
             multiplier exists (its loop gain there, in negative-feedback terms, is left of -1)",
            vehicle::model::ACTUATORS[which],
            hz(at)
        ));
    }
    let coarse: Vec<_> = grid(SDP_FREQUENCIES)
        .iter()
        .map(|&w| lp.loop_gain(w))
        .collect();
    let m = match multiplier(&coarse) {
        Ok(m) => m,
        Err(e) => return refused(format!("no diagonal multiplier found: {e}")),
    };
    let scale = m.iter().cloned().fold(0.0, f64::max);
    let (mut margin, mut at) = (f64::INFINITY, 0.0);
    for (w, l) in fine.iter().zip(&gains) {
        let e = least_eigenvalue(embedded(&m, l)) / scale;
        if e < margin {
            (margin, at) = (e, *w);
        }
    }
    let holds = margin > 0.0;
    SaturationCheck {
        verdict: if holds {
            "circle criterion"
        } else {
            "not certified"
        },
        multiplier: m,
        margin: Some(margin),
        worst_frequency_hz: Some(hz(at)),
        frequencies: fine.len(),
        recovery_abscissa: None,
        recovery_states: None,
        why: if holds {
            String::new()
        } else {
            format!(
                "the best diagonal multiplier leaves 2M - He(M L) with eigenvalue {margin:.3e} \
                 (relative) at {:.3} Hz",
                hz(at)
            )
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The real embedding has the Hermitian matrix's eigenvalues, each twice (nalgebra's
    /// complex Hermitian eigensolver as the reference).
    #[test]
    fn the_embedding_has_the_hermitian_eigenvalues() {
        let c = |re: f64, im: f64| Complex::new(re, im);
        let l = DMatrix::from_row_slice(
            3,
            3,
            &[
                c(0.3, -0.2),
                c(1.5, 0.7),
                c(-0.4, 0.1),
                c(0.2, 0.9),
                c(-1.1, 0.0),
                c(0.6, -0.8),
                c(0.0, 0.3),
                c(2.0, 1.0),
                c(0.5, 0.5),
            ],
        );
        let m = [0.7, 1.0, 0.2];
        let md = DMatrix::from_diagonal(&nalgebra::DVector::from_iterator(
            3,
            m.iter().map(|v| c(*v, 0.0)),
        ));
        let ml = &md * &l;
        let h = &md * c(2.0, 0.0) - (&ml + ml.adjoint());
        let mut reference: Vec<f64> = h.symmetric_eigenvalues().iter().copied().collect();
        let mut twice: Vec<f64> = embedded(&m, &l)
            .symmetric_eigenvalues()
            .iter()
            .copied()
            .collect();
        reference.sort_by(f64::total_cmp);
        twice.sort_by(f64::total_cmp);
        for (k, r) in reference.iter().enumerate() {
            for e in &twice[2 * k..2 * k + 2] {
                assert!((e - r).abs() < 1e-12, "{twice:?} vs {reference:?}");
            }
        }
    }

    /// Model recovery reads `A` only where the commands reach: a stable car block driven by
    /// `B`, beside an integrator (a road state) that drives the car but that no command
    /// reaches, holds; an unstable mode among the reached ones does not.
    #[test]
    fn model_recovery_reads_the_states_the_commands_reach() {
        // x1' = -x1 + x3 + u, x2' = x1 - 2 x2, x3' = 0 (driven by nothing, drives x1).
        let a = DMatrix::from_row_slice(3, 3, &[-1.0, 0.0, 1.0, 1.0, -2.0, 0.0, 0.0, 0.0, 0.0]);
        let b = DMatrix::from_row_slice(3, 1, &[1.0, 0.0, 0.0]);
        let c = SaturationCheck::model_recovery(&a, &b, "the");
        assert!(c.holds(), "{c:?}");
        assert_eq!(c.recovery_states, Some(2));
        assert!((c.recovery_abscissa.unwrap() + 1.0).abs() < 1e-12);
        // The reached x2 unstable: refused.
        let mut unstable = a.clone();
        unstable[(1, 1)] = 0.5;
        let c = SaturationCheck::model_recovery(&unstable, &b, "the");
        assert!(!c.holds() && c.why.contains("no bound"), "{c:?}");
        // The integrator reached (a command drives it): refused, abscissa 0.
        let b3 = DMatrix::from_row_slice(3, 1, &[1.0, 0.0, 1.0]);
        assert!(!SaturationCheck::model_recovery(&a, &b3, "the").holds());
    }

    /// `L = [[1/2, 10], [0, 1/2]]`: `2M − He(M L) = [[m₁, −10 m₁], [−10 m₁, m₂]]`, positive
    /// definite exactly when `m₂ > 100 m₁`. No scalar multiplier works; the SDP finds a diagonal
    /// one with `m₂ = 1` (the bound) and `m₁ < 0.01`, and the least eigenvalue it maximises is
    /// the analytic one.
    #[test]
    fn the_multiplier_is_the_diagonal_one_that_exists() {
        let l = DMatrix::from_row_slice(2, 2, &[0.5, 10.0, 0.0, 0.5]).map(|v| Complex::new(v, 0.0));
        assert!(least_eigenvalue(embedded(&[1.0, 1.0], &l)) < 0.0);
        let m = multiplier(std::slice::from_ref(&l)).expect("a multiplier");
        assert!(
            (m[1] - 1.0).abs() < 1e-5 && m[0] > 0.0 && m[0] < 0.01,
            "{m:?}"
        );
        // [[m1, −10 m1], [−10 m1, 1]]: its least eigenvalue is largest at m1 = 1/(101 + …);
        // whatever the optimum, the one found is positive and the analytic value at m.
        let analytic = {
            let (a, b, d) = (m[0], -10.0 * m[0], m[1]);
            // det / λ_max: no cancellation.
            (a * d - b * b) / ((a + d) / 2.0 + (((a - d) / 2.0).powi(2) + b * b).sqrt())
        };
        let found = least_eigenvalue(embedded(&m, &l));
        assert!(
            found > 0.0 && (found - analytic).abs() < 1e-12 * analytic,
            "{found} vs {analytic}"
        );
    }
}
