//! Eigenvalues and the real Schur form from LAPACK (`dgeev`, `dgees` of Debian's OpenBLAS, the
//! library the SDP solver already links). nalgebra's own QR iteration stalls on the badly
//! scaled Hamiltonians of 60-state closed loops (observed: minutes without converging);
//! LAPACK's balances (`dgeev`) and converges in milliseconds.

use nalgebra::{Complex, DMatrix};

/// The eigenvalues of a real square matrix; empty if LAPACK does not converge (which callers
/// treat as a failure).
pub fn eigenvalues(m: &DMatrix<f64>) -> Vec<Complex<f64>> {
    if m.nrows() == 0 {
        return Vec::new();
    }
    if !m.iter().all(|v| v.is_finite()) {
        return vec![Complex::new(f64::NAN, 0.0)];
    }
    match nalgebra_lapack::Eigen::new(m.clone(), false, false) {
        Some(e) => e
            .eigenvalues_re
            .iter()
            .zip(e.eigenvalues_im.iter())
            .map(|(re, im)| Complex::new(*re, *im))
            .collect(),
        None => vec![Complex::new(f64::NAN, 0.0)],
    }
}

/// The largest of `values` and `floor`, NaN if any of them is (where `f64::max` would drop it).
pub fn max_or_nan(floor: f64, values: impl IntoIterator<Item = f64>) -> f64 {
    values.into_iter().fold(floor, |a, b| {
        if b.is_nan() || a.is_nan() {
            f64::NAN
        } else {
            a.max(b)
        }
    })
}

/// The largest real part of the eigenvalues (NaN if they could not be computed).
pub fn spectral_abscissa(m: &DMatrix<f64>) -> f64 {
    max_or_nan(f64::NEG_INFINITY, eigenvalues(m).iter().map(|l| l.re))
}

/// The largest modulus of the eigenvalues (NaN if they could not be computed).
pub fn spectral_radius(m: &DMatrix<f64>) -> f64 {
    max_or_nan(0.0, eigenvalues(m).iter().map(|l| l.norm()))
}

/// The real Schur form of `m` with the eigenvalues of negative real part first, after balancing
/// (`dgebal`, scaling only, then `dgees` with sorting, Laub's method as in SLICOT and SciPy):
/// an orthonormal... basis of the stable invariant subspace of `m` as the first `k` columns of
/// `D U` (`D` the balancing scale; not orthonormal after it). Returns `(D U, k)`.
pub fn stable_subspace(m: &DMatrix<f64>) -> Option<(DMatrix<f64>, usize)> {
    let n = m.nrows();
    let (mut a, scale) = balance(m)?;
    let mut info = 0;
    extern "C" fn stable(re: *const f64, _im: *const f64) -> i32 {
        // SAFETY: LAPACK passes pointers to the real and imaginary part of an eigenvalue.
        i32::from(unsafe { *re } < 0.0)
    }
    let (mut sdim, mut wr, mut wi) = (0, vec![0.0; n], vec![0.0; n]);
    let mut vs = DMatrix::<f64>::zeros(n, n);
    let mut bwork = vec![0; n];
    let mut work = vec![0.0; 1];
    // Workspace query, then the decomposition.
    for query in [true, false] {
        let lwork = if query { -1 } else { work.len() as i32 };
        // SAFETY: all arrays have the sizes dgees documents for order n; `lwork` is the
        // queried workspace size (or −1 for the query).
        unsafe {
            lapack::dgees(
                b'V',
                b'S',
                Some(stable),
                n as i32,
                a.as_mut_slice(),
                n as i32,
                &mut sdim,
                &mut wr,
                &mut wi,
                vs.as_mut_slice(),
                n as i32,
                &mut work,
                lwork,
                &mut bwork,
                &mut info,
            );
        }
        if info != 0 {
            return None;
        }
        if query {
            work = vec![0.0; (work[0] as usize).max(3 * n)];
        }
    }
    let d = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(scale));
    Some((d * vs, sdim as usize))
}

/// `m` balanced by LAPACK's `dgebal` (scaling only, by powers of 2, so exactly): `(D⁻¹ m D, d)`
/// with `D = diag(d)`, rows and columns of comparable norm. `None` for a matrix with NaN or inf.
pub fn balance(m: &DMatrix<f64>) -> Option<(DMatrix<f64>, Vec<f64>)> {
    let n = m.nrows();
    if !m.iter().all(|v| v.is_finite()) {
        return None;
    }
    let mut a = m.clone();
    let (mut ilo, mut ihi, mut info) = (0, 0, 0);
    let mut scale = vec![0.0; n];
    // SAFETY: `a` is n×n column-major with leading dimension n, `scale` has n entries.
    unsafe {
        lapack::dgebal(
            b'S',
            n as i32,
            a.as_mut_slice(),
            n as i32,
            &mut ilo,
            &mut ihi,
            &mut scale,
            &mut info,
        );
    }
    (info == 0).then_some((a, scale))
}

/// The real Schur form `m = U T Uᵀ`, `T` quasi upper triangular: `(U, T)`.
pub fn real_schur(m: &DMatrix<f64>) -> Option<(DMatrix<f64>, DMatrix<f64>)> {
    if !m.iter().all(|v| v.is_finite()) {
        return None;
    }
    nalgebra_lapack::Schur::try_new(m.clone()).map(|s| s.unpack())
}

/// Every eigenvalue strictly in the left half plane (false for a matrix with NaN).
pub fn is_hurwitz(a: &DMatrix<f64>) -> bool {
    spectral_abscissa(a) < 0.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eigenvalues_and_schur_form_of_a_rotation_and_a_decay() {
        let m = DMatrix::from_row_slice(3, 3, &[0.0, 2.0, 0.0, -2.0, 0.0, 0.0, 0.0, 0.0, -1.0]);
        let mut ev: Vec<(f64, f64)> = eigenvalues(&m).iter().map(|l| (l.re, l.im)).collect();
        ev.sort_by(|a, b| a.partial_cmp(b).unwrap());
        assert!((ev[0].0 + 1.0).abs() < 1e-14);
        assert!((ev[1].1.abs() - 2.0).abs() < 1e-14 && (ev[2].1.abs() - 2.0).abs() < 1e-14);
        assert!(spectral_abscissa(&m).abs() < 1e-14);
        assert!(!is_hurwitz(&m) && is_hurwitz(&(-DMatrix::<f64>::identity(2, 2))));
        let (u, t) = real_schur(&m).unwrap();
        assert!((&u * &t * u.transpose() - &m).norm() < 1e-13);
        assert!(spectral_abscissa(&DMatrix::from_element(1, 1, f64::NAN)).is_nan());
    }
}
