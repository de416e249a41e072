//! The constraint LMIs (thesis ch. 5: actuator force, suspension stroke, dynamic tyre load
//! below the static load) on the shaped road, end to end: synthesis, the certificate's Gramian
//! check, and the design bump simulated exactly on the `vehicle` model itself (not on the
//! generalised plant the LMIs saw), read by the controller through its named inputs.

use nalgebra::DMatrix;
use synth::shipping::design::{Bump, Design, RoadModel, CONSTRAINED_DESIGN_FILE};
use synth::thesis::generalized::GeneralizedPlant;
use synth::thesis::synthesis::synthesise;
use synth::SynthError;
use vehicle::model::{physical_outputs, StateSpace, StaticEquilibrium, CORNERS, N_STATES};
use vehicle::VehicleParams;

/// The checked-in constrained design (`make constrained`): a 2.5 cm design bump.
fn constrained() -> Design {
    Design::from_json(CONSTRAINED_DESIGN_FILE).unwrap()
}

/// The constrained `hinf_sf` holds every limit on its design bump, within the peak its
/// certificate computed from the Gramian (which the bump, having exactly the design energy,
/// cannot exceed), and that peak within the LMI's bound.
#[test]
fn constrained_state_feedback_keeps_force_stroke_and_tyre_load_within_their_limits_on_its_bump() {
    let (p, d) = (VehicleParams::default(), constrained());
    let s = synthesise("hinf_sf", &p, &d).expect("feasible at 2.5 cm");
    let checks = &s.certificate.details["constraints"]["checks"][0]["peaks"];
    let gramian: Vec<(String, f64)> = checks
        .as_array()
        .unwrap()
        .iter()
        .map(|c| {
            (
                c["name"].as_str().unwrap().to_string(),
                c["gramian"].as_f64().unwrap(),
            )
        })
        .collect();
    assert_eq!(gramian.len(), 13);
    for c in checks.as_array().unwrap() {
        let (lmi, gram) = (
            c["lmi_bound"].as_f64().unwrap(),
            c["gramian"].as_f64().unwrap(),
        );
        assert!(gram <= lmi * (1.0 + 1e-6) && lmi <= 1.0 + 1e-6, "{c}");
    }

    // The controller reads x[1..16] and the four tyre deflections (its inputs, by name).
    let inputs: Vec<String> = s
        .controller_json
        .inputs
        .iter()
        .map(|i| i.name.clone())
        .collect();
    assert_eq!(inputs.len(), N_STATES + 4);
    assert!(s.controller.a.nrows() == 0, "static gain");
    let rows = physical_outputs(&p);
    let row = |name: &str| rows.iter().find(|r| r.name == name).unwrap();
    let ss = StateSpace::new(&p);
    // y = C_y x + D_y r (r = [z_r; ż_r]), u = D y, ẋ = A x + B_r r + B_u u.
    let c_y = DMatrix::from_fn(inputs.len(), N_STATES, |i, k| {
        if i < N_STATES {
            f64::from(u8::from(i == k))
        } else {
            row(&inputs[i]).c[k]
        }
    });
    let d_y = DMatrix::from_fn(inputs.len(), 8, |i, k| {
        if i < N_STATES {
            0.0
        } else {
            row(&inputs[i]).d_r[k]
        }
    });
    let k = &s.controller.d;
    let a_cl = &ss.a + &ss.b_u * k * &c_y;
    let b_cl = &ss.b_r + &ss.b_u * k * &d_y;

    // The design bump on the left wheels, the rear one a wheelbase later.
    let b = d.design_bump;
    let delay = (p.l1 + p.l2) / b.speed;
    let road = |t: f64| {
        let mut r = DMatrix::zeros(8, 1);
        for (wheel, t0) in [(0, 0.0), (2, delay)] {
            let x = b.speed * (t - t0);
            if (0.0..=b.length).contains(&x) {
                let w = 2.0 * std::f64::consts::PI / b.length;
                r[(wheel, 0)] = 0.5 * b.height * (1.0 - (w * x).cos());
                r[(4 + wheel, 0)] = 0.5 * b.height * w * b.speed * (w * x).sin();
            }
        }
        r
    };
    let h = 1e-4;
    let step = linsys::discretize(&a_cl, &b_cl, h).unwrap();
    let static_load = StaticEquilibrium::new(&p).tire_load;
    let limits = [d.u_max, d.u_max, d.u_max, d.u_max, d.u_max_seat];
    let RoadModel::Shaped { corner } = d.road_model else {
        unreachable!("constraints need the shaped road")
    };
    let mut peak = vec![0.0f64; 13];
    let mut tyre_ratio = 0.0f64;
    let mut x = DMatrix::zeros(N_STATES, 1);
    for n in 0..(3.0 / h) as usize {
        let (t, r) = (n as f64 * h, road(n as f64 * h));
        let u = k * (&c_y * &x + &d_y * &r);
        let out = |name: &str| {
            let o = row(name);
            (DMatrix::from_row_slice(1, N_STATES, &o.c) * &x
                + DMatrix::from_row_slice(1, 8, &o.d_r) * &r)[(0, 0)]
        };
        for j in 0..5 {
            peak[j] = peak[j].max((u[(j, 0)] / limits[j]).abs());
        }
        for (i, c) in CORNERS.iter().enumerate() {
            peak[5 + i] = peak[5 + i].max((out(&format!("stroke_{c}")) / d.stroke_max).abs());
            // The constraint row is the tyre load less the damper force on the filter's input
            // c_t (ż_r + a z_r), over the static load less the bump's largest such force.
            let load = out(&format!("tire_load_{c}"));
            let direct = p.c_t * (r[(4 + i, 0)] + corner * r[(i, 0)]);
            peak[9 + i] = peak[9 + i].max(
                ((load - direct) / (static_load[i] - p.c_t * d.design_bump_peak_velocity())).abs(),
            );
            tyre_ratio = tyre_ratio.max(load.abs() / static_load[i]);
        }
        x = &step.phi * &x + &step.gamma_hold * &r + &step.gamma_ramp * (road(t + h) - &r);
    }
    println!("design bump {b:?}: simulated peak / Gramian bound:");
    for ((name, bound), sim) in gramian.iter().zip(&peak) {
        println!("  {name:<14} {sim:.4} / {bound:.4}");
        assert!(
            *sim <= bound * (1.0 + 1e-3) + 1e-9,
            "{name}: simulated {sim} above the certified {bound}"
        );
    }
    assert!(tyre_ratio < 1.0, "dynamic tyre load {tyre_ratio} of static");
    // Not vacuous: the bump (left wheels) uses a fair part of the corner forces and of the
    // left strokes and tyre loads (a tenth to a half of the worst case over all inputs of its
    // energy).
    assert!(
        [0, 2, 5, 7, 9, 11].iter().all(|&i| peak[i] > 0.05),
        "{peak:?}"
    );
}

