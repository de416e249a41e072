//! `car_of`: the comfort design on the signals a production car gives it. It reads the plant's
//! `sensor_*` outputs (five height sensors, an accelerometer on the body above each wheel and
//! one on the seat, the roll and pitch gyros; their noise in the Kalman filter) and the
//! actuators' load cells (`f_*`), and is designed on a road with long waves and a seat stroke
//! limit ([`crate::shipping::design::CarDesign`]).
//!
//! **No steady force on a grade**, structurally: on a constant grade at constant speed the car
//! translates rigidly, so every sensor it reads (strokes, accelerations, rates, applied forces)
//! reads zero with zero force; with the observer's own dynamics nonsingular that is a steady
//! state of the closed loop, and a stable loop has one. (A design reading an absolute height or
//! velocity has no such state: it holds its actuators against the grade.) The certificate checks
//! the premises — every input's row free of absolute heights and velocities, the controller's
//! `A` nonsingular — and `tests/tests/real_car.rs` runs the grade.
//!
//! The observer is driven by the measured applied forces (as `ft_of`'s): its estimation error
//! does not depend on what happens between command and force — delay, saturation, a lost
//! actuator — which the accelerometers, whose readings carry the applied force at once, would
//! otherwise turn into estimation error.

use crate::comfort::controllers::{
    kalman_gain, noisy_sensors, observer_based, with_load_cells, ObserverInput,
};
use crate::comfort::designs::Uncertainty;
use crate::comfort::designs::{
    certify, delay_channel_norm, nominal_gain, ComfortDesignResult, ComfortError, Context,
};
use crate::comfort::guaranteed::{self, FORCE_REGULARISATION};
use crate::comfort::plant::{ComfortPlant, LONG_WAVE_ORDER};
use crate::numerics::hinf_norm::Lti;
use crate::numerics::interconnect::{Plant, Sensors};
use crate::predict::continuous::ControlLaw;
use crate::shipping::controller_file::Extensions;
use crate::shipping::design::{CarDesign, CarSensorNoise};
use nalgebra::DMatrix;
use vehicle::sensors::{Kind, PREFIX, SENSORS};

/// The sensors' names (`sensor_*`) and each one's noise density.
pub fn car_sensor_names(noise: &CarSensorNoise) -> Vec<(String, f64)> {
    SENSORS
        .iter()
        .map(|(name, kind)| {
            let density = match kind {
                Kind::Height => noise.height,
                Kind::Accelerometer => noise.acceleration,
                Kind::Gyro => noise.rate,
            };
            (format!("{PREFIX}{name}"), density)
        })
        .collect()
}

/// The car's sensors on `g` with their noise ([`noisy_sensors`]).
pub fn car_sensors(g: &ComfortPlant, noise: &CarSensorNoise) -> (Plant, Sensors) {
    noisy_sensors(g, &car_sensor_names(noise))
}

/// [`car_sensors`] followed by the load cells ([`with_load_cells`]), the inputs of the
/// force-driven observer.
pub fn car_sensors_and_load_cells(g: &ComfortPlant, noise: &CarSensorNoise) -> (Plant, Sensors) {
    with_load_cells(g, car_sensors(g, noise))
}

/// `k` with each of its `inputs` passed through the washout `s / (s + ω)` first: for each, a
/// state `ζ̇ = −ω ζ + y`, and `k` reads `y − ω ζ`. Its gain at zero frequency from those inputs
/// is then zero (a constant bias leaves no force); above `ω` it is `k`'s.
pub fn washout(k: &Lti, inputs: &[usize], omega: f64) -> Lti {
    let (n, m, p) = (k.a.nrows(), inputs.len(), k.b.ncols());
    let mut a = DMatrix::zeros(n + m, n + m);
    let mut b = DMatrix::zeros(n + m, p);
    let mut c = DMatrix::zeros(k.c.nrows(), n + m);
    a.view_mut((0, 0), (n, n)).copy_from(&k.a);
    b.view_mut((0, 0), (n, p)).copy_from(&k.b);
    c.view_mut((0, 0), (k.c.nrows(), n)).copy_from(&k.c);
    for (j, &i) in inputs.iter().enumerate() {
        a[(n + j, n + j)] = -omega;
        b[(n + j, i)] = 1.0;
        // The filtered input's −ω ζ through k's B and D.
        for r in 0..n {
            a[(r, n + j)] = -omega * k.b[(r, i)];
        }
        for r in 0..k.c.nrows() {
            c[(r, n + j)] = -omega * k.d[(r, i)];
        }
    }
    Lti::new(a, b, c, k.d.clone())
}

/// `car_of` on `ctx`, whose design is the comfort file's `for_car`
/// (`crate::shipping::design::ComfortDesign::for_car`): the guaranteed-cost gain that tolerates
/// the unmodelled delay, on the car's observer (`CarObserver`).
pub fn car_design(ctx: &Context) -> Result<ComfortDesignResult, ComfortError> {
    let variant = "car_of";
    let observer = CarObserver::new(ctx, variant)?;
    let (g, sf) = nominal_gain(ctx).map_err(|e| ctx.fail(variant, e))?;
    let note = format!(
        "the guaranteed-cost gain (the unmodelled delay of {} s, the force and stroke limits, \
         and a seat stroke limit of {} m)",
        ctx.design.unmodelled_delay, observer.car.seat_stroke_max,
    );
    observer.certify(ctx, variant, observer.law(&g, &sf.k), &note)
}

