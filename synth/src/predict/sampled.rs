//! What a controller does on an ISO 8608 road **when a master runs it at a communication step
//! `h`**: the prediction of [`crate::predict::continuous`] for the sampled-data loop the co-simulation
//! actually is, not the continuous-time loop the synthesis designs.
//!
//! The master's loop (`master::cosim::simulate`, Gauss–Seidel, the same for FMPy's fixed-step
//! master; libcosim's steps every simulator before it exchanges values, the Jacobi order): at `t_k = k h` it reads the plant's outputs `y_k`, hands them
//! to the controller, sets the controller's command `u_k` on the plant, steps both over `h`,
//! and sets the road at `t_{k+1}`. So over `[t_k, t_{k+1})` the plant sees the road **held** at
//! its value at `t_k` and each actuator the command held and delayed by `θ = d h + ε`
//! (`0 ≤ ε < h`): `u_{k−d−1}` until `t_k + ε`, then `u_{k−d}`. The controller FMU steps its
//! own state exactly with `y_k` held (`ξ_{k+1} = Φ_c ξ_k + Γ_c y_k`, `u_k = C ξ_k + D y_k`); a
//! predictor keeps the commands still in flight, `θ / h` of them
//! (`fmu-controller/src/predictor.rs`). The plant's outputs at `t_k` carry the force it applies
//! then, as the plant FMU computes it: with `θ = 0` the previous command (the new one is set
//! after the read), with `θ > 0` the command of `t_k − θ`.
//!
//! Everything is linear and shift-invariant in `k`, so a road `R e^{jωt}` gives commands
//! `U e^{jωkh}` and a state `X e^{jωkh}` at the sampling instants: the closed loop at the
//! sampling instants is one discrete-time system (the car with its weighting filters, the
//! controller's state, the commands in flight), evaluated at `z = e^{jωh}` by the Hessenberg
//! solve of [`crate::predict::continuous`]. Between the instants the state follows the held inputs, and
//! the **time-averaged** power of each figure over a step is an exact quadratic form in the
//! state and inputs at `t_k`: `(1/h) ∫₀^h |M e^{Fs} q|² ds = qᴴ Q q`, with
//! `F = [[A, B], [0, 0]]` (the held inputs as constant states) and `Q = (1/h) ∫ e^{Fᵀs} MᵀM e^{Fs}
//! ds` by Van Loan's exponential, once per figure and hold interval. The weighting filters are
//! states of the car, so the weighted figures are exact between the instants too.
//!
//! For a stationary random road, the time-averaged mean square of a figure is
//! `∫ S(f) Σ_track P(f) df`, `P` that power per unit road velocity (the loop's response to
//! different frequencies is uncorrelated); the integral is [`crate::predict::continuous`]'s, over the road
//! FMU's band, with the rear wheels exactly `L / V` behind. As `h → 0` this is the continuous
//! prediction (tested).

use crate::numerics::hinf_norm::Lti;
use crate::predict::continuous::{
    plain_signals, plant_outputs_at, resonances, road_integral, sensor_rows, track_input,
    Conditions, ControlLaw, Figures, HessenbergResponse, PredictionError, PredictorLaw, SensorRows,
    N_CHANNELS, WEIGHTED_SIGNALS,
};
use crate::shipping::design::ComfortRoad;
use linsys::predictor::{predicted_delay, PredictionMatrices, PredictorBlocks};
use linsys::{discretize, expm};
use nalgebra::{Complex, DMatrix, DVector};
use vehicle::iso2631::{ComfortMeter, METER_OUTPUTS};
use vehicle::model::{OutputRow, StateSpace, N_ACTUATORS, N_ROAD, N_STATES};

type C64 = Complex<f64>;

/// How a master orders, at each communication point `t_k`, the exchange of values and the
/// steps: what the controller's command over `[t_k, t_{k+1})` is. The plant's outputs at `t_k`
/// are read before the new command is set in every order (they carry `u_{k−1}`'s force), and
/// the road is the same; only the command differs. `master::cosim::Order` runs each (same
/// names).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Order {
    /// Gauss–Seidel, the plant's outputs first (`master`'s default, FMPy's fixed-step
    /// master): the controller is given `y_k`, its command read and set, then every
    /// FMU steps. `u_k = C ξ_k + D y_k`.
    GaussSeidel,
    /// Jacobi: every output read at `t_k` before any input is set (libcosim's fixed-step
    /// algorithm), so the command is the one the controller gives with its previous input.
    /// `u_k = C ξ_k + D y_{k−1}`.
    Jacobi,
    /// Gauss–Seidel with the controller stepped first: given `y_k`, stepped to `t_{k+1}`, and
    /// its command then drives the plant over `[t_k, t_{k+1})`. `u_k = C ξ_{k+1} + D y_k`.
    ControllerFirst,
}

/// Every [`Order`], the default first.
pub const ORDERS: [Order; 3] = [Order::GaussSeidel, Order::Jacobi, Order::ControllerFirst];

/// Evenly spaced frequencies of a held loop's integration grid ([`road_integral`]): half a
/// continuous loop's [`crate::predict::continuous::FREQUENCIES`]. A held loop's resonances are
/// always named, from its exact poles at the sampling instants (a delay there is a shift
/// register, no transcendental term), and graded around; the even grid carries the smooth rest,
/// where 501 points are within 3·10⁻⁸ relative of eight times as many
/// (`held_figures_on_the_coarser_grid_equal_a_fine_one`), and the designs' certificates within
/// 2·10⁻⁷ of 4001 points. The held loops were a quarter of the synthesis's time.
pub(crate) const HELD_FREQUENCIES: usize = 501;

/// Held inputs of the car: the road (heights, velocities), then the applied forces.
const N_HELD: usize = N_ROAD + N_ACTUATORS;

/// The car with its ISO 2631-1 weighting filters as states, driven by held inputs.
struct WeightedCar {
    /// `[x (16); the vibration meter's states (W_k on the seat, W_e on roll and pitch)]`, and
    /// with lagging actuators their applied forces `f` last.
    a: DMatrix<f64>,
    /// Per held input `[r; f]`, with lagging actuators `[r; u]` (the commands, which the lag
    /// turns into `f`).
    b: DMatrix<f64>,
    /// The figures' rows over `[state; held inputs]`, in [`N_CHANNELS`]' order.
    m: DMatrix<f64>,
    /// With lagging actuators, where their forces are among the states.
    forces_at: Option<usize>,
}