/// At the default 5 cm bump no state feedback can prove all three limits: the synthesis says
/// so, with the best bound any state feedback proves and the bump height that would be feasible.
#[test]
fn infeasible_constraints_are_diagnosed_not_shipped() {
    let d = constrained();
    let at_5cm = Design {
        design_bump: Bump {
            height: 0.05,
            ..d.design_bump
        },
        ..d.clone()
    };
    match synthesise("hinf_sf", &VehicleParams::default(), &at_5cm) {
        Err(SynthError::ConstraintsInfeasible { best, bump, .. }) => {
            assert!(best > 1.0 && best < 3.0, "{best}");
            // The bound is linear in the bump height: half the bump, half the bound — and then
            // the constrained synthesis succeeds (the test above, at the checked-in 2.5 cm).
            assert_eq!(bump.height, 0.05);
            assert!(best * d.design_bump.height / 0.05 < 1.0);
        }
        other => panic!(
            "expected ConstraintsInfeasible, got {:?}",
            other.map(|s| s.certificate.gamma)
        ),
    }
    // The other designs refuse the constraints, and two the road states, rather than ignore them.
    let p = VehicleParams::default();
    for v in ["robust_of", "delay_sf", "ft_of"] {
        assert!(
            matches!(synthesise(v, &p, &constrained()), Err(SynthError::Usage(_))),
            "{v}"
        );
    }
    let shaped = Design {
        constraints: false,
        ..constrained()
    };
    for v in ["robust_of", "ft_of"] {
        assert!(
            matches!(synthesise(v, &p, &shaped), Err(SynthError::Usage(_))),
            "{v}"
        );
    }
}

