//! `make bench`: one `fmi2DoStep` of the plant at a 1 ms communication step, through the
//! exported C functions (the same code the .so runs), in the situations a master meets.

use criterion::{criterion_group, criterion_main, Criterion};
use fmu_core::types::*;
use fmu_plant::*;
use std::ffi::CString;
use std::hint::black_box;
use std::ptr::null;

struct Instance {
    c: Fmi2Component,
    _cb: Box<CallbackFunctions>,
}

fn instance(setup: &[(&str, f64)]) -> Instance {
    let d = Plant::model_description();
    let cb = Box::new(CallbackFunctions {
        logger: None,
        allocate_memory: None,
        free_memory: None,
        step_finished: None,
        component_environment: std::ptr::null_mut(),
    });
    let name = CString::new("bench").unwrap();
    let guid = CString::new(d.guid.clone()).unwrap();
    let c = unsafe {
        fmi2Instantiate(
            name.as_ptr(),
            FMI2_CO_SIMULATION,
            guid.as_ptr(),
            null(),
            &*cb,
            0,
            0,
        )
    };
    for (n, v) in setup {
        let vr = d.variable(n).unwrap().value_reference;
        assert_eq!(unsafe { fmi2SetReal(c, &vr, 1, v) }, 0);
    }
    unsafe {
        fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0);
        fmi2EnterInitializationMode(c);
        fmi2ExitInitializationMode(c);
    }
    Instance { c, _cb: cb }
}

fn bench(c: &mut Criterion) {
    let h = 1e-3;
    let d = Plant::model_description();
    let inputs: Vec<u32> = input_names()
        .iter()
        .map(|n| d.variable(n).unwrap().value_reference)
        .collect();
    let outputs: Vec<u32> = d
        .variables
        .iter()
        .filter(|v| {
            v.causality == fmu_core::Causality::Output
                && matches!(v.kind, fmu_core::description::VarType::Real { .. })
        })
        .map(|v| v.value_reference)
        .collect();

    for (label, setup) in [
        ("do_step 1 ms, ideal actuators", vec![]),
        (
            "do_step 1 ms, tau = 20 ms (whole steps)",
            vec![("tau", 0.02)],
        ),
        (
            "do_step 1 ms, tau = 20.5 ms (two sub-steps)",
            vec![("tau", 0.0205)],
        ),
        (
            "do_step 1 ms, 20 Hz actuator lag",
            vec![("actuator_bandwidth", 20.0)],
        ),
    ] {
        let inst = instance(&setup);
        let mut t = 0.0;
        c.bench_function(label, |b| {
            b.iter(|| {
                let s = unsafe { fmi2DoStep(inst.c, black_box(t), h, 1) };
                t += h;
                s
            })
        });
        unsafe { fmi2FreeInstance(inst.c) };
    }

    // A master's full cycle: 13 inputs in, one step, every Real output out.
    let inst = instance(&[]);
    let mut t = 0.0;
    let mut u = vec![0.0; inputs.len()];
    let mut y = vec![0.0; outputs.len()];
    let label = format!(
        "set 13 inputs + do_step 1 ms + get {} outputs",
        outputs.len()
    );
    c.bench_function(&label, |b| {
        b.iter(|| {
            u[0] = 0.01 * (t * 10.0f64).sin();
            u[12] = 100.0 * (t * 7.0f64).sin();
            unsafe {
                fmi2SetReal(inst.c, inputs.as_ptr(), inputs.len(), u.as_ptr());
                fmi2DoStep(inst.c, t, h, 1);
                fmi2GetReal(inst.c, outputs.as_ptr(), outputs.len(), y.as_mut_ptr());
            }
            t += h;
            black_box(y[0])
        })
    });
    unsafe { fmi2FreeInstance(inst.c) };
}

criterion_group!(benches, bench);
criterion_main!(benches);
