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
    /// The last `unit_channels` columns of `B₁`/`D₁₁` and rows of `C₁`/`D₁₁` are a normalised
    /// uncertainty channel `p = δ q`, `|δ| ≤ 1` (S-procedure multiplier absorbed in their scaling):
    /// their diagonal blocks are `−I` instead of `−γI` (robust designs; 0 otherwise).
    pub unit_channels: usize,
}

/// `−diag(γ I_{k−r}, I_r)`: the diagonal block of `k` disturbance or performance channels of
/// which the last `r` are a normalised uncertainty channel.
fn gamma_block(gamma: &Affine, k: usize, r: usize) -> Affine {
    let perf = DMatrix::from_fn(k, k, |i, j| if i == j && i < k - r { -1.0 } else { 0.0 });
    let unit = DMatrix::from_fn(k, k, |i, j| if i == j && i >= k - r { -1.0 } else { 0.0 });
    gamma.map_scalar(&perf).add(&Affine::constant(unit))
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
    hinf_lmi_of(p, &VarExprs { x: v.x.expr(), y: v.y.expr(), ah: v.ah.expr(), bh: v.bh.expr(), ch: v.ch.expr(), dh: v.dh.expr() }, gamma)
}

/// The linearising variables as affine expressions (some may be constants).
struct VarExprs {
    x: Affine,
    y: Affine,
    ah: Affine,
    bh: Affine,
    ch: Affine,
    dh: Affine,
}

fn hinf_lmi_of(p: &OfPlant, v: &VarExprs, gamma: &Affine) -> Affine {
    let VarExprs { x, y, ah, bh, ch, dh } = v;
    let b2_dh = dh.left(p.b2); // B₂D̂ (n × ny)
    let m11 = x.left(p.a).add(&ch.left(p.b2)).he();
    let m12 = ah.t().add(&b2_dh.right(p.c2)).add(&Affine::constant(p.a.clone()));
    let m13 = b2_dh.right(p.d21).add(&Affine::constant(p.b1.clone()));
    let m14 = x.left(p.c1).add(&ch.left(p.d12)).t();
    let m22 = y.right(p.a).add(&bh.right(p.c2)).he();
    let m23 = y.right(p.b1).add(&bh.right(p.d21));
    let m24 = dh.left(p.d12).right(p.c2).add(&Affine::constant(p.c1.clone())).t();
    let m34 = dh.left(p.d12).right(p.d21).add(&Affine::constant(p.d11.clone())).t();
    let minus = |k: usize| gamma_block(gamma, k, p.unit_channels);
    Affine::symmetric_blocks(&[
        vec![Some(m11), Some(m12), Some(m13), Some(m14)],
        vec![None, Some(m22), Some(m23), Some(m24)],
        vec![None, None, Some(minus(p.b1.ncols())), Some(m34)],
        vec![None, None, None, Some(minus(p.c1.nrows()))],
    ])
}

/// `Ψ(X, Y, γ)`: the output-feedback LMI with `Ω = [Â B̂; Ĉ D̂] = 0`. The full LMI is
/// `Ψ + Pᵀ Ω Q + Qᵀ Ωᵀ P` with `Pᵀ = [0 B₂; I 0; 0 0; 0 D₁₂]`, `Q = [I 0 0 0; 0 C₂ D₂₁ 0]`.
fn psi(p: &OfPlant, x: &Affine, y: &Affine, gamma: &Affine) -> Affine {
    let (nw, nz) = (p.b1.ncols(), p.c1.nrows());
    let minus = |k: usize| gamma_block(gamma, k, p.unit_channels);
    Affine::symmetric_blocks(&[
        vec![Some(x.left(p.a).he()), Some(Affine::constant(p.a.clone())), Some(Affine::constant(p.b1.clone())), Some(x.left(p.c1).t())],
        vec![None, Some(y.right(p.a).he()), Some(y.right(p.b1)), Some(Affine::constant(p.c1.transpose()))],
        vec![None, None, Some(minus(nw)), Some(Affine::constant(p.d11.transpose()))],
        vec![None, None, None, Some(minus(nz))],
    ])
}

