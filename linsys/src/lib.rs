//! Linear systems shared by the car's plant FMU, the generic controller FMU and the synthesis
//! (a crate of its own, so the controller runtime does not depend on the car, and the FMUs do
//! not link the synthesis's LAPACK):
//!
//! * [`Lti`]: `ẋ = A x + B u`, `y = C x + D u` — every controller, closed loop and generalised
//!   plant the synthesis builds, and the controller a controller FMU runs (its `controller.json`
//!   core); the synthesis's norms of it are `synth::numerics::hinf_norm::Analysis`;
//! * [`discretize`], [`expm`]: exact discretisation over a step with held or ramped inputs;
//! * [`mat_vec_sum`]: the FMUs' inner-loop matrix-vector sum;
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
