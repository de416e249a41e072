//! The generic controller FMU through its exported C functions: a missing, corrupt or
//! mismatched `controller.json` is refused at `fmi2Instantiate` with a message; a dynamic
//! controller is stepped exactly; outputs feed through `D`.

use fmi_test_logger::LogCapture;
use fmu_controller::spec::Spec;
use fmu_controller::*;
use fmu_core::types::*;
use std::ffi::CString;
use std::path::{Path, PathBuf};
use std::ptr::null;

/// A first-order controller: ẋc = −2 xc + y1, u_a = 3 xc + 0.5 y2, u_b = −y1.
const SPEC: &str = r#"{
  "format": "suspension-controller/2", "variant": "test_ctrl", "description": "test", "guarantee": {"name": "gamma", "value": 1.5, "unit": "1", "description": "test"},
  "inputs": [{"name": "stroke_fl", "unit": "m"}, {"name": "v_body", "unit": "m/s"}],
  "outputs": [{"name": "u_fl", "unit": "N"}, {"name": "u_fr", "unit": "N"}],
  "A": [[-2.0]], "B": [[1.0, 0.0]], "C": [[3.0], [0.0]], "D": [[0.0, 0.5], [-1.0, 0.0]]
}"#;

fn dir_with(name: &str, content: Option<&str>) -> PathBuf {
    let d = std::env::temp_dir().join(format!("fmu-controller-test-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    let f = d.join("controller.json");
    match content {
        Some(c) => std::fs::write(&f, c).unwrap(),
        None => {
            let _ = std::fs::remove_file(&f);
        }
    }
    d
}

fn instantiate(
    log: &LogCapture,
    guid: &str,
    resources: Option<&Path>,
) -> (Fmi2Component, Box<fmi_test_logger::Callbacks>) {
    let cb = Box::new(log.callbacks());
    let name = CString::new("ctrl").unwrap();
    let guid = CString::new(guid).unwrap();
    let uri = resources.map(|p| CString::new(format!("file://{}", p.display())).unwrap());
    let c = unsafe {
        fmi2Instantiate(
            name.as_ptr(),
            FMI2_CO_SIMULATION,
            guid.as_ptr(),
            uri.as_ref().map_or(null(), |u| u.as_ptr()),
            &*cb as *const _ as *const CallbackFunctions,
            0,
            0,
        )
    };
    (c, cb)
}

fn guid_of(spec: &str) -> String {
    description_for(&Spec::from_json(spec).unwrap()).guid
}

/// The two outputs' value references of [`SPEC`]'s controller.
const OUTPUTS: [u32; 2] = [vr::OUTPUT, vr::OUTPUT + 1];

/// `spec` from the resource directory `name`, instantiated, initialised and its two inputs set
/// to `[0.2, 4.0]`: ready to step.
fn running(
    log: &LogCapture,
    name: &str,
    spec: &str,
) -> (Fmi2Component, Box<fmi_test_logger::Callbacks>) {
    let dir = dir_with(name, Some(spec));
    let (c, cb) = instantiate(log, &guid_of(spec), Some(&dir));
    assert!(!c.is_null(), "{:?}", log.messages());
    unsafe {
        fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0);
        fmi2EnterInitializationMode(c);
        fmi2ExitInitializationMode(c);
        let inputs = [vr::INPUT, vr::INPUT + 1];
        assert_eq!(fmi2SetReal(c, inputs.as_ptr(), 2, [0.2, 4.0].as_ptr()), 0);
    }
    (c, cb)
}

#[test]
fn dynamic_controller_is_stepped_exactly_with_feedthrough() {
    let log = LogCapture::default();
    let (c, _cb) = running(&log, "good", SPEC);
    let outs = OUTPUTS;
    unsafe {
        let mut u = [0.0; 2];
        fmi2GetReal(c, outs.as_ptr(), 2, u.as_mut_ptr());
        assert_eq!(u, [2.0, -0.2], "direct feed-through before any step");
        for k in 0..10 {
            assert_eq!(fmi2DoStep(c, k as f64 * 0.1, 0.1, 1), 0);
        }
        fmi2GetReal(c, outs.as_ptr(), 2, u.as_mut_ptr());
        // xc(1) = 0.2 (1 − e^{−2})/2 with y1 held at 0.2.
        let xc = 0.1 * (1.0 - (-2.0f64).exp());
        assert!((u[0] - (3.0 * xc + 2.0)).abs() < 1e-14, "{u:?}");
        let mut gamma = 0.0;
        fmi2GetReal(c, &vr::GUARANTEE, 1, &mut gamma);
        assert_eq!(gamma, 1.5);
        fmi2FreeInstance(c);
    }
}

#[test]
fn missing_corrupt_or_mismatched_controller_json_gives_null_with_a_message() {
    let log = LogCapture::default();
    let guid = guid_of(SPEC);
    let (c, _cb) = instantiate(&log, &guid, Some(&dir_with("missing", None)));
    assert!(c.is_null());
    assert!(
        log.contains("cannot read") && log.contains("controller.json"),
        "{:?}",
        log.messages()
    );

    let (c, _cb) = instantiate(
        &log,
        &guid,
        Some(&dir_with(
            "corrupt",
            Some("{\"format\": \"suspension-controller/1\", \"A\": [[1, 2]"),
        )),
    );
    assert!(c.is_null());
    assert!(
        log.contains("controller.json is not valid"),
        "{:?}",
        log.messages()
    );

    let bad_shape = SPEC.replace(r#""D": [[0.0, 0.5], [-1.0, 0.0]]"#, r#""D": [[0.0, 0.5]]"#);
    let (c, _cb) = instantiate(&log, &guid, Some(&dir_with("shape", Some(&bad_shape))));
    assert!(c.is_null());
    assert!(
        log.contains("matrix D should be 2×2"),
        "{:?}",
        log.messages()
    );

    // Same interface, other gains: the GUID the importer read from modelDescription.xml no
    // longer matches the controller.json beside the binary.
    let other = SPEC.replace("\"A\": [[-2.0]]", "\"A\": [[-3.0]]");
    let (c, _cb) = instantiate(&log, &guid, Some(&dir_with("mismatch", Some(&other))));
    assert!(c.is_null());
    assert!(log.contains("GUID mismatch"), "{:?}", log.messages());

    let (c, _cb) = instantiate(&log, &guid, None);
    assert!(c.is_null());
    assert!(log.contains("passed no resource location"));
}

#[test]
fn spec_rejects_non_finite_numbers_duplicates_and_bad_identifiers() {
    assert!(matches!(
        Spec::from_json(&SPEC.replace("1.5", "NaN")),
        Err(spec::SpecError::Syntax(_))
    ));
    assert!(matches!(
        Spec::from_json(&SPEC.replace("\"v_body\"", "\"stroke_fl\"")),
        Err(spec::SpecError::Invalid(_))
    ));
    assert!(matches!(
        Spec::from_json(&SPEC.replace("test_ctrl", "test ctrl")),
        Err(spec::SpecError::Invalid(_))
    ));
    assert!(matches!(
        Spec::from_json(&SPEC.replace("suspension-controller/2", "other/2")),
        Err(spec::SpecError::Format(_))
    ));
}

/// A communication step beyond the ones `controller.json` says its loop is stable at is
/// stepped (the step itself is exact) and answered with `fmi2Warning` and one log message per
/// step size; the steps within them stay `fmi2OK`. Values that make no range are refused.
#[test]
fn a_step_beyond_the_stable_communication_steps_is_a_warning_once_per_step_size() {
    let with = |steps: &str| {
        SPEC.replace(
            r#""variant": "test_ctrl","#,
            &format!(r#""variant": "test_ctrl", "communication_steps": {steps},"#),
        )
    };
    let spec = with(r#"{"stable_up_to_s": 0.001, "unstable_at_s": 0.00125}"#);
    let log = LogCapture::default();
    let (c, _cb) = running(&log, "steps", &spec);
    let mut t = 0.0;
    let mut step = |h: f64| {
        let status = unsafe { fmi2DoStep(c, t, h, 1) };
        t += h;
        status
    };
    assert_eq!(step(0.0005), 0);
    assert_eq!(step(0.001), 0);
    assert!(log.messages().is_empty(), "{:?}", log.messages());
    assert_eq!(step(0.002), 1, "fmi2Warning beyond the stable steps");
    let said = log.messages();
    assert_eq!(said.len(), 1, "{said:?}");
    assert!(
        said[0].contains("communication step 0.002 s")
            && said[0].contains("up to 0.001 s")
            && said[0].contains("unstable at 0.00125 s"),
        "{said:?}"
    );
    assert_eq!(step(0.002), 0, "said once per step size");
    assert_eq!(step(0.001), 0);
    assert_eq!(step(0.003), 1, "another step size is said again");
    assert_eq!(log.messages().len(), 2);
    // Stepped exactly all the same: xc after the steps with y1 held at 0.2.
    let mut u = [0.0; 2];
    unsafe { fmi2GetReal(c, OUTPUTS.as_ptr(), 2, u.as_mut_ptr()) };
    let xc = 0.1 * (1.0 - (-2.0 * t).exp());
    assert!((u[0] - (3.0 * xc + 2.0)).abs() < 1e-14, "{u:?}");
    unsafe { fmi2FreeInstance(c) };

    for bad in [
        r#"{"stable_up_to_s": 0.0}"#,
        r#"{"stable_up_to_s": 0.002, "unstable_at_s": 0.001}"#,
        r#"{"stable_up_to_s": -1.0}"#,
        r#"{"unstable_at_s": 0.001}"#,
        r#"{"stable_up_to_s": 0.001, "beyond": 2}"#,
    ] {
        assert!(Spec::from_json(&with(bad)).is_err(), "{bad} accepted");
    }
    assert!(Spec::from_json(&with(r#"{"stable_up_to_s": 0.01}"#)).is_ok());
}

/// Static controller `y_c = [10 y; 0]` with a scalar anti-windup state: `η̇ = −η + (u_fl − y_c,fl)`,
/// the controller reads `y − 0.5 η`, `u = sat(y_c + [0; 1] η)`.
const AW_SPEC: &str = r#"{
  "format": "suspension-controller/2", "variant": "test_aw", "description": "test", "guarantee": {"name": "gamma", "value": 1.0, "unit": "1", "description": "test"},
  "inputs": [{"name": "stroke_fl", "unit": "m"}],
  "outputs": [{"name": "u_fl", "unit": "N"}, {"name": "u_seat", "unit": "N"}],
  "A": [], "B": [], "C": [[], []], "D": [[10.0], [0.0]],
  "anti_windup": {"A": [[-1.0]], "B": [[1.0, 0.0]], "C": [[0.5]], "F": [[0.0], [1.0]], "u_max": [4.0, 1000.0]}
}"#;

/// Run the anti-windup controller with `y = 1` for one step of 0.1 s after setting `u_max`;
/// returns the commands before and after the step and the status of leaving initialisation.
fn aw_step(u_max: Option<f64>) -> (Fmi2Status, [f64; 2], [f64; 2]) {
    let log = LogCapture::default();
    let dir = dir_with(&format!("aw-{u_max:?}"), Some(AW_SPEC));
    let (c, _cb) = instantiate(&log, &guid_of(AW_SPEC), Some(&dir));
    assert!(!c.is_null(), "{:?}", log.messages());
    let outs = [vr::OUTPUT, vr::OUTPUT + 1];
    let (mut before, mut after) = ([0.0; 2], [0.0; 2]);
    unsafe {
        if let Some(l) = u_max {
            let status = fmi2SetReal(c, &vr::LIMIT, 1, &l);
            if status != 0 {
                fmi2FreeInstance(c);
                return (status, before, after);
            }
        }
        fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0);
        fmi2EnterInitializationMode(c);
        let status = fmi2ExitInitializationMode(c);
        if status == 0 {
            fmi2SetReal(c, &vr::INPUT, 1, &1.0);
            fmi2GetReal(c, outs.as_ptr(), 2, before.as_mut_ptr());
            assert_eq!(fmi2DoStep(c, 0.0, 0.1, 1), 0);
            fmi2GetReal(c, outs.as_ptr(), 2, after.as_mut_ptr());
        }
        fmi2FreeInstance(c);
        (status, before, after)
    }
}

#[test]
fn anti_windup_saturates_and_integrates_the_excess_exactly() {
    // Saturated: u_fl = sat(10) = 4; the excess −6 drives η = −6 (1 − e^{−0.1}), seen on u_seat.
    let (status, before, after) = aw_step(None);
    assert_eq!(status, 0);
    assert_eq!(before, [4.0, 0.0]);
    let eta = -6.0 * (1.0 - (-0.1f64).exp());
    assert!((after[1] - eta).abs() < 1e-14, "{after:?} vs η = {eta}");
    // The controller now reads y − 0.5 η: y_c = 10 (1 − 0.5 η) > 4, still saturated.
    assert_eq!(after[0], 4.0);
    // With a limit that is never reached the compensator stays at rest: the linear controller.
    let (_, before, after) = aw_step(Some(100.0));
    assert_eq!((before, after), ([10.0, 0.0], [10.0, 0.0]));
    // A negative limit is refused (the declared minimum is 0).
    assert_ne!(aw_step(Some(-1.0)).0, 0);
    // FMI's bounds are inclusive: a limit of 0 (an actuator that gives no force) saturates
    // everything; the whole command is excess: η = −10 (1 − e^{−0.1}).
    let (status, before, after) = aw_step(Some(0.0));
    assert_eq!(status, 0);
    assert_eq!(before, [0.0, 0.0]);
    let eta = -10.0 * (1.0 - (-0.1f64).exp());
    assert!((after[1] - eta).abs() < 1e-14, "{after:?} vs η = {eta}");
}

/// The inputs' feed-through of the forces (`anti_windup.D`): the controller `ẋ = −x + w`,
/// `y_c = [100 x; x]`, reads `w = y − D (u − y_c)` with `D = [0.5, 0]` (`C = 0`, `F = 0`:
/// the compensator's state plays no part). With `y = 1` the first step leaves `x₁ = 1 − e^{−0.1}`
/// unsaturated on the seat output; the corner's `100 x₁` saturates at 4, and its excess
/// `e = 4 − 100 x₁` enters the next step through `D`: `x₂ = x₁ e^{−0.1} + (1 − 0.5 e)(1 − e^{−0.1})`.
/// A file whose controller `D` reads an input `D` feeds the forces through to (the command would
/// depend on itself) is refused; one whose `D` reads only other inputs is not.
#[test]
fn anti_windup_feeds_the_excess_through_to_the_inputs_that_see_the_forces() {
    let spec = r#"{
  "format": "suspension-controller/2", "variant": "test_aw_d", "description": "test", "guarantee": {"name": "gamma", "value": 1.0, "unit": "1", "description": "test"},
  "inputs": [{"name": "sensor_a_seat", "unit": "m/s2"}],
  "outputs": [{"name": "u_fl", "unit": "N"}, {"name": "u_seat", "unit": "N"}],
  "A": [[-1.0]], "B": [[1.0]], "C": [[100.0], [1.0]], "D": [[0.0], [0.0]],
  "anti_windup": {"A": [[-1.0]], "B": [[1.0, 0.0]], "C": [[0.0]], "D": [[0.5, 0.0]], "F": [[0.0], [0.0]], "u_max": [4.0, 1000.0]}
}"#;
    let log = LogCapture::default();
    let dir = dir_with("aw-d", Some(spec));
    let (c, _cb) = instantiate(&log, &guid_of(spec), Some(&dir));
    assert!(!c.is_null(), "{:?}", log.messages());
    let outs = [vr::OUTPUT, vr::OUTPUT + 1];
    let mut u = [0.0; 2];
    let decay = (-0.1f64).exp();
    unsafe {
        fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0);
        fmi2EnterInitializationMode(c);
        assert_eq!(fmi2ExitInitializationMode(c), 0);
        fmi2SetReal(c, &vr::INPUT, 1, &1.0);
        assert_eq!(fmi2DoStep(c, 0.0, 0.1, 1), 0);
        fmi2GetReal(c, outs.as_ptr(), 2, u.as_mut_ptr());
        let x1 = 1.0 - decay;
        assert!((u[1] - x1).abs() < 1e-14, "{u:?}");
        assert_eq!(u[0], 4.0);
        assert_eq!(fmi2DoStep(c, 0.1, 0.1, 1), 0);
        fmi2GetReal(c, outs.as_ptr(), 2, u.as_mut_ptr());
        let excess = 4.0 - 100.0 * x1;
        let x2 = x1 * decay + (1.0 - 0.5 * excess) * (1.0 - decay);
        assert!((u[1] - x2).abs() < 1e-13, "{u:?} vs x₂ = {x2}");
        fmi2FreeInstance(c);
    }
    let looped = spec.replace(r#""D": [[0.0], [0.0]]"#, r#""D": [[1.0], [0.0]]"#);
    let e = Spec::from_json(&looped).unwrap_err().to_string();
    assert!(e.contains("depend on itself"), "{e}");
    // A feed-through on an input the forces do not reach is no loop (`D_K D = 0`: a state
    // feedback's gain on the stroke beside the accelerometer only its filters read).
    let two = spec
        .replace(
            r#"[{"name": "sensor_a_seat", "unit": "m/s2"}]"#,
            r#"[{"name": "sensor_a_seat", "unit": "m/s2"}, {"name": "sensor_stroke_seat", "unit": "m"}]"#,
        )
        .replace(r#""B": [[1.0]]"#, r#""B": [[1.0, 0.0]]"#)
        .replace(r#""C": [[0.0]], "D": [[0.5, 0.0]]"#, r#""C": [[0.0], [0.0]], "D": [[0.5, 0.0], [0.0, 0.0]]"#);
    let on_stroke = two.replace(r#""D": [[0.0], [0.0]]"#, r#""D": [[0.0, 3.0], [0.0, 0.0]]"#);
    assert!(
        Spec::from_json(&on_stroke).is_ok(),
        "{:?}",
        Spec::from_json(&on_stroke).err()
    );
    let on_acceleration = two.replace(r#""D": [[0.0], [0.0]]"#, r#""D": [[3.0, 0.0], [0.0, 0.0]]"#);
    let e = Spec::from_json(&on_acceleration).unwrap_err().to_string();
    assert!(e.contains("depend on itself"), "{e}");
}

/// Static controller `u = 2 y` with a scalar detector `ξ̇ = −ξ + y − 0.5 u`, `r = ξ`: with `y = 1`
/// held, `u = 2`, so `ξ̇ = −ξ` and `ξ(0) = 0` stays 0 (no fault signature); with `ξ(0) = 0` and
/// an input the command does not cancel, `ξ(t) = c (1 − e^{−t})`.
const FD_SPEC: &str = r#"{
  "format": "suspension-controller/2", "variant": "test_fd", "description": "test", "guarantee": {"name": "gamma", "value": 1.0, "unit": "1", "description": "test"},
  "inputs": [{"name": "stroke_fl", "unit": "m"}],
  "outputs": [{"name": "u_fl", "unit": "N"}],
  "A": [], "B": [], "C": [[]], "D": [[2.0]],
  "fault_detection": {"A": [[-1.0]], "B": [[3.0]], "B_u": [[-0.5]], "C": [[1.0]], "D": [[0.0]], "threshold": 1.0}
}"#;

#[test]
fn fault_detector_integrates_the_command_sent_and_latches_its_flag() {
    let log = LogCapture::default();
    let dir = dir_with("fd", Some(FD_SPEC));
    let (c, _cb) = instantiate(&log, &guid_of(FD_SPEC), Some(&dir));
    assert!(!c.is_null(), "{:?}", log.messages());
    unsafe {
        fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0);
        fmi2EnterInitializationMode(c);
        assert_eq!(fmi2ExitInitializationMode(c), 0);
        let (mut r, mut flag, mut threshold) = (0.0, 1, 0.0);
        fmi2GetReal(c, &vr::FAULT_THRESHOLD, 1, &mut threshold);
        assert_eq!(threshold, 1.0);
        // y = 1: ξ̇ = −ξ + 3 − 0.5·2 = −ξ + 2, so ξ(t) = 2 (1 − e^{−t}): above 1 from t = ln 2.
        fmi2SetReal(c, &vr::INPUT, 1, &1.0);
        let mut rose = None;
        for k in 0..10 {
            assert_eq!(fmi2DoStep(c, k as f64 * 0.1, 0.1, 1), 0);
            fmi2GetReal(c, &vr::RESIDUAL_NORM, 1, &mut r);
            let t = (k + 1) as f64 * 0.1;
            assert!(
                (r - 2.0 * (1.0 - (-t).exp())).abs() < 1e-14,
                "t = {t}: residual {r}"
            );
            fmi2GetBoolean(c, &vr::FAULT_DETECTED, 1, &mut flag);
            if flag != 0 && rose.is_none() {
                rose = Some(t);
            }
        }
        assert!(
            (rose.unwrap() - 0.7).abs() < 1e-9,
            "first communication point with ξ > 1 is t = 0.7, got {rose:?}"
        );
        // The residual falls back under the threshold (y = 0: ξ decays); the flag stays latched.
        fmi2SetReal(c, &vr::INPUT, 1, &0.0);
        for k in 10..40 {
            fmi2DoStep(c, k as f64 * 0.1, 0.1, 1);
        }
        fmi2GetReal(c, &vr::RESIDUAL_NORM, 1, &mut r);
        fmi2GetBoolean(c, &vr::FAULT_DETECTED, 1, &mut flag);
        assert!(r < 0.1 && flag != 0, "residual {r}, flag {flag}");
        fmi2FreeInstance(c);
    }
    // A threshold that is not > 0 is refused in the file; below 0 as a parameter.
    assert!(matches!(
        Spec::from_json(&FD_SPEC.replace("\"threshold\": 1.0", "\"threshold\": 0.0")),
        Err(spec::SpecError::Invalid(_))
    ));
    // Beside an anti-windup compensator (here one that changes no command) the detector reads
    // its own state: the same residual.
    let with_aw = FD_SPEC.replace("\"fault_detection\"", "\"anti_windup\": {\"A\": [[-1.0]], \"B\": [[1.0]], \"C\": [[0.0]], \"F\": [[0.0]], \"u_max\": [1000.0]}, \"fault_detection\"");
    let aw_dir = dir_with("fd-aw", Some(&with_aw));
    let (c, _cb) = instantiate(&log, &guid_of(&with_aw), Some(&aw_dir));
    assert!(!c.is_null(), "{:?}", log.messages());
    unsafe {
        fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0);
        fmi2EnterInitializationMode(c);
        assert_eq!(fmi2ExitInitializationMode(c), 0);
        fmi2SetReal(c, &vr::INPUT, 1, &1.0);
        let mut r = 0.0;
        for k in 0..10 {
            assert_eq!(fmi2DoStep(c, k as f64 * 0.1, 0.1, 1), 0);
            fmi2GetReal(c, &vr::RESIDUAL_NORM, 1, &mut r);
            let t = (k + 1) as f64 * 0.1;
            assert!((r - 2.0 * (1.0 - (-t).exp())).abs() < 1e-13, "t = {t}: {r}");
        }
        fmi2FreeInstance(c);
    }
    let (c, _cb) = instantiate(&log, &guid_of(FD_SPEC), Some(&dir));
    unsafe {
        assert_ne!(fmi2SetReal(c, &vr::FAULT_THRESHOLD, 1, &-1.0), 0);
        assert!(log.contains("below its minimum"), "{:?}", log.messages());
        fmi2FreeInstance(c);
    }
    // FMI's bounds are inclusive: the declared minimum 0 is a threshold (any residual flags).
    let (c, _cb) = instantiate(&log, &guid_of(FD_SPEC), Some(&dir));
    unsafe {
        assert_eq!(fmi2SetReal(c, &vr::FAULT_THRESHOLD, 1, &0.0), 0);
        fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0);
        fmi2EnterInitializationMode(c);
        assert_eq!(fmi2ExitInitializationMode(c), 0, "{:?}", log.messages());
        fmi2FreeInstance(c);
    }
}

/// A predictor of a scalar car with one filter of the command: design model
/// `ẋ₁ = −2 x₁ + 1.5 u`, `ẋ₂ = −5 x₂ + u` (the filter), gain `K = [−0.8, −2]`, `x₁ = y + 0.7 ξ₁`,
/// `x₂ = ξ₂`, `ξ̇₁ = −3 ξ₁ + 0.3 y`, `ξ̇₂ = −5 ξ₂ + u`, the input carrying the applied force as
/// `0.4 u(t − θ)`; `delay_max` 0.3 s. Its undelayed controller (A, B, C, D) is
/// `C = K S_ξ = [−0.56, −2]`, `D = −0.8`, `A = A_ξ + B_ξu C`, `B = B_ξ + B_ξu D`.
const PRED_SPEC: &str = r#"{
  "format": "suspension-controller/2", "variant": "test_pred", "description": "test", "guarantee": {"name": "gamma", "value": 1.0, "unit": "1", "description": "test"},
  "inputs": [{"name": "stroke_fl", "unit": "m"}],
  "outputs": [{"name": "u_fl", "unit": "N"}],
  "A": [[-3.0, 0.0], [-0.56, -7.0]], "B": [[0.3], [-0.8]], "C": [[-0.56, -2.0]], "D": [[-0.8]],
  "predictor": {"A": [[-2.0, 0.0], [0.0, -5.0]], "B": [[1.5], [1.0]], "K": [[-0.8, -2.0]],
                "S_y": [[1.0], [0.0]], "S_xi": [[0.7, 0.0], [0.0, 1.0]],
                "A_xi": [[-3.0, 0.0], [0.0, -5.0]], "B_xi": [[0.3], [0.0]], "B_xiu": [[0.0], [1.0]],
                "D_yu": [[0.4]], "delay_max": 0.3, "facts": {}}
}"#;

/// The predictor of [`PRED_SPEC`] in closed form, independent of the runtime's matrix
/// exponentials. Over each step the command sent is held; in closed form (sums of
/// exponentials): the car's copy `ξ₁`, on each piece of the step where the delayed command is
/// constant, driven by `y` held with its force part `0.4 u_r` (the command sent `θ` before the
/// step's start; with no delay the previous one) replaced by the force applied on the piece;
/// the model's prediction of the car state `θ` ahead, `z = e^{−2θ} (y + 0.7 ξ₁) + I` at the
/// step's start (`I = ∫ e^{−2(t−r)} 1.5 u(r) dr` over the commands in flight), moving on as the
/// model says with the command sent, `ż = −2 z + 1.5 u`; the filter `φ` in controller time
/// taking the command `−0.8 z − 2 φ` continuously. It predicts over `θ = max(τ, h)`, `h` the
/// last step's length (`τ` before the first step), the commands and the force as applied all
/// counted over that `θ` during the step. Clamped, what the clamp took moves the prediction by
/// `ζ`, `ζ̇ = −2 ζ + 1.5 (u − sat u)`: the command is `−0.8 (z + ζ) − 2 φ`, and the filter sees
/// `z + ζ` move with the command before the clamp.
struct ScalarPredictor {
    tau: f64,
    theta: f64,
    /// The force limit commands are clamped to.
    limit: f64,
    xi: f64,
    phi: f64,
    zeta: f64,
    /// `(start, end, command)`.
    sent: Vec<(f64, f64, f64)>,
}

impl ScalarPredictor {
    fn sent_at(&self, r: f64) -> f64 {
        self.sent
            .iter()
            .find(|(s, e, _)| *s <= r && r < *e)
            .map_or(0.0, |p| p.2)
    }

    fn in_flight(&self, t: f64) -> f64 {
        self.sent
            .iter()
            .map(|&(s, e, u)| {
                let (lo, hi) = (s.max(t - self.theta), e.min(t));
                if hi > lo {
                    1.5 * u * ((-2.0 * (t - hi)).exp() - (-2.0 * (t - lo)).exp()) / 2.0
                } else {
                    0.0
                }
            })
            .sum()
    }

    fn command(&self, t: f64, y: f64) -> f64 {
        let ahead = (-2.0 * self.theta).exp();
        -0.8 * (ahead * (y + 0.7 * self.xi) + self.in_flight(t) + self.zeta) - 2.0 * self.phi
    }

    fn step(&mut self, t: f64, h: f64, y: f64) -> f64 {
        let asked = self.command(t, y);
        let u = asked.clamp(-self.limit, self.limit);
        let read = if self.theta == 0.0 {
            self.sent.last().map_or(0.0, |p| p.2)
        } else {
            // A command's start counts as reached within rounding, as the plant counts it.
            self.sent_at(t - self.theta + 1e-12)
        };
        let ahead = (-2.0 * self.theta).exp();
        let mut z = ahead * (y + 0.7 * self.xi) + self.in_flight(t) + self.zeta;
        self.sent.push((t, t + h, u));
        let mut cuts = vec![t, t + h];
        for &(s, e, _) in &self.sent {
            for b in [s + self.theta, e + self.theta] {
                if b > t && b < t + h {
                    cuts.push(b);
                }
            }
        }
        cuts.sort_by(f64::total_cmp);
        for w in cuts.windows(2) {
            let d = w[1] - w[0];
            let applied = self.sent_at(0.5 * (w[0] + w[1]) - self.theta);
            // ξ₁ → c/3 at rate 3, z → q/2 at rate 2, φ̇ = −7 φ + g₀ + g₂ e^{−2s}.
            let c = 0.3 * (y + 0.4 * (applied - read));
            let q = 1.5 * asked;
            let (g0, g2) = (-0.8 * q / 2.0, -0.8 * (z - q / 2.0));
            let e = |rate: f64| (-rate * d).exp();
            self.phi = self.phi * e(7.0) + g0 * (1.0 - e(7.0)) / 7.0 + g2 * (e(2.0) - e(7.0)) / 5.0;
            self.xi = c / 3.0 + (self.xi - c / 3.0) * e(3.0);
            z = q / 2.0 + (z - q / 2.0) * e(2.0);
        }
        let e = (-2.0 * h).exp();
        self.zeta = self.zeta * e + 1.5 * (asked - u) * (1.0 - e) / 2.0;
        self.theta = self.tau.max(h);
        u
    }
}

#[test]
fn predictor_commands_are_the_closed_form_over_any_steps_and_restore_whole() {
    let log = LogCapture::default();
    let dir = dir_with("pred", Some(PRED_SPEC));
    let spec = Spec::from_json(PRED_SPEC).unwrap();
    let tau = description_for(&spec)
        .variables
        .iter()
        .find(|v| v.name == "tau")
        .map(|v| v.value_reference)
        .expect("a tau parameter");
    // Delays beyond the certified range are refused at the setter, with the reason.
    let (c, _cb) = instantiate(&log, &guid_of(PRED_SPEC), Some(&dir));
    assert!(!c.is_null(), "{:?}", log.messages());
    unsafe {
        assert_ne!(fmi2SetReal(c, &tau, 1, &0.31), 0);
        fmi2FreeInstance(c);
    }
    assert!(log.contains("0.31"), "{:?}", log.messages());
    // τ = 0.25 s: not a multiple of the steps, which change on the way; τ = 0 (predicted over
    // the last step, whose command the inputs carry the force of; 0 before the first step);
    // τ = 0.12 s, between the steps' lengths, so predicted over τ after the short steps and over
    // the step after the long one; τ = 0.2 s, whole steps at first; and τ = 0.25 s with the
    // commands clamped to a force limit of 0.2 (what is in flight is then clamped too).
    let steps = [
        0.1, 0.1, 0.1, 0.1, 0.05, 0.15, 0.1, 0.02, 0.1, 0.1, 0.1, 0.1, 0.1,
    ];
    let y = |t: f64| (3.0 * t).sin() + 0.5;
    let clamped = PRED_SPEC.replace(
        "\"delay_max\": 0.3,",
        "\"delay_max\": 0.3, \"u_max\": [0.2],",
    );
    let clamped_dir = dir_with("pred_clamped", Some(&clamped));
    let infinite = f64::INFINITY;
    for (theta, limit) in [
        (0.25, infinite),
        (0.0, infinite),
        (0.12, infinite),
        (0.2, infinite),
        (0.25, 0.2),
    ] {
        let mut reference = ScalarPredictor {
            tau: theta,
            theta,
            limit,
            xi: 0.0,
            phi: 0.0,
            zeta: 0.0,
            sent: Vec::new(),
        };
        let (text, dir) = if limit.is_finite() {
            (clamped.as_str(), &clamped_dir)
        } else {
            (PRED_SPEC, &dir)
        };
        let (c, _cb) = instantiate(&log, &guid_of(text), Some(dir));
        let mut sent = Vec::new();
        let mut saved: Fmi2FmuState = std::ptr::null_mut();
        unsafe {
            assert_eq!(fmi2SetReal(c, &tau, 1, &theta), 0);
            fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0);
            fmi2EnterInitializationMode(c);
            assert_eq!(fmi2ExitInitializationMode(c), 0);
            let mut t = 0.0;
            for (k, h) in steps.iter().enumerate() {
                if k == 6 {
                    assert_eq!(fmi2GetFMUstate(c, &mut saved), 0);
                }
                fmi2SetReal(c, &vr::INPUT, 1, &y(t));
                let mut u = 0.0;
                fmi2GetReal(c, &vr::OUTPUT, 1, &mut u);
                let expected = reference.step(t, *h, y(t));
                assert!(
                    (u - expected).abs() <= 1e-12 * expected.abs().max(1.0),
                    "θ = {theta}, t = {t}: command {u}, closed form {expected}"
                );
                sent.push(u);
                assert_eq!(fmi2DoStep(c, t, *h, 1), 0);
                t += h;
            }
            assert!(sent.iter().any(|u| u.abs() > 0.1), "{sent:?}");
            if limit.is_finite() {
                assert!(sent.iter().all(|u| u.abs() <= limit), "{sent:?}");
                assert!(sent.iter().any(|u| u.abs() == limit), "{sent:?}");
                assert!(reference.sent.iter().any(|p| p.2.abs() == limit));
            }
            // Back to the state before step 6 (commands in flight included): the same commands
            // again.
            assert_eq!(fmi2SetFMUstate(c, saved), 0);
            let mut t: f64 = steps[..6].iter().sum();
            for (k, h) in steps.iter().enumerate().skip(6) {
                fmi2SetReal(c, &vr::INPUT, 1, &y(t));
                let mut u = 0.0;
                fmi2GetReal(c, &vr::OUTPUT, 1, &mut u);
                assert_eq!(u, sent[k], "θ = {theta}: after restoring, step {k}");
                assert_eq!(fmi2DoStep(c, t, *h, 1), 0);
                t += h;
            }
            fmi2FreeFMUstate(c, &mut saved);
            fmi2FreeInstance(c);
        }
    }
}

/// The commands [`PRED_SPEC`]'s predictor gives, told the delay `tau` and `master_order`, at
/// steps of 0.1 s over inputs `y(t_k) + correction(k, commands so far)`, exchanged in that
/// order: per step, the command read (before the step in the Gauss–Seidel and Jacobi orders,
/// after it in the controller-first one). The state is saved after step 5 and restored at the
/// end: the steps after it give the same commands again.
fn told_the_order(tau: f64, order: i32, correction: impl Fn(usize, &[f64]) -> f64) -> Vec<f64> {
    let log = LogCapture::default();
    let dir = dir_with("pred_order", Some(PRED_SPEC));
    let (c, _cb) = instantiate(&log, &guid_of(PRED_SPEC), Some(&dir));
    let (h, steps) = (0.1, 12);
    let y = |t: f64| (3.0 * t).sin() + 0.5;
    let mut read = Vec::new();
    let mut saved: Fmi2FmuState = std::ptr::null_mut();
    let run = |from: usize, read: &mut Vec<f64>, saved: &mut Fmi2FmuState| unsafe {
        for k in from..steps {
            if k == 5 && saved.is_null() {
                assert_eq!(fmi2GetFMUstate(c, saved), 0);
            }
            let (t, mut u) = (k as f64 * h, 0.0);
            let input = y(t) + correction(k, read);
            if order != 1 {
                fmi2SetReal(c, &vr::INPUT, 1, &input);
            }
            if order != 2 {
                fmi2GetReal(c, &vr::OUTPUT, 1, &mut u);
            }
            if order == 1 {
                fmi2SetReal(c, &vr::INPUT, 1, &input);
            }
            assert_eq!(fmi2DoStep(c, t, h, 1), 0, "{:?}", log.messages());
            if order == 2 {
                fmi2GetReal(c, &vr::OUTPUT, 1, &mut u);
            }
            read.push(u);
        }
    };
    unsafe {
        assert_eq!(
            fmi2SetReal(c, &vr::DELAY, 1, &tau),
            0,
            "{:?}",
            log.messages()
        );
        assert_eq!(fmi2SetInteger(c, &vr::MASTER_ORDER, 1, &order), 0);
        fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0);
        fmi2EnterInitializationMode(c);
        assert_eq!(fmi2ExitInitializationMode(c), 0, "{:?}", log.messages());
    }
    run(0, &mut read, &mut saved);
    unsafe {
        assert_eq!(fmi2SetFMUstate(c, saved), 0);
        fmi2FreeFMUstate(c, &mut saved);
    }
    let mut again = read[..5].to_vec();
    run(5, &mut again, &mut saved);
    assert_eq!(
        again, read,
        "order {order}: after restoring the state of step 5"
    );
    unsafe { fmi2FreeInstance(c) };
    read
}

/// A predictor told the master's order (`master_order`) keeps the commands in flight the plant
/// gets. Stepped first (2), it gives after each step the command the Gauss–Seidel order (0)
/// reads before it, bit for bit. In the Jacobi order (1) it gives at `t_k` the command it
/// computed at `t_{k−1}` (0 at the start), predicted over `tau` plus the step: the commands of
/// the Gauss–Seidel order told that delay, for the inputs that order's plant, a step more
/// delayed, gives — the same inputs with a delay, and with none the inputs read before the
/// master sets the command taking over, which the controller corrects by the feedthrough `D_yu`
/// of the two commands in flight. An order that is not one is refused by name.
#[test]
fn a_predictor_told_the_masters_order_runs_the_gauss_seidel_loop() {
    let none = |_: usize, _: &[f64]| 0.0;
    for tau in [0.0, 0.15, 0.1] {
        let gauss_seidel = told_the_order(tau, 0, none);
        assert_eq!(told_the_order(tau, 2, none), gauss_seidel, "tau = {tau}");
        // The Gauss–Seidel loop a step later: told tau + h, its inputs carrying the command
        // taking over (with no delay the controller in the Jacobi order adds `D_yu (c_{k−1} −
        // c_{k−2})` to the inputs it reads, which carry c_{k−2}'s force).
        let later = told_the_order(tau + 0.1, 0, |k, c: &[f64]| {
            let at = |j: usize| if k >= j { c[k - j] } else { 0.0 };
            if tau == 0.0 {
                0.4 * (at(1) - at(2))
            } else {
                0.0
            }
        });
        let jacobi = told_the_order(tau, 1, none);
        assert_eq!(jacobi[0], 0.0);
        for (k, (j, l)) in jacobi[1..].iter().zip(&later).enumerate() {
            assert!(
                (j - l).abs() <= 1e-12 * l.abs().max(1.0),
                "tau = {tau}, step {k}: Jacobi {j}, Gauss-Seidel a step later {l}"
            );
        }
        assert!(later.iter().any(|u| u.abs() > 0.1), "{later:?}");
    }
    let log = LogCapture::default();
    let dir = dir_with("pred_bad_order", Some(PRED_SPEC));
    let (c, _cb) = instantiate(&log, &guid_of(PRED_SPEC), Some(&dir));
    unsafe {
        assert_eq!(fmi2SetInteger(c, &vr::MASTER_ORDER, 1, &3), 0);
        fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0);
        fmi2EnterInitializationMode(c);
        assert_ne!(fmi2ExitInitializationMode(c), 0);
        fmi2FreeInstance(c);
    }
    assert!(
        log.contains("master_order must be 0"),
        "{:?}",
        log.messages()
    );
}

