//! A dynamic controller stepped in a real Schur basis of its balanced stepped system.
//!
//! The system is first balanced, `A = S A_b S⁻¹` (`S` diagonal, powers of 2: exact in floating
//! point; nalgebra's Parlett–Reinsch balancing). A synthesised realisation can be badly scaled:
//! `hinf_of`'s `A` has a 1-norm of 1.2·10⁹ against eigenvalues of at most 1.7·10³ (its filter's
//! gains on the load cells), and a Schur form of it is exact only to `ε ‖A‖`, which moved its
//! commands by 2.6·10⁻⁶ of their size within 0.2 s against the exact discretisation; balanced,
//! 5·10⁻¹². With `A_b = Q T Qᵀ` (`Q` orthogonal, `T` quasi-upper-triangular: 1×1 and 2×2 blocks
//! on the diagonal, zero below its first subdiagonal) the state `z = P⁻¹ x`, `P = S Q`, steps as
//! `ż = T z + P⁻¹ B v`, and the exponential `Φ_z = e^{T h}` has `T`'s block structure too. Its
//! product ([`linsys::mat_vec_sum_quasi_upper`]) skips the blocks below the diagonal: for the 66
//! states of `hinf_of` (its filter and its anti-windup compensator) the step's products go
//! from about 6 500 to 4 600 multiply-adds (`docs/performance.md`). The commands are those of
//! the original basis to rounding (a test compares them).
//!
//! The stepped system is block upper triangular (the filter reads the compensator, neither
//! reads the fault detector, nothing reads the filter), and so is its balanced form (a diagonal
//! similarity keeps every zero), so `Q` is taken block by block,
//! `Q = diag(Q_1, Q_2, …)` with `A_b,ii = Q_i T_ii Q_iᵀ`: `T` is then quasi-upper-triangular and
//! keeps the blocks apart, so a compensator at rest (`η = 0`, no actuator saturated) is a block
//! of exact zeros in `z` too, whose products the controller skips. A single Schur form of the
//! whole `A` would mix the blocks: its modes are the blocks' modes, but its basis is not.

use nalgebra::DMatrix;

/// The basis and what reads the state in it.
#[derive(Debug, Clone)]
pub struct SchurBasis {
    /// `x = P z`, `P = S Q`.
    pub p: DMatrix<f64>,
    /// Whether `T` has a 2×2 block at rows `i, i + 1` (its subdiagonal entry `(i + 1, i)`).
    block: Vec<bool>,
}

/// The stepped system in the real Schur basis of its balanced form: `T = Qᵀ S⁻¹ A S Q`,
/// quasi-upper-triangular (zeroed below its blocks), and `P⁻¹ B = Qᵀ S⁻¹ B`.
pub struct SchurForm {
    pub basis: SchurBasis,
    pub a: DMatrix<f64>,
    pub b: DMatrix<f64>,
}

