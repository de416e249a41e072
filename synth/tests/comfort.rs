//! The comfort designs (`synth/designs/comfort.json`) end to end through the registry: what
//! their certificates claim, checked against the certificates' own independent predictions on
//! the car (exact wheelbase delay) and against the nominal counterparts at the same conditions.

use serde_json::Value;
use synth::shipping::registry::{synthesise_all, DesignFile, Outcome};
use vehicle::VehicleParams;

fn outcome() -> Outcome {
    let file = DesignFile::from_json(include_str!("../designs/comfort.json")).unwrap();
    synthesise_all(&[], &VehicleParams::default(), &file).unwrap()
}

fn seat(figures: &Value) -> f64 {
    figures["wk_rms_seat_m_s2"]
        .as_f64()
        .unwrap_or(f64::INFINITY)
}

/// `(own, nominal)` W_k seat predictions at each condition of a robust design's uncertainty
/// (infinite where a loop is unstable).
fn beside_nominal(cert: &Value) -> Vec<(String, f64, f64)> {
    let u = &cert["comfort"]["uncertainty"];
    let own = u["predictions"].as_array().unwrap();
    let nominal = u["nominal_design"].as_array().unwrap();
    assert_eq!(own.len(), nominal.len());
    own.iter()
        .zip(nominal)
        .map(|(o, n)| (o[0].as_str().unwrap().to_string(), seat(&o[1]), seat(&n[1])))
        .collect()
}

/// The same as a master runs the loops (`held`, `nominal_held`: held at the design file's
/// communication step).
fn held_beside_nominal(cert: &Value) -> Vec<(String, f64, f64)> {
    let u = &cert["comfort"]["uncertainty"];
    let figure = |h: &Value| {
        h["predicted_wk_rms_seat_m_s2"]
            .as_f64()
            .unwrap_or(f64::INFINITY)
    };
    let (own, nominal) = (
        u["held"].as_array().unwrap(),
        u["nominal_held"].as_array().unwrap(),
    );
    assert_eq!(own.len(), nominal.len());
    beside_nominal(cert)
        .into_iter()
        .zip(own.iter().zip(nominal))
        .map(|((label, _, _), (o, n))| (label, figure(o), figure(n)))
        .collect()
}

