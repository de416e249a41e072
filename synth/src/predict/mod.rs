//! What a controller does on an ISO 8608 road, computed from the car and the controller as the
//! FMUs run them, independently of any design model: the continuous-time loop
//! ([`continuous`]) and the sampled-data loop a master runs at a communication step
//! ([`sampled`]). The certificates' predictions of co-simulated comfort, and whether the loop
//! stays stable at its force limits ([`saturation`]).

pub mod continuous;
pub mod lag;
pub mod sampled;
pub mod saturation;
