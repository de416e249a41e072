//! H∞ norm of a stable LTI system by the Hamiltonian method of Bruinsma & Steinbuch, "A fast
//! algorithm to compute the H∞-norm of a transfer function matrix", Systems & Control Letters
//! 14 (1990) 287–293. Independent of any LMI: it is how we certify the γ an LMI claims.
//!
//! `γ` is a singular value of `G(jω)` exactly when the Hamiltonian
//! `H(γ) = [[A − B R⁻¹ Dᵀ C, −γ B R⁻¹ Bᵀ], [γ Cᵀ S⁻¹ C, −Aᵀ + Cᵀ D R⁻¹ Bᵀ]]`,
//! `R = DᵀD − γ²I`, `S = DDᵀ − γ²I`, has the eigenvalue `jω`. Starting from a lower bound, each
//! iteration evaluates `σ_max` at the midpoints between the imaginary-axis eigenvalues; when
//! `H((1 + 2ε) γ_lb)` has none, the norm lies in `[γ_lb, (1 + 2ε) γ_lb]`.

use nalgebra::{Complex, DMatrix};

/// A controller in the plant's units: `ẋc = Ac xc + Bc y`, `u [N] = Cc xc + Dc y` — an LTI
/// system like any other ([`Lti::static_gain`] for one without states).
pub type Controller = Lti;

pub use linsys::Lti;

/// The norm with its bracket and the frequency where it is attained.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Norm {
    pub lower: f64,
    pub upper: f64,
    /// [rad/s]
    pub peak_frequency: f64,
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NormError {
    #[error("the system is not asymptotically stable (spectral abscissa {0:e}); its H∞ norm is infinite")]
    Unstable(f64),
    #[error("the bisection did not converge in {0} iterations")]
    NoConvergence(usize),
    #[error("the system has feed-through (‖D‖ = {0:e}); its H2 norm is infinite")]
    Feedthrough(f64),
}

/// What the synthesis computes of an [`Lti`]: stability, the H∞ norm (Hamiltonian bisection,
/// LAPACK eigenvalues), the controllability Gramian and the H2 and energy-to-peak norms from it.
/// A trait here, not methods of `linsys::Lti`, so that the FMUs, which share the type, do not
/// link LAPACK.
pub trait Analysis {
    fn spectral_abscissa(&self) -> f64;
    fn sigma_max(&self, w: f64) -> f64;
    fn hinf_norm(&self, tol: f64) -> Result<Norm, NormError>;
    fn controllability_gramian(&self) -> Result<DMatrix<f64>, NormError>;
    fn h2_norm(&self) -> Result<f64, NormError>;
    fn energy_to_peak(&self) -> Result<Vec<f64>, NormError>;
}

impl Analysis for Lti {
    /// Largest real part of the eigenvalues of `A`.
    fn spectral_abscissa(&self) -> f64 {
        crate::numerics::eig::spectral_abscissa(&self.a)
    }

    /// `σ_max(G(jω))`.
    fn sigma_max(&self, w: f64) -> f64 {
        let n = self.a.nrows();
        let mut jw_a = self.a.map(|v| Complex::new(-v, 0.0));
        for i in 0..n {
            jw_a[(i, i)] += Complex::new(0.0, w);
        }
        let b = self.b.map(|v| Complex::new(v, 0.0));
        let x = jw_a
            .lu()
            .solve(&b)
            .expect("jωI − A is invertible for a stable A");
        let g = self.c.map(|v| Complex::new(v, 0.0)) * x + self.d.map(|v| Complex::new(v, 0.0));
        g.singular_values().max()
    }

