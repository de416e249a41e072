//! H∞ synthesis for the active suspension (thesis ch. 5–8, corrected per SPEC §3): LMIs on
//! Clarabel, controller reconstruction, and certificates computed independently of the LMIs.

pub mod hinf_norm;
pub mod lmi;
