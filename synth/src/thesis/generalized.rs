//! The generalised plant of the H∞ designs, built from the `vehicle` crate's model (never a
//! second copy of the matrices), scaled so the LMIs are well conditioned.
//!
//! `ẋ = A x + B_w w + B_u ũ`, `z = C_z x + D_zw w + D_zu ũ`, `y = C_y x + D_yw w`, with
//! * `x` the plant's 16 states (m, rad, m/s, rad/s), then with the shaped road
//!   ([`RoadModel::Shaped`]) the four road heights; `ũ` the actuator forces in kN;
//! * `w` the road: heights over `road_height_scale` and velocities over `road_velocity_scale`
//!   (independent road), or the four road-velocity inputs of the road filter (shaped road);
//! * `z` = weighted seat heave, roll, pitch and body heave accelerations, the four strokes over
//!   `stroke_max` (a soft stroke limit), the four dynamic tyre loads over their static loads
//!   (road holding), then `ρ ũᵢ / ũ_max,i`;
//! * `y` = the output-feedback measurements: four suspension strokes, seat stroke, body heave
//!   velocity, roll rate, pitch rate (plant outputs `stroke_*`, `v_body`, `omega_*`);
//! * constraint outputs `c` = forces over their limits, strokes over the stroke limit and (shaped
//!   road) dynamic tyre loads over the static loads, without feed-through from `w` (an
//!   energy-to-peak bound needs none).

use crate::shipping::design::{Design, RoadModel};
use nalgebra::DMatrix;
use vehicle::model::{
    physical_outputs, OutputRow, StateSpace, N_ACTUATORS, N_ROAD, N_STATES, N_WHEELS,
};
use vehicle::VehicleParams;

/// Newtons per unit of `ũ`.
pub const FORCE_UNIT: f64 = 1000.0;

/// Names of the plant outputs the output-feedback designs measure, in the order of `y`.
pub const MEASUREMENTS: [&str; 8] = [
    "stroke_fl",
    "stroke_fr",
    "stroke_rl",
    "stroke_rr",
    "stroke_seat",
    "v_body",
    "omega_roll",
    "omega_pitch",
];

/// What a controller reads from the generalised plant: `y = C x + D w`, one name per row.
#[derive(Debug, Clone)]
pub struct Measurement {
    pub c: DMatrix<f64>,
    pub d: DMatrix<f64>,
    pub names: Vec<String>,
}

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
    /// The physical size of a unit of each road channel of `w` (independent road: `r = diag(·) w`;
    /// shaped road: the road-velocity input of each filter).
    pub road_scale: Vec<f64>,
    pub road_model: RoadModel,
}

/// How `w` becomes the plant's road input `r = [z_r; ż_r]` (8): `r = R_x x_r + R_w w`, with road
/// states `ẋ_r = A_r x_r + B_r w` ([`RoadModel`]).
struct RoadMap {
    r_x: DMatrix<f64>,
    r_w: DMatrix<f64>,
    a: DMatrix<f64>,
    b: DMatrix<f64>,
    /// The physical size of a unit of each `w` channel.
    scale: Vec<f64>,
}

impl RoadMap {
    fn new(d: &Design) -> Self {
        match d.road_model {
            RoadModel::Independent => {
                let scale: Vec<f64> = (0..N_ROAD)
                    .map(|k| {
                        if k < N_WHEELS {
                            d.road_height_scale
                        } else {
                            d.road_velocity_scale
                        }
                    })
                    .collect();
                let r_w = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(scale.clone()));
                RoadMap {
                    r_x: DMatrix::zeros(N_ROAD, 0),
                    r_w,
                    a: DMatrix::zeros(0, 0),
                    b: DMatrix::zeros(0, N_ROAD),
                    scale,
                }
            }
            RoadModel::Shaped { corner } => {
                let s = d.road_velocity_scale;
                let eye = DMatrix::<f64>::identity(N_WHEELS, N_WHEELS);
                // z_r = x_r, ż_r = −a x_r + s w.
                let mut r_x = DMatrix::zeros(N_ROAD, N_WHEELS);
                r_x.view_mut((0, 0), (N_WHEELS, N_WHEELS)).copy_from(&eye);
                r_x.view_mut((N_WHEELS, 0), (N_WHEELS, N_WHEELS))
                    .copy_from(&(&eye * -corner));
                let mut r_w = DMatrix::zeros(N_ROAD, N_WHEELS);
                r_w.view_mut((N_WHEELS, 0), (N_WHEELS, N_WHEELS))
                    .copy_from(&(&eye * s));
                RoadMap {
                    r_x,
                    r_w,
                    a: &eye * -corner,
                    b: &eye * s,
                    scale: vec![s; N_WHEELS],
                }
            }
        }
    }

    fn states(&self) -> usize {
        self.a.nrows()
    }
}

