//! The FMI runtime exercised through its exported C functions, with a first-order lag as the
//! model and a real C variadic logger recording every message.

use fmi_test_logger::LogCapture;
use fmu_core::fmu_state::{StateReader, StateWriter};
use fmu_core::types::*;
use fmu_core::*;
use std::ffi::{CStr, CString};
use std::path::Path;
use std::ptr::{null, null_mut};

/// `ẏ = (u − y)/T`, stepped exactly with `u` held. `u = 666` makes the step panic, to test the
/// panic barrier.
#[derive(Clone)]
struct Lag {
    time_constant: f64,
    u: f64,
    y: f64,
    resources_seen: Option<String>,
}

const VR_T: u32 = 0;
const VR_U: u32 = 1;
const VR_Y: u32 = 2;
const VR_U_ECHO: u32 = 3;
const GUID: &str = "{00000000-lag0-0000-0000-000000000001}";

impl Model for Lag {
    fn description(_resources: Option<&Path>) -> Result<ModelDescription, ModelError> {
        Ok(ModelDescription {
            model_name: "lag".into(),
            model_identifier: "lag".into(),
            guid: GUID.into(),
            description: "first-order lag".into(),
            version: "1".into(),
            capabilities: Capabilities::exact_stepping(false),
            model_exchange: None,
            sample_clock: None,
            arrays: Vec::new(),
            terminals: Vec::new(),
            default_experiment: DefaultExperiment {
                start_time: 0.0,
                stop_time: 1.0,
                step_size: 0.01,
                tolerance: 1e-6,
            },
            variables: vec![
                Variable::real("T", VR_T, Causality::Parameter, "s", "time constant")
                    .with_start(0.5),
                Variable::real("u", VR_U, Causality::Input, "1", "input").with_start(0.0),
                Variable::real("y", VR_Y, Causality::Output, "1", "output"),
                Variable::real("u_echo", VR_U_ECHO, Causality::Output, "1", "input echo")
                    .depending_on(vec!["u".into()], DependencyKind::Constant),
            ],
        })
    }
    fn instantiate(resources: Option<&Path>) -> Result<Self, ModelError> {
        Ok(Lag {
            time_constant: 0.5,
            u: 0.0,
            y: 0.0,
            resources_seen: resources.map(|p| p.display().to_string()),
        })
    }
    fn check_real(&self, vr: u32, value: f64) -> Result<(), ModelError> {
        if vr == VR_T && value <= 0.0 {
            return Err(format!("T must be > 0 s, got {value}").into());
        }
        Ok(())
    }
    fn set_real(&mut self, vr: u32, value: f64) {
        match vr {
            VR_T => self.time_constant = value,
            VR_U => self.u = value,
            _ => unreachable!("runtime only sets settable variables"),
        }
    }
    fn get_real(&mut self, vr: u32) -> f64 {
        match vr {
            VR_T => self.time_constant,
            VR_U => self.u,
            VR_Y => self.y,
            _ => self.u,
        }
    }
    fn exit_initialization(&mut self, _t: f64) -> Result<(), ModelError> {
        Ok(())
    }
    fn do_step(&mut self, _t: f64, h: f64) -> Result<(), ModelError> {
        if self.u == 666.0 {
            panic!("the number of the beast");
        }
        let a = (-h / self.time_constant).exp();
        self.y = a * self.y + (1.0 - a) * self.u;
        Ok(())
    }
    fn save(&self, w: &mut StateWriter) {
        w.f64s(&[self.time_constant, self.u, self.y]);
    }
    fn restore(&mut self, r: &mut StateReader) -> Result<(), ModelError> {
        let v = r.f64s_exact(3, "lag state")?;
        r.finish()?;
        (self.time_constant, self.u, self.y) = (v[0], v[1], v[2]);
        Ok(())
    }
}

fmu_core::export_fmi2!(Lag);
fmu_core::export_fmi3!(Lag);

const OK: i32 = 0;
const DISCARD: i32 = 2;
const ERROR: i32 = 3;

struct Fmu<'a> {
    c: Fmi2Component,
    _log: &'a LogCapture,
    _cb: Box<fmi_test_logger::Callbacks>,
}

