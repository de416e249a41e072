//! The road FMU through its exported C functions: the outputs are the `vehicle::road` profiles
//! at the time reached, for any step size; bad parameters fail initialisation with a message;
//! the FMU state round-trips; the checked-in description and README table are current.

use fmi_test_logger::LogCapture;
use fmu_core::types::*;
use fmu_road::*;
use std::ffi::CString;
use std::ptr::{null, null_mut};
use vehicle::road::{Profile, Road};

struct Inst {
    c: Fmi2Component,
    _cb: Box<fmi_test_logger::Callbacks>,
}

impl Inst {
    fn new(log: &LogCapture) -> Inst {
        let cb = Box::new(log.callbacks());
        let name = CString::new("road").unwrap();
        let guid = CString::new(model_description().guid).unwrap();
        let c = unsafe {
            fmi2Instantiate(
                name.as_ptr(),
                FMI2_CO_SIMULATION,
                guid.as_ptr(),
                null(),
                &*cb as *const _ as *const CallbackFunctions,
                0,
                0,
            )
        };
        assert!(!c.is_null(), "{:?}", log.messages());
        Inst { c, _cb: cb }
    }
    fn vr(name: &str) -> u32 {
        model_description()
            .variable(name)
            .unwrap_or_else(|| panic!("no variable {name}"))
            .value_reference
    }
    fn set_real(&self, name: &str, v: f64) -> Fmi2Status {
        unsafe { fmi2SetReal(self.c, &Self::vr(name), 1, &v) }
    }
    fn set_int(&self, name: &str, v: i32) -> Fmi2Status {
        unsafe { fmi2SetInteger(self.c, &Self::vr(name), 1, &v) }
    }
    fn init(&self) -> Fmi2Status {
        unsafe {
            fmi2SetupExperiment(self.c, 0, 0.0, 0.0, 0, 0.0);
            fmi2EnterInitializationMode(self.c);
            fmi2ExitInitializationMode(self.c)
        }
    }
    fn outputs(&self) -> [f64; 8] {
        let vrs: Vec<u32> = (0..8).map(|k| vr::OUTPUT + k).collect();
        let mut out = [0.0; 8];
        assert_eq!(
            unsafe { fmi2GetReal(self.c, vrs.as_ptr(), 8, out.as_mut_ptr()) },
            0
        );
        out
    }
}

impl Drop for Inst {
    fn drop(&mut self) {
        unsafe { fmi2FreeInstance(self.c) };
    }
}

#[test]
fn outputs_are_the_profile_at_the_time_reached_for_any_step() {
    let log = LogCapture::default();
    let fmu = Inst::new(&log);
    for (name, v) in [("speed", 17.0), ("start_distance", -2.4)] {
        assert_eq!(fmu.set_real(name, v), 0);
    }
    for (name, v) in [("profile", 2), ("iso_class", 4), ("seed", 42)] {
        assert_eq!(fmu.set_int(name, v), 0);
    }
    assert_eq!(fmu.init(), 0, "{:?}", log.messages());
    let road = Road::new(
        Profile::Iso {
            class: 4,
            seed: 42,
            identical_tracks: false,
            fade_in: 1.0,
        },
        17.0,
        2.4,
        -2.4,
    )
    .unwrap();
    let mut t = 0.0;
    for k in 0..300 {
        let h = [1e-3, 0.0137, 0.25][k % 3];
        assert_eq!(unsafe { fmi2DoStep(fmu.c, t, h, 1) }, 0);
        t += h;
        assert_eq!(fmu.outputs(), road.at(t), "t = {t}");
    }
    // The rear wheels have the front's values one wheelbase later, through the FMU too.
    assert!(fmu.outputs()[2] != 0.0);
}

