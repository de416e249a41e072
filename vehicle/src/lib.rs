//! The 8-DOF full car with driver seat of the thesis (ch. 3–4), corrected per SPEC.md §1.
//!
//! * [`params`]: parameters, their units, admissible ranges and the documented defaults;
//! * [`model`]: the element-Jacobian derivation of `M, C, K`, the 16-state model and the
//!   physical outputs;
//! * [`polytope`]: the vertex and COG forms over the sprung mass;
//! * [`road`]: road profiles under the four wheels (the road FMU, the tests, the master);
//! * [`contact`]: where the car stops being linear: tyres leaving the road, bump, rebound and
//!   seat end stops, as unilateral elements switched by mode;
//! * [`iso2631`]: the ISO 2631-1 comfort weightings `W_k`, `W_e` (the master's metrics and the
//!   synthesis's comfort objective).
//!
//! Nothing here knows about FMI.

pub mod contact;
pub mod iso2631;
pub mod model;
pub mod params;
pub mod polytope;
pub mod road;
pub mod sensors;
pub mod terrain;

pub use model::{MechanicalModel, StateSpace};
pub use params::VehicleParams;
