//! Stop recovery: a controller that sees the car as if its seat had no end stops.
//!
//! A state feedback isolates the seat by cancelling its spring, so its loop is stable only up
//! to a seat spring of about 26 kN/m; with the seat's end stop engaged (100 kN/m more) it grows
//! (`engaged_stops` in its certificate, `docs/comfort-designs.md`). The stop's force acts on
//! the car as the seat actuator does (tested in `vehicle::contact`), and the plant outputs it
//! (`stop_force_seat`, a function of the seat stroke the controller reads anyway). The
//! recovering controller runs a model of the car driven by that force alone,
//! `η̇ = A η + b f`, and reads its inputs less what the model says the stop did to them,
//! `y − C_y η − d f`. Then `x − η` is the car without its stop under the loop as designed, and
//! `η` is the passive car's response to the stop's force: with the stop engaged the loop is the
//! designed one beside the passive car with its stop, whose springs and dampers dissipate, so
//! stable whatever the stop's stiffness. It is model-recovery anti-windup (thesis Th. 5.3) with
//! the stop's force as the dead zone and no gain on `η`: the stop acts as it would on the
//! passive car, and the controller does not fight it. Off the stops `f = 0`, `η` stays 0 and
//! the law is the one it extends, so every prediction off the stops is that law's.

use crate::comfort::controllers::Reconstruction;
use crate::comfort::designs::input_rows;
use crate::predict::continuous::ControlLaw;
use linsys::Lti;
use nalgebra::{DMatrix, DVector};
use vehicle::model::{StateSpace, ACTUATORS, N_STATES};
use vehicle::VehicleParams;

/// The plant output a recovering controller reads: the seat's end stops' force.
pub const STOP_FORCE: &str = "stop_force_seat";

/// `law` reading the seat's stop force too, and recovering from it on the model of the car `p`
/// (the module's text). Refused for a law without a state-space realisation (a predictor's) or
/// that reads the stop's force already.
pub fn stop_recovery(p: &VehicleParams, law: &ControlLaw) -> Result<ControlLaw, String> {
    if law.predictor.is_some() {
        return Err("stop recovery extends a linear law; a predictor's is not one".into());
    }
    if law.inputs.iter().any(|i| i == STOP_FORCE) {
        return Err(format!("the law reads {STOP_FORCE} already"));
    }
    let StopModel { ss, c_y, b, d } = StopModel::new(p, &law.inputs)?;
    let k = &law.lti;
    let (nk, n, ny) = (k.a.nrows(), N_STATES, law.inputs.len());
    let nu = k.c.nrows();
    let (b_k_d, d_k_d) = (&k.b * &d, &k.d * &d);
    let mut a = DMatrix::zeros(nk + n, nk + n);
    a.view_mut((0, 0), (nk, nk)).copy_from(&k.a);
    a.view_mut((0, nk), (nk, n)).copy_from(&(-&k.b * &c_y));
    a.view_mut((nk, nk), (n, n)).copy_from(&ss.a);
    let mut bm = DMatrix::zeros(nk + n, ny + 1);
    bm.view_mut((0, 0), (nk, ny)).copy_from(&k.b);
    bm.view_mut((0, ny), (nk, 1)).copy_from(&(-b_k_d));
    bm.view_mut((nk, ny), (n, 1)).copy_from(&b);
    let mut c = DMatrix::zeros(nu, nk + n);
    c.view_mut((0, 0), (nu, nk)).copy_from(&k.c);
    c.view_mut((0, nk), (nu, n)).copy_from(&(-&k.d * &c_y));
    let mut dm = DMatrix::zeros(nu, ny + 1);
    dm.view_mut((0, 0), (nu, ny)).copy_from(&k.d);
    dm.view_mut((0, ny), (nu, 1)).copy_from(&(-d_k_d));
    let mut inputs = law.inputs.clone();
    inputs.push(STOP_FORCE.into());
    Ok(ControlLaw {
        lti: Lti::new(a, bm, c, dm),
        inputs,
        predictor: None,
        accommodation: law.accommodation,
    })
}

/// What a recovery runs and reads its inputs through: the nominal car, the seat actuator's
/// column of `B_u` and of the inputs' feedthrough `D_y` (as which the stop's force acts), and
/// the inputs' rows `C_y`.
struct StopModel {
    ss: StateSpace,
    c_y: DMatrix<f64>,
    b: DVector<f64>,
    d: DVector<f64>,
}

impl StopModel {
    fn new(p: &VehicleParams, inputs: &[String]) -> Result<Self, String> {
        let seat = ACTUATORS
            .iter()
            .position(|a| *a == "seat")
            .expect("a seat actuator");
        let ss = StateSpace::new(p);
        let (c_y, d_y) = input_rows(p, inputs)?;
        let (b, d) = (
            ss.b_u.column(seat).into_owned(),
            d_y.column(seat).into_owned(),
        );
        Ok(StopModel { ss, c_y, b, d })
    }
}

