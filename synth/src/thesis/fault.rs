//! `ft_of`: fault-tolerant output feedback with an observer and a residual (thesis ch. 8,
//! Th. 8.1, corrected).
//!
//! **What the thesis gets wrong.** LMIs 8.6–8.8 put the fault input `f` in the bounded-real
//! inequality with a `0` where `−γ²I` belongs: the block `diag(…, 0, …) ≺ 0` cannot hold, so the
//! LMIs have no strictly feasible point and Th. 8.1 certifies nothing. The Lyapunov function of
//! the proof also uses `P` and `R` for the same error term, and the residual is driven by the
//! fault *and* by the road, which the observer does not know (eq. 8.4 writes `B_f u`).
//!
//! **What we build.** The fault is what the plant FMU models (thesis fig. 8.2): a loss of
//! effectiveness, the applied force being `ρᵢ uᵢ` with `ρᵢ ∈ [ρ_min, 1]` per actuator. The
//! closed loop is affine in `ρ`, so the box `[ρ_min, 1]⁵` is a polytope with 32 vertices and one
//! Lyapunov matrix valid at all of them is valid on the whole box. The controller is the scheme of
//! fig. 8.1 made consistent: an observer `x̂̇ = A x̂ + B_u u + L r` driven by the *residual*
//! `r = y − C_y x̂`, and the control `u = F x̂` (the thesis's `B_e e` path is the `L r` term: the
//! controller's state is the observer's). In `(x, e = x − x̂)` coordinates, at effectiveness
//! `D_ρ = diag(ρ)`:
//! ```text
//! ẋ = (A + B D_ρ F) x − B D_ρ F e + B_w w
//! ė = B (D_ρ − I) F x + (A − L C_y − B (D_ρ − I) F) e + (B_w − L D_yw) w
//! z = (C_z + D_zu D_ρ F) x − D_zu D_ρ F e + D_zw w
//! ```
//! Healthy (`ρ = 1`) the loop is block-triangular and the residual sees only the road and the
//! sensor noise; a fault couples `x` into `e` and so into `r` — that is what detection uses.
//! With `F` fixed (the robust state feedback over the same 32 vertices), `P = diag(P₁, P₂)` and
//! `Λ = P₂ L`, the bounded-real inequality at each vertex is linear in `(P₁, P₂, Λ, γ)`; `L = P₂⁻¹ Λ`.
//! The block-diagonal `P` is a restriction (sound, possibly conservative); the certificate
//! recomputes the closed-loop H∞ norm at every vertex by Hamiltonian bisection.

use crate::numerics::hinf_norm::Controller;
use crate::numerics::hinf_norm::{Analysis, Lti};
use crate::numerics::lmi::{Affine, LmiError, Problem};
use crate::shipping::controller_file::{matrix_rows, DetectorInput, FaultDetection};
use crate::thesis::certificate::{closed_loop, CertificateError, NORM_TOLERANCE};
use crate::thesis::generalized::{GeneralizedPlant, FORCE_UNIT};
use crate::thesis::state_feedback::NormBounded;
use nalgebra::DMatrix;
use vehicle::model::N_ACTUATORS;

/// The fault set: every actuator's effectiveness in `[rho_min, 1]`, independently.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FaultBox {
    pub rho_min: f64,
}

impl FaultBox {
    /// The `2⁵` vertices, healthy first.
    pub fn vertices(&self) -> Vec<[f64; N_ACTUATORS]> {
        (0..1usize << N_ACTUATORS)
            .map(|bits| {
                std::array::from_fn(|i| {
                    if bits >> i & 1 == 1 {
                        self.rho_min
                    } else {
                        1.0
                    }
                })
            })
            .collect()
    }

    /// `D_ρ = ρ_c I + r Δ`, `Δ = diag(δᵢ)`, `|δᵢ| ≤ 1`: `(ρ_c, r)`.
    pub fn center_radius(&self) -> (f64, f64) {
        ((1.0 + self.rho_min) / 2.0, (1.0 - self.rho_min) / 2.0)
    }