    /// The H∞ norm to relative accuracy `tol` (bracket width `2·tol`).
    fn hinf_norm(&self, tol: f64) -> Result<Norm, NormError> {
        require_stable(self)?;
        let (n, m, p) = (self.a.nrows(), self.b.ncols(), self.c.nrows());
        // Initial lower bound: D, DC gain, and the most lightly damped pole's frequency.
        let poles = crate::numerics::eig::eigenvalues(&self.a);
        let w_p = poles
            .iter()
            .max_by(|x, y| {
                let f = |l: &Complex<f64>| {
                    if l.im == 0.0 {
                        0.0
                    } else {
                        (l.im / l.re).abs() / l.norm()
                    }
                };
                f(x).total_cmp(&f(y))
            })
            .map(|l| {
                if l.im == 0.0 {
                    poles.iter().map(|q| q.norm()).fold(f64::INFINITY, f64::min)
                } else {
                    l.norm()
                }
            })
            .unwrap_or(0.0);
        let mut lower = self.d.singular_values().max();
        let mut peak = f64::INFINITY;
        for w in [0.0, w_p] {
            let s = self.sigma_max(w);
            if s > lower {
                lower = s;
                peak = w;
            }
        }
        if lower == 0.0 {
            return Ok(Norm {
                lower: 0.0,
                upper: 0.0,
                peak_frequency: 0.0,
            });
        }
        for _ in 0..100 {
            let gamma = (1.0 + 2.0 * tol) * lower;
            let g2 = gamma * gamma;
            let r = self.d.transpose() * &self.d - DMatrix::identity(m, m) * g2;
            let s = &self.d * self.d.transpose() - DMatrix::identity(p, p) * g2;
            let r_inv = r
                .try_inverse()
                .expect("R = DᵀD − γ²I is definite for γ > σ(D)");
            let s_inv = s
                .try_inverse()
                .expect("S = DDᵀ − γ²I is definite for γ > σ(D)");
            let mut h = DMatrix::zeros(2 * n, 2 * n);
            h.view_mut((0, 0), (n, n))
                .copy_from(&(&self.a - &self.b * &r_inv * self.d.transpose() * &self.c));
            h.view_mut((0, n), (n, n))
                .copy_from(&(&self.b * &r_inv * self.b.transpose() * (-gamma)));
            h.view_mut((n, 0), (n, n))
                .copy_from(&(self.c.transpose() * &s_inv * &self.c * gamma));
            h.view_mut((n, n), (n, n)).copy_from(
                &(-self.a.transpose() + self.c.transpose() * &self.d * &r_inv * self.b.transpose()),
            );
            let scale = h.norm().max(1.0);
            let mut freqs: Vec<f64> = crate::numerics::eig::eigenvalues(&h)
                .iter()
                .filter(|l| l.re.abs() <= 1e-8 * scale.max(l.norm()) && l.im >= 0.0)
                .map(|l| l.im)
                .collect();
            freqs.sort_by(f64::total_cmp);
            freqs.dedup_by(|a, b| (*a - *b).abs() <= 1e-10 * b.abs().max(1.0));
            if freqs.is_empty() {
                return Ok(Norm {
                    lower,
                    upper: gamma,
                    peak_frequency: peak,
                });
            }
            let mut candidates = freqs.clone();
            candidates.extend(freqs.windows(2).map(|w| 0.5 * (w[0] + w[1])));
            let mut improved = false;
            for w in candidates {
                let s = self.sigma_max(w);
                if s > lower {
                    lower = s;
                    peak = w;
                    improved = true;
                }
            }
            if !improved {
                // Imaginary eigenvalues without a larger singular value: rounding at the peak.
                return Ok(Norm {
                    lower,
                    upper: gamma,
                    peak_frequency: peak,
                });
            }
        }
        Err(NormError::NoConvergence(100))
    }

    /// The controllability Gramian `P`, `AP + PAᵀ + BBᵀ = 0` (the state covariance under unit
    /// white noise), by Bartels–Stewart ([`crate::numerics::riccati::lyapunov`]): exact and independent
    /// of any LMI bound.
    fn controllability_gramian(&self) -> Result<DMatrix<f64>, NormError> {
        require_stable(self)?;
        if self.d.amax() != 0.0 {
            return Err(NormError::Feedthrough(self.d.norm()));
        }
        let abscissa = self.spectral_abscissa();
        crate::numerics::riccati::lyapunov(&self.a, &(&self.b * self.b.transpose()))
            .map_err(|_| NormError::Unstable(abscissa))
    }

    /// The H2 norm `√tr(C P Cᵀ)`, `P` the controllability Gramian.
    fn h2_norm(&self) -> Result<f64, NormError> {
        let p = self.controllability_gramian()?;
        Ok((&self.c * p * self.c.transpose()).trace().max(0.0).sqrt())
    }

