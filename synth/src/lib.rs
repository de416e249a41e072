//! H∞ synthesis for the active suspension (thesis ch. 5–8, corrected per SPEC §3): LMIs on
//! Clarabel, controller reconstruction, and certificates computed independently of the LMIs.
//!
//! Where to look: the LMI layer is [`lmi`]; the generalised plant and its scaling
//! [`generalized`]; the state-feedback LMI [`state_feedback`]; the independent check
//! [`hinf_norm`] and [`certificate`]; the shipped variants [`variants`].

pub mod certificate;
pub mod controller_file;
pub mod design;
pub mod generalized;
pub mod hinf_norm;
pub mod lmi;
pub mod output_feedback;
pub mod state_feedback;
pub mod variants;

/// Why a synthesis run failed.
#[derive(Debug, thiserror::Error)]
pub enum SynthError {
    #[error("{0}")]
    Usage(String),
    #[error("{0}")]
    Io(String),
    #[error(transparent)]
    Design(#[from] design::DesignError),
    #[error("{0}: {1}")]
    Lmi(String, lmi::LmiError),
    #[error(transparent)]
    Certificate(#[from] certificate::CertificateError),
}