impl<'a> Fmu<'a> {
    fn new(log: &'a LogCapture, logging_on: bool) -> Self {
        Self::with(log, GUID, Some("file:///tmp/lag/resources"), logging_on).expect("instantiate")
    }
    fn with(
        log: &'a LogCapture,
        guid: &str,
        resources: Option<&str>,
        logging_on: bool,
    ) -> Option<Self> {
        let cb = Box::new(log.callbacks());
        let name = CString::new("lag1").unwrap();
        let guid = CString::new(guid).unwrap();
        let res = resources.map(|r| CString::new(r).unwrap());
        let c = unsafe {
            fmi2Instantiate(
                name.as_ptr(),
                FMI2_CO_SIMULATION,
                guid.as_ptr(),
                res.as_ref().map_or(null(), |r| r.as_ptr()),
                &*cb as *const _ as *const CallbackFunctions,
                0,
                logging_on as i32,
            )
        };
        (!c.is_null()).then_some(Fmu {
            c,
            _log: log,
            _cb: cb,
        })
    }
    fn init(&self) {
        unsafe {
            assert_eq!(fmi2SetupExperiment(self.c, 0, 0.0, 0.0, 0, 0.0), OK);
            assert_eq!(fmi2EnterInitializationMode(self.c), OK);
            assert_eq!(fmi2ExitInitializationMode(self.c), OK);
        }
    }
    fn set(&self, vr: u32, v: f64) -> i32 {
        unsafe { fmi2SetReal(self.c, &vr, 1, &v) }
    }
    fn get(&self, vr: u32) -> f64 {
        let mut v = f64::NAN;
        assert_eq!(unsafe { fmi2GetReal(self.c, &vr, 1, &mut v) }, OK);
        v
    }
    fn step(&self, t: f64, h: f64) -> i32 {
        unsafe { fmi2DoStep(self.c, t, h, 1) }
    }
    fn state(&self) -> fmu_core::state_machine::FmiState {
        unsafe { (*(self.c as *mut fmu_core::instance::Instance<Lag>)).state() }
    }
}

impl Drop for Fmu<'_> {
    fn drop(&mut self) {
        unsafe { fmi2FreeInstance(self.c) }
    }
}

#[test]
fn version_and_platform_strings() {
    unsafe {
        assert_eq!(CStr::from_ptr(fmi2GetVersion()).to_str().unwrap(), "2.0");
        assert_eq!(
            CStr::from_ptr(fmi2GetTypesPlatform()).to_str().unwrap(),
            "default"
        );
    }
}

#[test]
fn lag_steps_exactly_through_the_c_api() {
    let log = LogCapture::default();
    let fmu = Fmu::new(&log, false);
    fmu.init();
    assert_eq!(fmu.set(VR_U, 1.0), OK);
    for i in 0..10 {
        assert_eq!(fmu.step(i as f64 * 0.1, 0.1), OK);
    }
    assert!((fmu.get(VR_Y) - (1.0 - (-2.0f64).exp())).abs() < 1e-14);
    assert_eq!(fmu.model_resources(), Some("/tmp/lag/resources".into()));
}

impl Fmu<'_> {
    fn model_resources(&self) -> Option<String> {
        unsafe {
            (*(self.c as *mut fmu_core::instance::Instance<Lag>))
                .model()
                .resources_seen
                .clone()
        }
    }
}

#[test]
fn illegal_do_step_before_init_is_an_error() {
    let log = LogCapture::default();
    let fmu = Fmu::new(&log, false);
    assert_eq!(fmu.step(0.0, 0.1), ERROR);
    assert!(
        log.contains("fmi2DoStep: illegal call in state Instantiated"),
        "{:?}",
        log.messages()
    );
    assert_eq!(fmu.state(), fmu_core::state_machine::FmiState::Error);
    // Error is final until reset: even a legal-looking call is refused.
    assert_eq!(unsafe { fmi2EnterInitializationMode(fmu.c) }, ERROR);
    assert_eq!(unsafe { fmi2Reset(fmu.c) }, OK);
    fmu.init();
    assert_eq!(fmu.step(0.0, 0.1), OK);
}

#[test]
fn illegal_sequences_are_refused_with_their_state_named() {
    let log = LogCapture::default();
    let fmu = Fmu::new(&log, false);
    let mut v = 0.0;
    assert_eq!(unsafe { fmi2GetReal(fmu.c, &VR_Y, 1, &mut v) }, ERROR);
    assert!(log.contains("fmi2GetReal: illegal call in state Instantiated"));
    unsafe { fmi2Reset(fmu.c) };
    fmu.init();
    assert_eq!(unsafe { fmi2EnterInitializationMode(fmu.c) }, ERROR);
    assert!(log.contains("fmi2EnterInitializationMode: illegal call in state StepComplete"));
    unsafe { fmi2Reset(fmu.c) };
    fmu.init();
    assert_eq!(unsafe { fmi2Terminate(fmu.c) }, OK);
    assert_eq!(fmu.step(0.0, 0.1), ERROR);
    assert!(log.contains("fmi2DoStep: illegal call in state Terminated"));
    unsafe { fmi2Reset(fmu.c) };
    fmu.init();
    assert_eq!(
        unsafe { fmi2CancelStep(fmu.c) },
        ERROR,
        "no asynchronous step is ever in progress"
    );
}

