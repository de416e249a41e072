//! The generalised plant of the comfort designs: the car on an ISO 8608 road, its seat and body
//! accelerations weighted as ISO 2631-1 says people feel them.
//!
//! * **Road** (ISO 8608, waviness 2): each track's vertical velocity is white noise of one-sided
//!   PSD `S = 4π² n₀² G_d(n₀) V` ([`vehicle::road::iso_velocity_psd`]): `w` is unit white
//!   noise (two-sided PSD 1), `ż_f = −a z_f + √(S/2) w`. The small corner `a = 2π n_lo V` is the
//!   lower edge `n_lo` of the road FMU's spatial band: below it neither road has content. The
//!   left and right tracks are independent; the rear wheels see the front track `T = L/V` later,
//!   here a Padé approximant of `e^{−sT}` of the design's order (or, `independent`, four
//!   independent tracks). The certificates use the exact delay ([`crate::predict::continuous`]).
//! * **Comfort output** `z`: the seat's vertical acceleration weighted by `W_k`, the body's roll
//!   and pitch acceleration (the seat's, which has no rotation of its own) weighted by `W_e` and
//!   the ISO 2631-1 comfort factors 0.63 and 0.40 m/rad ([`vehicle::iso2631`]): `E|z|²` is the
//!   square of the vibration total value `a_v`, `E z₁²` that of the W_k RMS seat acceleration.
//!   The weightings are realised without their 100 Hz band-limit (within 0.1 % below 16 Hz).
//! * **Limits**, each over its limit, not part of the comfort norm: suspension strokes over
//!   `stroke_max`, the tyres' spring force `k_t (z_u − z_r)` over the static load (the dynamic
//!   tyre load less its damper part `c_t (ż_u − ż_r)`, which white road velocity makes
//!   unbounded in variance), and the forces over their limits.
//!
//! State `x = [car (16); road; W_k seat; W_e roll; W_e pitch]`, control `u` the five forces in N.

use crate::shipping::design::{ComfortDesign, ComfortRoad, RearWheels};
use crate::thesis::generalized::row;
use nalgebra::DMatrix;
use std::ops::Range;
use vehicle::iso2631::{Weighting, PITCH_FACTOR, ROLL_FACTOR};
use vehicle::model::{
    coord, corner_positions, OutputRow, StateSpace, StaticEquilibrium, ACTUATORS, CORNERS,
    N_ACTUATORS, N_DOF, N_ROAD, N_STATES, N_WHEELS,
};
use vehicle::VehicleParams;

/// The accelerations the comfort output weights, in the order of `z`, with their factors.
pub const COMFORT_OUTPUTS: [(&str, f64); 3] = [
    ("a_seat", 1.0),
    ("alpha_roll", ROLL_FACTOR),
    ("alpha_pitch", PITCH_FACTOR),
];

/// The weighting of each comfort output.
fn comfort_weighting(i: usize) -> Weighting {
    if i == 0 {
        Weighting::wk()
    } else {
        Weighting::we()
    }
}

/// `[A B; C D]` of a linear system, for the small building blocks here.
pub type Abcd = [DMatrix<f64>; 4];

/// The `[p/p]` Padé approximant of `e^{−sT}`: `Σ c_k (−sT)^k / Σ c_k (sT)^k`,
/// `c_k = (2p − k)! p! / ((2p)! k! (p − k)!)`, realised for `T = 1` in controllable canonical
/// form with its states scaled (below), and scaled in time (`A/T`, `B/T`).
pub fn pade(order: usize, delay: f64) -> Abcd {
    let p = order;
    if p == 0 {
        return [
            DMatrix::zeros(0, 0),
            DMatrix::zeros(0, 1),
            DMatrix::zeros(1, 0),
            DMatrix::from_element(1, 1, 1.0),
        ];
    }
    let fact = |k: usize| (1..=k).map(|i| i as f64).product::<f64>();
    let c: Vec<f64> = (0..=p)
        .map(|k| fact(2 * p - k) * fact(p) / (fact(2 * p) * fact(k) * fact(p - k)))
        .collect();
    // Monic denominator s^p + d_{p−1} s^{p−1} + … + d_0 (T = 1), numerator likewise.
    let lead = c[p];
    let den: Vec<f64> = (0..p).map(|k| c[k] / lead).collect();
    let sign = if p.is_multiple_of(2) { 1.0 } else { -1.0 };
    let num: Vec<f64> = (0..p)
        .map(|k| c[k] * (-1f64).powi(k as i32) / lead)
        .collect();
    let d0 = sign; // leading numerator coefficient (−1)^p c_p / c_p
    let mut a = DMatrix::zeros(p, p);
    for i in 0..p - 1 {
        a[(i, i + 1)] = 1.0;
    }
    for k in 0..p {
        a[(p - 1, k)] = -den[k];
    }
    let mut b = DMatrix::zeros(p, 1);
    b[(p - 1, 0)] = 1.0;
    let cm = DMatrix::from_fn(1, p, |_, k| num[k] - d0 * den[k]);
    // The companion form's coefficients grow like ω^{p−k}, ω = d_0^{1/p} the size of the roots
    // (order 8: d_0 = 5·10⁸, and the road velocity `C A ξ` of a car model reached 10¹² s⁻²,
    // which made its predictor's exponentials lose eight digits). The states scaled by
    // `ω^{k−p}` (`x = S x̃`) have every coefficient of order ω.
    let omega = den[0].abs().powf(1.0 / p as f64);
    let s = |i: usize| omega.powi(i as i32 - p as i32);
    let a = DMatrix::from_fn(p, p, |i, j| a[(i, j)] * s(j) / s(i));
    let b = DMatrix::from_fn(p, 1, |i, _| b[(i, 0)] / s(i));
    let cm = DMatrix::from_fn(1, p, |_, j| cm[(0, j)] * s(j));
    [a / delay, b / delay, cm, DMatrix::from_element(1, 1, d0)]
}

/// Where each part of the state lives.
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    pub car: Range<usize>,
    pub road: Range<usize>,
    /// The long waves' states, within `road` ([`LONG_WAVE_ORDER`] of them; empty without long
    /// waves). No sensor reads them apart from the roughness: a state feedback's realisation
    /// has no estimate of them ([`crate::comfort::controllers::reconstruction`]).
    pub waves: Range<usize>,
    /// One range per comfort output ([`COMFORT_OUTPUTS`]).
    pub filters: Vec<Range<usize>>,
    /// The delay weight's states, one per actuator ([`ComfortPlant::with_delay_weight`]).
    pub weight: Option<Range<usize>>,
    /// The frame's nine states ([`ComfortPlant::with_frame`]).
    pub frame: Option<Range<usize>>,
    /// The actuators' forces, one state per actuator ([`ComfortPlant::with_actuator_lag`]).
    pub actuators: Option<Range<usize>>,
}

