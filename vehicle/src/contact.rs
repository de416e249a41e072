//! Where the car stops being linear: tyres that leave the road, bump and rebound stops at each
//! corner, end stops on the seat (issue 51).
//!
//! Each is a *unilateral* spring/damper: a penetration `p`, affine in the state and the road,
//! `p = σ (J q − R z_r) + o` (`J`, `R` the rows of the [`Element`](crate::model::Element) it
//! sits on, `σ = ±1` the direction that closes it, `o` the free travel or the static preload),
//! pushes with `F = k p + c ṗ` while it is *engaged*, and with nothing while it is free. It is engaged
//! exactly while `g = min(p, F) > 0`: in contact and pressing. It engages when `g` rises
//! through 0 (the gap closes while closing, or a compressed element starts pressing again) and
//! releases when `g` falls through 0, which in practice is the force reaching zero: the force
//! is continuous there, so is the acceleration, so the guard leaves zero with the same slope
//! in both modes and the switch cannot chatter.
//!
//! The linear car of the thesis has every tyre engaged for good and no stop. Relative to it a
//! mode adds, for each element whose state differs, a *correction*: a free tyre takes its
//! whole force (static preload included) off the wheel; an engaged stop adds its force. Within
//! a mode the car is linear and affine (the preload is a constant input), so it can still be
//! stepped exactly; the plant locates the switches on the exact trajectory.

use crate::model::{ElementKind, MechanicalModel, CORNERS, N_DOF, N_ROAD, N_STATES, N_WHEELS};
use crate::VehicleParams;

/// Number of unilateral elements: per corner a tyre, a bump stop and a rebound stop; the
/// seat's two end stops.
pub const N_UNILATERAL: usize = 3 * N_WHEELS + 2;

/// Which unilateral element.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unilateral {
    /// The tyre of a corner on the road.
    Tyre(usize),
    /// The bump (jounce) stop of a corner: the suspension compressed past its free travel.
    Bump(usize),
    /// The rebound stop of a corner: the suspension extended past its free travel.
    Rebound(usize),
    /// The seat compressed past its free travel.
    SeatBump,
    /// The seat extended past its free travel.
    SeatRebound,
}

impl Unilateral {
    /// Every element, in the order of a [`Mode`]'s bits.
    pub const ALL: [Unilateral; N_UNILATERAL] = [
        Unilateral::Tyre(0),
        Unilateral::Tyre(1),
        Unilateral::Tyre(2),
        Unilateral::Tyre(3),
        Unilateral::Bump(0),
        Unilateral::Bump(1),
        Unilateral::Bump(2),
        Unilateral::Bump(3),
        Unilateral::Rebound(0),
        Unilateral::Rebound(1),
        Unilateral::Rebound(2),
        Unilateral::Rebound(3),
        Unilateral::SeatBump,
        Unilateral::SeatRebound,
    ];

    /// Whether the linear car has this element engaged for good (the tyres).
    pub fn in_linear_car(self) -> bool {
        matches!(self, Unilateral::Tyre(_))
    }

    /// A name for messages: `tyre FL`, `bump stop RR`, `seat rebound stop`.
    pub fn name(self) -> String {
        let corner = |i: usize| CORNERS[i].to_uppercase();
        match self {
            Unilateral::Tyre(i) => format!("tyre {}", corner(i)),
            Unilateral::Bump(i) => format!("bump stop {}", corner(i)),
            Unilateral::Rebound(i) => format!("rebound stop {}", corner(i)),
            Unilateral::SeatBump => "seat bump stop".into(),
            Unilateral::SeatRebound => "seat rebound stop".into(),
        }
    }
}

/// Which elements are engaged: bit `k` for [`Unilateral::ALL`]`[k]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Mode(pub u16);

impl Mode {
    /// The linear car's: every tyre on the road, no stop touched.
    pub const LINEAR: Mode = Mode(0b1111);

    pub fn engaged(self, k: usize) -> bool {
        self.0 & (1 << k) != 0
    }

    pub fn with(self, k: usize, engaged: bool) -> Mode {
        if engaged {
            Mode(self.0 | (1 << k))
        } else {
            Mode(self.0 & !(1 << k))
        }
    }

