//! Robustness to the sprung mass `m_s ∈ [m_min, m_max]` (thesis ch. 4 and 6).
//!
//! Only the heave row of `M⁻¹` depends on `m_s`, and of the performance outputs only the body
//! heave acceleration, so the generalised plant (with the weights of the nominal car) is exactly
//! affine in `1/m_s`: every mass of the range is a convex combination of the two vertices
//! ([`vehicle::polytope`]). Two equivalent descriptions, two sufficient LMI conditions:
//! * *vertex*: the LMI at both vertices with one Lyapunov matrix — sufficient for the whole
//!   range because, for fixed decision variables, each LMI is affine in the plant data;
//! * *norm-bounded* (the thesis's COG form, §4.4 and Lemma 1): the plant at the polytope's
//!   centre of gravity plus `H δ E`, `|δ| ≤ 1`, with `H E` half the difference of the vertices.
//!
//! The certificate does not rely on either: it computes the closed-loop H∞ norm by Hamiltonian
//! bisection at every mass of a uniform grid ([`mass_grid_certificate`]).

use crate::numerics::hinf_norm::{Analysis, Controller};
use crate::shipping::design::Design;
use crate::thesis::certificate::{closed_loop, NORM_TOLERANCE};
use crate::thesis::generalized::{GeneralizedPlant, Measurement};
use crate::thesis::state_feedback::NormBounded;
use nalgebra::DMatrix;
use serde::Serialize;
use vehicle::VehicleParams;

/// The mass-uncertain generalised plant.
#[derive(Debug, Clone)]
pub struct MassUncertainty {
    pub m_min: f64,
    pub m_max: f64,
    /// Plants at `m_min` and `m_max`.
    pub vertices: [GeneralizedPlant; 2],
    /// Plant at the centre of gravity of the polytope (`1/m` halfway: the harmonic mean mass).
    pub center: GeneralizedPlant,
    /// `[A B_u; C_z D_zu](m) = centre + H δ E` with `δ = 1` at `m_min`, `δ = −1` at `m_max`.
    pub norm_bounded: NormBounded,
    params: VehicleParams,
    design: Design,
    sensor_noise: bool,
}

/// `[A B_u; C_z D_zu]` of a generalised plant.
fn system_matrix(g: &GeneralizedPlant) -> DMatrix<f64> {
    let (n, nu, nz) = (g.n(), g.b_u.ncols(), g.c_z.nrows());
    let mut s = DMatrix::zeros(n + nz, n + nu);
    s.view_mut((0, 0), (n, n)).copy_from(&g.a);
    s.view_mut((0, n), (n, nu)).copy_from(&g.b_u);
    s.view_mut((n, 0), (nz, n)).copy_from(&g.c_z);
    s.view_mut((n, n), (nz, nu)).copy_from(&g.d_zu);
    s
}

fn plant_at(p: &VehicleParams, d: &Design, sensor_noise: bool, m: f64) -> GeneralizedPlant {
    let g = GeneralizedPlant::at_mass(p, d, m);
    if sensor_noise {
        g.with_sensor_noise(d)
    } else {
        g
    }
}

impl MassUncertainty {
    pub fn new(p: &VehicleParams, d: &Design) -> Self {
        Self::build(p, d, false)
    }

    /// The same with the output-feedback sensor-noise channels in `w`.
    pub fn with_sensor_noise(&self) -> Self {
        Self::build(&self.params, &self.design, true)
    }

    fn build(p: &VehicleParams, d: &Design, sensor_noise: bool) -> Self {
        let at = |m: f64| plant_at(p, d, sensor_noise, m);
        let (m_min, m_max) = (d.mass_min, d.mass_max);
        let vertices = [at(m_min), at(m_max)];
        let center = at(2.0 / (1.0 / m_min + 1.0 / m_max));
        // Half the difference of the vertices, factored by its SVD into H E (rank 1 here: the
        // heave row of M⁻¹; the balanced split keeps H and E of the same size).
        let delta = (system_matrix(&vertices[0]) - system_matrix(&vertices[1])) * 0.5;
        let svd = delta.clone().svd(true, true);
        let (u, vt) = (svd.u.expect("requested"), svd.v_t.expect("requested"));
        let tol = 1e-12 * svd.singular_values.max();
        let keep: Vec<usize> = (0..svd.singular_values.len())
            .filter(|&i| svd.singular_values[i] > tol)
            .collect();
        let h = DMatrix::from_columns(
            &keep
                .iter()
                .map(|&i| u.column(i) * svd.singular_values[i].sqrt())
                .collect::<Vec<_>>(),
        );
        let e = DMatrix::from_rows(
            &keep
                .iter()
                .map(|&i| vt.row(i) * svd.singular_values[i].sqrt())
                .collect::<Vec<_>>(),
        );
        MassUncertainty {
            m_min,
            m_max,
            vertices,
            center,
            norm_bounded: NormBounded {
                h,
                e,
                diagonal: false,
            },
            params: *p,
            design: d.clone(),
            sensor_noise,
        }
    }

    /// The plant at mass `m` (exact, not interpolated).
    pub fn at(&self, m: f64) -> GeneralizedPlant {
        plant_at(&self.params, &self.design, self.sensor_noise, m)
    }

    /// The uniform check grid of the design file, endpoints included.
    pub fn grid(&self) -> Vec<f64> {
        let k = self.design.mass_grid_points;
        (0..k)
            .map(|i| self.m_min + (self.m_max - self.m_min) * i as f64 / (k - 1) as f64)
            .collect()
    }
}

