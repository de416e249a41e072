//! `hinf_of`: full-order dynamic output feedback (thesis Th. 5.2, eq. 5.9; Remark 5.1).
//!
//! The thesis's LMI 5.9 lacks blocks; this is the standard form by the linearising change of
//! variables of Scherer, Gahinet & Chilali (IEEE TAC 42(7), 1997; Gahinet & Apkarian 1994):
//! with `X, Y` symmetric and `Â, B̂, Ĉ, D̂` free,
//! ```text
//! [ He(AX + B₂Ĉ)   Âᵀ + A + B₂D̂C₂   B₁ + B₂D̂D₂₁    (C₁X + D₁₂Ĉ)ᵀ      ]
//! [      *         He(YA + B̂C₂)     YB₁ + B̂D₂₁     (C₁ + D₁₂D̂C₂)ᵀ     ]  ≺ 0,  [X I; I Y] ≻ 0,
//! [      *              *             −γI        (D₁₁ + D₁₂D̂D₂₁)ᵀ   ]
//! [      *              *               *               −γI         ]
//! ```
//! and the controller is recovered with `M Nᵀ = I − XY` (Remark 5.1's factor), here `N = I`,
//! `M = I − XY`:
//! `D_K = D̂`, `C_K = (Ĉ − D_K C₂ X) M⁻ᵀ`, `B_K = N⁻¹(B̂ − Y B₂ D_K)`,
//! `A_K = N⁻¹(Â − N B_K C₂ X − Y B₂ C_K Mᵀ − Y (A + B₂ D_K C₂) X) M⁻ᵀ`.
//!
//! Numerics (SPEC §5): at the optimum `I − XY` is nearly singular and the reconstructed
//! controller can be wrong, so: (1) minimise γ; (2) fix γ at `(1 + δ)γ*`, bound `X, Y ⪯ βI`, and
//! maximise `t` with `[X I; I Y] ⪰ tI`; (3) reconstruct from that better-conditioned point.
//! The certificate then checks the reconstructed closed loop independently.

use crate::certificate::Controller;
use crate::generalized::FORCE_UNIT;
use crate::lmi::{Affine, LmiError, Problem, Var};
use nalgebra::DMatrix;

/// The plant as the output-feedback LMI sees it.
pub struct OfPlant<'a> {
    pub a: &'a DMatrix<f64>,
    pub b1: &'a DMatrix<f64>,
    pub b2: &'a DMatrix<f64>,
    pub c1: &'a DMatrix<f64>,
    pub d11: &'a DMatrix<f64>,
    pub d12: &'a DMatrix<f64>,
    pub c2: &'a DMatrix<f64>,
    pub d21: &'a DMatrix<f64>,
}

#[derive(Debug, Clone)]
pub struct OutputFeedback {
    /// In the plant's units: `u [N] = C_K xc + D_K y`.
    pub controller: Controller,
    /// The γ the reconstruction was made at (certified afterwards).
    pub gamma: f64,
    /// The minimum γ of stage 1.
    pub gamma_opt: f64,
    /// Coupling margin `t` of stage 2 and the condition number of `I − XY`.
    pub coupling_margin: f64,
    pub coupling_condition: f64,
}

struct Vars {
    x: Var,
    y: Var,
    ah: Var,
    bh: Var,
    ch: Var,
    dh: Var,
}

fn hinf_lmi(p: &OfPlant, v: &Vars, gamma: &Affine) -> Affine {
    let n = p.a.nrows();
    let (nw, nz) = (p.b1.ncols(), p.c1.nrows());
    let (x, y, ah, bh, ch, dh) = (v.x.expr(), v.y.expr(), v.ah.expr(), v.bh.expr(), v.ch.expr(), v.dh.expr());
    let b2_dh = dh.left(p.b2); // B₂D̂ (n × ny)
    let m11 = x.left(p.a).add(&ch.left(p.b2)).he();
    let m12 = ah.t().add(&b2_dh.right(p.c2)).add(&Affine::constant(p.a.clone()));
    let m13 = b2_dh.right(p.d21).add(&Affine::constant(p.b1.clone()));
    let m14 = x.left(p.c1).add(&ch.left(p.d12)).t();
    let m22 = y.right(p.a).add(&bh.right(p.c2)).he();
    let m23 = y.right(p.b1).add(&bh.right(p.d21));
    let m24 = dh.left(p.d12).right(p.c2).add(&Affine::constant(p.c1.clone())).t();
    let m34 = dh.left(p.d12).right(p.d21).add(&Affine::constant(p.d11.clone())).t();
    let minus = |k: usize| gamma.map_scalar(&(-DMatrix::identity(k, k)));
    let _ = n;
    Affine::symmetric_blocks(&[
        vec![Some(m11), Some(m12), Some(m13), Some(m14)],
        vec![None, Some(m22), Some(m23), Some(m24)],
        vec![None, None, Some(minus(nw)), Some(m34)],
        vec![None, None, None, Some(minus(nz))],
    ])
}

