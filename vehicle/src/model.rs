//! The 8-DOF full car with driver seat (thesis ch. 3, corrected; SPEC.md §1).
//!
//! Generalised coordinates `q = [z_s, φ, θ, z_seat, z_u,FL, z_u,FR, z_u,RL, z_u,RR]`, z up, roll
//! positive = left side up, pitch positive = nose up, all measured from static equilibrium.
//! A body point at `(x, y)` (x forward, y left) moves by `z_s + y·φ + x·θ`.
//!
//! Instead of the thesis's hand-derived equations (3.3)–(3.5), which omit the actuator moments in
//! roll and pitch and mix up signs, every spring/damper is an *element* whose deflection is
//! linear in `q` and the road heights, `d = J q − R z_r`. Euler–Lagrange with
//! `V = ½ Σ k dᵢ²`, `D = ½ Σ c ḋᵢ²` then gives
//! `M q̈ + C q̇ + K q = K_r z_r + C_r ż_r + B_f f` with `K = Jᵀ diag(k) J`, `C = Jᵀ diag(c) J`,
//! `K_r = Jᵀ diag(k) R`, `C_r = Jᵀ diag(c) R`, and, by virtual work of an actuator force `f`
//! that extends its element (`δW = f δd`), `B_f = J_actᵀ`.

use crate::params::VehicleParams;
use nalgebra::{DMatrix, DVector, SymmetricEigen};

/// Number of mechanical degrees of freedom.
pub const N_DOF: usize = 8;
/// Number of states `x = [q; q̇]`.
pub const N_STATES: usize = 16;
/// Number of wheels.
pub const N_WHEELS: usize = 4;
/// Number of road inputs `r = [z_r,FL..RR; ż_r,FL..RR]`.
pub const N_ROAD: usize = 8;
/// Number of actuators: four corners (between body and wheel) and the seat (between body and seat).
pub const N_ACTUATORS: usize = 5;
/// Number of rows of [`physical_outputs`].
pub const N_PHYSICAL_OUTPUTS: usize = 24;

/// Index of each generalised coordinate in `q`.
pub mod coord {
    pub const HEAVE: usize = 0;
    pub const ROLL: usize = 1;
    pub const PITCH: usize = 2;
    pub const SEAT: usize = 3;
    pub const WHEEL: [usize; 4] = [4, 5, 6, 7];
}

/// Suffixes of the corners, in the order used everywhere (`q`, road, actuators).
pub const CORNERS: [&str; 4] = ["fl", "fr", "rl", "rr"];
/// Suffixes of the actuators: the four corners, then the seat.
pub const ACTUATORS: [&str; 5] = ["fl", "fr", "rl", "rr", "seat"];

/// The names of the road signals between the road FMU's outputs and the plant's inputs, in the
/// order of `r = [z_r; ż_r]`: heights `road_z_<corner>`, then velocities `road_v_<corner>`.
pub const ROAD_PORTS: [&str; N_ROAD] = [
    "road_z_fl",
    "road_z_fr",
    "road_z_rl",
    "road_z_rr",
    "road_v_fl",
    "road_v_fr",
    "road_v_rl",
    "road_v_rr",
];
/// The names of the commanded forces between a controller's outputs and the plant's inputs
/// \[N\], `u_<actuator>` in the order of [`ACTUATORS`].
pub const FORCE_PORTS: [&str; N_ACTUATORS] = ["u_fl", "u_fr", "u_rl", "u_rr", "u_seat"];