#[test]
fn wrong_guid_wrong_type_and_bad_uri_give_null_with_a_message() {
    let log = LogCapture::default();
    assert!(Fmu::with(&log, "{not-ours}", None, false).is_none());
    assert!(log.contains("GUID mismatch"), "{:?}", log.messages());
    assert!(Fmu::with(&log, GUID, Some("http://example.org/res"), false).is_none());
    assert!(log.contains("is not a file: URI"));
    // FMI's log format reads `#` as the start of a value-reference escape: a `#` of the
    // importer's URI reaches the logger as `##`, a literal `#`.
    assert!(Fmu::with(&log, GUID, Some("http://example.org/res#frag"), false).is_none());
    assert!(
        log.contains("http://example.org/res##frag") && !log.contains("res#frag"),
        "{:?}",
        log.messages()
    );
    let cb = log.callbacks();
    let name = CString::new("x").unwrap();
    let guid = CString::new(GUID).unwrap();
    let c = unsafe {
        fmi2Instantiate(
            name.as_ptr(),
            FMI2_MODEL_EXCHANGE,
            guid.as_ptr(),
            null(),
            &cb as *const _ as *const CallbackFunctions,
            0,
            0,
        )
    };
    assert!(c.is_null());
    assert!(log.contains("supports Co-Simulation (1) only"));
    let c = unsafe {
        fmi2Instantiate(
            null(),
            FMI2_CO_SIMULATION,
            guid.as_ptr(),
            null(),
            &cb as *const _ as *const CallbackFunctions,
            0,
            0,
        )
    };
    assert!(c.is_null());
    assert!(log.contains("instanceName is NULL"));
    let c = unsafe {
        fmi2Instantiate(
            name.as_ptr(),
            FMI2_CO_SIMULATION,
            null(),
            null(),
            &cb as *const _ as *const CallbackFunctions,
            0,
            0,
        )
    };
    assert!(c.is_null());
    assert!(log.contains("fmuGUID is NULL"));
    let c = unsafe {
        fmi2Instantiate(
            name.as_ptr(),
            FMI2_CO_SIMULATION,
            guid.as_ptr(),
            null(),
            null(),
            0,
            0,
        )
    };
    assert!(c.is_null(), "no callbacks: refused, and nothing to log to");
}

#[test]
fn resource_uris_of_every_importer_are_accepted() {
    let log = LogCapture::default();
    for (uri, path) in [
        (
            Some("file:///tmp/a%20b/resources"),
            Some("/tmp/a b/resources"),
        ),
        (Some("file:/tmp/r/"), Some("/tmp/r/")),
        (Some("file://localhost/tmp/r"), Some("/tmp/r")),
        (None, None),
    ] {
        let fmu = Fmu::with(&log, GUID, uri, false).expect("instantiate");
        assert_eq!(fmu.model_resources().as_deref(), path, "{uri:?}");
    }
}

#[test]
fn null_pointers_unknown_references_and_wrong_causality_are_errors() {
    let log = LogCapture::default();
    let fmu = Fmu::new(&log, false);
    fmu.init();
    let mut v = [0.0; 2];
    assert_eq!(
        unsafe { fmi2GetReal(fmu.c, null(), 2, v.as_mut_ptr()) },
        ERROR
    );
    assert!(log.contains("fmi2GetReal: argument 'vr' is NULL"));
    unsafe { fmi2Reset(fmu.c) };
    fmu.init();
    assert_eq!(
        unsafe { fmi2GetReal(fmu.c, [VR_Y].as_ptr(), 1, null_mut()) },
        ERROR
    );
    unsafe { fmi2Reset(fmu.c) };
    fmu.init();
    assert_eq!(
        unsafe { fmi2GetReal(fmu.c, [VR_Y, 99].as_ptr(), 2, v.as_mut_ptr()) },
        ERROR
    );
    assert!(log.contains("fmi2GetReal: unknown value reference 99 for type Real"));
    unsafe { fmi2Reset(fmu.c) };
    fmu.init();
    assert_eq!(fmu.set(VR_Y, 1.0), ERROR);
    assert!(log.contains("variable 'y' (Output, Continuous) cannot be set"));
    unsafe { fmi2Reset(fmu.c) };
    fmu.init();
    assert_eq!(
        fmu.set(VR_T, 1.0),
        ERROR,
        "fixed parameter after initialisation"
    );
    assert!(log.contains("variable 'T' (Parameter, Fixed) cannot be set after initialisation"));
    unsafe { fmi2Reset(fmu.c) };
    fmu.init();
    let mut i = 0;
    assert_eq!(unsafe { fmi2GetInteger(fmu.c, &0, 1, &mut i) }, ERROR);
    assert!(log.contains("unknown value reference 0 for type Integer"));
    // Zero-length calls with NULL arrays are legal no-ops.
    unsafe { fmi2Reset(fmu.c) };
    fmu.init();
    assert_eq!(unsafe { fmi2GetReal(fmu.c, null(), 0, null_mut()) }, OK);
    assert_eq!(unsafe { fmi2GetString(fmu.c, null(), 0, null_mut()) }, OK);
    assert_eq!(unsafe { fmi2Terminate(null_mut()) }, ERROR, "NULL instance");
    unsafe { fmi2FreeInstance(null_mut()) };
}

#[test]
fn nan_or_infinite_input_is_refused_and_nothing_changes() {
    let log = LogCapture::default();
    let fmu = Fmu::new(&log, false);
    fmu.init();
    assert_eq!(fmu.set(VR_U, 0.25), OK);
    let mut saved: Fmi2FmuState = null_mut();
    assert_eq!(unsafe { fmi2GetFMUstate(fmu.c, &mut saved) }, OK);
    let vrs = [VR_U, VR_U];
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        // The first value is fine, the second is not: neither may be applied.
        let values = [0.75, bad];
        assert_eq!(
            unsafe { fmi2SetReal(fmu.c, vrs.as_ptr(), 2, values.as_ptr()) },
            ERROR
        );
        assert!(
            log.contains(&format!(
                "fmi2SetReal: value of 'u' must be finite, got {bad}"
            )),
            "{:?}",
            log.messages()
        );
        assert_eq!(fmu.get(VR_U), 0.25, "state unchanged");
        // fmi2Error leaves the instance in Error (FMI 2.0.4 §2.1.3); a saved state recovers it.
        assert_eq!(fmu.state(), fmu_core::state_machine::FmiState::Error);
        assert_eq!(unsafe { fmi2SetFMUstate(fmu.c, saved) }, OK);
        assert_eq!(fmu.step(0.0, 0.1), OK);
        assert_eq!(unsafe { fmi2SetFMUstate(fmu.c, saved) }, OK);
    }
}

