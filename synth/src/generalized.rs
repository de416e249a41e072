//! The generalised plant of the H∞ designs, built from the `vehicle` crate's model (never a
//! second copy of the matrices), scaled so the LMIs are well conditioned.
//!
//! `ẋ = A x + B_w w + B_u ũ`, `z = C_z x + D_zw w + D_zu ũ`, `y = C_y x + D_yw w`, with
//! * `x` the plant's 16 states (m, rad, m/s, rad/s), `ũ` the actuator forces in kN;
//! * `w` the road: heights over `road_height_scale`, velocities over `road_velocity_scale`;
//! * `z` = weighted seat heave, roll, pitch and body heave accelerations, the four strokes over
//!   `stroke_max` (a soft stroke limit), the four dynamic tyre loads over their static loads
//!   (road holding), then `ρ ũᵢ / ũ_max,i`;
//! * `y` = the output-feedback measurements: four suspension strokes, seat stroke, body heave
//!   velocity, roll rate, pitch rate (plant outputs `stroke_*`, `v_body`, `omega_*`);
//! * constraint outputs `c` = forces over their limits and strokes over the stroke limit,
//!   without feed-through from `w` (an energy-to-peak bound needs none).

use crate::design::Design;
use nalgebra::DMatrix;
use vehicle::model::{physical_outputs, OutputRow, StateSpace, N_ACTUATORS, N_ROAD, N_STATES};
use vehicle::VehicleParams;

/// Newtons per unit of `ũ`.
pub const FORCE_UNIT: f64 = 1000.0;

/// Names of the plant outputs the output-feedback designs measure, in the order of `y`.
pub const MEASUREMENTS: [&str; 8] = ["stroke_fl", "stroke_fr", "stroke_rl", "stroke_rr", "stroke_seat", "v_body", "omega_roll", "omega_pitch"];

#[derive(Debug, Clone)]
pub struct GeneralizedPlant {
    pub a: DMatrix<f64>,
    pub b_w: DMatrix<f64>,
    pub b_u: DMatrix<f64>,
    pub c_z: DMatrix<f64>,
    pub d_zw: DMatrix<f64>,
    pub d_zu: DMatrix<f64>,
    pub c_y: DMatrix<f64>,
    pub d_yw: DMatrix<f64>,
    /// Constraint outputs (limit = 1 each).
    pub c_c: DMatrix<f64>,
    pub d_cu: DMatrix<f64>,
    pub constraint_names: Vec<String>,
    /// `diag` of the road scaling: `r = W_r w`.
    pub road_scale: Vec<f64>,
}

fn row<'a>(rows: &'a [OutputRow], name: &str) -> &'a OutputRow {
    rows.iter().find(|r| r.name == name).unwrap_or_else(|| panic!("vehicle has no output {name}"))
}

impl GeneralizedPlant {
    pub fn new(p: &VehicleParams, d: &Design) -> Self {
        Self::at_mass(p, d, p.m_s)
    }

    /// The plant of the car `p` with sprung mass `m_s`, weighted as the nominal car (the tyre
    /// loads are normalised by the *nominal* static loads): the weights are design choices and
    /// stay fixed, so the generalised plant is exactly affine in `1/m_s` like the model.
    pub fn at_mass(p: &VehicleParams, d: &Design, m_s: f64) -> Self {
        let static_load = vehicle::model::StaticEquilibrium::new(p).tire_load;
        let p = &VehicleParams { m_s, ..*p };
        let ss = StateSpace::new(p);
        let rows = physical_outputs(p);
        let road_scale: Vec<f64> = (0..N_ROAD).map(|k| if k < 4 { d.road_height_scale } else { d.road_velocity_scale }).collect();
        let w_r = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(road_scale.clone()));
        let limits = [d.u_max, d.u_max, d.u_max, d.u_max, d.u_max_seat];
        let perf = [
            ("a_seat", d.weight_a_seat),
            ("alpha_roll", d.weight_alpha_roll),
            ("alpha_pitch", d.weight_alpha_pitch),
            ("a_body", d.weight_a_body),
            ("stroke_fl", d.weight_stroke / d.stroke_max),
            ("stroke_fr", d.weight_stroke / d.stroke_max),
            ("stroke_rl", d.weight_stroke / d.stroke_max),
            ("stroke_rr", d.weight_stroke / d.stroke_max),
            ("tire_load_fl", d.weight_tyre_load / static_load[0]),
            ("tire_load_fr", d.weight_tyre_load / static_load[1]),
            ("tire_load_rl", d.weight_tyre_load / static_load[2]),
            ("tire_load_rr", d.weight_tyre_load / static_load[3]),
        ];
        let nz = perf.len() + N_ACTUATORS;
        let mut c_z = DMatrix::zeros(nz, N_STATES);
        let mut d_zw = DMatrix::zeros(nz, N_ROAD);
        let mut d_zu = DMatrix::zeros(nz, N_ACTUATORS);
        for (i, (name, weight)) in perf.iter().enumerate() {
            let r = row(&rows, name);
            for k in 0..N_STATES {
                c_z[(i, k)] = weight * r.c[k];
            }
            for k in 0..N_ROAD {
                d_zw[(i, k)] = weight * r.d_r[k] * road_scale[k];
            }
            for k in 0..N_ACTUATORS {
                d_zu[(i, k)] = weight * r.d_u[k] * FORCE_UNIT;
            }
        }
        for k in 0..N_ACTUATORS {
            d_zu[(perf.len() + k, k)] = d.control_penalty * FORCE_UNIT / limits[k];
        }

