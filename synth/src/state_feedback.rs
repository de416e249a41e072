//! `hinf_sf`: H∞ state feedback `u = K x` (thesis Th. 5.1, eq. 5.4, corrected).
//!
//! Bounded-real lemma with `Q = P⁻¹`, `Y = K Q` (linearising change of variables), γ entering
//! linearly (V̇ + zᵀz/γ − γ wᵀw < 0):
//! ```text
//! [ He(A Q + B_u Y)   B_w    (C_z Q + D_zu Y)ᵀ ]
//! [       *          −γ I         D_zwᵀ        ]  ≺ 0,   Q ≻ 0.
//! [       *            *          −γ I         ]
//! ```
//! Thesis eq. 5.4 omits `D_zu Y`: the seat and body accelerations respond *directly* to the
//! actuator forces, so without it the LMI certifies a different closed loop than the real one.
//!
//! Constraints (thesis ch. 5: force and stroke limits) as energy-to-peak bounds with a common
//! Lyapunov matrix (Scherer, Gahinet & Chilali, IEEE TAC 42(7), 1997): `He(AQ + B_uY) + B_w B_wᵀ ≺ 0`
//! gives `xᵀQ⁻¹x < ‖w‖₂²`, and `[[Q, (CᵢQ + DᵢY)ᵀ], [CᵢQ + DᵢY, 1/E]] ⪰ 0` then bounds
//! `|cᵢ(t)| ≤ 1` for every disturbance of energy `‖w‖₂² ≤ E` (the design bump's energy).

use crate::generalized::{GeneralizedPlant, FORCE_UNIT};
use crate::lmi::{Affine, LmiError, Problem};
use nalgebra::DMatrix;

#[derive(Debug, Clone)]
pub struct StateFeedback {
    /// `u [N] = K x` (x in the plant's units).
    pub k: DMatrix<f64>,
    /// The γ the LMI guarantees: `‖T_zw‖∞ < γ` for the scaled `w`, `z`.
    pub gamma: f64,
    /// `max_t |cᵢ(t)|` bound for the design disturbance, per constraint (must be ≤ 1).
    pub peak_bounds: Vec<(String, f64)>,
    pub solver_status: String,
    pub iterations: u32,
    /// The LMI solution: `Q = P⁻¹` and `Y = K̃ Q` (K̃ in the scaled units of the plant).
    pub q: DMatrix<f64>,
    pub y: DMatrix<f64>,
    /// Norm-bounded designs: the optimal Lemma 1 multiplier ε of the first plant.
    pub multiplier: Option<f64>,
}

/// The terms shared by all state-feedback designs: `He(AQ + B_uY)`.
pub(crate) fn lyapunov_term(a: &DMatrix<f64>, b_u: &DMatrix<f64>, q: &Affine, y: &Affine) -> Affine {
    q.left(a).add(&y.left(b_u)).he()
}

pub fn hinf_sf(g: &GeneralizedPlant, eps: f64, design_energy: Option<f64>) -> Result<StateFeedback, LmiError> {
    hinf_sf_robust(&[g], None, eps, design_energy)
}

/// The state-feedback bounded-real LMI of `g` at `(Q, Y, γ)`.
fn bounded_real(g: &GeneralizedPlant, q: &Affine, y: &Affine, gamma: &Affine) -> Affine {
    let (nw, nz) = (g.b_w.ncols(), g.c_z.nrows());
    let czq = q.left(&g.c_z).add(&y.left(&g.d_zu));
    let minus_gamma = |k: usize| gamma.map_scalar(&(-DMatrix::identity(k, k)));
    Affine::symmetric_blocks(&[
        vec![Some(lyapunov_term(&g.a, &g.b_u, q, y)), Some(Affine::constant(g.b_w.clone())), Some(czq.t())],
        vec![None, Some(minus_gamma(nw)), Some(Affine::constant(g.d_zw.transpose()))],
        vec![None, None, Some(minus_gamma(nz))],
    ])
}

/// A norm-bounded uncertainty `[ΔA ΔB_u; ΔC_z ΔD_zu] = H Δ E` (`H = [H_x; H_z]`, `E = [E_x E_u]`):
/// `Δ` any matrix with `‖Δ‖ ≤ 1` (one multiplier), or with `diagonal`, `Δ = diag(δᵢ)`, `|δᵢ| ≤ 1`
/// (one multiplier per `δᵢ`, which commute with `Δ`: less conservative).
#[derive(Debug, Clone)]
pub struct NormBounded {
    pub h: DMatrix<f64>,
    pub e: DMatrix<f64>,
    pub diagonal: bool,
}

