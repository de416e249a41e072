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

use crate::numerics::hinf_norm::{Controller, Lti};
use crate::numerics::lmi::{Affine, LmiError, Problem, Var};
use crate::thesis::generalized::{GeneralizedPlant, FORCE_UNIT};
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

impl<'a> OfPlant<'a> {
    /// `g`'s matrices as the output-feedback LMI names them (`B₁ = B_w`, `C₁ = C_z`, …).
    pub fn of(g: &'a GeneralizedPlant) -> Self {
        OfPlant {
            a: &g.a,
            b1: &g.b_w,
            b2: &g.b_u,
            c1: &g.c_z,
            d11: &g.d_zw,
            d12: &g.d_zu,
            c2: &g.c_y,
            d21: &g.d_yw,
            unit_channels: 0,
        }
    }
}

/// The plant in balanced state coordinates `x = D x̄` (`D` diagonal, powers of two, Osborne's
/// iteration as in LAPACK's `dgebal`): `Ā = D⁻¹AD`, `B̄ = D⁻¹B`, `C̄ = CD`. The car's `A` mixes
/// positions and velocities (entries from 1 to ~5000); balanced, they are within a factor of
/// ~10, and Clarabel solves the reduced LMIs that it otherwise stops on. The controller maps
/// `y` to `u` and is the same in either coordinates; only `X, Y` are in balanced ones.
struct Balanced {
    a: DMatrix<f64>,
    b1: DMatrix<f64>,
    b2: DMatrix<f64>,
    c1: DMatrix<f64>,
    c2: DMatrix<f64>,
    /// `diag D`.
    d: Vec<f64>,
}

impl Balanced {
    fn new(p: &OfPlant) -> Self {
        let n = p.a.nrows();
        let mut a = p.a.clone();
        let mut d = vec![1.0f64; n];
        for _sweep in 0..100 {
            let mut changed = false;
            for i in 0..n {
                let c: f64 = (0..n).filter(|&k| k != i).map(|k| a[(k, i)].abs()).sum();
                let mut r: f64 = (0..n).filter(|&k| k != i).map(|k| a[(i, k)].abs()).sum();
                // A state driven by w alone (a road-filter state): balance its column against
                // its input row instead.
                if r == 0.0 {
                    r = p.b1.row(i).iter().map(|v| v.abs()).sum::<f64>() * d[i].recip();
                }
                if c == 0.0 || r == 0.0 {
                    continue;
                }
                // The power of two f closest to √(r/c): column i times f, row i divided by f.
                let f = 2f64.powi(((r / c).log2() / 2.0).round() as i32);
                if f != 1.0 && (c * f + r / f) < 0.95 * (c + r) {
                    a.column_mut(i).scale_mut(f);
                    a.row_mut(i).scale_mut(1.0 / f);
                    d[i] *= f;
                    changed = true;
                }
            }
            if !changed {
                break;
            }
        }
        Self::with_scaling(p, d)
    }
    /// `p` in the coordinates `x = D x̄` of a given `D` (e.g. another plant's balancing).
    fn with_scaling(p: &OfPlant, d: Vec<f64>) -> Self {
        let (dm, dinv) = (Self::diag(&d, 1.0), Self::diag(&d, -1.0));
        Balanced {
            a: &dinv * p.a * &dm,
            b1: &dinv * p.b1,
            b2: &dinv * p.b2,
            c1: p.c1 * &dm,
            c2: p.c2 * &dm,
            d,
        }
    }
    /// `D^power`.
    fn diag(d: &[f64], power: f64) -> DMatrix<f64> {
        DMatrix::from_diagonal(&nalgebra::DVector::from_iterator(
            d.len(),
            d.iter().map(|v| v.powf(power)),
        ))
    }
    fn plant<'a>(&'a self, p: &'a OfPlant) -> OfPlant<'a> {
        OfPlant {
            a: &self.a,
            b1: &self.b1,
            b2: &self.b2,
            c1: &self.c1,
            d11: p.d11,
            d12: p.d12,
            c2: &self.c2,
            d21: p.d21,
            unit_channels: p.unit_channels,
        }
    }
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
    hinf_lmi_of(
        p,
        &VarExprs {
            x: v.x.expr(),
            y: v.y.expr(),
            ah: v.ah.expr(),
            bh: v.bh.expr(),
            ch: v.ch.expr(),
            dh: v.dh.expr(),
        },
        gamma,
    )
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
    let VarExprs {
        x,
        y,
        ah,
        bh,
        ch,
        dh,
    } = v;
    let b2_dh = dh.left(p.b2); // B₂D̂ (n × ny)
    let m11 = x.left(p.a).add(&ch.left(p.b2)).he();
    let m12 = ah
        .t()
        .add(&b2_dh.right(p.c2))
        .add(&Affine::constant(p.a.clone()));
    let m13 = b2_dh.right(p.d21).add(&Affine::constant(p.b1.clone()));
    let m14 = x.left(p.c1).add(&ch.left(p.d12)).t();
    let m22 = y.right(p.a).add(&bh.right(p.c2)).he();
    let m23 = y.right(p.b1).add(&bh.right(p.d21));
    let m24 = dh
        .left(p.d12)
        .right(p.c2)
        .add(&Affine::constant(p.c1.clone()))
        .t();
    let m34 = dh
        .left(p.d12)
        .right(p.d21)
        .add(&Affine::constant(p.d11.clone()))
        .t();
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
        vec![
            Some(x.left(p.a).he()),
            Some(Affine::constant(p.a.clone())),
            Some(Affine::constant(p.b1.clone())),
            Some(x.left(p.c1).t()),
        ],
        vec![
            None,
            Some(y.right(p.a).he()),
            Some(y.right(p.b1)),
            Some(Affine::constant(p.c1.transpose())),
        ],
        vec![
            None,
            None,
            Some(minus(nw)),
            Some(Affine::constant(p.d11.transpose())),
        ],
        vec![None, None, None, Some(minus(nz))],
    ])
}