/// On the shaped road the output feedback estimates the road heights too (a 20th-order
/// controller, certified like any other). At ISO 8608's corner (1 rad/s at 15 m/s) its optimal γ
/// equals the state feedback's, which reads them: both are set by the static road warp of the
/// four independent filters (0.5 m per unit `w`), whose strokes no controller moves — the
/// reason the checked-in constrained design uses a = 5. (Output feedback can never do better
/// than state feedback on the same plant; equal here, to the solvers' accuracy.)
#[test]
fn on_the_iso_corner_the_road_warp_sets_gamma_for_state_and_output_feedback_alike() {
    let (p, d) = (
        VehicleParams::default(),
        Design {
            road_model: RoadModel::Shaped { corner: 1.0 },
            ..Design::default()
        },
    );
    let of = synthesise("hinf_of", &p, &d).unwrap();
    let sf = synthesise("hinf_sf", &p, &d).unwrap();
    assert_eq!(of.controller.a.nrows(), N_STATES + 4);
    let (g_of, g_sf) = (
        of.certificate.details["gamma_opt"].as_f64().unwrap(),
        sf.certificate.details["gamma_opt"].as_f64().unwrap(),
    );
    println!("shaped road: gamma* output feedback {g_of:.6}, state feedback {g_sf:.6}");
    assert!(
        g_of >= g_sf * (1.0 - 1e-4) && g_of <= g_sf * (1.0 + 1e-3),
        "{g_of} vs {g_sf}"
    );
    assert!(
        of.certificate.spectral_abscissa < 0.0
            && of.certificate.norm_upper <= of.certificate.gamma * (1.0 + 1e-6)
    );

    // Why: the open-loop gain at ω = 0 has rank one (the warp, the one road shape the rigid body
    // cannot follow), carried by the strokes, and neither controller gets below it by more than 1 %.
    let g = GeneralizedPlant::new(&p, &d);
    let dc = &g.d_zw - &g.c_z * g.a.clone().lu().solve(&g.b_w).unwrap();
    let sv = dc.clone().svd(false, false).singular_values;
    let strokes = (4..8).map(|i| dc.row(i).norm_squared()).sum::<f64>();
    println!(
        "shaped road, open loop at DC: singular values {:.4} {:.1e}, strokes' share {:.3}",
        sv[0],
        sv[1],
        strokes / dc.norm_squared()
    );
    assert!(sv[1] < 1e-9 * sv[0] && strokes > 0.95 * dc.norm_squared());
    for s in [&of, &sf] {
        assert!(
            s.certificate.norm_upper > 0.99 * sv[0],
            "{} vs {}",
            s.certificate.norm_upper,
            sv[0]
        );
    }
}

/// The constrained output feedback on the car (the LMI algebra is tested on a quarter car in
/// `output_feedback`): certified within every limit for its 2.5 cm bump. About 4 minutes.
#[test]
#[ignore = "about 4 minutes: cargo test --release -p synth --test constraints -- --ignored"]
fn constrained_output_feedback_is_certified_on_the_car() {
    let s = synthesise("hinf_of", &VehicleParams::default(), &constrained())
        .expect("feasible at 2.5 cm");
    assert_eq!(s.controller.d.amax(), 0.0, "strictly proper");
    for c in s.certificate.details["constraints"]["checks"][0]["peaks"]
        .as_array()
        .unwrap()
    {
        let (lmi, gram) = (
            c["lmi_bound"].as_f64().unwrap(),
            c["gramian"].as_f64().unwrap(),
        );
        println!("{c}");
        assert!(gram <= lmi * (1.0 + 1e-6) && lmi <= 1.0 + 1e-6, "{c}");
    }
}