/// `(Pᵀ, Q)` of the basic LMI `Ψ + Pᵀ Ω Q + Qᵀ Ωᵀ P ≺ 0`.
fn basic_lmi_factors(p: &OfPlant) -> (DMatrix<f64>, DMatrix<f64>) {
    let (n, nw, nz, nu, ny) = (p.a.nrows(), p.b1.ncols(), p.c1.nrows(), p.b2.ncols(), p.c2.nrows());
    let size = 2 * n + nw + nz;
    let mut pt = DMatrix::zeros(size, n + nu);
    pt.view_mut((0, n), (n, nu)).copy_from(p.b2);
    pt.view_mut((n, 0), (n, n)).fill_with_identity();
    pt.view_mut((2 * n + nw, n), (nz, nu)).copy_from(p.d12);
    let mut q = DMatrix::zeros(n + ny, size);
    q.view_mut((0, 0), (n, n)).fill_with_identity();
    q.view_mut((n, n), (ny, n)).copy_from(p.c2);
    q.view_mut((n, 2 * n), (ny, nw)).copy_from(p.d21);
    (pt, q)
}

/// Orthonormal basis of the null space of `m` (columns).
fn null_space(m: &DMatrix<f64>) -> DMatrix<f64> {
    // Pad to a square matrix so the SVD returns a complete set of right singular vectors.
    let cols = m.ncols();
    let mut sq = DMatrix::zeros(cols.max(m.nrows()), cols);
    sq.view_mut((0, 0), m.shape()).copy_from(m);
    let svd = sq.svd(false, true);
    let vt = svd.v_t.expect("requested");
    let tol = 1e-10 * svd.singular_values.max().max(1.0);
    let basis: Vec<_> = (0..cols).filter(|&i| svd.singular_values[i] <= tol).map(|i| vt.row(i).transpose()).collect();
    DMatrix::from_columns(&basis)
}

/// `[X I; I Y]`.
fn coupling(x: &Affine, y: &Affine) -> Affine {
    Affine::symmetric_blocks(&[vec![Some(x.clone()), Some(Affine::identity(x.nrows()))], vec![None, Some(y.clone())]])
}

/// Stage 2's conditioning (SPEC §5): `[X I; I Y] ⪰ tI`, `t ≥ 0`, each of `bounded` `⪯ βI`, and
/// `t` maximised. Returns `t`.
fn maximise_coupling_margin(prob: &mut Problem, x: &Affine, y: &Affine, bounded: &[(&str, &Affine)], beta: f64) -> Var {
    let n = x.nrows();
    let t = prob.scalar();
    prob.positive_definite("[X I; I Y] ⪰ tI", coupling(x, y).sub(&t.expr().map_scalar(&DMatrix::identity(2 * n, 2 * n))), 0.0);
    prob.positive_definite("t ≥ 0", t.expr(), 0.0);
    for (name, v) in bounded {
        prob.positive_definite(name, Affine::identity(n).scale(beta).sub(v), 0.0);
    }
    prob.minimise(&t, -1.0);
    t
}

fn new_vars(p: &mut Problem, n: usize, ny: usize, nu: usize) -> Vars {
    Vars { x: p.symmetric(n), y: p.symmetric(n), ah: p.full(n, n), bh: p.full(n, ny), ch: p.full(nu, n), dh: p.full(nu, ny) }
}

/// Projected LMIs (elimination lemma): `N_Pᵀ Ψ N_P ≺ 0`, `N_Qᵀ Ψ N_Q ≺ 0` with `N_P`, `N_Q`
/// bases of the null spaces of `P` and `Q` — the classical existence conditions in `X, Y` only.
fn projected(p: &OfPlant, prob: &mut Problem, x: &Var, y: &Var, gamma: &Affine, eps: f64) {
    let (np, nq) = projectors(p);
    let ps = psi(p, &x.expr(), &y.expr(), gamma);
    prob.negative_definite("projected LMI in X (null space of P)", ps.left(&np.transpose()).right(&np), eps);
    prob.negative_definite("projected LMI in Y (null space of Q)", ps.left(&nq.transpose()).right(&nq), eps);
}