/// `(Pᵀ, Q)` of the basic LMI `Ψ + Pᵀ Ω Q + Qᵀ Ωᵀ P ≺ 0`.
fn basic_lmi_factors(p: &OfPlant) -> (DMatrix<f64>, DMatrix<f64>) {
    let (n, nw, nz, nu, ny) = (
        p.a.nrows(),
        p.b1.ncols(),
        p.c1.nrows(),
        p.b2.ncols(),
        p.c2.nrows(),
    );
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
    let basis: Vec<_> = (0..cols)
        .filter(|&i| svd.singular_values[i] <= tol)
        .map(|i| vt.row(i).transpose())
        .collect();
    DMatrix::from_columns(&basis)
}

/// `[X I; I Y]`.
fn coupling(x: &Affine, y: &Affine) -> Affine {
    Affine::symmetric_blocks(&[
        vec![Some(x.clone()), Some(Affine::identity(x.nrows()))],
        vec![None, Some(y.clone())],
    ])
}

/// Strictness of `[X I; I Y] ⪰ tI` while `t` is maximised (so that the solver's point passes
/// our eigenvalue check instead of sitting on the boundary).
const COUPLING_STRICTNESS: f64 = 1e-7;

/// Stage 2's conditioning (SPEC §5): `[X I; I Y] ⪰ tI`, `t ≥ 0`, each of `bounded` `⪯ βI`, and
/// `t` maximised. Returns `t`.
fn maximise_coupling_margin(
    prob: &mut Problem,
    x: &Affine,
    y: &Affine,
    bounded: &[(&str, &Affine)],
    beta: f64,
) -> Var {
    let n = x.nrows();
    let t = prob.scalar();
    prob.positive_definite(
        "[X I; I Y] ⪰ tI",
        coupling(x, y).sub(&t.expr().map_scalar(&DMatrix::identity(2 * n, 2 * n))),
        COUPLING_STRICTNESS,
    );
    prob.positive_definite("t ≥ 0", t.expr(), 0.0);
    for (name, v) in bounded {
        prob.positive_definite(name, Affine::identity(n).scale(beta).sub(v), 0.0);
    }
    prob.minimise(&t, -1.0);
    t
}

fn new_vars(p: &mut Problem, n: usize, ny: usize, nu: usize) -> Vars {
    Vars {
        x: p.symmetric(n),
        y: p.symmetric(n),
        ah: p.full(n, n),
        bh: p.full(n, ny),
        ch: p.full(nu, n),
        dh: p.full(nu, ny),
    }
}

/// Bases of the null spaces of `[B₂ᵀ D₁₂ᵀ]` (`(n + n_z) × ·`, the `x` and `z` parts of the
/// null space of `P`) and of `[C₂ D₂₁]` (`(n + n_w) × ·`, the `x` and `w` parts of that of `Q`).
fn null_bases(p: &OfPlant) -> (DMatrix<f64>, DMatrix<f64>) {
    (
        null_space(&concat_cols(&p.b2.transpose(), &p.d12.transpose())),
        null_space(&concat_cols(p.c2, p.d21)),
    )
}

fn concat_cols(a: &DMatrix<f64>, b: &DMatrix<f64>) -> DMatrix<f64> {
    let mut m = DMatrix::zeros(a.nrows(), a.ncols() + b.ncols());
    m.view_mut((0, 0), a.shape()).copy_from(a);
    m.view_mut((0, a.ncols()), b.shape()).copy_from(b);
    m
}

fn concat_rows(a: &DMatrix<f64>, b: &DMatrix<f64>) -> DMatrix<f64> {
    concat_cols(&a.transpose(), &b.transpose()).transpose()
}

/// How γ enters the reduced projected LMIs ([`reduced_projected`]), as 1×1 expressions: the
/// diagonal blocks that remain are `−diag(a_p I, a_u I)` (performance, uncertainty channels)
/// and the Schur complement of the eliminated block adds `s_p b_p b_pᵀ + s_u b_u b_uᵀ`.
struct GammaTerms {
    a_p: Affine,
    a_u: Affine,
    s_p: Affine,
    s_u: Affine,
}

impl GammaTerms {
    /// γ fixed: `Γ = diag(γ I, I)`, `Γ⁻¹ = diag(I/γ, I)`.
    fn fixed(gamma: f64) -> Self {
        let c = |v: f64| Affine::constant(DMatrix::from_element(1, 1, v));
        GammaTerms {
            a_p: c(gamma),
            a_u: c(1.0),
            s_p: c(1.0 / gamma),
            s_u: c(1.0),
        }
    }
    /// Stage 1, in the scaled variables `X̃ = X/γ`, `Ỹ = Y/γ`, `η = 1/γ`, `ζ ≥ η²` (each LMI
    /// multiplied by `η`): `a = (1, η)`, `s = (ζ, η)`.
    fn scaled(eta: &Var, zeta: &Var) -> Self {
        GammaTerms {
            a_p: Affine::identity(1),
            a_u: eta.expr(),
            s_p: zeta.expr(),
            s_u: eta.expr(),
        }
    }
}

/// The projected existence conditions in `X, Y` (elimination lemma, Gahinet & Apkarian 1994),
/// each with one diagonal block removed by a Schur complement, which makes them the smallest
/// LMIs of the problem (28 and 24 rows here instead of 44 and 41; Clarabel's work per iteration
/// grows with the sixth power of the size). With `W`, `V` the bases of [`null_bases`]:
/// ```text
/// Wᵀ ( [He(AX)  XC₁ᵀ; C₁X  −Γ_z] + [B₁; D₁₁] Γ_w⁻¹ [B₁; D₁₁]ᵀ ) W ≺ 0   (w-block eliminated)
/// Vᵀ ( [He(YA)  YB₁; B₁ᵀY  −Γ_w] + [C₁ᵀ; D₁₁ᵀ] Γ_z⁻¹ [C₁ D₁₁] ) V ≺ 0   (z-block eliminated)
/// ```
/// `Γ = diag(γ I, I)` (the last `unit_channels` are the normalised uncertainty channel);
/// `g` says how γ enters ([`GammaTerms`]).
fn reduced_projected(p: &OfPlant, x: &Affine, y: &Affine, g: &GammaTerms) -> (Affine, Affine) {
    let (nw, nz, r) = (p.b1.ncols(), p.c1.nrows(), p.unit_channels);
    let (w, v) = null_bases(p);
    let diag = |k: usize| {
        let sel = |unit: bool| {
            DMatrix::from_fn(k, k, |i, j| {
                if i == j && (i >= k - r) == unit {
                    -1.0
                } else {
                    0.0
                }
            })
        };
        g.a_p
            .map_scalar(&sel(false))
            .add(&g.a_u.map_scalar(&sel(true)))
    };
    // Σ s b bᵀ over the performance and the uncertainty columns of `b`, projected on `basis`.
    let schur = |b: &DMatrix<f64>, basis: &DMatrix<f64>| {
        let k = b.ncols();
        let wb = basis.transpose() * b;
        let gram = |cols: std::ops::Range<usize>| {
            let part = wb.columns(cols.start, cols.len());
            part * part.transpose()
        };
        g.s_p
            .map_scalar(&gram(0..k - r))
            .add(&g.s_u.map_scalar(&gram(k - r..k)))
    };
    let in_x = Affine::symmetric_blocks(&[
        vec![Some(x.left(p.a).he()), Some(x.left(p.c1).t())],
        vec![None, Some(diag(nz))],
    ]);
    let lmi_x = in_x
        .left(&w.transpose())
        .right(&w)
        .add(&schur(&concat_rows(p.b1, p.d11), &w));
    let in_y = Affine::symmetric_blocks(&[
        vec![Some(y.right(p.a).he()), Some(y.right(p.b1))],
        vec![None, Some(diag(nw))],
    ]);
    let lmi_y = in_y.left(&v.transpose()).right(&v).add(&schur(
        &concat_rows(&p.c1.transpose(), &p.d11.transpose()),
        &v,
    ));
    (lmi_x, lmi_y)
}

