//! The numerics every design and certificate stands on, with no dependency back into the
//! designs: an LMI layer on Clarabel ([`lmi`]), Lyapunov and Riccati equations ([`riccati`]),
//! eigenvalues from LAPACK ([`eig`]), the H∞ norm by Bruinsma–Steinbuch ([`hinf_norm`]) and
//! the closed loop of a plant and a controller ([`interconnect`]).

pub mod eig;
pub mod hinf_norm;
pub mod interconnect;
pub mod lmi;
pub mod riccati;