/// Bases of the null spaces of `P` and `Q`, built with their block structure so the blocks
/// that must be zero are exactly zero (an SVD of the whole `P` leaves 1e-16 there, which puts
/// the other Lyapunov variable into the LMI with rounding-noise coefficients).
fn projectors(p: &OfPlant) -> (DMatrix<f64>, DMatrix<f64>) {
    let (n, nw, nz) = (p.a.nrows(), p.b1.ncols(), p.c1.nrows());
    let size = 2 * n + nw + nz;
    // P v = 0: v₂ = 0, B₂ᵀ v₁ + D₁₂ᵀ v₄ = 0, v₃ free.
    let w = null_space(&concat_cols(&p.b2.transpose(), &p.d12.transpose()));
    let k = w.ncols();
    let mut np = DMatrix::zeros(size, k + nw);
    np.view_mut((0, 0), (n, k)).copy_from(&w.rows(0, n));
    np.view_mut((2 * n + nw, 0), (nz, k)).copy_from(&w.rows(n, nz));
    np.view_mut((2 * n, k), (nw, nw)).fill_with_identity();
    // Q v = 0: v₁ = 0, C₂ v₂ + D₂₁ v₃ = 0, v₄ free.
    let v = null_space(&concat_cols(p.c2, p.d21));
    let k = v.ncols();
    let mut nq = DMatrix::zeros(size, k + nz);
    nq.view_mut((n, 0), (n + nw, k)).copy_from(&v);
    nq.view_mut((2 * n + nw, k), (nz, nz)).fill_with_identity();
    (np, nq)
}

fn concat_cols(a: &DMatrix<f64>, b: &DMatrix<f64>) -> DMatrix<f64> {
    let mut m = DMatrix::zeros(a.nrows(), a.ncols() + b.ncols());
    m.view_mut((0, 0), a.shape()).copy_from(a);
    m.view_mut((0, a.ncols()), b.shape()).copy_from(b);
    m
}

/// The explicit central solution of `Ψ + Pᵀ Ω Q + Qᵀ Ωᵀ P ≺ 0` (Iwasaki & Skelton, Automatica
/// 30(8), 1994): `Ω = −μ P Φ Qᵀ (Q Φ Qᵀ)⁻¹`, `Φ = (μ Pᵀ P − Ψ)⁻¹ ≻ 0`, with `μ` increased until
/// `Φ ≻ 0` and the LMI holds (it exists because the projected LMIs hold).
fn solve_basic_lmi(psi: &DMatrix<f64>, pt: &DMatrix<f64>, q: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    let ptp = pt * pt.transpose();
    let scale = psi.amax().max(1.0) / ptp.amax().max(1e-300);
    for k in 0..60 {
        let mu = scale * 2f64.powi(k - 10);
        let phi_inv = &ptp * mu - psi;
        let Some(chol) = phi_inv.clone().cholesky() else { continue };
        let phi = chol.inverse();
        let qpq = q * &phi * q.transpose();
        let Some(qpq_inv) = qpq.try_inverse() else { continue };
        let omega = -(pt.transpose() * &phi * q.transpose() * qpq_inv) * mu;
        let full = psi + pt * &omega * q + q.transpose() * omega.transpose() * pt.transpose();
        let sym = (&full + full.transpose()) * 0.5;
        if nalgebra::SymmetricEigen::new(sym).eigenvalues.max() < 0.0 {
            return Some(omega);
        }
    }
    None
}

/// Strictness of the stage-2 projected LMIs, relative to γ.
const RECONSTRUCTION_MARGIN: f64 = 1e-4;

/// Stage 1 by the projected LMIs (in `X, Y, γ` only): the optimal γ.
pub fn optimal_gamma(p: &OfPlant, eps: f64) -> Result<f64, LmiError> {
    let n = p.a.nrows();
    let mut s1 = Problem::new();
    let (x1, y1, g1) = (s1.symmetric(n), s1.symmetric(n), s1.scalar());
    projected(p, &mut s1, &x1, &y1, &g1.expr(), eps);
    s1.positive_definite("[X I; I Y] ≻ 0", coupling(&x1.expr(), &y1.expr()), eps);
    s1.minimise(&g1, 1.0);
    Ok(g1.value(&s1.solve()?.x)[(0, 0)])
}

