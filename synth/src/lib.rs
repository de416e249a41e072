//! H∞ synthesis for the active suspension (thesis ch. 5–8, corrected per SPEC §3): LMIs on
//! Clarabel, controller reconstruction, and certificates computed independently of the LMIs.
//!
//! Where to look, one folder per idea:
//! - [`numerics`]: LMIs on Clarabel, Riccati equations, eigenvalues, H∞ norms, interconnection;
//! - [`thesis`]: the thesis's H∞ LMI designs and their certificates (`make thesis`);
//! - [`comfort`]: the comfort designs `make` ships, with their certificates;
//! - [`predict`]: the comfort a controller gives on an ISO 8608 road, continuous and sampled;
//! - [`shipping`]: design files, the registry of variants, `controller.json`.

pub mod comfort;
pub mod numerics;
pub mod predict;
pub mod shipping;
pub mod thesis;

/// Why a synthesis run failed.
#[derive(Debug, thiserror::Error)]
pub enum SynthError {
    #[error("{0}")]
    Usage(String),
    #[error("{0}")]
    Io(String),
    /// Comfort designs refused by their certificates (the others were written).
    #[error("{0}")]
    Refused(String),
    #[error(transparent)]
    Design(#[from] shipping::design::DesignError),
    #[error("{0}: {1}")]
    Lmi(String, numerics::lmi::LmiError),
    #[error(transparent)]
    Certificate(#[from] thesis::certificate::CertificateError),
    #[error(transparent)]
    Comfort(#[from] comfort::designs::ComfortError),
    #[error("{variant}: the constraint LMIs cannot all hold for the design bump {bump:?}: the best common energy-to-peak bound any state feedback proves is {best:.4} of the limits (the bound grows with the bump height: feasible up to about {:.4} m at this bump's length and speed)", bump.height / best)]
    ConstraintsInfeasible {
        variant: String,
        best: f64,
        bump: shipping::design::Bump,
    },
}

extern "C" {
    /// OpenBLAS's own thread count (Debian's library, linked through `openblas-src`).
    fn openblas_set_num_threads(n: std::os::raw::c_int);
}

/// Run BLAS on the calling thread only (OpenBLAS's count is global: every thread's calls from
/// then on). The LMIs and the certificates' decompositions are small dense problems: OpenBLAS's
/// worker threads spin more than they compute (measured: 4 designs 28.5 s wall with its default
/// threads, 16.5 s with one), and the designs themselves run in parallel instead. One thread
/// also makes the results independent of the machine's core count.
pub fn single_threaded_blas() {
    // SAFETY: a plain setter of OpenBLAS's global thread count, callable at any time.
    unsafe { openblas_set_num_threads(1) }
}
