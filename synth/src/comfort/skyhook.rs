//! `skyhook`: the classical baseline the H∞ designs are measured against, not an H∞ design.
//! Each corner actuator pushes against the absolute vertical velocity of the body above it and
//! the seat actuator against the seat's (Karnopp's skyhook damper), the velocities estimated
//! from the accelerometers a car has (`sensor_a_body_<corner>`, `sensor_a_seat`):
//!
//! `v̂ = s / (s + ω_c)² · a`, `u = −c v̂`
//!
//! an integrator high-passed twice at `ω_c` (the design file's `skyhook_highpass_hz`). Its gain
//! at `s = 0` is zero, so neither an accelerometer's bias nor a road's grade leaves a steady
//! force, and the absolute velocity it needs (which an accelerometer alone cannot give at low
//! frequency) is only asked above `ω_c`.
//!
//! The two dampings (one for the four corners, one for the seat) are tuned on the design road
//! by the same prediction as every certificate ([`crate::predict::continuous`]): the least
//! `W_k` seat RMS whose suspension and seat strokes are no larger than those of the design it
//! is compared with (`hinf_of`) or of the passive car ([`Travel`]), within the design's force
//! and stroke limits at `limit_sigmas`. The search is a logarithmic grid, refined around its
//! best point.

use crate::comfort::controllers::named_sensors;
use crate::comfort::designs::{certify, ComfortDesignResult, ComfortError, Context, Uncertainty};
use crate::comfort::plant::force_limits;
use crate::numerics::hinf_norm::Lti;
use crate::predict::continuous::{predict, Conditions, ControlLaw, Figures};
use crate::shipping::controller_file::Extensions;
use nalgebra::DMatrix;
use vehicle::model::{ACTUATORS, N_ACTUATORS};

/// The accelerometers it reads, in the order of the actuators they drive.
pub fn accelerometers() -> Vec<String> {
    ACTUATORS
        .iter()
        .map(|a| match *a {
            "seat" => format!("{}a_seat", vehicle::sensors::PREFIX),
            corner => format!("{}a_body_{corner}", vehicle::sensors::PREFIX),
        })
        .collect()
}

/// A skyhook controller: its dampings and the estimator's high-pass corner.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Skyhook {
    /// Each corner's damping to the sky [N·s/m].
    pub body: f64,
    /// The seat's [N·s/m].
    pub seat: f64,
    /// The velocity estimator's corner frequency \[Hz\].
    pub highpass_hz: f64,
}

impl Skyhook {
    /// The controller: two states per actuator, `ξ̇₁ = −ω ξ₁ + a`, `ξ̇₂ = ξ₁ − ω ξ₂`,
    /// `v̂ = ξ₁ − ω ξ₂` (`= s / (s + ω)² · a`), `u = −c v̂`.
    pub fn lti(&self) -> Lti {
        let w = 2.0 * std::f64::consts::PI * self.highpass_hz;
        let n = 2 * N_ACTUATORS;
        let (mut a, mut b, mut c) = (
            DMatrix::zeros(n, n),
            DMatrix::zeros(n, N_ACTUATORS),
            DMatrix::zeros(N_ACTUATORS, n),
        );
        for i in 0..N_ACTUATORS {
            let (x1, x2) = (2 * i, 2 * i + 1);
            a[(x1, x1)] = -w;
            a[(x2, x1)] = 1.0;
            a[(x2, x2)] = -w;
            b[(x1, i)] = 1.0;
            let damping = if i < 4 { self.body } else { self.seat };
            c[(i, x1)] = -damping;
            c[(i, x2)] = damping * w;
        }
        Lti::new(a, b, c, DMatrix::zeros(N_ACTUATORS, N_ACTUATORS))
    }

    pub fn law(&self) -> ControlLaw {
        ControlLaw {
            lti: self.lti(),
            inputs: accelerometers(),
            predictor: None,
            accommodation: None,
        }
    }
}

/// The travel a tuned skyhook may use: each stroke of the reference design or of the passive
/// car, whichever is larger (a skyhook damps the body, which the passive car's travel
/// allows; it cannot remove that travel, and is not asked to).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Travel {
    /// The largest corner's RMS suspension stroke \[m\].
    pub suspension: f64,
    /// The RMS seat stroke \[m\].
    pub seat: f64,
}