impl WeightedCar {
    /// The car `p` read through `outputs`; with `lag_hz`, behind first-order actuators of that
    /// bandwidth, `ḟ = ω_a (u − f)` (the plant FMU's `actuator_bandwidth`).
    fn new(p: &vehicle::VehicleParams, outputs: &[OutputRow], lag_hz: Option<f64>) -> Self {
        let ss = StateSpace::new(p);
        // The plain figures' signals `c x + [d_r d_u] [r; f]`, divided by their divisors.
        let static_load = vehicle::model::StaticEquilibrium::new(p).tire_load;
        let plain = plain_signals(&static_load);
        let names: Vec<&str> = plain.iter().map(|(n, _)| n.as_str()).collect();
        let rows = sensor_rows(outputs, &names).expect("physical outputs");
        // The weighted figures: the plant's vibration meter, driven by `[x; r; f]`.
        let meter = ComfortMeter::new(outputs);
        let nw = ComfortMeter::order();
        let forces_at = lag_hz.map(|_| N_STATES + nw);
        let n = N_STATES + nw + forces_at.map_or(0, |_| N_ACTUATORS);
        let mut a = DMatrix::zeros(n, n);
        let mut b = DMatrix::zeros(n, N_HELD);
        let mut m = DMatrix::zeros(N_CHANNELS, n + N_HELD);
        // Where the forces act from: the held inputs, or the lag's states.
        let forces = ss.place(&mut a, &mut b, forces_at.zip(lag_hz));
        let force_column = forces_at.unwrap_or(n + N_ROAD);
        meter.place(&mut a, &mut b, N_STATES, forces);
        m.view_mut((0, N_STATES), (WEIGHTED_SIGNALS.len(), nw))
            .copy_from(&meter.c);
        let first = WEIGHTED_SIGNALS.len();
        for (k, (_, divisor)) in plain.iter().enumerate() {
            let row = first + k;
            m.view_mut((row, 0), (1, N_STATES))
                .copy_from(&(rows.c.row(k) / *divisor));
            m.view_mut((row, n), (1, N_ROAD))
                .copy_from(&(rows.d_r.row(k) / *divisor));
            m.view_mut((row, force_column), (1, N_ACTUATORS))
                .copy_from(&(rows.d_u.row(k) / *divisor));
        }
        for i in 0..N_ACTUATORS {
            m[(first + plain.len() + i, force_column + i)] = 1.0;
        }
        WeightedCar { a, b, m, forces_at }
    }

    fn order(&self) -> usize {
        self.a.nrows()
    }

    /// `F = [[A, B], [0, 0]]`: the car with its held inputs as constant states.
    fn held_generator(&self) -> DMatrix<f64> {
        let n = self.order() + N_HELD;
        let mut f = DMatrix::zeros(n, n);
        f.view_mut((0, 0), (self.order(), self.order()))
            .copy_from(&self.a);
        f.view_mut((0, self.order()), (self.order(), N_HELD))
            .copy_from(&self.b);
        f
    }

    /// `Q_c = (1/h) ∫₀^τ e^{Fᵀs} m_cᵀ m_c e^{Fs} ds` per figure `c` of the first `channels`
    /// (in [`N_CHANNELS`]' order, `W_k` seat first), `F` the
    /// [`WeightedCar::held_generator`]: Van Loan's `exp([[−Fᵀ, mᵀm], [0, F]] τ) =
    /// [[·, E₁₂], [0, E₂₂]]`, `∫ = E₂₂ᵀ E₁₂`.
    fn power_forms(
        &self,
        tau: f64,
        h: f64,
        channels: usize,
    ) -> Result<Vec<DMatrix<f64>>, PredictionError> {
        let n = self.order() + N_HELD;
        let f = self.held_generator();
        (0..channels)
            .map(|c| {
                let row = self.m.row(c);
                let mut big = DMatrix::zeros(2 * n, 2 * n);
                big.view_mut((0, 0), (n, n))
                    .copy_from(&(-f.transpose() * tau));
                big.view_mut((0, n), (n, n))
                    .copy_from(&(row.transpose() * row * tau));
                big.view_mut((n, n), (n, n)).copy_from(&(&f * tau));
                let e = expm(&big).map_err(|e| {
                    PredictionError::Unstable(format!("the hold's power integral: {e}"))
                })?;
                let q = e.view((n, n), (n, n)).transpose() * e.view((0, n), (n, n));
                // Symmetric by construction; rounding is not.
                Ok((&q + q.transpose()) * (0.5 / h))
            })
            .collect()
    }
}

/// The power forms of [`WeightedCar::power_forms`] factored once, `Q_c = Σ_i λ_i v_i v_iᵀ`
/// over the eigenpairs of each `Q_c` above `1e-17 max|λ|` (the others are below the forms' own
/// rounding), all channels' `v_i` stacked as rows of one matrix: a road frequency's quadratic
/// forms are then one product with that matrix instead of [`N_CHANNELS`] dense ones. A form
/// over a step is an integral of `e^{Fᵀs} mᵀ m e^{Fs}` over a short hold, so its eigenvalues
/// fall off fast: for holds of 0.2–5 ms, 84–112 rows are kept of the 19 × 49 = 931 the dense
/// forms have (the synthesis of all designs went from 29.7 to 26.1 s).
struct FactoredForms {
    /// `v_iᵀ`, channel after channel.
    rows: DMatrix<f64>,
    /// `λ_i`, in the order of `rows`.
    weights: Vec<f64>,
    /// Channel `c`'s rows are `end[c − 1] .. end[c]` (`0 ..` for the first).
    end: Vec<usize>,
}

impl FactoredForms {
    fn new(forms: &[DMatrix<f64>]) -> Self {
        let n = forms.first().map_or(0, |f| f.nrows());
        let (mut vectors, mut weights) = (Vec::new(), Vec::new());
        let mut end = Vec::with_capacity(forms.len());
        for form in forms {
            let eig = nalgebra::SymmetricEigen::new(form.clone());
            let largest = eig.eigenvalues.amax();
            for (i, &l) in eig.eigenvalues.iter().enumerate() {
                if l.abs() > 1e-17 * largest {
                    vectors.push(eig.eigenvectors.column(i).transpose());
                    weights.push(l);
                }
            }
            end.push(weights.len());
        }
        let rows = match vectors.is_empty() {
            true => DMatrix::zeros(0, n),
            false => DMatrix::from_rows(&vectors),
        };
        FactoredForms { rows, weights, end }
    }

    /// Adds `xᵀ Q_c x` for the real and imaginary parts of `x` to `out[c]`, for each channel
    /// the forms have.
    fn add(&self, x: &DVector<C64>, out: &mut [f64]) {
        if self.weights.is_empty() {
            return;
        }
        let (re, im) = (&self.rows * x.map(|v| v.re), &self.rows * x.map(|v| v.im));
        let mut start = 0;
        for (o, &end) in out.iter_mut().zip(&self.end) {
            *o += (start..end)
                .map(|i| self.weights[i] * (re[i] * re[i] + im[i] * im[i]))
                .sum::<f64>();
            start = end;
        }
    }
}

/// A controller as the FMU steps it at `h`: `ξ_{k+1} = Φ ξ_k + Γ y_k + G_u c_k`,
/// `u_k = C ξ_k + D y_k + K_u c_k`, where `c_k = [u_{k−1}; …; u_{k−d}]` are the commands it
/// sent in the last `d` steps (a predictor's commands in flight; `d = 0` otherwise). The loop
/// keeps those commands once, as the plant's command history, instead of a second copy in the
/// controller's state: `delay_sf`'s held loops at 50 ms went from 580 states to 330, their
/// per-frequency `O(n²)` solve about three times fewer operations (its synthesis 26 → 19 s).
struct DiscreteController {
    lti: Lti,
    /// `d`: how many past commands it reads.
    commands: usize,
    /// `G_u` and `K_u`, `d N_ACTUATORS` columns.
    g_u: DMatrix<f64>,
    k_u: DMatrix<f64>,
}

impl DiscreteController {
    fn new(law: &ControlLaw, h: f64) -> Result<Self, PredictionError> {
        if let Some(p) = &law.predictor {
            return discrete_predictor(p, h);
        }
        let d = discretize(&law.lti.a, &law.lti.b, h)
            .map_err(|e| PredictionError::Unstable(format!("the controller at h = {h}: {e}")))?;
        let (nc, nu) = (d.phi.nrows(), law.lti.c.nrows());
        Ok(DiscreteController {
            lti: Lti::new(d.phi, d.gamma_hold, law.lti.c.clone(), law.lti.d.clone()),
            commands: 0,
            g_u: DMatrix::zeros(nc, 0),
            k_u: DMatrix::zeros(nu, 0),
        })
    }
}

