//! The thesis's H∞ designs (ch. 5–8, corrected per SPEC §3; `make thesis`,
//! `synth/designs/thesis.json`): the scaled generalised plant ([`generalized`]), one LMI
//! synthesis per idea — state feedback ([`state_feedback`]), output feedback
//! ([`output_feedback`]), anti-windup ([`anti_windup`]), robustness to the sprung mass
//! ([`robust`]), to an input delay ([`delay`]), fault tolerance ([`fault`]) — their independent
//! certificates ([`certificate`]), and the variants built from them ([`synthesis`]).

pub mod anti_windup;
pub mod certificate;
pub mod delay;
pub mod fault;
pub mod generalized;
pub mod output_feedback;
pub mod robust;
pub mod state_feedback;
pub mod synthesis;