#[test]
fn inadmissible_parameter_is_refused_by_the_model() {
    let log = LogCapture::default();
    let fmu = Fmu::new(&log, false);
    assert_eq!(fmu.set(VR_T, -1.0), ERROR);
    assert!(log.contains("fmi2SetReal: rejected value for 'T': T must be > 0 s, got -1"));
}

#[test]
fn non_positive_and_mismatched_steps_are_errors() {
    let log = LogCapture::default();
    let fmu = Fmu::new(&log, false);
    for (t, h, msg) in [
        (
            0.0,
            0.0,
            "communicationStepSize must be a finite number > 0, got 0",
        ),
        (0.0, -0.1, "got -0.1"),
        (0.0, f64::NAN, "got NaN"),
        (
            0.5,
            0.1,
            "currentCommunicationPoint 0.5 does not match the FMU's time 0",
        ),
    ] {
        unsafe { fmi2Reset(fmu.c) };
        fmu.init();
        assert_eq!(fmu.step(t, h), ERROR);
        assert!(log.contains(msg), "{msg}: {:?}", log.messages());
    }
    // A master that computes t = i·h instead of summing is within tolerance.
    unsafe { fmi2Reset(fmu.c) };
    fmu.init();
    let h = 0.1;
    for i in 0..30 {
        assert_eq!(fmu.step(i as f64 * h, h), OK, "step {i}");
    }
}

#[test]
fn stop_time_is_enforced() {
    let log = LogCapture::default();
    let fmu = Fmu::new(&log, false);
    unsafe {
        fmi2SetupExperiment(fmu.c, 0, 0.0, 0.0, 1, 0.25);
        fmi2EnterInitializationMode(fmu.c);
        fmi2ExitInitializationMode(fmu.c);
    }
    assert_eq!(fmu.step(0.0, 0.25), OK);
    assert_eq!(fmu.step(0.25, 0.1), ERROR);
    assert!(log.contains("goes beyond stopTime 0.25"));
}

#[test]
fn panic_in_the_model_becomes_fmi2error_not_a_crash() {
    let log = LogCapture::default();
    let fmu = Fmu::new(&log, false);
    fmu.init();
    fmu.set(VR_U, 666.0);
    assert_eq!(fmu.step(0.0, 0.1), ERROR);
    assert!(log.contains("fmi2DoStep: internal error: the number of the beast"));
    // The FMU's quiet panic hook took the panic (it alone knows where it happened) instead of
    // printing it to the importer's stderr.
    assert!(
        log.contains("the number of the beast (at fmu-core/tests/runtime.rs:"),
        "{:?}",
        log.messages()
    );
    // A panic outside our FMI calls still reaches the previous hook and unwinds as usual.
    assert!(std::panic::catch_unwind(|| panic!("not ours")).is_err());
    assert_eq!(
        unsafe { fmi2Reset(fmu.c) },
        OK,
        "the instance can still be reset"
    );
}

#[test]
fn fmu_state_restores_exactly_and_moves_between_instances_by_value() {
    let log = LogCapture::default();
    let a = Fmu::new(&log, false);
    a.init();
    a.set(VR_U, 1.0);
    a.step(0.0, 0.1);
    let mut s: Fmi2FmuState = null_mut();
    assert_eq!(unsafe { fmi2GetFMUstate(a.c, &mut s) }, OK);
    let y_saved = a.get(VR_Y);
    a.step(0.1, 0.1);
    let y_next = a.get(VR_Y);
    assert_eq!(unsafe { fmi2SetFMUstate(a.c, s) }, OK);
    assert_eq!(a.get(VR_Y), y_saved);
    a.step(0.1, 0.1);
    assert_eq!(a.get(VR_Y).to_bits(), y_next.to_bits());

    // Serialise, deserialise into a second instance, continue identically.
    let mut size = 0usize;
    assert_eq!(unsafe { fmi2SerializedFMUstateSize(a.c, s, &mut size) }, OK);
    let mut bytes = vec![0 as Fmi2Byte; size];
    assert_eq!(
        unsafe { fmi2SerializeFMUstate(a.c, s, bytes.as_mut_ptr(), size) },
        OK
    );
    assert_eq!(
        unsafe { fmi2SerializeFMUstate(a.c, s, bytes.as_mut_ptr(), size - 1) },
        ERROR,
        "buffer too small"
    );
    unsafe { fmi2Reset(a.c) };
    let b = Fmu::new(&log, false);
    let mut sb: Fmi2FmuState = null_mut();
    assert_eq!(
        unsafe { fmi2DeSerializeFMUstate(b.c, bytes.as_ptr(), size, &mut sb) },
        OK
    );
    assert_eq!(unsafe { fmi2SetFMUstate(b.c, sb) }, OK);
    assert_eq!(b.state(), fmu_core::state_machine::FmiState::StepComplete);
    b.step(0.1, 0.1);
    assert_eq!(b.get(VR_Y).to_bits(), y_next.to_bits());

    // A state handle of instance A is not accepted by instance B.
    a.init();
    let mut sa: Fmi2FmuState = null_mut();
    assert_eq!(unsafe { fmi2GetFMUstate(a.c, &mut sa) }, OK);
    assert_eq!(unsafe { fmi2SetFMUstate(b.c, sa) }, ERROR);
    assert!(log.contains("not created by this instance"));
    assert_eq!(unsafe { fmi2FreeFMUstate(a.c, &mut sa) }, OK);
    assert!(sa.is_null());
    assert_eq!(
        unsafe { fmi2FreeFMUstate(a.c, &mut sa) },
        OK,
        "freeing NULL is a no-op"
    );
    assert_eq!(
        unsafe { fmi2FreeFMUstate(a.c, null_mut()) },
        OK,
        "so is a NULL pointer to a state"
    );
}