impl SchurForm {
    /// `(a, b)` in its real Schur basis taken block by block along `blocks` (the sizes of the
    /// diagonal blocks, summing to `a`'s order; `a` zero below them), or `None` where it has
    /// no state, is not block upper triangular along `blocks`, or the QR iteration does not
    /// converge on a block (the controller then steps in its own basis).
    pub fn new(a: &DMatrix<f64>, b: &DMatrix<f64>, blocks: &[usize]) -> Option<SchurForm> {
        let n = a.nrows();
        if n == 0 || blocks.iter().sum::<usize>() != n {
            return None;
        }
        let starts: Vec<usize> = blocks
            .iter()
            .scan(0, |at, &k| {
                *at += k;
                Some(*at - k)
            })
            .collect();
        let below_blocks_is_zero = starts
            .iter()
            .zip(blocks)
            .all(|(&at, &k)| (at + k..n).all(|i| (at..at + k).all(|j| a[(i, j)] == 0.0)));
        if !below_blocks_is_zero {
            return None;
        }
        let mut balanced = a.clone();
        let s = nalgebra::linalg::balancing::balance_parlett_reinsch(&mut balanced);
        let scale = balanced.amax().max(f64::MIN_POSITIVE);
        let (mut q, mut diagonal) = (DMatrix::zeros(n, n), Vec::new());
        let mut block = vec![false; n.saturating_sub(1)];
        for (&at, &k) in starts.iter().zip(blocks).filter(|(_, &k)| k > 0) {
            let aii = balanced.view((at, at), (k, k)).into_owned();
            let (qi, ti) = nalgebra::linalg::Schur::try_new(aii, f64::EPSILON, 10_000)?.unpack();
            // A subdiagonal entry the iteration left negligible is no block.
            for i in 0..k - 1 {
                block[at + i] = ti[(i + 1, i)].abs() > 8.0 * f64::EPSILON * scale;
            }
            q.view_mut((at, at), (k, k)).copy_from(&qi);
            diagonal.push((at, ti));
        }
        let mut t = q.transpose() * balanced * &q;
        // Each diagonal block as its QR iteration left it (the product's is the same to
        // rounding); the blocks below the diagonal are exact zeros, `Q` being block diagonal.
        for (at, ti) in diagonal {
            t.view_mut((at, at), ti.shape()).copy_from(&ti);
        }
        let mut unscaled = b.clone();
        for (i, si) in s.iter().enumerate() {
            unscaled.row_mut(i).unscale_mut(*si);
        }
        let b = q.transpose() * unscaled;
        for (i, si) in s.iter().enumerate() {
            q.row_mut(i).scale_mut(*si);
        }
        let basis = SchurBasis { p: q, block };
        Some(SchurForm {
            a: basis.quasi_upper(t),
            b,
            basis,
        })
    }
}

impl SchurBasis {
    /// `m` with the entries outside `T`'s structure (below the subdiagonal, and on it where
    /// `T` has no 2×2 block) set to zero: rounding, in `T` and in its exponential.
    pub fn quasi_upper(&self, mut m: DMatrix<f64>) -> DMatrix<f64> {
        let n = m.nrows();
        for j in 0..n {
            for i in j + 1..n {
                if i > j + 1 || !self.block[j] {
                    m[(i, j)] = 0.0;
                }
            }
        }
        m
    }