/// Name, unit and meaning of each state, in the order of `x`.
pub const STATES: [(&str, &str, &str); N_STATES] = [
    ("z_s", "m", "body heave displacement"),
    ("phi", "rad", "body roll angle (left side up)"),
    ("theta", "rad", "body pitch angle (nose up)"),
    ("z_seat", "m", "seat heave displacement"),
    ("z_u_fl", "m", "front-left wheel displacement"),
    ("z_u_fr", "m", "front-right wheel displacement"),
    ("z_u_rl", "m", "rear-left wheel displacement"),
    ("z_u_rr", "m", "rear-right wheel displacement"),
    ("dz_s", "m/s", "body heave velocity"),
    ("dphi", "rad/s", "body roll rate"),
    ("dtheta", "rad/s", "body pitch rate"),
    ("dz_seat", "m/s", "seat heave velocity"),
    ("dz_u_fl", "m/s", "front-left wheel velocity"),
    ("dz_u_fr", "m/s", "front-right wheel velocity"),
    ("dz_u_rl", "m/s", "rear-left wheel velocity"),
    ("dz_u_rr", "m/s", "rear-right wheel velocity"),
];

/// What a spring/damper element connects.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ElementKind {
    /// Suspension of a corner, body to wheel; deflection = body point − wheel (stroke).
    Suspension(usize),
    /// Tyre of a corner, wheel to road; deflection = wheel − road.
    Tyre(usize),
    /// Seat cushion, body to seat; deflection = seat − body attachment point.
    Seat,
}

/// One linear spring/damper: `d = jacobian·q − road·z_r`.
#[derive(Debug, Clone)]
pub struct Element {
    pub kind: ElementKind,
    pub stiffness: f64,
    pub damping: f64,
    pub jacobian: [f64; N_DOF],
    pub road: [f64; N_WHEELS],
}

/// Longitudinal and lateral position `(x, y)` of each corner relative to the body COG \[m\].
pub fn corner_positions(p: &VehicleParams) -> [(f64, f64); 4] {
    [(p.l2, p.w1), (p.l2, -p.w2), (-p.l1, p.w1), (-p.l1, -p.w2)]
}

/// Row of `q` giving the vertical displacement of the body point `(x, y)`.
fn body_point(x: f64, y: f64) -> [f64; N_DOF] {
    let mut row = [0.0; N_DOF];
    row[coord::HEAVE] = 1.0;
    row[coord::ROLL] = y;
    row[coord::PITCH] = x;
    row
}

/// The nine elements of the car: four suspensions, four tyres, the seat.
pub fn elements(p: &VehicleParams) -> Vec<Element> {
    let mut elements = Vec::with_capacity(9);
    for (i, &(x, y)) in corner_positions(p).iter().enumerate() {
        let front = i < 2;
        let mut jacobian = body_point(x, y);
        jacobian[coord::WHEEL[i]] = -1.0;
        elements.push(Element {
            kind: ElementKind::Suspension(i),
            stiffness: if front { p.k_s_f } else { p.k_s_r },
            damping: if front { p.c_s_f } else { p.c_s_r },
            jacobian,
            road: [0.0; 4],
        });
    }
    for i in 0..N_WHEELS {
        let mut jacobian = [0.0; N_DOF];
        jacobian[coord::WHEEL[i]] = 1.0;
        let mut road = [0.0; 4];
        road[i] = 1.0;
        elements.push(Element {
            kind: ElementKind::Tyre(i),
            stiffness: p.k_t,
            damping: p.c_t,
            jacobian,
            road,
        });
    }
    // Seat attachment at roll lever −s1, pitch lever +s2: z9 = z_seat − z − s2·θ + s1·φ.
    let mut jacobian = body_point(p.s2, -p.s1).map(|v| -v);
    jacobian[coord::SEAT] = 1.0;
    elements.push(Element {
        kind: ElementKind::Seat,
        stiffness: p.k_seat,
        damping: p.c_seat,
        jacobian,
        road: [0.0; 4],
    });
    elements
}

/// Second-order model `M q̈ + C q̇ + K q = K_r z_r + C_r ż_r + B_f f`.
#[derive(Debug, Clone)]
pub struct MechanicalModel {
    pub mass: DMatrix<f64>,
    pub damping: DMatrix<f64>,
    pub stiffness: DMatrix<f64>,
    /// `K_r` (8×4): generalised force per metre of road height.
    pub road_stiffness: DMatrix<f64>,
    /// `C_r` (8×4): generalised force per m/s of road velocity.
    pub road_damping: DMatrix<f64>,
    /// `B_f` (8×5): generalised force per newton of each actuator.
    pub actuation: DMatrix<f64>,
    /// Generalised gravity force (8) [N, N·m].
    pub gravity: DVector<f64>,
    pub elements: Vec<Element>,
}

