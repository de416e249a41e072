//! The master on the FMUs `make` built into dist/: scenario files are checked with a clear
//! message, a controller whose inputs the plant lacks is refused before anything runs, and a run
//! reproduces the test helpers' loop (tests/src/lib.rs) on the same FMUs.

use master::cosim::{check_connections, run, Fmu, Scenario};
use std::path::{Path, PathBuf};

fn dist() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../dist")
}

fn scenario(name: &str) -> Scenario {
    Scenario::load(
        &PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("../scenarios")
            .join(format!("{name}.json")),
    )
    .unwrap()
}

fn scenario_error(text: &str) -> String {
    let path = std::env::temp_dir().join(format!(
        "master-scenario-{}-{}.json",
        std::process::id(),
        text.len()
    ));
    std::fs::write(&path, text).unwrap();
    Scenario::load(&path).unwrap_err().0
}

#[test]
fn bad_scenario_files_are_refused_with_the_reason() {
    let good = r#"{"name": "x", "duration": 1.0, "step": 0.001, "road": {"profile": 1}}"#;
    assert!(scenario_error(&good.replace("0.001", "-0.001"))
        .contains("duration and step must be finite and > 0"));
    assert!(
        scenario_error(&good.replace("\"road\"", "\"roads\"")).contains("unknown field `roads`")
    );
    assert!(scenario_error(&good.replace("\"x\"", "\"a b\"")).contains("letters, digits"));
    assert!(scenario_error("{\"name\": ").contains("EOF"));
    let no_limit = good.replace("}}", "}, \"stroke_max\": 0}");
    assert!(scenario_error(&no_limit).contains("stroke_max must be finite and > 0, got 0"));
    assert!(Scenario::load(Path::new("/nonexistent/s.json"))
        .unwrap_err()
        .0
        .contains("cannot read scenario"));
    // Every checked-in scenario loads.
    for entry in
        std::fs::read_dir(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../scenarios")).unwrap()
    {
        Scenario::load(&entry.unwrap().path()).unwrap();
    }
}

#[test]
fn a_controller_reading_what_the_plant_lacks_is_refused() {
    let plant = Fmu::load(&dist(), "plant").unwrap();
    let road = Fmu::load(&dist(), "road").unwrap();
    // The road FMU has outputs but none of the plant's force outputs nor its names: as a
    // "controller" it must be refused with the names it lacks.
    let e = check_connections(&plant, &road).unwrap_err().0;
    assert!(e.contains("has no variable 'u_fl'"), "{e}");
    // The plant as its own controller reads road and force inputs the plant does not output.
    let e = check_connections(&plant, &plant).unwrap_err().0;
    assert!(
        e.contains("reads road_z_fl") && e.contains("which the plant does not output"),
        "{e}"
    );
    check_connections(&plant, &Fmu::load(&dist(), "hinf_of").unwrap()).unwrap();
    assert!(Fmu::load(&dist(), "no_such")
        .err()
        .unwrap()
        .0
        .contains("run `make`"));
    // A road parameter that does not exist fails the run with its name.
    let mut s = scenario("bump");
    s.road.insert("bump_heigth".into(), serde_json::json!(0.1));
    assert!(run(&dist(), &s, None)
        .err()
        .unwrap()
        .0
        .contains("bump_heigth"));
    // A bad road parameter value fails initialisation, not silently, and the error quotes
    // the road FMU's own explanation from its log.
    let mut s = scenario("bump");
    s.road.insert("side".into(), serde_json::json!(3));
    let e = run(&dist(), &s, None).err().unwrap().0;
    assert!(
        e.contains("road: initialisation failed")
            && e.contains("road says: fmi2ExitInitializationMode: side must be 0 (left)"),
        "{e}"
    );
    // Outside its declared range, refused by the road's setter, with the range.
    let mut s = scenario("bump");
    s.road.insert("speed".into(), serde_json::json!(-3.0));
    let e = run(&dist(), &s, None).err().unwrap().0;
    assert!(
        e.contains("road says: fmi2SetReal: value -3 of 'speed' is below its minimum 0.1"),
        "{e}"
    );
    // A value refused at the setter quotes the setter's message.
    let mut s = scenario("bump");
    s.plant.insert("m_s".into(), -1.0);
    let e = run(&dist(), &s, None).err().unwrap().0;
    assert!(
        e.contains("plant: setting 'm_s' = Real(-1.0): Error; plant says: ") && e.contains("m_s"),
        "{e}"
    );
}

/// A scenario's run (its road parameters given to the road FMU) is the loop on the in-process
/// road of the same profile: the scenario file means the road the tests use.
#[test]
fn a_scenario_run_is_the_loop_on_the_in_process_road_of_its_profile() {
    let s = scenario("iso_c");
    let r = run(&dist(), &Scenario { duration: 3.0, ..s }, Some("hinf_of")).unwrap();
    let plant = integration_tests::load("plant");
    let ctrl = integration_tests::load("hinf_of");
    let reference = integration_tests::run_loop(
        &plant,
        Some(&ctrl),
        &integration_tests::iso_road(3, 20.0, 7),
        1e-3,
        3000,
        &["a_seat", "f_fl"],
    );
    let a = r.column("a_seat").unwrap();
    let f = r.column("f_fl").unwrap();
    let worst = reference
        .iter()
        .zip(a.iter().zip(&f))
        .map(|(x, (a, f))| ((x[0] - a).abs() / 1.0).max((x[1] - f).abs() / 1000.0))
        .fold(0.0, f64::max);
    assert!(
        worst < 1e-9,
        "scenario and in-process road differ by {worst}"
    );
    assert_eq!(r.time.len(), 3000);
    assert!((r.time[2999] - 3.0).abs() < 1e-9);
}

/// The saturation flag against a second reading of the same run: with no delay, lag or fault
/// the plant applies exactly the clamped command, so the recorded forces sit at the limit at the
/// same communication points as the commands. And the CSV header carries the FMUs' units.
#[test]
fn the_time_at_the_force_limits_is_the_time_the_applied_forces_sit_there() {
    use master::report::figures;
    let mut s = scenario("saturation");
    s.duration = 2.0;
    for c in ["hinf_of", "hinf_of_aw"] {
        let r = run(&dist(), &s, Some(c)).unwrap();
        assert_eq!(r.delay, 0.0);
        let limits = r.force_limits;
        assert_eq!(limits, [300.0, 300.0, 300.0, 300.0, 100.0]);
        let forces: Vec<Vec<f64>> = ["f_fl", "f_fr", "f_rl", "f_rr", "f_seat"]
            .iter()
            .map(|n| r.column(n).unwrap())
            .collect();
        let at_limit = (0..r.time.len())
            .filter(|&k| {
                forces
                    .iter()
                    .zip(limits)
                    .any(|(f, l)| f[k].abs() >= l * (1.0 - 1e-9))
            })
            .count() as f64
            / r.time.len() as f64;
        let share = figures(&r, &s).flags.saturated_share;
        assert!(share > 0.5, "{c}: {share}");
        assert!(
            (share - at_limit).abs() < 1e-9,
            "{c}: {share} vs {at_limit}"
        );
        let path =
            std::env::temp_dir().join(format!("master-units-{}-{c}.csv", std::process::id()));
        r.write_csv(&path).unwrap();
        let header = std::fs::read_to_string(&path).unwrap();
        let header = header.lines().next().unwrap().to_string();
        assert!(
            header.starts_with("time [s],a_seat [m/s2],alpha_roll [rad/s2],"),
            "{header}"
        );
        assert!(header.contains(",f_seat [N]"), "{header}");
    }
}

/// The comparison's figure says what it shows: unweighted, the fault time marked, the
/// controlled cars on their own scale, a run identical to another named so, and axis labels
/// that read as numbers (not `9.999999999e-5` or `6.9e-11` for zero).
#[test]
fn the_scenario_figure_labels_what_it_shows() {
    let mut s = scenario("fault");
    s.duration = 3.0;
    let runs: Vec<(String, master::cosim::Run)> = [None, Some("hinf_of"), Some("hinf_of_aw")]
        .into_iter()
        .map(|c| {
            (
                c.unwrap_or("passive").to_string(),
                run(&dist(), &s, c).unwrap(),
            )
        })
        .collect();
    let path = std::env::temp_dir().join(format!("master-plot-{}.svg", std::process::id()));
    master::report::plot(
        &path,
        &s,
        &runs.iter().map(|(n, r)| (n.clone(), r)).collect::<Vec<_>>(),
    )
    .unwrap();
    let svg = std::fs::read_to_string(&path).unwrap();
    for text in [
        "fault: seat acceleration, unweighted (the tables are W_k-weighted)",
        "fault at 2 s",
        "The controlled cars on their own scale (unweighted)",
        "PSD of the seat acceleration, unweighted",
        "hinf_of_aw = hinf_of",
    ] {
        assert!(svg.contains(text), "the figure lacks '{text}'");
    }
    // The SVG writes each label on a line of its own, between its tags.
    let labels: Vec<&str> = svg
        .lines()
        .map(str::trim)
        .filter(|l| !l.starts_with('<'))
        .collect();
    for label in [
        "1e-1", "1e-5", "0.5", "2", "20", "0.0", "-1.0", "0.05", "-0.10",
    ] {
        assert!(labels.contains(&label), "no axis label '{label}'");
    }
    assert!(
        !labels
            .iter()
            .any(|l| l.contains("99999") || l.contains("00000")),
        "a label in floating-point noise"
    );
}

#[test]
fn system_descriptions_carry_typed_parameters_and_refuse_bad_ones() {
    use master::cosim::Typed;
    use master::structure::Loop;
    let s = scenario("saturation");
    let l = Loop::new(&dist(), &s, "hinf_of_aw").unwrap();
    let values = |c: &str| l.components.iter().find(|x| x.0 == c).unwrap().1.clone();
    assert!(values("road").contains(&("iso_class".into(), Typed::Integer(4))));
    assert!(values("plant").contains(&("u_max".into(), Typed::Real(300.0))));
    // The anti-windup controller gets the force limits it shares with the plant.
    assert_eq!(
        values("hinf_of_aw"),
        vec![
            ("u_max".into(), Typed::Real(300.0)),
            ("u_max_seat".into(), Typed::Real(100.0))
        ]
    );
    // 8 road signals, the controller's measurements, 5 commands.
    assert_eq!(l.connections.len(), 8 + l.measured.len() + 5);
    // The structure names FMUs beside it: a path is refused, with why.
    let path = dist().join("hinf_of_aw.fmu");
    let e = Loop::new(&dist(), &s, path.to_str().unwrap())
        .err()
        .unwrap()
        .0;
    assert!(e.contains("by its name in --dist"), "{e}");
    let ssd = l.ssd();
    assert!(
        ssd.contains(
            "<ssv:Parameter name=\"iso_class\"><ssv:Integer value=\"4\"/></ssv:Parameter>"
        ),
        "{ssd}"
    );
    assert!(
        ssd.contains("startElement=\"hinf_of_aw\" startConnector=\"u_seat\" endElement=\"plant\"")
    );
    assert!(l
        .osp()
        .contains("<InitialValue variable=\"u_max\"><Real value=\"3e2\"/></InitialValue>"));
    // libcosim steps every simulator before it exchanges values (Jacobi): a predictor is told so
    // in the OSP structure, and only there; a controller without the parameter is not.
    let told = "<InitialValue variable=\"master_order\"><Integer value=\"1\"/></InitialValue>";
    let predictor = Loop::new(&dist(), &scenario("bump"), "delay_sf").unwrap();
    assert!(predictor.osp().contains(told), "{}", predictor.osp());
    assert!(!predictor.ssd().contains("master_order"));
    assert!(!l.osp().contains("master_order"));
    // A value the variable's type cannot take is refused with the names.
    let mut bad = scenario("bump");
    bad.road.insert("profile".into(), serde_json::json!(1.5));
    let e = Loop::new(&dist(), &bad, "hinf_of").err().unwrap().0;
    assert!(
        e.contains("road: parameter 'profile' cannot take 1.5"),
        "{e}"
    );
    let e = Loop::new(&dist(), &scenario("bump"), "no_such")
        .err()
        .unwrap()
        .0;
    assert!(e.contains("no_such.fmu not found"), "{e}");
}

/// The master explains itself: a mistyped controller or parameter gets the closest name, a
/// controller FMU can be given by path, a scenario sets controller parameters, and `master run`
/// prints the metrics it measured.
#[test]
fn mistakes_get_suggestions_and_controllers_take_paths_and_parameters() {
    let e = run(&dist(), &scenario("bump"), Some("hinf_sff"))
        .err()
        .unwrap()
        .0;
    assert!(e.contains("did you mean 'hinf_sf'?"), "{e}");
    let mut s = scenario("bump");
    s.road.insert("bump_heigth".into(), serde_json::json!(0.1));
    let e = run(&dist(), &s, None).err().unwrap().0;
    assert!(e.contains("did you mean 'bump_height'?"), "{e}");
    // Nothing close: no suggestion.
    let e = run(&dist(), &scenario("bump"), Some("zzz"))
        .err()
        .unwrap()
        .0;
    assert!(!e.contains("did you mean"), "{e}");

    // A path to an .fmu is the same controller as its name in --dist.
    let by_name = run(&dist(), &scenario("bump"), Some("hinf_of")).unwrap();
    let path = dist().join("hinf_of.fmu");
    let elsewhere = Path::new("/nonexistent");
    let by_path = run(elsewhere, &scenario("bump"), Some(path.to_str().unwrap()));
    let by_path = by_path.err().map(|e| e.0).unwrap_or_default();
    assert!(
        by_path.contains("road.fmu not found"),
        "road and plant stay in --dist: {by_path}"
    );
    let by_path = run(&dist(), &scenario("bump"), Some(path.to_str().unwrap())).unwrap();
    assert_eq!(by_name.columns, by_path.columns);
    assert_eq!(by_name.data, by_path.data);

    // Controller parameters: ft_of's detector with a threshold nothing reaches never fires.
    let detected =
        |r: &master::cosim::Run| r.column("fault_detected").unwrap().iter().any(|v| *v > 0.5);
    let fault = scenario("fault");
    assert!(detected(&run(&dist(), &fault, Some("ft_of")).unwrap()));
    let mut s = fault.clone();
    s.controller
        .insert("fault_threshold".into(), serde_json::json!(1e9));
    assert!(!detected(&run(&dist(), &s, Some("ft_of")).unwrap()));
    // … a misspelt one is refused with the right name, an output is not a parameter, and a
    // controller without the parameter refuses the scenario.
    let mut s = fault.clone();
    s.controller
        .insert("fault_treshold".into(), serde_json::json!(10.0));
    let e = run(&dist(), &s, Some("ft_of")).err().unwrap().0;
    assert!(e.contains("did you mean 'fault_threshold'?"), "{e}");
    let mut s = fault.clone();
    s.controller.insert("u_fl".into(), serde_json::json!(1.0));
    let e = run(&dist(), &s, Some("ft_of")).err().unwrap().0;
    assert!(e.contains("'u_fl' is not a parameter"), "{e}");
    let mut s = fault.clone();
    s.controller
        .insert("fault_threshold".into(), serde_json::json!(10.0));
    assert!(run(&dist(), &s, Some("hinf_sf")).is_err());
    // The passive car ignores them.
    run(&dist(), &s, None).unwrap();

    // `master run` prints what it measured.
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_master"))
        .args(["--dist", dist().to_str().unwrap(), "run", "--scenario"])
        .arg(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../scenarios/bump.json"))
        .args(["--controller", "hinf_sf", "--out"])
        .arg(std::env::temp_dir().join(format!("master-run-{}.csv", std::process::id())))
        .output()
        .unwrap();
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    let figures = master::report::figures(
        &run(&dist(), &scenario("bump"), Some("hinf_sf")).unwrap(),
        &scenario("bump"),
    );
    assert!(
        text.contains(&format!(
            "wk_rms_seat_m_s2       {:.6}",
            figures.wk_rms_seat
        )),
        "{text}"
    );
}

/// A scenario's plant overrides are numbers: the plant's Boolean `sensor_model` takes 0 or 1
/// and its Integer `sensor_seed` a whole number; anything else is refused with the parameter's
/// name, and a run with the sensor model switched on this way runs.
#[test]
fn plant_overrides_set_boolean_and_integer_parameters_from_numbers() {
    use master::cosim::Typed;
    let plant = Fmu::load(&dist(), "plant").unwrap();
    let typed = |name: &str, v: f64| plant.typed(name, &serde_json::json!(v));
    assert_eq!(typed("sensor_model", 1.0).unwrap(), Typed::Boolean(true));
    assert_eq!(typed("sensor_model", 0.0).unwrap(), Typed::Boolean(false));
    assert_eq!(typed("sensor_seed", 42.0).unwrap(), Typed::Integer(42));
    for (name, v) in [
        ("sensor_model", 0.5),
        ("sensor_seed", 1.5),
        ("sensor_seed", 1e12),
    ] {
        let e = typed(name, v).unwrap_err().0;
        assert!(
            e.contains(&format!("parameter '{name}' cannot take")),
            "{e}"
        );
    }
    let mut s = scenario("bump");
    s.duration = 0.5;
    s.plant.insert("sensor_model".into(), 1.0);
    s.plant.insert("sensor_seed".into(), 3.0);
    run(&dist(), &s, Some("hinf_of")).unwrap();
}
