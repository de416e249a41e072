//! A dynamic controller stepped in a real Schur basis of its stepped system.
//!
//! With `A = Q T Qᵀ` (`Q` orthogonal, `T` quasi-upper-triangular: 1×1 and 2×2 blocks on the
//! diagonal, zero below its first subdiagonal) the state `z = Qᵀ x` steps as `ż = T z + Qᵀ B v`,
//! and the exponential `Φ_z = e^{T h}` has `T`'s block structure too. Its product
//! ([`linsys::mat_vec_sum_quasi_upper`]) skips the blocks below the diagonal: for the 66
//! states of `hinf_of` (its filter and its anti-windup compensator) the step's products go
//! from about 6 500 to 4 600 multiply-adds, and the loop got 9–12 % faster
//! (`docs/performance.md`). `Q` is orthogonal, so the basis costs no conditioning; the commands
//! are those of the original basis to rounding (a test compares them).

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
    /// `(a, b)` in its real Schur basis, or `None` where it has no state or the QR iteration
    /// does not converge (the controller then steps in its own basis).
    pub fn new(a: &DMatrix<f64>, b: &DMatrix<f64>) -> Option<SchurForm> {
        let n = a.nrows();
        if n == 0 {
            return None;
        }
        let (q, t) = nalgebra::linalg::Schur::try_new(a.clone(), f64::EPSILON, 10_000)?.unpack();
        let scale = a.amax().max(f64::MIN_POSITIVE);
        // A subdiagonal entry the iteration left negligible is no block.
        let block: Vec<bool> = (0..n - 1)
            .map(|i| t[(i + 1, i)].abs() > 8.0 * f64::EPSILON * scale)
            .collect();
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
        } = SchurForm::new(&a, &b).unwrap();
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
}