/// The road model's numbers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoadModel {
    /// `√(S/2)`: road velocity [m/s] per unit of `w`.
    pub sigma: f64,
    /// `a` [rad/s].
    pub corner: f64,
    /// Wheelbase delay `T = (L1 + L2)/V` \[s\].
    pub delay: f64,
    pub rear: RearWheels,
    /// Long waves `(b [rad/s], RMS height [m])` under every wheel (`road_system`).
    pub long_waves: Option<(f64, f64)>,
}

impl RoadModel {
    /// The road model of the design plant for the car `p` on `road`.
    pub fn new(road: &ComfortRoad, p: &VehicleParams) -> Self {
        RoadModel {
            sigma: (0.5 * vehicle::road::iso_velocity_psd(road.iso_class.0, road.speed)).sqrt(),
            corner: 2.0 * std::f64::consts::PI * vehicle::road::ISO_BAND.0 * road.speed,
            delay: (p.l1 + p.l2) / road.speed,
            rear: road.rear_wheels,
            long_waves: road.long_waves.map(|l| {
                let b = 2.0 * std::f64::consts::PI * road.speed / l.wavelength;
                (b, l.height_rms)
            }),
        }
    }
}

/// The comfort design plant: `ẋ = A x + B_w w + B_u u`, `z = C_z x`, limits `l = C_l x + D_lu u`.
#[derive(Debug, Clone)]
pub struct ComfortPlant {
    pub a: DMatrix<f64>,
    pub b_w: DMatrix<f64>,
    /// Per newton.
    pub b_u: DMatrix<f64>,
    /// `[W_k a_seat; 0.63 W_e α_roll; 0.40 W_e α_pitch]` [m/s²].
    pub c_z: DMatrix<f64>,
    /// Each limit signal over its limit.
    pub c_lim: DMatrix<f64>,
    pub d_lim_u: DMatrix<f64>,
    pub limit_names: Vec<String>,
    pub layout: Layout,
    pub road: RoadModel,
    /// The road under the four wheels `r = [z_r; ż_r] = R_x x + R_w w`.
    pub r_x: DMatrix<f64>,
    pub r_w: DMatrix<f64>,
    /// The car's physical output rows (vehicle crate) at this plant's mass.
    pub outputs: Vec<OutputRow>,
    pub sprung_mass: f64,
    /// Each actuator's effectiveness: the force applied per unit command (1 when healthy). It
    /// scales `B_u`'s car and weighting rows and the outputs' `D_u` (accelerometers feel the
    /// applied force), not the delay weight, which the command drives.
    pub effectiveness: [f64; N_ACTUATORS],
    /// The frame a state feedback measures the car from ([`Frame`]; `None`: the equilibrium).
    pub frame: Option<Frame>,
    /// `∂ẋ/∂v_r` (`n × 4`): each state's rate per m/s of road velocity under each wheel (the
    /// tyre dampers, and through them the accelerations the weightings filter). `A` holds it
    /// times the road model's velocity, [`ComfortPlant::prediction_model`] times another.
    pub road_velocity: DMatrix<f64>,
}

/// A frame that follows the road's pose `p = (z, φ, θ)` (the plane through the road heights
/// under the four wheels) below `ω`: `f = F(s) p` with the type-2 low-pass
/// `F(s) = (a₁ s + a₀) / ((s² + 2ζω s + ω²)(s + ω))` ([`Frame::denominator`]), whose error
/// `1 − F` has `s²`, so it follows a ramp with no error, and whose rate `s F` rolls off (a
/// second-order frame's rate passed the road's pose through at every frequency). A state
/// feedback in the frame reads every height (the road's too) and velocity relative to the frame
/// moved rigidly ([`ComfortPlant::with_frame`]). On a constant grade or crossfall the car and
/// the road settle into a rigid pose moving at a constant rate, which the frame follows
/// exactly: the feedback then reads zero and holds no force, where on heights from the
/// equilibrium it held its force limits. The frame reads only the road: it moves no pole of
/// the loop.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// `R` (8 × 3): each coordinate of `q` under a rigid pose `(z_s, φ, θ)` of the car.
    pub rigid: DMatrix<f64>,
    pub omega: f64,
    pub zeta: f64,
}

/// The order of [`Frame`]'s low-pass, per axis.
pub const FRAME_ORDER: usize = 3;

impl Frame {
    /// The damping of [`Frame`]'s low-pass: `1/√2`.
    pub const ZETA: f64 = std::f64::consts::FRAC_1_SQRT_2;

    /// `(F_η, Ḟ_η)`: the frame's pose `f = F_η η` and rate `ḟ = Ḟ_η η` from its states
    /// (three per axis, [`ComfortPlant::with_frame`]).
    pub fn outputs(&self) -> (DMatrix<f64>, DMatrix<f64>) {
        let [a0, a1, _] = self.denominator();
        let m = 3 * FRAME_ORDER;
        let (mut f, mut rate) = (DMatrix::zeros(3, m), DMatrix::zeros(3, m));
        for c in 0..3 {
            let o = FRAME_ORDER * c;
            f[(c, o)] = a0;
            f[(c, o + 1)] = a1;
            rate[(c, o + 1)] = a0;
            rate[(c, o + 2)] = a1;
        }
        (f, rate)
    }

    /// `[a₀, a₁, a₂]` of `F(s)`'s denominator `(s² + 2ζω s + ω²)(s + ω)`; its numerator is
    /// `a₁ s + a₀`.
    pub fn denominator(&self) -> [f64; 3] {
        let (w, d) = (self.omega, 2.0 * self.zeta * self.omega);
        [w * w * w, w * w + d * w, d + w]
    }

    pub fn new(p: &VehicleParams, hz: f64) -> Self {
        let mut rigid = DMatrix::zeros(N_DOF, 3);
        let point = |x: f64, y: f64| [1.0, y, x];
        let mut set = |k: usize, r: [f64; 3]| {
            for (c, v) in r.iter().enumerate() {
                rigid[(k, c)] = *v;
            }
        };
        set(coord::HEAVE, [1.0, 0.0, 0.0]);
        set(coord::ROLL, [0.0, 1.0, 0.0]);
        set(coord::PITCH, [0.0, 0.0, 1.0]);
        set(coord::SEAT, point(p.s2, -p.s1));
        for (i, &(x, y)) in corner_positions(p).iter().enumerate() {
            set(coord::WHEEL[i], point(x, y));
        }
        Frame {
            rigid,
            omega: 2.0 * std::f64::consts::PI * hz,
            zeta: Self::ZETA,
        }
    }
}

