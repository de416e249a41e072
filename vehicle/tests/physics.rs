//! Physical properties of the element-Jacobian model, each checked against an independent
//! reference: symmetry/definiteness, energy conservation, the hand-computed static load
//! distribution, the actuator moments the thesis omitted, the polytope forms, and the modal
//! frequencies SPEC §1 gives.

use linsys::discretize;
use nalgebra::{DMatrix, DVector, SymmetricEigen};
use vehicle::model::{coord, physical_outputs, StaticEquilibrium, N_DOF};
use vehicle::polytope::MassPolytope;
use vehicle::{MechanicalModel, StateSpace, VehicleParams};

fn eigenvalues(m: &DMatrix<f64>) -> Vec<f64> {
    SymmetricEigen::new(m.clone())
        .eigenvalues
        .iter()
        .copied()
        .collect()
}

#[test]
fn mass_damping_stiffness_are_symmetric_and_definite() {
    let mech = MechanicalModel::new(&VehicleParams::default());
    for (name, m) in [
        ("M", &mech.mass),
        ("C", &mech.damping),
        ("K", &mech.stiffness),
    ] {
        assert!(
            (m - m.transpose()).amax() <= 1e-14 * m.amax(),
            "{name} is not symmetric"
        );
        let min = eigenvalues(m).into_iter().fold(f64::INFINITY, f64::min);
        // The tyres anchor every coordinate, so even C (c_t > 0) is positive definite.
        assert!(min > 0.0, "{name} has eigenvalue {min}");
    }
    // Without tyre damping C is only semidefinite: the rigid motion of the whole car is undamped.
    let p = VehicleParams {
        c_t: 0.0,
        ..VehicleParams::default()
    };
    let c = MechanicalModel::new(&p).damping;
    let eig = eigenvalues(&c);
    let (min, max) = eig.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &v| {
        (lo.min(v), hi.max(v))
    });
    assert!(
        min.abs() < 1e-9 * max,
        "C without tyre damping should be singular, min eigenvalue {min}"
    );
}

#[test]
fn energy_is_conserved_without_dampers() {
    let p = VehicleParams {
        c_s_f: 0.0,
        c_s_r: 0.0,
        c_t: 0.0,
        c_seat: 0.0,
        ..VehicleParams::default()
    };
    let mech = MechanicalModel::new(&p);
    let ss = StateSpace::from_mechanical(&mech);
    let d = discretize(&ss.a, &ss.b_u, 0.01).unwrap();
    let energy = |x: &DVector<f64>| {
        let q = x.rows(0, N_DOF);
        let v = x.rows(N_DOF, N_DOF);
        0.5 * (v.transpose() * &mech.mass * v)[(0, 0)]
            + 0.5 * (q.transpose() * &mech.stiffness * q)[(0, 0)]
    };
    // Every coordinate displaced and moving.
    let mut x = DVector::from_fn(16, |i, _| 0.01 * ((i as f64) * 0.7).sin());
    let e0 = energy(&x);
    let mut worst: f64 = 0.0;
    for _ in 0..20_000 {
        x = &d.phi * x;
        worst = worst.max((energy(&x) - e0).abs() / e0);
    }
    assert!(worst < 1e-9, "relative energy drift {worst} over 200 s");

    // The check has teeth: the same run with the thesis's damping loses energy.
    let damped = StateSpace::new(&VehicleParams::default());
    let dd = discretize(&damped.a, &damped.b_u, 0.01).unwrap();
    let mut y = DVector::from_fn(16, |i, _| 0.01 * ((i as f64) * 0.7).sin());
    for _ in 0..100 {
        y = &dd.phi * y;
    }
    assert!(energy(&y) < 0.5 * e0);
}