    /// Whether the element's force differs from the linear car's in this mode.
    pub fn corrected(self, k: usize) -> bool {
        self.engaged(k) != Unilateral::ALL[k].in_linear_car()
    }

    /// Whether a bit pattern read back (an FMU state) is a mode.
    pub fn from_bits(bits: f64) -> Option<Mode> {
        (bits.fract() == 0.0 && (0.0..(1u32 << N_UNILATERAL) as f64).contains(&bits))
            .then_some(Mode(bits as u16))
    }
}

/// The stops' geometry and stiffness, and whether the car is the physical one at all.
///
/// Defaults: the free travels are ±8 cm from the static position at each corner, the travel
/// past which issue 51 measured the linear car to be unphysical, and about what a passenger car
/// has in jounce and rebound before its bump stop or rebound stop (Gillespie, *Fundamentals of
/// Vehicle Dynamics*, ch. 6, quotes 3–4 in of jounce travel); the stop rate of 250 kN/m is ten
/// times the corner spring (a progressive polyurethane jounce bumper's rate well into its
/// travel) with little damping. The seat travels ±5 cm before its end stops, a seat
/// suspension's range, on stops of 100 kN/m. These are stated choices, not measurements of one
/// car: every one is a parameter of the plant FMU.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactParams {
    /// `true`: tyres leave the road and the stops act; `false`: the linear car of the thesis.
    pub physical: bool,
    /// Free travel of each corner in bump (compression) from static, before its stop \[m\].
    pub bump_travel: f64,
    /// Free travel of each corner in rebound (extension) from static \[m\].
    pub rebound_travel: f64,
    /// Stiffness of a corner's bump or rebound stop \[N/m\].
    pub stop_stiffness: f64,
    /// Damping of a corner's bump or rebound stop \[N·s/m\].
    pub stop_damping: f64,
    /// Free travel of the seat each way from static \[m\].
    pub seat_travel: f64,
    /// Stiffness of a seat end stop \[N/m\].
    pub seat_stop_stiffness: f64,
    /// Damping of a seat end stop \[N·s/m\].
    pub seat_stop_damping: f64,
}

impl Default for ContactParams {
    fn default() -> Self {
        ContactParams {
            physical: true,
            bump_travel: 0.08,
            rebound_travel: 0.08,
            stop_stiffness: 250e3,
            stop_damping: 500.0,
            seat_travel: 0.05,
            seat_stop_stiffness: 100e3,
            seat_stop_damping: 200.0,
        }
    }
}

/// One unilateral element of a given car: its penetration and force as rows over `[x; r]`
/// (16 states, 8 road inputs) plus a constant, and what its force does to the velocities.
#[derive(Debug, Clone)]
pub struct Contact {
    pub kind: Unilateral,
    /// `p = penetration · [x; r] + offset` \[m\].
    pub penetration: [f64; N_STATES + N_ROAD],
    pub offset: f64,
    /// `F = force · [x; r] + force_offset` \[N\], the force while engaged (≥ 0 pressing).
    pub force: [f64; N_STATES + N_ROAD],
    pub force_offset: f64,
    /// `ẋ` per newton of `F` (zero in the position rows): `M⁻¹ (−σ Jᵀ)`, the generalised force
    /// per newton over each coordinate's mass.
    pub acceleration: [f64; N_STATES],
    /// `ṗ = rate · [x; r]`.
    pub rate: Point,
    /// `σ`: the penetration is `σ (J q − R z_r) + offset`.
    pub sigma: f64,
    pub stiffness: f64,
    pub damping: f64,
}

/// `[x; r]` in one array, as the rows index it.
pub type Point = [f64; N_STATES + N_ROAD];

/// The car's state `x` (its first 16 entries) and the road `r` as one [`Point`].
#[inline]
pub fn point(x: &[f64], r: &[f64]) -> Point {
    let (x, r): (&[f64; N_STATES], &[f64; N_ROAD]) = (
        x[..N_STATES].try_into().expect("16 states"),
        r[..N_ROAD].try_into().expect("8 road inputs"),
    );
    let mut z = [0.0; N_STATES + N_ROAD];
    z[..N_STATES].copy_from_slice(x);
    z[N_STATES..].copy_from_slice(r);
    z
}