#[test]
fn bad_parameters_fail_initialisation_with_a_message() {
    for (what, int, real, message) in [
        (
            "profile",
            Some(("profile", 7)),
            None,
            "profile must be 1 (bump)",
        ),
        (
            "class",
            Some(("iso_class", 9)),
            None,
            "iso_class must be 1 (A)",
        ),
        ("side", Some(("side", 3)), None, "side must be 0 (left)"),
        (
            "speed",
            None,
            Some(("speed", 0.0)),
            "value 0 of 'speed' is below its minimum 0.1",
        ),
        (
            "bump",
            None,
            Some(("bump_length", -1.0)),
            "value -1 of 'bump_length' is below its minimum 0.01",
        ),
    ] {
        let log = LogCapture::default();
        let fmu = Inst::new(&log);
        if let Some((n, v)) = int {
            fmu.set_int(n, v);
            if n == "iso_class" {
                fmu.set_int("profile", 2);
            }
        }
        if let Some((n, v)) = real {
            fmu.set_real(n, v);
        }
        assert_ne!(fmu.init(), 0, "{what}: accepted");
        assert!(log.contains(message), "{what}: {:?}", log.messages());
    }
}

#[test]
fn fmu_state_round_trips_with_its_parameters() {
    let log = LogCapture::default();
    let a = Inst::new(&log);
    a.set_int("profile", 3);
    a.set_real("sweep_f_end", 8.0);
    assert_eq!(a.init(), 0);
    for k in 0..100 {
        unsafe { fmi2DoStep(a.c, k as f64 * 0.01, 0.01, 1) };
    }
    let bytes = a.serialized_state();
    let at_one = a.outputs();
    // A fresh instance with default parameters (a bump) takes the sweep and its time.
    let b = Inst::new(&log);
    assert_eq!(b.init(), 0);
    assert_eq!(b.set_serialized_state(&bytes), 0);
    assert_eq!(b.outputs(), at_one);
    unsafe {
        fmi2DoStep(a.c, 1.0, 0.5, 1);
        fmi2DoStep(b.c, 1.0, 0.5, 1);
    }
    assert_eq!(a.outputs(), b.outputs());
    assert_ne!(a.outputs(), at_one);
}

#[test]
fn checked_in_description_and_readme_table_are_current() {
    let xml = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../modelDescription/road.xml"
    ))
    .expect("modelDescription/road.xml exists");
    assert!(
        xml == model_description().to_xml(),
        "modelDescription/road.xml is stale: run `make descriptions` and commit it"
    );
    let xml3 = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../modelDescription/fmi3/road.xml"
    ))
    .expect("modelDescription/fmi3/road.xml exists");
    assert!(
        xml3 == model_description().to_xml3(),
        "modelDescription/fmi3/road.xml is stale: run `make descriptions` and commit it"
    );
    let readme =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../README.md")).unwrap();
    let expected = fmu_core::ModelDescription::splice_into(
        &readme,
        "road-variables",
        &model_description().to_markdown_table(),
    )
    .unwrap();
    assert!(
        readme == expected,
        "README.md's road variable table is stale: run `make descriptions` and commit it"
    );
    model_description().check().unwrap();
}

impl Inst {
    fn serialized_state(&self) -> Vec<u8> {
        let mut s: Fmi2FmuState = null_mut();
        assert_eq!(unsafe { fmi2GetFMUstate(self.c, &mut s) }, 0);
        let mut size = 0;
        unsafe { fmi2SerializedFMUstateSize(self.c, s, &mut size) };
        let mut bytes = vec![0 as Fmi2Byte; size];
        assert_eq!(
            unsafe { fmi2SerializeFMUstate(self.c, s, bytes.as_mut_ptr(), size) },
            0
        );
        unsafe { fmi2FreeFMUstate(self.c, &mut s) };
        bytes.into_iter().map(|b| b as u8).collect()
    }
    fn set_serialized_state(&self, bytes: &[u8]) -> Fmi2Status {
        let mut s: Fmi2FmuState = null_mut();
        let status = unsafe {
            fmi2DeSerializeFMUstate(
                self.c,
                bytes.as_ptr() as *const Fmi2Byte,
                bytes.len(),
                &mut s,
            )
        };
        if status != 0 {
            return status;
        }
        let status = unsafe { fmi2SetFMUstate(self.c, s) };
        unsafe { fmi2FreeFMUstate(self.c, &mut s) };
        status
    }
}