/// The order of the long waves' low-pass ([`RoadModel::long_waves`]): steep enough that they
/// add nothing near the body's modes, where the ISO roughness is the road (at order 2 and 0.2 m
/// RMS they were three times the roughness at 1 Hz, and the design paid for it in comfort).
pub const LONG_WAVE_ORDER: usize = 4;

/// The road states and `r = R_x x_r + R_w w`: `(A_r, B_r, R_x, R_w)`, with the long waves'
/// states and input last.
fn road_system(m: &RoadModel) -> Abcd {
    let [ar, br, rx, rw] = roughness_system(m);
    let Some((b, height_rms)) = m.long_waves else {
        return [ar, br, rx, rw];
    };
    let (nr, nw, k) = (ar.nrows(), br.ncols(), LONG_WAVE_ORDER);
    // h = (b / (s + b))^k q' w: a chain of k first-order lags, q' giving h its RMS.
    let mut al = DMatrix::zeros(k, k);
    for i in 0..k {
        al[(i, i)] = -b;
        if i > 0 {
            al[(i, i - 1)] = b;
        }
    }
    let mut bl = DMatrix::zeros(k, 1);
    bl[(0, 0)] = b;
    let unit =
        crate::numerics::riccati::lyapunov(&al, &(&bl * bl.transpose())).expect("a stable chain");
    let q = height_rms / unit[(k - 1, k - 1)].sqrt();
    let bl = bl * q;
    let mut ch = DMatrix::zeros(1, k);
    ch[(0, k - 1)] = 1.0;
    // Front wheels: h and ḣ = C A x + C B w. The rear wheels meet the wave T later: h(t − T)
    // ≈ h − T ḣ (the wave is long: b T ≈ 0.08 at 200 m), its velocity ḣ − T ḧ.
    let t = m.delay;
    let (ca, cb) = (&ch * &al, &ch * &bl);
    let (caa, cab) = (&ca * &al, &ca * &bl);
    let rows = [
        (ch.clone(), DMatrix::zeros(1, 1)),
        (&ca * 1.0, cb.clone()),
        (&ch - &ca * t, DMatrix::zeros(1, 1) - &cb * t),
        (&ca - &caa * t, &cb - &cab * t),
    ];
    let grow = |m: &DMatrix<f64>, r: usize, c: usize| {
        let mut g = DMatrix::zeros(m.nrows() + r, m.ncols() + c);
        g.view_mut((0, 0), m.shape()).copy_from(m);
        g
    };
    let (mut ar, mut br, mut rx, mut rw) = (
        grow(&ar, k, k),
        grow(&br, k, 1),
        grow(&rx, 0, k),
        grow(&rw, 0, 1),
    );
    ar.view_mut((nr, nr), (k, k)).copy_from(&al);
    br.view_mut((nr, nw), (k, 1)).copy_from(&bl);
    for wheel in 0..N_WHEELS {
        let rear = usize::from(wheel >= 2) * 2;
        let (height, velocity) = (&rows[rear], &rows[rear + 1]);
        rx.view_mut((wheel, nr), (1, k)).copy_from(&height.0);
        rx.view_mut((N_WHEELS + wheel, nr), (1, k))
            .copy_from(&velocity.0);
        rw[(wheel, nw)] = height.1[(0, 0)];
        rw[(N_WHEELS + wheel, nw)] = velocity.1[(0, 0)];
    }
    [ar, br, rx, rw]
}

/// The ISO roughness's road states ([`road_system`] without the long waves).
fn roughness_system(m: &RoadModel) -> Abcd {
    let (s, a) = (m.sigma, m.corner);
    match m.rear {
        RearWheels::Independent => {
            let eye = DMatrix::<f64>::identity(N_WHEELS, N_WHEELS);
            let mut rx = DMatrix::zeros(N_ROAD, N_WHEELS);
            rx.view_mut((0, 0), (4, 4)).copy_from(&eye);
            rx.view_mut((4, 0), (4, 4)).copy_from(&(&eye * -a));
            let mut rw = DMatrix::zeros(N_ROAD, N_WHEELS);
            rw.view_mut((4, 0), (4, 4)).copy_from(&(&eye * s));
            [&eye * -a, &eye * s, rx, rw]
        }
        RearWheels::Pade { order } => {
            let [pa, pb, pc, pd] = pade(order, m.delay);
            let per = 1 + order;
            let nr = 2 * per;
            let (mut ar, mut br) = (DMatrix::zeros(nr, nr), DMatrix::zeros(nr, 2));
            let (mut rx, mut rw) = (DMatrix::zeros(N_ROAD, nr), DMatrix::zeros(N_ROAD, 2));
            let pd = pd[(0, 0)];
            for t in 0..2 {
                let o = t * per;
                // Front height: ż_f = −a z_f + s w; the Padé states ξ̇ = A_p ξ + B_p z_f.
                ar[(o, o)] = -a;
                br[(o, t)] = s;
                ar.view_mut((o + 1, o + 1), (order, order)).copy_from(&pa);
                ar.view_mut((o + 1, o), (order, 1)).copy_from(&pb);
                let (front, rear) = (t, 2 + t);
                rx[(front, o)] = 1.0;
                rx[(N_WHEELS + front, o)] = -a;
                rw[(N_WHEELS + front, t)] = s;
                // Rear height C_p ξ + D_p z_f, its velocity C_p ξ̇ + D_p ż_f.
                rx.view_mut((rear, o + 1), (1, order)).copy_from(&pc);
                rx[(rear, o)] = pd;
                rx.view_mut((N_WHEELS + rear, o + 1), (1, order))
                    .copy_from(&(&pc * &pa));
                rx[(N_WHEELS + rear, o)] = (&pc * &pb)[(0, 0)] - a * pd;
                rw[(N_WHEELS + rear, t)] = s * pd;
            }
            [ar, br, rx, rw]
        }
    }
}

impl ComfortPlant {
    pub fn new(p: &VehicleParams, d: &ComfortDesign) -> Self {
        Self::at_mass(p, d, p.m_s)
    }