/// All three stages without `Â, B̂, Ĉ, D̂` as LMI variables: projected LMIs for stages 1–2,
/// then the explicit basic-LMI solution (1.7 s instead of 9 s). Its controller is another point
/// of the γ-suboptimal set, certified at the same γ but with weaker time-domain figures on our
/// scenarios than the one-shot stage 2, which is why [`hinf_of`] keeps the latter.
pub fn hinf_of_projected(p: &OfPlant, eps: f64, delta: f64, beta: f64) -> Result<OutputFeedback, LmiError> {
    let n = p.a.nrows();
    let (ny, nu) = (p.c2.nrows(), p.b2.ncols());
    let gamma_opt = optimal_gamma(p, eps)?;

    let gamma = (1.0 + delta) * gamma_opt;
    let mut s2 = Problem::new();
    let (xv, yv) = (s2.symmetric(n), s2.symmetric(n));
    // A real strictness margin here: the explicit reconstruction below needs room (maximising
    // the coupling margin otherwise drives the projected LMIs onto their boundary).
    let strict = (RECONSTRUCTION_MARGIN * gamma).max(eps);
    projected(p, &mut s2, &xv, &yv, &Affine::constant(DMatrix::from_element(1, 1, gamma)), strict);
    let (xe, ye) = (xv.expr(), yv.expr());
    let t = maximise_coupling_margin(&mut s2, &xe, &ye, &[("X ⪯ βI", &xe), ("Y ⪯ βI", &ye)], beta);
    let sol = s2.solve()?;
    let (x, y) = (xv.value(&sol.x), yv.value(&sol.x));

    let gconst = Affine::constant(DMatrix::from_element(1, 1, gamma));
    let psi_val = psi(p, &Affine::constant(x.clone()), &Affine::constant(y.clone()), &gconst).constant;
    let (pt, q) = basic_lmi_factors(p);
    let omega = solve_basic_lmi(&psi_val, &pt, &q).ok_or(LmiError::Setup("no explicit solution of the basic LMI was found".into()))?;
    let ah = omega.view((0, 0), (n, n)).into_owned();
    let bh = omega.view((0, n), (n, ny)).into_owned();
    let ch = omega.view((n, 0), (nu, n)).into_owned();
    let dh = omega.view((n, n), (nu, ny)).into_owned();
    reconstruct(p, &x, &y, &ah, &bh, &ch, &dh, gamma, gamma_opt, t.value(&sol.x)[(0, 0)])
}

/// Remark 5.1: controller from `X, Y` and the linearising variables, `N = I`, `M = I − XY`.
#[allow(clippy::too_many_arguments)]
fn reconstruct(p: &OfPlant, x: &DMatrix<f64>, y: &DMatrix<f64>, ah: &DMatrix<f64>, bh: &DMatrix<f64>, ch: &DMatrix<f64>, dh: &DMatrix<f64>, gamma: f64, gamma_opt: f64, margin: f64) -> Result<OutputFeedback, LmiError> {
    let n = p.a.nrows();
    let ident = DMatrix::<f64>::identity(n, n);
    let m = &ident - x * y;
    let mt_inv = m.transpose().try_inverse().ok_or(LmiError::Setup("I − XY is singular".into()))?;
    let sv = m.singular_values();
    let dk = dh.clone();
    let ck = (ch - &dk * p.c2 * x) * &mt_inv;
    let bk = bh - y * p.b2 * &dk;
    let ak = (ah - &bk * p.c2 * x - y * p.b2 * &ck * m.transpose() - y * (p.a + p.b2 * &dk * p.c2) * x) * &mt_inv;
    Ok(OutputFeedback {
        controller: Controller::new(ak, bk, ck * FORCE_UNIT, dk * FORCE_UNIT),
        gamma,
        gamma_opt,
        coupling_margin: margin,
        coupling_condition: sv.max() / sv.min(),
    })
}

/// The one-shot stage 1: all of `X, Y, Â, B̂, Ĉ, D̂` in one LMI (slow; the reference the
/// projected [`optimal_gamma`] is tested against).
pub fn optimal_gamma_one_shot(p: &OfPlant, eps: f64) -> Result<f64, LmiError> {
    let n = p.a.nrows();
    let (ny, nu) = (p.c2.nrows(), p.b2.ncols());
    let mut s1 = Problem::new();
    let v1 = new_vars(&mut s1, n, ny, nu);
    let g1 = s1.scalar();
    s1.negative_definite("H∞ output-feedback LMI", hinf_lmi(p, &v1, &g1.expr()), eps);
    s1.positive_definite("[X I; I Y] ≻ 0", coupling(&v1.x.expr(), &v1.y.expr()), eps);
    s1.minimise(&g1, 1.0);
    Ok(g1.value(&s1.solve()?.x)[(0, 0)])
}