/// The analytic centre of `{Ω : L(Ω) = Ψ + PᵀΩQ + QᵀΩᵀP ≺ 0}`, the maximiser of
/// `log det(−L(Ω))`, by damped Newton from a strictly feasible `Ω₀` (`log det` is
/// self-concordant, so the step `1/(1 + λ)` keeps `L ≺ 0` and the iteration converges).
///
/// Why this point: it is as far inside the set of controllers that achieve γ with the
/// Lyapunov matrix of `X, Y` as the set allows. (It is not the controller that the earlier
/// one-shot stage 2 — all of `X, Y, Â, B̂, Ĉ, D̂` in one SDP — returned: their frequency
/// responses differ by up to 370 % (relative, 0.1–100 Hz), and that one did worse in the time
/// domain on every scenario but the fault.)
/// Our own code rather than an SDP because the problem is a smooth unconstrained one with a
/// closed-form Hessian, `∂²/∂Ω_ij ∂Ω_kl = 2 (M₁_ik M₂_jl + M₃_il M₃_kj)` with `S = (−L)⁻¹`,
/// `M₁ = PSPᵀ`, `M₂ = QSQᵀ`, `M₃ = PSQᵀ` (gradient `2M₃`): about 10 ms against several seconds
/// for the same point from Clarabel with `Ω`'s 500 variables in a 65-row cone.
fn analytic_centre(
    psi: &DMatrix<f64>,
    pt: &DMatrix<f64>,
    q: &DMatrix<f64>,
    omega0: &DMatrix<f64>,
) -> Option<DMatrix<f64>> {
    let (nr, nc) = (pt.ncols(), q.nrows());
    let len = nr * nc;
    let lmi = |om: &DMatrix<f64>| {
        let t = pt * om * q;
        psi + &t + t.transpose()
    };
    let mut omega = omega0.clone();
    let mut previous = f64::INFINITY;
    for _ in 0..200 {
        let f = -lmi(&omega);
        let s = f.cholesky()?.inverse();
        let (sp, sq) = (&s * pt, &s * q.transpose());
        let (m1, m2, m3) = (pt.transpose() * &sp, q * &sq, pt.transpose() * &sq);
        let grad = DMatrix::from_fn(len, 1, |k, _| 2.0 * m3[(k % nr, k / nr)]);
        let hess = DMatrix::from_fn(len, len, |k, l| {
            let (i, j, a, b) = (k % nr, k / nr, l % nr, l / nr);
            2.0 * (m1[(i, a)] * m2[(j, b)] + m3[(i, b)] * m3[(a, j)])
        });
        let step = -hess.cholesky()?.solve(&grad);
        let decrement = (-(grad.transpose() * &step)[(0, 0)]).max(0.0).sqrt();
        let damping = if decrement > 0.25 {
            1.0 / (1.0 + decrement)
        } else {
            1.0
        };
        omega += DMatrix::from_column_slice(nr, nc, step.as_slice()) * damping;
        // Converged: at 1e-9, or where rounding stops the decrease below 1e-6 (the log-det
        // is then within λ²/2 < 1e-12 of its maximum; the road-state plant stalls at 4e-9).
        if decrement < 1e-9 || (decrement < 1e-6 && decrement >= previous) {
            return Some(omega);
        }
        previous = decrement;
    }
    None
}

/// The explicit central solution of `Ψ + Pᵀ Ω Q + Qᵀ Ωᵀ P ≺ 0` (Iwasaki & Skelton, Automatica
/// 30(8), 1994): `Ω = −μ P Φ Qᵀ (Q Φ Qᵀ)⁻¹`, `Φ = (μ Pᵀ P − Ψ)⁻¹ ≻ 0`, with `μ` increased until
/// `Φ ≻ 0` and the LMI holds (it exists because the projected LMIs hold). The starting point of
/// [`analytic_centre`].
fn solve_basic_lmi(
    psi: &DMatrix<f64>,
    pt: &DMatrix<f64>,
    q: &DMatrix<f64>,
) -> Option<DMatrix<f64>> {
    let ptp = pt * pt.transpose();
    let scale = psi.amax().max(1.0) / ptp.amax().max(1e-300);
    for k in 0..60 {
        let mu = scale * 2f64.powi(k - 10);
        let phi_inv = &ptp * mu - psi;
        let Some(chol) = phi_inv.clone().cholesky() else {
            continue;
        };
        let phi = chol.inverse();
        let qpq = q * &phi * q.transpose();
        let Some(qpq_inv) = qpq.try_inverse() else {
            continue;
        };
        let omega = -(pt.transpose() * &phi * q.transpose() * qpq_inv) * mu;
        let full = psi + pt * &omega * q + q.transpose() * omega.transpose() * pt.transpose();
        let sym = (&full + full.transpose()) * 0.5;
        if nalgebra::SymmetricEigen::new(sym).eigenvalues.max() < 0.0 {
            return Some(omega);
        }
    }
    None
}