/// Why `Spec::from_json` refuses `text` with `from` replaced by `to`.
fn refusal(text: &str, from: &str, to: &str) -> String {
    let edited = text.replace(from, to);
    assert_ne!(edited, text, "'{from}' is not in the spec");
    Spec::from_json(&edited).unwrap_err().to_string()
}

#[test]
fn predictor_blocks_must_be_the_controller_without_delay() {
    assert!(Spec::from_json(PRED_SPEC).unwrap().predictor.is_some());
    // An edited gain no longer matches C, D, A, B.
    let err = refusal(PRED_SPEC, "\"K\": [[-0.8, -2.0]]", "\"K\": [[-0.9, -2.0]]");
    assert!(err.contains("without delay"), "{err}");
    let err = refusal(PRED_SPEC, "\"delay_max\": 0.3", "\"delay_max\": -1.0");
    assert!(err.contains("delay_max"), "{err}");
    // An input named like a variable the runtime adds (here the predictor's delay) is refused.
    let err = refusal(PRED_SPEC, "\"name\": \"stroke_fl\"", "\"name\": \"tau\"");
    assert!(err.contains("'tau'") && err.contains("adds"), "{err}");
    let err = refusal(SPEC, "\"name\": \"stroke_fl\"", "\"name\": \"gamma\"");
    assert!(err.contains("'gamma'"), "{err}");
    let err = refusal(
        PRED_SPEC,
        "\"S_y\": [[1.0], [0.0]]",
        "\"S_y\": [[1.0, 2.0], [0.0, 0.0]]",
    );
    assert!(err.contains("predictor.S_y"), "{err}");
    // The command's filter must be the command's alone: read from y, or coupled to the car's
    // states, it could not run in controller time.
    for (from, to, why) in [
        (
            "\"B_xi\": [[0.3], [0.0]]",
            "\"B_xi\": [[0.3], [0.1]]",
            "driven by or read from y",
        ),
        (
            "\"S_y\": [[1.0], [0.0]]",
            "\"S_y\": [[1.0], [0.2]]",
            "driven by or read from y",
        ),
        (
            "\"A\": [[-2.0, 0.0], [0.0, -5.0]]",
            "\"A\": [[-2.0, 0.5], [0.0, -5.0]]",
            "coupled",
        ),
        (
            "\"A_xi\": [[-3.0, 0.0], [0.0, -5.0]]",
            "\"A_xi\": [[-3.0, 0.0], [0.1, -5.0]]",
            "coupled",
        ),
        (
            "\"S_xi\": [[0.7, 0.0], [0.0, 1.0]]",
            "\"S_xi\": [[0.7, 0.3], [0.0, 1.0]]",
            "into 2 design",
        ),
        (
            "\"B\": [[1.5], [1.0]]",
            "\"B\": [[1.5], [0.8]]",
            "does not follow the design model",
        ),
    ] {
        let err = refusal(PRED_SPEC, from, to);
        assert!(
            err.contains(why) && err.contains("B_xiu drives"),
            "{to}: {err}"
        );
    }
    let err = refusal(PRED_SPEC, "\"D_yu\": [[0.4]]", "\"D_yu\": [[0.4], [0.1]]");
    assert!(err.contains("predictor.D_yu"), "{err}");
    for limits in ["[-1.0]", "[1.0, 2.0]", "[0.0]"] {
        let err = refusal(
            PRED_SPEC,
            "\"delay_max\": 0.3,",
            &format!("\"delay_max\": 0.3, \"u_max\": {limits},"),
        );
        assert!(err.contains("predictor.u_max"), "{limits}: {err}");
    }
}