/// A physical output by name; a sensor (`sensor_x`) reads its physical output `x`.
pub(crate) fn row<'a>(rows: &'a [OutputRow], name: &str) -> &'a OutputRow {
    let physical = vehicle::sensors::physical_name(name);
    rows.iter()
        .find(|r| r.name == physical)
        .unwrap_or_else(|| panic!("vehicle has no output {name}"))
}

impl GeneralizedPlant {
    pub fn new(p: &VehicleParams, d: &Design) -> Self {
        Self::at_mass(p, d, p.m_s)
    }

    /// The plant of the car `p` with sprung mass `m_s`, weighted as the nominal car (the tyre
    /// loads are normalised by the *nominal* static loads): the weights are design choices and
    /// stay fixed, so the generalised plant is exactly affine in `1/m_s` like the model.
    pub fn at_mass(p: &VehicleParams, d: &Design, m_s: f64) -> Self {
        let nominal = *p;
        let static_load = vehicle::model::StaticEquilibrium::new(&nominal).tire_load;
        let p = &VehicleParams { m_s, ..nominal };
        let ss = StateSpace::new(p);
        let rows = physical_outputs(p);
        let road = RoadMap::new(d);
        let (n, nr) = (N_STATES + road.states(), road.states());
        // A plant output row (c, d_r, d_u) → its rows of [x; x_r], w and ũ.
        let output = |r: &OutputRow, weight: f64| {
            let d_r = DMatrix::from_row_slice(1, N_ROAD, &r.d_r) * weight;
            let mut c = DMatrix::zeros(1, n);
            c.view_mut((0, 0), (1, N_STATES))
                .copy_from(&(DMatrix::from_row_slice(1, N_STATES, &r.c) * weight));
            c.view_mut((0, N_STATES), (1, nr))
                .copy_from(&(&d_r * &road.r_x));
            (
                c,
                &d_r * &road.r_w,
                DMatrix::from_row_slice(1, N_ACTUATORS, &r.d_u) * (weight * FORCE_UNIT),
            )
        };
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
        let nw = road.r_w.ncols();
        let nz = perf.len() + N_ACTUATORS;
        let mut c_z = DMatrix::zeros(nz, n);
        let mut d_zw = DMatrix::zeros(nz, nw);
        let mut d_zu = DMatrix::zeros(nz, N_ACTUATORS);
        for (i, (name, weight)) in perf.iter().enumerate() {
            let (c, dw, du) = output(row(&rows, name), *weight);
            c_z.set_row(i, &c.row(0));
            d_zw.set_row(i, &dw.row(0));
            d_zu.set_row(i, &du.row(0));
        }
        for k in 0..N_ACTUATORS {
            d_zu[(perf.len() + k, k)] = d.control_penalty * FORCE_UNIT / limits[k];
        }
        let measured: Vec<_> = MEASUREMENTS
            .iter()
            .map(|name| output(row(&rows, name), 1.0))
            .collect();
        let c_y = DMatrix::from_rows(
            &measured
                .iter()
                .map(|m| m.0.row(0).into_owned())
                .collect::<Vec<_>>(),
        );
        let d_yw = DMatrix::from_rows(
            &measured
                .iter()
                .map(|m| m.1.row(0).into_owned())
                .collect::<Vec<_>>(),
        );

        let mut names = Vec::new();
        let mut c_c = DMatrix::zeros(0, n);
        let mut d_cu = DMatrix::zeros(0, N_ACTUATORS);
        if d.constraints {
            for (k, a) in vehicle::model::ACTUATORS.iter().enumerate() {
                names.push(format!("force_{a}"));
                let mut du = DMatrix::zeros(1, N_ACTUATORS);
                du[(0, k)] = FORCE_UNIT / limits[k];
                c_c = stack(&c_c, &DMatrix::zeros(1, n));
                d_cu = stack(&d_cu, &du);
            }
            for c in vehicle::model::CORNERS {
                let name = format!("stroke_{c}");
                let (row_c, _, row_u) = output(row(&rows, &name), 1.0 / d.stroke_max);
                c_c = stack(&c_c, &row_c);
                d_cu = stack(&d_cu, &row_u);
                names.push(name);
            }
            // Dynamic tyre load ≤ static load: its part without feed-through from `w` over the
            // static load less the damper force `c_t ṙ` the design bump can add directly
            // (`w` reaches the tyre load only through `c_t`, [`Design::design_bump_peak_velocity`]),
            // so that `|part| ≤ 1` gives `|tyre load| ≤ static load` on that bump.
            for (i, c) in vehicle::model::CORNERS.iter().enumerate() {
                let name = format!("tire_load_{c}");
                let direct = nominal.c_t * d.design_bump_peak_velocity();
                let (row_c, _, row_u) = output(row(&rows, &name), 1.0 / (static_load[i] - direct));
                c_c = stack(&c_c, &row_c);
                d_cu = stack(&d_cu, &row_u);
                names.push(name);
            }
        }
        let mut a = DMatrix::zeros(n, n);
        a.view_mut((0, 0), (N_STATES, N_STATES)).copy_from(&ss.a);
        a.view_mut((0, N_STATES), (N_STATES, nr))
            .copy_from(&(&ss.b_r * &road.r_x));
        a.view_mut((N_STATES, N_STATES), (nr, nr))
            .copy_from(&road.a);
        let mut b_w = DMatrix::zeros(n, nw);
        b_w.view_mut((0, 0), (N_STATES, nw))
            .copy_from(&(&ss.b_r * &road.r_w));
        b_w.view_mut((N_STATES, 0), (nr, nw)).copy_from(&road.b);
        let mut b_u = DMatrix::zeros(n, N_ACTUATORS);
        b_u.view_mut((0, 0), (N_STATES, N_ACTUATORS))
            .copy_from(&(&ss.b_u * FORCE_UNIT));
        GeneralizedPlant {
            a,
            b_w,
            b_u,
            c_z,
            d_zw,
            d_zu,
            c_y,
            d_yw,
            c_c,
            d_cu,
            constraint_names: names,
            road_scale: road.scale,
            road_model: d.road_model,
        }
    }