/// Closed-loop H∞ norm and spectral abscissa at every mass of the grid.
#[derive(Debug, Clone, Serialize)]
pub struct MassGrid {
    pub masses: Vec<f64>,
    /// `None` where the closed loop is unstable.
    pub norms: Vec<Option<f64>>,
    pub spectral_abscissas: Vec<f64>,
    /// Worst norm over the grid (`None` if unstable anywhere) and where.
    pub worst_norm: Option<f64>,
    pub worst_mass: f64,
}

impl MassGrid {
    pub fn evaluate(unc: &MassUncertainty, meas: &Measurement, k: &Controller) -> Self {
        let masses = unc.grid();
        let mut norms = Vec::new();
        let mut abscissas = Vec::new();
        for &m in &masses {
            let cl = closed_loop(&unc.at(m), meas, k);
            abscissas.push(cl.spectral_abscissa());
            norms.push(cl.hinf_norm(1e-9).ok().map(|n| n.upper));
        }
        let stable = norms.iter().all(|n| n.is_some());
        let (worst_i, worst) = norms
            .iter()
            .enumerate()
            .map(|(i, n)| (i, n.unwrap_or(f64::INFINITY)))
            .fold((0, f64::NEG_INFINITY), |a, b| if b.1 > a.1 { b } else { a });
        MassGrid {
            worst_mass: masses[worst_i],
            masses,
            norms,
            spectral_abscissas: abscissas,
            worst_norm: stable.then_some(worst),
        }
    }

    /// Whether every mass of the grid is stable with a norm within the claimed γ.
    pub fn holds(&self, gamma: f64) -> bool {
        self.worst_norm
            .is_some_and(|w| w <= gamma * (1.0 + NORM_TOLERANCE))
    }
}

/// The robust certificate: stable with `‖T_zw‖∞ ≤ γ` at every mass of the grid, else an error.
pub fn mass_grid_certificate(
    variant: &str,
    unc: &MassUncertainty,
    meas: &Measurement,
    k: &Controller,
    gamma: f64,
) -> Result<MassGrid, crate::thesis::certificate::CertificateError> {
    let grid = MassGrid::evaluate(unc, meas, k);
    if grid.holds(gamma) {
        Ok(grid)
    } else {
        Err(crate::thesis::certificate::CertificateError::NotRobust {
            variant: variant.into(),
            mass: grid.worst_mass,
            norm: grid.worst_norm.unwrap_or(f64::INFINITY),
            gamma,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::thesis::certificate::CertificateError;
    use crate::thesis::state_feedback::{hinf_sf, hinf_sf_robust};

    #[test]
    fn both_robust_formulations_hold_over_the_grid_and_the_nominal_design_does_not() {
        let (p, d) = (VehicleParams::default(), Design::default());
        let unc = MassUncertainty::new(&p, &d);
        let meas = unc.center.state_measurement();
        let nominal = hinf_sf(&GeneralizedPlant::new(&p, &d), d.lmi_margin, None).unwrap();
        match mass_grid_certificate(
            "nominal",
            &unc,
            &meas,
            &Controller::static_gain(nominal.k),
            nominal.gamma,
        ) {
            Err(CertificateError::NotRobust {
                mass, norm, gamma, ..
            }) => assert!(mass == d.mass_min && norm > gamma, "{mass} {norm} {gamma}"),
            other => panic!("the nominal design's γ must not hold over the range: {other:?}"),
        }
        let vertex = hinf_sf_robust(
            &[&unc.vertices[0], &unc.vertices[1]],
            None,
            d.lmi_margin,
            None,
        )
        .unwrap();
        let nb =
            hinf_sf_robust(&[&unc.center], Some(&unc.norm_bounded), d.lmi_margin, None).unwrap();
        for sf in [&vertex, &nb] {
            let grid = mass_grid_certificate(
                "robust",
                &unc,
                &meas,
                &Controller::static_gain(sf.k.clone()),
                sf.gamma,
            )
            .unwrap();
            // Sound (checked above) and, with a rank-one uncertainty, not conservative.
            assert!(
                grid.worst_norm.unwrap() > 0.999 * sf.gamma,
                "worst {:?} vs γ {}",
                grid.worst_norm,
                sf.gamma
            );
        }
    }

    #[test]
    fn vertex_combination_and_norm_bounded_form_reproduce_the_plant_at_every_mass() {
        let d = Design::default();
        let unc = MassUncertainty::new(&VehicleParams::default(), &d);
        assert_eq!(
            unc.norm_bounded.h.ncols(),
            1,
            "the mass enters through one row of M⁻¹"
        );
        let he = &unc.norm_bounded.h * &unc.norm_bounded.e;
        for m in [1200.0, 1333.0, 1500.0, 1777.0, 1800.0] {
            let exact = system_matrix(&unc.at(m));
            // 1/m = α/m_min + (1 − α)/m_max, δ = 2α − 1.
            let alpha = (1.0 / m - 1.0 / unc.m_max) / (1.0 / unc.m_min - 1.0 / unc.m_max);
            let vertex = system_matrix(&unc.vertices[0]) * alpha
                + system_matrix(&unc.vertices[1]) * (1.0 - alpha);
            let nb = system_matrix(&unc.center) + &he * (2.0 * alpha - 1.0);
            let scale = exact.amax();
            assert!(
                (&vertex - &exact).amax() < 1e-12 * scale,
                "vertex form at {m}"
            );
            assert!(
                (&nb - &exact).amax() < 1e-12 * scale,
                "norm-bounded form at {m}"
            );
            assert_eq!(unc.at(m).b_w, unc.center.b_w);
        }
    }
}
