//! Sprung-mass uncertainty `m_s ∈ [m₁, m₂]` (thesis ch. 4).
//!
//! Only the heave row of `M⁻¹` depends on `m_s`, so the model is affine in `1/m_s`. With the
//! barycentric coordinates in `1/m_s` (thesis eq. 4.9–4.10)
//! `α₁ = (1/m − 1/m₂)/(1/m₁ − 1/m₂)`, `α₂ = 1 − α₁`, the *vertex form* is
//! `A = α₁ A₁ + α₂ A₂` (thesis eq. 3.2 misprints this as `α₁A₁ + α₁A₁`), and the *COG form*
//! (thesis §4.4) is `A = A_cog + θ₁ A₁ + θ₂ A₂` with `θᵢ = αᵢ − αᵢ,cog`, `A_cog` the model at the
//! polytope's centre of gravity `α_cog = (½, ½)`. Both are exact at every mass in the range.

use crate::model::StateSpace;
use crate::params::VehicleParams;

/// The two-vertex polytope over the sprung mass.
#[derive(Debug, Clone)]
pub struct MassPolytope {
    /// Lightest sprung mass \[kg\].
    pub m_min: f64,
    /// Heaviest sprung mass \[kg\].
    pub m_max: f64,
    /// Model at `m_min` and at `m_max`.
    pub vertices: [StateSpace; 2],
}

impl MassPolytope {
    /// Default range of SPEC §1: 1200–1800 kg.
    pub const DEFAULT_RANGE: (f64, f64) = (1200.0, 1800.0);

    pub fn new(p: &VehicleParams, m_min: f64, m_max: f64) -> Self {
        assert!(
            0.0 < m_min && m_min < m_max,
            "mass range must satisfy 0 < m_min < m_max"
        );
        let at = |m| StateSpace::new(&VehicleParams { m_s: m, ..*p });
        MassPolytope {
            m_min,
            m_max,
            vertices: [at(m_min), at(m_max)],
        }
    }

    /// Barycentric coordinates `(α₁, α₂)` of mass `m` (thesis eq. 4.9–4.10 at any `m`).
    pub fn alphas(&self, m: f64) -> [f64; 2] {
        let a1 = (1.0 / m - 1.0 / self.m_max) / (1.0 / self.m_min - 1.0 / self.m_max);
        [a1, 1.0 - a1]
    }

    /// Vertex form `α₁ S₁ + α₂ S₂`.
    pub fn vertex_form(&self, m: f64) -> StateSpace {
        let [a1, a2] = self.alphas(m);
        StateSpace::combination(&[(a1, &self.vertices[0]), (a2, &self.vertices[1])])
    }

    /// Mass at the polytope's centre of gravity, `α = (½, ½)`: the harmonic mean of the vertices.
    pub fn cog_mass(&self) -> f64 {
        2.0 / (1.0 / self.m_min + 1.0 / self.m_max)
    }

    /// COG form data: `S_cog` and `θ(m)`.
    pub fn cog_form(&self) -> CogForm {
        CogForm {
            cog: self.vertex_form(self.cog_mass()),
            alpha_cog: [0.5, 0.5],
            polytope: self.clone(),
        }
    }
}

/// `S = S_cog + θ₁ S₁ + θ₂ S₂` (thesis §4.4).
#[derive(Debug, Clone)]
pub struct CogForm {
    pub cog: StateSpace,
    pub alpha_cog: [f64; 2],
    pub polytope: MassPolytope,
}

impl CogForm {
    /// `θᵢ = αᵢ(m) − αᵢ,cog`; `|θᵢ| ≤ ½` over the range and `θ₁ + θ₂ = 0`.
    pub fn theta(&self, m: f64) -> [f64; 2] {
        let a = self.polytope.alphas(m);
        [a[0] - self.alpha_cog[0], a[1] - self.alpha_cog[1]]
    }

    pub fn at(&self, m: f64) -> StateSpace {
        let [t1, t2] = self.theta(m);
        let v = &self.polytope.vertices;
        StateSpace::combination(&[(1.0, &self.cog), (t1, &v[0]), (t2, &v[1])])
    }
}