    /// The plant of the car `p` with sprung mass `m_s`; the limits stay those of the nominal car
    /// (its static tyre loads), so the plant is affine in `1/m_s` like the car.
    pub fn at_mass(p: &VehicleParams, d: &ComfortDesign, m_s: f64) -> Self {
        let static_load = StaticEquilibrium::new(p).tire_load;
        let car = VehicleParams { m_s, ..*p };
        let ss = StateSpace::new(&car);
        let outputs = vehicle::model::readable_outputs(&car);
        let road = RoadModel::new(&d.road, &car);
        let [ar, br, r_x, r_w] = road_system(&road);
        let nr = ar.nrows();
        let weightings: Vec<Abcd> = (0..COMFORT_OUTPUTS.len())
            .map(|i| comfort_weighting(i).without_low_pass().state_space())
            .collect();
        let nf: usize = weightings.iter().map(|w| w[0].nrows()).sum();
        let n = N_STATES + nr + nf;
        let nw = br.ncols();
        let mut a = DMatrix::zeros(n, n);
        let mut b_w = DMatrix::zeros(n, nw);
        let mut b_u = DMatrix::zeros(n, N_ACTUATORS);
        a.view_mut((0, 0), (N_STATES, N_STATES)).copy_from(&ss.a);
        a.view_mut((0, N_STATES), (N_STATES, nr))
            .copy_from(&(&ss.b_r * &r_x));
        b_w.view_mut((0, 0), (N_STATES, nw))
            .copy_from(&(&ss.b_r * &r_w));
        b_u.view_mut((0, 0), (N_STATES, N_ACTUATORS))
            .copy_from(&ss.b_u);
        a.view_mut((N_STATES, N_STATES), (nr, nr)).copy_from(&ar);
        b_w.view_mut((N_STATES, 0), (nr, nw)).copy_from(&br);
        let layout_car = 0..N_STATES;
        let road_range = N_STATES..N_STATES + nr;
        // A physical output as rows of (x, w, u).
        let out = |name: &str| physical_rows(row(&outputs, name), &r_x, &r_w, n);
        let mut c_z = DMatrix::zeros(COMFORT_OUTPUTS.len(), n);
        let mut filters = Vec::new();
        let mut road_velocity = DMatrix::zeros(n, N_WHEELS);
        road_velocity
            .view_mut((0, 0), (N_STATES, N_WHEELS))
            .copy_from(&ss.b_r.columns(N_WHEELS, N_WHEELS));
        let mut o = N_STATES + nr;
        for (i, ((name, factor), [fa, fb, fc, fd])) in
            COMFORT_OUTPUTS.iter().zip(&weightings).enumerate()
        {
            assert_eq!(fd[(0, 0)], 0.0, "the weightings are strictly proper");
            let m = fa.nrows();
            let (cx, dw, du) = out(name);
            let d_v = DMatrix::from_row_slice(1, N_WHEELS, &row(&outputs, name).d_r[N_WHEELS..]);
            road_velocity
                .view_mut((o, 0), (m, N_WHEELS))
                .copy_from(&(fb * d_v));
            a.view_mut((o, o), (m, m)).copy_from(fa);
            let drive = fb * &cx;
            let mut block = a.view_mut((o, 0), (m, n));
            block += &drive;
            b_w.view_mut((o, 0), (m, nw)).copy_from(&(fb * &dw));
            b_u.view_mut((o, 0), (m, N_ACTUATORS))
                .copy_from(&(fb * &du));
            c_z.view_mut((i, o), (1, m)).copy_from(&(fc * *factor));
            filters.push(o..o + m);
            o += m;
        }
        // Limits.
        let mut limit_names = Vec::new();
        let mut c_lim = DMatrix::zeros(0, n);
        let mut d_lim_u = DMatrix::zeros(0, N_ACTUATORS);
        let mut push = |name: String, c: DMatrix<f64>, du: DMatrix<f64>| {
            c_lim = stack(&c_lim, &c);
            d_lim_u = stack(&d_lim_u, &du);
            limit_names.push(name);
        };
        for c in CORNERS {
            let (cx, _, du) = out(&format!("stroke_{c}"));
            push(format!("stroke_{c}"), cx / d.stroke_max, du);
        }
        for (i, c) in CORNERS.iter().enumerate() {
            let (cx, _, du) = out(&format!("tire_defl_{c}"));
            let scale = p.k_t / static_load[i];
            push(format!("tire_spring_load_{c}"), cx * scale, du * scale);
        }
        if let Some(max) = d.seat_stroke_max {
            let (cx, _, du) = out("stroke_seat");
            push("stroke_seat".into(), cx / max, du / max);
        }
        let limits = [d.u_max, d.u_max, d.u_max, d.u_max, d.u_max_seat];
        for (k, a) in ACTUATORS.iter().enumerate() {
            let mut du = DMatrix::zeros(1, N_ACTUATORS);
            du[(0, k)] = 1.0 / limits[k];
            push(format!("force_{a}"), DMatrix::zeros(1, n), du);
        }
        ComfortPlant {
            a,
            b_w,
            b_u,
            c_z,
            c_lim,
            d_lim_u,
            limit_names,
            layout: Layout {
                car: layout_car,
                waves: match road.long_waves {
                    Some(_) => road_range.end - LONG_WAVE_ORDER..road_range.end,
                    None => road_range.end..road_range.end,
                },
                road: road_range,
                filters,
                weight: None,
                frame: None,
                actuators: None,
            },
            road,
            r_x,
            r_w,
            outputs,
            sprung_mass: m_s,
            effectiveness: [1.0; N_ACTUATORS],
            frame: d.state_feedback_frame_hz.map(|hz| Frame::new(&car, hz)),
            road_velocity,
        }
    }

    pub fn n(&self) -> usize {
        self.a.nrows()
    }

    /// A physical output of the car as rows of this plant's `(x, w, u)`.
    pub fn output(&self, name: &str) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
        let (mut c, d_w, mut d_u) =
            physical_rows(row(&self.outputs, name), &self.r_x, &self.r_w, self.n());
        for (k, rho) in self.effectiveness.iter().enumerate() {
            d_u.column_mut(k).scale_mut(*rho);
        }
        // Behind lagging actuators an output feels the applied force, a state.
        if let Some(forces) = &self.layout.actuators {
            let mut by_force = c.columns_mut(forces.start, forces.len());
            by_force += &d_u;
            d_u.fill(0.0);
        }
        (c, d_w, d_u)
    }

    /// This plant with actuator `k`'s effectiveness multiplied by `rho[k]` (before the delay
    /// weight is added).
    pub fn with_effectiveness(&self, rho: &[f64; N_ACTUATORS]) -> Self {
        assert!(
            self.layout.weight.is_none() && self.layout.actuators.is_none(),
            "scale the effectiveness before adding the delay weight or the actuators' lag"
        );
        let mut g = self.clone();
        for (k, r) in rho.iter().enumerate() {
            g.b_u.column_mut(k).scale_mut(*r);
            g.effectiveness[k] *= r;
        }
        g
    }

    /// The front road heights (left, right) in terms of the state (Padé rear model), or the four
    /// heights (independent rear wheels): what a state-feedback controller must know of the
    /// road, and which it reads as `z_u − tire_defl`.
    pub fn road_height_rows(&self) -> Vec<(usize, usize)> {
        // (state index, wheel) of each road height that is itself a state.
        match self.road.rear {
            RearWheels::Independent => (0..N_WHEELS)
                .map(|k| (self.layout.road.start + k, k))
                .collect(),
            RearWheels::Pade { order } => (0..2)
                .map(|t| (self.layout.road.start + t * (1 + order), t))
                .collect(),
        }
    }
}

