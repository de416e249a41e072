//! Exact discretisation of a linear system over one step.
//!
//! For `ẋ = A x + B v(t)` with `v` linear over `[0, h]` (`v(s) = v₀ + (v₁ − v₀) s/h`, which
//! covers held inputs as `v₁ = v₀`), the exponential of the augmented matrix
//! `exp([[A h, B h, 0], [0, 0, I], [0, 0, 0]]) = [[Φ, Γ₀, Γ₁], [0, I, I], [0, 0, I]]` gives
//! `x(h) = Φ x₀ + Γ₀ v₀ + Γ₁ (v₁ − v₀)` without approximation beyond rounding
//! (Franklin, Powell & Workman, *Digital Control*, §6.3.2, triangle-hold equivalent).
//! The matrix exponential is nalgebra's (Padé with scaling and squaring), behind [`expm`]'s
//! bounds: nalgebra's scaling count is an `f64` cast to `u64`, which saturates when its norm
//! estimates (powers of the matrix up to the 27th) overflow, and then squares forever.

use nalgebra::DMatrix;

/// The largest 1-norm of a matrix [`expm`] exponentiates. nalgebra's estimates take powers of
/// the unscaled matrix up to the 10th (1e200 here, far below `f64::MAX`; the 27th power it
/// takes is of the matrix already scaled to a norm of about 4), and the result takes at most
/// 66 squarings. The plant at the most extreme parameters it admits has `‖A‖₁` up to about
/// 2e13/s (an inertia of 0.01 kg·m² on 20 m levers with 1e8 N/m springs), so steps of minutes
/// pass; beyond, scaling and squaring would lose the slow modes' digits anyway.
pub const MAX_EXP_NORM: f64 = 1e20;

/// Why a matrix exponential was not computed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ExpError {
    #[error("the matrix has non-finite entries")]
    NonFinite,
    #[error("the matrix's 1-norm {0:e} exceeds {MAX_EXP_NORM:e} (a step far too long for the system's time constants, or entries far out of range)")]
    TooLarge(f64),
    #[error("the exponential overflows (the system grows by more than 1e308 over the step)")]
    Overflow,
}

/// `e^M`, refused (never hanging) when `M` is non-finite or too large, or the result overflows.
pub fn expm(m: &DMatrix<f64>) -> Result<DMatrix<f64>, ExpError> {
    if !m.iter().all(|v| v.is_finite()) {
        return Err(ExpError::NonFinite);
    }
    let norm = m.one_norm();
    if norm > MAX_EXP_NORM {
        return Err(ExpError::TooLarge(norm));
    }
    let e = m.exp();
    if e.iter().all(|v| v.is_finite()) {
        Ok(e)
    } else {
        Err(ExpError::Overflow)
    }
}

/// `x(h) = Φ x₀ + Γ₀ v₀ + Γ₁ (v₁ − v₀)`.
#[derive(Debug, Clone, PartialEq)]
pub struct Discretization {
    pub step: f64,
    pub phi: DMatrix<f64>,
    pub gamma_hold: DMatrix<f64>,
    pub gamma_ramp: DMatrix<f64>,
}

/// Discretise `(A, B)` exactly for step `h ≥ 0`; [`expm`]'s errors for absurd `A h` or `B h`.
pub fn discretize(a: &DMatrix<f64>, b: &DMatrix<f64>, h: f64) -> Result<Discretization, ExpError> {
    let (n, m) = (a.nrows(), b.ncols());
    assert!(a.is_square() && b.nrows() == n, "A must be n×n and B n×m");
    let mut big = DMatrix::zeros(n + 2 * m, n + 2 * m);
    big.view_mut((0, 0), (n, n)).copy_from(&(a * h));
    big.view_mut((0, n), (n, m)).copy_from(&(b * h));
    big.view_mut((n, n + m), (m, m)).fill_with_identity();
    let e = expm(&big)?;
    Ok(Discretization {
        step: h,
        phi: e.view((0, 0), (n, n)).into_owned(),
        gamma_hold: e.view((0, n), (n, m)).into_owned(),
        gamma_ramp: e.view((0, n + m), (n, m)).into_owned(),
    })
}

/// `y = Σ_k A_k x_k`, e.g. `Φ x + Γ₀ v₀` in one pass.
///
/// Our own instead of nalgebra's `gemv` because this is the inner loop of every FMU step:
/// `gemv` is a sequence of column `axpy`s that loads and stores all of `y` once per column,
/// while this keeps a block of 16 rows of `y` in registers across every column of every term:
/// 16 independent sums, enough to hide the latency of the additions (each row is a chain of
/// dependent additions in a fixed order). The plant's and the controllers' steps got about 2×
/// faster. Each element sums the same products in the same order (columns of `A_1`, then of
/// `A_2` …), so the results are those of chained `gemv`s bit for bit (a test checks it).
pub fn mat_vec_sum(y: &mut [f64], terms: &[(&DMatrix<f64>, &[f64])]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx") {
        // SAFETY: the CPU has AVX, checked just above.
        return unsafe { mat_vec_sum_avx::<false>(y, terms) };
    }
    mat_vec_sum_blocks::<false>(y, terms)
}

