//! Lyapunov and algebraic Riccati equations: the numerics of the comfort designs (covariances,
//! H2 norms, LQ and full-information H∞ gains, Kalman filters) and of their certificates.
//!
//! Our own, on nalgebra, because they are this crate's core and no maintained Rust crate solves
//! them on nalgebra's matrices:
//! * [`lyapunov`]: Bartels–Stewart (CACM 15(9), 1972) on nalgebra's real Schur form: backward
//!   stable, `O(n³)`, where the Kronecker form of [`crate::numerics::hinf_norm`] is `O(n⁶)` (a 60-state
//!   closed loop: milliseconds instead of minutes);
//! * [`care`]: the stabilising solution from the stable invariant subspace of the Hamiltonian
//!   (Laub's Schur method, IEEE TAC 24(6), 1979, with LAPACK's balancing and ordered Schur form,
//!   as SLICOT and SciPy), refined by Newton–Kleinman steps. `R` may be indefinite: the same
//!   routine solves the game Riccati equation of full-information H∞ control. (A matrix-sign
//!   iteration was tried first: it stalls on the 60-state closed loops' badly scaled
//!   Hamiltonians.)

use nalgebra::DMatrix;

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RiccatiError {
    #[error("the Lyapunov equation has no unique solution: A has eigenvalues λᵢ + λⱼ ≈ 0")]
    Singular,
    #[error("the real Schur form of A did not converge")]
    Schur,
    #[error("the Hamiltonian has eigenvalues on or near the imaginary axis: no stabilising solution ({0})")]
    NoStabilisingSolution(String),
    #[error("R is singular")]
    SingularR,
    #[error("the Riccati solution's relative residual is {0:e}, above 1e-8")]
    Inaccurate(f64),
}

/// `(U, T, blocks)`: see [`schur_blocks`].
type SchurBlocks = (DMatrix<f64>, DMatrix<f64>, Vec<(usize, usize)>);

/// The real Schur form `A = U T Uᵀ` with the start and size (1 or 2) of each diagonal block.
fn schur_blocks(a: &DMatrix<f64>) -> Result<SchurBlocks, RiccatiError> {
    let n = a.nrows();
    let (u, t) = crate::numerics::eig::real_schur(a).ok_or(RiccatiError::Schur)?;
    let mut blocks = Vec::new();
    let mut i = 0;
    while i < n {
        let size = if i + 1 < n && t[(i + 1, i)] != 0.0 {
            2
        } else {
            1
        };
        blocks.push((i, size));
        i += size;
    }
    Ok((u, t, blocks))
}

/// The `X` of `A X + X Aᵀ + C = 0` (`C` symmetric; `A` with no two eigenvalues summing to 0,
/// e.g. Hurwitz: then `X` is the controllability Gramian of `(A, B)` for `C = B Bᵀ`).
/// For the observability form `Aᵀ X + X A + C = 0` pass `Aᵀ`.
pub fn lyapunov(a: &DMatrix<f64>, c: &DMatrix<f64>) -> Result<DMatrix<f64>, RiccatiError> {
    let n = a.nrows();
    assert!(
        a.is_square() && c.shape() == (n, n),
        "lyapunov: A and C must be n×n"
    );
    if n == 0 {
        return Ok(DMatrix::zeros(0, 0));
    }
    // Balanced (exactly, by powers of two): `A = D Ã D⁻¹`, `X = D X̃ D` with
    // `Ã X̃ + X̃ Ãᵀ + D⁻¹ C D⁻¹ = 0`.
    let (a, d) = crate::numerics::eig::balance(a).ok_or(RiccatiError::Schur)?;
    let c = DMatrix::from_fn(n, n, |i, j| c[(i, j)] / (d[i] * d[j]));
    let (u, t, blocks) = schur_blocks(&a)?;
    // T Y + Y Tᵀ = F, F = −Uᵀ C U, solved block by block from the bottom right:
    // T_ii Y_ij + Y_ij T_jjᵀ = F_ij − Σ_{k>i} T_ik Y_kj − Σ_{k>j} Y_ik T_jkᵀ.
    let f = -(u.transpose() * &c * &u);
    let mut y = DMatrix::<f64>::zeros(n, n);
    for &(i, p) in blocks.iter().rev() {
        for &(j, q) in blocks.iter().rev() {
            let mut rhs = f.view((i, j), (p, q)).into_owned();
            let (ri, rj) = (n - i - p, n - j - q);
            if ri > 0 {
                rhs -= t.view((i, i + p), (p, ri)) * y.view((i + p, j), (ri, q));
            }
            if rj > 0 {
                rhs -= y.view((i, j + q), (p, rj)) * t.view((j, j + q), (q, rj)).transpose();
            }
            // (I_q ⊗ T_ii + T_jj ⊗ I_p) vec(Y_ij) = vec(rhs).
            let tii = t.view((i, i), (p, p));
            let tjj = t.view((j, j), (q, q));
            let m = DMatrix::<f64>::identity(q, q).kronecker(&tii.into_owned())
                + tjj.into_owned().kronecker(&DMatrix::<f64>::identity(p, p));
            let v = m
                .lu()
                .solve(&DMatrix::from_column_slice(p * q, 1, rhs.as_slice()))
                .ok_or(RiccatiError::Singular)?;
            y.view_mut((i, j), (p, q))
                .copy_from(&DMatrix::from_column_slice(p, q, v.as_slice()));
        }
    }
    let mut x = &u * y * u.transpose();
    for j in 0..n {
        for i in 0..n {
            x[(i, j)] *= d[i] * d[j];
        }
    }
    if !x.iter().all(|v| v.is_finite()) {
        return Err(RiccatiError::Singular);
    }
    Ok((&x + x.transpose()) * 0.5)
}