/// Every Real parameter declares a plausible range, the setter refuses a value outside it with
/// a message naming the parameter (the values that once gave `fmi2OK` with infinite or NaN
/// outputs among them), and at every corner of the ranges each profile's outputs stay finite.
#[test]
fn every_real_parameter_is_bounded_and_the_outputs_stay_finite_at_its_bounds() {
    let desc = model_description();
    let reals: Vec<(String, f64, f64)> = desc
        .variables
        .iter()
        .filter(|v| v.value_reference < vr::INTEGER)
        .map(|v| match v.kind {
            fmu_core::VarType::Real {
                min: Some(lo),
                max: Some(hi),
                ..
            } => (v.name.clone(), lo, hi),
            _ => panic!("{} declares no range", v.name),
        })
        .collect();
    assert_eq!(reals.len(), 19);
    let log = LogCapture::default();
    for (name, value) in [
        ("bump_height", 1e308),
        ("sweep_amplitude", 1e308),
        ("sweep_f_start", f64::MAX),
        ("sweep_f_end", 1e308),
        ("pothole_depth", -1e308),
        ("speed", 1e9),
    ] {
        let fmu = Inst::new(&log);
        assert_ne!(fmu.set_real(name, value), 0, "{name} = {value} accepted");
        assert!(
            log.contains(&format!("of '{name}' is")),
            "{name}: {:?}",
            log.messages()
        );
    }
    for profile in 1..=4 {
        for (name, lo, hi) in &reals {
            for value in [*lo, *hi] {
                let fmu = Inst::new(&log);
                assert_eq!(fmu.set_int("profile", profile), 0);
                assert_eq!(fmu.set_real(name, value), 0, "{name} = {value}");
                if fmu.init() != 0 {
                    // A combination the profile refuses (a pothole shorter than its ramps):
                    // refused with a message, never run.
                    assert!(
                        log.contains("pothole"),
                        "{name} = {value}: {:?}",
                        log.messages()
                    );
                    continue;
                }
                for k in 0..400 {
                    let t = k as f64 * 0.025;
                    assert_eq!(unsafe { fmi2DoStep(fmu.c, t, 0.025, 1) }, 0);
                    let out = fmu.outputs();
                    assert!(
                        out.iter().all(|v| v.is_finite()),
                        "profile {profile}, {name} = {value}, t = {t}: {out:?}"
                    );
                }
            }
        }
    }
}

/// A state taken in initialisation mode carries the experiment's start and stop time: the
/// instance it is restored into starts where the original does (it used its own start time).
#[test]
fn a_state_taken_in_initialisation_mode_carries_start_and_stop_time() {
    let log = LogCapture::default();
    let a = Inst::new(&log);
    assert_eq!(a.set_int("profile", 3), 0);
    unsafe {
        assert_eq!(fmi2SetupExperiment(a.c, 0, 0.0, 2.5, 1, 4.0), 0);
        assert_eq!(fmi2EnterInitializationMode(a.c), 0);
    }
    let bytes = a.serialized_state();
    assert_eq!(unsafe { fmi2ExitInitializationMode(a.c) }, 0);
    let b = Inst::new(&log);
    assert_eq!(b.set_serialized_state(&bytes), 0, "{:?}", log.messages());
    assert_eq!(unsafe { fmi2ExitInitializationMode(b.c) }, 0);
    assert_eq!(b.outputs(), a.outputs());
    assert_ne!(a.outputs(), [0.0; 8], "the sweep has started at 2.5 s");
    unsafe {
        assert_eq!(fmi2DoStep(a.c, 2.5, 0.5, 1), 0);
        assert_eq!(fmi2DoStep(b.c, 2.5, 0.5, 1), 0);
    }
    assert_eq!(b.outputs(), a.outputs());
    // The stop time came along too: a step past it is refused.
    unsafe {
        assert_ne!(fmi2DoStep(b.c, 3.0, 1.5, 1), 0);
    }
}