    /// What `w` is, for the certificate.
    pub fn w_description(&self) -> String {
        match self.road_model {
            RoadModel::Independent => "road heights / road_height_scale (4), then road velocities / road_velocity_scale (4)".into(),
            RoadModel::Shaped { corner } => format!("road-filter inputs (4): the road heights are the states x[17..20] with dz_r/dt = -{corner} z_r + road_scale w"),
        }
    }

    /// The closed loop's constraint outputs as a plant whose performance output they are
    /// (`C_z = C_c`, `D_zu = D_cu`, `D_zw = 0`), e.g. for [`crate::thesis::certificate::closed_loop`].
    pub fn constraint_plant(&self) -> GeneralizedPlant {
        GeneralizedPlant {
            c_z: self.c_c.clone(),
            d_zu: self.d_cu.clone(),
            d_zw: DMatrix::zeros(self.c_c.nrows(), self.b_w.ncols()),
            ..self.clone()
        }
    }

    /// Number of road states (4 with the shaped road, after the plant's 16; 0 otherwise).
    pub fn road_states(&self) -> usize {
        self.n() - N_STATES
    }

    /// What a state-feedback controller reads: the plant's states `x[1]…x[16]`, and with road
    /// states the tyre deflections `tire_defl_*` (`= z_u − z_r`, which give the road heights),
    /// as `y = C x̄` (no feed-through) with `C` square and invertible.
    pub fn state_measurement(&self) -> Measurement {
        let (n, nr) = (self.n(), self.road_states());
        let mut names: Vec<String> = (1..=N_STATES).map(|k| format!("x[{k}]")).collect();
        let mut c = DMatrix::identity(n, n);
        for i in 0..nr {
            names.push(format!("tire_defl_{}", vehicle::model::CORNERS[i]));
            c[(N_STATES + i, vehicle::model::coord::WHEEL[i])] = 1.0;
            c[(N_STATES + i, N_STATES + i)] = -1.0;
        }
        Measurement {
            c,
            d: DMatrix::zeros(n, self.b_w.ncols()),
            names,
        }
    }

    /// What the output-feedback designs read: [`MEASUREMENTS`], `y = C_y x + D_yw w`.
    pub fn output_measurement(&self) -> Measurement {
        Measurement {
            c: self.c_y.clone(),
            d: self.d_yw.clone(),
            names: MEASUREMENTS.iter().map(|s| s.to_string()).collect(),
        }
    }

    /// A state-feedback gain `u = K x̄` on the generalised plant's state as the controller
    /// matrix on [`Self::state_measurement`]'s inputs: `K C⁻¹`.
    pub fn gain_on_measurement(&self, k: &DMatrix<f64>) -> DMatrix<f64> {
        k * self
            .state_measurement()
            .c
            .try_inverse()
            .expect("the state measurement is invertible")
    }

    pub fn n(&self) -> usize {
        self.a.nrows()
    }

