//! A dynamic controller stepped in a real Schur basis of its stepped system.
//!
//! With `A = Q T Qᵀ` (`Q` orthogonal, `T` quasi-upper-triangular: 1×1 and 2×2 blocks on the
//! diagonal, zero below its first subdiagonal) the state `z = Qᵀ x` steps as `ż = T z + Qᵀ B v`,
//! and the exponential `Φ_z = e^{T h}` has `T`'s block structure too. Its product
//! ([`linsys::mat_vec_sum_quasi_upper`]) skips the blocks below the diagonal: for the 66
//! states of `hinf_of` (its filter and its anti-windup compensator) the step's products go
//! from about 6 500 to 4 600 multiply-adds (`docs/performance.md`). `Q` is orthogonal, so the
//! basis costs no conditioning; the commands are those of the original basis to rounding (a
//! test compares them).
//!
//! The stepped system is block upper triangular (the filter reads the compensator, neither
//! reads the fault detector, nothing reads the filter), so `Q` is taken block by block,
//! `Q = diag(Q_1, Q_2, …)` with `A_ii = Q_i T_ii Q_iᵀ`: `T` is then quasi-upper-triangular and
//! keeps the blocks apart, so a compensator at rest (`η = 0`, no actuator saturated) is a block
//! of exact zeros in `z` too, whose products the controller skips. A single Schur form of the
//! whole `A` would mix the blocks: its modes are the blocks' modes, but its basis is not.

use nalgebra::DMatrix;

/// The basis and what reads the state in it.
#[derive(Debug, Clone)]
pub struct SchurBasis {
    /// `x = Q z`.
    pub q: DMatrix<f64>,
    /// Whether `T` has a 2×2 block at rows `i, i + 1` (its subdiagonal entry `(i + 1, i)`).
    block: Vec<bool>,
}

/// The stepped system in its real Schur basis: `T = Qᵀ A Q`, quasi-upper-triangular (zeroed
/// below its blocks), and `Qᵀ B`.
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
        let scale = a.amax().max(f64::MIN_POSITIVE);
        let (mut q, mut diagonal) = (DMatrix::zeros(n, n), Vec::new());
        let mut block = vec![false; n.saturating_sub(1)];
        for (&at, &k) in starts.iter().zip(blocks).filter(|(_, &k)| k > 0) {
            let aii = a.view((at, at), (k, k)).into_owned();
            let (qi, ti) = nalgebra::linalg::Schur::try_new(aii, f64::EPSILON, 10_000)?.unpack();
            // A subdiagonal entry the iteration left negligible is no block.
            for i in 0..k - 1 {
                block[at + i] = ti[(i + 1, i)].abs() > 8.0 * f64::EPSILON * scale;
            }
            q.view_mut((at, at), (k, k)).copy_from(&qi);
            diagonal.push((at, ti));
        }
        let mut t = q.transpose() * a * &q;
        // Each diagonal block as its QR iteration left it (the product's is the same to
        // rounding); the blocks below the diagonal are exact zeros, `Q` being block diagonal.
        for (at, ti) in diagonal {
            t.view_mut((at, at), ti.shape()).copy_from(&ti);
        }
        let b = q.transpose() * b;
        let basis = SchurBasis { q, block };
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

    /// Rows that read `x`, read `z`: `M Q`.
    pub fn reading(&self, m: &DMatrix<f64>) -> DMatrix<f64> {
        m * &self.q
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A basis that reproduces the system: `Q` orthogonal, `Q T Qᵀ = A`, `T` quasi-upper-
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
        let identity = s.q.transpose() * &s.q;
        assert!((identity - DMatrix::identity(4, 4)).amax() < 1e-14);
        assert!((&s.q * &t * s.q.transpose() - &a).amax() < 1e-12 * a.amax());
        assert!((&s.q * &qb - &b).amax() < 1e-13);
        for j in 0..4 {
            for i in j + 2..4 {
                assert_eq!(t[(i, j)], 0.0);
            }
        }
        assert_eq!(s.block.iter().filter(|b| **b).count(), 1, "{:?}", s.block);
    }

    /// Taken block by block, the basis keeps a block upper triangular system's blocks apart:
    /// `Q` block diagonal and orthogonal, `Q T Qᵀ = A`, `T` quasi-upper-triangular with no 2×2
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
        assert!((s.q.transpose() * &s.q - DMatrix::identity(n, n)).amax() < 1e-14);
        assert!((&s.q * &t * s.q.transpose() - &a).amax() < 1e-12 * a.amax());
        assert!((&s.q * &qb - &b).amax() < 1e-13);
        for i in 0..n {
            for j in 0..n {
                if (i < n1) != (j < n1) && i > j {
                    assert_eq!(s.q[(i, j)], 0.0, "Q at ({i}, {j})");
                    assert_eq!(s.q[(j, i)], 0.0, "Q at ({j}, {i})");
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
}