impl DiscreteController {
    /// The controller as a master of `order` runs it, as a controller of the Gauss–Seidel form
    /// (`u_k = C ξ_k + D y_k`) on a state of its own: for [`Order::ControllerFirst`]
    /// `u_k = C (Φ ξ_k + Γ y_k) + D y_k`; for [`Order::Jacobi`] the input it holds, `y_{k−1}`,
    /// joins its state. A predictor is told the order, which makes its loop a Gauss–Seidel one
    /// ([`told_the_order`]): it comes here in that order only.
    fn in_order(self, order: Order) -> Self {
        debug_assert!(self.commands == 0 || order == Order::GaussSeidel);
        let k = &self.lti;
        let lti = match order {
            Order::GaussSeidel => return self,
            Order::ControllerFirst => {
                Lti::new(k.a.clone(), k.b.clone(), &k.c * &k.a, &k.c * &k.b + &k.d)
            }
            Order::Jacobi => {
                let (n, m, p) = (k.a.nrows(), k.b.ncols(), k.c.nrows());
                let mut a = DMatrix::zeros(n + m, n + m);
                a.view_mut((0, 0), (n, n)).copy_from(&k.a);
                let mut b = DMatrix::zeros(n + m, m);
                b.view_mut((0, 0), (n, m)).copy_from(&k.b);
                b.view_mut((n, 0), (m, m)).fill_with_identity();
                let mut c = DMatrix::zeros(p, n + m);
                c.view_mut((0, 0), (p, n)).copy_from(&k.c);
                c.view_mut((0, n), (p, m)).copy_from(&k.d);
                Lti::new(a, b, c, DMatrix::zeros(p, m))
            }
        };
        let nc = lti.a.nrows();
        DiscreteController {
            lti,
            commands: 0,
            g_u: DMatrix::zeros(nc, 0),
            k_u: DMatrix::zeros(self.k_u.nrows(), 0),
        }
    }
}

/// A predictor (`fmu-controller`'s runtime) at a step `h`, predicting over
/// `θ = max(τ, h) = d h + ε` (`0 ≤ ε < h`, [`linsys::predictor::predicted_delay`]). At `t_k` the commands in
/// flight are `u_{k−1} … u_{k−d}` whole and the first `ε` of `u_{k−d−1}`:
/// `I_k = Σ_{j<d} e^{A jh} G(h) u_{k−1−j} + e^{A dh} G(ε) u_{k−d−1}` (`G(ℓ) = ∫₀^ℓ e^{As} ds B`).
///
/// `ξ` has two kinds of rows. The **command's own filters** (the rows `B_ξu` drives: the
/// unmodelled-delay weight) are kept in controller time, `φ(t)` the filter of the commands up to
/// `t`, which is exactly the design state's part `θ` ahead (those states and the car's do not
/// drive each other, so `e^{Aθ}` does not mix them); the **rest** follows the car, driven by
/// `y_k − D_yu u_{k−r}` held and the force as the actuators apply it (`u_{k−d−1}` until
/// `t_k + ε`, then `u_{k−d}`; `u_{k−r}` the command whose force `y_k` carries, [`read_lag`]).
/// The command is `u = K̃ z + K_φ φ`, `z = e^{Aθ} x + I` the design state predicted `θ` ahead,
/// `K̃` the gain without the filters' columns, `x = S_y y + S_ξ ξ`: `u = K_x ξ + K_y y + K̃ I`.
///
/// Over the step the controller runs the design's loop on its model: the prediction moves on
/// as the model says with the command sent, `ż = A z + B u_k`, and the filters take the command
/// the design gives at every instant, `φ̇ = A_φ φ + B_φ (K̃ z + K_φ φ)`. The hold never enters
/// the filters' own loop, which is the gain's fastest (−2000 rad/s): driving `φ` by the held
/// command instead made `delay_sf` unstable at every step above 1.1 ms (a hold of `h` cannot
/// follow a mode faster than about `2 / h`). Over `[0, h]` with `w = [ξ; z]`:
/// `ẇ = Ā w + B̄ [y_k; u_{k−r}; u_a; u_k]`, one Van Loan exponential per part of the step.
fn discrete_predictor(p: &PredictorLaw, h: f64) -> Result<DiscreteController, PredictionError> {
    let theta = predicted_delay(p.delay, h);
    // At least one whole step (`θ ≥ h`): `u_k` acts only from the next step on, and the
    // inputs carry the force of the oldest command in flight (`u_{k−d}`, or `u_{k−d−1}` when
    // the delayed command changes mid-step).
    let (d, eps) = whole_steps(theta, h);
    debug_assert!(d >= 1, "θ = {theta} below one step {h}");
    let fail = |e| PredictionError::Unstable(format!("the predictor at h = {h}: {e}"));
    let r = &p.reconstruction;
    let (nxi, nu, n, ny) = (r.a_xi.nrows(), p.k.nrows(), p.a.nrows(), r.b_xi.ncols());
    let own = own_filters(p);
    let m = PredictionMatrices::new(&blocks(p, &own), theta).map_err(fail)?;
    let (cy, cr, ca, cu) = PredictionMatrices::columns(ny, nu);
    let full = discretize(&m.a_bar, &m.b_bar, h).map_err(fail)?;
    let applied = m.b_bar.columns(ca, nu).into_owned();
    let late = discretize(&m.a_bar, &applied, h - eps).map_err(fail)?;
    let early = discretize(&m.a_bar, &applied, eps).map_err(fail)?;
    let top = |x: &DMatrix<f64>, c0: usize, cols: usize| x.view((0, c0), (nxi, cols)).into_owned();
    // `z(t_k) = Z_ξ ξ + Z_y y + Σ_j M_j c_j`, the commands in flight `I_k = Σ_j M_j c_j`.
    let g = discretize(&p.a, &p.b, h).map_err(fail)?.gamma_hold;
    let g_eps = discretize(&p.a, &p.b, eps).map_err(fail)?.gamma_hold;
    let step = expm(&(&p.a * h)).map_err(fail)?;
    let commands = d + usize::from(eps > 0.0);
    debug_assert_eq!(commands, read_lag(theta, d, eps));
    let phi_on_z = full.phi.view((0, nxi), (nxi, n)).into_owned();
    let mut k_u = DMatrix::zeros(nu, commands * nu);
    let mut g_u = DMatrix::zeros(nxi, commands * nu);
    let mut age = DMatrix::identity(n, n);
    for j in 0..commands {
        let in_flight = &age * if j < d { &g } else { &g_eps };
        k_u.columns_mut(j * nu, nu)
            .copy_from(&(&m.k_tilde * &in_flight));
        g_u.columns_mut(j * nu, nu)
            .copy_from(&(&phi_on_z * &in_flight));
        age = &step * age;
    }
    // The command whose force the inputs carry, and the applied force: the one taking over at
    // `t_k + ε` (`u_{k−d}`) after it, the one before (`u_{k−d−1}`) until then.
    let mut on_read = g_u.columns_mut((commands - 1) * nu, nu);
    on_read += top(&full.gamma_hold, cr, nu);
    if eps > 0.0 {
        let mut on_early = g_u.columns_mut(d * nu, nu);
        on_early += top(&(&late.phi * &early.gamma_hold), 0, nu);
    }
    let mut on_late = g_u.columns_mut((d - 1) * nu, nu);
    on_late += top(&late.gamma_hold, 0, nu);
    // `u_k` itself goes into the prediction; `z(t_k)` and the substitution
    // `u_k = K_x ξ + K_y y + K_u c`.
    let on_sent = top(&full.gamma_hold, cu, nu);
    let phi = full.phi.view((0, 0), (nxi, nxi)) + &phi_on_z * &m.z_xi + &on_sent * &m.k_xi;
    let gamma = top(&full.gamma_hold, cy, ny) + &phi_on_z * &m.z_y + &on_sent * &m.k_y;
    g_u += &on_sent * &k_u;
    Ok(DiscreteController {
        lti: Lti::new(phi, gamma, m.k_xi, m.k_y),
        commands,
        g_u,
        k_u,
    })
}