/// A norm-bounded uncertainty of the plant: `p = Δ q`, `‖Δ‖ ≤ 1` (a real parameter, or an LTI
/// system of gain ≤ 1 at every frequency), entering as `B_p p`, with `q = C_q x + D_q u`.
#[derive(Debug, Clone)]
pub struct Channel {
    pub name: &'static str,
    pub b_p: DMatrix<f64>,
    /// When `p` acts as an applied force `f = F p` (`B_p = B_u F` on the plant's rows), `F`:
    /// accelerometers then feel it too, and a closed loop must route it like a force.
    pub applied_force: Option<DMatrix<f64>>,
    pub c_q: DMatrix<f64>,
    pub d_q: DMatrix<f64>,
}

impl Channel {
    /// One channel per column of `p` (row of `q`): a block-diagonal uncertainty, each block with
    /// its own multiplier (less conservative than one full block when the `p`'s are independent
    /// parameters, such as one effectiveness per actuator).
    pub fn split(&self) -> Vec<Channel> {
        (0..self.b_p.ncols())
            .map(|k| Channel {
                name: self.name,
                b_p: self.b_p.columns(k, 1).into_owned(),
                applied_force: self
                    .applied_force
                    .as_ref()
                    .map(|f| f.columns(k, 1).into_owned()),
                c_q: self.c_q.rows(k, 1).into_owned(),
                d_q: self.d_q.rows(k, 1).into_owned(),
            })
            .collect()
    }
}

/// `W(s) = c τ s / (1 + τ s / d)` covers the envelope `max_{θ ≤ τ} |e^{−jωθ} − 1|` of every
/// delay up to `τ`, `2 sin(min(ωτ, π)/2)`: `(c, d)` with `d = 3` and the smallest `c` that covers
/// on a log grid of `ωτ` over 10⁻³…10³ (1.0163…, times 1.001). A second-order cover could be
/// tighter; at `d = 3` the first-order one over-bounds by under 2 % below `ωτ = 1`.
pub fn delay_cover() -> (f64, f64) {
    let d = 3.0;
    let c = (0..=6000)
        .map(|i| 10f64.powf(-3.0 + i as f64 * 1e-3))
        .map(|x| {
            2.0 * (x.min(std::f64::consts::PI) / 2.0).sin() * (1.0 + (x / d).powi(2)).sqrt() / x
        })
        .fold(0.0, f64::max);
    (c * 1.001, d)
}

impl ComfortPlant {
    /// The actuators' unmodelled delay, up to `tau`, as the input-multiplicative uncertainty
    /// `u_applied = (I + Δ W) u` with `W` the [`delay_cover`], and the plant with `W`'s states
    /// (one per actuator, driven by the command `u`): `(plant, channel)`. `q` and `p` are in
    /// units of each actuator's force limit, so one multiplier serves all five.
    /// This plant with `m` states appended, zero everywhere until the caller fills them in.
    fn with_states_appended(&self, m: usize) -> ComfortPlant {
        let n = self.n();
        let grow = |x: &DMatrix<f64>, rows: usize, cols: usize| {
            let mut y = DMatrix::zeros(rows, cols);
            y.view_mut((0, 0), x.shape()).copy_from(x);
            y
        };
        ComfortPlant {
            a: grow(&self.a, n + m, n + m),
            b_w: grow(&self.b_w, n + m, self.b_w.ncols()),
            b_u: grow(&self.b_u, n + m, self.b_u.ncols()),
            c_z: grow(&self.c_z, self.c_z.nrows(), n + m),
            c_lim: grow(&self.c_lim, self.c_lim.nrows(), n + m),
            road_velocity: grow(&self.road_velocity, n + m, N_WHEELS),
            ..self.clone()
        }
    }

    pub fn with_delay_weight(
        &self,
        tau: f64,
        u_limit: &[f64; N_ACTUATORS],
    ) -> (ComfortPlant, Channel) {
        let (c, d) = delay_cover();
        let (n, m) = (self.n(), N_ACTUATORS);
        let mut g = self.with_states_appended(m);
        for k in 0..m {
            g.a[(n + k, n + k)] = -d / tau;
            g.b_u[(n + k, k)] = d / tau;
        }
        g.layout.weight = Some(n..n + m);
        // p enters where u does, except the weight's own states (the controller's: the applied
        // force does not drive them), in units of the limits.
        let limits = DMatrix::from_fn(m, m, |i, j| if i == j { u_limit[i] } else { 0.0 });
        let mut b_p = &g.b_u * &limits;
        b_p.rows_mut(n, m).fill(0.0);
        let per_limit = DMatrix::from_fn(m, m, |i, j| if i == j { 1.0 / u_limit[i] } else { 0.0 });
        let mut c_q = DMatrix::zeros(m, n + m);
        c_q.view_mut((0, n), (m, m))
            .copy_from(&(&per_limit * (-c * d)));
        let channel = Channel {
            name: "actuator delay",
            b_p,
            // Behind lagging actuators `p` drives their forces, not the car.
            applied_force: g.layout.actuators.is_none().then_some(limits),
            c_q,
            d_q: per_limit * (c * d),
        };
        (g, channel)
    }
}

impl ComfortPlant {
    /// This plant behind first-order actuators of `bandwidth_hz` (the plant FMU's
    /// `actuator_bandwidth`): each applied force a state, `ḟ = ω_a (u − f)`, driving what the
    /// command drove (the car, the weightings and, through [`ComfortPlant::output`], the
    /// accelerometers and load cells), the command driving the forces only. A force limit stays
    /// a limit of the command; every other limit that read the command reads the force.
    pub fn with_actuator_lag(&self, bandwidth_hz: f64) -> ComfortPlant {
        assert!(
            self.layout.weight.is_none() && self.layout.frame.is_none(),
            "the actuators' lag comes before the delay weight and the frame"
        );
        assert!(self.layout.actuators.is_none(), "one lag");
        let (n, m) = (self.n(), N_ACTUATORS);
        let w = 2.0 * std::f64::consts::PI * bandwidth_hz;
        let mut g = self.with_states_appended(m);
        g.a.view_mut((0, n), (n, m)).copy_from(&self.b_u);
        g.b_u.fill(0.0);
        for k in 0..m {
            g.a[(n + k, n + k)] = -w;
            g.b_u[(n + k, k)] = w;
        }
        for (i, name) in self.limit_names.iter().enumerate() {
            if !name.starts_with("force_") {
                let du = g.d_lim_u.row(i).into_owned();
                let mut by_force = g.c_lim.view_mut((i, n), (1, m));
                by_force += &du;
                g.d_lim_u.row_mut(i).fill(0.0);
            }
        }
        g.layout.actuators = Some(n..n + m);
        g
    }
}