/// A `controller.json` whose `A` is absurd (1e40, finite, so it loads): a step returns
/// `fmi2Discard` with the reason instead of never returning (nalgebra's exponential squared
/// forever), as a step too long for the controller's dynamics does: the commands are as they
/// were and `fmi2LastSuccessfulTime` is the step's start.
#[test]
fn an_absurd_controller_matrix_discards_the_step_and_returns() {
    let log = LogCapture::default();
    let spec = SPEC.replace(r#""A": [[-2.0]]"#, r#""A": [[-1e40]]"#);
    assert_ne!(spec, SPEC);
    let (c, _cb) = running(&log, "absurd", &spec);
    let outs = OUTPUTS;
    unsafe {
        let (mut before, mut after) = ([0.0; 2], [0.0; 2]);
        fmi2GetReal(c, outs.as_ptr(), 2, before.as_mut_ptr());
        assert_eq!(fmi2DoStep(c, 0.0, 1e-3, 1), 2, "fmi2Discard");
        // GetReal is legal in the StepFailed state.
        assert_eq!(fmi2GetReal(c, outs.as_ptr(), 2, after.as_mut_ptr()), 0);
        assert_eq!(after, before);
        let mut last = f64::NAN;
        assert_eq!(fmi2GetRealStatus(c, 2, &mut last), 0);
        assert_eq!(last, 0.0, "fmi2LastSuccessfulTime");
        fmi2FreeInstance(c);
    }
    assert!(
        log.contains("cannot discretise the controller over 0.001 s")
            && log.contains("exceeds 1e20"),
        "{:?}",
        log.messages()
    );
}

/// A step far too long for an unstable controller (its state would overflow, as `hinf_sf`'s
/// and `hinf_of`'s did over 1e12 s and 1000 s) is discarded like the plant's: `fmi2Discard`,
/// `fmi2LastSuccessfulTime` the step's start, nothing changed; the master restores the state
/// it saved and goes on in ordinary steps, exactly as an instance that never tried.
#[test]
fn a_step_too_long_is_discarded_and_the_controller_goes_on_after_a_restore() {
    let log = LogCapture::default();
    let spec = SPEC.replace(r#""A": [[-2.0]]"#, r#""A": [[2.0]]"#);
    let (c, _cb) = running(&log, "too-long", &spec);
    let (reference, _cb2) = running(&log, "too-long-reference", &spec);
    let outs = OUTPUTS;
    unsafe {
        for k in 0..5 {
            assert_eq!(fmi2DoStep(c, k as f64 * 0.01, 0.01, 1), 0);
            assert_eq!(fmi2DoStep(reference, k as f64 * 0.01, 0.01, 1), 0);
        }
        let saved = serialized(c);
        for long in [1e3, 1e12] {
            assert_eq!(
                fmi2DoStep(c, 0.05, long, 1),
                2,
                "a step of {long} s: fmi2Discard"
            );
            let mut last = f64::NAN;
            assert_eq!(fmi2GetRealStatus(c, 2, &mut last), 0);
            assert_eq!(last, 0.05, "fmi2LastSuccessfulTime");
            assert_eq!(restore(c, &saved), 0, "{:?}", log.messages());
        }
        for k in 5..20 {
            assert_eq!(fmi2DoStep(c, k as f64 * 0.01, 0.01, 1), 0);
            assert_eq!(fmi2DoStep(reference, k as f64 * 0.01, 0.01, 1), 0);
        }
        let (mut a, mut b) = ([0.0; 2], [0.0; 2]);
        fmi2GetReal(c, outs.as_ptr(), 2, a.as_mut_ptr());
        fmi2GetReal(reference, outs.as_ptr(), 2, b.as_mut_ptr());
        assert_eq!(a, b);
        fmi2FreeInstance(c);
        fmi2FreeInstance(reference);
    }
    assert!(
        log.contains("the step was discarded"),
        "{:?}",
        log.messages()
    );
}

/// The instance's FMU state, serialised.
fn serialized(c: Fmi2Component) -> Vec<u8> {
    let mut s: Fmi2FmuState = std::ptr::null_mut();
    let mut size = 0;
    unsafe {
        assert_eq!(fmi2GetFMUstate(c, &mut s), 0);
        fmi2SerializedFMUstateSize(c, s, &mut size);
        let mut bytes = vec![0 as Fmi2Byte; size];
        fmi2SerializeFMUstate(c, s, bytes.as_mut_ptr(), size);
        fmi2FreeFMUstate(c, &mut s);
        bytes.into_iter().map(|b| b as u8).collect()
    }
}

/// Deserialise `bytes` and set them as the instance's state: the first status that is not OK.
fn restore(c: Fmi2Component, bytes: &[u8]) -> Fmi2Status {
    let mut s: Fmi2FmuState = std::ptr::null_mut();
    unsafe {
        let st = fmi2DeSerializeFMUstate(c, bytes.as_ptr() as *const Fmi2Byte, bytes.len(), &mut s);
        if st != 0 {
            return st;
        }
        let st = fmi2SetFMUstate(c, s);
        fmi2FreeFMUstate(c, &mut s);
        st
    }
}

/// A state whose checksum matches but whose force limit is forged (NaN, 0, negative) is refused
/// with the reason and changes nothing; it once gave "internal error" on every later call.
#[test]
fn forged_limits_in_a_state_are_refused() {
    let log = LogCapture::default();
    let dir = dir_with("aw-forged", Some(AW_SPEC));
    let start = |limit: f64| {
        let (c, cb) = instantiate(&log, &guid_of(AW_SPEC), Some(&dir));
        assert!(!c.is_null(), "{:?}", log.messages());
        unsafe {
            assert_eq!(fmi2SetReal(c, &vr::LIMIT, 1, &limit), 0);
            fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0);
            fmi2EnterInitializationMode(c);
            assert_eq!(fmi2ExitInitializationMode(c), 0);
            fmi2SetReal(c, &vr::INPUT, 1, &1.0);
            assert_eq!(fmi2DoStep(c, 0.0, 0.1, 1), 0);
        }
        (c, cb)
    };
    let (a, _cba) = start(4.25);
    let good = serialized(a);
    let (b, _cbb) = start(3.5);
    let outs = [vr::OUTPUT, vr::OUTPUT + 1];
    let read = |c: Fmi2Component| {
        let mut u = [0.0; 2];
        unsafe { fmi2GetReal(c, outs.as_ptr(), 2, u.as_mut_ptr()) };
        u
    };
    let before = read(b);
    for forged in [f64::NAN, f64::INFINITY, -4.25] {
        log.clear();
        assert_ne!(
            restore(b, &fmi_test_logger::forge_state(&good, 4.25, forged)),
            0
        );
        assert!(
            log.contains("FMU state refused"),
            "{forged}: {:?}",
            log.messages()
        );
        assert_eq!(read(b), before, "{forged}");
    }
    assert_eq!(restore(b, &good), 0, "{:?}", log.messages());
    assert_eq!(read(b), read(a));
    unsafe {
        fmi2FreeInstance(a);
        fmi2FreeInstance(b);
    }
}

/// The `<ModelStructure>` of every kind of controller tells the truth: what each command moves
/// with, measured by perturbing one known at a time, is declared, and what is declared is seen
/// — except the fault flag, whose threshold and measurements move it only when the residual
/// crosses the threshold (not at the probed point), and a saturation limit not reached.
#[test]
fn declared_dependencies_are_the_measured_ones() {
    let log = LogCapture::default();
    let cb = log.callbacks();
    let callbacks = unsafe { &*(&cb as *const _ as *const CallbackFunctions) };
    for (name, text) in [
        ("plain", SPEC),
        ("aw", AW_SPEC),
        ("fd", FD_SPEC),
        ("pred", PRED_SPEC),
        ("acc", ACC_SPEC),
    ] {
        let dir = dir_with(&format!("deps-{name}"), Some(text));
        let uri = format!("file://{}", dir.display());
        let measured = fmu_core::dependencies::measure::<fmu_controller::Controller>(
            Some(&uri),
            callbacks,
            &[],
        )
        .unwrap_or_else(|e| panic!("{name}: {e}"));
        let d = description_for(&Spec::from_json(text).unwrap());
        let m = measured.compare(&d);
        assert!(
            m.undeclared.is_empty(),
            "{name}: undeclared {:?}",
            m.undeclared
        );
        let unexplained: Vec<_> = m
            .unobserved
            .iter()
            .filter(|(unknown, known)| unknown != "fault_detected" && !known.starts_with("u_max"))
            .collect();
        assert!(
            unexplained.is_empty(),
            "{name}: declared, not seen {unexplained:?}"
        );
        eprintln!("{name}: {:?} / {:?}", measured.initial, m.unobserved);
    }
}

/// Static controller `u = 2 y` with fault accommodation: the load cell `f_fl` measures what the
/// actuator applies.
const ACC_SPEC: &str = r#"{
  "format": "suspension-controller/2", "variant": "test_acc", "description": "test", "guarantee": {"name": "gamma", "value": 1.0, "unit": "1", "description": "test"},
  "inputs": [{"name": "stroke_fl", "unit": "m"}, {"name": "f_fl", "unit": "N"}],
  "outputs": [{"name": "u_fl", "unit": "N"}],
  "A": [], "B": [], "C": [[]], "D": [[2.0, 0.0]],
  "accommodation": {"forces": ["f_fl"], "rho_min": 0.5, "time_constant": 0.1, "u_max": [100.0]}
}"#;