impl MechanicalModel {
    pub fn new(p: &VehicleParams) -> Self {
        let elements = elements(p);
        let n_el = elements.len();
        let jac = DMatrix::from_fn(n_el, N_DOF, |e, j| elements[e].jacobian[j]);
        let road = DMatrix::from_fn(n_el, N_WHEELS, |e, j| elements[e].road[j]);
        let k = DMatrix::from_diagonal(&DVector::from_iterator(
            n_el,
            elements.iter().map(|e| e.stiffness),
        ));
        let c = DMatrix::from_diagonal(&DVector::from_iterator(
            n_el,
            elements.iter().map(|e| e.damping),
        ));
        let jt = jac.transpose();

        // Actuators act along the suspension elements (corners) and the seat element.
        let actuated: Vec<usize> = (0..N_WHEELS)
            .map(|i| {
                elements
                    .iter()
                    .position(|e| e.kind == ElementKind::Suspension(i))
                    .unwrap()
            })
            .chain(std::iter::once(
                elements
                    .iter()
                    .position(|e| e.kind == ElementKind::Seat)
                    .unwrap(),
            ))
            .collect();
        let actuation =
            DMatrix::from_fn(N_DOF, N_ACTUATORS, |j, a| elements[actuated[a]].jacobian[j]);

        let masses = [p.m_s, p.i_x, p.i_y, p.m_seat, p.m_u, p.m_u, p.m_u, p.m_u];
        let translational = [1.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0, 1.0];
        MechanicalModel {
            mass: DMatrix::from_diagonal(&DVector::from_row_slice(&masses)),
            damping: &jt * &c * &jac,
            stiffness: &jt * &k * &jac,
            road_stiffness: &jt * &k * &road,
            road_damping: &jt * &c * &road,
            actuation,
            gravity: DVector::from_fn(N_DOF, |j, _| -p.g * masses[j] * translational[j]),
            elements,
        }
    }

    /// Static deflection of every element under gravity, flat road, no actuator force \[m\]
    /// (negative = compressed): `d₀ = J q₀`, `K q₀ = Q_g`.
    pub fn static_deflections(&self) -> Vec<f64> {
        let q0 = self
            .stiffness
            .clone()
            .cholesky()
            .expect("K is positive definite for admissible parameters")
            .solve(&self.gravity);
        self.elements
            .iter()
            .map(|e| e.jacobian.iter().zip(q0.iter()).map(|(a, b)| a * b).sum())
            .collect()
    }

    /// Undamped natural frequencies \[Hz\], each with the coordinate that carries most of the
    /// mode's kinetic energy, sorted by frequency.
    pub fn modes(&self) -> Vec<(f64, usize)> {
        let m_inv_sqrt = DMatrix::from_diagonal(&self.mass.diagonal().map(|m| 1.0 / m.sqrt()));
        let sym = &m_inv_sqrt * &self.stiffness * &m_inv_sqrt;
        let eig = SymmetricEigen::new(sym);
        let mut modes: Vec<(f64, usize)> = (0..N_DOF)
            .map(|k| {
                // Mass-normalised eigenvector: its squared entries are kinetic-energy shares.
                let v = eig.eigenvectors.column(k);
                let dominant = (0..N_DOF)
                    .max_by(|&a, &b| v[a].abs().total_cmp(&v[b].abs()))
                    .unwrap();
                (
                    eig.eigenvalues[k].sqrt() / (2.0 * std::f64::consts::PI),
                    dominant,
                )
            })
            .collect();
        modes.sort_by(|a, b| a.0.total_cmp(&b.0));
        modes
    }