impl ComfortPlant {
    /// This plant with its frame's states `η` appended ([`Frame`]; itself where it has none),
    /// and `T`, the relative state `x̃ = T [x; η] = x − E_f f − E_ḟ ḟ` (a gain `K` on this
    /// plant's state is `K T` on the other's).
    ///
    /// The road's pose `p = P x` is the least-squares plane through the road heights under the
    /// wheels; per axis `η̇₁ = η₂`, `η̇₂ = η₃`, `η̇₃ = −a₀ η₁ − a₁ η₂ − a₂ η₃ + p`,
    /// `f = a₀ η₁ + a₁ η₂`, `ḟ = a₀ η₂ + a₁ η₃` ([`Frame::outputs`]). `E` is the state of the car and road in the rigid pose `f` moving
    /// at `ḟ`: the car's heights `R f` and velocities `R ḟ`, the road heights under the wheels
    /// `R f`, and the other road states (the rear road's preview) their steady state under
    /// those heights rising at a constant rate, `M h + A_pp⁻¹ M ḣ` with `M = −A_pp⁻¹ A_ph`
    /// (exact for a Padé track, which passes a ramp with its delay). The frame's states are
    /// the design model's (driven by its road states): a controller realising `K T`
    /// reconstructs them from the road it reads, and they move no pole of its loop.
    pub fn with_frame(&self) -> (ComfortPlant, DMatrix<f64>) {
        let Some(frame) = &self.frame else {
            return (self.clone(), DMatrix::identity(self.n(), self.n()));
        };
        let n = self.n();
        let rigid = &frame.rigid;
        let wheels = rigid.select_rows(&coord::WHEEL);
        let plane = (wheels.transpose() * &wheels)
            .try_inverse()
            .expect("the wheels span a plane")
            * wheels.transpose();
        let mut pose = DMatrix::zeros(3, n);
        pose.view_mut((0, self.layout.road.start), (3, self.layout.road.len()))
            .copy_from(&(&plane * self.r_x.rows(0, N_WHEELS)));
        let heights = self.road_height_rows();
        let hs: Vec<usize> = heights.iter().map(|(s, _)| *s).collect();
        let others: Vec<usize> = self
            .layout
            .road
            .clone()
            .filter(|s| !hs.contains(s))
            .collect();
        let (mut e_f, mut e_d) = (DMatrix::zeros(n, 3), DMatrix::zeros(n, 3));
        for i in 0..N_DOF {
            e_f.row_mut(i).copy_from(&rigid.row(i));
            e_d.row_mut(N_DOF + i).copy_from(&rigid.row(i));
        }
        for (state, wheel) in &heights {
            e_f.row_mut(*state)
                .copy_from(&rigid.row(coord::WHEEL[*wheel]));
        }
        if !others.is_empty() {
            let a_pp = self.a.select_rows(&others).select_columns(&others);
            let a_ph = self.a.select_rows(&others).select_columns(&hs);
            let inv = a_pp.try_inverse().expect("the road's preview is stable");
            let m = -&inv * a_ph * e_f.select_rows(&hs);
            let dm = &inv * &m;
            for (j, state) in others.iter().enumerate() {
                e_f.row_mut(*state).copy_from(&m.row(j));
                e_d.row_mut(*state).copy_from(&dm.row(j));
            }
        }
        // Per axis, in controllable form: `η̇₁ = η₂`, `η̇₂ = η₃`,
        // `η̇₃ = −a₀ η₁ − a₁ η₂ − a₂ η₃ + p`, `f = a₀ η₁ + a₁ η₂`, `ḟ = a₀ η₂ + a₁ η₃`.
        let [a0, a1, a2] = frame.denominator();
        let m = 3 * FRAME_ORDER;
        let (f_eta, fd_eta) = frame.outputs();
        let mut g = self.with_states_appended(m);
        for c in 0..3 {
            let [e1, e2, e3] = [0, 1, 2].map(|i| FRAME_ORDER * c + i);
            g.a[(n + e1, n + e2)] = 1.0;
            g.a[(n + e2, n + e3)] = 1.0;
            g.a[(n + e3, n + e1)] = -a0;
            g.a[(n + e3, n + e2)] = -a1;
            g.a[(n + e3, n + e3)] = -a2;
            g.a.view_mut((n + e3, 0), (1, n)).copy_from(&pose.row(c));
        }
        g.layout.frame = Some(n..n + m);
        let mut t = DMatrix::zeros(n, n + m);
        t.view_mut((0, 0), (n, n)).fill_with_identity();
        t.view_mut((0, n), (n, m))
            .copy_from(&(-&e_f * f_eta - &e_d * fd_eta));
        (g, t)
    }
}

impl ComfortPlant {
    /// The model a predictor of this plant runs: its `A`, except that with a frame
    /// ([`ComfortPlant::with_frame`]) the road heights that are states rise at the frame's rate
    /// (`ż_f = R ḟ` under each front wheel) instead of reverting to zero at `a` (1.4 rad/s at
    /// 20 m/s), and the car's tyre dampers (and the accelerations) feel that road velocity.
    /// The design road forgets a height: predicted from 30 m up a long grade it sank under the
    /// car (and the tyre dampers felt it sink), and the predictor held its force limits. Here a
    /// car and road in a rigid pose climbing at a constant rate, with the frame settled on it,
    /// is a solution: predicted exactly, so on a grade the gain in the frame reads zero. The
    /// road is the predictor's guess either way; nothing the controller does reaches it.
    pub fn prediction_model(&self) -> DMatrix<f64> {
        let mut a = self.a.clone();
        let (Some(frame), Some(states)) = (&self.frame, &self.layout.frame) else {
            return a;
        };
        let (n, road) = (self.n(), self.layout.road.clone());
        let (_, rate) = frame.outputs();
        for (state, wheel) in self.road_height_rows() {
            a.row_mut(state).fill(0.0);
            a.view_mut((state, states.start), (1, states.len()))
                .copy_from(&(frame.rigid.row(coord::WHEEL[wheel]) * &rate));
        }
        // The road velocity under the wheels: the heights' rate under the new road rows,
        // against the road model's.
        let heights = self.r_x.rows(0, N_WHEELS);
        let velocity = heights * a.rows(road.start, road.len());
        let mut before = DMatrix::zeros(N_WHEELS, n);
        before
            .view_mut((0, road.start), (N_WHEELS, road.len()))
            .copy_from(&self.r_x.rows(N_WHEELS, N_WHEELS));
        a += &self.road_velocity * (velocity - before);
        a
    }
}

