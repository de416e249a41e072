//! `delay_sf`: `hinf_sf`'s gain behind a predictor of the design state over the actuators'
//! known delay `θ` (thesis Prop. 7.1's aim, a controller for an input delay; its LMI's proof is
//! unfinished, and a fixed controller robust to every delay up to 20 ms pays for it at small
//! delays: measured, `hinf_sf` redesigned for a 20 ms unmodelled delay loses a factor five in
//! seat comfort at no delay).
//!
//! The controller knows `θ` (the FMU parameter `tau`, at most `delay_max`) and
//! commands `u(t) = K x̂(t + θ)`, `x̂(t + θ) = e^{Aθ} x(t) + ∫_{t−θ}^{t} e^{A(t−s)} B u(s) ds`: the
//! design state `θ` ahead, from what it reads now and the commands still in flight (Smith 1959;
//! Manitius & Olbrot, IEEE TAC 24(4), 1979, finite spectrum assignment; Artstein 1982). With the
//! delay it compensates, its closed loop has the roots of `A + B K` and of `A` — stable, as the
//! car and the design model's filters are — for every `θ`, so it is stable over the whole
//! interval `[0, delay_max]`; the road still acts during the last `θ` seconds, which no
//! controller can undo, so the comfort worsens with `θ` as the predicted model says exactly:
//! `J(θ) = tr(C X C') `-form below ([`comfort_at`]).
//!
//! The model it predicts is the car model ([`predictor_model`]: the rear wheels on the front
//! track through a Padé approximant of order 8, the gain's order-2 preview beside it), so on that
//! model the predictor is matched and the closed form holds. In a frame
//! ([`crate::comfort::plant::Frame`], the shipped design) it lets the road climb at the frame's
//! rate instead ([`ComfortPlant::prediction_model`]), exact on a constant grade; the closed form
//! is then reported, not claimed.
//!
//! Certified: stability for every `θ` (the roots above), and the car model's seat comfort
//! `J(θ)` bounded at every delay of the interval ([`over_delays`]), which is the guarantee
//! where it covers the predictions on the car at delays across the interval (beside
//! `hinf_sf`'s). Checked: the margins to a mismatch between the actual and the predicted delay,
//! and the loop as a master runs it (held inputs and commands, `crate::predict::sampled`) stable at
//! delays between whole communication steps, where the delayed command changes mid-step, and
//! at which communication steps it is stable at delays across the interval.
//!
//! The runtime keeps the command's own filters (the unmodelled-delay weight's states, which
//! the gain reads) in controller time and, over each step, runs the design's loop on its model:
//! the prediction moves on with the command sent, and the filters take the command the design
//! gives at every instant (`crate::predict::sampled`'s `discrete_predictor`,
//! `fmu-controller/src/predictor.rs`). Equal in continuous time; the hold no longer enters the
//! gain's fastest loop (stable to 7.5 ms at every delay instead of 1.1 ms).

use crate::comfort::controllers::{reconstruction, state_feedback_sensors, Reconstruction};
use crate::comfort::designs::{
    bound_model, certify, recovering_state_feedback_wiring, ComfortCertificate,
    ComfortDesignResult, ComfortError, Context, OverDelays, OverUncertainty, Uncertainty,
};
use crate::comfort::guaranteed::StateFeedback;
use crate::comfort::plant::ComfortPlant;
use crate::comfort::stop_recovery::{recovering_reconstruction, STOP_FORCE};
use crate::numerics::riccati::lyapunov;
use crate::predict::continuous::{Conditions, ControlLaw, Loop, PredictorLaw};
use crate::shipping::design::RearWheels;
use linsys::expm;
use nalgebra::DMatrix;
use serde::Serialize;

/// A model's comfort with a predictor of that model at the delay it compensates (`delay_sf`:
/// the car model of [`predictor_model`]):
/// `x = x̂ + ε`, `x̂` driven by `e^{Aθ} B_w w` through `A + B K`, `ε` the road's effect during the
/// last `θ` seconds, independent of it: `J(θ) = tr(C [P̂ + P_ε] Cᵀ)`,
/// `(A + BK) P̂ + P̂ (A + BK)ᵀ + e^{Aθ} B_w B_wᵀ e^{Aᵀθ} = 0`, `P_ε = ∫_0^θ e^{As} B_w B_wᵀ e^{Aᵀs} ds`
/// (Van Loan's block exponential).
pub fn comfort_at(g: &ComfortPlant, k: &DMatrix<f64>, c: &DMatrix<f64>, theta: f64) -> Option<f64> {
    let a_cl = &g.a + &g.b_u * k;
    let e = expm(&(&g.a * theta)).ok()?;
    let f = &e * &g.b_w;
    let p_hat = lyapunov(&a_cl, &(&f * f.transpose())).ok()?;
    let p = p_hat + road_gramian(g, theta)?;
    Some((c * p * c.transpose()).trace().max(0.0).sqrt())
}

/// `P_ε(θ) = ∫_0^θ e^{As} B_w B_wᵀ e^{Aᵀs} ds`.
fn road_gramian(g: &ComfortPlant, theta: f64) -> Option<DMatrix<f64>> {
    gramian_integral(&g.a, &(&g.b_w * g.b_w.transpose()), theta)
}

/// `∫_0^t e^{as} w e^{aᵀs} ds` by Van Loan's block exponential (IEEE TAC 23(3), 1978):
/// `exp([[−a, w], [0, aᵀ]] t) = [[·, F₁₂], [0, F₂₂]]` and the integral is `F₂₂ᵀ F₁₂`.
fn gramian_integral(a: &DMatrix<f64>, w: &DMatrix<f64>, t: f64) -> Option<DMatrix<f64>> {
    let n = a.nrows();
    let mut m = DMatrix::zeros(2 * n, 2 * n);
    m.view_mut((0, 0), (n, n)).copy_from(&(-a * t));
    m.view_mut((0, n), (n, n)).copy_from(&(w * t));
    m.view_mut((n, n), (n, n)).copy_from(&(a.transpose() * t));
    let big = expm(&m).ok()?;
    Some(big.view((n, n), (n, n)).transpose() * big.view((0, n), (n, n)))
}