    /// The modes in words, by frequency, the four wheel hops as one range: `body heave 1.05
    /// Hz, pitch 1.36 Hz, roll 1.41 Hz, seat 2.16 Hz, wheel hop 11.63–11.69 Hz` (the README's,
    /// written by `synth` for the car it designs for).
    pub fn modes_in_words(&self) -> String {
        let modes = self.modes();
        let wheels: Vec<f64> = modes
            .iter()
            .filter(|m| coord::WHEEL.contains(&m.1))
            .map(|m| m.0)
            .collect();
        let mut words = Vec::new();
        let mut hops_said = false;
        for (f, c) in &modes {
            let name = match *c {
                coord::HEAVE => "body heave",
                coord::ROLL => "roll",
                coord::PITCH => "pitch",
                coord::SEAT => "seat",
                // The wheel hops as one range, where the lowest of them falls.
                _ => {
                    if !hops_said {
                        let (lo, hi) = (wheels[0], wheels[wheels.len() - 1]);
                        words.push(format!("wheel hop {lo:.2}–{hi:.2} Hz"));
                        hops_said = true;
                    }
                    continue;
                }
            };
            words.push(format!("{name} {f:.2} Hz"));
        }
        words.join(", ")
    }
}

/// First-order model `ẋ = A x + B_u u + B_r r`, `x = [q; q̇]`, `r = [z_r; ż_r]`.
#[derive(Debug, Clone, PartialEq)]
pub struct StateSpace {
    /// 16×16.
    pub a: DMatrix<f64>,
    /// 16×5, per newton of each actuator.
    pub b_u: DMatrix<f64>,
    /// 16×8, per metre of road height and per m/s of road velocity.
    pub b_r: DMatrix<f64>,
}

impl StateSpace {
    pub fn new(p: &VehicleParams) -> Self {
        Self::from_mechanical(&MechanicalModel::new(p))
    }

    pub fn from_mechanical(m: &MechanicalModel) -> Self {
        let m_inv = DMatrix::from_diagonal(&m.mass.diagonal().map(|v| 1.0 / v));
        let mut a = DMatrix::zeros(N_STATES, N_STATES);
        a.view_mut((0, N_DOF), (N_DOF, N_DOF)).fill_with_identity();
        a.view_mut((N_DOF, 0), (N_DOF, N_DOF))
            .copy_from(&(-&m_inv * &m.stiffness));
        a.view_mut((N_DOF, N_DOF), (N_DOF, N_DOF))
            .copy_from(&(-&m_inv * &m.damping));
        let mut b_u = DMatrix::zeros(N_STATES, N_ACTUATORS);
        b_u.view_mut((N_DOF, 0), (N_DOF, N_ACTUATORS))
            .copy_from(&(&m_inv * &m.actuation));
        let mut b_r = DMatrix::zeros(N_STATES, N_ROAD);
        b_r.view_mut((N_DOF, 0), (N_DOF, N_WHEELS))
            .copy_from(&(&m_inv * &m.road_stiffness));
        b_r.view_mut((N_DOF, N_WHEELS), (N_DOF, N_WHEELS))
            .copy_from(&(&m_inv * &m.road_damping));
        StateSpace { a, b_u, b_r }
    }