    /// The rows of `z` whose `D_zw` row is zero (all but the tyre loads, which carry the road
    /// height straight through): the ones with an H2 norm for white `w` under a strictly proper
    /// (or state-feedback) controller, which the mixed H2/H∞ designs minimise.
    pub fn h2_rows(&self) -> Vec<usize> {
        (0..self.c_z.nrows())
            .filter(|&i| self.d_zw.row(i).iter().all(|v| *v == 0.0))
            .collect()
    }

    /// `g` with an uncertainty channel `p = Δ q` as extra inputs and outputs: `p` enters as
    /// `H_x p` in `ẋ` and `H_z p` in `z`, `q = E_x x + E_u u` is appended to `z`; nothing of it
    /// reaches `y` (the uncertainty acts on the plant, not on the sensors).
    pub fn with_uncertainty_channel(
        &self,
        h_x: &DMatrix<f64>,
        h_z: &DMatrix<f64>,
        e_x: &DMatrix<f64>,
        e_u: &DMatrix<f64>,
    ) -> GeneralizedPlant {
        let (n, nw, nz, nu, ny) = (
            self.n(),
            self.b_w.ncols(),
            self.c_z.nrows(),
            self.b_u.ncols(),
            self.c_y.nrows(),
        );
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
        let (n, nw, ny, nz) = (
            self.n(),
            self.b_w.ncols(),
            self.c_y.nrows(),
            self.c_z.nrows(),
        );
        let mut g = self.clone();
        g.b_w = DMatrix::zeros(n, nw + ny);
        g.b_w.view_mut((0, 0), (n, nw)).copy_from(&self.b_w);
        g.d_zw = DMatrix::zeros(nz, nw + ny);
        g.d_zw.view_mut((0, 0), (nz, nw)).copy_from(&self.d_zw);
        g.d_yw = DMatrix::zeros(ny, nw + ny);
        g.d_yw.view_mut((0, 0), (ny, nw)).copy_from(&self.d_yw);
        for (k, name) in MEASUREMENTS.iter().enumerate() {
            g.d_yw[(k, nw + k)] = if name.starts_with("stroke") {
                d.noise_stroke
            } else {
                d.noise_rate
            };
        }
        g
    }
}

