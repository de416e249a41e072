//! `delay_sf`: delay-dependent H∞ state feedback
//! for an input delay `τ` (thesis Prop. 7.1, whose proof is unfinished), by the descriptor
//! Lyapunov–Krasovskii functional with Jensen's inequality (Fridman & Shaked, IEEE TAC 47(2),
//! 2002):
//! `V = xᵀP₁x + ∫_{t−τ}^t xᵀSx + τ ∫_{−τ}^0 ∫_{t+θ}^t ẋᵀRẋ`, the descriptor identity
//! `0 = 2(xᵀP₂ᵀ + ẋᵀP₃ᵀ)(A x + B_u K x(t−τ) + B_w w − ẋ)` with `P₃ = ε P₂`, and the congruence
//! `X = P₂⁻¹`, `Y = K X`, `P̄₁ = XᵀP₁X`, `S̄ = XᵀSX`, `R̄ = XᵀRX`:
//! ```text
//! [ S̄ − R̄ + He(AX)   P̄₁ − X + εXᵀAᵀ      R̄ + B_uY    B_w    XᵀC_zᵀ   ]
//! [       *          τ²R̄ − ε He(X)       εB_uY       εB_w      0     ]
//! [       *                *            −S̄ − R̄        0     YᵀD_zuᵀ  ]  ≺ 0
//! [       *                *               *         −γI     D_zwᵀ   ]
//! [       *                *               *           *      −γI    ]
//! ```
//! with `P̄₁, S̄, R̄ ≻ 0`: then `ẋ = A x + B_u K x(t − τ) + B_w w` is stable with `‖z‖ < γ‖w‖`.

use crate::numerics::lmi::{Affine, LmiError, Problem};
use crate::thesis::generalized::{GeneralizedPlant, FORCE_UNIT};
use nalgebra::{Complex, DMatrix};

#[derive(Debug, Clone)]
pub struct DelayFeedback {
    /// `u(t) [N] = K x(t)`, applied at `t + τ`.
    pub k: DMatrix<f64>,
    pub gamma: f64,
    pub tau: f64,
    pub epsilon: f64,
}

pub fn delay_sf(
    g: &GeneralizedPlant,
    tau: f64,
    epsilon: f64,
    eps: f64,
) -> Result<DelayFeedback, LmiError> {
    let (n, nw, nz, nu) = (g.n(), g.b_w.ncols(), g.c_z.nrows(), g.b_u.ncols());
    let mut p = Problem::new();
    let (p1, s, r) = (p.symmetric(n), p.symmetric(n), p.symmetric(n));
    let (xv, yv, gamma) = (p.full(n, n), p.full(nu, n), p.scalar());
    let (p1, s, r, x, y) = (p1.expr(), s.expr(), r.expr(), xv.expr(), yv.expr());
    let ax = x.left(&g.a);
    let by = y.left(&g.b_u);
    let minus_gamma = |k: usize| gamma.expr().map_scalar(&(-DMatrix::identity(k, k)));
    let lmi = Affine::symmetric_blocks(&[
        vec![
            Some(s.sub(&r).add(&ax.he())),
            Some(p1.sub(&x).add(&ax.t().scale(epsilon))),
            Some(r.add(&by)),
            Some(Affine::constant(g.b_w.clone())),
            Some(x.left(&g.c_z).t()),
        ],
        vec![
            None,
            Some(r.scale(tau * tau).sub(&x.he().scale(epsilon))),
            Some(by.scale(epsilon)),
            Some(Affine::constant(&g.b_w * epsilon)),
            Some(Affine::zeros(n, nz)),
        ],
        vec![
            None,
            None,
            Some(s.add(&r).scale(-1.0)),
            Some(Affine::zeros(n, nw)),
            Some(y.left(&g.d_zu).t()),
        ],
        vec![
            None,
            None,
            None,
            Some(minus_gamma(nw)),
            Some(Affine::constant(g.d_zw.transpose())),
        ],
        vec![None, None, None, None, Some(minus_gamma(nz))],
    ]);
    p.negative_definite(
        "delay-dependent bounded-real LMI (descriptor, Jensen)",
        lmi,
        eps,
    );
    for (name, m) in [("P1 ≻ 0", &p1), ("S ≻ 0", &s), ("R ≻ 0", &r)] {
        p.positive_definite(name, m.clone(), eps);
    }
    p.minimise(&gamma, 1.0);
    let sol = p.solve()?;
    let xm = xv.value(&sol.x);
    let x_inv = xm
        .try_inverse()
        .ok_or(LmiError::Setup("X is singular".into()))?;
    Ok(DelayFeedback {
        k: yv.value(&sol.x) * x_inv * FORCE_UNIT,
        gamma: gamma.value(&sol.x)[(0, 0)],
        tau,
        epsilon,
    })
}