    /// Rows that read `x`, read `z`: `M P`.
    pub fn reading(&self, m: &DMatrix<f64>) -> DMatrix<f64> {
        m * &self.p
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DVector;

    /// A basis that reproduces the system: `P T P⁻¹ = A`, `P⁻¹ B` the input, `T` quasi-upper-
    /// triangular with a 2×2 block for each complex pair.
    #[test]
    fn the_schur_basis_reproduces_the_system() {
        // A lightly damped oscillator (a complex pair), a real mode, a coupling.
        let a = DMatrix::from_row_slice(
            4,
            4,
            &[
                0.0, 1.0, 0.3, 0.0, //
                -400.0, -2.0, 0.0, 1.0, //
                0.0, 0.0, -30.0, 0.5, //
                1.0, 0.0, 0.0, -5.0,
            ],
        );
        let b = DMatrix::from_fn(4, 2, |i, j| (i + 2 * j) as f64 - 1.5);
        let SchurForm {
            basis: s,
            a: t,
            b: qb,
        } = SchurForm::new(&a, &b, &[4]).unwrap();
        let p_inv = s.p.clone().try_inverse().unwrap();
        assert!((&s.p * &t * &p_inv - &a).amax() < 1e-12 * a.amax());
        assert!((&s.p * &qb - &b).amax() < 1e-13);
        for j in 0..4 {
            for i in j + 2..4 {
                assert_eq!(t[(i, j)], 0.0);
            }
        }
        assert_eq!(s.block.iter().filter(|b| **b).count(), 1, "{:?}", s.block);
    }

    /// Taken block by block, the basis keeps a block upper triangular system's blocks apart:
    /// `P` block diagonal, `P T P⁻¹ = A`, `T` quasi-upper-triangular with no 2×2
    /// block across two of the system's blocks. A system with a coupling below its blocks has
    /// no such basis.
    #[test]
    fn a_basis_taken_block_by_block_keeps_the_blocks_apart() {
        let mut uniform = linsys::lcg(5);
        let (n1, n2) = (5, 4);
        let n = n1 + n2;
        // Each block a few oscillators and a real mode; the first reads the second.
        let mut a = DMatrix::from_fn(n, n, |i, j| match (i < n1, j < n1) {
            (false, true) => 0.0,
            _ if i == j => -1.0 - i as f64,
            _ => 3.0 * (uniform() - 0.5),
        });
        let b = DMatrix::from_fn(n, 3, |i, j| (i * 3 + j) as f64 * 0.1 - 1.0);
        let SchurForm {
            basis: s,
            a: t,
            b: qb,
        } = SchurForm::new(&a, &b, &[n1, n2]).unwrap();
        let p_inv = s.p.clone().try_inverse().unwrap();
        assert!((&s.p * &t * &p_inv - &a).amax() < 1e-12 * a.amax());
        assert!((&s.p * &qb - &b).amax() < 1e-13);
        for i in 0..n {
            for j in 0..n {
                if (i < n1) != (j < n1) && i > j {
                    assert_eq!(s.p[(i, j)], 0.0, "P at ({i}, {j})");
                    assert_eq!(s.p[(j, i)], 0.0, "P at ({j}, {i})");
                }
                if i > j + 1 || (i == j + 1 && !s.block[j]) {
                    assert_eq!(t[(i, j)], 0.0, "T at ({i}, {j})");
                }
            }
        }
        assert!(!s.block[n1 - 1], "a 2×2 block across the two blocks");
        assert!(
            s.block.iter().any(|b| *b),
            "the test's blocks have complex pairs"
        );
        a[(n1, 0)] = 1e-3;
        assert!(SchurForm::new(&a, &b, &[n1, n2]).is_none());
        assert!(SchurForm::new(&a, &b, &[n]).is_some());
    }

    /// A badly scaled realisation (a well-scaled system under a diagonal similarity of 10⁻⁴ …
    /// 10⁴, as a synthesis can write one) steps in its basis as the well-scaled twin does: the
    /// outputs of 200 held steps of 1 ms agree with the twin's to 10⁻¹⁰ of their size. Without
    /// the balancing (the Schur form of the raw `A`) they are off by 7.6·10⁻⁵ of it (measured;
    /// `hinf_of`'s commands by 2.6·10⁻⁶).
    #[test]
    fn a_badly_scaled_system_steps_as_its_well_scaled_twin() {
        let mut uniform = linsys::lcg(11);
        let n = 8;
        let a0 = DMatrix::from_fn(n, n, |i, j| {
            if i == j {
                -1.0 - 40.0 * i as f64
            } else {
                30.0 * (uniform() - 0.5)
            }
        });
        let b0 = DMatrix::from_fn(n, 2, |i, j| (i + j) as f64 * 0.3 - 1.0);
        let c0 = DMatrix::from_fn(2, n, |i, j| (i * n + j) as f64 * 0.1 - 0.7);
        let d: Vec<f64> = (0..n)
            .map(|i| 10f64.powf(-4.0 + 8.0 * i as f64 / (n - 1) as f64))
            .collect();
        // A = D A₀ D⁻¹, B = D B₀, C = C₀ D⁻¹: the same system.
        let a = DMatrix::from_fn(n, n, |i, j| d[i] * a0[(i, j)] / d[j]);
        let b = DMatrix::from_fn(n, 2, |i, j| d[i] * b0[(i, j)]);
        let c = DMatrix::from_fn(2, n, |i, j| c0[(i, j)] / d[j]);
        let outputs = |a: &DMatrix<f64>, b: &DMatrix<f64>, c: &DMatrix<f64>| {
            let d = linsys::discretize(a, b, 1e-3).unwrap();
            let v = DVector::from_element(2, 1.0);
            let mut x = DVector::zeros(a.nrows());
            let mut y = Vec::new();
            for _ in 0..200 {
                x = &d.phi * x + &d.gamma_hold * &v;
                y.push(c * &x);
            }
            y
        };
        let twin = outputs(&a0, &b0, &c0);
        let size = twin.iter().map(|y| y.amax()).fold(0.0, f64::max);
        let s = SchurForm::new(&a, &b, &[n]).unwrap();
        let stepped = outputs(&s.a, &s.b, &s.basis.reading(&c));
        let off = twin
            .iter()
            .zip(&stepped)
            .map(|(t, s)| (t - s).amax())
            .fold(0.0, f64::max);
        assert!(off < 1e-10 * size, "{off} of {size}");
    }
}