/// Strictness of the stage-2 projected LMIs, relative to γ: room for the controller variables.
const RECONSTRUCTION_MARGIN: f64 = 1e-4;

/// Stage 1: the optimal γ from the reduced projected LMIs (`reduced_projected`) in the scaled
/// variables `X̃ = X/γ`, `Ỹ = Y/γ`, `η = 1/γ`: `max η` subject to `LMI_X(X̃, ζ) ≺ 0`,
/// `LMI_Y(Ỹ, ζ) ≺ 0`, `[X̃ ηI; ηI Ỹ] ≻ 0` and `[ζ η; η 1] ⪰ 0` (`ζ ≥ η²`). Both LMIs are linear
/// in `ζ` with a positive semidefinite coefficient, so at the optimum `ζ = η²` and the relaxation
/// is exact.
pub fn optimal_gamma(p: &OfPlant, eps: f64) -> Result<f64, LmiError> {
    optimal_gamma_balanced(&Balanced::new(p).plant(p), eps)
}

/// [`optimal_gamma`] of a plant already in balanced coordinates.
fn optimal_gamma_balanced(p: &OfPlant, eps: f64) -> Result<f64, LmiError> {
    let n = p.a.nrows();
    let mut s1 = Problem::new();
    let (x, y, eta, zeta) = (s1.symmetric(n), s1.symmetric(n), s1.scalar(), s1.scalar());
    let (lmi_x, lmi_y) =
        reduced_projected(p, &x.expr(), &y.expr(), &GammaTerms::scaled(&eta, &zeta));
    s1.negative_definite("reduced projected LMI in X", lmi_x, eps);
    s1.negative_definite("reduced projected LMI in Y", lmi_y, eps);
    let scaled_coupling = Affine::symmetric_blocks(&[
        vec![
            Some(x.expr()),
            Some(eta.expr().map_scalar(&DMatrix::identity(n, n))),
        ],
        vec![None, Some(y.expr())],
    ]);
    s1.positive_definite("[X̃ ηI; ηI Ỹ] ≻ 0", scaled_coupling, eps);
    let one = Affine::identity(1);
    // Its entries are O(η²) ≈ 1e-2…1e-3: a margin of ε would bias γ* by ~ε/(2η²) relative.
    s1.positive_definite(
        "ζ ≥ η²",
        Affine::symmetric_blocks(&[
            vec![Some(zeta.expr()), Some(eta.expr())],
            vec![None, Some(one)],
        ]),
        eps * 1e-4,
    );
    s1.minimise(&eta, -1.0);
    s1.without_iterative_refinement();
    Ok(1.0 / eta.value(&s1.solve()?.x)[(0, 0)])
}

/// What every output-feedback synthesis here takes besides the plant: the strictness margin `eps`
/// of its LMIs, the back-off `delta` from the optimum (`γ = (1 + delta) γ*`) and the bound
/// `beta` on `X, Y` (SPEC §5).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OfSettings {
    pub eps: f64,
    pub delta: f64,
    pub beta: f64,
}

/// The shipped synthesis, three stages (SPEC §5):
/// 1. γ* by [`optimal_gamma`];
/// 2. γ fixed at `(1 + delta) γ*`, `X, Y ⪯ βI`, coupling margin `t` in `[X I; I Y] ⪰ tI`
///    maximised, on the reduced projected LMIs (in `X, Y` only);
/// 3. `Ω = [Â B̂; Ĉ D̂]` the analytic centre of the full LMI at that `X, Y` (`analytic_centre`,
///    started from the Iwasaki–Skelton solution), and the Remark 5.1 reconstruction.
///
/// All on the balanced plant (`Balanced`). Stage 2 as one 65-row SDP with all of
/// `X, Y, Â, B̂, Ĉ, D̂` (777 variables) took ~7 s; stages 2–3 here take ~0.3 s.
pub fn hinf_of(p: &OfPlant, settings: OfSettings) -> Result<OutputFeedback, LmiError> {
    let OfSettings { eps, delta, beta } = settings;
    let balanced = Balanced::new(p);
    let p = &balanced.plant(p);
    let n = p.a.nrows();
    let (ny, nu) = (p.c2.nrows(), p.b2.ncols());
    let gamma_opt = optimal_gamma_balanced(p, eps)?;

    let gamma = (1.0 + delta) * gamma_opt;
    let mut s2 = Problem::new();
    let (xv, yv) = (s2.symmetric(n), s2.symmetric(n));
    let (xe, ye) = (xv.expr(), yv.expr());
    let (lmi_x, lmi_y) = reduced_projected(p, &xe, &ye, &GammaTerms::fixed(gamma));
    let strict = (RECONSTRUCTION_MARGIN * gamma).max(eps);
    s2.negative_definite("reduced projected LMI in X at fixed γ", lmi_x, strict);
    s2.negative_definite("reduced projected LMI in Y at fixed γ", lmi_y, strict);
    let t = maximise_coupling_margin(&mut s2, &xe, &ye, &[("X ⪯ βI", &xe), ("Y ⪯ βI", &ye)], beta);
    s2.without_iterative_refinement();
    let sol = s2.solve()?;
    let (x, y) = (xv.value(&sol.x), yv.value(&sol.x));

    let gconst = Affine::constant(DMatrix::from_element(1, 1, gamma));
    let psi_val = psi(
        p,
        &Affine::constant(x.clone()),
        &Affine::constant(y.clone()),
        &gconst,
    )
    .constant;
    let (pt, q) = basic_lmi_factors(p);
    let start = solve_basic_lmi(&psi_val, &pt, &q).ok_or(LmiError::Setup(
        "no explicit solution of the basic LMI was found".into(),
    ))?;
    let omega = analytic_centre(&psi_val, &pt, &q, &start).ok_or(LmiError::Setup(
        "the analytic centre of the controller LMI was not found".into(),
    ))?;
    let ah = omega.view((0, 0), (n, n)).into_owned();
    let bh = omega.view((0, n), (n, ny)).into_owned();
    let ch = omega.view((n, 0), (nu, n)).into_owned();
    let dh = omega.view((n, n), (nu, ny)).into_owned();
    reconstruct(
        p,
        &x,
        &y,
        &Lti::new(ah, bh, ch, dh),
        gamma,
        gamma_opt,
        t.value(&sol.x)[(0, 0)],
    )
}