/// A state whose checksum matches but whose parameters the setters or initialisation would
/// refuse is refused, with the reason, and the instance keeps its own state.
#[test]
fn forged_states_are_refused_and_change_nothing() {
    let log = LogCapture::default();
    let a = Inst::new(&log);
    assert_eq!(a.set_real("speed", 12.345), 0);
    assert_eq!(a.init(), 0);
    unsafe { fmi2DoStep(a.c, 0.0, 0.1, 1) };
    let good = a.serialized_state();
    let b = Inst::new(&log);
    assert_eq!(b.set_real("speed", 11.0), 0);
    assert_eq!(b.init(), 0);
    unsafe { fmi2DoStep(b.c, 0.0, 0.2, 1) };
    let before = b.outputs();
    for (forged, why) in [
        (f64::NAN, "must be finite"),
        (-12.345, "speed"),
        (1e308, "value 1e308 of 'speed' is above its maximum 100"),
    ] {
        log.clear();
        let bytes = fmi_test_logger::forge_state(&good, 12.345, forged);
        assert_ne!(b.set_serialized_state(&bytes), 0, "speed {forged} accepted");
        assert!(
            log.contains("FMU state refused") && log.contains(why),
            "{forged}: {:?}",
            log.messages()
        );
        assert_eq!(b.outputs(), before);
    }
    assert_eq!(b.set_serialized_state(&good), 0);
    assert_eq!(b.outputs(), a.outputs());
}

/// The `<ModelStructure>` tells the truth: the road reads no inputs, and at the start time its
/// outputs move with the parameters of the profile in use (probed with the wheels on the bump);
/// the other profiles' parameters are declared, flat here.
#[test]
fn declared_dependencies_are_the_measured_ones() {
    let log = LogCapture::default();
    let cb = log.callbacks();
    let callbacks = unsafe { &*(&cb as *const _ as *const CallbackFunctions) };
    let measured = fmu_core::dependencies::measure::<fmu_road::RoadFmu>(
        None,
        callbacks,
        &[("start_distance", -3.0)],
    )
    .expect("measured");
    let d = fmu_road::model_description();
    let m = measured.compare(&d);
    assert!(m.undeclared.is_empty(), "undeclared: {:?}", m.undeclared);
    assert!(measured.outputs.iter().all(|(_, k)| k.is_empty()));
    let (_, z) = measured
        .initial
        .iter()
        .find(|(n, _)| n == "road_z_fl")
        .unwrap();
    for k in [
        "bump_height",
        "bump_length",
        "start_distance",
        "profile",
        "side",
    ] {
        assert!(z.contains(k), "road_z_fl does not move with {k}: {z:?}");
    }
    let (_, z) = measured
        .initial
        .iter()
        .find(|(n, _)| n == "road_z_rl")
        .unwrap();
    assert!(z.contains("wheelbase"), "{z:?}");
}

/// Outputs read in Initialization Mode are the road at the start time — what the first step
/// starts from — and parameters that do not make a road refuse the read with a message instead
/// of returning a flat road with fmi2OK.
#[test]
fn outputs_in_initialisation_mode_are_the_road_at_the_start_time() {
    let log = LogCapture::default();
    let r = Inst::new(&log);
    unsafe {
        assert_eq!(fmi2SetupExperiment(r.c, 0, 0.0, 1.5, 0, 0.0), 0);
        assert_eq!(fmi2EnterInitializationMode(r.c), 0);
    }
    // At 20 m/s the front wheels reach the 5 m bump 27.5 m ahead at t = 1.375 s.
    assert_eq!(r.set_real("start_distance", 27.5), 0);
    let during = r.outputs();
    assert!(during[0] > 0.0, "{during:?}");
    // A parameter set after a read is taken into account by the next read.
    assert_eq!(r.set_real("bump_height", 0.1), 0);
    let higher = r.outputs();
    assert!(
        (higher[0] - 2.0 * during[0]).abs() < 1e-15,
        "{higher:?} vs {during:?}"
    );
    unsafe { assert_eq!(fmi2ExitInitializationMode(r.c), 0) };
    assert_eq!(r.outputs(), higher);

    let r = Inst::new(&log);
    unsafe {
        assert_eq!(fmi2SetupExperiment(r.c, 0, 0.0, 0.0, 0, 0.0), 0);
        assert_eq!(fmi2EnterInitializationMode(r.c), 0);
    }
    assert_eq!(r.set_int("side", 7), 0);
    let mut z = 0.0;
    let status = unsafe { fmi2GetReal(r.c, &vr::OUTPUT, 1, &mut z) };
    assert_eq!(status, 3, "{:?}", log.messages());
    assert!(log.contains("side must be 0"), "{:?}", log.messages());
}
