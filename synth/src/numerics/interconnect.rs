//! The closed loop of a plant and a controller that reads sensors which may feel the applied
//! forces directly (accelerometers): what every comfort certificate evaluates.
//!
//! Plant `ẋ = A x + B_w w + B_u u_a`, sensors `y = C_y x + D_yw w + D_yu u_a`, controller
//! `ξ̇ = A_c ξ + B_c y`, `u = C_c ξ + D_c y`, and the applied force `u_a = u + f`, `f` an extra
//! input for what disturbs the actuators (an uncertainty channel's `p`). With
//! `M = (I − D_c D_yu)⁻¹` the command is `u = M (D_c C_y x + C_c ξ + D_c D_yw w + D_c D_yu f)`.

use crate::numerics::hinf_norm::Lti;
use nalgebra::DMatrix;

/// `ẋ = A x + B_w w + B_u u_a`.
#[derive(Debug, Clone)]
pub struct Plant {
    pub a: DMatrix<f64>,
    pub b_w: DMatrix<f64>,
    pub b_u: DMatrix<f64>,
}

/// `y = C x + D_w w + D_u u_a`, one name per row.
#[derive(Debug, Clone)]
pub struct Sensors {
    pub c: DMatrix<f64>,
    pub d_w: DMatrix<f64>,
    pub d_u: DMatrix<f64>,
    pub names: Vec<String>,
}

/// The closed loop in the state `[x; ξ]`, driven by `w` and `f`.
#[derive(Debug, Clone)]
pub struct ClosedLoop {
    pub a: DMatrix<f64>,
    pub b_w: DMatrix<f64>,
    pub b_f: DMatrix<f64>,
    /// The command `u = C_u [x; ξ] + D_uw w + D_uf f`.
    pub c_u: DMatrix<f64>,
    pub d_uw: DMatrix<f64>,
    pub d_uf: DMatrix<f64>,
    /// The plant's state count (the first rows of `[x; ξ]`).
    pub plant_order: usize,
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum InterconnectError {
    #[error("the loop is not well posed: I − D_c D_yu is singular")]
    IllPosed,
    #[error("the controller reads {controller} signals, the sensors give {sensors}")]
    Inputs { controller: usize, sensors: usize },
}

/// Close the loop of `plant`, `sensors` and the controller `k`.
pub fn close(plant: &Plant, sensors: &Sensors, k: &Lti) -> Result<ClosedLoop, InterconnectError> {
    let (n, nc, nu, nw) = (
        plant.a.nrows(),
        k.order(),
        plant.b_u.ncols(),
        plant.b_w.ncols(),
    );
    if k.b.ncols() != sensors.c.nrows() {
        return Err(InterconnectError::Inputs {
            controller: k.b.ncols(),
            sensors: sensors.c.nrows(),
        });
    }
    let m = (DMatrix::<f64>::identity(nu, nu) - &k.d * &sensors.d_u)
        .try_inverse()
        .ok_or(InterconnectError::IllPosed)?;
    // u = C_u [x; ξ] + D_uw w + D_uf f.
    let mut c_u = DMatrix::zeros(nu, n + nc);
    c_u.view_mut((0, 0), (nu, n))
        .copy_from(&(&m * &k.d * &sensors.c));
    c_u.view_mut((0, n), (nu, nc)).copy_from(&(&m * &k.c));
    let d_uw = &m * &k.d * &sensors.d_w;
    let d_uf = &m * &k.d * &sensors.d_u;
    // u_a = u + f; y = C x + D_w w + D_u u_a.
    let id = DMatrix::<f64>::identity(nu, nu);
    let mut a = DMatrix::zeros(n + nc, n + nc);
    a.view_mut((0, 0), (n, n)).copy_from(&plant.a);
    let mut bu_full = DMatrix::zeros(n + nc, nu);
    bu_full.view_mut((0, 0), (n, nu)).copy_from(&plant.b_u);
    bu_full
        .view_mut((n, 0), (nc, nu))
        .copy_from(&(&k.b * &sensors.d_u));
    a.view_mut((n, 0), (nc, n)).copy_from(&(&k.b * &sensors.c));
    a.view_mut((n, n), (nc, nc)).copy_from(&k.a);
    a += &bu_full * &c_u;
    let mut b_w = DMatrix::zeros(n + nc, nw);
    b_w.view_mut((0, 0), (n, nw)).copy_from(&plant.b_w);
    b_w.view_mut((n, 0), (nc, nw))
        .copy_from(&(&k.b * &sensors.d_w));
    b_w += &bu_full * &d_uw;
    let b_f = &bu_full * (&id + &d_uf);
    Ok(ClosedLoop {
        a,
        b_w,
        b_f,
        c_u,
        d_uw,
        d_uf,
        plant_order: n,
    })
}

impl ClosedLoop {
    /// A plant output `c x + d_w w + d_u u_a` as rows of the closed loop: `(C, D_w, D_f)`.
    pub fn output(
        &self,
        c: &DMatrix<f64>,
        d_w: &DMatrix<f64>,
        d_u: &DMatrix<f64>,
    ) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
        let (n, total) = (self.plant_order, self.a.nrows());
        let mut cc = DMatrix::zeros(c.nrows(), total);
        cc.view_mut((0, 0), (c.nrows(), n)).copy_from(c);
        cc += d_u * &self.c_u;
        let id = DMatrix::<f64>::identity(d_u.ncols(), d_u.ncols());
        (cc, d_w + d_u * &self.d_uw, d_u * (&id + &self.d_uf))
    }

    /// The closed loop from `w` to the plant outputs `(c, d_w, d_u)`.
    pub fn from_w(&self, c: &DMatrix<f64>, d_w: &DMatrix<f64>, d_u: &DMatrix<f64>) -> Lti {
        let (cc, dw, _) = self.output(c, d_w, d_u);
        Lti::new(self.a.clone(), self.b_w.clone(), cc, dw)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A scalar plant `ẋ = −x + w + u_a`, an accelerometer-like sensor `y = x + 0.5 u_a` and the
    /// static controller `u = −2 y`: by hand `u = −2x − (u + f)`, so `u = −x − 0.5 f` and
    /// `ẋ = −2x + w + 0.5 f`; with `u = +2 y` the loop `u = 2x + u + f` has no solution.
    #[test]
    fn feedthrough_of_the_applied_force_is_solved_exactly() {
        let m = |v: f64| DMatrix::from_element(1, 1, v);
        let plant = Plant {
            a: m(-1.0),
            b_w: m(1.0),
            b_u: m(1.0),
        };
        let sensors = Sensors {
            c: m(1.0),
            d_w: m(0.0),
            d_u: m(0.5),
            names: vec!["y".into()],
        };
        let cl = close(&plant, &sensors, &Lti::static_gain(m(-2.0))).unwrap();
        assert!((cl.a[(0, 0)] + 2.0).abs() < 1e-15);
        assert!((cl.b_f[(0, 0)] - 0.5).abs() < 1e-15);
        assert!((cl.c_u[(0, 0)] + 1.0).abs() < 1e-15 && (cl.d_uf[(0, 0)] + 0.5).abs() < 1e-15);
        let ill = close(&plant, &sensors, &Lti::static_gain(m(2.0)));
        assert_eq!(ill.unwrap_err(), InterconnectError::IllPosed);
    }
}