#[test]
fn comfort_designs_beat_the_passive_car_and_robust_designs_earn_their_name() {
    let out = outcome();
    for (name, why) in &out.refused {
        assert!(!why.is_empty(), "{name} refused without a reason");
    }
    let cert = |name: &str| -> &Value {
        &out.designs
            .iter()
            .find(|(n, _)| n == name)
            .unwrap_or_else(|| panic!("{name} was refused: {:?}", out.refused))
            .1
            .certificate
    };
    for (name, s) in &out.designs {
        let c = &s.certificate["comfort"];
        let (predicted, passive) = (
            c["predicted_wk_rms_seat_m_s2"].as_f64().unwrap(),
            c["passive_wk_rms_seat_m_s2"].as_f64().unwrap(),
        );
        // Every design 80 % below the passive car on the design road: each pays on it for the
        // long waves and the seat stroke limit of its design road (the state feedbacks' as the
        // car's: `ComfortDesign::for_state_feedback`; they were 95 % below without them, and
        // rode the seat on its stops over 1 m hills). The baselines (no H∞ design) are what
        // they are: the floors guard what they measured (skyhook 0.28, lqg 0.53 of the passive
        // car).
        let floor = match name.as_str() {
            "skyhook" => 0.35,
            "lqg" => 0.6,
            _ => 0.2,
        };
        assert!(
            predicted < floor * passive,
            "{name}: {predicted} vs passive {passive}"
        );
        // A claimed guarantee covers every prediction the certificate makes.
        if let Some(g) = c["guaranteed_wk_rms_seat_m_s2"].as_f64() {
            let worst = c["uncertainty"]["worst_predicted_wk_rms_seat_m_s2"]
                .as_f64()
                .unwrap_or(predicted);
            assert!(
                g >= worst * (1.0 - 1e-12),
                "{name}: guarantee {g} below {worst}"
            );
        }
        // Every loop tolerates the unmodelled delay; the LQG baseline's control weight is tuned
        // to the least that does (a bisection to 1 %), so its channel's norm sits just below 1.
        let norm = s.certificate["unmodelled_delay"]["small_gain_norm"]
            .as_f64()
            .unwrap();
        assert!(norm < 1.0, "{name}: unmodelled-delay norm {norm}");
        if name == "lqg" {
            assert!(
                norm > 0.95,
                "lqg: its force weight is not the least that holds ({norm})"
            );
        }
        // The controller file says what the FMU will report.
        assert!(s.controller_json.guarantee.value > 0.0, "{name}");
    }
    // robust_of (on the car's sensors): at most 5 % worse than its nominal design hinf_of
    // anywhere in its mass range (the bound; it picks its filter within it, measured at
    // most 4.3 % worse), better at both ends, where hinf_of degrades, and at its worst better
    // than hinf_of's worst (measured 5.4 %: 0.0744 against 0.0786 m/s² at 1200 kg; 21 % when
    // hinf_of was designed behind ideal actuators, whose loop degraded more off its mass, and
    // robust_of still is).
    let rows = beside_nominal(cert("robust_of"));
    for (label, own, nominal) in &rows {
        assert!(
            *own <= 1.05 * nominal,
            "robust_of at {label}: {own} vs hinf_of {nominal}"
        );
    }
    for (label, own, nominal) in [&rows[0], &rows[rows.len() - 1]] {
        assert!(
            own < nominal,
            "robust_of at {label}: {own} vs hinf_of {nominal}"
        );
    }
    let worst = |r: &[(String, f64, f64)], i: usize| {
        r.iter()
            .map(|x| if i == 0 { x.1 } else { x.2 })
            .fold(0.0, f64::max)
    };
    assert!(worst(&rows, 0) < 0.97 * worst(&rows, 1), "{rows:?}");
    // robust_sf: state feedback's comfort barely depends on the mass (hinf_sf is robust by
    // physics: 0.00848 to 0.00897 m/s² over the range), and the guaranteed-cost gain over the
    // range was 3–5.4 % worse everywhere; robust_sf takes the better of the two certified gains
    // over the range, so it is within the 5 % of hinf_sf at every mass.
    for (label, own, nominal) in beside_nominal(cert("robust_sf")) {
        assert!(
            own <= 1.05 * nominal,
            "robust_sf at {label}: {own} vs hinf_sf {nominal}"
        );
    }
    // The mass designs' bounds are certified on the car model (its own rear track, Padé
    // order 8, beside the controller's order-2 preview) and claimed where each covers every
    // prediction on the exact car (checked above) and the car model at every mass of the
    // file's grid: robust_of's does. On the design model robust_sf's bound (0.008971) fell
    // 0.03 % short of the car's worst prediction (0.008974): that model's preview was the rear
    // road itself. In its frame (`synth::comfort::plant::Frame`) robust_sf follows the road's
    // long waves, of which the car's road (a flat velocity spectrum down to its band's lower
    // end) has more than the car model's first-order one: its bound falls about 1 % short of
    // the car's worst, and is not claimed; the certificate says so.
    for name in ["robust_sf", "robust_of"] {
        let u = &cert(name)["comfort"]["uncertainty"];
        let guaranteed = cert(name)["comfort"]["guaranteed_wk_rms_seat_m_s2"].as_f64();
        let bound = u["bound_wk_rms_seat"]["value"].as_f64().unwrap();
        if name == "robust_sf" {
            let worst = u["worst_predicted_wk_rms_seat_m_s2"].as_f64().unwrap();
            assert_eq!(guaranteed, None, "{name}");
            assert!(
                bound < worst && worst < 1.02 * bound,
                "{name}: bound {bound}, worst {worst}"
            );
            assert!(
                u["bound_failure"]
                    .as_str()
                    .is_some_and(|f| f.contains("does not cover")),
                "{name}: {}",
                u["bound_failure"]
            );
        } else {
            assert_eq!(guaranteed, Some(bound), "{name}: {}", u["bound_failure"]);
        }
        assert!(
            u["bound_model"].as_str().unwrap().contains("order 8"),
            "{name}: {}",
            u["bound_model"]
        );
        let grid = u["bound_model_grid_worst_wk_rms_seat"].as_f64().unwrap();
        assert!(grid <= bound, "{name}: grid {grid} above bound {bound}");
        assert_eq!(u["bound_model_grid_points"].as_u64(), Some(61), "{name}");
    }
    // delay_sf's predictor lets the car model's road climb at its frame's rate, so the closed
    // form over the delays (the car model with the predictor matched to its road) is computed
    // and reported but not claimed for it. (Without the frame it was, and covered every prediction
    // on the exact car; predicting the design model, the car's worst was 8.7 % above it.)
    let u = &cert("delay_sf")["comfort"]["uncertainty"];
    assert_eq!(
        cert("delay_sf")["comfort"]["guaranteed_wk_rms_seat_m_s2"].as_f64(),
        None
    );
    assert!(u["over_delays"]["bound"].as_f64().is_some());
    assert!(
        u["bound_failure"]
            .as_str()
            .is_some_and(|f| f.contains("climb at its frame's rate")),
        "{}",
        u["bound_failure"]
    );
    assert!(u["bound_model"].as_str().unwrap().contains("order 8"));
    // delay_sf: stable and predicted at every delay up to delay_max, where hinf_sf is not.
    let rows = beside_nominal(cert("delay_sf"));
    assert!(rows.iter().all(|(_, own, _)| own.is_finite()), "{rows:?}");
    assert!(
        rows.iter().any(|(_, _, nominal)| !nominal.is_finite()),
        "{rows:?}"
    );
    assert!(
        rows.iter().any(|(label, _, _)| label == "delay 20.0 ms"),
        "{rows:?}"
    );
    for (label, own, nominal) in &rows {
        assert!(
            *own <= 1.05 * nominal,
            "delay_sf at {label}: {own} vs hinf_sf {nominal}"
        );
    }
    // ft_of: accommodated, its loop at every condition of the effectiveness box is, once the
    // estimate settles, the nominal one: every prediction is its nominal prediction. Its nominal
    // design hinf_of (the same law, its observer driven by the load cells, no accommodation)
    // barely notices a corner at half force (within 2 %: measured 0.3 % better to 2 % worse),
    // but loses its seat isolation, a cancellation by command, with the seat actuator at half
    // (predicted 0.186 m/s²) or all at half (0.271): there ft_of is at least twice as good.
    let ft = cert("ft_of");
    let own_nominal = ft["comfort"]["predicted_wk_rms_seat_m_s2"]
        .as_f64()
        .unwrap();
    let rows = beside_nominal(ft);
    assert_eq!(rows.len(), 6, "{rows:?}");
    for (label, own, nominal) in &rows {
        assert!(
            (own / own_nominal - 1.0).abs() < 1e-12,
            "ft_of at {label}: {own}, nominally {own_nominal}"
        );
        assert!(
            *own <= 1.05 * nominal,
            "ft_of at {label}: {own} vs hinf_of {nominal}"
        );
        if label.starts_with("seat") || label.starts_with("all") {
            assert!(
                *own < 0.5 * nominal,
                "ft_of at {label}: {own} vs hinf_of {nominal}"
            );
        }
    }
    assert_eq!(
        ft["comfort"]["guaranteed_wk_rms_seat_m_s2"].as_f64(),
        Some(own_nominal)
    );
    // The same comparisons as a master runs the loops (held at 1 ms): the hold adds 5–40 % to
    // a design's figures, unevenly over its uncertainty, but keeps the comparisons.
    for (robust, nominal) in [
        ("robust_sf", "hinf_sf"),
        ("robust_of", "hinf_of"),
        ("delay_sf", "hinf_sf"),
        ("ft_of", "hinf_of"),
    ] {
        let rows = held_beside_nominal(cert(robust));
        for (label, own, nom) in &rows {
            assert!(own.is_finite(), "{robust} at {label} unstable at the step");
            assert!(
                *own <= 1.05 * nom,
                "{robust} at {label}: {own} vs {nominal} {nom} at the step"
            );
        }
        // Better where the nominal design degrades: the ends of the mass range, the longest
        // delay, the seat's and every actuator's fault (hinf_sf is robust to mass by physics;
        // hinf_of barely notices a corner's fault).
        let ends = match robust {
            "robust_sf" => vec![],
            "delay_sf" => vec![&rows[rows.len() - 1]],
            "ft_of" => vec![&rows[rows.len() - 2], &rows[rows.len() - 1]],
            _ => vec![&rows[0], &rows[rows.len() - 1]],
        };
        for (label, own, nom) in ends {
            assert!(own < nom, "{robust} at {label}: {own} vs {nominal} {nom}");
        }
    }
}