#[test]
fn corrupted_serialized_state_is_rejected_without_crash() {
    let log = LogCapture::default();
    let a = Fmu::new(&log, false);
    a.init();
    a.set(VR_U, 0.5);
    a.step(0.0, 0.1);
    let mut s: Fmi2FmuState = null_mut();
    unsafe { fmi2GetFMUstate(a.c, &mut s) };
    let mut size = 0usize;
    unsafe { fmi2SerializedFMUstateSize(a.c, s, &mut size) };
    let mut bytes = vec![0 as Fmi2Byte; size];
    unsafe { fmi2SerializeFMUstate(a.c, s, bytes.as_mut_ptr(), size) };
    let y = a.get(VR_Y);
    for i in (0..size).step_by(3) {
        let mut bad = bytes.clone();
        bad[i] ^= 0x11;
        let mut out: Fmi2FmuState = null_mut();
        unsafe { fmi2Reset(a.c) };
        a.init();
        assert_eq!(
            unsafe { fmi2DeSerializeFMUstate(a.c, bad.as_ptr(), size, &mut out) },
            ERROR,
            "byte {i}"
        );
        assert!(out.is_null());
    }
    assert!(
        log.contains("fmi2DeSerializeFMUstate: FMU state is corrupted (checksum mismatch)")
            || log.contains("bad magic")
    );
    let mut out: Fmi2FmuState = null_mut();
    unsafe { fmi2Reset(a.c) };
    assert_eq!(
        unsafe { fmi2DeSerializeFMUstate(a.c, bytes.as_ptr(), size / 2, &mut out) },
        ERROR,
        "truncated"
    );
    unsafe { fmi2Reset(a.c) };
    assert_eq!(
        unsafe { fmi2DeSerializeFMUstate(a.c, bytes.as_ptr(), size, &mut out) },
        OK
    );
    assert_eq!(unsafe { fmi2SetFMUstate(a.c, out) }, OK);
    assert_eq!(a.get(VR_Y), y);
}

#[test]
fn logging_honours_logging_on_and_categories() {
    let log = LogCapture::default();
    let quiet = Fmu::new(&log, false);
    assert!(
        log.entries().is_empty(),
        "no event messages with loggingOn = false"
    );
    quiet.step(0.0, 0.1);
    let e = log.entries();
    assert_eq!(e.len(), 1, "errors are logged regardless: {e:?}");
    assert_eq!(
        (e[0].status, e[0].category.as_str(), e[0].instance.as_str()),
        (ERROR, "logStatusError", "lag1")
    );
    log.clear();
    let loud = Fmu::new(&log, true);
    assert!(log.contains("fmi2Instantiate: lag instantiated"));
    log.clear();
    let cats = [c"logStatusError".as_ptr()];
    assert_eq!(
        unsafe { fmi2SetDebugLogging(loud.c, 1, 1, cats.as_ptr()) },
        OK
    );
    loud.init();
    assert!(
        log.entries().is_empty(),
        "logEvents switched off: {:?}",
        log.messages()
    );
    let bad = [c"logEverything".as_ptr()];
    assert_eq!(
        unsafe { fmi2SetDebugLogging(loud.c, 1, 1, bad.as_ptr()) },
        ERROR
    );
    assert!(log.contains("unknown log category 'logEverything'"));
}