/// Static load distribution computed by hand, independently of the Jacobians: the body rests on
/// four corner "legs" (suspension in series with tyre). Equilibrium of vertical force, pitch and
/// roll moment, plus the compatibility condition that the four corner deflections of a rigid
/// body lie in a plane (`δ_FL − δ_FR − δ_RL + δ_RR = 0`) fix the four corner forces.
#[test]
fn static_deflection_matches_hand_computed_load_share() {
    for p in [
        VehicleParams::default(),
        VehicleParams {
            m_s: 1800.0,
            s1: 0.4,
            s2: -0.3,
            w1: 0.75,
            ..VehicleParams::default()
        },
    ] {
        let g = p.g;
        let seat_w = p.m_seat * g;
        let total = p.m_s * g + seat_w;
        let x = [p.l2, p.l2, -p.l1, -p.l1];
        let y = [p.w1, -p.w2, p.w1, -p.w2];
        let ks = [p.k_s_f, p.k_s_f, p.k_s_r, p.k_s_r];
        // Corner sinkage per newton of corner force: suspension and tyre in series.
        let flex: Vec<f64> = ks.iter().map(|k| 1.0 / k + 1.0 / p.k_t).collect();
        let a = DMatrix::from_row_slice(
            4,
            4,
            &[
                1.0, 1.0, 1.0, 1.0, x[0], x[1], x[2], x[3], y[0], y[1], y[2], y[3], flex[0],
                -flex[1], -flex[2], flex[3],
            ],
        );
        // Seat weight acts at the seat attachment (x = s2, y = −s1); the wheel weight only
        // adds a constant tyre compression, which cancels in the planarity condition.
        let b = DVector::from_row_slice(&[total, seat_w * p.s2, -seat_w * p.s1, 0.0]);
        let force = a.lu().solve(&b).unwrap();
        let st = StaticEquilibrium::new(&p);
        for i in 0..4 {
            let stroke = -force[i] / ks[i];
            let tyre_load = force[i] + p.m_u * g;
            assert!(
                (st.stroke[i] - stroke).abs() < 1e-12 * stroke.abs().max(1e-3),
                "corner {i}: {} vs {stroke}",
                st.stroke[i]
            );
            assert!(
                (st.tire_load[i] - tyre_load).abs() < 1e-9 * tyre_load,
                "corner {i}: {} vs {tyre_load}",
                st.tire_load[i]
            );
            assert!((st.tire_defl[i] + tyre_load / p.k_t).abs() < 1e-12);
        }
        assert!((st.stroke_seat + seat_w / p.k_seat).abs() < 1e-12);
        let weight = (p.m_s + p.m_seat + 4.0 * p.m_u) * g;
        assert!((st.tire_load.iter().sum::<f64>() - weight).abs() < 1e-9 * weight);
    }
    // For the symmetric default car the body's own share is the lever rule: front corners carry
    // m_s g L1 / (2 (L1 + L2)) when the seat is weightless.
    let p = VehicleParams {
        m_seat: 1e-9,
        ..VehicleParams::default()
    };
    let st = StaticEquilibrium::new(&p);
    let front = p.m_s * p.g * p.l1 / (2.0 * p.wheelbase());
    assert!((st.stroke[0] + front / p.k_s_f).abs() < 1e-9);
    assert!(
        (st.stroke[1] - st.stroke[0]).abs() < 1e-12,
        "left/right symmetric"
    );
}

#[test]
fn corner_actuators_in_roll_give_roll_and_no_heave_or_pitch() {
    let p = VehicleParams::default();
    let mech = MechanicalModel::new(&p);
    let f = 1000.0;
    // Left corners extend, right corners retract: a pure roll moment on the body.
    let u = DVector::from_row_slice(&[f, -f, f, -f, 0.0]);
    let gen = &mech.actuation * &u;
    assert_eq!(gen[coord::HEAVE], 0.0);
    assert!(
        gen[coord::PITCH].abs() < 1e-12,
        "pitch moment {}",
        gen[coord::PITCH]
    );
    let roll = 2.0 * f * (p.w1 + p.w2);
    assert!(
        (gen[coord::ROLL] - roll).abs() < 1e-9,
        "roll moment {} vs {roll}",
        gen[coord::ROLL]
    );
    // The reaction pushes each wheel the other way.
    for (i, w) in coord::WHEEL.iter().enumerate() {
        assert_eq!(gen[*w], -u[i]);
    }
    // From rest, the body's response is a roll acceleration only.
    let ss = StateSpace::new(&p);
    let xdot = &ss.b_u * &u;
    assert!((xdot[N_DOF + coord::ROLL] - roll / p.i_x).abs() < 1e-9);
    assert_eq!(xdot[N_DOF + coord::HEAVE], 0.0);
    assert!(xdot[N_DOF + coord::PITCH].abs() < 1e-15);
}