/// [`mat_vec_sum`] whose first term is quasi-upper-triangular (zero below its first
/// subdiagonal: a real Schur form, or its exponential): a block of rows skips the columns left
/// of its first row's subdiagonal, about half of a square matrix. The same values as
/// [`mat_vec_sum`] of the same matrices, bit for bit but for the sign of a zero (the products
/// skipped are of exact zeros, and `acc + 0·x` is `acc` for a finite `x` unless `acc` is −0).
pub fn mat_vec_sum_quasi_upper(y: &mut [f64], terms: &[(&DMatrix<f64>, &[f64])]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx") {
        // SAFETY: the CPU has AVX, checked just above.
        return unsafe { mat_vec_sum_avx::<true>(y, terms) };
    }
    mat_vec_sum_blocks::<true>(y, terms)
}

/// [`mat_vec_sum`] in AVX's four-wide registers where the CPU has them (the FMUs are built for
/// the x86-64 baseline, two-wide SSE2). Bit-identical: the same products summed in the same
/// order per row, and Rust never fuses a multiply and an add.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn mat_vec_sum_avx<const UPPER: bool>(y: &mut [f64], terms: &[(&DMatrix<f64>, &[f64])]) {
    mat_vec_sum_blocks::<UPPER>(y, terms)
}

/// With `UPPER`, the first term is quasi-upper-triangular ([`mat_vec_sum_quasi_upper`]).
#[inline(always)]
fn mat_vec_sum_blocks<const UPPER: bool>(y: &mut [f64], terms: &[(&DMatrix<f64>, &[f64])]) {
    let n = y.len();
    for (a, x) in terms {
        assert!(
            a.nrows() == n && a.ncols() == x.len(),
            "mat_vec_sum: {}×{} matrix, {} rows and {} values",
            a.nrows(),
            a.ncols(),
            n,
            x.len()
        );
    }
    let mut r0 = 0;
    while r0 + 16 <= n {
        row_block::<16, UPPER>(y, terms, r0);
        r0 += 16;
    }
    if r0 + 8 <= n {
        row_block::<8, UPPER>(y, terms, r0);
        r0 += 8;
    }
    // The last rows, as a block of their own size (accumulators in registers again).
    match n - r0 {
        1 => row_block::<1, UPPER>(y, terms, r0),
        2 => row_block::<2, UPPER>(y, terms, r0),
        3 => row_block::<3, UPPER>(y, terms, r0),
        4 => row_block::<4, UPPER>(y, terms, r0),
        5 => row_block::<5, UPPER>(y, terms, r0),
        6 => row_block::<6, UPPER>(y, terms, r0),
        7 => row_block::<7, UPPER>(y, terms, r0),
        _ => {}
    }
}

