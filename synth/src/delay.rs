//! `delay_sf` (work in progress, not yet a shipped variant): delay-dependent H∞ state feedback
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

use crate::generalized::{GeneralizedPlant, FORCE_UNIT};
use crate::lmi::{Affine, LmiError, Problem};
use nalgebra::DMatrix;

#[derive(Debug, Clone)]
pub struct DelayFeedback {
    /// `u(t) [N] = K x(t)`, applied at `t + τ`.
    pub k: DMatrix<f64>,
    pub gamma: f64,
    pub tau: f64,
    pub epsilon: f64,
}

pub fn delay_sf(g: &GeneralizedPlant, tau: f64, epsilon: f64, eps: f64) -> Result<DelayFeedback, LmiError> {
    let (n, nw, nz, nu) = (g.n(), g.b_w.ncols(), g.c_z.nrows(), g.b_u.ncols());
    let mut p = Problem::new();
    let (p1, s, r) = (p.symmetric(n), p.symmetric(n), p.symmetric(n));
    let (xv, yv, gamma) = (p.full(n, n), p.full(nu, n), p.scalar());
    let (p1, s, r, x, y) = (p1.expr(), s.expr(), r.expr(), xv.expr(), yv.expr());
    let ax = x.left(&g.a);
    let by = y.left(&g.b_u);
    let minus_gamma = |k: usize| gamma.expr().map_scalar(&(-DMatrix::identity(k, k)));
    let lmi = Affine::symmetric_blocks(&[
        vec![Some(s.sub(&r).add(&ax.he())), Some(p1.sub(&x).add(&ax.t().scale(epsilon))), Some(r.add(&by)), Some(Affine::constant(g.b_w.clone())), Some(x.left(&g.c_z).t())],
        vec![None, Some(r.scale(tau * tau).sub(&x.he().scale(epsilon))), Some(by.scale(epsilon)), Some(Affine::constant(&g.b_w * epsilon)), Some(Affine::zeros(n, nz))],
        vec![None, None, Some(s.add(&r).scale(-1.0)), Some(Affine::zeros(n, nw)), Some(y.left(&g.d_zu).t())],
        vec![None, None, None, Some(minus_gamma(nw)), Some(Affine::constant(g.d_zw.transpose()))],
        vec![None, None, None, None, Some(minus_gamma(nz))],
    ]);
    p.negative_definite("delay-dependent bounded-real LMI (descriptor, Jensen)", lmi, eps);
    for (name, m) in [("P1 ≻ 0", &p1), ("S ≻ 0", &s), ("R ≻ 0", &r)] {
        p.positive_definite(name, m.clone(), eps);
    }
    p.minimise(&gamma, 1.0);
    let sol = p.solve()?;
    let xm = xv.value(&sol.x);
    let x_inv = xm.try_inverse().ok_or(LmiError::Setup("X is singular".into()))?;
    Ok(DelayFeedback { k: yv.value(&sol.x) * x_inv * FORCE_UNIT, gamma: gamma.value(&sol.x)[(0, 0)], tau, epsilon })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::Design;

    /// Timing probe for the next step (`cargo test -p synth --release delay -- --ignored --nocapture`).
    #[test]
    #[ignore]
    fn probe_delay_lmi() {
        let d = Design::default();
        let g = GeneralizedPlant::new(&vehicle::VehicleParams::default(), &d);
        for (tau, epsilon) in [(0.02, 0.1), (0.02, 1.0), (0.05, 0.1)] {
            let t = std::time::Instant::now();
            let r = delay_sf(&g, tau, epsilon, d.lmi_margin);
            eprintln!("τ = {tau}, ε = {epsilon}: {:?} in {:.2} s", r.as_ref().map(|f| f.gamma), t.elapsed().as_secs_f64());
        }
    }
}