    /// The energy-to-peak gain of each output, `sup { max_t |zᵢ(t)| : ‖w‖₂ ≤ 1 } = √(C P Cᵀ)ᵢᵢ`
    /// (exact for one output: by Cauchy–Schwarz on `zᵢ(t) = ∫ cᵢ e^{A(t−s)} B w(s) ds`, attained
    /// by the time-reversed impulse response; Wilson, IEEE TAC 34(1), 1989).
    fn energy_to_peak(&self) -> Result<Vec<f64>, NormError> {
        let p = self.controllability_gramian()?;
        let cpc = &self.c * p * self.c.transpose();
        Ok((0..self.c.nrows())
            .map(|i| cpc[(i, i)].max(0.0).sqrt())
            .collect())
    }
}

/// `Ok` when asymptotically stable (a NaN abscissa is not).
fn require_stable(sys: &Lti) -> Result<(), NormError> {
    let abscissa = sys.spectral_abscissa();
    if abscissa < 0.0 {
        Ok(())
    } else {
        Err(NormError::Unstable(abscissa))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn m(r: usize, c: usize, v: &[f64]) -> DMatrix<f64> {
        DMatrix::from_row_slice(r, c, v)
    }

    #[test]
    fn energy_to_peak_of_a_lag_matches_its_closed_form_and_an_attaining_input() {
        // 3/(s + 2): P = 1/4, gain 3/2; the input w(s) = e^{−2(t−s)} on [0, t] (normalised)
        // attains it as t → ∞ (here t = 20: e^{−80} away).
        let g = Lti::new(
            m(1, 1, &[-2.0]),
            m(1, 1, &[1.0]),
            m(2, 1, &[3.0, -1.0]),
            m(2, 1, &[0.0, 0.0]),
        );
        let peak = g.energy_to_peak().unwrap();
        assert!(
            (peak[0] - 1.5).abs() < 1e-12 && (peak[1] - 0.5).abs() < 1e-12,
            "{peak:?}"
        );
        let (t, steps) = (20.0, 200_000);
        let h = t / steps as f64;
        let (mut z, mut energy) = (0.0, 0.0);
        for k in 0..steps {
            let s = (k as f64 + 0.5) * h;
            let w = (-2.0 * (t - s)).exp();
            z += 3.0 * (-2.0 * (t - s)).exp() * w * h;
            energy += w * w * h;
        }
        assert!(
            (z / energy.sqrt() - 1.5).abs() < 1e-6,
            "{}",
            z / energy.sqrt()
        );
        assert!(matches!(
            Lti::new(
                m(1, 1, &[-2.0]),
                m(1, 1, &[1.0]),
                m(1, 1, &[1.0]),
                m(1, 1, &[0.1])
            )
            .energy_to_peak(),
            Err(NormError::Feedthrough(_))
        ));
    }

    #[test]
    fn first_order_lag_peaks_at_dc() {
        // 3/(s + 2): ‖G‖∞ = 1.5 at ω = 0.
        let g = Lti::new(
            m(1, 1, &[-2.0]),
            m(1, 1, &[1.0]),
            m(1, 1, &[3.0]),
            m(1, 1, &[0.0]),
        );
        let n = g.hinf_norm(1e-10).unwrap();
        assert!((n.lower - 1.5).abs() < 1e-12 && n.upper >= 1.5 && n.upper < 1.5 * (1.0 + 3e-10));
        assert_eq!(n.peak_frequency, 0.0);
    }

    #[test]
    fn lightly_damped_resonance_matches_the_closed_form() {
        // ωn²/(s² + 2ζωn s + ωn²): peak 1/(2ζ√(1−ζ²)) at ωn√(1−2ζ²).
        for (zeta, wn) in [(0.1, 3.0), (0.02, 50.0), (0.5, 1.0)] {
            let g = Lti::new(
                m(2, 2, &[0.0, 1.0, -wn * wn, -2.0 * zeta * wn]),
                m(2, 1, &[0.0, wn * wn]),
                m(1, 2, &[1.0, 0.0]),
                m(1, 1, &[0.0]),
            );
            let exact = 1.0 / (2.0 * zeta * (1.0 - zeta * zeta).sqrt());
            let n = g.hinf_norm(1e-9).unwrap();
            assert!(
                n.lower <= exact * (1.0 + 1e-12) && n.upper >= exact * (1.0 - 1e-12),
                "ζ = {zeta}: [{}, {}] vs {exact}",
                n.lower,
                n.upper
            );
            assert!((n.lower - exact).abs() < 1e-8 * exact);
            assert!((n.peak_frequency - wn * (1.0 - 2.0 * zeta * zeta).sqrt()).abs() < 1e-3 * wn);
        }
    }

    #[test]
    fn mimo_with_feedthrough_agrees_with_a_dense_frequency_sweep() {
        let a = m(
            4,
            4,
            &[
                -0.5, 4.0, 0.0, 0.3, -4.0, -0.5, 0.2, 0.0, 0.0, 0.0, -0.05, 9.0, 0.1, 0.0, -9.0,
                -0.05,
            ],
        );
        let b = m(4, 2, &[1.0, 0.0, 0.0, 1.0, 0.5, 0.2, 0.0, -1.0]);
        let c = m(
            3,
            4,
            &[1.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.5, 0.3, 0.0, 0.0, 1.0],
        );
        let d = m(3, 2, &[0.2, 0.0, 0.0, 0.1, 0.0, 0.0]);
        let g = Lti::new(a, b, c, d);
        let n = g.hinf_norm(1e-10).unwrap();
        let sweep = (0..200_000)
            .map(|k| 10f64.powf(-2.0 + 4.0 * k as f64 / 200_000.0))
            .map(|w| g.sigma_max(w))
            .fold(0.0, f64::max);
        assert!(
            sweep <= n.upper,
            "sweep {sweep} above the certified upper bound {}",
            n.upper
        );
        assert!(
            sweep > n.lower * (1.0 - 1e-4),
            "sweep {sweep} far below {}",
            n.lower
        );
    }

    #[test]
    fn unstable_systems_are_refused() {
        let g = Lti::new(
            m(1, 1, &[0.1]),
            m(1, 1, &[1.0]),
            m(1, 1, &[1.0]),
            m(1, 1, &[0.0]),
        );
        assert!(matches!(g.hinf_norm(1e-9), Err(NormError::Unstable(_))));
        assert!(matches!(g.h2_norm(), Err(NormError::Unstable(_))));
    }

    #[test]
    fn h2_norms_match_the_closed_forms() {
        // 3/(s + 2): ‖G‖₂² = 9/(2·2).
        let lag = Lti::new(
            m(1, 1, &[-2.0]),
            m(1, 1, &[1.0]),
            m(1, 1, &[3.0]),
            m(1, 1, &[0.0]),
        );
        assert!((lag.h2_norm().unwrap() - (9.0f64 / 4.0).sqrt()).abs() < 1e-12);
        // ωn²/(s² + 2ζωn s + ωn²): ‖G‖₂² = ωn/(4ζ).
        for (zeta, wn) in [(0.1, 3.0), (0.02, 50.0), (0.7, 1.0)] {
            let g = Lti::new(
                m(2, 2, &[0.0, 1.0, -wn * wn, -2.0 * zeta * wn]),
                m(2, 1, &[0.0, wn * wn]),
                m(1, 2, &[1.0, 0.0]),
                m(1, 1, &[0.0]),
            );
            let exact = (wn / (4.0 * zeta)).sqrt();
            assert!(
                (g.h2_norm().unwrap() - exact).abs() < 1e-9 * exact,
                "ζ = {zeta}"
            );
            // Two outputs: the squares add.
            let two = Lti::new(
                g.a.clone(),
                g.b.clone(),
                m(2, 2, &[1.0, 0.0, 2.0, 0.0]),
                m(2, 1, &[0.0, 0.0]),
            );
            assert!((two.h2_norm().unwrap() - exact * 5f64.sqrt()).abs() < 1e-9 * exact);
            assert_eq!(
                two.select_outputs(&[1]).h2_norm().unwrap(),
                g.h2_norm().unwrap() * 2.0
            );
        }
        let with_d = Lti::new(
            m(1, 1, &[-2.0]),
            m(1, 1, &[1.0]),
            m(1, 1, &[3.0]),
            m(1, 1, &[0.5]),
        );
        assert!(matches!(with_d.h2_norm(), Err(NormError::Feedthrough(_))));
    }
}