/// `p`'s blocks, its command's own filters `own` ([`own_filters`]).
fn blocks<'a>(p: &'a PredictorLaw, own: &'a [(usize, usize, f64)]) -> PredictorBlocks<'a> {
    let r = &p.reconstruction;
    PredictorBlocks {
        a: &p.a,
        b: &p.b,
        k: &p.k,
        s_y: &r.s_y,
        s_xi: &r.s_xi,
        a_xi: &r.a_xi,
        b_xi: &r.b_xi,
        b_xiu: &r.b_xiu,
        d_yu: &r.d_yu,
        own,
    }
}

/// The command's own filters of a predictor: `(row j of ξ, design state i, s)` for each row
/// that the command drives (`B_ξu`), which `S_ξ` reads into that one state (`x_i = s ξ_j`).
/// They drive no other state and no other drives them (the controller FMU refuses a file where
/// they do).
pub(crate) fn own_filters(p: &PredictorLaw) -> Vec<(usize, usize, f64)> {
    let r = &p.reconstruction;
    (0..r.a_xi.nrows())
        .filter(|&j| r.b_xiu.row(j).iter().any(|v| *v != 0.0))
        .filter_map(|j| {
            let i = (0..r.s_xi.nrows()).find(|&i| r.s_xi[(i, j)] != 0.0)?;
            Some((j, i, r.s_xi[(i, j)]))
        })
        .collect()
}

/// Which past command `u_{k−j}` the plant's outputs at `t_k` carry the force of: with no delay
/// the previous one (a master sets the new command after reading), else the one sent at
/// `t_k − θ` (at a whole number of steps the one taking over at `t_k`).
fn read_lag(theta: f64, d: usize, eps: f64) -> usize {
    if theta == 0.0 {
        1
    } else {
        d + usize::from(eps > 0.0)
    }
}

/// `θ = d h + ε`, `0 ≤ ε < h`: `(d, ε)`, a delay within `10⁻⁹ h` of a whole number of steps
/// taken as whole, as the controller FMU's runtime takes it.
fn whole_steps(theta: f64, h: f64) -> (usize, f64) {
    let d = (theta / h + 1e-9).floor().max(0.0) as usize;
    let eps = (theta - d as f64 * h).max(0.0);
    (d, if eps < 1e-9 * h { 0.0 } else { eps })
}

/// The loop at conditions and a communication step, ready to be evaluated at any frequency.
pub struct SampledLoop {
    car: WeightedCar,
    step: f64,
    /// `l1 + l2` [m]: the rear wheels see the front track `wheelbase / V` later.
    wheelbase: f64,
    /// `θ − h ⌊θ / h⌋`: where in a step the delayed command changes.
    eps: f64,
    /// The closed loop at the sampling instants, road samples in, `[x_k; v_a; v_b; recorded]`
    /// out: the car's state, the held inputs before and after `t_k + ε`, and the weighted
    /// figures' signals as the plant outputs them at `t_k`.
    instants: HessenbergResponse,
    /// `(Φ(ε), Γ(ε))`: the car over the first part of the step.
    first: (DMatrix<f64>, DMatrix<f64>),
    /// Power forms over `[0, ε)` (none when `ε = 0`) and `[ε, h)`.
    forms: (FactoredForms, FactoredForms),
    /// The spectral radius of the loop at the sampling instants (below 1).
    radius: f64,
    /// The loop's poles at the sampling instants: its resonances guide the frequency grid.
    poles: Vec<C64>,
}

/// The loop at the sampling instants before its power forms: what [`SampledLoop::new`],
/// [`spectral_radius`] and [`step_check`] share.
struct Instants {
    car: WeightedCar,
    step: f64,
    wheelbase: f64,
    eps: f64,
    first: (DMatrix<f64>, DMatrix<f64>),
    lti: Lti,
    radius: f64,
    poles: Vec<C64>,
}

/// The spectral radius at the sampling instants of the loop a master runs at `step` (`≥ 1`:
/// unstable), without the power forms [`SampledLoop::new`] adds: the check of a step alone.
pub fn spectral_radius(
    law: Option<&ControlLaw>,
    conditions: Conditions,
    step: f64,
) -> Result<f64, PredictionError> {
    Ok(Instants::new(law, conditions, step, Order::GaussSeidel)?.radius)
}