/// `(c, d_w, d_u)` of a physical output row with the road `r = R_x x + R_w w`.
fn physical_rows(
    r: &OutputRow,
    r_x: &DMatrix<f64>,
    r_w: &DMatrix<f64>,
    n: usize,
) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
    let d_r = DMatrix::from_row_slice(1, N_ROAD, &r.d_r);
    let mut c = DMatrix::zeros(1, n);
    c.view_mut((0, 0), (1, N_STATES))
        .copy_from(&DMatrix::from_row_slice(1, N_STATES, &r.c));
    c.view_mut((0, N_STATES), (1, r_x.ncols()))
        .copy_from(&(&d_r * r_x));
    (
        c,
        &d_r * r_w,
        DMatrix::from_row_slice(1, N_ACTUATORS, &r.d_u),
    )
}

pub(crate) fn stack(top: &DMatrix<f64>, bottom: &DMatrix<f64>) -> DMatrix<f64> {
    let mut m = DMatrix::zeros(top.nrows() + bottom.nrows(), top.ncols());
    m.view_mut((0, 0), top.shape()).copy_from(top);
    m.view_mut((top.nrows(), 0), bottom.shape())
        .copy_from(bottom);
    m
}

/// Evaluate a state-space system's frequency response at `s = jω` (helper for tests and
/// certificates): `C (sI − A)⁻¹ B + D`.
pub fn frequency_response(sys: &Abcd, omega: f64) -> DMatrix<nalgebra::Complex<f64>> {
    transfer_at(sys, nalgebra::Complex::new(0.0, omega))
}

/// A state-space system's transfer matrix at any `s` that is not a pole:
/// `C (sI − A)⁻¹ B + D`.
pub fn transfer_at(sys: &Abcd, s: nalgebra::Complex<f64>) -> DMatrix<nalgebra::Complex<f64>> {
    use nalgebra::Complex;
    let [a, b, c, d] = sys;
    let n = a.nrows();
    let cx = |m: &DMatrix<f64>| m.map(|v| Complex::new(v, 0.0));
    let m = DMatrix::<Complex<f64>>::identity(n, n) * s - cx(a);
    let x = m.lu().solve(&cx(b)).expect("sI − A is invertible");
    cx(c) * x + cx(d)
}

/// The limits of the five actuators \[N\].
pub fn force_limits(d: &ComfortDesign) -> [f64; N_ACTUATORS] {
    [d.u_max, d.u_max, d.u_max, d.u_max, d.u_max_seat]
}

/// The sprung-mass range as a channel around the plant at the harmonic-mean mass (the middle of
/// the range in `1/m_s`, in which the plant is affine): `[A B_u](m) = centre + H δ E`,
/// `δ ∈ [−1, 1]` (`δ = 1` at `mass_min`), rank one (only the heave row of `M⁻¹` depends on the
/// mass). Returns the centre plant with the delay weight, its delay channel and the mass channel.
pub fn mass_channel(p: &VehicleParams, d: &ComfortDesign) -> (ComfortPlant, Channel, Channel) {
    let limits = force_limits(d);
    let at = |m: f64| ComfortPlant::at_mass(p, d, m).with_delay_weight(d.unmodelled_delay, &limits);
    let centre_mass = 2.0 / (1.0 / d.mass_min + 1.0 / d.mass_max);
    let ((light, _), (heavy, _)) = (at(d.mass_min), at(d.mass_max));
    let (centre, delay) = at(centre_mass);
    let (n, m) = (centre.n(), centre.b_u.ncols());
    let system = |g: &ComfortPlant| {
        let mut s = DMatrix::zeros(n, n + m);
        s.view_mut((0, 0), (n, n)).copy_from(&g.a);
        s.view_mut((0, n), (n, m)).copy_from(&g.b_u);
        s
    };
    let half = (system(&light) - system(&heavy)) * 0.5;
    let svd = half.svd(true, true);
    let (u, vt) = (svd.u.expect("requested"), svd.v_t.expect("requested"));
    let (k, s0) = svd
        .singular_values
        .iter()
        .enumerate()
        .fold((0, 0.0), |a, (i, s)| if *s > a.1 { (i, *s) } else { a });
    let h = u.column(k) * s0.sqrt();
    let e = DMatrix::from_row_slice(1, n + m, (vt.row(k) * s0.sqrt()).transpose().as_slice());
    (
        centre,
        delay,
        Channel {
            name: "sprung mass",
            b_p: DMatrix::from_column_slice(n, 1, h.as_slice()),
            applied_force: None,
            c_q: e.columns(0, n).into_owned(),
            d_q: e.columns(n, m).into_owned(),
        },
    )
}