/// `J(θ)² = f(θ) + e(θ)`, `f = tr(Mᵀ Q M)` with `M(θ) = e^{Aθ} B_w` and `Q` the closed loop's
/// observability Gramian (`(A + BK)ᵀ Q + Q (A + BK) + CᵀC = 0`), `e = tr(C P_ε(θ) Cᵀ)`.
///
/// On `[θᵢ, θᵢ + h]`: `e` does not decrease (`P_ε` integrates a positive semidefinite
/// integrand), so `e(θᵢ + h)` bounds it; `√f` is the Frobenius norm of
/// `v(δ) = Q^{1/2} e^{Aδ} M(θᵢ)`, and `‖v(δ)‖ ≤ ‖v(0)‖ + ∫_0^δ ‖v'‖ ≤ ‖v(0)‖ + √h (∫_0^h ‖v'‖²)^{1/2}`
/// (Cauchy–Schwarz), where `∫_0^h ‖v'(s)‖² ds = tr(M(θᵢ)ᵀ G_h M(θᵢ))` exactly, with
/// `G_h = ∫_0^h e^{Aᵀs} AᵀQA e^{As} ds` (one Van Loan exponential for the whole interval).
/// The excess over the grid is about `h ‖v'‖`: first order in `h` with the loop's own rates,
/// where the norm bounds of `e^{Aδ}` and its derivatives (logarithmic norm, `‖A‖²`)
/// over-cover by orders of magnitude on this stiff model. Every term is exact up to rounding.
///
/// The same figures as [`comfort_at`] at each grid point, from one Lyapunov equation and three
/// exponentials for the whole interval, by the semigroup steps `M(θ + h) = e^{Ah} M(θ)`,
/// `P_ε(θ + h) = P_ε(θ) + e^{Aθ} P_ε(h) e^{Aᵀθ}`.
pub fn over_delays(
    g: &ComfortPlant,
    k: &DMatrix<f64>,
    c: &DMatrix<f64>,
    theta_max: f64,
    intervals: usize,
) -> Option<OverDelays> {
    let h = theta_max / intervals as f64;
    let a_cl = &g.a + &g.b_u * k;
    let q = lyapunov(&a_cl.transpose(), &(c.transpose() * c)).ok()?;
    let e_step = expm(&(&g.a * h)).ok()?;
    let p_step = road_gramian(g, h)?;
    let g_step = gramian_integral(&g.a.transpose(), &(g.a.transpose() * &q * &g.a), h)?;
    let quadratic = |w: &DMatrix<f64>, m: &DMatrix<f64>| (m.transpose() * w * m).trace().max(0.0);
    let (mut m, mut ce, mut e) = (g.b_w.clone(), c.clone(), 0.0);
    let (mut grid_worst, mut bound) = (0.0f64, 0.0f64);
    for i in 0..=intervals {
        let f = quadratic(&q, &m);
        grid_worst = grid_worst.max((f + e).sqrt());
        if i == intervals {
            break;
        }
        let e_next = e + (&ce * &p_step * ce.transpose()).trace();
        let top = f.sqrt() + (h * quadratic(&g_step, &m)).sqrt();
        bound = bound.max((top * top + e_next).sqrt());
        (m, ce, e) = (&e_step * &m, &ce * &e_step, e_next);
    }
    let result = OverDelays {
        delay_max_s: theta_max,
        intervals,
        grid_worst,
        bound: bound.max(grid_worst),
    };
    result.bound.is_finite().then_some(result)
}

/// Intervals of the design-model bound over `[0, delay_max]`: `h` = 10 µs at 50 ms, where the
/// bound's excess over the grid is below 0.1 % (`over_delays`'s test measures it).
const DELAY_INTERVALS: usize = 5000;

/// The predictor's figures for its certificate.
#[derive(Debug, Clone, Serialize)]
pub struct PredictorFacts {
    pub delay_max_s: f64,
    /// Spectral abscissas of `A + B K` and `A`: the closed loop's roots at every matched delay.
    pub closed_loop_abscissa: f64,
    pub open_loop_abscissa: f64,
    /// Over the checked delays, the least extra delay and advance of the actual delay over the
    /// predicted one that the loop tolerates.
    pub mismatch_margin_lag_s: f64,
    pub mismatch_margin_lead_s: f64,
    /// The spectral abscissa of the controller's own states as they run, below 0 (checked):
    /// `A_ξ` with the command's own filters closed through their part of the gain
    /// (`A_φ + B_φ K_φ`: they take the command the design gives, unclamped, over each step),
    /// so they follow what it reads and the forces it commands through stable filters. Its
    /// commands are clamped to the actuators' limits (the parameters `u_max`, `u_max_seat`),
    /// which are the forces it integrates as in flight, so under saturation every state stays
    /// bounded (before the clamp, held commands with the plant saturated ran away at 1 ms: the
    /// in-flight prediction fed the unapplied commands back).
    pub own_states_abscissa: f64,
    /// The loop as a master runs it at `step_s` with the delay not a whole number of steps (the
    /// delayed command changes mid-step): `fractional_delays` delays checked stable, the largest
    /// spectral radius at the sampling instants among them.
    pub step_s: f64,
    pub fractional_delays: Vec<f64>,
    pub fractional_worst_radius: f64,
}

/// `A_ξ + B_ξu K_φ` ([`linsys::predictor::split_gain`]): the controller's own states as its
/// runtime steps them, the command's filters closed through their part of the gain.
fn own_loop(p: &PredictorLaw) -> DMatrix<f64> {
    let r = &p.reconstruction;
    let (_, k_own) = linsys::predictor::split_gain(
        &p.k,
        r.a_xi.nrows(),
        &crate::predict::sampled::own_filters(p),
    );
    &r.a_xi + &r.b_xiu * k_own
}