    /// Writes the car into a system `ẋ = A x + B v` whose first 16 states are its own and whose
    /// inputs start with the road's and the commands, `v = [r; u; …]`: driven by the road, and
    /// by the commands as the applied forces or, with `lag = Some((at, hz))`, through
    /// first-order actuators of that bandwidth, `ḟ = ω_a (u − f)`, their forces the states
    /// from `at` on (the plant FMU's `actuator_bandwidth`). Returns where the applied forces
    /// are, for [`crate::iso2631::ComfortMeter::place`].
    pub fn place(
        &self,
        a: &mut DMatrix<f64>,
        b: &mut DMatrix<f64>,
        lag: Option<(usize, f64)>,
    ) -> crate::iso2631::Forces {
        use crate::iso2631::Forces;
        a.view_mut((0, 0), (N_STATES, N_STATES)).copy_from(&self.a);
        b.view_mut((0, 0), (N_STATES, N_ROAD)).copy_from(&self.b_r);
        match lag {
            Some((at, hz)) => {
                let w = 2.0 * std::f64::consts::PI * hz;
                a.view_mut((0, at), (N_STATES, N_ACTUATORS))
                    .copy_from(&self.b_u);
                for i in 0..N_ACTUATORS {
                    a[(at + i, at + i)] = -w;
                    b[(at + i, N_ROAD + i)] = w;
                }
                Forces::States(at)
            }
            None => {
                b.view_mut((0, N_ROAD), (N_STATES, N_ACTUATORS))
                    .copy_from(&self.b_u);
                Forces::Inputs(N_ROAD)
            }
        }
    }

    /// `Σ wᵢ Sᵢ`, the same linear combination of every matrix.
    pub fn combination(terms: &[(f64, &StateSpace)]) -> StateSpace {
        let mut out = StateSpace {
            a: DMatrix::zeros(N_STATES, N_STATES),
            b_u: DMatrix::zeros(N_STATES, N_ACTUATORS),
            b_r: DMatrix::zeros(N_STATES, N_ROAD),
        };
        for (w, s) in terms {
            out.a += &s.a * *w;
            out.b_u += &s.b_u * *w;
            out.b_r += &s.b_r * *w;
        }
        out
    }

    /// Largest absolute entry-wise difference of all three matrices.
    pub fn max_abs_difference(&self, other: &StateSpace) -> f64 {
        [
            (&self.a, &other.a),
            (&self.b_u, &other.b_u),
            (&self.b_r, &other.b_r),
        ]
        .iter()
        .map(|(x, y)| (*x - *y).amax())
        .fold(0.0, f64::max)
    }
}

/// A named physical output `y = C x + D_r r + D_u u`.
#[derive(Debug, Clone)]
pub struct OutputRow {
    pub name: String,
    pub unit: &'static str,
    pub description: String,
    pub c: [f64; N_STATES],
    pub d_r: [f64; N_ROAD],
    pub d_u: [f64; N_ACTUATORS],
}

impl OutputRow {
    /// The row over `[x; r; u]`: `c`, then `d_r`, then `d_u`.
    pub fn coefficients(&self) -> impl Iterator<Item = &f64> {
        self.c.iter().chain(&self.d_r).chain(&self.d_u)
    }
}

/// The physical outputs engineers and controllers need, all dynamic parts (deviation from
/// static equilibrium): accelerations, the velocities measured by the output-feedback designs,
/// suspension and seat strokes, tyre deflections and dynamic tyre loads.
pub fn physical_outputs(p: &VehicleParams) -> Vec<OutputRow> {
    physical_outputs_with_accelerations(p)
        .into_iter()
        .map(|(row, _)| row)
        .collect()
}

/// [`physical_outputs`], each with the combination `w` of the generalised accelerations it is
/// (`y = w · q̈`; zero for an output that is no acceleration): a force the linear car does not
/// have (a tyre off the road, a stop) moves it by `w · M⁻¹ Q`.
pub fn physical_outputs_with_accelerations(p: &VehicleParams) -> Vec<(OutputRow, [f64; N_DOF])> {
    let mech = MechanicalModel::new(p);
    let ss = StateSpace::from_mechanical(&mech);
    // Each block of rows, and the acceleration weights of those that are accelerations.
    let mut out: Vec<(OutputRow, [f64; N_DOF])> = acceleration_rows(&ss);
    let none = |rows: Vec<OutputRow>| rows.into_iter().map(|r| (r, [0.0; N_DOF]));
    out.extend(none(rate_rows()));
    out.extend(none(deflection_rows(&mech)));
    out.extend(none(tyre_load_rows(&mech)));
    out.extend(body_accelerometer_rows(p, &ss));
    assert_eq!(out.len(), N_PHYSICAL_OUTPUTS);
    out
}