impl Instants {
    fn new(
        law: Option<&ControlLaw>,
        conditions: Conditions,
        step: f64,
        order: Order,
    ) -> Result<Self, PredictionError> {
        if !(step > 0.0 && step.is_finite()) {
            return Err(PredictionError::Unstable(format!(
                "a communication step must be > 0, got {step}"
            )));
        }
        let (told, conditions, order, read_before) = told_the_order(law, conditions, step, order);
        let law = told.as_ref().or(law);
        let mut conditions = conditions;
        if let Some(rho_min) = law.and_then(|l| l.accommodation) {
            for rho in conditions.effectiveness.iter_mut() {
                *rho /= rho.clamp(rho_min, 1.0);
            }
        }
        let p = &conditions.params;
        let outputs = plant_outputs_at(&conditions);
        let car = WeightedCar::new(p, &outputs, conditions.actuator_bandwidth_hz);
        let h = step;
        let theta = conditions.delay;
        let (d, eps) = whole_steps(theta, h);
        let fail = |e| PredictionError::Unstable(format!("the car at h = {h}: {e}"));
        let full = discretize(&car.a, &car.b, h).map_err(fail)?;
        let first = discretize(&car.a, &car.b, eps).map_err(fail)?;
        let rest = discretize(&car.a, &car.b, h - eps).map_err(fail)?;
        // The forces of the command held from `t_k + ε` reach the end of the step through
        // `Γ_f(h − ε)`, those of the one before through `Φ(h − ε) Γ_f(ε)`.
        let na = car.order();
        let gamma_late = rest.gamma_hold.columns(N_ROAD, N_ACTUATORS).into_owned();
        let gamma_early = &rest.phi * first.gamma_hold.columns(N_ROAD, N_ACTUATORS);
        let gamma_road = full.gamma_hold.columns(0, N_ROAD).into_owned();
        let rho = DMatrix::from_diagonal(&DVector::from_column_slice(&conditions.effectiveness));

        let controller = law
            .map(|l| DiscreteController::new(l, h).map(|k| k.in_order(order)))
            .transpose()?;
        let nc = controller.as_ref().map_or(0, |k| k.lti.order());
        // The plant's outputs read at `t_k` carry the force of the command `lag_read` back.
        let lag_read = read_lag(theta, d, eps);
        // Commands kept: `u_{k−1} … u_{k−depth}` (`lag_read ≤ d + 1`), and as many as the
        // controller reads.
        let depth = (d + 1).max(controller.as_ref().map_or(0, |k| k.commands));
        let nu = N_ACTUATORS;
        let n = na + nc + depth * nu;
        let (xi0, hist0) = (na, na + nc);
        // Linear forms over the state `s_k = [x; ξ; u_{k−1} … u_{k−depth}]` and the road
        // sample `r_k`: (on s, on r).
        let zero = |rows: usize| (DMatrix::zeros(rows, n), DMatrix::zeros(rows, N_ROAD));
        let past = |j: usize| {
            let mut f = zero(nu);
            f.0.view_mut((0, hist0 + (j - 1) * nu), (nu, nu))
                .fill_with_identity();
            f
        };
        // What the plant outputs at `t_k`: `C x + D_r r + D_u ρ u_{k−lag_read}`, or with
        // lagging actuators `C x + D_r r + D_u f` (their forces, states).
        let read = |rows: &SensorRows| {
            let (mut on_s, _) = zero(rows.c.nrows());
            on_s.view_mut((0, 0), (rows.c.nrows(), N_STATES))
                .copy_from(&rows.c);
            match car.forces_at {
                Some(at) => on_s
                    .view_mut((0, at), (rows.c.nrows(), N_ACTUATORS))
                    .copy_from(&rows.d_u),
                None => on_s += &rows.d_u * &rho * past(lag_read).0,
            }
            (on_s, rows.d_r.clone())
        };
        let mut a_cl = DMatrix::zeros(n, n);
        let mut b_cl = DMatrix::zeros(n, N_ROAD);
        let u_now = match (&controller, law) {
            (Some(k), Some(law)) => {
                // y_k as read; u_k = C ξ + D y_k + K_u c_k.
                let names: Vec<&str> = law.inputs.iter().map(|s| s.as_str()).collect();
                let (y_s, y_r) = read(&sensor_rows(&outputs, &names)?);
                let lti = &k.lti;
                let mut u_s = &lti.d * &y_s;
                let mut on_xi = u_s.view_mut((0, xi0), (nu, nc));
                on_xi += &lti.c;
                let u_r = &lti.d * &y_r;
                // ξ_{k+1} = Φ_c ξ + Γ_c y_k + G_u c_k.
                let mut rows = a_cl.rows_mut(xi0, nc);
                rows += &lti.b * &y_s;
                let mut own = a_cl.view_mut((xi0, xi0), (nc, nc));
                own += &lti.a;
                let sent = k.commands * nu;
                let mut on_sent = a_cl.view_mut((xi0, hist0), (nc, sent));
                on_sent += &k.g_u;
                let mut on_sent = u_s.view_mut((0, hist0), (nu, sent));
                on_sent += &k.k_u;
                b_cl.rows_mut(xi0, nc).copy_from(&(&lti.b * &y_r));
                (u_s, u_r)
            }
            _ => zero(nu),
        };
        let lagged = |j: usize| if j == 0 { u_now.clone() } else { past(j) };
        let (early, late) = (lagged(d + 1), lagged(d));
        // x_{k+1} = Φ x + Γ_r r + Γ_early ρ u_{k−d−1} + Γ_late ρ u_{k−d}.
        let (ge, gl) = (&gamma_early * &rho, &gamma_late * &rho);
        a_cl.view_mut((0, 0), (na, na)).copy_from(&full.phi);
        let mut rows = a_cl.rows_mut(0, na);
        rows += &ge * &early.0 + &gl * &late.0;
        b_cl.rows_mut(0, na)
            .copy_from(&(gamma_road + &ge * &early.1 + &gl * &late.1));
        // The commands move one place back, `u_k` first.
        a_cl.rows_mut(hist0, nu).copy_from(&u_now.0);
        b_cl.rows_mut(hist0, nu).copy_from(&u_now.1);
        for j in 1..depth {
            a_cl.view_mut((hist0 + j * nu, hist0 + (j - 1) * nu), (nu, nu))
                .fill_with_identity();
        }
        let poles = crate::numerics::eig::eigenvalues(&a_cl);
        let radius = crate::numerics::eig::max_or_nan(0.0, poles.iter().map(|z| z.norm()));
        // Out: x_k (the meter's states included), then the held inputs `[r; ρ u]` before and
        // after `t_k + ε`, then the accelerations the meter weights as the plant outputs them
        // at `t_k` (with the force it applies then; `recorded`).
        let mut c_out = DMatrix::zeros(na + 2 * N_HELD + 3, n);
        let mut d_out = DMatrix::zeros(na + 2 * N_HELD + 3, N_ROAD);
        let (mut recorded_s, recorded_r) = read(&sensor_rows(&outputs, &WEIGHTED_SIGNALS)?);
        if read_before && car.forces_at.is_none() {
            // Recorded with the force before the one the controller is corrected to.
            let d_u = sensor_rows(&outputs, &WEIGHTED_SIGNALS)?.d_u * &rho;
            recorded_s += &d_u * (past(lag_read + 1).0 - past(lag_read).0);
        }
        let at = na + 2 * N_HELD;
        c_out.rows_mut(at, 3).copy_from(&recorded_s);
        d_out.rows_mut(at, 3).copy_from(&recorded_r);
        c_out.view_mut((0, 0), (na, na)).fill_with_identity();
        for (k, part) in [&early, &late].iter().enumerate() {
            let at = na + k * N_HELD;
            d_out
                .view_mut((at, 0), (N_ROAD, N_ROAD))
                .fill_with_identity();
            c_out.rows_mut(at + N_ROAD, nu).copy_from(&(&rho * &part.0));
            d_out.rows_mut(at + N_ROAD, nu).copy_from(&(&rho * &part.1));
        }
        Ok(Instants {
            wheelbase: p.l1 + p.l2,
            step: h,
            car,
            eps,
            first: (first.phi, first.gamma_hold),
            lti: Lti::new(a_cl, b_cl, c_out, d_out),
            radius,
            poles,
        })
    }
}

impl SampledLoop {
    /// `law = None` is the passive car. A loop unstable at the sampling instants is refused.
    /// The master's order is the default one ([`Order::GaussSeidel`]).
    pub fn new(
        law: Option<&ControlLaw>,
        conditions: Conditions,
        step: f64,
    ) -> Result<Self, PredictionError> {
        Self::in_order(law, conditions, step, Order::GaussSeidel)
    }

    /// [`Self::new`] as a master of `order` runs the loop.
    pub fn in_order(
        law: Option<&ControlLaw>,
        conditions: Conditions,
        step: f64,
        order: Order,
    ) -> Result<Self, PredictionError> {
        Self::of(Instants::new(law, conditions, step, order)?, N_CHANNELS)
    }

    /// The loop at its instants with the power forms of the first `channels` figures (in
    /// [`N_CHANNELS`]' order).
    fn of(i: Instants, channels: usize) -> Result<Self, PredictionError> {
        let (h, eps, radius) = (i.step, i.eps, i.radius);
        if radius.is_nan() || radius >= 1.0 {
            return Err(PredictionError::Unstable(format!(
                "spectral radius {radius} at the sampling instants (step {h} s)"
            )));
        }
        let forms = (
            FactoredForms::new(&if eps > 0.0 {
                i.car.power_forms(eps, h, channels)?
            } else {
                Vec::new()
            }),
            FactoredForms::new(&i.car.power_forms(h - eps, h, channels)?),
        );
        Ok(SampledLoop {
            instants: HessenbergResponse::new(&i.lti),
            wheelbase: i.wheelbase,
            car: i.car,
            step: h,
            eps,
            first: i.first,
            forms,
            radius,
            poles: i.poles,
        })
    }