/// `0, 0.005, …, 0.05`.
fn list_delays(delays: &[f64]) -> String {
    match delays {
        [first, second, .., last] => format!("{first}, {second}, ..., {last}"),
        _ => format!("{delays:?}"),
    }
}

/// Delays off the step grid where the held loop is checked stable: a quarter, a half and
/// three quarters of a step past each of the first five whole steps (where a step is largest
/// against the delay), and half a step before each 5 ms mark of the interval.
fn fractional_delays(delay_max: f64, h: f64) -> Vec<f64> {
    let early = (0..5).flat_map(|d| [0.25, 0.5, 0.75].map(|e| (d as f64 + e) * h));
    let marks = (1..=(delay_max / 0.005).round() as usize)
        .map(|i| i as f64 * 0.005 - 0.5 * h)
        .filter(|&t| t > 5.0 * h);
    early
        .chain(marks)
        .filter(|&t| t > 0.0 && t <= delay_max)
        .collect()
}

/// The gain `k` on `g`'s design state behind a predictor over `theta`, the design state
/// known through `reconstruction`.
fn predictor_law(
    g: &ComfortPlant,
    k: &DMatrix<f64>,
    reconstruction: Reconstruction,
    theta: f64,
) -> ControlLaw {
    ControlLaw {
        lti: reconstruction.realise(k),
        inputs: state_feedback_sensors(g).names,
        accommodation: None,
        predictor: Some(PredictorLaw {
            a: g.prediction_model(),
            b: g.b_u.clone(),
            k: k.clone(),
            reconstruction,
            delay: theta,
        }),
    }
}

/// The model `delay_sf`'s predictor runs, and the gain on it: the car model of
/// [`bound_model`] (the rear wheels on the front track through a Padé approximant of order
/// [`crate::comfort::designs::BOUND_MODEL_PADE_ORDER`]) with the design model's preview states
/// (its order-2 rear track, which the gain reads) beside it as filters of the front road that
/// drive nothing. `k` on the design model's state `g` (with its delay weight) is mapped onto
/// it, zero on the car model's rear-track states.
///
/// Predicting the design model instead, the predictor took the preview states for the rear road
/// over its horizon; the car's rear road is the front track's, so its comfort on the car was
/// 8.7 % worse than the design model's closed form at 50 ms (0.0676 against 0.0622 m/s²), and
/// that form bounded nothing on the car. Predicting this model, the closed form holds on it
/// (the predictor matched) and is within 0.02 % of the car's prediction at 40–50 ms.
pub fn predictor_model(
    ctx: &Context,
    g: &ComfortPlant,
    k: &DMatrix<f64>,
) -> Result<(ComfortPlant, DMatrix<f64>), String> {
    let d = ctx.design;
    let RearWheels::Pade { order: p2 } = g.road.rear else {
        return Err(format!(
            "a predictor needs the design model's rear wheels as a Padé track, not {}",
            g.road.rear
        ));
    };
    let (model, _) = bound_model(d, ctx.params);
    let car = ComfortPlant::new(ctx.params, &model);
    let RearWheels::Pade { order: p8 } = car.road.rear else {
        unreachable!("the bound model's rear track is a Padé track")
    };
    let extra = 2 * p2;
    let at = car.layout.road.end;
    // The car model with `extra` zero states inserted at `at`, the end of its road block.
    let rows = |m: &DMatrix<f64>| m.clone().insert_rows(at, extra, 0.0);
    let cols = |m: &DMatrix<f64>| m.clone().insert_columns(at, extra, 0.0);
    let mut a = cols(&rows(&car.a));
    // Design state index → this model's, with the preview rows copied from the design model.
    let design_road = g.layout.road.start;
    let mut map: Vec<usize> = (0..g.n()).collect();
    for t in 0..2 {
        let (front_g, front) = (
            design_road + t * (1 + p2),
            car.layout.road.start + t * (1 + p8),
        );
        map[front_g] = front;
        for q in 0..p2 {
            map[front_g + 1 + q] = at + t * p2 + q;
        }
    }
    // The long waves, last in both road blocks: the same chain in both models.
    let (waves, car_waves) = (g.layout.waves.clone(), car.layout.waves.clone());
    for (j, m) in waves.zip(car_waves) {
        map[j] = m;
    }
    let filters_g = g.layout.filters[0].start;
    for (j, m) in map.iter_mut().enumerate().skip(filters_g) {
        *m = j - filters_g + car.layout.filters[0].start + extra;
    }
    for t in 0..2 {
        let front_g = design_road + t * (1 + p2);
        for q in 0..p2 {
            let row = front_g + 1 + q;
            for col in [front_g].into_iter().chain(front_g + 1..front_g + 1 + p2) {
                a[(map[row], map[col])] = g.a[(row, col)];
            }
        }
    }
    let mut layout = car.layout.clone();
    layout.road = car.layout.road.start..at + extra;
    for f in &mut layout.filters {
        *f = f.start + extra..f.end + extra;
    }
    let augmented = ComfortPlant {
        a,
        b_w: rows(&car.b_w),
        b_u: rows(&car.b_u),
        road_velocity: rows(&car.road_velocity),
        c_z: cols(&car.c_z),
        c_lim: cols(&car.c_lim),
        // `R_x` reads the road states only; the preview states, last among them, drive nothing.
        r_x: car
            .r_x
            .clone()
            .resize_horizontally(car.r_x.ncols() + extra, 0.0),
        layout,
        ..car.clone()
    };
    let (augmented, _) =
        augmented.with_delay_weight(d.unmodelled_delay, &crate::comfort::plant::force_limits(d));
    // Each design state to its own state of the model (a state mapped twice would carry two
    // gains, and one left on the identity map lands on another state).
    let mut distinct = map.clone();
    distinct.sort_unstable();
    distinct.dedup();
    if distinct.len() != map.len() || map.iter().any(|m| *m >= augmented.n()) {
        return Err("the design model's states do not map one to one onto the car model's".into());
    }
    let mut k_ext = DMatrix::zeros(k.nrows(), augmented.n());
    for (j, m) in map.iter().enumerate() {
        k_ext.column_mut(*m).copy_from(&k.column(j));
    }
    Ok((augmented, k_ext))
}