/// The row of the state space's `(A, B_r, B_u)` that is `w · q̈`.
fn acceleration_row(
    ss: &StateSpace,
    name: String,
    unit: &'static str,
    description: String,
    w: [f64; N_DOF],
) -> (OutputRow, [f64; N_DOF]) {
    let combine = |m: &nalgebra::DMatrix<f64>, k: usize| -> f64 {
        (0..N_DOF).map(|j| w[j] * m[(N_DOF + j, k)]).sum()
    };
    let row = OutputRow {
        name,
        unit,
        description,
        c: std::array::from_fn(|k| combine(&ss.a, k)),
        d_r: std::array::from_fn(|k| combine(&ss.b_r, k)),
        d_u: std::array::from_fn(|k| combine(&ss.b_u, k)),
    };
    (row, w)
}

/// The seat's heave and the body's heave, roll and pitch accelerations.
fn acceleration_rows(ss: &StateSpace) -> Vec<(OutputRow, [f64; N_DOF])> {
    [
        (
            "a_seat",
            "m/s2",
            "Seat (driver) heave acceleration",
            coord::SEAT,
        ),
        (
            "a_body",
            "m/s2",
            "Body heave acceleration at the COG",
            coord::HEAVE,
        ),
        (
            "alpha_roll",
            "rad/s2",
            "Body roll acceleration (left side up)",
            coord::ROLL,
        ),
        (
            "alpha_pitch",
            "rad/s2",
            "Body pitch acceleration (nose up)",
            coord::PITCH,
        ),
    ]
    .into_iter()
    .map(|(name, unit, description, j)| {
        let (mut w, r) = ([0.0; N_DOF], N_DOF + j);
        w[j] = 1.0;
        // The rows themselves (a weighted sum would give the same values, perhaps not the
        // same signs of their zeros).
        let row = OutputRow {
            name: name.into(),
            unit,
            description: description.into(),
            c: std::array::from_fn(|k| ss.a[(r, k)]),
            d_r: std::array::from_fn(|k| ss.b_r[(r, k)]),
            d_u: std::array::from_fn(|k| ss.b_u[(r, k)]),
        };
        (row, w)
    })
    .collect()
}

/// The body's heave velocity and its roll and pitch rates: states.
fn rate_rows() -> Vec<OutputRow> {
    [
        (
            "v_body",
            "m/s",
            "Body heave velocity at the COG (measured)",
            coord::HEAVE,
        ),
        (
            "omega_roll",
            "rad/s",
            "Body roll rate (measured)",
            coord::ROLL,
        ),
        (
            "omega_pitch",
            "rad/s",
            "Body pitch rate (measured)",
            coord::PITCH,
        ),
    ]
    .into_iter()
    .map(|(name, unit, description, j)| {
        let mut c = [0.0; N_STATES];
        c[N_DOF + j] = 1.0;
        OutputRow {
            name: name.into(),
            unit,
            description: description.into(),
            c,
            d_r: [0.0; 8],
            d_u: [0.0; 5],
        }
    })
    .collect()
}