/// `lqg`, the classical baseline on `car_of`'s design and observer: the LQR gain of the same
/// comfort cost (the limits weighted in until each holds at the design's standard deviations),
/// with no robustness channel. Untuned, that loop does not tolerate the unmodelled delay every
/// design is certified for (its channel's norm is 3.15 at the cost's own force weight), so the
/// forces' weight is raised, as an engineer tunes an LQG's control weight for robustness, to the
/// least (within 1 %) whose loop passes the same small-gain test (bisection in its logarithm).
pub fn lqg_design(ctx: &Context) -> Result<ComfortDesignResult, ComfortError> {
    let variant = "lqg";
    let observer = CarObserver::new(ctx, variant)?;
    let g = ctx.plant();
    let d = ctx.design;
    // The law at a force weight, and whether its loop tolerates the delay.
    let at = |weight: f64| -> Result<(ControlLaw, bool), ComfortError> {
        let sf = guaranteed::state_feedback_weighted(&g, &[], d.limit_sigmas, weight)
            .map_err(|e| ctx.fail(variant, e))?;
        let law = observer.law(&g, &sf.k);
        let norm =
            delay_channel_norm(ctx, &law, &observer.wiring()).map_err(|e| ctx.fail(variant, e))?;
        Ok((law, norm < 1.0))
    };
    let (mut low, mut high) = (FORCE_REGULARISATION, FORCE_REGULARISATION);
    let (mut law, mut holds) = at(high)?;
    while !holds {
        (low, high) = (high, high * 4.0);
        if high > 1e6 * FORCE_REGULARISATION {
            return Err(ctx.fail(
                variant,
                "no force weight makes the LQG loop tolerate the unmodelled delay",
            ));
        }
        (law, holds) = at(high)?;
    }
    while high / low > 1.01 {
        let mid = (low * high).sqrt();
        match at(mid)? {
            (l, true) => (law, high) = (l, mid),
            (_, false) => low = mid,
        }
    }
    let note = format!(
        "the LQR gain of the comfort cost (the force and stroke limits and a seat stroke limit \
         of {} m weighted in until each holds at {} standard deviations; no robustness channel), \
         each force (in units of its limit) weighted {high:.3e}: the least weight, within 1 %, \
         whose loop tolerates the unmodelled delay of {} s",
        observer.car.seat_stroke_max, d.limit_sigmas, d.unmodelled_delay,
    );
    observer.certify(ctx, variant, law, &note)
}

/// The Kalman filter of a design on the sensors a car has: an estimate of the design state from
/// the `sensor_*` outputs (their noise densities from the design file's `car` block), driven by
/// the load cells' measured applied forces, each accelerometer washed out first.
struct CarObserver {
    car: CarDesign,
    sensors: Sensors,
    l: DMatrix<f64>,
}

impl CarObserver {
    fn new(ctx: &Context, variant: &str) -> Result<Self, ComfortError> {
        let car = ctx
            .design
            .car
            .ok_or_else(|| ctx.fail(variant, "the design file has no \"car\" block"))?;
        let (plant, sensors) = car_sensors(&ctx.plant(), &car.noise);
        let l = kalman_gain(&plant, &sensors, None).map_err(|e| ctx.fail(variant, e))?;
        Ok(CarObserver { car, sensors, l })
    }

    fn wiring(&self) -> impl Fn(&ComfortPlant) -> (Plant, Sensors) {
        let noise = self.car.noise;
        move |g: &ComfortPlant| car_sensors_and_load_cells(g, &noise)
    }

    /// The gain `k` on the design state of `g` (the design plant, or it with the delay weight's
    /// states, which the observer then carries too) on this observer.
    fn law(&self, g: &ComfortPlant, k: &DMatrix<f64>) -> ControlLaw {
        let observer = observer_based(g, k, &self.sensors, &self.l, ObserverInput::MeasuredForce);
        let accelerometers: Vec<usize> = SENSORS
            .iter()
            .enumerate()
            .filter(|(_, (_, kind))| *kind == Kind::Accelerometer)
            .map(|(k, _)| k)
            .collect();
        let omega = 2.0 * std::f64::consts::PI * self.car.accelerometer_washout_hz;
        ControlLaw {
            lti: washout(&observer, &accelerometers, omega),
            inputs: self.wiring()(g).1.names,
            accommodation: None,
            predictor: None,
        }
    }

    /// `law` certified as `variant`; `gain_note` says what its gain is.
    fn certify(
        &self,
        ctx: &Context,
        variant: &str,
        law: ControlLaw,
        gain_note: &str,
    ) -> Result<ComfortDesignResult, ComfortError> {
        let car = &self.car;
        let notes = vec![format!(
            "On the sensors a car has: {gain_note}, on a design road with long waves under \
             every wheel ({} m RMS, a lag chain of order {} at a wavelength of {} m), on a \
             Kalman estimate of the design state from {} (noise densities: heights {} \
             m/sqrt(Hz), accelerometers {} m/s2/sqrt(Hz), gyros {} rad/s/sqrt(Hz)), driven by \
             the load cells' measured applied forces; each accelerometer washed out at {} Hz \
             before the filter (no force from a bias).",
            car.long_waves.height_rms,
            LONG_WAVE_ORDER,
            car.long_waves.wavelength,
            law.inputs.join(", "),
            car.noise.height,
            car.noise.acceleration,
            car.noise.rate,
            car.accelerometer_washout_hz,
        )];
        let certificate = certify(ctx, variant, Uncertainty::None, &law, &self.wiring(), notes)?;
        Ok(ComfortDesignResult {
            law,
            extensions: Extensions::default(),
            certificate,
        })
    }
}