#[test]
fn seat_actuator_reacts_on_the_body_at_the_seat_point() {
    // Thesis eq. 3.4 drops this reaction; by virtual work it is −f at (x = s2, y = −s1).
    let p = VehicleParams::default();
    let gen = MechanicalModel::new(&p).actuation.column(4).into_owned();
    assert_eq!(gen[coord::SEAT], 1.0);
    assert_eq!(gen[coord::HEAVE], -1.0);
    assert_eq!(gen[coord::PITCH], -p.s2);
    assert_eq!(gen[coord::ROLL], p.s1);
}

#[test]
fn nominal_vertex_and_cog_forms_agree_at_every_mass() {
    let p = VehicleParams::default();
    let (lo, hi) = MassPolytope::DEFAULT_RANGE;
    let poly = MassPolytope::new(&p, lo, hi);
    let cog = poly.cog_form();
    for m in [1200.0, 1500.0, 1650.0, 1700.0, 1800.0] {
        let nominal = StateSpace::new(&VehicleParams { m_s: m, ..p });
        let scale = nominal.a.amax();
        assert!(
            poly.vertex_form(m).max_abs_difference(&nominal) < 1e-12 * scale,
            "vertex form at {m} kg"
        );
        assert!(
            cog.at(m).max_abs_difference(&nominal) < 1e-12 * scale,
            "COG form at {m} kg"
        );
        let [t1, t2] = cog.theta(m);
        assert!(t1.abs() <= 0.5 + 1e-15 && (t1 + t2).abs() < 1e-15);
    }
    // Mass enters only through 1/m_s: linear interpolation in m itself would be wrong.
    let m = 1500.0;
    let wrong_alpha = (hi - m) / (hi - lo);
    let wrong = StateSpace::combination(&[
        (wrong_alpha, &poly.vertices[0]),
        (1.0 - wrong_alpha, &poly.vertices[1]),
    ]);
    let nominal = StateSpace::new(&VehicleParams { m_s: m, ..p });
    assert!(wrong.max_abs_difference(&nominal) > 1e-3);
}

#[test]
fn modal_frequencies_are_in_the_ranges_spec_gives() {
    let modes = MechanicalModel::new(&VehicleParams::default()).modes();
    let of = |c: usize| {
        modes
            .iter()
            .filter(|m| m.1 == c)
            .map(|m| m.0)
            .collect::<Vec<_>>()
    };
    let heave = of(coord::HEAVE);
    let roll = of(coord::ROLL);
    let pitch = of(coord::PITCH);
    let seat = of(coord::SEAT);
    let wheels: Vec<f64> = coord::WHEEL.iter().flat_map(|&w| of(w)).collect();
    assert_eq!(
        (
            heave.len(),
            roll.len(),
            pitch.len(),
            seat.len(),
            wheels.len()
        ),
        (1, 1, 1, 1, 4),
        "{modes:?}"
    );
    assert!(
        (0.95..1.15).contains(&heave[0]),
        "body heave {} Hz",
        heave[0]
    );
    assert!((1.3..1.45).contains(&roll[0]), "roll {} Hz", roll[0]);
    assert!((1.3..1.45).contains(&pitch[0]), "pitch {} Hz", pitch[0]);
    assert!((2.0..2.2).contains(&seat[0]), "seat {} Hz", seat[0]);
    for w in &wheels {
        assert!((11.2..11.8).contains(w), "wheel hop {w} Hz");
    }
    let hop = (
        wheels.iter().copied().fold(f64::INFINITY, f64::min),
        wheels.iter().copied().fold(0.0, f64::max),
    );
    // In words (the README's line), from the same modes.
    assert_eq!(
        MechanicalModel::new(&VehicleParams::default()).modes_in_words(),
        format!(
            "body heave {:.2} Hz, pitch {:.2} Hz, roll {:.2} Hz, seat {:.2} Hz, wheel hop {:.2}–{:.2} Hz",
            heave[0],
            pitch[0],
            roll[0],
            seat[0],
            hop.0,
            hop.1
        )
    );
}