    /// The plant at the centre of the box and the box as a structured norm-bounded uncertainty
    /// around it: `ΔB_u = B_u r Δ`, `ΔD_zu = D_zu r Δ` (`H = r [B_u; D_zu]`, `E = [0 I]`).
    pub fn norm_bounded(&self, g: &GeneralizedPlant) -> (GeneralizedPlant, NormBounded) {
        let (c, r) = self.center_radius();
        let center = with_effectiveness(g, &[c; N_ACTUATORS]);
        let (n, nu, nz) = (g.n(), g.b_u.ncols(), g.c_z.nrows());
        let mut h = DMatrix::zeros(n + nz, nu);
        h.view_mut((0, 0), (n, nu)).copy_from(&(&g.b_u * r));
        h.view_mut((n, 0), (nz, nu)).copy_from(&(&g.d_zu * r));
        let mut e = DMatrix::zeros(nu, n + nu);
        e.view_mut((0, n), (nu, nu)).fill_with_identity();
        (
            center,
            NormBounded {
                h,
                e,
                diagonal: true,
            },
        )
    }
}

/// `g` with actuator effectiveness `rho`: the applied force is `ρᵢ uᵢ`, so `B_u` and `D_zu`
/// (accelerations respond to the applied force; the control penalty weighs it too) scale by
/// column.
pub fn with_effectiveness(g: &GeneralizedPlant, rho: &[f64]) -> GeneralizedPlant {
    assert_eq!(rho.len(), g.b_u.ncols(), "one effectiveness per actuator");
    let d = DMatrix::from_diagonal(&nalgebra::DVector::from_column_slice(rho));
    GeneralizedPlant {
        b_u: &g.b_u * &d,
        d_zu: &g.d_zu * &d,
        ..g.clone()
    }
}

/// An observer-based controller `x̂̇ = A x̂ + B_u u + L (y − C_y x̂)`, `u = F x̂`.
#[derive(Debug, Clone)]
pub struct ObserverBased {
    /// `ũ [kN] = F x̂`.
    pub f: DMatrix<f64>,
    /// Observer gain (plant units: `x̂̇` per unit of each measurement).
    pub l: DMatrix<f64>,
    /// The γ the LMI guarantees on the whole fault box, for any `ρ(t)` in it.
    pub gamma: f64,
    /// The H2 bound on the estimation error `F e` (when weighted in).
    pub estimation_h2: Option<f64>,
    /// The diagonal multiplier `S` of the fault channel.
    pub multiplier: Vec<f64>,
    pub solver_status: String,
}

impl ObserverBased {
    /// The controller in the plant's units (`u` in N), for the certificate and the FMU:
    /// `A_K = A + B_u F − L C_y`, `B_K = L`, `C_K = F` (in N), `D_K = 0`.
    pub fn controller(&self, g: &GeneralizedPlant) -> Controller {
        let a = &g.a + &g.b_u * &self.f - &self.l * &g.c_y;
        Controller::new(
            a,
            self.l.clone(),
            &self.f * FORCE_UNIT,
            DMatrix::zeros(self.f.nrows(), self.l.ncols()),
        )
    }
}