/// An error reaches the logger whatever categories are on: with only `logEvents`, and with
/// logging off. The standard's `logAll` switches every category on.
#[test]
fn errors_are_logged_whatever_the_categories_and_log_all_is_accepted() {
    for logging_on in [1, 0] {
        let log = LogCapture::default();
        let fmu = Fmu::new(&log, true);
        let events = [c"logEvents".as_ptr()];
        assert_eq!(
            unsafe { fmi2SetDebugLogging(fmu.c, logging_on, 1, events.as_ptr()) },
            OK
        );
        log.clear();
        assert_eq!(fmu.step(0.0, 0.1), ERROR, "a step before initialisation");
        let e = log.entries();
        assert!(
            e.iter()
                .any(|e| e.status == ERROR && e.category == "logStatusError"),
            "loggingOn {logging_on}: {e:?}"
        );
    }
    let log = LogCapture::default();
    let fmu = Fmu::new(&log, false);
    let all = [c"logAll".as_ptr()];
    assert_eq!(
        unsafe { fmi2SetDebugLogging(fmu.c, 1, 1, all.as_ptr()) },
        OK
    );
    log.clear();
    fmu.init();
    assert!(
        log.entries().iter().any(|e| e.category == "logEvents"),
        "{:?}",
        log.messages()
    );
    // A discard is logged under its own category.
    let mut s = 0;
    assert_eq!(
        unsafe { fmi2GetStatus(fmu.c, status_kind::PENDING_STATUS, &mut s) },
        DISCARD
    );
    assert!(
        log.entries()
            .iter()
            .any(|e| e.status == DISCARD && e.category == "logStatusDiscard"),
        "{:?}",
        log.messages()
    );
}

#[test]
fn percent_signs_in_messages_reach_the_logger_verbatim() {
    let log = LogCapture::default();
    let fmu = Fmu::new(&log, false);
    // An unknown category name with printf conversions is echoed in the error message.
    let cats = [c"%s%n%x".as_ptr()];
    assert_eq!(
        unsafe { fmi2SetDebugLogging(fmu.c, 1, 1, cats.as_ptr()) },
        ERROR
    );
    assert!(
        log.contains("unknown log category '%s%n%x'"),
        "{:?}",
        log.messages()
    );
}

#[test]
fn status_queries() {
    let log = LogCapture::default();
    let fmu = Fmu::new(&log, false);
    fmu.init();
    fmu.step(0.0, 0.25);
    let mut t = 0.0;
    assert_eq!(
        unsafe { fmi2GetRealStatus(fmu.c, status_kind::LAST_SUCCESSFUL_TIME, &mut t) },
        OK
    );
    assert_eq!(t, 0.25);
    let mut b = 1;
    assert_eq!(
        unsafe { fmi2GetBooleanStatus(fmu.c, status_kind::TERMINATED, &mut b) },
        OK
    );
    assert_eq!(b, 0);
    let mut s = 0;
    assert_eq!(
        unsafe { fmi2GetStatus(fmu.c, status_kind::PENDING_STATUS, &mut s) },
        DISCARD
    );
    assert_eq!(
        fmu.step(0.25, 0.25),
        OK,
        "Discard does not break the instance"
    );
    assert_eq!(
        unsafe { fmi2GetDirectionalDerivative(fmu.c, null(), 0, null(), 0, null(), null_mut()) },
        ERROR
    );
    assert!(log.contains("providesDirectionalDerivative = false"));
}

#[test]
fn many_instances_coexist_without_shared_state() {
    let log = LogCapture::default();
    let fmus: Vec<Fmu> = (0..8).map(|_| Fmu::new(&log, false)).collect();
    for (k, f) in fmus.iter().enumerate() {
        f.init();
        f.set(VR_U, k as f64);
        f.step(0.0, 1.0);
    }
    for (k, f) in fmus.iter().enumerate() {
        assert!((f.get(VR_Y) - k as f64 * (1.0 - (-2.0f64).exp())).abs() < 1e-14);
    }
}

/// The dependency probe sees exactly the lag's structure — `u_echo` follows `u` at once, `y`
/// only through its state — and reports a description that leaves the feed-through out.
#[test]
fn measured_dependencies_match_the_lag_and_expose_a_missing_one() {
    let log = LogCapture::default();
    let cb = log.callbacks();
    let callbacks = unsafe { &*(&cb as *const _ as *const CallbackFunctions) };
    let uri = "file:///tmp/lag/resources";
    let measured = fmu_core::dependencies::measure::<Lag>(Some(uri), callbacks, &[]).unwrap();
    let d = Lag::description(None).unwrap();
    let m = measured.compare(&d);
    assert!(m.undeclared.is_empty() && m.unobserved.is_empty(), "{m:?}");
    let mut wrong = d.clone();
    wrong.variables[3].depends_on.clear();
    let m = measured.compare(&wrong);
    let echo = ("u_echo".to_string(), "u".to_string());
    assert_eq!(m.undeclared, vec![echo.clone(), echo]);
    // A point to probe at that names no variable is refused.
    let err = fmu_core::dependencies::measure::<Lag>(Some(uri), callbacks, &[("nope", 1.0)]);
    assert!(err.unwrap_err().contains("no variable 'nope'"));
}

/// FMI 3.0 through the same library's `fmi3*` exports: messages land in a `Vec` through a Rust
/// `fmi3LogMessageCallback` (not variadic), the environment pointing at it.
mod fmi3 {
    use super::*;
    use fmu_core::description::FMI3_TIME_VR;
    use std::os::raw::{c_char, c_int, c_void};
    use std::sync::Mutex;

    type Messages = Mutex<Vec<(c_int, String, String)>>;