    /// The spectral radius of the loop at the sampling instants (below 1: checked by `new`).
    pub fn radius(&self) -> f64 {
        self.radius
    }

    /// Adds the time-averaged power of each figure over a step, from `q`: the loop's response
    /// at the sampling instants (`instants`' outputs) to a road vector.
    fn power(&self, q: &DVector<C64>, out: &mut [f64]) {
        let na = self.car.order();
        let x0 = q.rows(0, na);
        let (va, vb) = (q.rows(na, N_HELD), q.rows(na + N_HELD, N_HELD));
        let stack = |x: DVector<C64>, v: nalgebra::DVectorView<C64>| {
            let mut s = DVector::zeros(na + N_HELD);
            s.rows_mut(0, na).copy_from(&x);
            s.rows_mut(na, N_HELD).copy_from(&v);
            s
        };
        let c = |m: &DMatrix<f64>| m.map(|v| C64::new(v, 0.0));
        let start_b = if self.eps > 0.0 {
            self.forms.0.add(&stack(x0.into_owned(), va), out);
            c(&self.first.0) * x0 + c(&self.first.1) * va
        } else {
            x0.into_owned()
        };
        self.forms.1.add(&stack(start_b, vb), out);
    }

    /// The values the plant outputs at the communication points, as complex amplitudes: a road
    /// `r e^{jωt}` (unit road velocity on a track: [`crate::predict::continuous::track_input`]) gives
    /// samples `Re(A e^{jω t_k})` once settled. `a_seat`, `alpha_roll`, `alpha_pitch` (as read
    /// with the force the plant applies at `t_k`), then its vibration meter's
    /// [`METER_OUTPUTS`] (filter states: no force reaches them at once).
    pub fn recorded(&self, omega: f64, road: &DVector<C64>) -> [C64; 6] {
        let road = DMatrix::from_column_slice(road.len(), 1, road.as_slice());
        let q = self
            .instants
            .applied(C64::from_polar(1.0, omega * self.step), &road)
            .column(0)
            .into_owned();
        let at = self.recorded_row();
        let meter = self.meter(&q);
        [q[at], q[at + 1], q[at + 2], meter[0], meter[1], meter[2]]
    }

    /// Where the signals as read start among `instants`' outputs.
    fn recorded_row(&self) -> usize {
        self.car.order() + 2 * N_HELD
    }

    /// The meter's outputs at `t_k` from the loop's response there.
    fn meter(&self, q: &DVector<C64>) -> [C64; METER_OUTPUTS.len()] {
        let x = q.rows(0, self.car.order());
        std::array::from_fn(|k| {
            self.car
                .m
                .row(k)
                .columns(0, self.car.order())
                .iter()
                .zip(x.iter())
                .map(|(c, x)| x * *c)
                .sum()
        })
    }

    /// The figures on `road`: time-averaged over the steps, and the weighted ones as a master
    /// records them (the meter's outputs at the communication points). One pass over the
    /// frequencies for both (a solve at the sampling instants per frequency and track).
    pub fn figures(&self, road: &ComfortRoad) -> HeldFigures {
        self.figures_on(road, HELD_FREQUENCIES)
    }

    /// [`Self::figures`] on `even` evenly spaced frequencies and the graded ones.
    fn figures_on(&self, road: &ComfortRoad, even: usize) -> HeldFigures {
        let mean_squares = road_integral(road, even, &self.resonances(road), |omega, _| {
            let mut out = [0.0; N_CHANNELS + METER_OUTPUTS.len()];
            for q in self.tracks(road, omega) {
                let (power, recorded) = out.split_at_mut(N_CHANNELS);
                self.power(&q, power);
                for (o, y) in recorded.iter_mut().zip(self.meter(&q)) {
                    *o += y.norm_sqr();
                }
            }
            out
        });
        let mut time_averaged = [0.0; N_CHANNELS];
        time_averaged.copy_from_slice(&mean_squares[..N_CHANNELS]);
        HeldFigures {
            time_averaged: Figures::from_mean_squares(time_averaged),
            recorded_weighted: [0, 1, 2].map(|k| mean_squares[N_CHANNELS + k].sqrt()),
        }
    }

    /// The loop's response at the sampling instants (`instants`' outputs) to a unit road
    /// velocity on each track at `omega`, the rear wheels `wheelbase / V` behind.
    fn tracks(&self, road: &ComfortRoad, omega: f64) -> [DVector<C64>; 2] {
        let delay = self.wheelbase / road.speed;
        let tracks = DMatrix::from_columns(&[0, 1].map(|t| track_input(t, omega, delay)));
        let at_z = self
            .instants
            .applied(C64::from_polar(1.0, omega * self.step), &tracks);
        [0, 1].map(|t| at_z.column(t).into_owned())
    }

    /// Its resonances over the road's band, for the frequency grid.
    fn resonances(&self, road: &ComfortRoad) -> Vec<(f64, f64)> {
        resonances(&self.poles, self.step, road.band_hz().1)
    }

    /// [`Self::figures`]' `W_k` seat alone: a loop made by [`step_check`] has the seat's power
    /// forms only.
    fn seat(&self, road: &ComfortRoad) -> HeldSeat {
        let resonances = self.resonances(road);
        let [felt, recorded] = road_integral(road, HELD_FREQUENCIES, &resonances, |omega, _| {
            let mut out = [0.0; 2];
            for q in self.tracks(road, omega) {
                self.power(&q, &mut out[..1]);
                out[1] += self.meter(&q)[0].norm_sqr();
            }
            out
        });
        let (f_lo, f_hi) = road.band_hz();
        HeldSeat {
            predicted_wk_rms_seat_m_s2: felt.max(0.0).sqrt(),
            recorded_wk_rms_seat_m_s2: recorded.sqrt(),
            sharpest_resonance: resonances
                .into_iter()
                .filter(|(f, _)| (f_lo..=f_hi).contains(f))
                .map(|(f, width)| Resonance {
                    frequency_hz: f,
                    relative_half_width: width / f,
                })
                .min_by(|a, b| a.relative_half_width.total_cmp(&b.relative_half_width)),
        }
    }
}

/// A held loop's `W_k` seat RMS on the design road ([`step_check`]).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct HeldSeat {
    /// Time-averaged over the steps: what the occupant feels.
    pub predicted_wk_rms_seat_m_s2: f64,
    /// Of the plant's weighted output sampled at the communication points, as a master
    /// measures it.
    pub recorded_wk_rms_seat_m_s2: f64,
    /// The loop's sharpest resonance over the road's band: a hold near its limit leaves a
    /// mode barely damped, whose narrow peak can dominate the figures.
    pub sharpest_resonance: Option<Resonance>,
}

/// A resonance of a loop at the sampling instants, seen at a road frequency.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Resonance {
    pub frequency_hz: f64,
    /// Its half-width over its frequency (the damping ratio of a lightly damped mode).
    pub relative_half_width: f64,
}

/// One communication step checked ([`step_check`]).
#[derive(Debug, Clone, Copy)]
pub struct StepCheck {
    /// At the sampling instants (`≥ 1`: unstable).
    pub radius: f64,
    /// Where asked and stable, the held `W_k` seat on the road.
    pub seat: Option<HeldSeat>,
}

