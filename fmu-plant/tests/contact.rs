//! The physical car (issue 51): tyres that leave the road, bump, rebound and seat stops.
//!
//! Between events the car is linear and is stepped exactly, and each event is located on the
//! exact trajectory, so the trajectory does not depend on the communication step: runs at
//! steps of 0.1, 1 and 7 ms must agree at their common instants to rounding, whatever the
//! contacts do in between. A located switch a step late would show there as an error of
//! `h` times the jump in acceleration. The independent reference (an event-located ODE solve
//! in SciPy) is `tests/python/test_contact.py`.

use fmu_plant::simulator::{ActuatorParams, Simulator};
use vehicle::contact::ContactParams;
use vehicle::model::{N_ROAD, N_STATES};
use vehicle::VehicleParams;

fn started(physical: bool) -> Simulator {
    let mut sim = Simulator::new(VehicleParams::default(), ActuatorParams::default());
    sim.contact = ContactParams {
        physical,
        ..ContactParams::default()
    };
    sim.start(0.0);
    sim
}

/// The road `drop` below the car under every wheel from the start: the car at its static
/// position hangs above it, falls, lands, bounces and settles.
fn dropped(sim: &mut Simulator, drop: f64) {
    sim.road = [0.0; N_ROAD];
    sim.road[..4].fill(-drop);
}

/// Run to `end` with step `h`, reading the state at every multiple of `every`.
fn run(sim: &mut Simulator, h: f64, end: f64, every: f64) -> Vec<[f64; N_STATES]> {
    let n = (end / h).round() as usize;
    let stride = (every / h).round() as usize;
    let mut out = Vec::new();
    for k in 0..n {
        if k % stride == 0 {
            out.push(sim.state().try_into().unwrap());
        }
        sim.step(k as f64 * h, h).unwrap();
    }
    out.push(sim.state().try_into().unwrap());
    out
}

#[test]
fn a_dropped_car_lands_bounces_and_settles_on_its_tyres() {
    let mut sim = started(true);
    dropped(&mut sim, 0.1);
    let c = sim.contact_state();
    assert_eq!(
        c.on_road, [false; 4],
        "10 cm above the road every wheel hangs"
    );
    let statics = sim.static_equilibrium().clone();
    let mut landed = [None; 4];
    let h = 1e-3;
    // 20 s: the body's heave (ζ ≈ 0.17 at 1 Hz) rings down to 1e-10 of the drop.
    for k in 0..20_000 {
        sim.step(k as f64 * h, h).unwrap();
        let c = sim.contact_state();
        for (when, &on) in landed.iter_mut().zip(&c.on_road) {
            if on && when.is_none() {
                *when = Some((k + 1) as f64 * h);
            }
        }
    }
    let c = sim.contact_state();
    assert_eq!(c.on_road, [true; 4]);
    for (i, when) in landed.iter().enumerate() {
        let t = when.expect("every wheel lands");
        // The gap is 10 cm less the tyre's static compression (2 cm). The suspension's preload
        // (about 3.7 kN on a 40 kg wheel, 92 m/s² on top of g) closes it in about
        // sqrt(2 · 0.079 / 102) = 39 ms, a little later as the preload eases with the stroke.
        assert!((0.039..0.08).contains(&t), "wheel {i} lands at {t} s");
        // In the air until it first lands (to within the step it landed in), and in the
        // bounces after.
        let airborne = c.dwell.airborne[i];
        assert!(
            airborne > t - h && airborne < 1.0,
            "wheel {i} airborne {airborne} s"
        );
        let load = statics.tire_load[i];
        assert!(
            (c.tyre_force[i] - load).abs() < 1e-6 * load,
            "settled on its static load: {} against {load}",
            c.tyre_force[i]
        );
    }
    // Settled 10 cm lower, exactly as the static car shifted down.
    let x = sim.state();
    for (j, expected) in [
        (0, -0.1),
        (1, 0.0),
        (2, 0.0),
        (3, -0.1),
        (4, -0.1),
        (7, -0.1),
    ] {
        assert!((x[j] - expected).abs() < 1e-8, "q[{j}] = {}", x[j]);
    }
    assert_eq!(c.stop_force, [0.0; 5], "no stop is touched once settled");
}