/// The suspension strokes, the seat's stroke and the tyre deflections: each element's
/// deflection (its Jacobian on `q`, less the road under it).
fn deflection_rows(mech: &MechanicalModel) -> Vec<OutputRow> {
    let deflection = |e: &Element, name: String, description: String| {
        let mut c = [0.0; N_STATES];
        c[..N_DOF].copy_from_slice(&e.jacobian);
        let mut d_r = [0.0; N_ROAD];
        for (k, v) in e.road.iter().enumerate() {
            d_r[k] = -v;
        }
        OutputRow {
            name,
            unit: "m",
            description,
            c,
            d_r,
            d_u: [0.0; 5],
        }
    };
    let mut rows = Vec::new();
    for e in &mech.elements {
        if let ElementKind::Suspension(i) = e.kind {
            rows.push(deflection(
                e,
                format!("stroke_{}", CORNERS[i]),
                format!(
                    "Suspension stroke {}, body minus wheel, dynamic part (positive = extension)",
                    CORNERS[i].to_uppercase()
                ),
            ));
        }
    }
    let seat = mech
        .elements
        .iter()
        .find(|e| e.kind == ElementKind::Seat)
        .unwrap();
    rows.push(deflection(
        seat,
        "stroke_seat".into(),
        "Seat stroke, seat minus its body attachment point, dynamic part (positive = extension)"
            .into(),
    ));
    for e in &mech.elements {
        if let ElementKind::Tyre(i) = e.kind {
            rows.push(deflection(
                e,
                format!("tire_defl_{}", CORNERS[i]),
                format!(
                    "Tyre deflection {}, wheel minus road, dynamic part (negative = more compressed)",
                    CORNERS[i].to_uppercase()
                ),
            ));
        }
    }
    rows
}

/// The dynamic tyre loads: the load on the road rises when the tyre is compressed,
/// `−k_t d − c_t ḋ`.
fn tyre_load_rows(mech: &MechanicalModel) -> Vec<OutputRow> {
    let mut rows = Vec::new();
    for e in &mech.elements {
        if let ElementKind::Tyre(i) = e.kind {
            let mut c = [0.0; N_STATES];
            let mut d_r = [0.0; N_ROAD];
            let w = coord::WHEEL[i];
            c[w] = -e.stiffness;
            c[N_DOF + w] = -e.damping;
            d_r[i] = e.stiffness;
            d_r[N_WHEELS + i] = e.damping;
            rows.push(OutputRow {
                name: format!("tire_load_{}", CORNERS[i]),
                unit: "N",
                description: format!(
                    "Dynamic tyre load {} (positive = more load than static)",
                    CORNERS[i].to_uppercase()
                ),
                c,
                d_r,
                d_u: [0.0; 5],
            });
        }
    }
    rows
}

/// What a body accelerometer above each wheel reads (at the suspension's top mount): that body
/// point's height is the row `body_point` of `q` (the suspension element's body part), so its
/// acceleration is that row applied to `q̈`, the velocity rows of `A` and `B`.
fn body_accelerometer_rows(p: &VehicleParams, ss: &StateSpace) -> Vec<(OutputRow, [f64; N_DOF])> {
    CORNERS
        .iter()
        .enumerate()
        .map(|(i, corner)| {
            let (x, y) = corner_positions(p)[i];
            acceleration_row(
                ss,
                format!("a_body_{corner}"),
                "m/s2",
                format!(
                    "Body vertical acceleration above the {} wheel (an accelerometer at the suspension's top mount)",
                    corner.to_uppercase()
                ),
                body_point(x, y),
            )
        })
        .collect()
}

/// The forces the actuators actually apply (`f_fl … f_seat`, the plant FMU's outputs of those
/// names) as output rows: each its own applied force, `d_u` a unit row. A controller that reads
/// them (force sensors on the actuators) knows what acts on the car whatever the actuators'
/// delay, saturation or loss of effectiveness.
pub fn applied_force_rows() -> Vec<OutputRow> {
    ACTUATORS
        .iter()
        .enumerate()
        .map(|(i, a)| {
            let mut d_u = [0.0; N_ACTUATORS];
            d_u[i] = 1.0;
            OutputRow {
                name: format!("f_{a}"),
                unit: "N",
                description: format!(
                    "Force actually applied by the {} actuator",
                    a.to_uppercase()
                ),
                c: [0.0; N_STATES],
                d_r: [0.0; N_ROAD],
                d_u,
            }
        })
        .collect()
}

/// Every plant output a controller may read, as rows of the linear car `p`: its physical
/// outputs, the forces the actuators apply ([`applied_force_rows`], load cells) and the stops'
/// forces ([`stop_force_rows`]).
pub fn readable_outputs(p: &VehicleParams) -> Vec<OutputRow> {
    let mut rows = physical_outputs(p);
    rows.extend(applied_force_rows());
    rows.extend(stop_force_rows());
    rows
}