/// The observer gain `L` and the γ for the fixed state-feedback gain `f` (kN per state), robust
/// to the whole fault box, `g` carrying the sensor noise (`D_yw` of full row rank); the objective
/// is `γ + h2_weight · ν` (see below).
///
/// With `q = F (x − e)` (the command), `p = Δ q`, the loop at the box centre `ρ_c` with the
/// fault channel `r B p` (into `x` and `e`) and `r D_zu p` (into `z`); the S-procedure term
/// `qᵀ S q − pᵀ S p ≥ 0` (`S` diagonal, commuting with `Δ`) gives, in `(x, e, w, p, z)`:
/// ```text
/// [ He(P₁A_ρ) + FᵀSF   −ρ_c P₁BF + (ρ_c−1)FᵀBᵀP₂ − FᵀSF   P₁B_w          r P₁B   (C_z + ρ_c D_zu F)ᵀ ]
/// [        *           He(P₂A − ΛC_y − (ρ_c−1)P₂BF) + FᵀSF   P₂B_w − ΛD_yw  r P₂B   −ρ_c (D_zu F)ᵀ     ]
/// [        *                     *                          −γI            0       D_zwᵀ              ] ≺ 0
/// [        *                     *                           *            −S       r D_zuᵀ            ]
/// [        *                     *                           *             *       −γI                ]
/// ```
/// `A_ρ = A + ρ_c B F`. The bound holds pointwise in time, so for any time-varying `ρ(t)` in the
/// box, a fault that switches on at `t = 2 s` included.
pub fn observer_for_faults(
    g: &GeneralizedPlant,
    faults: &FaultBox,
    f: &DMatrix<f64>,
    eps: f64,
    h2_weight: f64,
) -> Result<ObserverBased, LmiError> {
    let (n, ny, nw, nz, nu) = (
        g.n(),
        g.c_y.nrows(),
        g.b_w.ncols(),
        g.c_z.nrows(),
        g.b_u.ncols(),
    );
    let (rc, r) = faults.center_radius();
    let mut p = Problem::new();
    let p1v = p.symmetric(n);
    let p2v = p.symmetric(n);
    let lamv = p.full(n, ny);
    let gamma = p.scalar();
    let s: Vec<_> = (0..nu).map(|_| p.scalar()).collect();
    let (p1, p2, lam) = (p1v.expr(), p2v.expr(), lamv.expr());
    let minus_gamma = |k: usize| gamma.expr().map_scalar(&(-DMatrix::identity(k, k)));
    let unit = |i: usize| DMatrix::from_fn(nu, nu, |a, b| if a == b && a == i { 1.0 } else { 0.0 });
    let s_m = Affine::combination(&s, unit);
    let ft_s_f = Affine::combination(&s, |i| f.transpose() * unit(i) * f);
    let bf = &g.b_u * f;
    let dzu_f = &g.d_zu * f;
    let lmi = Affine::symmetric_blocks(&[
        vec![
            Some(p1.right(&(&g.a + &bf * rc)).he().add(&ft_s_f)),
            Some(
                p1.right(&(&bf * -rc))
                    .add(&p2.right(&(&bf * (rc - 1.0))).t())
                    .sub(&ft_s_f),
            ),
            Some(p1.right(&g.b_w)),
            Some(p1.right(&(&g.b_u * r))),
            Some(Affine::constant((&g.c_z + &dzu_f * rc).transpose())),
        ],
        vec![
            None,
            Some(
                p2.right(&(&g.a - &bf * (rc - 1.0)))
                    .sub(&lam.right(&g.c_y))
                    .he()
                    .add(&ft_s_f),
            ),
            Some(p2.right(&g.b_w).sub(&lam.right(&g.d_yw))),
            Some(p2.right(&(&g.b_u * r))),
            Some(Affine::constant(-(&dzu_f * rc).transpose())),
        ],
        vec![
            None,
            None,
            Some(minus_gamma(nw)),
            None,
            Some(Affine::constant(g.d_zw.transpose())),
        ],
        vec![
            None,
            None,
            None,
            Some(s_m.scale(-1.0)),
            Some(Affine::constant((&g.d_zu * r).transpose())),
        ],
        vec![None, None, None, None, Some(minus_gamma(nz))],
    ]);
    p.negative_definite("robust bounded-real LMI over the fault box", lmi, eps);
    p.positive_definite("P1 ≻ 0", p1, eps);
    p.positive_definite("P2 ≻ 0", p2.clone(), eps);
    for v in &s {
        p.positive_definite("S ≻ 0", v.expr(), eps);
    }
    p.minimise(&gamma, 1.0);
    // The secondary objective: an H2 bound ν on the estimation error as the control law sees it,
    // F e, from w (He(P₂A − ΛC_y) + FᵀF ≺ 0 and [[Z, B̃ᵀP₂], [P₂B̃, P₂]] ≻ 0, B̃ = B_w − L D_yw, ν >
    // trace Z), with the same P₂ and Λ. γ alone is pinned by the wheel-hop peak and leaves L free
    // to estimate badly what the seat needs (measured: seat RMS twice hinf_of's).
    let nu_v = p.scalar();
    if h2_weight > 0.0 {
        let zv = p.symmetric(nw);
        let lyapunov = p2
            .right(&g.a)
            .sub(&lam.right(&g.c_y))
            .he()
            .add(&Affine::constant(f.transpose() * f));
        p.negative_definite("H2 observability LMI of F e", lyapunov, eps);
        let b_tilde = p2.right(&g.b_w).sub(&lam.right(&g.d_yw));
        p.positive_definite(
            "H2 trace LMI",
            Affine::symmetric_blocks(&[
                vec![Some(zv.expr()), Some(b_tilde.t())],
                vec![None, Some(p2.clone())],
            ]),
            eps,
        );
        p.positive_definite("nu > trace Z", nu_v.expr().sub(&zv.expr().trace()), eps);
        p.minimise(&nu_v, h2_weight);
    }
    let sol = p.solve()?;
    let l = p2v
        .value(&sol.x)
        .lu()
        .solve(&lamv.value(&sol.x))
        .expect("P2 ≻ 0 was checked at the solution");
    Ok(ObserverBased {
        f: f.clone(),
        l,
        gamma: gamma.value(&sol.x)[(0, 0)],
        estimation_h2: (h2_weight > 0.0).then(|| nu_v.value(&sol.x)[(0, 0)].sqrt()),
        multiplier: s.iter().map(|v| v.value(&sol.x)[(0, 0)]).collect(),
        solver_status: sol.status,
    })
}