/// `delay_sf` from the nominal gain.
pub fn predictor_design(
    ctx: &Context,
    nominal: &(ComfortPlant, StateFeedback),
) -> Result<ComfortDesignResult, ComfortError> {
    let variant = "delay_sf";
    let d = ctx.design;
    let fail = |reason: String| ComfortError::Certificate {
        variant: variant.into(),
        reason,
    };
    let (g, k) = predictor_model(ctx, &nominal.0, &nominal.1.k).map_err(&fail)?;
    let (g, k) = (&g, &k);
    // In a frame, the gain `K T` on the model with the frame's states, whose predictor runs
    // the model with a road that climbs at the frame's rate: on a constant grade the
    // prediction is exact and the gain reads zero.
    let (framed, t) = g.with_frame();
    let k_framed = k * t;
    // Recovering from the seat's stops (`crate::comfort::stop_recovery`): it reads their force
    // and predicts the car without them.
    let plain = state_feedback_sensors(&framed).names;
    let r =
        recovering_reconstruction(ctx.params, &reconstruction(&framed), &plain).map_err(&fail)?;
    let law_at = |theta: f64| {
        let mut law = predictor_law(&framed, &k_framed, r.clone(), theta);
        law.inputs.push(STOP_FORCE.into());
        law
    };
    let law = law_at(0.0);
    let notes = vec![format!(
        "hinf_sf's guaranteed-cost gain behind a predictor over the actuators' known delay \
         theta (parameter tau, 0 ... {} s) of the car model's state (the rear wheels on the \
         front track through a Pade approximant of order {}, the gain's order-2 preview beside \
         it): u(t) = K x_hat(t + theta), x_hat(t + theta) = e^(A theta) x(t) + integral over \
         the commands still in flight. With the delay it predicts over, the closed loop has \
         the roots of A + B K and of A for every theta (finite spectrum assignment): stable \
         over the whole interval.",
        d.delay_max,
        crate::comfort::designs::BOUND_MODEL_PADE_ORDER
    )];
    let mut certificate = certify(
        ctx,
        variant,
        Uncertainty::InputDelay,
        &law,
        &recovering_state_feedback_wiring,
        notes,
    )?;
    // Delays across the interval, the predictor matched.
    let count = (d.delay_max / 0.005).round().max(1.0) as usize;
    let delays: Vec<f64> = (0..=count)
        .map(|i| d.delay_max * i as f64 / count as f64)
        .collect();
    let sweep = sweep_delays(ctx, &law_at, &delays).map_err(&fail)?;
    let (fractional_at, fractional) = between_whole_steps(ctx, &law_at).map_err(&fail)?;
    certificate.comfort.communication_steps = steps_across_delays(ctx, &law_at, &delays);
    let seat = g.c_z.rows(0, 1).into_owned();
    let over = over_delays(g, k, &seat, d.delay_max, DELAY_INTERVALS)
        .ok_or_else(|| fail("the car model's comfort over the delays".into()))?;
    let a_cl = &g.a + &g.b_u * k;
    let predictor = law
        .predictor
        .as_ref()
        .expect("predictor_law sets the predictor");
    let facts = PredictorFacts {
        delay_max_s: d.delay_max,
        closed_loop_abscissa: crate::numerics::eig::spectral_abscissa(&a_cl),
        open_loop_abscissa: crate::numerics::eig::spectral_abscissa(&g.a),
        mismatch_margin_lag_s: sweep.lag,
        mismatch_margin_lead_s: sweep.lead,
        own_states_abscissa: crate::numerics::eig::spectral_abscissa(&own_loop(predictor)),
        step_s: d.communication_step,
        fractional_worst_radius: crate::numerics::eig::max_or_nan(0.0, fractional.iter().copied()),
        fractional_delays: fractional_at,
    };
    if !(facts.closed_loop_abscissa < 0.0 && facts.open_loop_abscissa < 0.0) {
        return Err(fail(format!("not stable for every delay: {facts:?}")));
    }
    // Its anti-windup, model recovery in the runtime, on the prediction model it carries.
    certificate.saturation = crate::predict::saturation::SaturationCheck::model_recovery(
        &predictor.a,
        &predictor.b,
        "the predictor's",
    );
    if !certificate.saturation.holds() {
        return Err(fail(format!(
            "its model-recovery anti-windup is not proven: {}",
            certificate.saturation.why
        )));
    }
    if facts.own_states_abscissa.is_nan() || facts.own_states_abscissa >= 0.0 {
        return Err(fail(format!(
            "the controller's own states are not stable (spectral abscissa {}): clamped \
             commands would not bound them",
            facts.own_states_abscissa
        )));
    }
    certificate.comfort.uncertainty = Some(over_the_delays(ctx, g, sweep, &over, &mut certificate));
    certificate.notes.push(format!(
        "Over delays: the car model's W_k seat comfort with the predictor matched is at most \
         {:.5} at every delay of [0, {} s] (worst {:.5} on {} delays, the bound between them by \
         the Gramian of the state's rate); mismatch between the actual and the predicted delay \
         tolerated: +{:.2} ms / -{:.2} ms (least over the checked delays). As a master runs \
         it at {} s: stable at {} delays between whole steps (largest spectral radius {:.6}); \
         commands clamped to the force limits u_max, u_max_seat (set them as the plant's).",
        over.bound,
        d.delay_max,
        over.grid_worst,
        over.intervals + 1,
        1e3 * facts.mismatch_margin_lag_s,
        1e3 * facts.mismatch_margin_lead_s,
        facts.step_s,
        facts.fractional_delays.len(),
        facts.fractional_worst_radius,
    ));
    let extensions = controller_extensions(predictor, &facts, d);
    Ok(ComfortDesignResult {
        law,
        extensions,
        certificate,
    })
}