        let c_y = DMatrix::from_fn(MEASUREMENTS.len(), N_STATES, |i, k| row(&rows, MEASUREMENTS[i]).c[k]);
        let d_yw = DMatrix::from_fn(MEASUREMENTS.len(), N_ROAD, |i, k| row(&rows, MEASUREMENTS[i]).d_r[k] * road_scale[k]);

        let mut names = Vec::new();
        let mut c_c = DMatrix::zeros(0, N_STATES);
        let mut d_cu = DMatrix::zeros(0, N_ACTUATORS);
        if d.constraints {
            for (k, a) in vehicle::model::ACTUATORS.iter().enumerate() {
                names.push(format!("force_{a}"));
                let mut du = DMatrix::zeros(1, N_ACTUATORS);
                du[(0, k)] = FORCE_UNIT / limits[k];
                c_c = stack(&c_c, &DMatrix::zeros(1, N_STATES));
                d_cu = stack(&d_cu, &du);
            }
            for c in vehicle::model::CORNERS {
                let name = format!("stroke_{c}");
                let r = row(&rows, &name);
                c_c = stack(&c_c, &DMatrix::from_fn(1, N_STATES, |_, k| r.c[k] / d.stroke_max));
                d_cu = stack(&d_cu, &DMatrix::zeros(1, N_ACTUATORS));
                names.push(name);
            }
        }
        GeneralizedPlant {
            a: ss.a.clone(),
            b_w: &ss.b_r * &w_r,
            b_u: &ss.b_u * FORCE_UNIT,
            c_z,
            d_zw,
            d_zu,
            c_y,
            d_yw,
            c_c,
            d_cu,
            constraint_names: names,
            road_scale,
        }
    }

    pub fn n(&self) -> usize {
        self.a.nrows()
    }

    /// The rows of `z` whose `D_zw` row is zero (all but the tyre loads, which carry the road
    /// height straight through): the ones with an H2 norm for white `w` under a strictly proper
    /// (or state-feedback) controller, which the mixed H2/H∞ designs minimise.
    pub fn h2_rows(&self) -> Vec<usize> {
        (0..self.c_z.nrows()).filter(|&i| self.d_zw.row(i).iter().all(|v| *v == 0.0)).collect()
    }

    /// The matrices as the output-feedback LMI names them (`B₁ = B_w`, `C₁ = C_z`, …).
    pub fn of_plant(&self) -> crate::output_feedback::OfPlant<'_> {
        crate::output_feedback::OfPlant {
            a: &self.a,
            b1: &self.b_w,
            b2: &self.b_u,
            c1: &self.c_z,
            d11: &self.d_zw,
            d12: &self.d_zu,
            c2: &self.c_y,
            d21: &self.d_yw,
            unit_channels: 0,
        }
    }

    /// `g` with an uncertainty channel `p = Δ q` as extra inputs and outputs: `p` enters as
    /// `H_x p` in `ẋ` and `H_z p` in `z`, `q = E_x x + E_u u` is appended to `z`; nothing of it
    /// reaches `y` (the uncertainty acts on the plant, not on the sensors).
    pub fn with_uncertainty_channel(&self, h_x: &DMatrix<f64>, h_z: &DMatrix<f64>, e_x: &DMatrix<f64>, e_u: &DMatrix<f64>) -> GeneralizedPlant {
        let (n, nw, nz, nu, ny) = (self.n(), self.b_w.ncols(), self.c_z.nrows(), self.b_u.ncols(), self.c_y.nrows());
        let (np, nq) = (h_x.ncols(), e_x.nrows());
        let mut g = self.clone();
        g.b_w = DMatrix::zeros(n, nw + np);
        g.b_w.view_mut((0, 0), (n, nw)).copy_from(&self.b_w);
        g.b_w.view_mut((0, nw), (n, np)).copy_from(h_x);
        g.d_zw = DMatrix::zeros(nz + nq, nw + np);
        g.d_zw.view_mut((0, 0), (nz, nw)).copy_from(&self.d_zw);
        g.d_zw.view_mut((0, nw), (nz, np)).copy_from(h_z);
        g.c_z = DMatrix::zeros(nz + nq, n);
        g.c_z.view_mut((0, 0), (nz, n)).copy_from(&self.c_z);
        g.c_z.view_mut((nz, 0), (nq, n)).copy_from(e_x);
        g.d_zu = DMatrix::zeros(nz + nq, nu);
        g.d_zu.view_mut((0, 0), (nz, nu)).copy_from(&self.d_zu);
        g.d_zu.view_mut((nz, 0), (nq, nu)).copy_from(e_u);
        g.d_yw = DMatrix::zeros(ny, nw + np);
        g.d_yw.view_mut((0, 0), (ny, nw)).copy_from(&self.d_yw);
        g
    }

    /// The plant the output-feedback designs use: `w` extended by one sensor-noise channel per
    /// measurement (`y += noise_k · w_noise,k`), which enters nothing else. This regularises the
    /// otherwise singular filtering problem (`D_yw` has full row rank).
    pub fn with_sensor_noise(&self, d: &Design) -> GeneralizedPlant {
        let (n, nw, ny, nz) = (self.n(), self.b_w.ncols(), self.c_y.nrows(), self.c_z.nrows());
        let mut g = self.clone();
        g.b_w = DMatrix::zeros(n, nw + ny);
        g.b_w.view_mut((0, 0), (n, nw)).copy_from(&self.b_w);
        g.d_zw = DMatrix::zeros(nz, nw + ny);
        g.d_zw.view_mut((0, 0), (nz, nw)).copy_from(&self.d_zw);
        g.d_yw = DMatrix::zeros(ny, nw + ny);
        g.d_yw.view_mut((0, 0), (ny, nw)).copy_from(&self.d_yw);
        for (k, name) in MEASUREMENTS.iter().enumerate() {
            g.d_yw[(k, nw + k)] = if name.starts_with("stroke") { d.noise_stroke } else { d.noise_rate };
        }
        g
    }
}