#[test]
fn the_trajectory_through_landings_and_bounces_does_not_depend_on_the_step() {
    let every = 0.007;
    let runs: Vec<_> = [1e-4, 1e-3, 7e-3]
        .iter()
        .map(|&h| {
            let mut sim = started(true);
            // A drop high enough that the rebound reaches the stops.
            dropped(&mut sim, 0.3);
            let states = run(&mut sim, h, 1.4, every);
            let c = sim.contact_state();
            (states, c)
        })
        .collect();
    let at_stop: f64 = runs[1].1.dwell.at_stop.iter().sum();
    assert!(at_stop > 0.0, "the drop reaches a stop");
    let reference = &runs[0].0;
    for (states, _) in &runs[1..] {
        assert_eq!(states.len(), reference.len());
        for (a, b) in states.iter().zip(reference) {
            for j in 0..N_STATES {
                let scale = if j < 8 { 0.3 } else { 3.0 };
                assert!(
                    (a[j] - b[j]).abs() < 1e-9 * scale,
                    "state {j}: {} against {}",
                    a[j],
                    b[j]
                );
            }
        }
    }
    for (_, c) in &runs[1..] {
        for i in 0..4 {
            let (a, b) = (c.dwell.airborne[i], runs[0].1.dwell.airborne[i]);
            assert!((a - b).abs() < 1e-9, "time airborne {a} against {b}");
        }
    }
}

#[test]
fn a_state_saved_in_flight_restores_and_continues_bit_identically() {
    let mut sim = started(true);
    dropped(&mut sim, 0.2);
    let h = 1e-3;
    for k in 0..40 {
        sim.step(k as f64 * h, h).unwrap();
    }
    assert!(!sim.contact_state().on_road[0], "in flight at 40 ms");
    let saved = sim.save();
    let mut copy = started(true);
    copy.restore(&saved).unwrap();
    for k in 40..800 {
        sim.step(k as f64 * h, h).unwrap();
        copy.step(k as f64 * h, h).unwrap();
    }
    assert_eq!(sim.state(), copy.state());
    assert_eq!(sim.contact_state(), copy.contact_state());
    assert_eq!(sim.save(), copy.save());
}

/// On a road that never unloads a tyre or reaches a stop, the physical car is the linear car
/// bit for bit: the same matrices, the same products.
#[test]
fn where_nothing_touches_the_physical_car_is_the_linear_car_bit_for_bit() {
    let (mut physical, mut linear) = (started(true), started(false));
    let h = 1e-3;
    let mut out = ([0.0; 24], [0.0; 24]);
    for k in 0..3000 {
        let t = k as f64 * h;
        for sim in [&mut physical, &mut linear] {
            for i in 0..4 {
                let w = 2.0 * std::f64::consts::PI * (1.3 + 2.1 * i as f64);
                sim.road[i] = 0.01 * (w * t).sin();
                sim.road[4 + i] = 0.01 * w * (w * t).cos();
            }
            sim.command = [300.0, -200.0, 100.0, 0.0, 50.0].map(|f| f * (5.0 * t).sin());
        }
        physical.physical_outputs(&mut out.0);
        linear.physical_outputs(&mut out.1);
        assert_eq!(out.0, out.1);
        physical.step(t, h).unwrap();
        linear.step(t, h).unwrap();
    }
    assert_eq!(physical.state(), linear.state());
    assert_eq!(physical.meter(), linear.meter());
    let c = physical.contact_state();
    assert_eq!(c.on_road, [true; 4]);
    assert_eq!(c.dwell.airborne, [0.0; 4]);
    assert_eq!(c.dwell.at_stop, [0.0; 5]);
}

/// The linear car pulls a wheel down onto a road that falls away (a negative tyre force); the
/// physical car lets it go, and its tyre force never goes negative.
#[test]
fn the_linear_car_pulls_on_the_road_and_the_physical_car_does_not() {
    let (mut physical, mut linear) = (started(true), started(false));
    for sim in [&mut physical, &mut linear] {
        // A 6 cm pothole under FL, 20 ms long: at 20 m/s a 40 cm hole.
        let h = 1e-3;
        let mut least = f64::INFINITY;
        for k in 0..500 {
            sim.road[0] = if (100..120).contains(&k) { -0.06 } else { 0.0 };
            least = least.min(sim.contact_state().tyre_force[0]);
            sim.step(k as f64 * h, h).unwrap();
        }
        if sim.contact.physical {
            assert_eq!(least, 0.0, "the wheel leaves the road");
            assert!(sim.contact_state().dwell.airborne[0] > 0.0);
        } else {
            assert!(least < -1000.0, "the linear tyre pulls: {least} N");
        }
    }
}