/// The shipped synthesis: γ* by the projected LMIs ([`optimal_gamma`]), then stage 2 with all
/// variables (γ fixed at `(1 + delta) γ*`, `X, Y ⪯ βI`, coupling margin maximised) and the
/// Remark 5.1 reconstruction.
pub fn hinf_of(p: &OfPlant, eps: f64, delta: f64, beta: f64) -> Result<OutputFeedback, LmiError> {
    let n = p.a.nrows();
    let (ny, nu) = (p.c2.nrows(), p.b2.ncols());
    let gamma_opt = optimal_gamma(p, eps)?;

    // Stage 2: γ fixed a little above, X, Y bounded, coupling margin maximised.
    let gamma = (1.0 + delta) * gamma_opt;
    let mut s2 = Problem::new();
    let v = new_vars(&mut s2, n, ny, nu);
    let gconst = Affine::constant(DMatrix::from_element(1, 1, gamma));
    s2.negative_definite("H∞ output-feedback LMI at fixed γ", hinf_lmi(p, &v, &gconst), eps);
    let (xe, ye) = (v.x.expr(), v.y.expr());
    let t = maximise_coupling_margin(&mut s2, &xe, &ye, &[("X ⪯ βI", &xe), ("Y ⪯ βI", &ye)], beta);
    let sol = s2.solve()?;
    let val = |var: &Var| var.value(&sol.x);
    let (x, y, ah, bh, ch, dh) = (val(&v.x), val(&v.y), val(&v.ah), val(&v.bh), val(&v.ch), val(&v.dh));

    reconstruct(p, &x, &y, &ah, &bh, &ch, &dh, gamma, gamma_opt, t.value(&sol.x)[(0, 0)])
}


