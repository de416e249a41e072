//! The comfort designs `make` ships (`synth/designs/comfort.json`): the car on an ISO 8608 road
//! weighted as ISO 2631-1 says people feel it ([`plant`]), guaranteed-cost gains over an
//! uncertainty ([`guaranteed`]), the controllers a car can run ([`controllers`]), the delay
//! predictor of `delay_sf` ([`predictor`]), each design with its certificate ([`designs`]), the
//! classical baseline they are measured against ([`skyhook`]), and a state feedback's recovery
//! from the seat's end stops ([`stop_recovery`]).

pub mod car;
pub mod controllers;
pub mod designs;
pub mod guaranteed;
pub mod plant;
pub mod predictor;
pub mod skyhook;
pub mod stop_recovery;