    unsafe extern "C" fn log(
        env: *mut c_void,
        status: c_int,
        category: *const c_char,
        message: *const c_char,
    ) {
        let messages = &*(env as *const Messages);
        let text = |p: *const c_char| CStr::from_ptr(p).to_string_lossy().into_owned();
        messages
            .lock()
            .unwrap()
            .push((status, text(category), text(message)));
    }

    fn last(messages: &Messages) -> (c_int, String) {
        let m = messages.lock().unwrap();
        let (s, _, text) = m.last().expect("a message").clone();
        (s, text)
    }

    fn instantiate(
        messages: &Messages,
        token: &str,
        resources: Option<&Path>,
        event_mode: bool,
    ) -> *mut c_void {
        let name = CString::new("lag3").unwrap();
        let token = CString::new(token).unwrap();
        let path = resources.map(|p| CString::new(p.to_str().unwrap()).unwrap());
        unsafe {
            fmi3InstantiateCoSimulation(
                name.as_ptr(),
                token.as_ptr(),
                path.as_ref().map_or(null(), |p| p.as_ptr()),
                false,
                true,
                event_mode,
                false,
                null(),
                0,
                messages as *const Messages as *mut c_void,
                Some(log),
                None,
            )
        }
    }

    /// A whole Co-Simulation run: the exact lag, `lastSuccessfulTime`, the independent variable,
    /// and the resource path taken as a native path.
    #[test]
    fn a_co_simulation_run_steps_the_model_exactly() {
        let messages = Messages::default();
        let dir = std::env::temp_dir();
        let c = instantiate(&messages, GUID, Some(&dir), false);
        assert!(!c.is_null(), "{:?}", messages.lock().unwrap());
        let inst = unsafe { &*(c as *mut fmu_core::instance::Instance<Lag>) };
        assert_eq!(inst.model().resources_seen.as_deref(), dir.to_str());
        unsafe {
            assert_eq!(
                fmi3EnterInitializationMode(c, false, 0.0, 0.5, true, 2.0),
                OK
            );
            assert_eq!(fmi3SetFloat64(c, &VR_U, 1, &1.0, 1), OK);
            assert_eq!(fmi3ExitInitializationMode(c), OK);
            let (mut event, mut terminate, mut early, mut last) = (true, true, true, 0.0);
            for k in 0..10 {
                let t = 0.5 + 0.1 * k as f64;
                let status = fmi3DoStep(
                    c,
                    t,
                    0.1,
                    true,
                    &mut event,
                    &mut terminate,
                    &mut early,
                    &mut last,
                );
                assert_eq!(status, OK);
                assert!(!event && !terminate && !early);
                assert!((last - (t + 0.1)).abs() < 1e-12);
            }
            let (mut y, mut t) = (f64::NAN, f64::NAN);
            assert_eq!(fmi3GetFloat64(c, &VR_Y, 1, &mut y, 1), OK);
            assert_eq!(fmi3GetFloat64(c, &FMI3_TIME_VR, 1, &mut t, 1), OK);
            assert!((y - (1.0 - (-1.0f64 / 0.5).exp())).abs() < 1e-14, "{y}");
            assert!((t - 1.5).abs() < 1e-12);
            assert_eq!(fmi3Terminate(c), OK);
            fmi3FreeInstance(c);
        }
    }