/// [`hinf_of`] with the constraint LMIs (force, stroke, tyre load; see
/// [`crate::thesis::state_feedback`]): every output `cᵢ = C_c,i x + D_cu,i u` of the closed loop stays
/// within `|cᵢ(t)| ≤ 1` for every disturbance of energy `energy`. With the Lyapunov matrix `P` of
/// the H∞ LMI (common, as for state feedback) and, by the congruence with `Π₁ = [X I; Mᵀ 0]`
/// (Scherer, Gahinet & Chilali 1997, §IV), in the same linearising variables:
/// ```text
/// [ He(AX + B₂Ĉ)   Âᵀ + A          B₁          ]
/// [      *         He(YA + B̂C₂)    YB₁ + B̂D₂₁ ]  ≺ 0          (V̇ ≤ ‖w‖²)
/// [      *              *          −I          ]
/// [ X  I  (C_c,i X + D_cu,i Ĉ)ᵀ ]
/// [ I  Y  C_c,iᵀ               ]  ⪰ 0                              (|cᵢ|² ≤ E · V)
/// [ *  *  1/E                  ]
/// ```
/// The controller is strictly proper (`D̂ = D_K = 0`): the measurements carry sensor noise, so
/// a `D_K` would put `w` straight into the forces, whose peak over finite-energy inputs is then
/// unbounded. The constraints couple `Ĉ` to `X`, so the controller variables cannot be
/// eliminated as in [`hinf_of`]: stage 1 minimises γ over all of `X, Y, Â, B̂, Ĉ`; stage 2 fixes
/// γ at `(1 + delta)γ*`, bounds `X, Y ⪯ βI` and maximises the coupling margin; the controller is
/// rebuilt from stage 2's variables. Returns the controller and each constraint's peak bound.
/// Slow: on the car with the shaped road (n = 20, 13 constraints) about 4 minutes.
pub fn hinf_of_constrained(
    p: &OfPlant,
    c_c: &DMatrix<f64>,
    d_cu: &DMatrix<f64>,
    energy: f64,
    settings: OfSettings,
) -> Result<(OutputFeedback, Vec<f64>), LmiError> {
    let OfSettings { eps, delta, beta } = settings;
    let balanced = Balanced::new(p);
    let c_c = c_c * Balanced::diag(&balanced.d, 1.0);
    let p = &balanced.plant(p);
    let n = p.a.nrows();
    let (ny, nu, nw) = (p.c2.nrows(), p.b2.ncols(), p.b1.ncols());
    // The variables of `Ω` but `D̂` (0 here).
    struct StrictlyProper {
        x: Var,
        y: Var,
        ah: Var,
        bh: Var,
        ch: Var,
    }
    let build = |prob: &mut Problem, gamma: &Affine, strict: f64| -> StrictlyProper {
        let v = StrictlyProper {
            x: prob.symmetric(n),
            y: prob.symmetric(n),
            ah: prob.full(n, n),
            bh: prob.full(n, ny),
            ch: prob.full(nu, n),
        };
        let e = VarExprs {
            x: v.x.expr(),
            y: v.y.expr(),
            ah: v.ah.expr(),
            bh: v.bh.expr(),
            ch: v.ch.expr(),
            dh: Affine::zeros(nu, ny),
        };
        prob.negative_definite(
            "H∞ output-feedback LMI (D̂ = 0)",
            hinf_lmi_of(p, &e, gamma),
            strict,
        );
        let energy_lmi = Affine::symmetric_blocks(&[
            vec![
                Some(e.x.left(p.a).add(&e.ch.left(p.b2)).he()),
                Some(e.ah.t().add(&Affine::constant(p.a.clone()))),
                Some(Affine::constant(p.b1.clone())),
            ],
            vec![
                None,
                Some(e.y.right(p.a).add(&e.bh.right(p.c2)).he()),
                Some(e.y.right(p.b1).add(&e.bh.right(p.d21))),
            ],
            vec![None, None, Some(Affine::identity(nw).scale(-1.0))],
        ]);
        prob.negative_definite("energy LMI (V ≤ ‖w‖²)", energy_lmi, eps);
        for i in 0..c_c.nrows() {
            let (ci, di) = (c_c.rows(i, 1).into_owned(), d_cu.rows(i, 1).into_owned());
            let peak = Affine::symmetric_blocks(&[
                vec![
                    Some(e.x.clone()),
                    Some(Affine::identity(n)),
                    Some(e.x.left(&ci).add(&e.ch.left(&di)).t()),
                ],
                vec![
                    None,
                    Some(e.y.clone()),
                    Some(Affine::constant(ci.transpose())),
                ],
                vec![
                    None,
                    None,
                    Some(Affine::constant(DMatrix::from_element(1, 1, 1.0 / energy))),
                ],
            ]);
            prob.positive_definite(&format!("peak bound on constraint {i}"), peak, eps);
        }
        v
    };
    let mut s1 = Problem::new();
    let g1 = s1.scalar();
    let v1 = build(&mut s1, &g1.expr(), eps);
    s1.positive_definite("[X I; I Y] ≻ 0", coupling(&v1.x.expr(), &v1.y.expr()), eps);
    s1.minimise(&g1, 1.0);
    let gamma_opt = g1.value(&s1.solve()?.x)[(0, 0)];

    let gamma = (1.0 + delta) * gamma_opt;
    let mut s2 = Problem::new();
    let v = build(
        &mut s2,
        &Affine::constant(DMatrix::from_element(1, 1, gamma)),
        (RECONSTRUCTION_MARGIN * gamma).max(eps),
    );
    let (xe, ye) = (v.x.expr(), v.y.expr());
    let t = maximise_coupling_margin(&mut s2, &xe, &ye, &[("X ⪯ βI", &xe), ("Y ⪯ βI", &ye)], beta);
    let sol = s2.solve()?;
    let (x, y, ch) = (v.x.value(&sol.x), v.y.value(&sol.x), v.ch.value(&sol.x));
    // The bound each peak LMI proves: E · [cX + dĈ, c] [X I; I Y]⁻¹ [cX + dĈ, c]ᵀ.
    let pi = coupling(&Affine::constant(x.clone()), &Affine::constant(y.clone())).constant;
    let pi_inv = pi
        .cholesky()
        .ok_or(LmiError::Setup(
            "[X I; I Y] is not positive definite".into(),
        ))?
        .inverse();
    let bounds = (0..c_c.nrows())
        .map(|i| {
            let mut row = DMatrix::zeros(1, 2 * n);
            row.view_mut((0, 0), (1, n))
                .copy_from(&(c_c.rows(i, 1) * &x + d_cu.rows(i, 1) * &ch));
            row.view_mut((0, n), (1, n)).copy_from(&c_c.rows(i, 1));
            (energy * (&row * &pi_inv * row.transpose())[(0, 0)]).sqrt()
        })
        .collect();
    let of = reconstruct(
        p,
        &x,
        &y,
        &Lti::new(
            v.ah.value(&sol.x),
            v.bh.value(&sol.x),
            ch,
            DMatrix::zeros(nu, ny),
        ),
        gamma,
        gamma_opt,
        t.value(&sol.x)[(0, 0)],
    )?;
    Ok((of, bounds))
}