fn dense_dot(row: &Point, z: &Point) -> f64 {
    row.iter().zip(z).map(|(a, b)| a * b).sum()
}

impl Contact {
    /// The penetration at `z = [x; r]` ([`point`]), from the full rows (see [`Contacts`] for
    /// the fast path).
    pub fn penetration(&self, z: &Point) -> f64 {
        dense_dot(&self.penetration, z) + self.offset
    }

    /// The force it would push with if engaged.
    pub fn force(&self, z: &Point) -> f64 {
        dense_dot(&self.force, z) + self.force_offset
    }

    /// `min(p, F)`: positive exactly while the element is in contact and pressing.
    pub fn guard(&self, z: &Point) -> f64 {
        self.penetration(z).min(self.force(z))
    }
}

/// Most non-zero terms in a row (a suspension's: heave, roll, pitch, wheel).
const ROW_TERMS: usize = 4;

/// A row's non-zero terms over a [`Point`], padded with zero coefficients.
type Terms = [(usize, f64); ROW_TERMS];

fn terms(row: &Point) -> Terms {
    let mut t = [(0, 0.0); ROW_TERMS];
    let nonzero = row.iter().copied().enumerate().filter(|(_, v)| *v != 0.0);
    for (n, term) in nonzero.enumerate() {
        assert!(n < ROW_TERMS, "a contact row has at most {ROW_TERMS} terms");
        t[n] = term;
    }
    t
}

#[inline(always)]
fn dot(t: &Terms, z: &Point) -> f64 {
    t[0].1 * z[t[0].0] + t[1].1 * z[t[1].0] + t[2].1 * z[t[2].0] + t[3].1 * z[t[3].0]
}

/// The unilateral elements of a car, with their guards in the form a plant reads twice a step:
/// each element's row (`J q − R z_r`, unsigned) and its rate as at most four terms, and its
/// constants side by side.
#[derive(Debug, Clone)]
pub struct Contacts {
    pub elements: Vec<Contact>,
    rows: [Terms; N_UNILATERAL],
    rates: [Terms; N_UNILATERAL],
    sigma: [f64; N_UNILATERAL],
    offset: [f64; N_UNILATERAL],
    stiffness: [f64; N_UNILATERAL],
    damping: [f64; N_UNILATERAL],
    /// The elements whose guard reads the road (the tyres), as mode bits.
    road: u16,
}

impl Contacts {
    fn new(elements: Vec<Contact>) -> Self {
        // The unsigned rows: σ² = 1.
        let unsigned =
            |k: usize, row: &Point| -> Terms { terms(&row.map(|v| elements[k].sigma * v)) };
        let each = |f: fn(&Contact) -> f64| -> [f64; N_UNILATERAL] {
            std::array::from_fn(|k| f(&elements[k]))
        };
        let road = (0..N_UNILATERAL)
            .filter(|&k| {
                elements[k].penetration[N_STATES..]
                    .iter()
                    .any(|v| *v != 0.0)
            })
            .fold(0, |bits, k| bits | 1 << k);
        Contacts {
            rows: std::array::from_fn(|k| unsigned(k, &elements[k].penetration)),
            rates: std::array::from_fn(|k| unsigned(k, &elements[k].rate)),
            sigma: each(|c| c.sigma),
            offset: each(|c| c.offset),
            stiffness: each(|c| c.stiffness),
            damping: each(|c| c.damping),
            road,
            elements,
        }
    }

    #[inline(always)]
    fn force_at(&self, k: usize, penetration: f64, z: &Point) -> f64 {
        self.stiffness[k] * penetration + self.damping[k] * self.sigma[k] * dot(&self.rates[k], z)
    }

    /// Element `k`'s penetration at `z`.
    #[inline(always)]
    pub fn penetration(&self, k: usize, z: &Point) -> f64 {
        self.sigma[k] * dot(&self.rows[k], z) + self.offset[k]
    }

