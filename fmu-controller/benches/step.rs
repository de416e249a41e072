//! `make bench`: one communication step of a shipped controller at 1 ms as a master makes it
//! (its inputs set, its commands read, `do_step`), on the `Model` interface the FMU's C
//! functions call, with its `dist/<variant>/controller.json` (`make` writes them; a variant
//! not built is skipped with a line saying so). Each with its commands within their limits
//! since the start (`hinf_of`'s and `hinf_sf`'s anti-windup compensator at rest, its products
//! skipped; `ft_of` steps in full either way) and after one excursion past them (the
//! compensator moving, never at rest again).

use criterion::{criterion_group, criterion_main, Criterion};
use fmu_controller::{vr, Controller};
use fmu_core::Model;
use std::hint::black_box;
use std::path::PathBuf;

/// The measurement `i` at step `k`, of amplitude `scale`.
fn input(i: usize, k: usize, scale: f64) -> f64 {
    let t = k as f64 * 1e-3;
    scale * ((7.0 * t + i as f64).sin() + 0.3 * (31.0 * t * (i + 1) as f64).cos())
}

/// One step: the inputs set, the commands read, the step taken.
fn step(c: &mut Controller, inputs: usize, outputs: usize, k: usize, scale: f64) -> f64 {
    for i in 0..inputs {
        c.set_real(vr::INPUT + i as u32, input(i, k, scale));
    }
    let sum: f64 = (0..outputs)
        .map(|i| c.get_real(vr::OUTPUT + i as u32))
        .sum();
    c.do_step(k as f64 * 1e-3, 1e-3).expect("a step");
    sum
}

fn bench(crit: &mut Criterion) {
    let dist = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../dist");
    for variant in ["hinf_of", "hinf_sf", "ft_of"] {
        let resources = dist.join(variant);
        let Ok(text) = std::fs::read_to_string(resources.join("controller.json")) else {
            println!("{variant}: no {}; run `make` first", resources.display());
            continue;
        };
        let file: serde_json::Value = serde_json::from_str(&text).expect("controller.json");
        let (inputs, outputs) = (
            file["inputs"].as_array().expect("inputs").len(),
            file["outputs"].as_array().expect("outputs").len(),
        );
        for moving in [false, true] {
            let mut c = Controller::instantiate(Some(&resources)).expect("the controller");
            c.exit_initialization(0.0).expect("initialised");
            let mut k = 0;
            if moving {
                // Past the limits for 0.2 s: the compensator moves, and never rests again.
                for _ in 0..200 {
                    step(&mut c, inputs, outputs, k, 1e3);
                    k += 1;
                }
            }
            let label = if moving {
                "after saturating"
            } else {
                "within its limits"
            };
            crit.bench_function(&format!("{variant}: a 1 ms step, {label}"), |b| {
                b.iter(|| {
                    k += 1;
                    black_box(step(&mut c, inputs, outputs, k, 1e-3))
                })
            });
        }
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