fn coupling(v: &Vars, n: usize) -> Affine {
    Affine::symmetric_blocks(&[vec![Some(v.x.expr()), Some(Affine::identity(n))], vec![None, Some(v.y.expr())]])
}

fn new_vars(p: &mut Problem, n: usize, ny: usize, nu: usize) -> Vars {
    Vars { x: p.symmetric(n), y: p.symmetric(n), ah: p.full(n, n), bh: p.full(n, ny), ch: p.full(nu, n), dh: p.full(nu, ny) }
}

/// Synthesise with relative γ back-off `delta` and bound `beta` on `X, Y`.
pub fn hinf_of(p: &OfPlant, eps: f64, delta: f64, beta: f64) -> Result<OutputFeedback, LmiError> {
    let n = p.a.nrows();
    let (ny, nu) = (p.c2.nrows(), p.b2.ncols());

    // Stage 1: the optimal γ.
    let mut s1 = Problem::new();
    let v1 = new_vars(&mut s1, n, ny, nu);
    let g1 = s1.scalar();
    s1.negative_definite("H∞ output-feedback LMI", hinf_lmi(p, &v1, &g1.expr()), eps);
    s1.positive_definite("[X I; I Y] ≻ 0", coupling(&v1, n), eps);
    s1.minimise(&g1, 1.0);
    let gamma_opt = g1.value(&s1.solve()?.x)[(0, 0)];

    // Stage 2: γ fixed a little above, X, Y bounded, coupling margin maximised.
    let gamma = (1.0 + delta) * gamma_opt;
    let mut s2 = Problem::new();
    let v = new_vars(&mut s2, n, ny, nu);
    let t = s2.scalar();
    let gconst = Affine::constant(DMatrix::from_element(1, 1, gamma));
    s2.negative_definite("H∞ output-feedback LMI at fixed γ", hinf_lmi(p, &v, &gconst), eps);
    let tn = t.expr().map_scalar(&DMatrix::identity(2 * n, 2 * n));
    s2.positive_definite("[X I; I Y] ⪰ tI", coupling(&v, n).sub(&tn), 0.0);
    s2.positive_definite("t ≥ 0", t.expr(), 0.0);
    for (name, var) in [("X ⪯ βI", v.x), ("Y ⪯ βI", v.y)] {
        s2.positive_definite(name, Affine::identity(n).scale(beta).sub(&var.expr()), 0.0);
    }
    s2.minimise(&t, -1.0);
    let sol = s2.solve()?;
    let val = |var: &Var| var.value(&sol.x);
    let (x, y, ah, bh, ch, dh) = (val(&v.x), val(&v.y), val(&v.ah), val(&v.bh), val(&v.ch), val(&v.dh));

    // Stage 3: reconstruction, N = I, M = I − XY.
    let ident = DMatrix::<f64>::identity(n, n);
    let m = &ident - &x * &y;
    let mt_inv = m.transpose().try_inverse().ok_or(LmiError::Setup("I − XY is singular".into()))?;
    let sv = m.singular_values();
    let coupling_condition = sv.max() / sv.min();
    let dk = dh.clone();
    let ck = (&ch - &dk * p.c2 * &x) * &mt_inv;
    let bk = &bh - &y * p.b2 * &dk;
    let ak = (&ah - &bk * p.c2 * &x - &y * p.b2 * &ck * m.transpose() - &y * (p.a + p.b2 * &dk * p.c2) * &x) * &mt_inv;
    Ok(OutputFeedback {
        controller: Controller { a: ak, b: bk, c: ck * FORCE_UNIT, d: dk * FORCE_UNIT },
        gamma,
        gamma_opt,
        coupling_margin: t.value(&sol.x)[(0, 0)],
        coupling_condition,
    })
}