/// Rows `r0 .. r0 + B` of [`mat_vec_sum`], the accumulators in registers; with `UPPER` the
/// first term's columns left of `r0 − 1` (zero in these rows) skipped.
#[inline(always)]
fn row_block<const B: usize, const UPPER: bool>(
    y: &mut [f64],
    terms: &[(&DMatrix<f64>, &[f64])],
    r0: usize,
) {
    let n = y.len();
    let mut acc = [0.0; B];
    for (k, (a, x)) in terms.iter().enumerate() {
        let first = if UPPER && k == 0 {
            r0.saturating_sub(1)
        } else {
            0
        };
        let columns = a.as_slice().chunks_exact(n).zip(x.iter()).skip(first);
        for (col, &xj) in columns {
            let col: &[f64; B] = col[r0..r0 + B].try_into().unwrap();
            for r in 0..B {
                acc[r] += col[r] * xj;
            }
        }
    }
    y[r0..r0 + B].copy_from_slice(&acc);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_quasi_upper_first_term_gives_the_dense_sum() {
        let mut uniform = crate::lcg(777);
        let mut rand = || uniform() - 0.5;
        for n in [1, 2, 7, 16, 17, 33, 66] {
            // Zero below the first subdiagonal, which holds 2×2 blocks here and there.
            let u = DMatrix::from_fn(n, n, |i, j| {
                if i <= j || (i == j + 1 && j % 3 == 1) {
                    1.0 + rand()
                } else {
                    0.0
                }
            });
            let g = DMatrix::from_fn(n, 5, |_, _| rand());
            let (x, v): (Vec<f64>, Vec<f64>) = ((0..n).map(|_| rand()).collect(), vec![0.3; 5]);
            let (mut fast, mut dense) = (vec![f64::NAN; n], vec![f64::NAN; n]);
            mat_vec_sum_quasi_upper(&mut fast, &[(&u, &x), (&g, &v)]);
            mat_vec_sum(&mut dense, &[(&u, &x), (&g, &v)]);
            for (k, (a, b)) in fast.iter().zip(&dense).enumerate() {
                assert_eq!(a.to_bits(), b.to_bits(), "n = {n}, row {k}: {a} vs {b}");
            }
        }
    }

    #[test]
    fn mat_vec_sum_is_chained_gemv_bit_for_bit() {
        // Sizes with and without a partial block; a small LCG for reproducible values.
        let mut uniform = crate::lcg(12345);
        let mut rand = || uniform() - 0.5;
        for (n, m1, m2) in [
            (16, 16, 13),
            (21, 21, 13),
            (29, 29, 13),
            (5, 16, 8),
            (1, 3, 0),
            (8, 0, 4),
            (32, 7, 2),
            (2, 4, 4),
            (3, 1, 1),
            (4, 2, 2),
            (6, 3, 3),
            (7, 5, 0),
            (0, 3, 2),
        ] {
            let a1 = DMatrix::from_fn(n, m1, |_, _| rand());
            let a2 = DMatrix::from_fn(n, m2, |_, _| rand());
            let x1: Vec<f64> = (0..m1).map(|_| rand()).collect();
            let x2: Vec<f64> = (0..m2).map(|_| rand()).collect();
            let mut y = vec![f64::NAN; n];
            mat_vec_sum(&mut y, &[(&a1, &x1), (&a2, &x2)]);
            // The baseline code too (what runs where the CPU has no AVX).
            let mut baseline = vec![f64::NAN; n];
            mat_vec_sum_blocks::<false>(&mut baseline, &[(&a1, &x1), (&a2, &x2)]);
            for (k, (a, b)) in y.iter().zip(&baseline).enumerate() {
                assert_eq!(a.to_bits(), b.to_bits(), "n = {n}, row {k}: {a} vs {b}");
            }
            let mut reference = nalgebra::DVector::from_element(n, 0.0);
            reference.gemv(1.0, &a1, &nalgebra::DVector::from_column_slice(&x1), 0.0);
            reference.gemv(1.0, &a2, &nalgebra::DVector::from_column_slice(&x2), 1.0);
            for (k, (a, b)) in y.iter().zip(reference.iter()).enumerate() {
                assert_eq!(a.to_bits(), b.to_bits(), "n = {n}, row {k}: {a} vs {b}");
            }
        }
    }

    #[test]
    fn scalar_system_matches_closed_form() {
        // ẋ = −2x + 3v, v(s) = v0 + (v1 − v0) s/h: closed form by hand.
        let (a, b, h) = (-2.0f64, 3.0, 0.37);
        let d = discretize(
            &DMatrix::from_element(1, 1, a),
            &DMatrix::from_element(1, 1, b),
            h,
        )
        .unwrap();
        let phi = (a * h).exp();
        let g0 = b * (phi - 1.0) / a;
        // ∫₀ʰ e^{a(h−s)} b s/h ds = b/(a² h) (e^{ah} − 1 − a h)
        let g1 = b / (a * a * h) * (phi - 1.0 - a * h);
        assert!((d.phi[(0, 0)] - phi).abs() < 1e-15);
        assert!((d.gamma_hold[(0, 0)] - g0).abs() < 1e-14);
        assert!((d.gamma_ramp[(0, 0)] - g1).abs() < 1e-14);
    }

    #[test]
    fn undamped_oscillator_rotates_exactly() {
        let w = 7.0;
        let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -w * w, 0.0]);
        let d = discretize(&a, &DMatrix::zeros(2, 1), 0.1).unwrap();
        assert!((d.phi[(0, 0)] - (0.7f64).cos()).abs() < 1e-14);
        assert!((d.phi[(0, 1)] - (0.7f64).sin() / w).abs() < 1e-14);
    }

    /// nalgebra's `exp` of these never returns (its scaling count saturates); ours refuses
    /// them, and still computes a large but admissible one: a stiff decay over a long step.
    #[test]
    fn absurd_exponentials_are_refused_not_computed_forever() {
        let m = |v: f64| DMatrix::from_row_slice(2, 2, &[-v, 1.0, 0.0, -1.0]);
        assert_eq!(expm(&m(1e40)), Err(ExpError::TooLarge(1e40)));
        assert_eq!(expm(&m(1e21)), Err(ExpError::TooLarge(1e21)));
        assert_eq!(expm(&m(f64::NAN)), Err(ExpError::NonFinite));
        assert_eq!(expm(&m(f64::INFINITY)), Err(ExpError::NonFinite));
        let e = expm(&m(1e14)).unwrap();
        assert_eq!(e[(0, 0)], 0.0);
        // The slow mode after 45 squarings: scaling and squaring loses digits (3e-9 here).
        assert!((e[(1, 1)] - (-1.0f64).exp()).abs() < 1e-8);
        // Growth beyond f64: refused, not returned as infinities.
        let grow = DMatrix::from_row_slice(2, 2, &[800.0, 0.0, 0.0, 1.0]);
        assert_eq!(expm(&grow), Err(ExpError::Overflow));
        let b = DMatrix::from_element(2, 1, 1e40);
        assert!(matches!(
            discretize(&m(1.0), &b, 1.0),
            Err(ExpError::TooLarge(_))
        ));
    }
}
