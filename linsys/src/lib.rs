//! Linear systems shared by the car's plant FMU, the generic controller FMU and the synthesis
//! (a crate of its own, so the controller runtime does not depend on the car, and the FMUs do
//! not link the synthesis's LAPACK):
//!
//! * [`Lti`]: `ẋ = A x + B u`, `y = C x + D u` — every controller, closed loop and generalised
//!   plant the synthesis builds, and the controller a controller FMU runs (its `controller.json`
//!   core); the synthesis's norms of it are `synth::numerics::hinf_norm::Analysis`;
//! * [`discretize`], [`expm`]: exact discretisation over a step with held or ramped inputs;
//! * [`mat_vec_sum`]: the FMUs' inner-loop matrix-vector sum;
//! * [`lcg`]: the road's and the tests' reproducible pseudo-random numbers;
//! * [`same_step`]: a step size as an importer's time arithmetic hands it over;
//! * [`predictor`]: a predictor's matrices over a delay, as the controller FMU runs it and the
//!   synthesis certifies it.
//!
//! The car's own first-order model (`vehicle::model::StateSpace`: `A`, and the input matrices of
//! forces and road apart) stays with the car.

mod exact;
mod lti;
pub mod predictor;

pub use exact::*;
pub use lti::Lti;

/// Whether a communication step `step` from `start` is the step `previous` to the rounding of
/// its time points. An importer that keeps time in integer nanoseconds (libcosim) hands each
/// step over as the difference of two doubles, so 1 ms arrives as 0.0010000000000001119 at
/// t = 2 s, and a little differently at every step: an FMU that keys its discretisation on the
/// step's bits recomputed its matrix exponentials at every step (`delay_sf` in libcosim took
/// 45 s for 4 s of road, the master 0.1 s). Stepped as `previous`, the state moves as if the
/// step's end were off by less than the rounding of its time points.
pub fn same_step(previous: f64, step: f64, start: f64) -> bool {
    (previous - step).abs() <= 8.0 * f64::EPSILON * (start.abs() + step.abs())
}

/// A 64-bit LCG (Knuth's MMIX constants) giving uniform numbers in [0, 1): the phases of the ISO
/// road (`vehicle::road`), deterministic for a seed on every platform (a PRNG crate's stream may
/// change between versions; this one cannot), and the tests' reproducible matrices.
pub fn lcg(seed: u64) -> impl FnMut() -> f64 {
    let mut state = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    }
}