/// The detection residual: a first-order parity relation of the measurements that the road
/// cannot excite. Rows `π` with `π C_y B_w = 0` and `π C_y A = κ C_y` make
/// `d/dt (π y) = κ y + G u_applied`, `G = π C_y B_u`, whatever the road does: physically, the
/// momentum balance of the sprung body, which feels the wheels only through the measured strokes
/// (spring forces) and their derivatives (damper forces, absorbed in `π y`). The generator
/// `ξ̇ = −ξ/T + (κ + π/T) y + G u_cmd` then has `r = π y − ξ` with `ṙ = −r/T + G (u_applied − u_cmd)`:
/// zero when the actuators are healthy, the low-passed force deficit when they are not. It is
/// reported as `G⁺ r / T` — the smallest actuator force deficit (N, over the five actuators)
/// consistent with it (unit DC gain; the choice of basis of `π` cancels).
#[derive(Debug, Clone)]
pub struct DetectionResidual {
    pub pi: DMatrix<f64>,
    pub kappa: DMatrix<f64>,
    /// `π C_y B_u` per N of command.
    pub g: DMatrix<f64>,
    /// Filter time constant \[s\].
    pub time_constant: f64,
}

impl DetectionResidual {
    /// From the plant (`B_w` the road only, `B_u` per kN), `T` in s.
    pub fn new(g: &GeneralizedPlant, time_constant: f64) -> Self {
        let (a, b_road, b_u, c_y) = (&g.a, &g.b_w, &g.b_u, &g.c_y);
        let (n, ny, nw) = (a.nrows(), c_y.nrows(), b_road.ncols());
        // [π κ] M = 0, M = [[C_y A, C_y B_w], [−C_y, 0]]: the left null space of M.
        let mut m = DMatrix::zeros(2 * ny, n + nw);
        m.view_mut((0, 0), (ny, n)).copy_from(&(c_y * a));
        m.view_mut((0, n), (ny, nw)).copy_from(&(c_y * b_road));
        m.view_mut((ny, 0), (ny, n)).copy_from(&-c_y);
        let svd = m.transpose().svd(false, true);
        let v_t = svd.v_t.expect("requested");
        let tol = 1e-9 * svd.singular_values.max();
        // Rows of Vᵀ for zero singular values span the null space of Mᵀ (Vᵀ is 2ny × 2ny).
        let null: Vec<usize> = (0..2 * ny)
            .filter(|&k| svd.singular_values.get(k).is_none_or(|s| *s <= tol))
            .collect();
        let basis = DMatrix::from_fn(null.len(), 2 * ny, |i, j| v_t[(null[i], j)]);
        let pi = basis.columns(0, ny).into_owned();
        let kappa = basis.columns(ny, ny).into_owned();
        // Per N: the division last, as the thesis designs always did.
        let gm = &pi * c_y * b_u / FORCE_UNIT;
        DetectionResidual {
            pi,
            kappa,
            g: gm,
            time_constant,
        }
    }