/// Robust output feedback at the vertices of a polytope with one `X, Y` (thesis Th. 6.2, vertex
/// form). With plant-dependent `A, B₂` the linearising variable `Â` depends on the plant
/// (`Â = … + Y(A + B₂D_K C₂)X + Y B₂ C_K Mᵀ`): the vertex conditions are bilinear in `Y` and
/// `X, Ĉ`. Made tractable by fixing `X` and `Ĉ` to a robust state-feedback solution (the
/// `(X, Ĉ)` block of the output-feedback LMI *is* the state-feedback LMI with `Q = X`,
/// `Y_sf = Ĉ`) and `D̂ = 0`. Then `Â(vertex) = Â₀ + Y (A_i − A_c) X + Y (B₂,ᵢ − B₂,c) Ĉ` is
/// affine in the unknowns `(Y, Â₀, B̂, γ)`, the vertex LMIs are exact congruences of the
/// closed-loop bounded-real LMI with one Lyapunov matrix at each vertex, and, being affine in
/// the plant data for fixed unknowns, they hold on the whole segment between the vertices. The
/// controller (from `Â₀` and the centre plant `c`) does not depend on the vertex: the vertex
/// terms cancel in the Remark 5.1 reconstruction. Sound, but conservative: `X` is not optimised
/// for output feedback.
#[allow(clippy::too_many_arguments)]
pub fn hinf_of_common_x(vertices: &[OfPlant], center: &OfPlant, x: &DMatrix<f64>, ch: &DMatrix<f64>, eps: f64, delta: f64, beta: f64) -> Result<OutputFeedback, LmiError> {
    let n = center.a.nrows();
    let (ny, nu) = (center.c2.nrows(), center.b2.ncols());
    let build = |prob: &mut Problem, gamma: &Affine, strict: f64| -> (Var, Var, Var) {
        let (yv, ahv, bhv) = (prob.symmetric(n), prob.full(n, n), prob.full(n, ny));
        for (i, v) in vertices.iter().enumerate() {
            let y = yv.expr();
            let shift = y.right(&((v.a - center.a) * x + (v.b2 - center.b2) * ch));
            let e = VarExprs { x: Affine::constant(x.clone()), y, ah: ahv.expr().add(&shift), bh: bhv.expr(), ch: Affine::constant(ch.clone()), dh: Affine::zeros(nu, ny) };
            prob.negative_definite(&format!("H∞ output-feedback LMI at vertex {i}"), hinf_lmi_of(v, &e, gamma), strict);
        }
        (yv, ahv, bhv)
    };
    let xc = Affine::constant(x.clone());
    // Stage 1: γ*.
    let mut s1 = Problem::new();
    let g1 = s1.scalar();
    let (y1, _, _) = build(&mut s1, &g1.expr(), eps);
    s1.positive_definite("[X I; I Y] ≻ 0", coupling(&xc, &y1.expr()), eps);
    s1.minimise(&g1, 1.0);
    let gamma_opt = g1.value(&s1.solve()?.x)[(0, 0)];
    // Stage 2: γ fixed above γ*, Y bounded, coupling margin maximised.
    let gamma = (1.0 + delta) * gamma_opt;
    let mut s2 = Problem::new();
    let (yv, ahv, bhv) = build(&mut s2, &Affine::constant(DMatrix::from_element(1, 1, gamma)), eps);
    let ye = yv.expr();
    let t = maximise_coupling_margin(&mut s2, &xc, &ye, &[("Y ⪯ βI", &ye)], beta);
    let sol = s2.solve()?;
    let (y, ah, bh) = (yv.value(&sol.x), ahv.value(&sol.x), bhv.value(&sol.x));
    reconstruct(center, x, &y, &ah, &bh, ch, &DMatrix::zeros(nu, ny), gamma, gamma_opt, t.value(&sol.x)[(0, 0)])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::certificate::closed_loop;
    use crate::design::Design;
    use crate::generalized::GeneralizedPlant;

    #[test]
    fn projected_and_one_shot_formulations_agree_and_both_controllers_certify() {
        let d = Design::default();
        let g = GeneralizedPlant::new(&vehicle::VehicleParams::default(), &d).with_sensor_noise(&d);
        let p = g.of_plant();
        let projected = optimal_gamma(&p, d.lmi_margin).unwrap();
        let one_shot = optimal_gamma_one_shot(&p, d.lmi_margin).unwrap();
        let rel = (projected - one_shot).abs() / one_shot;
        assert!(rel < 1e-6, "γ*: projected {projected} vs one-shot {one_shot}");
        let shipped = hinf_of(&p, d.lmi_margin, 0.02, 1e3).unwrap();
        let fast = hinf_of_projected(&p, d.lmi_margin, 0.02, 1e3).unwrap();
        for of in [&shipped, &fast] {
            let norm = closed_loop(&g, &g.c_y, &g.d_yw, &of.controller).hinf_norm(1e-9).unwrap();
            assert!(norm.upper <= of.gamma * (1.0 + 1e-6), "{} > {}", norm.upper, of.gamma);
        }
    }

    #[test]
    fn basic_lmi_solution_makes_the_full_lmi_negative_definite() {
        // Ψ = −I on the null spaces is enough: a random instance with a known solution Ω₀.
        let pt = DMatrix::from_fn(6, 2, |i, j| ((i * 3 + j * 5) % 7) as f64 - 3.0);
        let q = DMatrix::from_fn(3, 6, |i, j| ((i * 2 + j * 3) % 5) as f64 - 2.0);
        let omega0 = DMatrix::from_fn(2, 3, |i, j| (i as f64 - j as f64) * 0.3);
        let base = DMatrix::<f64>::identity(6, 6) * -1.0;
        // Ψ such that Ω₀ solves it: Ψ = −I − (PᵀΩ₀Q + QᵀΩ₀ᵀP).
        let psi = &base - (&pt * &omega0 * &q + q.transpose() * omega0.transpose() * pt.transpose());
        let omega = solve_basic_lmi(&psi, &pt, &q).expect("solvable");
        let full = &psi + &pt * &omega * &q + q.transpose() * omega.transpose() * pt.transpose();
        assert!(nalgebra::SymmetricEigen::new((&full + full.transpose()) * 0.5).eigenvalues.max() < 0.0);
    }
}