/// The loop a master runs at `step`: its spectral radius, and with `seat_on` a road and the
/// loop stable, its held `W_k` seat there, from one power form instead of
/// [`SampledLoop::figures`]' `N_CHANNELS`.
pub fn step_check(
    law: Option<&ControlLaw>,
    conditions: Conditions,
    step: f64,
    seat_on: Option<&ComfortRoad>,
) -> Result<StepCheck, PredictionError> {
    order_check(law, conditions, step, Order::GaussSeidel, seat_on)
}

/// [`step_check`] as a master of `order` runs the loop.
pub fn order_check(
    law: Option<&ControlLaw>,
    conditions: Conditions,
    step: f64,
    order: Order,
    seat_on: Option<&ComfortRoad>,
) -> Result<StepCheck, PredictionError> {
    let i = Instants::new(law, conditions, step, order)?;
    let radius = i.radius;
    let seat = match seat_on {
        Some(road) if radius < 1.0 => Some(SampledLoop::of(i, 1)?.seat(road)),
        _ => None,
    };
    Ok(StepCheck { radius, seat })
}

/// A predictor told the master's `order` (the controller FMU's `master_order`) as a
/// Gauss–Seidel loop. In the controller-first order the command read after a step is the one
/// computed at its start from the same inputs: the Gauss–Seidel loop. In the Jacobi order the
/// command read at `t_k` is the one computed at `t_{k−1}`, predicted over the delay told plus
/// the step: a Gauss–Seidel master's loop with every command a step later, the plant's delay and
/// the predictor's a step longer (at a constant step). With no delay the plant is read before
/// the master sets the command taking over, so its outputs carry the one before, one further
/// back than that loop's (`true`: recorded so); the controller reads them corrected by the
/// difference's feedthrough, as that loop's (`fmu-controller`). Any other law, or order, as it
/// is.
fn told_the_order(
    law: Option<&ControlLaw>,
    conditions: Conditions,
    step: f64,
    order: Order,
) -> (Option<ControlLaw>, Conditions, Order, bool) {
    match (law, order) {
        (Some(l), Order::ControllerFirst) if l.predictor.is_some() => {
            (None, conditions, Order::GaussSeidel, false)
        }
        (Some(l), Order::Jacobi) if l.predictor.is_some() => {
            let mut later = l.clone();
            if let Some(p) = later.predictor.as_mut() {
                p.delay += step;
            }
            let shifted = Conditions {
                delay: conditions.delay + step,
                ..conditions
            };
            let before = conditions.delay == 0.0;
            (Some(later), shifted, Order::GaussSeidel, before)
        }
        _ => (None, conditions, order, false),
    }
}

/// The predicted figures of a held loop ([`SampledLoop::figures`]).
#[derive(Debug, Clone, PartialEq)]
pub struct HeldFigures {
    /// Time-averaged over the steps: what the occupant feels.
    pub time_averaged: Figures,
    /// `W_k` seat, `W_e` roll and pitch RMS of the plant's weighted outputs
    /// ([`METER_OUTPUTS`]) sampled at the communication points, as a master measures them.
    pub recorded_weighted: [f64; 3],
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::predict::continuous::{plant_outputs, predict};
    use crate::shipping::design::ComfortDesign;

    fn road() -> ComfortRoad {
        ComfortDesign::from_json(include_str!("../../designs/comfort.json"))
            .unwrap()
            .road
    }

    /// A skyhook-like controller with a state: the corners push against a low-passed body
    /// heave velocity, the seat against its own velocity and its acceleration (a plant output
    /// with direct feedthrough of the seat force).
    fn skyhook() -> ControlLaw {
        let mut c = DMatrix::zeros(N_ACTUATORS, 1);
        let mut d = DMatrix::zeros(N_ACTUATORS, 3);
        for i in 0..4 {
            c[(i, 0)] = -3000.0;
        }
        d[(4, 1)] = -400.0;
        d[(4, 2)] = -20.0;
        ControlLaw {
            lti: Lti::new(
                DMatrix::from_element(1, 1, -60.0),
                DMatrix::from_row_slice(1, 3, &[60.0, 0.0, 0.0]),
                c,
                d,
            ),
            inputs: vec!["x[9]".into(), "x[12]".into(), "a_seat".into()],
            predictor: None,
            accommodation: None,
        }
    }

    /// As the step shrinks the sampled-data loop becomes the continuous one: the time-averaged
    /// figures converge to [`crate::predict::continuous`]'s (first order in `h`, a hold being a delay of
    /// half a step). At every step the samples of the plant's weighted outputs have the time
    /// average's mean square (the meter integrates the jumps a held force makes). With ideal
    /// actuators and with 5 Hz first-order ones (the lag exact in the frequency domain there,
    /// states of the car here: two computations).
    #[test]
    fn as_the_step_shrinks_the_sampled_prediction_tends_to_the_continuous_one() {
        for lag in [None, Some(5.0)] {
            let mut c = Conditions::nominal(vehicle::VehicleParams::default());
            c.actuator_bandwidth_hz = lag;
            converges_to_the_continuous_loop(c);
        }
    }

    fn converges_to_the_continuous_loop(c: Conditions) {
        let road = road();
        let law = skyhook();
        let continuous = predict(Some(&law), c, &road).unwrap();
        let passive = predict(None, c, &road).unwrap();
        assert!(continuous.wk_rms_seat_m_s2 < 0.8 * passive.wk_rms_seat_m_s2);
        let rel = |a: f64, b: f64| (a / b - 1.0).abs();
        let gap = |h: f64| {
            let held = SampledLoop::new(Some(&law), c, h).unwrap().figures(&road);
            let (f, recorded) = (held.time_averaged, held.recorded_weighted);
            let sampled = rel(recorded[0], f.wk_rms_seat_m_s2)
                .max(rel(recorded[1], f.we_rms_roll_rad_s2))
                .max(rel(recorded[2], f.we_rms_pitch_rad_s2));
            (
                rel(f.wk_rms_seat_m_s2, continuous.wk_rms_seat_m_s2)
                    .max(rel(f.we_rms_roll_rad_s2, continuous.we_rms_roll_rad_s2))
                    .max(rel(f.rms_force_n[0], continuous.rms_force_n[0]))
                    .max(rel(f.rms_stroke_m[2], continuous.rms_stroke_m[2]))
                    .max(rel(
                        f.rms_tire_load_ratio[3],
                        continuous.rms_tire_load_ratio[3],
                    )),
                sampled,
            )
        };
        let (coarse, fine) = (gap(1e-3), gap(1e-5));
        println!(
            "lag {:?} Hz: relative gaps (to the continuous loop, samples to time average) at 1 ms \
             {coarse:?}, at 0.01 ms {fine:?}",
            c.actuator_bandwidth_hz
        );
        assert!(fine.0 < 2e-3, "{fine:?}");
        assert!(coarse.0 > 10.0 * fine.0, "{coarse:?} against {fine:?}");
        assert!(coarse.1 < 1e-4 && fine.1 < 1e-4, "{coarse:?} {fine:?}");
    }