/// `G(jω) = K (jωI − A)⁻¹ B`: the loop broken at the delayed actuator input (positive
/// feedback, `ẋ = A x + B K x(t − τ)`).
fn loop_gain(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    k: &DMatrix<f64>,
    omega: f64,
) -> Option<DMatrix<Complex<f64>>> {
    let n = a.nrows();
    let m = DMatrix::<Complex<f64>>::identity(n, n) * Complex::new(0.0, omega)
        - a.map(|v| Complex::new(v, 0.0));
    let x = m.lu().solve(&b.map(|v| Complex::new(v, 0.0)))?;
    Some(k.map(|v| Complex::new(v, 0.0)) * x)
}

fn eigenvalues(m: DMatrix<Complex<f64>>) -> Vec<Complex<f64>> {
    // The complex Schur form is triangular: its diagonal is always available.
    nalgebra::Schur::new(m)
        .eigenvalues()
        .map(|e| e.iter().copied().collect())
        .unwrap_or_default()
}

fn count_outside_unit_circle(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    k: &DMatrix<f64>,
    omega: f64,
) -> usize {
    loop_gain(a, b, k, omega).map_or(usize::MAX, |g| {
        eigenvalues(g).iter().filter(|l| l.norm() > 1.0).count()
    })
}

/// Delay margin of `ẋ = A x + B K x(t − τ)` (stable at `τ = 0`): the smallest `τ > 0` for which a
/// root reaches the imaginary axis. At a crossing `s = jω`, `det(I − e^{−jωτ} G(jω)) = 0`: `G(jω)`
/// has an eigenvalue `λ` on the unit circle and `τ = (arg λ mod 2π)/ω`. Crossing frequencies are
/// where the number of eigenvalues outside the unit circle changes: located on a log grid of
/// 20001 points in `[1e-3, 1e5]` rad/s and refined by bisection. `f64::INFINITY` if there is none
/// (delay-independent stability on that band). Requires `A + B K` Hurwitz (checked).
pub fn delay_margin(a: &DMatrix<f64>, b: &DMatrix<f64>, k: &DMatrix<f64>) -> Result<f64, String> {
    let abscissa = (a + b * k)
        .complex_eigenvalues()
        .iter()
        .map(|l| l.re)
        .fold(f64::NEG_INFINITY, f64::max);
    if abscissa >= 0.0 {
        return Err(format!(
            "not stable without delay: spectral abscissa of A + BK is {abscissa:e}"
        ));
    }
    let grid: Vec<f64> = (0..=20000)
        .map(|i| 10f64.powf(-3.0 + 8.0 * i as f64 / 20000.0))
        .collect();
    let counts: Vec<usize> = grid
        .iter()
        .map(|&w| count_outside_unit_circle(a, b, k, w))
        .collect();
    let mut margin = f64::INFINITY;
    for i in 0..grid.len() - 1 {
        if counts[i] == counts[i + 1] {
            continue;
        }
        let (mut lo, mut hi) = (grid[i], grid[i + 1]);
        for _ in 0..60 {
            let mid = (lo * hi).sqrt();
            if count_outside_unit_circle(a, b, k, mid) == counts[i] {
                lo = mid
            } else {
                hi = mid
            }
        }
        let omega = (lo * hi).sqrt();
        let g = loop_gain(a, b, k, omega).ok_or("singular jωI − A")?;
        let lambda = eigenvalues(g)
            .into_iter()
            .min_by(|x, y| (x.norm() - 1.0).abs().total_cmp(&(y.norm() - 1.0).abs()))
            .ok_or("no eigenvalues")?;
        let phase = lambda.arg().rem_euclid(2.0 * std::f64::consts::PI);
        margin = margin.min(phase / omega);
    }
    Ok(margin)
}