    pub fn order(&self) -> usize {
        self.pi.nrows()
    }

    /// `G⁺ / T`: residual to force deficit \[N\].
    pub fn to_force(&self) -> DMatrix<f64> {
        self.g.clone().pseudo_inverse(1e-12).expect("finite") / self.time_constant
    }
}

/// The detector as an LTI system: `ξ̇ = A ξ + B y + B_u u`, `r = C ξ + D y` (`u`, `r` in N).
#[derive(Debug, Clone)]
pub struct Detector {
    pub a: DMatrix<f64>,
    pub b: DMatrix<f64>,
    pub b_u: DMatrix<f64>,
    pub c: DMatrix<f64>,
    pub d: DMatrix<f64>,
}

impl Detector {
    /// The `fault_detection` block of `controller.json` for a controller with `inputs` inputs:
    /// the detector reads the first of them (the output-feedback sensors), so `B` and `D` get
    /// zero columns for any after them (e.g. the applied forces a comfort `ft_of` also reads).
    pub fn file_block(&self, inputs: usize, threshold: f64) -> FaultDetection {
        let pad = |m: &DMatrix<f64>| {
            let mut out = DMatrix::zeros(m.nrows(), inputs);
            out.columns_mut(0, m.ncols()).copy_from(m);
            out
        };
        FaultDetection {
            a: matrix_rows(&self.a),
            b: matrix_rows(&pad(&self.b)),
            b_u: matrix_rows(&self.b_u),
            c: matrix_rows(&self.c),
            d: matrix_rows(&pad(&self.d)),
            threshold,
            input: DetectorInput::Command,
        }
    }
}

impl DetectionResidual {
    /// `A = −I/T`, `B = κ + π/T`, `B_u = G`, `C = −G⁺/T`, `D = G⁺π/T`.
    pub fn detector(&self) -> Detector {
        let (m, t) = (self.order(), self.time_constant);
        let to_force = self.to_force();
        Detector {
            a: DMatrix::identity(m, m) * (-1.0 / t),
            b: &self.kappa + &self.pi / t,
            b_u: self.g.clone(),
            c: -&to_force,
            d: &to_force * &self.pi,
        }
    }
}

/// The whole `ft_of` controller as one LTI system from `y`: states `[x̂; ξ]`, outputs `u` (N)
/// and, separately, the residual's `(C_r, D_r)` on those states — for the certificate. (The FMU
/// feeds the detector the command it actually sent, held over the step.)
pub fn with_detection(
    k: &Controller,
    det: &DetectionResidual,
) -> (Controller, DMatrix<f64>, DMatrix<f64>) {
    let d = det.detector();
    let (n, m, ny, nu) = (k.order(), det.order(), k.b.ncols(), k.c.nrows());
    let mut a = DMatrix::zeros(n + m, n + m);
    a.view_mut((0, 0), (n, n)).copy_from(&k.a);
    a.view_mut((n, 0), (m, n)).copy_from(&(&d.b_u * &k.c));
    a.view_mut((n, n), (m, m)).copy_from(&d.a);
    let mut b = DMatrix::zeros(n + m, ny);
    b.view_mut((0, 0), (n, ny)).copy_from(&k.b);
    b.view_mut((n, 0), (m, ny))
        .copy_from(&(&d.b + &d.b_u * &k.d));
    let mut c = DMatrix::zeros(nu, n + m);
    c.view_mut((0, 0), (nu, n)).copy_from(&k.c);
    let mut c_r = DMatrix::zeros(d.c.nrows(), n + m);
    c_r.view_mut((0, n), (d.c.nrows(), m)).copy_from(&d.c);
    (Controller::new(a, b, c, k.d.clone()), c_r, d.d)
}