/// A predictor's [`Reconstruction`] (of a law reading `inputs`) recovering from the seat's stops
/// as [`stop_recovery`] does a linear law's: it reads the stop's force `f` after `inputs`, runs
/// `η̇ = A η + b f` among its own states and knows the design state from `y − C_y η − d f`, so
/// it predicts the car without its stop. Its realisation at zero delay is [`stop_recovery`] of
/// the plain one's.
pub fn recovering_reconstruction(
    p: &VehicleParams,
    r: &Reconstruction,
    inputs: &[String],
) -> Result<Reconstruction, String> {
    let StopModel { ss, c_y, b, d } = StopModel::new(p, inputs)?;
    let (n, ny, nxi, m) = (r.s_y.nrows(), r.s_y.ncols(), r.a_xi.nrows(), N_STATES);
    if ny != inputs.len() {
        return Err(format!(
            "the reconstruction reads {ny} inputs, the law {}",
            inputs.len()
        ));
    }
    let mut s_y = DMatrix::zeros(n, ny + 1);
    s_y.view_mut((0, 0), (n, ny)).copy_from(&r.s_y);
    s_y.view_mut((0, ny), (n, 1)).copy_from(&(-&r.s_y * &d));
    let mut s_xi = DMatrix::zeros(n, nxi + m);
    s_xi.view_mut((0, 0), (n, nxi)).copy_from(&r.s_xi);
    s_xi.view_mut((0, nxi), (n, m)).copy_from(&(-&r.s_y * &c_y));
    let mut a_xi = DMatrix::zeros(nxi + m, nxi + m);
    a_xi.view_mut((0, 0), (nxi, nxi)).copy_from(&r.a_xi);
    a_xi.view_mut((0, nxi), (nxi, m))
        .copy_from(&(-&r.b_xi * &c_y));
    a_xi.view_mut((nxi, nxi), (m, m)).copy_from(&ss.a);
    let mut b_xi = DMatrix::zeros(nxi + m, ny + 1);
    b_xi.view_mut((0, 0), (nxi, ny)).copy_from(&r.b_xi);
    b_xi.view_mut((0, ny), (nxi, 1)).copy_from(&(-&r.b_xi * &d));
    b_xi.view_mut((nxi, ny), (m, 1)).copy_from(&b);
    Ok(Reconstruction {
        s_y,
        s_xi,
        a_xi,
        b_xi,
        b_xiu: r.b_xiu.clone().insert_rows(nxi, m, 0.0),
        d_yu: r.d_yu.clone().insert_row(ny, 0.0),
    })
}