fn largest(s: &[f64; 4]) -> f64 {
    s.iter().copied().fold(0.0, f64::max)
}

impl Travel {
    pub fn of(reference: &Figures, passive: &Figures) -> Travel {
        Travel {
            suspension: largest(&reference.rms_stroke_m).max(largest(&passive.rms_stroke_m)),
            seat: reference.rms_seat_stroke_m.max(passive.rms_seat_stroke_m),
        }
    }

    /// Whether `f` uses no more than this travel and stays within the design's limits at
    /// `limit_sigmas` standard deviations.
    fn admits(&self, f: &Figures, ctx: &Context) -> bool {
        let d = ctx.design;
        let limits = force_limits(d);
        largest(&f.rms_stroke_m) <= self.suspension
            && f.rms_seat_stroke_m <= self.seat
            && d.limit_sigmas * largest(&f.rms_stroke_m) <= d.stroke_max
            && f.rms_force_n
                .iter()
                .zip(&limits)
                .all(|(f, l)| d.limit_sigmas * f <= *l)
    }
}

/// The dampings tried: a logarithmic grid from 100 to 12 800 N·s/m (ratio 2), then the best
/// point's neighbours at ratio 2^¼ twice.
const COARSE: [f64; 8] = [100.0, 200.0, 400.0, 800.0, 1600.0, 3200.0, 6400.0, 12800.0];

/// The tuned skyhook on the design road and its predicted figures: the least `W_k` seat among
/// the dampings `travel` admits (`Travel::admits`). An error if none is.
pub fn tune(ctx: &Context, travel: &Travel) -> Result<(Skyhook, Figures), String> {
    let d = ctx.design;
    let conditions = Conditions::nominal(*ctx.params);
    let evaluate = |body: f64, seat: f64| -> Option<(Skyhook, Figures)> {
        let s = Skyhook {
            body,
            seat,
            highpass_hz: d.skyhook_highpass_hz,
        };
        let f = predict(Some(&s.law()), conditions, &d.road).ok()?;
        travel.admits(&f, ctx).then_some((s, f))
    };
    let best = |candidates: Vec<(f64, f64)>| {
        use rayon::prelude::*;
        candidates
            .into_par_iter()
            .filter_map(|(b, s)| evaluate(b, s))
            .min_by(|x, y| x.1.wk_rms_seat_m_s2.total_cmp(&y.1.wk_rms_seat_m_s2))
    };
    let grid = |bodies: &[f64], seats: &[f64]| -> Vec<(f64, f64)> {
        bodies
            .iter()
            .flat_map(|b| seats.iter().map(move |s| (*b, *s)))
            .collect()
    };
    let mut found = best(grid(&COARSE, &COARSE)).ok_or_else(|| {
        format!(
            "no damping from {} to {} N·s/m keeps the strokes within {travel:?} and the \
             limits",
            COARSE[0],
            COARSE[COARSE.len() - 1]
        )
    })?;
    for ratio in [2f64.powf(0.5), 2f64.powf(0.25)] {
        let around = |c: f64| [c / ratio, c, c * ratio];
        let (s, _) = found;
        if let Some(better) = best(grid(&around(s.body), &around(s.seat))) {
            if better.1.wk_rms_seat_m_s2 < found.1.wk_rms_seat_m_s2 {
                found = better;
            }
        }
    }
    Ok(found)
}