/// The undamped car dropped 30 cm: it lands, bounces off its tyres into its stops and flies
/// again, forever. With no damper anywhere its energy (kinetic, every spring's including a
/// tyre's or a stop's only while compressed, gravity's) is constant through every event: a
/// contact switched late, or a free tyre that kept its preload, would show as a jump.
#[test]
fn an_undamped_car_keeps_its_energy_through_every_landing_and_stop() {
    use vehicle::contact::contacts;
    use vehicle::model::{MechanicalModel, N_DOF};
    let mut p = VehicleParams::default();
    (p.c_s_f, p.c_s_r, p.c_t, p.c_seat) = (0.0, 0.0, 0.0, 0.0);
    let contact = ContactParams {
        stop_damping: 0.0,
        seat_stop_damping: 0.0,
        ..ContactParams::default()
    };
    let mut sim = Simulator::new(p, ActuatorParams::default());
    sim.contact = contact;
    sim.start(0.0);
    dropped(&mut sim, 0.3);
    let mech = MechanicalModel::new(&p);
    let statics = mech.static_deflections();
    let unilateral = contacts(&p, &contact);
    let masses = [p.m_s, p.i_x, p.i_y, p.m_seat, p.m_u, p.m_u, p.m_u, p.m_u];
    let heights = [1.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0, 1.0];
    let energy = |x: &[f64], r: &[f64]| -> f64 {
        let (q, v) = x.split_at(N_DOF);
        let kinetic: f64 = (0..N_DOF).map(|j| 0.5 * masses[j] * v[j] * v[j]).sum();
        let gravity: f64 = (0..N_DOF)
            .map(|j| masses[j] * heights[j] * p.g * q[j])
            .sum();
        // The suspensions and the seat: always connected, preloaded by their static deflection.
        let springs: f64 = mech
            .elements
            .iter()
            .zip(&statics)
            .filter(|(e, _)| !matches!(e.kind, vehicle::model::ElementKind::Tyre(_)))
            .map(|(e, d0)| {
                let d: f64 = (0..N_DOF).map(|j| e.jacobian[j] * q[j]).sum();
                0.5 * e.stiffness * (d0 + d).powi(2)
            })
            .sum();
        let contacts: f64 = unilateral
            .elements
            .iter()
            .map(|c| {
                let pen = c.penetration(&vehicle::contact::point(x, r)).max(0.0);
                0.5 * c.stiffness * pen * pen
            })
            .sum();
        kinetic + gravity + springs + contacts
    };
    let r = sim.road;
    let start = energy(sim.state(), &r);
    let scale = (p.m_s + p.m_seat + 4.0 * p.m_u) * p.g * 0.3;
    let (h, mut worst, mut stops, mut flights) = (1e-3, 0.0f64, 0.0, 0.0);
    for k in 0..3000 {
        sim.step(k as f64 * h, h).unwrap();
        worst = worst.max((energy(sim.state(), &r) - start).abs());
        let c = sim.contact_state();
        stops = c.dwell.at_stop.iter().sum();
        flights = c.dwell.airborne.iter().sum();
    }
    eprintln!(
        "energy drift {:.2e} of m g h over 3 s ({stops:.3} s at stops, {flights:.3} s airborne)",
        worst / scale
    );
    assert!(
        stops > 0.0 && flights > 0.3,
        "the run exercises the stops and the flights"
    );
    assert!(worst < 1e-9 * scale, "energy drifts by {worst} J");
}

/// A tyre releases only where its force has fallen to zero, so the acceleration is continuous
/// there and the guard leaves zero on the free side: no chattering. Read every 0.1 ms through
/// a drop that bounces, every flight and every contact of every wheel lasts longer than 2 ms, and a settled
/// wheel stays on the road.
#[test]
fn contacts_do_not_chatter() {
    let mut sim = started(true);
    // 30 cm: the wheels bounce off the road before they stay.
    dropped(&mut sim, 0.3);
    let h = 1e-4;
    let mut last_switch = [0.0; 4];
    let mut on = sim.contact_state().on_road;
    let mut switches = [0; 4];
    let mut shortest = f64::INFINITY;
    for k in 0..20_000 {
        sim.step(k as f64 * h, h).unwrap();
        let t = (k + 1) as f64 * h;
        let now = sim.contact_state().on_road;
        for i in 0..4 {
            if now[i] != on[i] {
                shortest = shortest.min(t - last_switch[i]);
                last_switch[i] = t;
                switches[i] += 1;
            }
        }
        on = now;
    }
    eprintln!("switches per wheel {switches:?}, shortest phase {shortest:.4} s");
    assert!(switches.iter().all(|n| (3..20).contains(n)), "{switches:?}");
    assert!(shortest > 2e-3, "a phase of {shortest} s");
    assert_eq!(on, [true; 4]);
}