/// What the loops at delays across the interval show, the predictor matched to each.
struct DelaySweep {
    /// The least extra delay and advance over the predicted one the loops tolerate \[s\].
    lag: f64,
    lead: f64,
    predictions: Vec<(String, crate::predict::continuous::Figures)>,
    conditions: Vec<Conditions>,
    held: Vec<Option<crate::comfort::designs::Held>>,
}

/// The nominal car at `delay`.
fn at_delay(ctx: &Context, delay: f64) -> Conditions {
    Conditions {
        delay,
        ..Conditions::nominal(*ctx.params)
    }
}

/// The loop at each of `delays` with the predictor matched: its mismatch margins, its
/// predicted figures, and the loop as a master runs it. Each delay's loop on its own thread
/// (the rest of the synthesis is done by then): the delay-margin scans, and then the held loops
/// (up to 330 states at 50 ms), are delay_sf's synthesis time. Collected in order.
fn sweep_delays(
    ctx: &Context,
    law_at: &(dyn Fn(f64) -> ControlLaw + Sync),
    delays: &[f64],
) -> Result<DelaySweep, String> {
    use rayon::prelude::*;
    let d = ctx.design;
    let evaluated = delays
        .par_iter()
        .map(|&theta| {
            let c = at_delay(ctx, theta);
            let lp = Loop::new(Some(&law_at(theta)), c).map_err(|e| e.to_string())?;
            let label = format!("delay {:.1} ms", 1e3 * theta);
            Ok((lp.delay_margins(), (label, lp.figures(&d.road)), c))
        })
        .collect::<Result<Vec<_>, String>>()?;
    let (mut lag, mut lead) = (f64::INFINITY, f64::INFINITY);
    let mut predictions = Vec::new();
    let mut conditions = Vec::new();
    for ((l, r), prediction, c) in evaluated {
        lag = lag.min(l);
        lead = lead.min(r);
        predictions.push(prediction);
        conditions.push(c);
    }
    let held = conditions
        .par_iter()
        .map(|c| crate::comfort::designs::held_at(&law_at(c.delay), *c, d))
        .collect();
    Ok(DelaySweep {
        lag,
        lead,
        predictions,
        conditions,
        held,
    })
}

/// The loop as a master runs it at delays that are not a whole number of steps (the delayed
/// command changes mid-step): the delays and each one's spectral radius, stable or refused.
fn between_whole_steps(
    ctx: &Context,
    law_at: &(dyn Fn(f64) -> ControlLaw + Sync),
) -> Result<(Vec<f64>, Vec<f64>), String> {
    use rayon::prelude::*;
    let d = ctx.design;
    let at = fractional_delays(d.delay_max, d.communication_step);
    let radii = at
        .par_iter()
        .map(|&theta| {
            crate::predict::sampled::SampledLoop::new(
                Some(&law_at(theta)),
                at_delay(ctx, theta),
                d.communication_step,
            )
            .map(|l| l.radius())
            .map_err(|e| format!("at a delay of {theta} s, between whole steps: {e}"))
        })
        .collect::<Result<Vec<f64>, String>>()?;
    Ok((at, radii))
}

/// The communication steps at delays across the interval (the held loop's history, and so
/// what the hold does to it, grows with the delay). Every other delay of the grid: at 0.25 ms a
/// held loop at 50 ms has 1080 states, and the whole grid took the synthesis from 22.6 to
/// 26–30 s.
fn steps_across_delays(
    ctx: &Context,
    law_at: &dyn Fn(f64) -> ControlLaw,
    delays: &[f64],
) -> crate::comfort::designs::StepStability {
    let d = ctx.design;
    let step_delays: Vec<f64> = delays.iter().step_by(2).copied().collect();
    let loops: Vec<(ControlLaw, Conditions)> = step_delays
        .iter()
        .map(|&theta| (law_at(theta), at_delay(ctx, theta)))
        .collect();
    crate::comfort::designs::StepStability::check(
        &loops,
        &format!(
            "the nominal car at each delay of {} s, the predictor matched",
            list_delays(&step_delays)
        ),
        &d.road,
        d.communication_step,
    )
}

/// The certificate's figures over the delays, and its guarantee where it is one. Claimed for
/// the car only where the car model's bound covers every prediction on it (exact wheelbase
/// delay, the road FMU's band), as for the other robust designs, and only for the predictor the
/// bound is about: one that predicts the model's road. In a frame the predictor lets the road
/// climb at the frame's rate instead, and the closed form says nothing of that.
fn over_the_delays(
    ctx: &Context,
    g: &ComfortPlant,
    sweep: DelaySweep,
    over: &OverDelays,
    certificate: &mut ComfortCertificate,
) -> OverUncertainty {
    let d = ctx.design;
    let mut uncertainty = OverUncertainty::predicted(
        Uncertainty::InputDelay,
        sweep.predictions,
        sweep.conditions,
        ctx.params,
    );
    uncertainty.set_held(sweep.held);
    uncertainty.bound_model = format!(
        "{} with the gain's own preview beside it, the predictor matched to the delay",
        bound_model(d, ctx.params).1
    );
    certificate.comfort.guaranteed_wk_rms_seat_m_s2 = if g.frame.is_some() {
        uncertainty.bound_failure = Some(format!(
            "the bound {:.5} is the car model's with the predictor matched to it; this \
             predictor lets the road climb at its frame's rate: no guarantee claimed",
            over.bound
        ));
        None
    } else {
        uncertainty.claim(
            over.bound,
            &format!(" over every delay of [0, {} s]", d.delay_max),
        )
    };
    uncertainty.bound_model_grid_worst_wk_rms_seat = Some(over.grid_worst);
    uncertainty.bound_model_grid_points = over.intervals + 1;
    uncertainty.over_delays = Some(*over);
    uncertainty
}