fn stack(top: &DMatrix<f64>, bottom: &DMatrix<f64>) -> DMatrix<f64> {
    let mut m = DMatrix::zeros(top.nrows() + bottom.nrows(), top.ncols());
    m.view_mut((0, 0), top.shape()).copy_from(top);
    m.view_mut((top.nrows(), 0), bottom.shape())
        .copy_from(bottom);
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    /// With road states, the plant driven by `w = (ż_r + a z_r)/s_v` from road state `z_r` is the
    /// independent-road plant driven by `z_r/s_h`, `ż_r/s_v`: same `ẋ`, `z` and `y` for any
    /// state, road and force (so the shaped plant adds the road filter and nothing else), and
    /// the road states follow `ż_r`. Its constraint rows are the physical outputs over their
    /// limits, and the state measurement reads the tyre deflections.
    #[test]
    fn the_shaped_road_plant_is_the_plant_driven_by_a_filtered_road() {
        let corner = 1.3;
        let base = Design::default();
        let shaped = Design {
            road_model: RoadModel::Shaped { corner },
            constraints: true,
            ..base.clone()
        };
        let p = VehicleParams::default();
        let (gi, gs) = (
            GeneralizedPlant::new(&p, &base),
            GeneralizedPlant::new(&p, &shaped),
        );
        assert_eq!(
            (gs.n(), gs.road_states(), gs.b_w.ncols(), gi.road_states()),
            (20, 4, 4, 0)
        );
        let x = DMatrix::from_fn(N_STATES, 1, |i, _| (0.7 * i as f64).sin() * 0.01);
        let r = DMatrix::from_fn(4, 1, |i, _| 0.02 * (i as f64 - 1.5));
        let rdot = DMatrix::from_fn(4, 1, |i, _| 0.3 * (i as f64 + 0.5).cos());
        let u = DMatrix::from_fn(N_ACTUATORS, 1, |i, _| 0.4 - 0.1 * i as f64);
        let w_shaped = (&rdot + &r * corner) / shaped.road_velocity_scale;
        let mut w_ind = DMatrix::zeros(8, 1);
        w_ind
            .view_mut((0, 0), (4, 1))
            .copy_from(&(&r / base.road_height_scale));
        w_ind
            .view_mut((4, 0), (4, 1))
            .copy_from(&(&rdot / base.road_velocity_scale));
        let mut xs = DMatrix::zeros(20, 1);
        xs.view_mut((0, 0), (N_STATES, 1)).copy_from(&x);
        xs.view_mut((N_STATES, 0), (4, 1)).copy_from(&r);
        let close = |a: DMatrix<f64>, b: DMatrix<f64>| {
            assert!((&a - &b).amax() <= 1e-9 * b.amax().max(1.0), "{a} vs {b}")
        };
        let xdot = &gs.a * &xs + &gs.b_w * &w_shaped + &gs.b_u * &u;
        close(
            xdot.rows(0, N_STATES).into_owned(),
            &gi.a * &x + &gi.b_w * &w_ind + &gi.b_u * &u,
        );
        close(xdot.rows(N_STATES, 4).into_owned(), rdot.clone());
        close(
            &gs.c_z * &xs + &gs.d_zw * &w_shaped + &gs.d_zu * &u,
            &gi.c_z * &x + &gi.d_zw * &w_ind + &gi.d_zu * &u,
        );
        close(
            &gs.c_y * &xs + &gs.d_yw * &w_shaped,
            &gi.c_y * &x + &gi.d_yw * &w_ind,
        );
        // Constraint rows: force, stroke, then the tyre load without its c_t·s_v·w part.
        let rows = physical_outputs(&p);
        let phys = |name: &str| {
            let o = row(&rows, name);
            let mut road = DMatrix::zeros(8, 1);
            road.view_mut((0, 0), (4, 1)).copy_from(&r);
            road.view_mut((4, 0), (4, 1)).copy_from(&rdot);
            (DMatrix::from_row_slice(1, N_STATES, &o.c) * &x
                + DMatrix::from_row_slice(1, 8, &o.d_r) * road
                + DMatrix::from_row_slice(1, 5, &o.d_u) * &u * FORCE_UNIT)[(0, 0)]
        };
        let c = &gs.c_c * &xs + &gs.d_cu * &u;
        assert_eq!(gs.constraint_names.len(), 13);
        assert!((c[(0, 0)] - u[(0, 0)] * FORCE_UNIT / shaped.u_max).abs() < 1e-12);
        assert!((c[(5, 0)] - phys("stroke_fl") / shaped.stroke_max).abs() < 1e-12);
        let static_load = vehicle::model::StaticEquilibrium::new(&p).tire_load;
        for i in 0..4 {
            let direct = p.c_t * w_shaped[(i, 0)] * shaped.road_velocity_scale;
            let limit = static_load[i] - p.c_t * shaped.design_bump_peak_velocity();
            assert!(
                (c[(9 + i, 0)] * limit - (phys(&gs.constraint_names[9 + i]) - direct)).abs()
                    < 1e-9 * static_load[i]
            );
        }
        // The controller's inputs give back the state.
        let Measurement {
            c: cm,
            d: dm,
            names,
        } = gs.state_measurement();
        assert_eq!(
            names[16..],
            [
                "tire_defl_fl",
                "tire_defl_fr",
                "tire_defl_rl",
                "tire_defl_rr"
            ]
        );
        assert_eq!(dm.amax(), 0.0);
        for i in 0..4 {
            assert!(((&cm * &xs)[(16 + i, 0)] - phys(&names[16 + i])).abs() < 1e-15);
        }
        let k = DMatrix::from_fn(N_ACTUATORS, 20, |i, j| (i * 20 + j) as f64);
        close(gs.gain_on_measurement(&k) * &cm, k);
    }

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
        assert_eq!(
            (aug.b_w.ncols(), aug.c_z.nrows(), aug.d_yw.ncols()),
            (nw + 2, nz + 2, nw + 2)
        );
        // p = δ q with q = E_x x + E_u u + (no w feed-through), and no p → q feed-through.
        assert_eq!(aug.d_zw.view((nz, 0), (2, nw + 2)).norm(), 0.0);
        let delta = 0.3;
        let a_closed = &aug.a + aug.b_w.columns(nw, 2) * delta * aug.c_z.rows(nz, 2);
        let b_closed = &aug.b_u + aug.b_w.columns(nw, 2) * delta * aug.d_zu.rows(nz, 2);
        let c_closed =
            aug.c_z.rows(0, nz) + aug.d_zw.view((0, nw), (nz, 2)) * delta * aug.c_z.rows(nz, 2);
        assert!((a_closed - (&g.a + &h_x * delta * &e_x)).norm() < 1e-12);
        assert!((b_closed - (&g.b_u + &h_x * delta * &e_u)).norm() < 1e-12);
        assert!((c_closed - (&g.c_z + &h_z * delta * &e_x)).norm() < 1e-12);
        assert_eq!(aug.d_yw.columns(nw, 2).norm(), 0.0);
    }
}