/// Largest road-to-residual gain accepted as "decoupled" [N per unit of scaled road].
pub const ROAD_DECOUPLING_TOLERANCE: f64 = 1e-3;

/// The independent checks of an `ft_of` design.
#[derive(Debug, Clone, serde::Serialize)]
pub struct FaultCertificate {
    /// Closed-loop H∞ norm (Hamiltonian bisection) at each of the 32 effectiveness vertices.
    pub vertex_norms: Vec<f64>,
    pub worst_vertex_norm: f64,
    /// `‖diag(γ^-½, S^½) M diag(γ^-½, S^-½)‖∞` of the loop at the box centre with the fault
    /// channel `(w, p) → (z, q)`: below 1 proves `‖T_zw‖ < γ` for every `ρ(t)` in the box (small
    /// gain; the LMI's claim, re-checked without the LMI).
    pub scaled_small_gain_norm: f64,
    /// Largest gain from the road (healthy car) to the force-deficit residual over
    /// `frequencies` (N per unit of scaled road): zero but for rounding.
    pub road_to_residual: f64,
    /// DC gain of the residual norm per N of deficit at each actuator alone.
    pub residual_dc_per_actuator: Vec<f64>,
    pub frequencies: usize,
}

/// Check an `ft_of` design, `g` the plant with sensor noise. The norms are of the loop with the
/// observer-based controller `ob` alone: the detector states of `k` (the whole controller) do not
/// reach `u`, so they change no `w → z` map (and, unobservable, they only slow the Hamiltonian
/// bisection down); `k` is used for the residual checks.
#[allow(clippy::too_many_arguments)]
pub fn certify_faults(
    variant: &str,
    g: &GeneralizedPlant,
    faults: &FaultBox,
    ob: &ObserverBased,
    det: &DetectionResidual,
    k: &Controller,
    c_r: &DMatrix<f64>,
    d_r: &DMatrix<f64>,
) -> Result<FaultCertificate, CertificateError> {
    let fail = |reason: String| CertificateError::Fault {
        variant: variant.into(),
        reason,
    };
    let control = ob.controller(g);
    let mut vertex_norms = Vec::new();
    for rho in faults.vertices() {
        let norm = closed_loop(
            &with_effectiveness(g, &rho),
            &g.output_measurement(),
            &control,
        )
        .hinf_norm(1e-8)
        .map_err(|e| fail(format!("at effectiveness {rho:?}: {e}")))?;
        if norm.upper > ob.gamma * (1.0 + NORM_TOLERANCE) {
            return Err(fail(format!(
                "at effectiveness {rho:?} the closed-loop norm {} exceeds gamma {}",
                norm.upper, ob.gamma
            )));
        }
        vertex_norms.push(norm.upper);
    }
    // The fault channel: p = Δ q enters as r B_u p and r D_zu p, q = ũ (the command, kN).
    let (rc, r) = faults.center_radius();
    let center = with_effectiveness(g, &[rc; N_ACTUATORS]);
    let (n, nw, nz, nu) = (g.n(), g.b_w.ncols(), g.c_z.nrows(), g.b_u.ncols());
    let aug = center.with_uncertainty_channel(
        &(&g.b_u * r),
        &(&g.d_zu * r),
        &DMatrix::zeros(nu, n),
        &DMatrix::identity(nu, nu),
    );
    let mut m = closed_loop(&aug, &aug.output_measurement(), &control);
    let in_scale: Vec<f64> = (0..nw)
        .map(|_| ob.gamma.powf(-0.5))
        .chain(ob.multiplier.iter().map(|s| s.powf(-0.5)))
        .collect();
    let out_scale: Vec<f64> = (0..nz)
        .map(|_| ob.gamma.powf(-0.5))
        .chain(ob.multiplier.iter().map(|s| s.sqrt()))
        .collect();
    for (j, s) in in_scale.iter().enumerate() {
        m.b.column_mut(j).scale_mut(*s);
        m.d.column_mut(j).scale_mut(*s);
    }
    for (i, s) in out_scale.iter().enumerate() {
        m.c.row_mut(i).scale_mut(*s);
        m.d.row_mut(i).scale_mut(*s);
    }
    let small_gain = m
        .hinf_norm(1e-8)
        .map_err(|e| fail(format!("the scaled fault loop: {e}")))?
        .upper;
    if small_gain > 1.0 + NORM_TOLERANCE {
        return Err(fail(format!("the scaled small-gain norm {small_gain} exceeds 1: the LMI's claim on the fault box does not hold")));
    }
    // The residual: from the road (healthy) it must vanish; from each actuator's deficit it is
    // the min-norm deficit estimate, DC gain ‖G⁺ G eᵢ‖.
    let healthy = closed_loop(g, &g.output_measurement(), k);
    let nk = k.order();
    let mut c_res = DMatrix::zeros(c_r.nrows(), n + nk);
    c_res
        .view_mut((0, 0), (c_r.nrows(), n))
        .copy_from(&(d_r * &g.c_y));
    c_res.view_mut((0, n), (c_r.nrows(), nk)).copy_from(c_r);
    let road = g.road_scale.len();
    let residual = Lti::new(
        healthy.a.clone(),
        healthy.b.columns(0, road).into_owned(),
        c_res,
        (d_r * &g.d_yw).columns(0, road).into_owned(),
    );
    let frequencies: Vec<f64> = (0..400)
        .map(|k| 10f64.powf(-2.0 + 5.0 * k as f64 / 399.0))
        .collect();
    let road_to_residual = frequencies
        .iter()
        .map(|w| residual.sigma_max(*w))
        .fold(residual.d.norm(), f64::max);
    // A unit of scaled road moves a tyre force of order k_t · 5 cm ≈ 1e4 N: 1e-3 N is rounding.
    if road_to_residual > ROAD_DECOUPLING_TOLERANCE {
        return Err(fail(format!("the road reaches the detection residual (gain {road_to_residual:e} N per unit road): it is not decoupled")));
    }
    let projection = det.to_force() * &det.g * det.time_constant;
    let residual_dc_per_actuator: Vec<f64> = (0..nu).map(|i| projection.column(i).norm()).collect();
    if residual_dc_per_actuator
        .iter()
        .any(|v| v.is_nan() || *v <= 0.05)
    {
        return Err(fail(format!("an actuator's deficit barely reaches the residual (DC gains {residual_dc_per_actuator:?}): its faults are not detectable")));
    }
    Ok(FaultCertificate {
        worst_vertex_norm: vertex_norms.iter().copied().fold(0.0, f64::max),
        vertex_norms,
        scaled_small_gain_norm: small_gain,
        road_to_residual,
        residual_dc_per_actuator,
        frequencies: frequencies.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shipping::design::Design;
    use crate::thesis::state_feedback::hinf_sf_robust;
    use vehicle::VehicleParams;

    #[test]
    fn the_box_has_every_combination_once_and_the_plant_scales_by_column() {
        let v = FaultBox { rho_min: 0.5 }.vertices();
        assert_eq!(v.len(), 32);
        assert_eq!(v[0], [1.0; 5]);
        let mut sorted: Vec<String> = v.iter().map(|r| format!("{r:?}")).collect();
        sorted.sort();
        sorted.dedup();
        assert_eq!(sorted.len(), 32);
        let g = GeneralizedPlant::new(&VehicleParams::default(), &Design::default());
        let gr = with_effectiveness(&g, &[1.0, 0.5, 1.0, 1.0, 0.25]);
        assert_eq!(gr.b_u.column(1), g.b_u.column(1) * 0.5);
        assert_eq!(gr.d_zu.column(4), g.d_zu.column(4) * 0.25);
        assert_eq!(gr.b_u.column(0), g.b_u.column(0));
    }

    /// The detector on the open plant, by frequency response (not the algebra it was built
    /// with): no response to the road, and `G⁺G (D_ρ − I) / (1 + jωT)` to the commands.
    #[test]
    fn the_detection_residual_ignores_the_road_and_reports_the_force_deficit() {
        use nalgebra::Complex;
        let d = Design::default();
        let g = GeneralizedPlant::new(&VehicleParams::default(), &d);
        let det = DetectionResidual::new(&g, 0.05);
        assert_eq!(
            det.order(),
            3,
            "the body's heave, roll and pitch momentum balances"
        );
        let dt = det.detector();
        let rho = [0.5, 1.0, 0.8, 1.0, 0.3];
        let b_applied = with_effectiveness(&g, &rho).b_u / FORCE_UNIT;
        let cx = |m: &DMatrix<f64>| m.map(|v| Complex::new(v, 0.0));
        let expected_dc = det.to_force()
            * &det.g
            * det.time_constant
            * (DMatrix::from_diagonal(&nalgebra::DVector::from_column_slice(&rho))
                - DMatrix::identity(5, 5));
        for w in [0.1, 1.0, 8.0, 70.0, 400.0] {
            let jw = Complex::new(0.0, w);
            let plant = (DMatrix::<Complex<f64>>::identity(16, 16) * jw - cx(&g.a))
                .try_inverse()
                .unwrap();
            let filter = (DMatrix::<Complex<f64>>::identity(3, 3) * jw - cx(&dt.a))
                .try_inverse()
                .unwrap();
            // y per input, then r = (C_d (jω − A_d)⁻¹ B_d + D_d) y + C_d (jω − A_d)⁻¹ B_du u.
            let from_y = cx(&dt.c) * &filter * cx(&dt.b) + cx(&dt.d);
            let road = &from_y * cx(&g.c_y) * &plant * cx(&g.b_w);
            let command =
                &from_y * cx(&g.c_y) * &plant * cx(&b_applied) + cx(&dt.c) * &filter * cx(&dt.b_u);
            let expected = cx(&expected_dc) / (Complex::new(1.0, 0.0) + jw * det.time_constant);
            assert!(
                road.norm() < 1e-7,
                "ω = {w}: road reaches the residual, gain {}",
                road.norm()
            );
            assert!(
                (&command - &expected).norm() < 1e-8 * expected.norm(),
                "ω = {w}: {} vs {}",
                command,
                expected
            );
        }
        // Each actuator's deficit is seen (the seat's through its reaction on the body).
        assert!(
            (0..5).all(|i| expected_dc.column(i).norm() > 0.1 * (1.0 - rho[i]) || rho[i] == 1.0)
        );
    }

    /// The design certifies, and the same controller with a 1 % lower γ claimed does not.
    #[test]
    fn ft_of_is_certified_on_the_fault_box_and_an_overclaim_is_refused() {
        let d = Design::default();
        let g = GeneralizedPlant::new(&VehicleParams::default(), &d);
        let gn = g.with_sensor_noise(&d);
        let faults = FaultBox {
            rho_min: d.fault_rho_min,
        };
        let (center, nb) = faults.norm_bounded(&g);
        let sf = hinf_sf_robust(&[&center], Some(&nb), d.lmi_margin, None).unwrap();
        let ob = observer_for_faults(
            &gn,
            &faults,
            &(&sf.k / FORCE_UNIT),
            d.lmi_margin,
            d.fault_h2_weight,
        )
        .unwrap();
        let det = DetectionResidual::new(&g, d.fault_time_constant);
        let (k, c_r, d_r) = with_detection(&ob.controller(&gn), &det);
        let cert = certify_faults("ft_of", &gn, &faults, &ob, &det, &k, &c_r, &d_r).unwrap();
        assert_eq!(cert.vertex_norms.len(), 32);
        assert!(
            cert.worst_vertex_norm <= ob.gamma
                && cert.scaled_small_gain_norm < 1.0
                && cert.road_to_residual < ROAD_DECOUPLING_TOLERANCE
        );
        let overclaim = ObserverBased {
            gamma: cert.worst_vertex_norm * 0.99,
            ..ob
        };
        assert!(matches!(
            certify_faults("ft_of", &gn, &faults, &overclaim, &det, &k, &c_r, &d_r),
            Err(CertificateError::Fault { .. })
        ));
    }
}