    /// The FMI 3.0 calling rules, each refusal with its reason in the log.
    #[test]
    fn illegal_calls_and_absent_capabilities_are_errors_with_a_message() {
        let messages = Messages::default();
        assert!(instantiate(&messages, "{not-lag}", None, false).is_null());
        assert!(last(&messages).1.contains("instantiation token mismatch"));
        assert!(instantiate(&messages, GUID, None, true).is_null());
        assert!(last(&messages).1.contains("hasEventMode = false"));
        assert!(instantiate(
            &messages,
            GUID,
            Some(Path::new("/nonexistent/resources")),
            false
        )
        .is_null());
        assert!(last(&messages).1.contains("is not a directory"));
        let name = CString::new("me").unwrap();
        let token = CString::new(GUID).unwrap();
        let env = &messages as *const Messages as *mut c_void;
        let me = unsafe {
            fmi3InstantiateModelExchange(
                name.as_ptr(),
                token.as_ptr(),
                null(),
                false,
                false,
                env,
                Some(log),
            )
        };
        assert!(me.is_null());
        assert!(last(&messages).1.contains("supports Co-Simulation only"));
        let se = unsafe {
            fmi3InstantiateScheduledExecution(
                name.as_ptr(),
                token.as_ptr(),
                null(),
                false,
                false,
                env,
                Some(log),
                None,
                None,
                None,
            )
        };
        assert!(se.is_null());
        assert!(last(&messages)
            .1
            .contains("does not support Scheduled Execution"));

        let c = instantiate(&messages, GUID, None, false);
        let (mut event, mut terminate, mut early, mut last_time) = (false, false, false, 0.0);
        unsafe {
            assert_eq!(
                fmi3DoStep(
                    c,
                    0.0,
                    0.1,
                    true,
                    &mut event,
                    &mut terminate,
                    &mut early,
                    &mut last_time
                ),
                ERROR
            );
            assert_eq!(
                last(&messages),
                (
                    ERROR,
                    "fmi3DoStep: illegal call in state Instantiated".into()
                )
            );
            assert_eq!(fmi3Reset(c), OK);
            assert_eq!(
                fmi3EnterInitializationMode(c, false, 0.0, 0.0, false, 0.0),
                OK
            );
            let mut two = [0.0; 2];
            assert_eq!(fmi3GetFloat64(c, &VR_Y, 1, two.as_mut_ptr(), 2), ERROR);
            assert!(last(&messages)
                .1
                .contains("nValues = 2 for nValueReferences = 1"));
            assert_eq!(fmi3Reset(c), OK);
            assert_eq!(
                fmi3EnterInitializationMode(c, false, 0.0, 0.0, false, 0.0),
                OK
            );
            let mut x = 0i64;
            assert_eq!(fmi3GetInt64(c, null(), 0, &mut x, 0), OK);
            assert_eq!(fmi3GetInt64(c, &VR_Y, 1, &mut x, 1), ERROR);
            assert!(last(&messages).1.contains("this FMU has no Int64 variable"));
            // Above the model's references only FMI 3.0's own variables are: this FMU has no
            // event indicator.
            assert_eq!(fmi3Reset(c), OK);
            assert_eq!(
                fmi3EnterInitializationMode(c, false, 0.0, 0.0, false, 0.0),
                OK
            );
            let indicator = FMI3_TIME_VR + 1;
            assert_eq!(fmi3SetFloat64(c, &indicator, 1, &1.0, 1), ERROR);
            assert!(last(&messages)
                .1
                .contains("unknown value reference 1000000001"));
            let refused: [(unsafe extern "C" fn(*mut c_void) -> c_int, &str); 3] = [
                (fmi3EnterConfigurationMode, "no structural parameters"),
                (
                    fmi3EvaluateDiscreteStates,
                    "providesEvaluateDiscreteStates = false",
                ),
                (fmi3EnterStepMode, "illegal call in state Instantiated"),
            ];
            for (call, why) in refused {
                assert_eq!(call(c), ERROR);
                assert!(last(&messages).1.contains(why), "{:?}", last(&messages));
                assert_eq!(fmi3Reset(c), OK);
            }
            // A Model Exchange function on a Co-Simulation instance.
            let mut n = 0usize;
            assert_eq!(fmi3GetNumberOfContinuousStates(c, &mut n), ERROR);
            assert!(last(&messages)
                .1
                .contains("a function of Model Exchange only"));
            fmi3FreeInstance(c);
        }
    }

    /// A panic in the model is `fmi3Error`, and an FMU state serialises and restores by value.
    #[test]
    fn a_panic_is_an_error_and_a_state_restores_by_value() {
        let messages = Messages::default();
        let c = instantiate(&messages, GUID, None, false);
        let (mut e, mut t, mut r, mut last_time) = (false, false, false, 0.0);
        unsafe {
            assert_eq!(
                fmi3EnterInitializationMode(c, false, 0.0, 0.0, false, 0.0),
                OK
            );
            assert_eq!(fmi3SetFloat64(c, &VR_U, 1, &1.0, 1), OK);
            assert_eq!(fmi3ExitInitializationMode(c), OK);
            assert_eq!(
                fmi3DoStep(c, 0.0, 0.1, true, &mut e, &mut t, &mut r, &mut last_time),
                OK
            );
            let mut state: *mut c_void = null_mut();
            assert_eq!(fmi3GetFMUState(c, &mut state), OK);
            let mut size = 0usize;
            assert_eq!(fmi3SerializedFMUStateSize(c, state, &mut size), OK);
            let mut bytes = vec![0u8; size];
            assert_eq!(
                fmi3SerializeFMUState(c, state, bytes.as_mut_ptr(), size),
                OK
            );
            assert_eq!(fmi3FreeFMUState(c, &mut state), OK);
            let mut y0 = 0.0;
            assert_eq!(fmi3GetFloat64(c, &VR_Y, 1, &mut y0, 1), OK);
            assert_eq!(fmi3SetFloat64(c, &VR_U, 1, &666.0, 1), OK);
            assert_eq!(
                fmi3DoStep(c, 0.1, 0.1, true, &mut e, &mut t, &mut r, &mut last_time),
                ERROR
            );
            assert!(last(&messages).1.contains("the number of the beast"));
            let mut restored: *mut c_void = null_mut();
            assert_eq!(
                fmi3DeserializeFMUState(c, bytes.as_ptr(), size, &mut restored),
                OK
            );
            assert_eq!(fmi3SetFMUState(c, restored), OK);
            let (mut y, mut time) = (f64::NAN, f64::NAN);
            assert_eq!(fmi3GetFloat64(c, &VR_Y, 1, &mut y, 1), OK);
            assert_eq!(fmi3GetFloat64(c, &FMI3_TIME_VR, 1, &mut time, 1), OK);
            assert_eq!((y, time), (y0, 0.1));
            assert_eq!(
                fmi3DoStep(c, 0.1, 0.1, true, &mut e, &mut t, &mut r, &mut last_time),
                OK
            );
            assert_eq!(fmi3FreeFMUState(c, &mut restored), OK);
            fmi3FreeInstance(c);
        }
    }
}