/// The stops' forces as the plant FMU outputs them (`stop_force_fl` … `stop_force_seat`, one
/// per place of [`ACTUATORS`]) as output rows of the linear car, where no stop acts: each row
/// is zero. A prediction with a stop engaged for good reads [`engaged_stop_row`] instead. A
/// stop's force acts on the car as the actuator at its place does (tested).
pub fn stop_force_rows() -> Vec<OutputRow> {
    ACTUATORS
        .iter()
        .map(|place| OutputRow {
            name: format!("stop_force_{place}"),
            unit: "N",
            description: format!(
                "Force of the {} stops: positive while the bump stop pushes back, negative \
                 while the rebound stop holds, 0 between them",
                if *place == "seat" {
                    "seat".to_string()
                } else {
                    place.to_uppercase()
                }
            ),
            c: [0.0; N_STATES],
            d_r: [0.0; N_ROAD],
            d_u: [0.0; N_ACTUATORS],
        })
        .collect()
}

/// [`stop_force_rows`]' row at `place` (an index of [`ACTUATORS`]) on a car whose stop there is
/// engaged for good with `stiffness` and `damping` (and whose spring and damper there are
/// stiffened by as much): `−(k s + c ṡ)`, `s` the stroke (negative in compression), without the
/// constant the free travel adds.
pub fn engaged_stop_row(
    p: &VehicleParams,
    place: usize,
    stiffness: f64,
    damping: f64,
) -> OutputRow {
    let name = format!("stroke_{}", ACTUATORS[place]);
    let stroke = physical_outputs(p)
        .into_iter()
        .find(|r| r.name == name)
        .expect("every place has a stroke");
    assert!(
        stroke.c[N_DOF..]
            .iter()
            .chain(&stroke.d_r)
            .chain(&stroke.d_u)
            .all(|v| *v == 0.0),
        "a stroke is a function of the positions alone"
    );
    let mut row = stop_force_rows().swap_remove(place);
    for j in 0..N_DOF {
        row.c[j] = -stiffness * stroke.c[j];
        row.c[N_DOF + j] = -damping * stroke.c[j];
    }
    row
}

/// Static values under gravity, for the calculated parameters of the plant.
#[derive(Debug, Clone, PartialEq)]
pub struct StaticEquilibrium {
    /// Suspension strokes \[m\] (negative = compressed).
    pub stroke: [f64; 4],
    /// Seat stroke \[m\].
    pub stroke_seat: f64,
    /// Tyre deflections \[m\].
    pub tire_defl: [f64; 4],
    /// Tyre loads \[N\] (positive = pressing on the road).
    pub tire_load: [f64; 4],
}

impl StaticEquilibrium {
    pub fn new(p: &VehicleParams) -> Self {
        let mech = MechanicalModel::new(p);
        let d = mech.static_deflections();
        let mut s = StaticEquilibrium {
            stroke: [0.0; 4],
            stroke_seat: 0.0,
            tire_defl: [0.0; 4],
            tire_load: [0.0; 4],
        };
        for (e, d) in mech.elements.iter().zip(d) {
            match e.kind {
                ElementKind::Suspension(i) => s.stroke[i] = d,
                ElementKind::Tyre(i) => {
                    s.tire_defl[i] = d;
                    s.tire_load[i] = -e.stiffness * d;
                }
                ElementKind::Seat => s.stroke_seat = d,
            }
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn port_names_follow_the_corners_and_actuators() {
        for (k, c) in CORNERS.iter().enumerate() {
            assert_eq!(ROAD_PORTS[k], format!("road_z_{c}"));
            assert_eq!(ROAD_PORTS[4 + k], format!("road_v_{c}"));
        }
        for (k, a) in ACTUATORS.iter().enumerate() {
            assert_eq!(FORCE_PORTS[k], format!("u_{a}"));
        }
    }
}