/// [`ACC_SPEC`]'s exchange at a communication point: its input `y` and load cell `f` set, its
/// command and `rho_hat_fl` read.
unsafe fn exchange(c: Fmi2Component, y: f64, f: f64) -> (f64, f64) {
    let ins = [vr::INPUT, vr::INPUT + 1];
    fmi2SetReal(c, ins.as_ptr(), 2, [y, f].as_ptr());
    let (mut u, mut rho) = (0.0, 0.0);
    fmi2GetReal(c, &vr::OUTPUT, 1, &mut u);
    fmi2GetReal(c, &vr::RHO_HAT, 1, &mut rho);
    (u, rho)
}

/// Through the C functions, against an actuator of effectiveness 0.6 saturating at `u_max`
/// (simulated here: the force measured at a point is 0.6 sat(u) of the command read at the
/// point before): `rho_hat_fl` settles on 0.6 from above, the command is `2 y / ρ̂`, so the
/// force applied is the asked `2 y`; with the limit lowered (the parameter, as the plant's)
/// saturation is not taken for a loss; a state restores the estimate; a malformed block is
/// refused by name.
#[test]
fn accommodation_estimates_the_effectiveness_and_compensates_it() {
    let log = LogCapture::default();
    let spec = Spec::from_json(ACC_SPEC).unwrap();
    let names: Vec<String> = description_for(&spec)
        .variables
        .iter()
        .map(|v| v.name.clone())
        .collect();
    for n in ["rho_hat_fl", "u_max"] {
        assert!(names.iter().any(|v| v == n), "{n} missing from {names:?}");
    }
    let run = |limit: f64, steps: usize| -> (Vec<(f64, f64, f64)>, Vec<u8>) {
        let dir = dir_with("acc", Some(ACC_SPEC));
        let (c, _cb) = instantiate(&log, &guid_of(ACC_SPEC), Some(&dir));
        assert!(!c.is_null(), "{:?}", log.messages());
        let mut out = Vec::new();
        let mut state = Vec::new();
        unsafe {
            assert_eq!(fmi2SetReal(c, &vr::LIMIT, 1, &limit), 0);
            fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0);
            fmi2EnterInitializationMode(c);
            assert_eq!(fmi2ExitInitializationMode(c), 0);
            let h = 1e-3;
            let mut sent: f64 = 0.0;
            for k in 0..steps {
                let y = 30.0 * (k as f64 * h * 25.0).sin();
                let f = 0.6 * sent.clamp(-limit, limit);
                let (u, rho) = exchange(c, y, f);
                out.push((2.0 * y, u, rho));
                if k == steps / 2 {
                    state = serialized(c);
                }
                assert_eq!(fmi2DoStep(c, k as f64 * h, h, 1), 0);
                sent = u;
            }
            fmi2FreeInstance(c);
        }
        (out, state)
    };
    let (free, _) = run(100.0, 2000);
    let mut last = 1.0;
    for (k, (asked, u, rho)) in free.iter().enumerate() {
        assert!(
            *rho >= 0.6 - 1e-12 && *rho <= last + 1e-12,
            "step {k}: ρ̂ {rho} after {last}"
        );
        last = *rho;
        assert!(
            (u * rho - asked).abs() <= 1e-12 * asked.abs().max(1.0),
            "step {k}"
        );
    }
    // How far the estimate is from 0.6 after 1 s.
    let off = |rows: &[(f64, f64, f64)]| {
        rows[1000..]
            .iter()
            .map(|r| (r.2 - 0.6).abs())
            .fold(0.0, f64::max)
    };
    assert!(off(&free) < 1e-9, "ρ̂ off by {} after 1 s", off(&free));
    // Saturating at 20 N (commands up to 100 N): the estimate reads sat(u), so still 0.6.
    let (saturated, _) = run(20.0, 2000);
    assert!(
        off(&saturated) < 1e-9,
        "saturation read as a loss: ρ̂ off by {}",
        off(&saturated)
    );
    // A state taken half way restores the estimate, bit for bit, into a new instance.
    let (_, state) = run(100.0, 1200);
    let dir = dir_with("acc", Some(ACC_SPEC));
    let (c, _cb) = instantiate(&log, &guid_of(ACC_SPEC), Some(&dir));
    unsafe {
        fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0);
        fmi2EnterInitializationMode(c);
        fmi2ExitInitializationMode(c);
        assert_eq!(restore(c, &state), 0, "{:?}", log.messages());
        let mut rho = 0.0;
        fmi2GetReal(c, &vr::RHO_HAT, 1, &mut rho);
        assert_eq!(rho.to_bits(), free[600].2.to_bits());
        fmi2FreeInstance(c);
    }
    for (bad, why) in [
        (r#""forces": ["f_fr"]"#, "'f_fr' is not an input"),
        (r#""forces": ["f_fl", "f_fl"]"#, "must name 1 inputs"),
        (r#""rho_min": 0.0"#, "rho_min must be in (0, 1]"),
        (r#""rho_min": 1.5"#, "rho_min must be in (0, 1]"),
        (
            r#""time_constant": -0.1"#,
            "time_constant must be finite and > 0",
        ),
        (
            r#""u_max": [100.0, 1.0]"#,
            "u_max must hold 1 finite limits > 0",
        ),
    ] {
        let key = &bad[..bad.find(':').unwrap()];
        let start = ACC_SPEC.find(key).unwrap();
        let end = start + ACC_SPEC[start..].find([',', '}']).unwrap();
        let end = if ACC_SPEC[start..end].contains('[') {
            start + ACC_SPEC[start..].find(']').unwrap() + 1
        } else {
            end
        };
        let text = format!("{}{bad}{}", &ACC_SPEC[..start], &ACC_SPEC[end..]);
        let e = Spec::from_json(&text).unwrap_err().to_string();
        assert!(e.contains(why), "{bad}: {e}");
    }
    // With a detector or an anti-windup compensator it is one controller; an anti-windup
    // compensator with other limits than the accommodation's is refused (both are the
    // parameters u_max, u_max_seat).
    let with =
        |block: &str| ACC_SPEC.replace("\"accommodation\"", &format!("{block}, \"accommodation\""));
    assert!(Spec::from_json(&with(r#""fault_detection": {"A": [], "B": [], "B_u": [], "C": [[]], "D": [[0.0, 1.0]], "threshold": 1.0}"#)).is_ok());
    let aw = |limit: &str| {
        with(&format!(
            r#""anti_windup": {{"A": [], "B": [], "C": [[], []], "F": [[]], "u_max": [{limit}]}}"#
        ))
    };
    assert!(Spec::from_json(&aw("100.0")).is_ok());
    let e = Spec::from_json(&aw("4.0")).unwrap_err().to_string();
    assert!(e.contains("differ"), "{e}");
}

/// Anti-windup with fault accommodation: `u = y_c = 2 y` and a compensator `η̇ = −η + v`,
/// `u = sat((y_c + η) / ρ̂)` (`F = 1`), whose input is the design's force the command makes,
/// `v = ρ̂ u − y_c` (an actuator of effectiveness `ρ̂` saturates at `ρ̂` times its limit in the
/// design's units). Against an actuator of effectiveness 0.6 saturating at 20 N, the commands
/// through the C functions are the recurrence's, `η` stepped exactly over each held step with
/// the `ρ̂` the FMU reports, to 1e-12.
#[test]
fn anti_windup_with_accommodation_counts_the_force_the_accommodated_command_makes() {
    let spec = ACC_SPEC
        .replace(r#""u_max": [100.0]"#, r#""u_max": [20.0]"#)
        .replace(
            "\"accommodation\"",
            r#""anti_windup": {"A": [[-1.0]], "B": [[1.0]], "C": [[0.0], [0.0]], "F": [[1.0]], "u_max": [20.0]}, "accommodation""#,
        );
    let log = LogCapture::default();
    let dir = dir_with("aw-acc", Some(&spec));
    let (c, _cb) = instantiate(&log, &guid_of(&spec), Some(&dir));
    assert!(!c.is_null(), "{:?}", log.messages());
    let (h, limit): (f64, f64) = (1e-3, 20.0);
    let decay = (-h).exp();
    let (mut eta, mut sent, mut saturated) = (0.0f64, 0.0f64, 0);
    unsafe {
        fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0);
        fmi2EnterInitializationMode(c);
        assert_eq!(fmi2ExitInitializationMode(c), 0);
        for k in 0..3000 {
            let y = 30.0 * (k as f64 * h * 7.0).sin();
            let f = 0.6 * sent.clamp(-limit, limit);
            let (u, rho) = exchange(c, y, f);
            let yc = 2.0 * y;
            let expected = ((yc + eta) / rho).clamp(-limit, limit);
            assert!(
                (u - expected).abs() <= 1e-12 * limit,
                "step {k}: {u} against {expected} (ρ̂ {rho})"
            );
            saturated += (expected.abs() == limit) as usize;
            assert_eq!(fmi2DoStep(c, k as f64 * h, h, 1), 0);
            eta = decay * eta + (1.0 - decay) * (rho * u - yc);
            sent = u;
        }
        fmi2FreeInstance(c);
    }
    assert!(saturated > 300, "the limit must bite: {saturated} steps");
}

/// An importer that keeps time in integer nanoseconds (libcosim) hands 1 ms over as the
/// difference of two doubles, a little different at each step. The controller takes each as
/// the step before it (`linsys::same_step`): its commands are those of the same controller
/// stepped at exactly 1 ms, to the bit, a dynamic controller's and a predictor's (which
/// predicts over the step). Before, each such step recomputed the matrix exponentials:
/// `delay_sf` in libcosim took 45 s for 4 s of road.
#[test]
fn steps_in_nanosecond_time_are_the_constant_step_to_the_bit() {
    let log = LogCapture::default();
    for (name, spec) in [("ns_dynamic", SPEC), ("ns_predictor", PRED_SPEC)] {
        let dir = dir_with(name, Some(spec));
        let ny = Spec::from_json(spec).unwrap().inputs.len();
        let run = |nanoseconds: bool| -> (Vec<f64>, usize) {
            let (c, _cb) = instantiate(&log, &guid_of(spec), Some(&dir));
            assert!(!c.is_null(), "{:?}", log.messages());
            let (mut commands, mut differed) = (Vec::new(), 0);
            unsafe {
                fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0);
                fmi2EnterInitializationMode(c);
                fmi2ExitInitializationMode(c);
                for k in 0..3000i64 {
                    let (t, h) = if nanoseconds {
                        let seconds = |ns: i64| ns as f64 / 1e9;
                        let t = seconds(k * 1_000_000);
                        (t, seconds((k + 1) * 1_000_000) - t)
                    } else {
                        (k as f64 * 1e-3, 1e-3)
                    };
                    differed += (h != 1e-3) as usize;
                    for i in 0..ny {
                        let y = (7.0 * k as f64 * 1e-3 + i as f64).sin();
                        assert_eq!(fmi2SetReal(c, &(vr::INPUT + i as u32), 1, &y), 0);
                    }
                    let mut u = f64::NAN;
                    assert_eq!(fmi2GetReal(c, &vr::OUTPUT, 1, &mut u), 0);
                    commands.push(u);
                    assert_eq!(fmi2DoStep(c, t, h, 1), 0, "{:?}", log.messages());
                }
                fmi2FreeInstance(c);
            }
            (commands, differed)
        };
        let ((constant, _), (nanoseconds, differed)) = (run(false), run(true));
        assert!(differed > 1000, "{name}: the nanosecond steps were 1 ms");
        let first = constant
            .iter()
            .zip(&nanoseconds)
            .position(|(a, b)| a.to_bits() != b.to_bits());
        assert_eq!(
            first, None,
            "{name}: the commands differ from step {first:?}"
        );
    }
}