    /// The force element `k` would push with if engaged.
    pub fn force(&self, k: usize, z: &Point) -> f64 {
        self.force_at(k, self.penetration(k, z), z)
    }

    /// Element `k`'s guard `min(p, F)` ([`Contact::guard`]): positive exactly while it is in
    /// contact and pressing.
    pub fn guard(&self, k: usize, z: &Point) -> f64 {
        let p = self.penetration(k, z);
        p.min(self.force_at(k, p, z))
    }

    /// The mode the car is in at `z = [x; r]`, coming from `mode`: each element whose guard is
    /// strictly past zero on the other side switches; one exactly at zero keeps its mode.
    pub fn reconcile(&self, mode: Mode, z: &Point) -> Mode {
        self.reconcile_some(mode, z, u16::MAX)
    }

    /// [`Contacts::reconcile`] for the tyres only: what a moved road can switch.
    pub fn reconcile_tyres(&self, mode: Mode, z: &Point) -> Mode {
        self.reconcile_some(mode, z, self.road)
    }

    #[inline(always)]
    fn reconcile_some(&self, mode: Mode, z: &Point, which: u16) -> Mode {
        let mut next = mode;
        for k in 0..N_UNILATERAL {
            if which & (1 << k) == 0 {
                continue;
            }
            let p = self.penetration(k, z);
            // The force is read only where the penetration does not decide.
            let switches = if mode.engaged(k) {
                p < 0.0 || self.force_at(k, p, z) < 0.0
            } else {
                p > 0.0 && self.force_at(k, p, z) > 0.0
            };
            if switches {
                next = next.with(k, !mode.engaged(k));
            }
        }
        next
    }
}

/// The unilateral elements of the car `p` with stops `c`, in the order of [`Unilateral::ALL`].
pub fn contacts(p: &VehicleParams, c: &ContactParams) -> Contacts {
    Contacts::new(elements(p, c))
}

fn elements(p: &VehicleParams, c: &ContactParams) -> Vec<Contact> {
    let mech = MechanicalModel::new(p);
    let statics = mech.static_deflections();
    let element = |kind: ElementKind| {
        let k = mech
            .elements
            .iter()
            .position(|e| e.kind == kind)
            .expect("every element of the car exists");
        (&mech.elements[k], statics[k])
    };
    Unilateral::ALL
        .iter()
        .map(|&kind| {
            // (element, σ, o, k, c)
            let (on, sigma, offset, k, d) = match kind {
                Unilateral::Tyre(i) => {
                    let (e, d0) = element(ElementKind::Tyre(i));
                    (e, -1.0, -d0, e.stiffness, e.damping)
                }
                Unilateral::Bump(i) => {
                    let (e, _) = element(ElementKind::Suspension(i));
                    (e, -1.0, -c.bump_travel, c.stop_stiffness, c.stop_damping)
                }
                Unilateral::Rebound(i) => {
                    let (e, _) = element(ElementKind::Suspension(i));
                    (e, 1.0, -c.rebound_travel, c.stop_stiffness, c.stop_damping)
                }
                Unilateral::SeatBump => {
                    let (e, _) = element(ElementKind::Seat);
                    let (k, d) = (c.seat_stop_stiffness, c.seat_stop_damping);
                    (e, -1.0, -c.seat_travel, k, d)
                }
                Unilateral::SeatRebound => {
                    let (e, _) = element(ElementKind::Seat);
                    let (k, d) = (c.seat_stop_stiffness, c.seat_stop_damping);
                    (e, 1.0, -c.seat_travel, k, d)
                }
            };
            let mut penetration = [0.0; N_STATES + N_ROAD];
            let mut rate = [0.0; N_STATES + N_ROAD];
            for j in 0..N_DOF {
                penetration[j] = sigma * on.jacobian[j];
                rate[N_DOF + j] = sigma * on.jacobian[j];
            }
            for w in 0..N_WHEELS {
                penetration[N_STATES + w] = -sigma * on.road[w];
                rate[N_STATES + N_WHEELS + w] = -sigma * on.road[w];
            }
            let force: [f64; N_STATES + N_ROAD] =
                std::array::from_fn(|m| k * penetration[m] + d * rate[m]);
            let mut acceleration = [0.0; N_STATES];
            for j in 0..N_DOF {
                acceleration[N_DOF + j] = -sigma * on.jacobian[j] / mech.mass[(j, j)];
            }
            Contact {
                kind,
                rate,
                sigma,
                stiffness: k,
                damping: d,
                penetration,
                offset,
                force,
                force_offset: k * offset,
                acceleration,
            }
        })
        .collect()
}