/// The controller file's predictor: what the certificate checked.
fn controller_extensions(
    p: &PredictorLaw,
    facts: &PredictorFacts,
    d: &crate::shipping::design::ComfortDesign,
) -> crate::shipping::controller_file::Extensions {
    let m = crate::shipping::controller_file::matrix_rows;
    let r = &p.reconstruction;
    crate::shipping::controller_file::Extensions {
        predictor: Some(crate::shipping::controller_file::Predictor {
            a: m(&p.a),
            b: m(&p.b),
            k: m(&p.k),
            s_y: m(&r.s_y),
            s_xi: m(&r.s_xi),
            a_xi: m(&r.a_xi),
            b_xi: m(&r.b_xi),
            b_xiu: m(&r.b_xiu),
            d_yu: Some(m(&r.d_yu)),
            u_max: Some(crate::comfort::plant::force_limits(d).to_vec()),
            delay_max: d.delay_max,
            facts: serde_json::to_value(facts).expect("serialisable"),
        }),
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::comfort::controllers::realise_state_feedback;
    use crate::comfort::designs::nominal_gain;
    use crate::predict::continuous::Figures;
    use crate::shipping::design::ComfortDesign;
    use vehicle::VehicleParams;

    /// The checked-in comfort design, the default car, `hinf_sf`'s gain and the seat's row.
    fn nominal() -> (
        ComfortDesign,
        VehicleParams,
        ComfortPlant,
        StateFeedback,
        DMatrix<f64>,
    ) {
        let d = ComfortDesign::from_json(include_str!("../../designs/comfort.json")).unwrap();
        let p = VehicleParams::default();
        let (g, sf) = nominal_gain(&Context {
            params: &p,
            design: &d,
        })
        .unwrap();
        let seat = g.c_z.rows(0, 1).into_owned();
        (d, p, g, sf, seat)
    }

    /// `delay_sf`'s model and gain as shipped, from [`nominal`]'s.
    fn shipped(
        d: &ComfortDesign,
        p: &VehicleParams,
        g_design: &ComfortPlant,
        sf: &StateFeedback,
    ) -> (ComfortPlant, DMatrix<f64>) {
        let ctx = Context {
            params: p,
            design: d,
        };
        predictor_model(&ctx, g_design, &sf.k).unwrap()
    }

    /// The grid's recurrences give [`comfort_at`]'s figures: the worst over a grid equals the
    /// worst of the point-by-point formula, on a grid where `J(θ)` varies by a factor of
    /// several. To 1e-4: the two go through different Lyapunov equations of this stiff loop (the
    /// disturbance's Gramian, the output's), measured to differ by 4e-5 relative at θ = 0 where
    /// the recurrences play no part, 2e-7 at 50 ms; a missing or misplaced term of the
    /// recurrences changes the figure by percents.
    #[test]
    fn the_delay_grid_is_the_closed_form_at_each_point() {
        let (_, _, g, sf, seat) = nominal();
        for (theta_max, intervals) in [(0.05, 10), (0.02, 4), (0.05, 1)] {
            let direct = (0..=intervals)
                .map(|i| comfort_at(&g, &sf.k, &seat, theta_max * i as f64 / intervals as f64))
                .map(Option::unwrap)
                .fold(0.0f64, f64::max);
            let grid = over_delays(&g, &sf.k, &seat, theta_max, intervals)
                .unwrap()
                .grid_worst;
            assert!(
                (grid - direct).abs() <= 1e-4 * direct,
                "{theta_max} s, {intervals} intervals: {grid} vs {direct}"
            );
        }
        // The figure grows with the delay: the grid's worst is not its first point.
        let first = comfort_at(&g, &sf.k, &seat, 0.0).unwrap();
        let over = over_delays(&g, &sf.k, &seat, 0.05, 10).unwrap();
        assert!(over.grid_worst > 3.0 * first);
    }

    /// The bound holds between the grid's points: on a coarse grid (5 ms intervals, where it
    /// must do real work), [`comfort_at`] at 9 delays inside every interval, each computed on
    /// its own, stays below it; and it is tight where it is used: with the certificate's
    /// intervals it exceeds the grid's worst by under 0.1 %. The coarse grid's bound also
    /// exceeds the fine one's (a bound that did not grow with the step would be no bound).
    #[test]
    fn the_delay_bound_covers_every_delay_between_the_grid_points() {
        let (_, _, g, sf, seat) = nominal();
        let (theta_max, intervals) = (0.05, 10);
        let coarse = over_delays(&g, &sf.k, &seat, theta_max, intervals).unwrap();
        let h = theta_max / intervals as f64;
        let mut dense_worst = 0.0f64;
        for i in 0..intervals {
            for j in 1..10 {
                let theta = h * (i as f64 + j as f64 / 10.0);
                let j_theta = comfort_at(&g, &sf.k, &seat, theta).unwrap();
                assert!(
                    j_theta <= coarse.bound * (1.0 + 1e-6),
                    "θ = {theta}: J = {j_theta} above the bound {}",
                    coarse.bound
                );
                dense_worst = dense_worst.max(j_theta);
            }
        }
        let fine = over_delays(&g, &sf.k, &seat, theta_max, DELAY_INTERVALS).unwrap();
        let excess = fine.bound / fine.grid_worst - 1.0;
        assert!(
            (0.0..1e-3).contains(&excess),
            "excess over the grid {excess:e}"
        );
        assert!(
            fine.bound >= dense_worst * (1.0 - 1e-4),
            "{} vs {dense_worst}",
            fine.bound
        );
        assert!(
            coarse.bound > fine.bound,
            "{} vs {}",
            coarse.bound,
            fine.bound
        );
    }

    /// Between whole steps the loop a master runs is stable only if `ξ` sees the force as the
    /// actuators apply it: with `D_yu` zeroed (the held inputs carrying the force of the step's
    /// start through the step), the sampled loop at a quarter of a step past a whole step is
    /// unstable at 2 and 2.5 ms steps (measured radius 1.08 and 1.14; before the command's
    /// filters ran in controller time it was so at the design step of 1 ms, 1.41 at 1.1 ms, and
    /// the co-simulations diverged or limit-cycled); with it, those loops and every delay of
    /// [`fractional_delays`] are stable; at whole steps and with no delay the correction
    /// cancels (the same figure with it and without it).
    #[test]
    fn the_held_loop_is_stable_between_whole_steps_with_the_force_as_applied() {
        let (d, p, g, sf, _) = nominal();
        let law_at = |theta: f64, d_yu: bool| {
            let mut reconstruction = reconstruction(&g);
            if !d_yu {
                reconstruction.d_yu.fill(0.0);
            }
            predictor_law(&g, &sf.k, reconstruction, theta)
        };
        let at = |theta: f64| Conditions {
            delay: theta,
            ..Conditions::nominal(p)
        };
        for (step, theta) in [(2e-3, 2.5e-3), (2.5e-3, 3.125e-3)] {
            let radius = |d_yu: bool| {
                crate::predict::sampled::spectral_radius(
                    Some(&law_at(theta, d_yu)),
                    at(theta),
                    step,
                )
                .unwrap()
            };
            let (with, without) = (radius(true), radius(false));
            assert!(
                with < 1.0 && without > 1.04,
                "{step}, {theta}: {with}, {without}"
            );
        }
        let h = d.communication_step;
        let held = |theta: f64, d_yu: bool| {
            crate::predict::sampled::SampledLoop::new(Some(&law_at(theta, d_yu)), at(theta), h)
        };
        let delays = fractional_delays(d.delay_max, h);
        assert_eq!(delays.len(), 24, "{delays:?}");
        for &theta in &delays {
            assert!(theta % h > 1e-9 * h, "{theta} is a whole number of steps");
            let radius = held(theta, true).unwrap().radius();
            assert!(radius < 1.0, "{theta}: {radius}");
        }
        for theta in [0.0, 2e-3, 2e-2] {
            let (with, without) = (held(theta, true).unwrap(), held(theta, false).unwrap());
            let (a, b) = (
                with.figures(&d.road).time_averaged.wk_rms_seat_m_s2,
                without.figures(&d.road).time_averaged.wk_rms_seat_m_s2,
            );
            // With no delay too: the predictor predicts over the step, whose command the
            // inputs carry the force of (predicting over no delay, the correction cost 8 %).
            assert!((a / b - 1.0).abs() < 1e-7, "{theta}: {a} vs {b}");
        }
    }

    /// The command's own filters run in controller time and the prediction moves on with the
    /// model over each step: as the step shrinks the held loop tends to the continuous one
    /// (`W_k` seat within a percent at 0.1 ms, a few percent at 1 ms, with no delay and at 3
    /// and 20 ms), and it is stable at 5 ms, where driving the filters by the held commands made
    /// the loop unstable above 1.1 ms (radius 2.2 at 2 ms).
    #[test]
    fn the_predictor_as_stepped_tends_to_the_continuous_loop_and_holds_at_long_steps() {
        let (d, p, g, sf, _) = nominal();
        for theta in [0.0, 3e-3, 2e-2] {
            let law = predictor_law(&g, &sf.k, reconstruction(&g), theta);
            let c = Conditions {
                delay: theta,
                ..Conditions::nominal(p)
            };
            let continuous = Loop::new(Some(&law), c)
                .unwrap()
                .figures(&d.road)
                .wk_rms_seat_m_s2;
            let held = |step: f64| {
                crate::predict::sampled::SampledLoop::new(Some(&law), c, step)
                    .unwrap()
                    .figures(&d.road)
                    .time_averaged
                    .wk_rms_seat_m_s2
            };
            let (fine, coarse) = (held(1e-4), held(1e-3));
            println!("{theta}: continuous {continuous}, held at 0.1 ms {fine}, at 1 ms {coarse}");
            assert!(
                (fine / continuous - 1.0).abs() < 0.02,
                "{theta}: {fine} vs {continuous}"
            );
            assert!(
                (coarse / continuous - 1.0).abs() > (fine / continuous - 1.0).abs(),
                "{theta}"
            );
            let radius = crate::predict::sampled::spectral_radius(Some(&law), c, 5e-3).unwrap();
            assert!(radius < 1.0, "{theta}: {radius}");
        }
    }

    /// The gain as the plain realised controller, no predictor (with `nominal`'s model and gain,
    /// `hinf_sf`'s controller).
    fn plain_law(g: &ComfortPlant, k: &DMatrix<f64>) -> ControlLaw {
        ControlLaw {
            lti: realise_state_feedback(g, k),
            inputs: state_feedback_sensors(g).names,
            accommodation: None,
            predictor: None,
        }
    }

    /// With an actuator delay `θ` below one communication step `h` the predictor predicts over
    /// `h` ([`linsys::predictor::predicted_delay`]): the car at the step's end under the previous
    /// command, whose force the plant's outputs carry (a master reads them before it sets the
    /// new one). Its held loop beats `hinf_sf`'s (the same gain, no predictor) at every `θ` of
    /// a step (measured, W_k seat on the design road, m/s²): at 1 ms 0.0089, 0.0090, 0.0092,
    /// 0.0095, 0.0100 at θ = 0, h/4 … h against `hinf_sf`'s 0.0103 with no delay; at 2.5 ms
    /// 0.0102, 0.0099, 0.0103, 0.0114, 0.0130 against 0.0216. With no delay it is stable at
    /// every checked step to 10 ms (radius 0.9978 there), where `hinf_sf`'s loop is unstable
    /// from 7.5 ms (1.0039; 1.063 at 10 ms).
    /// Predicting over `θ` itself (matched) was measured 0.0102 at 1 ms, 0.0145 at 2.5 ms
    /// (no delay), and unstable at 10 ms (radius 1.06).
    #[test]
    fn below_one_step_the_predictor_over_the_step_beats_the_plain_gain_held() {
        let (d, p, g_design, sf, _) = nominal();
        let (g, k) = shipped(&d, &p, &g_design, &sf);
        let r = reconstruction(&g);
        let at = |theta: f64| Conditions {
            delay: theta,
            ..Conditions::nominal(p)
        };
        let seat = |l: crate::predict::sampled::SampledLoop| {
            l.figures(&d.road).time_averaged.wk_rms_seat_m_s2
        };
        let plain = plain_law(&g_design, &sf.k);
        for h in [1e-3, 2.5e-3] {
            let reference =
                seat(crate::predict::sampled::SampledLoop::new(Some(&plain), at(0.0), h).unwrap());
            for theta in [0.0, 0.25 * h, 0.5 * h, 0.75 * h, h] {
                let law = predictor_law(&g, &k, r.clone(), theta);
                let held = seat(
                    crate::predict::sampled::SampledLoop::new(Some(&law), at(theta), h).unwrap(),
                );
                println!(
                    "step {h}, delay {theta}: {held:.5} (hinf_sf with no delay {reference:.5})"
                );
                let margin = if theta < 0.5 * h { 0.9 } else { 1.0 };
                assert!(
                    held < margin * reference,
                    "{h}, {theta}: {held} vs {reference}"
                );
            }
        }
        for h in [5e-3, 7.5e-3, 1e-2] {
            let law = predictor_law(&g, &k, r.clone(), 0.0);
            let radius = crate::predict::sampled::spectral_radius(Some(&law), at(0.0), h).unwrap();
            let plain_radius =
                crate::predict::sampled::spectral_radius(Some(&plain), at(0.0), h).unwrap();
            println!("step {h}: radius {radius:.5}, hinf_sf's {plain_radius:.5}");
            assert!(radius < 1.0, "{h}: {radius}");
            assert!(
                h < 7.5e-3 || plain_radius > 1.0,
                "{h}: hinf_sf {plain_radius}"
            );
        }
    }

    /// Van Loan's integral against Simpson's rule on the exponential itself, for a matrix
    /// with a fast and a slow mode, oscillation and coupling.
    #[test]
    fn the_gramian_integral_is_the_integral() {
        let a = DMatrix::from_row_slice(3, 3, &[-1.0, 8.0, 0.5, -8.0, -2.0, 0.0, 0.3, 1.0, -40.0]);
        let w = DMatrix::from_row_slice(3, 3, &[2.0, 0.5, 0.1, 0.5, 1.0, -0.2, 0.1, -0.2, 3.0]);
        let t = 0.3;
        let integrand = |s: f64| {
            let e = expm(&(&a * s)).unwrap();
            &e * &w * e.transpose()
        };
        let n = 2000;
        let h = t / n as f64;
        let mut simpson = integrand(0.0) + integrand(t);
        for i in 1..n {
            simpson += integrand(i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
        }
        simpson *= h / 3.0;
        let van_loan = gramian_integral(&a, &w, t).unwrap();
        let error = (&van_loan - &simpson).norm() / simpson.norm();
        assert!(error < 1e-10, "relative error {error:e}");
    }

    /// The predictor's frequency-domain loop on the car (the certificate's predictions) against
    /// the closed form `J(θ)` on the model it predicts ([`predictor_model`]): at `θ = 0` the
    /// predictor is the plain realised law (equal to 1e-6: two evaluations of the same
    /// response), and at every delay the two agree up to the car model's differences from the
    /// car (the weightings' and the road's band limits, the Padé track's residual). Measured,
    /// the car's prediction over `J(θ)`: 1.010 at 0, 1.018 at 10 ms, 1.041 at 20 ms, 1.009 at
    /// 30 ms, 0.9999 at 40 ms and 0.9998 at 50 ms, where the comfort is the road's during the
    /// horizon, which the car model predicts as the car has it. So within 5 % everywhere and
    /// 1e-3 from 40 ms, where `J` is largest and the guarantee is decided. (Predicting the design
    /// model the ratio was 1.078 at 0, 0.988 at 10 ms and 1.087 at 50 ms.)
    #[test]
    fn the_predictor_loop_matches_the_closed_form_comfort_at_every_delay() {
        let (d, p, g_design, sf, _) = nominal();
        let (g, k) = shipped(&d, &p, &g_design, &sf);
        let seat = g.c_z.rows(0, 1).into_owned();
        let ratio = |theta: f64| {
            let law = predictor_law(&g, &k, reconstruction(&g), theta);
            let c = Conditions {
                delay: theta,
                ..Conditions::nominal(p)
            };
            let f: Figures = Loop::new(Some(&law), c).unwrap().figures(&d.road);
            f.wk_rms_seat_m_s2 / comfort_at(&g, &k, &seat, theta).unwrap()
        };
        // A gain as the plain realised controller (no predictor), on the car.
        let plain = |g: &ComfortPlant, k: &DMatrix<f64>| {
            Loop::new(Some(&plain_law(g, k)), Conditions::nominal(p))
                .unwrap()
                .figures(&d.road)
        };
        let f = plain(&g, &k);
        // The gain mapped onto the predictor's model is hinf_sf's controller on the car.
        let h = plain(&g_design, &sf.k);
        let same = f.wk_rms_seat_m_s2 / h.wk_rms_seat_m_s2 - 1.0;
        assert!(same.abs() < 1e-9, "mapped gain vs hinf_sf: {same:e}");
        let r_plain = f.wk_rms_seat_m_s2 / comfort_at(&g, &k, &seat, 0.0).unwrap();
        let r0 = ratio(0.0);
        assert!((r0 / r_plain - 1.0).abs() < 1e-6, "{r0} vs {r_plain}");
        for theta in [0.0, 0.01, 0.02, 0.03, 0.04, 0.05] {
            let r = ratio(theta);
            let tolerance = if theta >= 0.04 { 1e-3 } else { 0.05 };
            assert!(
                (r - 1.0).abs() < tolerance,
                "θ = {theta}: car / car model {r}"
            );
        }
    }
}