fn stack(top: &DMatrix<f64>, bottom: &DMatrix<f64>) -> DMatrix<f64> {
    let mut m = DMatrix::zeros(top.nrows() + bottom.nrows(), top.ncols());
    m.view_mut((0, 0), top.shape()).copy_from(top);
    m.view_mut((top.nrows(), 0), bottom.shape()).copy_from(bottom);
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The channel, closed with a scalar `Δ = δ I`, is the plant with `[A B_u; C_z D_zu] +
    /// [H_x; H_z] δ [E_x E_u]` (the standard LFT identity, by hand for a static `Δ`).
    #[test]
    fn closing_the_uncertainty_channel_gives_the_perturbed_plant() {
        let d = Design::default();
        let g = GeneralizedPlant::new(&VehicleParams::default(), &d);
        let (n, nz, nu, nw) = (g.n(), g.c_z.nrows(), g.b_u.ncols(), g.b_w.ncols());
        let h_x = DMatrix::from_fn(n, 2, |i, j| ((i + 3 * j) as f64).sin());
        let h_z = DMatrix::from_fn(nz, 2, |i, j| ((2 * i + j) as f64).cos());
        let e_x = DMatrix::from_fn(2, n, |i, j| ((i * j) as f64 * 0.1).sin());
        let e_u = DMatrix::from_fn(2, nu, |i, j| (i + j) as f64 * 0.01);
        let aug = g.with_uncertainty_channel(&h_x, &h_z, &e_x, &e_u);
        assert_eq!((aug.b_w.ncols(), aug.c_z.nrows(), aug.d_yw.ncols()), (nw + 2, nz + 2, nw + 2));
        // p = δ q with q = E_x x + E_u u + (no w feed-through), and no p → q feed-through.
        assert_eq!(aug.d_zw.view((nz, 0), (2, nw + 2)).norm(), 0.0);
        let delta = 0.3;
        let a_closed = &aug.a + aug.b_w.columns(nw, 2) * delta * aug.c_z.rows(nz, 2);
        let b_closed = &aug.b_u + aug.b_w.columns(nw, 2) * delta * aug.d_zu.rows(nz, 2);
        let c_closed = aug.c_z.rows(0, nz) + aug.d_zw.view((0, nw), (nz, 2)) * delta * aug.c_z.rows(nz, 2);
        assert!((a_closed - (&g.a + &h_x * delta * &e_x)).norm() < 1e-12);
        assert!((b_closed - (&g.b_u + &h_x * delta * &e_u)).norm() < 1e-12);
        assert!((c_closed - (&g.c_z + &h_z * delta * &e_x)).norm() < 1e-12);
        assert_eq!(aug.d_yw.columns(nw, 2).norm(), 0.0);
    }
}