#[test]
fn outputs_are_consistent_with_the_state_equation() {
    let p = VehicleParams::default();
    let ss = StateSpace::new(&p);
    let rows = physical_outputs(&p);
    let x = DVector::from_fn(16, |i, _| ((i * 7 % 11) as f64 - 5.0) * 1e-3);
    let r = DVector::from_fn(8, |i, _| ((i * 3 % 5) as f64 - 2.0) * 1e-2);
    let u = DVector::from_fn(5, |i, _| (i as f64 - 2.0) * 300.0);
    let xdot = &ss.a * &x + &ss.b_r * &r + &ss.b_u * &u;
    let eval = |name: &str| {
        let row = rows.iter().find(|o| o.name == name).unwrap();
        (0..16).map(|k| row.c[k] * x[k]).sum::<f64>()
            + (0..8).map(|k| row.d_r[k] * r[k]).sum::<f64>()
            + (0..5).map(|k| row.d_u[k] * u[k]).sum::<f64>()
    };
    assert_eq!(eval("a_seat"), xdot[N_DOF + coord::SEAT]);
    assert_eq!(eval("alpha_roll"), xdot[N_DOF + coord::ROLL]);
    // Stroke FL by hand: body point at (L2, w1) minus the FL wheel.
    let stroke = x[0] + p.w1 * x[1] + p.l2 * x[2] - x[4];
    assert!((eval("stroke_fl") - stroke).abs() < 1e-15);
    // The body accelerometers above the wheels, by hand from the body's accelerations: the
    // left side rises with roll, the front with pitch.
    let q_ddot = |j: usize| xdot[N_DOF + j];
    for (corner, (x_pos, y_pos)) in [
        ("fl", (p.l2, p.w1)),
        ("fr", (p.l2, -p.w2)),
        ("rl", (-p.l1, p.w1)),
        ("rr", (-p.l1, -p.w2)),
    ] {
        let by_hand =
            q_ddot(coord::HEAVE) + y_pos * q_ddot(coord::ROLL) + x_pos * q_ddot(coord::PITCH);
        let read = eval(&format!("a_body_{corner}"));
        assert!(
            (read - by_hand).abs() < 1e-12 * by_hand.abs().max(1.0),
            "{corner}: {read} vs {by_hand}"
        );
    }
    // Seat stroke: z9 = z_seat − z − s2 θ + s1 φ.
    let z9 = x[3] - x[0] - p.s2 * x[2] + p.s1 * x[1];
    assert!((eval("stroke_seat") - z9).abs() < 1e-15);
    // Dynamic tyre load RR: k_t (z_r − z_u) + c_t (ż_r − ż_u).
    let load = p.k_t * (r[3] - x[7]) + p.c_t * (r[7] - x[15]);
    assert!((eval("tire_load_rr") - load).abs() < 1e-9);
}

/// The parameter ranges are a promise: every car they admit has a positive definite stiffness
/// matrix (the static equilibrium solves by Cholesky), a finite equilibrium, and a
/// discretisation over a millisecond and over a minute. Checked at 2000 random corners of the
/// box (each parameter at its minimum or maximum), the default car with each parameter alone at
/// either end, and the stiffest car against the longest step the bound admits.
#[test]
fn every_admitted_car_has_an_equilibrium_and_a_discretisation() {
    use vehicle::model::{StateSpace, StaticEquilibrium};
    use vehicle::params::PARAMETERS;
    let check = |p: &VehicleParams, what: &str| {
        p.validate().unwrap();
        let eq = StaticEquilibrium::new(p);
        assert!(
            eq.stroke.iter().chain(&eq.tire_load).all(|v| v.is_finite()),
            "{what}: {eq:?}"
        );
        let ss = StateSpace::new(p);
        for h in [1e-3, 60.0] {
            let d =
                discretize(&ss.a, &ss.b_u, h).unwrap_or_else(|e| panic!("{what}, h = {h}: {e}"));
            assert!(d.phi.iter().all(|v| v.is_finite()), "{what}, h = {h}");
        }
    };
    let default = VehicleParams::default();
    for spec in PARAMETERS {
        for v in [spec.admissible.min, spec.admissible.max] {
            let mut p = default;
            p.set(spec.name, v).unwrap();
            check(&p, &format!("{} = {v}", spec.name));
        }
    }
    let mut state = 0x2545_f491_4f6c_dd1d_u64;
    for k in 0..2000 {
        let mut p = default;
        for spec in PARAMETERS {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let v = if state & 1 == 0 {
                spec.admissible.min
            } else {
                spec.admissible.max
            };
            p.set(spec.name, v).unwrap();
        }
        check(&p, &format!("corner {k}: {p:?}"));
    }
}