    /// The power forms (Van Loan) against a quadrature of `|m e^{Fs} q|²` over the hold.
    #[test]
    fn power_forms_are_the_time_average_of_the_held_response() {
        let p = vehicle::VehicleParams::default();
        let car = WeightedCar::new(&p, &plant_outputs(&p), None);
        let (h, tau) = (1e-3, 0.7e-3);
        let forms = car.power_forms(tau, h, N_CHANNELS).unwrap();
        let n = car.order() + N_HELD;
        let f = car.held_generator();
        let q = DVector::from_fn(n, |i, _| ((i * 37 % 11) as f64 - 5.0) * 0.1);
        // Simpson's rule on 2000 intervals.
        let m = 2000;
        let mut acc = DVector::zeros(N_CHANNELS);
        for i in 0..=m {
            let s = tau * i as f64 / m as f64;
            let w = if i == 0 || i == m {
                1.0
            } else if i % 2 == 1 {
                4.0
            } else {
                2.0
            };
            let z = &car.m * (expm(&(&f * s)).unwrap() * &q);
            acc += z.map(|v| v * v) * w;
        }
        acc *= tau / (3.0 * m as f64) / h;
        for (c, form) in forms.iter().enumerate() {
            let exact = (form * &q).dot(&q);
            assert!(
                (exact - acc[c]).abs() <= 1e-9 * acc[c].abs().max(1e-300),
                "figure {c}: form {exact:e}, quadrature {:e}",
                acc[c]
            );
        }
    }

    /// The factored forms give the dense forms' quadratic values to rounding, with few rows.
    #[test]
    fn factored_power_forms_equal_the_dense_ones() {
        let p = vehicle::VehicleParams::default();
        let car = WeightedCar::new(&p, &plant_outputs(&p), None);
        let n = car.order() + N_HELD;
        for (tau, h) in [(0.7e-3, 1e-3), (1e-3, 1e-3), (0.2e-3, 1e-3), (5e-3, 5e-3)] {
            let forms = car.power_forms(tau, h, N_CHANNELS).unwrap();
            let factored = FactoredForms::new(&forms);
            assert!(
                factored.weights.len() < N_CHANNELS * n / 3,
                "{} rows of {}",
                factored.weights.len(),
                N_CHANNELS * n
            );
            for seed in 0..5 {
                let x = DVector::from_fn(n, |i, _| {
                    let k = (i * 37 + seed * 101) % 23;
                    C64::new(k as f64 - 11.0, (k * k % 7) as f64 - 3.0) * 0.01
                });
                let mut got = [0.0; N_CHANNELS];
                factored.add(&x, &mut got);
                let (re, im) = (x.map(|v| v.re), x.map(|v| v.im));
                for (c, form) in forms.iter().enumerate() {
                    let dense = (form * &re).dot(&re) + (form * &im).dot(&im);
                    assert!(
                        (got[c] - dense).abs() <= 1e-12 * dense.abs(),
                        "τ = {tau}, channel {c}: factored {:e}, dense {dense:e}",
                        got[c]
                    );
                }
            }
        }
        assert!(FactoredForms::new(&[]).weights.is_empty());
    }

    /// The check of a step gives [`SampledLoop::figures`]' `W_k` seat (time-averaged and as
    /// recorded) from its own seat-only forms, with the car's force
    /// changing between whole steps (a delay of 2.6 steps) and not; and no figure where the
    /// loop is unstable.
    #[test]
    fn a_step_check_is_the_held_figures_seat() {
        let road = road();
        let nominal = Conditions::nominal(vehicle::VehicleParams::default());
        for (h, delay) in [(1e-3, 0.0), (1e-3, 2.6e-3), (5e-3, 0.0), (5e-3, 13e-3)] {
            let c = Conditions { delay, ..nominal };
            let t = std::time::Instant::now();
            let full = SampledLoop::new(Some(&skyhook()), c, h)
                .unwrap()
                .figures(&road);
            let t_full = t.elapsed();
            let t = std::time::Instant::now();
            let check = step_check(Some(&skyhook()), c, h, Some(&road)).unwrap();
            let t_check = t.elapsed();
            let seat = check.seat.unwrap();
            let pairs = [
                (
                    seat.predicted_wk_rms_seat_m_s2,
                    full.time_averaged.wk_rms_seat_m_s2,
                ),
                (seat.recorded_wk_rms_seat_m_s2, full.recorded_weighted[0]),
            ];
            println!("{h} s, delay {delay} s: {pairs:?}, {t_check:?} against {t_full:?}");
            for (got, want) in pairs {
                assert!(
                    (got - want).abs() < 1e-12 * want,
                    "{h}, {delay}: {got} vs {want}"
                );
            }
            assert_eq!(
                check.radius,
                spectral_radius(Some(&skyhook()), c, h).unwrap()
            );
            assert!(step_check(Some(&skyhook()), c, h, None)
                .unwrap()
                .seat
                .is_none());
        }
        let mut stiff = skyhook();
        stiff.lti.d[(4, 1)] = -2e5;
        let check = step_check(Some(&stiff), nominal, 5e-3, Some(&road)).unwrap();
        assert!(check.radius >= 1.0 && check.seat.is_none(), "{check:?}");
    }

    /// The held figures on [`HELD_FREQUENCIES`] equal those on eight times as many, at steps
    /// with and without a delay between whole steps, at a quarter of the design speed (the
    /// wheelbase delay's oscillation fastest across the band) and at it.
    #[test]
    fn held_figures_on_the_coarser_grid_equal_a_fine_one() {
        let nominal = Conditions::nominal(vehicle::VehicleParams::default());
        let mut worst: f64 = 0.0;
        for speed in [5.0, 20.0] {
            let mut road = road();
            road.speed = speed;
            for (h, delay) in [(1e-3, 0.0), (5e-3, 13e-3)] {
                let held =
                    SampledLoop::new(Some(&skyhook()), Conditions { delay, ..nominal }, h).unwrap();
                let (coarse, fine) = (
                    held.figures(&road),
                    held.figures_on(&road, 8 * (HELD_FREQUENCIES - 1) + 1),
                );
                let (a, b) = (coarse.time_averaged, fine.time_averaged);
                let pairs = [
                    (a.wk_rms_seat_m_s2, b.wk_rms_seat_m_s2),
                    (a.we_rms_roll_rad_s2, b.we_rms_roll_rad_s2),
                    (a.rms_stroke_m[0], b.rms_stroke_m[0]),
                    (a.rms_tire_load_ratio[3], b.rms_tire_load_ratio[3]),
                    (a.rms_force_n[4], b.rms_force_n[4]),
                    (coarse.recorded_weighted[0], fine.recorded_weighted[0]),
                ];
                for (x, y) in pairs {
                    worst = worst.max((x / y - 1.0).abs());
                }
            }
        }
        println!(
            "held figures on {HELD_FREQUENCIES} points against eight times as many: {worst:e}"
        );
        assert!(worst < 1e-7, "{worst:e}");
    }

    /// An unstable sampled loop is refused, not integrated: a seat damper of 2·10⁵ N s/m
    /// (a pole near −2500 rad/s with the seat's mass) is stable at a fine step and unstable
    /// at 5 ms.
    #[test]
    fn a_loop_unstable_at_its_step_is_refused() {
        let c = Conditions::nominal(vehicle::VehicleParams::default());
        let mut law = skyhook();
        law.lti.d[(4, 1)] = -2e5;
        assert!(SampledLoop::new(Some(&law), c, 1e-5).is_ok());
        match SampledLoop::new(Some(&law), c, 5e-3) {
            Err(PredictionError::Unstable(why)) => {
                assert!(why.contains("spectral radius"), "{why}")
            }
            other => panic!("expected a refusal, got {:?}", other.map(|_| ())),
        }
    }
}