/// The actuators' effectiveness box `ρᵢ ∈ [rho_min, 1]` as a channel around its centre
/// `ρ_c = (1 + rho_min)/2`: the applied force `(ρ_c + r δᵢ) uᵢ`, `r = (1 − rho_min)/2`,
/// `|δᵢ| ≤ 1` (one real parameter per actuator; one multiplier serves them, `q` and `p` in units
/// of the limits). Returns the plant at the centre with the delay weight, its delay channel and
/// the fault channel.
pub fn fault_channel(g0: &ComfortPlant, d: &ComfortDesign) -> (ComfortPlant, Channel, Channel) {
    let limits = force_limits(d);
    let (rc, r) = crate::thesis::fault::FaultBox {
        rho_min: d.fault_rho_min,
    }
    .center_radius();
    let centre = g0.with_effectiveness(&[rc; N_ACTUATORS]);
    let (g, delay) = centre.with_delay_weight(d.unmodelled_delay, &limits);
    let (n, m) = (g.n(), g.b_u.ncols());
    let lim = DMatrix::from_fn(m, m, |i, j| if i == j { limits[i] } else { 0.0 });
    let mut b_p = g0.b_u.clone() * &lim;
    b_p = stack(&b_p, &DMatrix::zeros(n - g0.n(), m));
    let channel = Channel {
        name: "actuator effectiveness",
        b_p,
        // B_u is the centre's, ρ_c times the car's: p's force is lim p / ρ_c in its units.
        applied_force: Some(&lim / rc),
        c_q: DMatrix::zeros(m, n),
        d_q: lim.try_inverse().expect("limits > 0") * r,
    };
    (g, delay, channel)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::numerics::hinf_norm::{Analysis, Lti};
    use nalgebra::Complex;

    pub(crate) fn design() -> ComfortDesign {
        ComfortDesign::from_json(include_str!("../../designs/comfort.json")).unwrap()
    }

    #[test]
    fn pade_approximant_matches_the_delay_at_low_frequency() {
        for order in 1..=4 {
            let sys = pade(order, 0.12);
            for f in [0.1, 0.5, 1.0] {
                let w = 2.0 * std::f64::consts::PI * f;
                let g = frequency_response(&sys, w)[(0, 0)];
                let exact = Complex::from_polar(1.0, -w * 0.12);
                // All-pass, and the phase error of [p/p] grows as (ωT)^(2p+1).
                assert!((g.norm() - 1.0).abs() < 1e-12, "order {order}");
                let tol = (w * 0.12f64).powi(2 * order as i32 + 1) * 0.1 + 1e-12;
                assert!(
                    (g - exact).norm() < tol,
                    "order {order}, {f} Hz: {g} vs {exact}"
                );
            }
        }
    }

    /// The plant's frequency response from the left track's noise to the comfort output equals
    /// its composition from independent parts: the car's response (vehicle crate) to the left
    /// wheels' road, the road filter `√(S/2)/(jω + a)` and the Padé delay to the rear wheel, and
    /// the weighting times its comfort factor.
    #[test]
    fn comfort_plant_is_the_car_on_the_road_model_weighted() {
        let d = design();
        let p = VehicleParams::default();
        let g = ComfortPlant::new(&p, &d);
        let sys = [
            g.a.clone(),
            g.b_w.clone(),
            g.c_z.clone(),
            DMatrix::zeros(3, g.b_w.ncols()),
        ];
        let ss = StateSpace::new(&p);
        let car_rows = vehicle::model::physical_outputs(&p);
        let order = match d.road.rear_wheels {
            RearWheels::Pade { order } => order,
            RearWheels::Independent => unreachable!("the checked-in design uses Padé"),
        };
        let delay = pade(order, g.road.delay);
        for f in [0.3, 1.2, 4.0, 11.0] {
            let w = 2.0 * std::f64::consts::PI * f;
            let s = Complex::new(0.0, w);
            let plant = frequency_response(&sys, w);
            // Car: C (sI − A)⁻¹ B_r + D_r for each output.
            let car = |name: &str| {
                let r = row(&car_rows, name);
                let c = DMatrix::from_row_slice(1, N_STATES, &r.c);
                let dr = DMatrix::from_row_slice(1, N_ROAD, &r.d_r);
                frequency_response(&[ss.a.clone(), ss.b_r.clone(), c, dr], w)
            };
            let height = Complex::new(g.road.sigma, 0.0) / (s + g.road.corner);
            let rear = frequency_response(&delay, w)[(0, 0)];
            for (i, (name, factor)) in COMFORT_OUTPUTS.iter().enumerate() {
                let h = car(name);
                // Left track: FL (index 0) now, RL (index 2) delayed; heights and velocities.
                let left =
                    (h[(0, 0)] + h[(0, 4)] * s + (h[(0, 2)] + h[(0, 6)] * s) * rear) * height;
                let expected = left * comfort_weighting(i).without_low_pass().response(f) * *factor;
                let got = plant[(i, 0)];
                assert!(
                    (got - expected).norm() <= 1e-8 * expected.norm(),
                    "{name} at {f} Hz: {got} vs {expected}"
                );
            }
        }
        // Passive comfort on the design road: finite, and the seat's W_k part of it.
        let passive = Lti::new(
            g.a.clone(),
            g.b_w.clone(),
            g.c_z.clone(),
            DMatrix::zeros(3, 2),
        );
        let seat = passive.select_outputs(&[0]).h2_norm().unwrap();
        let total = passive.h2_norm().unwrap();
        eprintln!("passive on ISO C at 20 m/s (design model): a_v {total:.4}, W_k seat {seat:.4}");
        assert!(seat > 0.3 && seat < total);
    }

    /// Behind first-order actuators every response to the command is the ideal actuators' times
    /// `ω_a / (s + ω_a)`: the comfort outputs, an accelerometer (which felt the command at
    /// once), a load cell, a limit; and a force limit still reads the command.
    #[test]
    fn behind_lagging_actuators_every_response_is_the_ideal_one_lagged() {
        let g = ComfortPlant::new(&VehicleParams::default(), &design());
        let hz = 10.0;
        let lagged = g.with_actuator_lag(hz);
        assert_eq!(lagged.layout.actuators, Some(g.n()..g.n() + N_ACTUATORS));
        let responses = |g: &ComfortPlant, w: f64| {
            let (a_seat, _, a_seat_u) = g.output("sensor_a_seat");
            let (force, _, force_u) = g.output("f_seat");
            let c = stack(&stack(&stack(&g.c_z, &a_seat), &force), &g.c_lim);
            let mut d = DMatrix::zeros(c.nrows(), N_ACTUATORS);
            d.rows_mut(3, 1).copy_from(&a_seat_u);
            d.rows_mut(4, 1).copy_from(&force_u);
            d.rows_mut(5, g.d_lim_u.nrows()).copy_from(&g.d_lim_u);
            frequency_response(&[g.a.clone(), g.b_u.clone(), c, d], w)
        };
        let forces = g
            .limit_names
            .iter()
            .position(|n| n.starts_with("force_"))
            .unwrap();
        for f in [0.5, 2.0, 9.0, 40.0] {
            let w = 2.0 * std::f64::consts::PI * f;
            let lag = Complex::new(2.0 * std::f64::consts::PI * hz, 0.0)
                / Complex::new(2.0 * std::f64::consts::PI * hz, w);
            let (ideal, behind) = (responses(&g, w), responses(&lagged, w));
            for i in 0..ideal.nrows() {
                let expected = if i >= 5 + forces {
                    Complex::new(1.0, 0.0)
                } else {
                    lag
                };
                for k in 0..N_ACTUATORS {
                    let (want, got) = (ideal[(i, k)] * expected, behind[(i, k)]);
                    assert!(
                        (got - want).norm() <= 1e-9 * (1.0 + want.norm()),
                        "row {i}, actuator {k} at {f} Hz: {got} vs {want}"
                    );
                }
            }
        }
    }
}