/// `max σ(T(jω))` of the delayed closed loop, `T = (C_z + D_zu K e^{−jωτ})(jωI − A − B_u K
/// e^{−jωτ})⁻¹ B_w + D_zw` (scaled units, `K` in the plant's N): a log grid of 4001 points in
/// `[1e-2, 1e4]` rad/s refined by golden section around the largest — a lower bound of the norm,
/// which has no finite-dimensional Hamiltonian test.
pub fn delayed_hinf_sweep(g: &GeneralizedPlant, k: &DMatrix<f64>, tau: f64) -> f64 {
    let n = g.n();
    let ks = k / FORCE_UNIT;
    let c = |m: &DMatrix<f64>| m.map(|v| Complex::new(v, 0.0));
    let (a, bu, bw, cz, dzu, dzw, kc) = (
        c(&g.a),
        c(&g.b_u),
        c(&g.b_w),
        c(&g.c_z),
        c(&g.d_zu),
        c(&g.d_zw),
        c(&ks),
    );
    let sigma = |w: f64| {
        let e = Complex::from_polar(1.0, -w * tau);
        let m = DMatrix::<Complex<f64>>::identity(n, n) * Complex::new(0.0, w) - &a - &bu * &kc * e;
        match m.lu().solve(&bw) {
            Some(x) => ((&cz + &dzu * &kc * e) * x + &dzw).singular_values().max(),
            None => f64::INFINITY,
        }
    };
    let grid: Vec<f64> = (0..=4000)
        .map(|i| 10f64.powf(-2.0 + 6.0 * i as f64 / 4000.0))
        .collect();
    let values: Vec<f64> = grid.iter().map(|&w| sigma(w)).collect();
    let i = (0..values.len())
        .max_by(|&x, &y| values[x].total_cmp(&values[y]))
        .unwrap();
    let (mut lo, mut hi) = (
        grid[i.saturating_sub(1)].ln(),
        grid[(i + 1).min(grid.len() - 1)].ln(),
    );
    let r = (5f64.sqrt() - 1.0) / 2.0;
    let mut best = values[i].max(sigma(0.0));
    for _ in 0..60 {
        let (c1, c2) = (hi - r * (hi - lo), lo + r * (hi - lo));
        let (f1, f2) = (sigma(c1.exp()), sigma(c2.exp()));
        best = best.max(f1).max(f2);
        if f1 >= f2 {
            hi = c2
        } else {
            lo = c1
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shipping::design::Design;

    #[test]
    fn delay_margin_of_a_scalar_loop_matches_the_closed_form() {
        // ẋ = −x − 2 x(t − τ): ω* = √3, τ* = (π − atan √3)/√3 = 2π/(3√3).
        let (a, b, k) = (
            DMatrix::from_element(1, 1, -1.0),
            DMatrix::from_element(1, 1, 1.0),
            DMatrix::from_element(1, 1, -2.0),
        );
        let tau = delay_margin(&a, &b, &k).unwrap();
        let exact = 2.0 * std::f64::consts::PI / (3.0 * 3f64.sqrt());
        assert!((tau - exact).abs() < 1e-9, "{tau} vs {exact}");
        // |k| < |a|: stable for every delay.
        assert_eq!(
            delay_margin(&a, &b, &DMatrix::from_element(1, 1, -0.5)).unwrap(),
            f64::INFINITY
        );
        // Unstable without delay: refused.
        assert!(delay_margin(&a, &b, &DMatrix::from_element(1, 1, 2.0)).is_err());
    }

    /// The largest delay for which the LMI is feasible (ε of the design file), by bisection:
    /// `cargo test --release -p synth largest_feasible_delay -- --ignored --nocapture` (~1 min).
    #[test]
    #[ignore]
    fn largest_feasible_delay() {
        let d = Design::default();
        let g = GeneralizedPlant::new(&vehicle::VehicleParams::default(), &d);
        let feasible = |tau: f64| delay_sf(&g, tau, d.delay_epsilon, d.lmi_margin).is_ok();
        assert!(feasible(d.delay_tau));
        let (mut lo, mut hi) = (d.delay_tau, 2.0);
        while feasible(hi) {
            lo = hi;
            hi *= 2.0;
        }
        while hi - lo > 1e-3 {
            let mid = 0.5 * (lo + hi);
            if feasible(mid) {
                lo = mid
            } else {
                hi = mid
            }
        }
        eprintln!(
            "delay LMI feasible up to τ = {lo:.4} s (infeasible at {hi:.4} s), ε = {}",
            d.delay_epsilon
        );
    }
}