/// The certificate's note of a recovering law.
pub fn note() -> String {
    format!(
        "With stop recovery: it reads the seat's end-stop force ({STOP_FORCE}) and runs the \
         nominal car driven by it alone, eta' = A eta + b f, reading its inputs less what that \
         model says the stop did to them (y - C_y eta - d f, b and d the seat actuator's, as \
         which the stop acts). The loop then stays the designed one beside the passive car with \
         its stop (engaged_stops); off the stops eta = 0 and the law is the one it extends."
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::numerics::eig::spectral_abscissa;

    /// A predictor's recovering reconstruction, realised at zero delay, is [`stop_recovery`] of
    /// the plain realisation (`hinf_sf`'s gain in its frame, on the state feedbacks' design):
    /// the same matrices, state for state.
    #[test]
    fn a_recovering_predictor_at_zero_delay_is_the_recovered_law() {
        use crate::comfort::controllers::{reconstruction, state_feedback_sensors};
        use crate::comfort::designs::{nominal_gain, Context};
        use crate::shipping::design::ComfortDesign;
        let d = ComfortDesign::from_json(include_str!("../../designs/comfort.json"))
            .unwrap()
            .for_state_feedback();
        let p = VehicleParams::default();
        let (g, sf) = nominal_gain(&Context {
            params: &p,
            design: &d,
        })
        .unwrap();
        let (framed, t) = g.with_frame();
        let k = &sf.k * t;
        let r = reconstruction(&framed);
        let names = state_feedback_sensors(&framed).names;
        let plain = ControlLaw {
            lti: r.realise(&k),
            inputs: names.clone(),
            predictor: None,
            accommodation: None,
        };
        let expected = stop_recovery(&p, &plain).unwrap().lti;
        let got = recovering_reconstruction(&p, &r, &names)
            .unwrap()
            .realise(&k);
        for (name, a, b) in [
            ("A", &got.a, &expected.a),
            ("B", &got.b, &expected.b),
            ("C", &got.c, &expected.c),
            ("D", &got.d, &expected.d),
        ] {
            assert_eq!(a.shape(), b.shape(), "{name}");
            let scale = b.amax().max(1.0);
            assert!(
                (a - b).amax() <= 1e-12 * scale,
                "{name}: {}",
                (a - b).amax()
            );
        }
        // A reconstruction for other inputs is refused.
        assert!(recovering_reconstruction(&p, &r, &names[1..]).is_err());
    }

    /// A static gain on the seat stroke and acceleration, recovered: its closed loop with the seat
    /// stop engaged (a stiffer seat spring, the stop's force read by its row) has the eigenvalues
    /// of the designed loop and of the passive car with the stop, and no others.
    #[test]
    fn the_recovered_loop_is_the_designed_one_beside_the_passive_car_with_its_stop() {
        let p = VehicleParams::default();
        let inputs: Vec<String> = ["stroke_seat", "a_seat"].map(String::from).to_vec();
        // A seat actuator that cancels 80 % of the seat's spring, with an a_seat feed-through
        // (which makes the recovery's `d` matter).
        let mut d = DMatrix::zeros(5, 2);
        d[(4, 0)] = 0.8 * p.k_seat;
        d[(4, 1)] = -20.0;
        let law = ControlLaw {
            lti: Lti::new(
                DMatrix::zeros(0, 0),
                DMatrix::zeros(0, 2),
                DMatrix::zeros(5, 0),
                d,
            ),
            inputs,
            predictor: None,
            accommodation: None,
        };
        let recovered = stop_recovery(&p, &law).unwrap();
        assert_eq!(recovered.lti.a.nrows(), N_STATES);
        let (k_stop, c_stop) = (100e3, 200.0);
        // The closed loop `[x; ξ]` of a law whose inputs read `C x + D u` and, for the stop's
        // force, `row · x`, on the car `q`.
        let close = |law: &ControlLaw, q: &VehicleParams, stop: Option<[f64; N_STATES]>| {
            let ss = StateSpace::new(q);
            let names: Vec<String> = law
                .inputs
                .iter()
                .filter(|n| *n != STOP_FORCE)
                .cloned()
                .collect();
            let (mut c_y, mut d_y) = input_rows(q, &names).unwrap();
            if law.inputs.len() > names.len() {
                let row = stop.unwrap_or([0.0; N_STATES]);
                c_y = c_y.insert_row(names.len(), 0.0);
                d_y = d_y.insert_row(names.len(), 0.0);
                for j in 0..N_STATES {
                    c_y[(names.len(), j)] = row[j];
                }
            }
            let k = &law.lti;
            let solve = (DMatrix::identity(5, 5) - &k.d * &d_y)
                .try_inverse()
                .unwrap();
            let (ux, uxi) = (&solve * &k.d * &c_y, &solve * &k.c);
            let (n, nk) = (N_STATES, k.a.nrows());
            let mut a = DMatrix::zeros(n + nk, n + nk);
            a.view_mut((0, 0), (n, n))
                .copy_from(&(&ss.a + &ss.b_u * &ux));
            a.view_mut((0, n), (n, nk)).copy_from(&(&ss.b_u * &uxi));
            a.view_mut((n, 0), (nk, n))
                .copy_from(&(&k.b * (&c_y + &d_y * &ux)));
            a.view_mut((n, n), (nk, nk))
                .copy_from(&(&k.a + &k.b * &d_y * &uxi));
            a
        };
        let stiff = VehicleParams {
            k_seat: p.k_seat + k_stop,
            c_seat: p.c_seat + c_stop,
            ..p
        };
        let row = vehicle::model::engaged_stop_row(&stiff, 4, k_stop, c_stop).c;
        let designed = spectral_abscissa(&close(&law, &p, None));
        assert!(designed < 0.0, "the designed loop is stable: {designed}");
        let with_stop = close(&recovered, &stiff, Some(row));
        let passive_with_stop = StateSpace::new(&stiff).a;
        let mut expected: Vec<f64> = close(&law, &p, None)
            .complex_eigenvalues()
            .iter()
            .chain(passive_with_stop.complex_eigenvalues().iter())
            .map(|e| e.re)
            .collect();
        let mut got: Vec<f64> = with_stop
            .complex_eigenvalues()
            .iter()
            .map(|e| e.re)
            .collect();
        expected.sort_by(f64::total_cmp);
        got.sort_by(f64::total_cmp);
        assert_eq!(got.len(), expected.len());
        for (g, e) in got.iter().zip(&expected) {
            assert!(
                (g - e).abs() < 1e-6 * (1.0 + e.abs()),
                "{got:?}\n{expected:?}"
            );
        }
        // Off the stop it is the law it extends: the stop's force reads zero.
        let off = spectral_abscissa(&close(&recovered, &p, None));
        assert!((off - designed.max(spectral_abscissa(&StateSpace::new(&p).a))).abs() < 1e-9);
    }

    #[test]
    fn a_predictor_or_a_law_that_reads_the_stop_already_is_refused() {
        let p = VehicleParams::default();
        let law = ControlLaw {
            lti: Lti::new(
                DMatrix::zeros(0, 0),
                DMatrix::zeros(0, 1),
                DMatrix::zeros(5, 0),
                DMatrix::zeros(5, 1),
            ),
            inputs: vec![STOP_FORCE.into()],
            predictor: None,
            accommodation: None,
        };
        let e = stop_recovery(&p, &law).unwrap_err();
        assert!(e.contains("already"), "{e}");
    }
}