/// Remark 5.1: controller from `X, Y` and the linearising variables, `N = I`, `M = I − XY`.
fn reconstruct(
    p: &OfPlant,
    x: &DMatrix<f64>,
    y: &DMatrix<f64>,
    hat: &Lti,
    gamma: f64,
    gamma_opt: f64,
    margin: f64,
) -> Result<OutputFeedback, LmiError> {
    let n = p.a.nrows();
    let ident = DMatrix::<f64>::identity(n, n);
    let m = &ident - x * y;
    let mt_inv = m
        .transpose()
        .try_inverse()
        .ok_or(LmiError::Setup("I − XY is singular".into()))?;
    let sv = m.singular_values();
    let (ah, bh, ch) = (&hat.a, &hat.b, &hat.c);
    let dk = hat.d.clone();
    let ck = (ch - &dk * p.c2 * x) * &mt_inv;
    let bk = bh - y * p.b2 * &dk;
    let ak =
        (ah - &bk * p.c2 * x - y * p.b2 * &ck * m.transpose() - y * (p.a + p.b2 * &dk * p.c2) * x)
            * &mt_inv;
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
///
/// Solved on the vertices balanced with the centre plant's scaling (`Balanced`): `X̄ = D⁻¹XD⁻¹`,
/// `Ĉ̄ = ĈD⁻¹` (so `ĀX̄ + B̄₂Ĉ̄ = D⁻¹(AX + B₂Ĉ)D⁻¹`). Unbalanced, Clarabel stopped with
/// NumericalError on stage 2 for some weights (roll weight 0.8).
pub fn hinf_of_common_x(
    vertices: &[OfPlant],
    center: &OfPlant,
    x: &DMatrix<f64>,
    ch: &DMatrix<f64>,
    settings: OfSettings,
) -> Result<OutputFeedback, LmiError> {
    let OfSettings { eps, delta, beta } = settings;
    let balanced_center = Balanced::new(center);
    let scaling = balanced_center.d.clone();
    let balanced: Vec<Balanced> = vertices
        .iter()
        .map(|v| Balanced::with_scaling(v, scaling.clone()))
        .collect();
    let vertices: Vec<OfPlant> = balanced
        .iter()
        .zip(vertices)
        .map(|(b, v)| b.plant(v))
        .collect();
    let vertices = &vertices[..];
    let center = &balanced_center.plant(center);
    let dinv = Balanced::diag(&scaling, -1.0);
    let (x, ch) = (&(&dinv * x * &dinv), &(ch * &dinv));
    let n = center.a.nrows();
    let (ny, nu) = (center.c2.nrows(), center.b2.ncols());
    let build = |prob: &mut Problem, gamma: &Affine, strict: f64| -> (Var, Var, Var) {
        let (yv, ahv, bhv) = (prob.symmetric(n), prob.full(n, n), prob.full(n, ny));
        for (i, v) in vertices.iter().enumerate() {
            let y = yv.expr();
            let shift = y.right(&((v.a - center.a) * x + (v.b2 - center.b2) * ch));
            let e = VarExprs {
                x: Affine::constant(x.clone()),
                y,
                ah: ahv.expr().add(&shift),
                bh: bhv.expr(),
                ch: Affine::constant(ch.clone()),
                dh: Affine::zeros(nu, ny),
            };
            prob.negative_definite(
                &format!("H∞ output-feedback LMI at vertex {i}"),
                hinf_lmi_of(v, &e, gamma),
                strict,
            );
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
    let (yv, ahv, bhv) = build(
        &mut s2,
        &Affine::constant(DMatrix::from_element(1, 1, gamma)),
        eps,
    );
    let ye = yv.expr();
    let t = maximise_coupling_margin(&mut s2, &xc, &ye, &[("Y ⪯ βI", &ye)], beta);
    let sol = s2.solve()?;
    let (y, ah, bh) = (yv.value(&sol.x), ahv.value(&sol.x), bhv.value(&sol.x));
    reconstruct(
        center,
        x,
        &y,
        &Lti::new(ah, bh, ch.clone(), DMatrix::zeros(nu, ny)),
        gamma,
        gamma_opt,
        t.value(&sol.x)[(0, 0)],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    const SETTINGS: OfSettings = OfSettings {
        eps: 1e-7,
        delta: 0.02,
        beta: 1e3,
    };
    use crate::numerics::hinf_norm::Analysis;
    use crate::shipping::design::Design;
    use crate::thesis::certificate::closed_loop;
    use crate::thesis::generalized::GeneralizedPlant;

    /// The constrained synthesis on a quarter car (u in kN): the closed loop it rebuilds meets
    /// its γ (Hamiltonian bisection) and each constraint's exact energy-to-peak gain (Gramian) is
    /// within the bound the LMIs prove and within 1, at an energy where the unconstrained design
    /// exceeds a limit by half — so the constraints are what holds it.
    #[test]
    fn constrained_output_feedback_meets_its_gamma_and_its_peak_bounds() {
        let (ms, mu, ks, cs, kt) = (300.0, 40.0, 2.0e4, 1.0e3, 2.0e5);
        #[rustfmt::skip]
        let a = DMatrix::from_row_slice(4, 4, &[
            0.0, 0.0, 1.0, 0.0,
            0.0, 0.0, 0.0, 1.0,
            -ks / ms, ks / ms, -cs / ms, cs / ms,
            ks / mu, -(ks + kt) / mu, cs / mu, -cs / mu,
        ]);
        // w: a force on the wheel (kN), then noise on the two measurements.
        let b1 = DMatrix::from_row_slice(
            4,
            3,
            &[
                0.0,
                0.0,
                0.0,
                0.0,
                0.0,
                0.0,
                0.0,
                0.0,
                0.0,
                1e3 / mu,
                0.0,
                0.0,
            ],
        );
        let b2 = DMatrix::from_row_slice(4, 1, &[0.0, 0.0, 1e3 / ms, -1e3 / mu]);
        // z: body acceleration, then the control penalty.
        let c1 = DMatrix::from_row_slice(
            2,
            4,
            &[-ks / ms, ks / ms, -cs / ms, cs / ms, 0.0, 0.0, 0.0, 0.0],
        );
        let d12 = DMatrix::from_row_slice(2, 1, &[1e3 / ms, 1.0]);
        let d11 = DMatrix::zeros(2, 3);
        // y: stroke and body velocity, with noise.
        let c2 = DMatrix::from_row_slice(2, 4, &[1.0, -1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
        let d21 = DMatrix::from_row_slice(2, 3, &[0.0, 1e-3, 0.0, 0.0, 0.0, 5e-3]);
        // c: stroke over 5 cm, force over 5 kN (at 1 kN the constrained problem is infeasible
        // at this energy: Clarabel stops with InsufficientProgress).
        let c_c = DMatrix::from_row_slice(2, 4, &[20.0, -20.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        let d_cu = DMatrix::from_row_slice(2, 1, &[0.0, 0.2]);
        let g = GeneralizedPlant {
            a,
            b_w: b1,
            b_u: b2,
            c_z: c1,
            d_zw: d11,
            d_zu: d12,
            c_y: c2,
            d_yw: d21,
            c_c,
            d_cu,
            constraint_names: vec!["stroke".into(), "force".into()],
            road_scale: Vec::new(),
            road_model: crate::shipping::design::RoadModel::Independent,
        };
        let p = OfPlant::of(&g);
        // The energy at which the unconstrained design's stroke peaks at 1.5 of its limit (its
        // force, with D_K ≠ 0, has no finite peak at all).
        let free = hinf_of(&p, SETTINGS).unwrap();
        let free_stroke = closed_loop(
            &g.constraint_plant(),
            &g.output_measurement(),
            &free.controller,
        )
        .select_outputs(&[0])
        .energy_to_peak()
        .unwrap()[0];
        let energy = (1.5 / free_stroke).powi(2);
        let (of, bounds) = hinf_of_constrained(&p, &g.c_c, &g.d_cu, energy, SETTINGS).unwrap();
        let norm = closed_loop(&g, &g.output_measurement(), &of.controller)
            .hinf_norm(1e-9)
            .unwrap();
        assert!(
            norm.upper <= of.gamma * (1.0 + 1e-6) && of.gamma >= free.gamma_opt * (1.0 - 1e-6),
            "{} vs γ {} (free γ* {})",
            norm.upper,
            of.gamma,
            free.gamma_opt
        );
        // Each Gramian peak within the LMI's bound and within 1 (the certificate's check).
        let claimed: Vec<(String, f64)> = g.constraint_names.iter().cloned().zip(bounds).collect();
        crate::thesis::certificate::certify_peaks(
            "test",
            &g,
            &g.output_measurement(),
            &of.controller,
            energy,
            &claimed,
        )
        .unwrap();
    }

    #[test]
    fn reduced_projected_gamma_matches_the_one_shot_lmi_and_the_controller_certifies() {
        let d = Design::default();
        let g = GeneralizedPlant::new(&vehicle::VehicleParams::default(), &d).with_sensor_noise(&d);
        let p = OfPlant::of(&g);
        // Stage 1 by the reduced, scaled projected LMIs against all of X, Y, Â, B̂, Ĉ, D̂ in one
        // 65-row LMI (unbalanced coordinates: a second formulation in other coordinates).
        let reduced = optimal_gamma(&p, d.lmi_margin).unwrap();
        let one_shot = optimal_gamma_one_shot(&p, d.lmi_margin).unwrap();
        let rel = (reduced - one_shot).abs() / one_shot;
        assert!(
            rel < 1e-6,
            "γ*: reduced {reduced} vs one-shot {one_shot} ({rel:e})"
        );
        let of = hinf_of(
            &p,
            OfSettings {
                eps: d.lmi_margin,
                ..SETTINGS
            },
        )
        .unwrap();
        assert_eq!(of.gamma_opt, reduced);
        let norm = closed_loop(&g, &g.output_measurement(), &of.controller)
            .hinf_norm(1e-9)
            .unwrap();
        assert!(
            norm.upper <= of.gamma * (1.0 + 1e-6),
            "{} > {}",
            norm.upper,
            of.gamma
        );
    }

    #[test]
    fn stage_one_lmis_are_the_fixed_gamma_lmis_times_eta() {
        // LMI(X̃ = X/γ, η = 1/γ, ζ = η²) = η · LMI(X, γ), for any X, Y and the real plant.
        let d = Design::default();
        let g = GeneralizedPlant::new(&vehicle::VehicleParams::default(), &d).with_sensor_noise(&d);
        let p = OfPlant::of(&g);
        let n = p.a.nrows();
        let x = DMatrix::from_fn(n, n, |i, j| 1.0 / (1.0 + i as f64 + j as f64))
            + DMatrix::identity(n, n);
        let y = DMatrix::from_fn(n, n, |i, j| ((i * j) % 5) as f64 - 2.0);
        let y = &y + y.transpose();
        let gamma = 13.0;
        let (fx, fy) = reduced_projected(
            &p,
            &Affine::constant(x.clone()),
            &Affine::constant(y.clone()),
            &GammaTerms::fixed(gamma),
        );
        let mut pr = Problem::new();
        let (eta, zeta) = (pr.scalar(), pr.scalar());
        let (sx, sy) = reduced_projected(
            &p,
            &Affine::constant(&x / gamma),
            &Affine::constant(&y / gamma),
            &GammaTerms::scaled(&eta, &zeta),
        );
        let vals = [1.0 / gamma, 1.0 / gamma / gamma];
        assert!((sx.eval(&vals) - &fx.constant / gamma).amax() < 1e-12 * fx.constant.amax());
        assert!((sy.eval(&vals) - &fy.constant / gamma).amax() < 1e-12 * fy.constant.amax());
    }

    #[test]
    fn reduced_lmis_hold_exactly_when_the_full_projected_lmis_do() {
        // The Schur complement against the uneliminated projected LMI `N_Pᵀ Ψ N_P`, built from
        // `Ψ` and the bases directly, at points on both sides of feasibility.
        let d = Design::default();
        let g = GeneralizedPlant::new(&vehicle::VehicleParams::default(), &d).with_sensor_noise(&d);
        let p = OfPlant::of(&g);
        let (n, nw, nz) = (p.a.nrows(), p.b1.ncols(), p.c1.nrows());
        let balanced = Balanced::new(&p);
        let p = &balanced.plant(&p);
        let (w, v) = null_bases(p);
        let size = 2 * n + nw + nz;
        let mut np = DMatrix::zeros(size, w.ncols() + nw);
        np.view_mut((0, 0), (n, w.ncols())).copy_from(&w.rows(0, n));
        np.view_mut((2 * n + nw, 0), (nz, w.ncols()))
            .copy_from(&w.rows(n, nz));
        np.view_mut((2 * n, w.ncols()), (nw, nw))
            .fill_with_identity();
        let mut nq = DMatrix::zeros(size, v.ncols() + nz);
        nq.view_mut((n, 0), (n + nw, v.ncols())).copy_from(&v);
        nq.view_mut((2 * n + nw, v.ncols()), (nz, nz))
            .fill_with_identity();
        let max_eig = |m: &DMatrix<f64>| {
            nalgebra::SymmetricEigen::new((m + m.transpose()) * 0.5)
                .eigenvalues
                .max()
        };
        // A point where the reduced LMIs hold at γ = 14 (γ* ≈ 13.1), then γ on both sides.
        let mut prob = Problem::new();
        let (xv, yv) = (prob.symmetric(n), prob.symmetric(n));
        let (lx, ly) = reduced_projected(p, &xv.expr(), &yv.expr(), &GammaTerms::fixed(14.0));
        prob.negative_definite("x", lx, 1e-6);
        prob.negative_definite("y", ly, 1e-6);
        prob.positive_definite("coupling", coupling(&xv.expr(), &yv.expr()), 1e-6);
        let sol = prob.solve().unwrap();
        let (x, y) = (xv.value(&sol.x), yv.value(&sol.x));
        let mut outcomes = Vec::new();
        for gamma in [1e3, 14.0, 13.0, 12.0, 5.0] {
            for (xs, ys) in [(x.clone(), y.clone()), (&x * 0.5, &y * 2.0)] {
                let gc = Affine::constant(DMatrix::from_element(1, 1, gamma));
                let full = psi(
                    p,
                    &Affine::constant(xs.clone()),
                    &Affine::constant(ys.clone()),
                    &gc,
                )
                .constant;
                let (rx, ry) = reduced_projected(
                    p,
                    &Affine::constant(xs.clone()),
                    &Affine::constant(ys.clone()),
                    &GammaTerms::fixed(gamma),
                );
                let pairs = [
                    (
                        max_eig(&(np.transpose() * &full * &np)),
                        max_eig(&rx.constant),
                    ),
                    (
                        max_eig(&(nq.transpose() * &full * &nq)),
                        max_eig(&ry.constant),
                    ),
                ];
                for (unreduced, reduced) in pairs {
                    assert_eq!(
                        unreduced < 0.0,
                        reduced < 0.0,
                        "γ {gamma}: {unreduced} vs {reduced}"
                    );
                    outcomes.push(reduced < 0.0);
                }
            }
        }
        assert!(
            outcomes.iter().any(|o| *o) && outcomes.iter().any(|o| !*o),
            "both sides of feasibility were tried"
        );
    }

    #[test]
    fn analytic_centre_is_stationary_and_beats_its_neighbours() {
        let pt = DMatrix::from_fn(6, 2, |i, j| ((i * 3 + j * 5) % 7) as f64 - 3.0);
        let q = DMatrix::from_fn(3, 6, |i, j| ((i * 2 + j * 3) % 5) as f64 - 2.0);
        let omega0 = DMatrix::from_fn(2, 3, |i, j| (i as f64 - j as f64) * 0.3);
        let psi = DMatrix::<f64>::identity(6, 6) * -1.0
            - (&pt * &omega0 * &q + q.transpose() * omega0.transpose() * pt.transpose());
        let logdet = |om: &DMatrix<f64>| {
            let l = &psi + &pt * om * &q + q.transpose() * om.transpose() * pt.transpose();
            (-l).cholesky()
                .map(|c| 2.0 * c.l().diagonal().map(f64::ln).sum())
                .unwrap_or(f64::NEG_INFINITY)
        };
        let start = solve_basic_lmi(&psi, &pt, &q).unwrap();
        let centre = analytic_centre(&psi, &pt, &q, &start).unwrap();
        let best = logdet(&centre);
        assert!(best.is_finite() && best >= logdet(&start));
        for k in 0..6 {
            for h in [1e-3, -1e-3, 1e-1] {
                let mut e = DMatrix::zeros(2, 3);
                e[(k % 2, k / 2)] = h;
                assert!(
                    logdet(&(&centre + &e)) <= best + 1e-12,
                    "direction {k}, step {h}"
                );
                // Central differences: the gradient vanishes at the centre.
                if h == 1e-3 {
                    let slope = (logdet(&(&centre + &e)) - logdet(&(&centre - &e))) / (2.0 * h);
                    assert!(slope.abs() < 1e-6, "slope {slope} in direction {k}");
                }
            }
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
        let psi =
            &base - (&pt * &omega0 * &q + q.transpose() * omega0.transpose() * pt.transpose());
        let omega = solve_basic_lmi(&psi, &pt, &q).expect("solvable");
        let full = &psi + &pt * &omega * &q + q.transpose() * omega.transpose() * pt.transpose();
        assert!(
            nalgebra::SymmetricEigen::new((&full + full.transpose()) * 0.5)
                .eigenvalues
                .max()
                < 0.0
        );
    }
}