/// `skyhook`, tuned to the travel of `reference` (the design it is compared with,
/// [`Travel::of`]) and certified like every design.
pub fn skyhook_design(
    ctx: &Context,
    reference: &ComfortDesignResult,
) -> Result<ComfortDesignResult, ComfortError> {
    let variant = "skyhook";
    let comfort = &reference.certificate.comfort;
    let travel = Travel::of(&comfort.predicted, &comfort.passive);
    let (tuned, figures) = tune(ctx, &travel).map_err(|reason| ComfortError::Synthesis {
        variant: variant.into(),
        reason,
    })?;
    let law = tuned.law();
    let notes = vec![format!(
        "Baseline, not an H-inf design: a skyhook damper of {:.0} N.s/m at each corner and {:.0} \
         N.s/m at the seat on the absolute velocities estimated from the accelerometers ({}), \
         each integrated and high-passed twice at {} Hz (s/(s+w)^2: no gain at zero frequency, \
         so no steady force from a grade or a bias). The dampings are the least predicted W_k \
         seat on the design road among those whose RMS strokes (largest corner {:.2} cm, seat \
         {:.2} cm) do not exceed those of the reference design {} or of the passive car, \
         whichever is larger ({:.2} cm, {:.2} cm), within the force and stroke limits at {} \
         standard deviations.",
        tuned.body,
        tuned.seat,
        law.inputs.join(", "),
        tuned.highpass_hz,
        100.0 * largest(&figures.rms_stroke_m),
        100.0 * figures.rms_seat_stroke_m,
        reference.certificate.variant,
        100.0 * travel.suspension,
        100.0 * travel.seat,
        ctx.design.limit_sigmas,
    )];
    let names = law.inputs.clone();
    let wiring = move |g: &crate::comfort::plant::ComfortPlant| named_sensors(g, names.clone());
    let certificate = certify(ctx, variant, Uncertainty::None, &law, &wiring, notes)?;
    Ok(ComfortDesignResult {
        law,
        extensions: Extensions::default(),
        certificate,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Complex;

    fn response(lti: &Lti, omega: f64) -> DMatrix<Complex<f64>> {
        let n = lti.a.nrows();
        let s = Complex::new(0.0, omega);
        let m = DMatrix::<Complex<f64>>::identity(n, n) * s - lti.a.map(|v| Complex::new(v, 0.0));
        let x = m.lu().solve(&lti.b.map(|v| Complex::new(v, 0.0))).unwrap();
        lti.c.map(|v| Complex::new(v, 0.0)) * x + lti.d.map(|v| Complex::new(v, 0.0))
    }

    #[test]
    fn it_is_a_damper_above_its_corner_and_has_no_gain_at_zero_frequency() {
        let s = Skyhook {
            body: 2000.0,
            seat: 1500.0,
            highpass_hz: 0.3,
        };
        let lti = s.lti();
        // At s = 0: C (−A)⁻¹ B + D, exactly zero (a grade or a bias leaves no steady force).
        let dc = &lti.c * lti.a.clone().try_inverse().unwrap() * &lti.b * -1.0 + &lti.d;
        assert!(dc.amax() < 1e-9, "{dc}");
        // Well above the corner, u = −c a / s: −c times the velocity of an acceleration.
        let omega = 2.0 * std::f64::consts::PI * 30.0;
        let h = response(&lti, omega);
        for (i, c) in [2000.0, 2000.0, 2000.0, 2000.0, 1500.0].iter().enumerate() {
            let expected = Complex::new(0.0, *c / omega); // −c / (jω)
            assert!(
                (h[(i, i)] - expected).norm() < 0.03 * expected.norm(),
                "{i}"
            );
            for j in (0..N_ACTUATORS).filter(|j| *j != i) {
                assert_eq!(h[(i, j)], Complex::new(0.0, 0.0));
            }
        }
        // At the corner the estimate is half the velocity, a quarter turn ahead of it.
        let w = 2.0 * std::f64::consts::PI * 0.3;
        let h = response(&lti, w)[(0, 0)] * Complex::new(0.0, w) / -2000.0;
        assert!((h - Complex::new(0.0, 0.5)).norm() < 1e-12, "{h}");
    }

    #[test]
    fn it_reads_the_accelerometers_a_car_has() {
        let names = accelerometers();
        assert_eq!(
            names,
            [
                "sensor_a_body_fl",
                "sensor_a_body_fr",
                "sensor_a_body_rl",
                "sensor_a_body_rr",
                "sensor_a_seat"
            ]
        );
        for n in &names {
            let physical = vehicle::sensors::physical_name(n);
            assert_ne!(physical, n.as_str());
            assert!(vehicle::sensors::SENSORS
                .iter()
                .any(|(s, _)| *s == physical));
        }
    }
}
