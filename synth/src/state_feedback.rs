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
}

/// The terms shared by all state-feedback designs: `He(AQ + B_uY)`.
pub(crate) fn lyapunov_term(a: &DMatrix<f64>, b_u: &DMatrix<f64>, q: &Affine, y: &Affine) -> Affine {
    q.left(a).add(&y.left(b_u)).he()
}

pub fn hinf_sf(g: &GeneralizedPlant, eps: f64, design_energy: Option<f64>) -> Result<StateFeedback, LmiError> {
    let n = g.n();
    let (nw, nz, nu) = (g.b_w.ncols(), g.c_z.nrows(), g.b_u.ncols());
    let mut p = Problem::new();
    let qv = p.symmetric(n);
    let yv = p.full(nu, n);
    let gamma = p.scalar();
    let (q, y) = (qv.expr(), yv.expr());
    let lyap = lyapunov_term(&g.a, &g.b_u, &q, &y);
    let czq = q.left(&g.c_z).add(&y.left(&g.d_zu));
    let minus_gamma = |k: usize| gamma.expr().map_scalar(&(-DMatrix::identity(k, k)));
    let hinf = Affine::symmetric_blocks(&[
        vec![Some(lyap.clone()), Some(Affine::constant(g.b_w.clone())), Some(czq.t())],
        vec![None, Some(minus_gamma(nw)), Some(Affine::constant(g.d_zw.transpose()))],
        vec![None, None, Some(minus_gamma(nz))],
    ]);
    p.negative_definite("H∞ bounded-real LMI", hinf, eps);
    p.positive_definite("Q ≻ 0", q.clone(), eps);
    if let Some(energy) = design_energy {
        let energy_lmi = Affine::symmetric_blocks(&[
            vec![Some(lyap), Some(Affine::constant(g.b_w.clone()))],
            vec![None, Some(Affine::identity(nw).scale(-1.0))],
        ]);
        p.negative_definite("energy LMI (V ≤ ‖w‖²)", energy_lmi, eps);
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
    })
}