/// State feedback with one `(Q, Y)` for every plant of `plants` (the vertices of a polytope,
/// or the nominal plant alone) and, optionally, a norm-bounded uncertainty around `plants[0]`.
///
/// Norm-bounded (thesis Lemma 1, Th. 6.1): `Ψ + M δ N + (M δ N)ᵀ ≺ 0` for all `|δ| ≤ 1` holds
/// if `Ψ + ε M Mᵀ + ε⁻¹ NᵀN ≺ 0` for some `ε > 0`, with `M = [H_x; 0; H_z]`,
/// `N = [E_x Q + E_u Y, 0, 0]`. By a Schur complement this is
/// `[Ψ + ε M Mᵀ, Nᵀ; N, −ε I] ≺ 0`, jointly linear in `(Q, Y, γ, ε)`: ε is optimised with the
/// rest instead of being fixed as in the thesis.
pub fn hinf_sf_robust(plants: &[&GeneralizedPlant], norm_bounded: Option<&NormBounded>, eps: f64, design_energy: Option<f64>) -> Result<StateFeedback, LmiError> {
    let g = plants[0];
    let n = g.n();
    let (nw, nu) = (g.b_w.ncols(), g.b_u.ncols());
    let mut p = Problem::new();
    let qv = p.symmetric(n);
    let yv = p.full(nu, n);
    let gamma = p.scalar();
    let (q, y) = (qv.expr(), yv.expr());
    let mut multipliers = Vec::new();
    for (i, gi) in plants.iter().enumerate() {
        assert!(gi.b_w == g.b_w && gi.d_zw == g.d_zw, "the plants may differ only in A, B_u, C_z, D_zu");
        let brl = bounded_real(gi, &q, &y, &gamma.expr());
        match norm_bounded {
            None => p.negative_definite(&format!("H∞ bounded-real LMI, plant {i}"), brl, eps),
            Some(nb) => {
                let (r, nz) = (nb.h.ncols(), g.c_z.nrows());
                let mut m = DMatrix::zeros(n + nw + nz, r);
                m.view_mut((0, 0), (n, r)).copy_from(&nb.h.rows(0, n));
                m.view_mut((n + nw, 0), (nz, r)).copy_from(&nb.h.rows(n, nz));
                // The multiplier S = εI, or diag(εᵢ) for a diagonal Δ: Ψ + M S Mᵀ + Nᵀ S⁻¹ N ≺ 0.
                let eps_vars: Vec<_> = (0..if nb.diagonal { r } else { 1 }).map(|_| p.scalar()).collect();
                multipliers.extend(eps_vars.iter().copied());
                let unit = |i: usize| DMatrix::from_fn(r, r, |a, b| if a == b && (!nb.diagonal || a == i) { 1.0 } else { 0.0 });
                let s_m = Affine::combination(&eps_vars, unit);
                let m_s_mt = Affine::combination(&eps_vars, |i| &m * unit(i) * m.transpose());
                let e_x = nb.e.columns(0, n).into_owned();
                let e_u = nb.e.columns(n, nu).into_owned();
                let nq = q.left(&e_x).add(&y.left(&e_u));
                let n_full = nq.embed(r, n + nw + nz, 0, 0);
                let lmi = Affine::symmetric_blocks(&[vec![Some(brl.add(&m_s_mt)), Some(n_full.t())], vec![None, Some(s_m.scale(-1.0))]]);
                p.negative_definite(&format!("norm-bounded robust H∞ LMI (Lemma 1), plant {i}"), lmi, eps);
                for v in &eps_vars {
                    p.positive_definite("ε > 0", v.expr(), eps);
                }
            }
        }
    }
    p.positive_definite("Q ≻ 0", q.clone(), eps);
    if let Some(energy) = design_energy {
        for gi in plants {
            let energy_lmi = Affine::symmetric_blocks(&[
                vec![Some(lyapunov_term(&gi.a, &gi.b_u, &q, &y)), Some(Affine::constant(g.b_w.clone()))],
                vec![None, Some(Affine::identity(nw).scale(-1.0))],
            ]);
            p.negative_definite("energy LMI (V ≤ ‖w‖²)", energy_lmi, eps);
        }
        for i in 0..g.c_c.nrows() {
            let ci = q.left(&g.c_c.rows(i, 1).into_owned()).add(&y.left(&g.d_cu.rows(i, 1).into_owned()));
            let peak = Affine::symmetric_blocks(&[vec![Some(q.clone()), Some(ci.t())], vec![None, Some(Affine::constant(DMatrix::from_element(1, 1, 1.0 / energy)))]]);
            p.positive_definite(&format!("peak bound on {}", g.constraint_names[i]), peak, 0.0);
        }
    }
    p.minimise(&gamma, 1.0);
    let s = p.solve()?;
    let qm = qv.value(&s.x);
    let ym = yv.value(&s.x);
    let q_inv = qm.clone().cholesky().expect("Q ≻ 0 was checked").inverse();
    let k_scaled = &ym * &q_inv;
    let peak_bounds = match design_energy {
        Some(e) => (0..g.c_c.nrows())
            .map(|i| {
                let ci = g.c_c.rows(i, 1) * &qm + g.d_cu.rows(i, 1) * &ym;
                (g.constraint_names[i].clone(), (e * (&ci * &q_inv * ci.transpose())[(0, 0)]).sqrt())
            })
            .collect(),
        None => Vec::new(),
    };
    Ok(StateFeedback {
        k: k_scaled * FORCE_UNIT,
        gamma: gamma.value(&s.x)[(0, 0)],
        peak_bounds,
        solver_status: s.status,
        iterations: s.iterations,
        q: qm,
        y: ym,
        multiplier: multipliers.first().map(|v| v.value(&s.x)[(0, 0)]),
    })
}