/// The stabilising solution of `Aᵀ X + X A − (X B + N) R⁻¹ (Bᵀ X + Nᵀ) + Q = 0` and its gain
/// `K = R⁻¹ (Bᵀ X + Nᵀ)` (`A − B K` Hurwitz).
#[derive(Debug, Clone)]
pub struct Riccati {
    pub x: DMatrix<f64>,
    pub k: DMatrix<f64>,
    /// `‖residual‖_F` relative to the size of the equation's terms.
    pub residual: f64,
}

/// Solve the continuous algebraic Riccati equation (see [`Riccati`]) for `Q`, `R` symmetric,
/// `R` invertible (indefinite allowed), `N` the cross term (`None` = 0).
pub fn care(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    q: &DMatrix<f64>,
    r: &DMatrix<f64>,
    n_cross: Option<&DMatrix<f64>>,
) -> Result<Riccati, RiccatiError> {
    let (n, m) = (a.nrows(), b.ncols());
    let zero = DMatrix::zeros(n, m);
    let nc = n_cross.unwrap_or(&zero);
    let r_inv = r.clone().try_inverse().ok_or(RiccatiError::SingularR)?;
    // Hamiltonian of the equation without cross term: F = A − B R⁻¹ Nᵀ, G = B R⁻¹ Bᵀ,
    // Q̃ = Q − N R⁻¹ Nᵀ; H = [[F, −G], [−Q̃, −Fᵀ]].
    let f = a - b * &r_inv * nc.transpose();
    let g = b * &r_inv * b.transpose();
    let qt = q - nc * &r_inv * nc.transpose();
    let mut h = DMatrix::zeros(2 * n, 2 * n);
    h.view_mut((0, 0), (n, n)).copy_from(&f);
    h.view_mut((0, n), (n, n)).copy_from(&(-&g));
    h.view_mut((n, 0), (n, n)).copy_from(&(-&qt));
    h.view_mut((n, n), (n, n)).copy_from(&(-f.transpose()));
    // The stable invariant subspace [U₁; U₂] of H: X = U₂ U₁⁻¹.
    let (basis, k) = crate::numerics::eig::stable_subspace(&h).ok_or_else(|| {
        RiccatiError::NoStabilisingSolution("the Schur form of the Hamiltonian failed".into())
    })?;
    if k != n {
        return Err(RiccatiError::NoStabilisingSolution(format!(
            "the Hamiltonian has {k} stable eigenvalues, not {n}"
        )));
    }
    let u1 = basis.view((0, 0), (n, n)).into_owned();
    let u2 = basis.view((n, 0), (n, n)).into_owned();
    let x = u1
        .transpose()
        .lu()
        .solve(&u2.transpose())
        .ok_or_else(|| RiccatiError::NoStabilisingSolution("U₁ is singular".into()))?
        .transpose();
    let mut x = (&x + x.transpose()) * 0.5;
    let residual = |x: &DMatrix<f64>| {
        let k = &r_inv * (b.transpose() * x + nc.transpose());
        let xa = x * a;
        let res = xa.transpose() + &xa - (x * b + nc) * &k + q;
        let scale = xa.norm() + q.norm() + (k.transpose() * r * &k).norm();
        (k, res.norm() / scale.max(f64::MIN_POSITIVE))
    };
    let (mut k, mut res) = residual(&x);
    // Newton–Kleinman: (A − BK)ᵀ X⁺ + X⁺ (A − BK) + Q + Kᵀ R K − N K − Kᵀ Nᵀ = 0.
    for _ in 0..3 {
        if res < 1e-13 {
            break;
        }
        let ac = a - b * &k;
        let rhs = q + k.transpose() * r * &k - nc * &k - k.transpose() * nc.transpose();
        let Ok(next) = lyapunov(&ac.transpose(), &rhs) else {
            break;
        };
        let (k_next, res_next) = residual(&next);
        if res_next.is_nan() || res_next >= res {
            break;
        }
        (x, k, res) = (next, k_next, res_next);
    }
    if res.is_nan() || res > 1e-8 {
        return Err(RiccatiError::Inaccurate(res));
    }
    let abscissa = crate::numerics::eig::spectral_abscissa(&(a - b * &k));
    if abscissa.is_nan() || abscissa >= 0.0 {
        return Err(RiccatiError::NoStabilisingSolution(format!(
            "A − B K has spectral abscissa {abscissa:e}"
        )));
    }
    Ok(Riccati {
        x,
        k,
        residual: res,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::numerics::hinf_norm::{Analysis, Lti};

    fn random(n: usize, m: usize, seed: u64) -> DMatrix<f64> {
        let mut s = seed.wrapping_mul(6364136223846793005).wrapping_add(1);
        DMatrix::from_fn(n, m, |_, _| {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        })
    }

    /// A stable matrix with real and complex eigenvalues spread over three decades.
    fn stable(n: usize, seed: u64) -> DMatrix<f64> {
        let m = random(n, n, seed) * 4.0;
        let shift = m
            .complex_eigenvalues()
            .iter()
            .map(|l| l.re)
            .fold(f64::MIN, f64::max);
        let mut a = m - DMatrix::identity(n, n) * (shift + 0.05);
        a[(0, 0)] -= 300.0;
        a
    }

    /// Against the Kronecker form `(I ⊗ A + A ⊗ I) vec X = −vec C`, a second algorithm.
    #[test]
    fn lyapunov_matches_the_kronecker_solution_and_its_residual_vanishes() {
        for (n, seed) in [(1, 1), (2, 2), (7, 3), (12, 4)] {
            let a = stable(n, seed);
            let b = random(n, 2, seed + 10);
            let c = &b * b.transpose();
            let x = lyapunov(&a, &c).unwrap();
            let eye = DMatrix::<f64>::identity(n, n);
            let op = eye.kronecker(&a) + a.kronecker(&eye);
            let v = op
                .lu()
                .solve(&DMatrix::from_column_slice(n * n, 1, (-&c).as_slice()))
                .unwrap();
            let kron = DMatrix::from_column_slice(n, n, v.as_slice());
            assert!((&x - &kron).norm() <= 1e-10 * kron.norm(), "n = {n}");
        }
        let a = stable(60, 9);
        let c = random(60, 3, 1) * random(60, 3, 1).transpose();
        let c = &c + c.transpose();
        let x = lyapunov(&a, &c).unwrap();
        let res = &a * &x + &x * a.transpose() + &c;
        assert!(res.norm() <= 1e-11 * (a.norm() * x.norm() + c.norm()));
        // No unique solution when λᵢ + λⱼ = 0.
        let bad = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, -1.0]);
        assert!(lyapunov(&bad, &DMatrix::identity(2, 2)).is_err());
    }

    /// A system in badly scaled state coordinates, as the closed loops are (controller states
    /// in large units beside the car's metres): `A = S A₀ S⁻¹`, `C = S C₀ S`, so `X = S X₀ S`
    /// exactly, with `S` spanning ten decades. Each entry of `S⁻¹ X S⁻¹` must match `X₀` (solved
    /// well scaled) to the accuracy of `X₀` itself, which the Gramian's quadratic forms need.
    #[test]
    fn lyapunov_is_accurate_in_badly_scaled_coordinates() {
        let n = 12;
        let a0 = stable(n, 5);
        let b = random(n, 2, 15);
        let c0 = &b * b.transpose();
        let x0 = lyapunov(&a0, &c0).unwrap();
        let s: Vec<f64> = (0..n)
            .map(|i| 10f64.powf(-5.0 + 10.0 * (i * 7 % n) as f64 / (n - 1) as f64))
            .collect();
        let a = DMatrix::from_fn(n, n, |i, j| s[i] * a0[(i, j)] / s[j]);
        let c = DMatrix::from_fn(n, n, |i, j| s[i] * c0[(i, j)] * s[j]);
        let x = lyapunov(&a, &c).unwrap();
        let back = DMatrix::from_fn(n, n, |i, j| x[(i, j)] / (s[i] * s[j]));
        let err = (&back - &x0).amax() / x0.amax();
        assert!(err <= 1e-10, "relative error {err:e}");
    }

    /// Scalar LQR: `2 a x − b² x² / r + q = 0`, `x = r (a + √(a² + b² q / r)) / b²`.
    #[test]
    fn scalar_riccati_matches_its_closed_form() {
        for (a, b, q, r) in [
            (-1.0, 1.0, 1.0, 1.0),
            (2.0, 0.5, 3.0, 0.1),
            (0.0, 2.0, 1.0, 4.0),
        ] {
            let m = |v: f64| DMatrix::from_element(1, 1, v);
            let s = care(&m(a), &m(b), &m(q), &m(r), None).unwrap();
            let exact = r * (a + (a * a + b * b * q / r).sqrt()) / (b * b);
            assert!(
                (s.x[(0, 0)] - exact).abs() <= 1e-12 * exact,
                "{a} {b} {q} {r}"
            );
            assert!((s.k[(0, 0)] - b * exact / r).abs() <= 1e-12 * exact.max(1.0));
        }
    }

    /// The LQ gain of `care` is optimal: its cost `tr(Bwᵀ X Bw)` equals the closed loop's H2 norm
    /// (from the Gramian, a Lyapunov equation) and any other stabilising gain nearby costs more.
    #[test]
    fn lq_gain_is_optimal_and_its_cost_is_the_h2_norm() {
        let n = 8;
        let a = stable(n, 21) + DMatrix::identity(n, n) * 1.0; // unstable modes too
        let b = random(n, 2, 22);
        let bw = random(n, 3, 23);
        let c = random(4, n, 24);
        let (q, r) = (c.transpose() * &c, DMatrix::identity(2, 2) * 0.3);
        let s = care(&a, &b, &q, &r, None).unwrap();
        let cost = |k: &DMatrix<f64>| {
            // z = [C; √R K]... cost E[xᵀQx + uᵀRu] = ‖[C; R^½ (−K)] (sI − A + BK)⁻¹ Bw‖₂².
            let mut cz = DMatrix::zeros(6, n);
            cz.view_mut((0, 0), (4, n)).copy_from(&c);
            cz.view_mut((4, 0), (2, n))
                .copy_from(&(-(k * 0.3f64.sqrt())));
            Lti::new(a.clone() - &b * k, bw.clone(), cz, DMatrix::zeros(6, 3))
                .h2_norm()
                .map(|h| h * h)
                .unwrap_or(f64::INFINITY)
        };
        let optimal = (bw.transpose() * &s.x * &bw).trace();
        assert!((cost(&s.k) - optimal).abs() <= 1e-9 * optimal);
        for seed in 0..10 {
            let dk = random(2, n, 100 + seed) * 1e-3;
            assert!(cost(&(&s.k + dk)) > optimal);
        }
    }

    /// With `R = blkdiag(R_u, −γ² I)` the equation is full-information H∞ control's: for
    /// `ẋ = A x + B_u u + B_p p`, `z = [C x; R_u^½ u]`, the gain `u = −K_u x` of its stabilising
    /// solution keeps `‖z ← p‖∞ < γ` (checked by Hamiltonian bisection, an independent algorithm),
    /// and below the optimal γ there is no stabilising solution.
    #[test]
    fn game_riccati_gives_the_h_infinity_bound() {
        let n = 6;
        let a = stable(n, 31);
        let bu = random(n, 2, 32);
        let bp = random(n, 1, 33);
        let c = random(2, n, 34);
        let norm_with = |gamma: f64| -> Result<f64, RiccatiError> {
            let mut b = DMatrix::zeros(n, 3);
            b.view_mut((0, 0), (n, 2)).copy_from(&bu);
            b.view_mut((0, 2), (n, 1)).copy_from(&bp);
            let mut r = DMatrix::identity(3, 3);
            r[(2, 2)] = -gamma * gamma;
            let s = care(&a, &b, &(c.transpose() * &c), &r, None)?;
            let ku = s.k.rows(0, 2).into_owned();
            let mut cz = DMatrix::zeros(4, n);
            cz.view_mut((0, 0), (2, n)).copy_from(&c);
            cz.view_mut((2, 0), (2, n)).copy_from(&(-&ku));
            Ok(
                Lti::new(&a - &bu * &ku, bp.clone(), cz, DMatrix::zeros(4, 1))
                    .hinf_norm(1e-9)
                    .unwrap()
                    .upper,
            )
        };
        let mut feasible = 0;
        for gamma in [0.05, 0.2, 1.0, 5.0] {
            if let Ok(norm) = norm_with(gamma) {
                assert!(norm < gamma, "γ = {gamma}: {norm}");
                feasible += 1;
            }
        }
        assert!(feasible >= 2);
        assert!(norm_with(1e-4).is_err(), "γ far below the optimum");
    }
}