/// The corrections of `mode` to the linear car: for each element whose force differs, its
/// index and the sign its force `F` enters with (−1: a free tyre takes its force off; +1: an
/// engaged stop adds its force).
pub fn corrections(mode: Mode) -> impl Iterator<Item = (usize, f64)> {
    (0..N_UNILATERAL)
        .filter(move |&k| mode.corrected(k))
        .map(move |k| (k, if mode.engaged(k) { 1.0 } else { -1.0 }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{StateSpace, StaticEquilibrium};

    fn default_contacts() -> Contacts {
        contacts(&VehicleParams::default(), &ContactParams::default())
    }

    /// What a stop-force recovery in a controller assumes (`synth`'s `stop_recovery`): the plant's
    /// `stop_force_*` output (bump positive, rebound negative) acts on the car as the actuator
    /// at its place does, per newton, and engaged it reads [`crate::model::engaged_stop_row`].
    #[test]
    fn a_stop_force_acts_as_the_actuator_at_its_place_and_reads_its_engaged_row() {
        let p = VehicleParams::default();
        let ss = StateSpace::new(&p);
        for c in &default_contacts().elements {
            let (place, sign) = match c.kind {
                Unilateral::Tyre(_) => continue,
                Unilateral::Bump(i) => (i, 1.0),
                Unilateral::Rebound(i) => (i, -1.0),
                Unilateral::SeatBump => (4, 1.0),
                Unilateral::SeatRebound => (4, -1.0),
            };
            for j in 0..N_STATES {
                let (stop, actuator) = (sign * c.acceleration[j], ss.b_u[(j, place)]);
                assert!(
                    (stop - actuator).abs() < 1e-12,
                    "{}: {stop} {actuator}",
                    c.kind.name()
                );
            }
            let row = crate::model::engaged_stop_row(&p, place, c.stiffness, c.damping);
            for j in 0..N_STATES {
                let force = sign * c.force[j];
                assert!(
                    (row.c[j] - force).abs() < 1e-9 * c.stiffness,
                    "{}",
                    c.kind.name()
                );
            }
            assert!(
                c.force[N_STATES..].iter().all(|v| *v == 0.0),
                "{}",
                c.kind.name()
            );
        }
    }

    #[test]
    fn at_rest_on_a_flat_road_the_tyres_carry_the_static_load_and_no_stop_touches() {
        let p = VehicleParams::default();
        let statics = StaticEquilibrium::new(&p);
        let cs = default_contacts();
        let z = [0.0; N_STATES + N_ROAD];
        for (k, c) in cs.elements.iter().enumerate() {
            match c.kind {
                Unilateral::Tyre(i) => {
                    let f = c.force(&z);
                    assert!((f - statics.tire_load[i]).abs() < 1e-9 * f, "{f}");
                }
                _ => assert!(c.guard(&z) < 0.0, "{} touches at rest", c.kind.name()),
            }
            assert_eq!(Mode::LINEAR.engaged(k), c.guard(&z) > 0.0);
        }
        assert_eq!(cs.reconcile(Mode::LINEAR, &z), Mode::LINEAR);
    }

    /// An engaged element's force, entered through its `acceleration`, is what the linear car's
    /// matrices give for the tyre: the tyre rows of `A` and `B_r` are `acceleration · force`.
    #[test]
    fn a_tyres_correction_cancels_exactly_the_tyre_terms_of_the_linear_car() {
        let p = VehicleParams::default();
        let ss = StateSpace::new(&p);
        let cs = default_contacts();
        for (k, c) in cs
            .elements
            .iter()
            .enumerate()
            .filter(|(_, c)| c.kind.in_linear_car())
        {
            let Unilateral::Tyre(i) = c.kind else {
                unreachable!()
            };
            let w = N_DOF + crate::model::coord::WHEEL[i];
            // The wheel's row of A minus the tyre's share is the suspension's only: it does not
            // depend on the wheel's own position beyond the suspension spring.
            let tyre_share = c.acceleration[w] * c.force[w - N_DOF];
            let p_mu = p.m_u;
            assert!((tyre_share - (-p.k_t / p_mu)).abs() < 1e-9 * p.k_t / p_mu);
            let road_share = c.acceleration[w] * c.force[N_STATES + i];
            assert!((road_share - ss.b_r[(w, i)]).abs() < 1e-12 * road_share.abs());
            assert!(Mode::LINEAR.engaged(k) && !Mode::LINEAR.corrected(k));
            assert!(Mode::LINEAR.with(k, false).corrected(k));
        }
    }

    #[test]
    fn a_wheel_lifted_above_the_road_is_free_and_one_pushed_down_is_in_contact() {
        let cs = default_contacts();
        let mut r = [0.0; N_ROAD];
        r[0] = -0.1; // the road drops 10 cm under FL: the wheel hangs above it
        let x = [0.0; N_STATES];
        let m = cs.reconcile(Mode::LINEAR, &point(&x, &r));
        assert!(!m.engaged(0) && m.engaged(1) && m.engaged(2) && m.engaged(3));
        assert_eq!(cs.reconcile_tyres(Mode::LINEAR, &point(&x, &r)), m);
        assert_eq!(cs.reconcile(m, &point(&x, &[0.0; N_ROAD])), Mode::LINEAR);
        // The body 9 cm down at standstill: every corner past its 8 cm bump travel.
        let mut x = [0.0; N_STATES];
        x[0] = -0.09;
        let m = cs.reconcile(Mode::LINEAR, &point(&x, &[0.0; N_ROAD]));
        assert!((4..8).all(|k| m.engaged(k)) && (8..12).all(|k| !m.engaged(k)));
        assert_eq!(
            cs.reconcile_tyres(Mode::LINEAR, &point(&x, &[0.0; N_ROAD])),
            Mode::LINEAR,
            "a moved road switches no stop"
        );
    }

    /// The fast guards are the full rows': over states of every sign and size, each element's
    /// penetration and force are the rows', and an element switches exactly where `min(p, F)`
    /// computed from the full rows is past zero.
    #[test]
    fn the_fast_guards_are_the_rows() {
        let cs = default_contacts();
        let mut uniform = linsys::lcg(12345);
        let mut next = || 2.0 * uniform() - 1.0;
        let mut switched = 0;
        for _ in 0..2000 {
            let x: [f64; N_STATES] = std::array::from_fn(|_| 0.15 * next());
            let r: [f64; N_ROAD] = std::array::from_fn(|_| 0.1 * next());
            let z = point(&x, &r);
            let mode = Mode((next().abs() * 16383.0) as u16);
            let fast = cs.reconcile(mode, &z);
            for (k, c) in cs.elements.iter().enumerate() {
                let (p, f) = (c.penetration(&z), c.force(&z));
                assert!((cs.penetration(k, &z) - p).abs() <= 1e-12 * (1.0 + p.abs()));
                assert!((cs.force(k, &z) - f).abs() <= 1e-9 * (1.0 + f.abs()));
                let g = p.min(f);
                if g.abs() > 1e-6 {
                    let switches = if mode.engaged(k) { g < 0.0 } else { g > 0.0 };
                    assert_eq!(fast.engaged(k) != mode.engaged(k), switches);
                    switched += switches as usize;
                }
            }
        }
        assert!(switched > 1000, "the states reach both sides of the guards");
    }

    #[test]
    fn a_mode_survives_its_bits() {
        let m = Mode(0b10_0110_1010_0101);
        assert_eq!(Mode::from_bits(m.0 as f64), Some(m));
        for bad in [-1.0, 0.5, 16384.0, f64::NAN] {
            assert_eq!(Mode::from_bits(bad), None, "{bad}");
        }
    }
}
