//! Exact discretisation of a linear system over one step.
//!
//! For `ẋ = A x + B v(t)` with `v` linear over `[0, h]` (`v(s) = v₀ + (v₁ − v₀) s/h`, which
//! covers held inputs as `v₁ = v₀`), the exponential of the augmented matrix
//! `exp([[A h, B h, 0], [0, 0, I], [0, 0, 0]]) = [[Φ, Γ₀, Γ₁], [0, I, I], [0, 0, I]]` gives
//! `x(h) = Φ x₀ + Γ₀ v₀ + Γ₁ (v₁ − v₀)` without approximation beyond rounding
//! (Franklin, Powell & Workman, *Digital Control*, §6.3.2, triangle-hold equivalent).
//! The matrix exponential is nalgebra's (Padé with scaling and squaring).

use nalgebra::DMatrix;

/// `x(h) = Φ x₀ + Γ₀ v₀ + Γ₁ (v₁ − v₀)`.
#[derive(Debug, Clone, PartialEq)]
pub struct Discretization {
    pub step: f64,
    pub phi: DMatrix<f64>,
    pub gamma_hold: DMatrix<f64>,
    pub gamma_ramp: DMatrix<f64>,
}

/// Discretise `(A, B)` exactly for step `h ≥ 0`.
pub fn discretize(a: &DMatrix<f64>, b: &DMatrix<f64>, h: f64) -> Discretization {
    let (n, m) = (a.nrows(), b.ncols());
    assert!(a.is_square() && b.nrows() == n, "A must be n×n and B n×m");
    let mut big = DMatrix::zeros(n + 2 * m, n + 2 * m);
    big.view_mut((0, 0), (n, n)).copy_from(&(a * h));
    big.view_mut((0, n), (n, m)).copy_from(&(b * h));
    big.view_mut((n, n + m), (m, m)).fill_with_identity();
    let e = big.exp();
    Discretization {
        step: h,
        phi: e.view((0, 0), (n, n)).into_owned(),
        gamma_hold: e.view((0, n), (n, m)).into_owned(),
        gamma_ramp: e.view((0, n + m), (n, m)).into_owned(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scalar_system_matches_closed_form() {
        // ẋ = −2x + 3v, v(s) = v0 + (v1 − v0) s/h: closed form by hand.
        let (a, b, h) = (-2.0f64, 3.0, 0.37);
        let d = discretize(&DMatrix::from_element(1, 1, a), &DMatrix::from_element(1, 1, b), h);
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
        let d = discretize(&a, &DMatrix::zeros(2, 1), 0.1);
        assert!((d.phi[(0, 0)] - (0.7f64).cos()).abs() < 1e-14);
        assert!((d.phi[(0, 1)] - (0.7f64).sin() / w).abs() < 1e-14);
    }
}
