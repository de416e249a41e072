//! A predictor's matrices over a delay `θ` (the controller file's `predictor` block): one
//! construction for the controller FMU's runtime (`fmu-controller/src/predictor.rs`) and for
//! the synthesis's model of it as a master steps it (`synth::predict::sampled`), so the loop a
//! certificate checks is built from the matrices the FMU runs.
//!
//! The command is `u = K̃ z + K_φ φ`: `z = e^{Aθ} (S_y y + S_ξ ξ) + I` the design state predicted
//! `θ` ahead (`I` the commands in flight), `φ` the command's own filters (the rows of `ξ` that
//! `B_ξu` drives, kept in controller time), `K̃` the gain without their columns and `K_φ` theirs
//! on their rows of `ξ`. Over a step, with `w = [ξ; z]`,
//! `ẇ = Ā w + B̄ [y; u_r; u_a; u]`: `y` held, `u_r` the command whose force it carries, `u_a`
//! the command as the actuators apply it, `u` the command sent.

use crate::{expm, ExpError};
use nalgebra::DMatrix;

/// A predictor's blocks: the design model `A`, `B`, the gain `K`, the reconstruction of the
/// design state `x = S_y y + S_ξ ξ` with `ξ̇ = A_ξ ξ + B_ξ y + B_ξu u`, `D_yu` (how the applied
/// force reaches `y` at once), and the command's own filters `(row j of ξ, design state i, s)`
/// (`x_i = s ξ_j`).
#[derive(Debug, Clone, Copy)]
pub struct PredictorBlocks<'a> {
    pub a: &'a DMatrix<f64>,
    pub b: &'a DMatrix<f64>,
    pub k: &'a DMatrix<f64>,
    pub s_y: &'a DMatrix<f64>,
    pub s_xi: &'a DMatrix<f64>,
    pub a_xi: &'a DMatrix<f64>,
    pub b_xi: &'a DMatrix<f64>,
    pub b_xiu: &'a DMatrix<f64>,
    pub d_yu: &'a DMatrix<f64>,
    pub own: &'a [(usize, usize, f64)],
}

/// The predictor's matrices over a delay `θ`.
#[derive(Debug, Clone)]
pub struct PredictionMatrices {
    /// `K̃`: the gain without the columns of the command's own filters.
    pub k_tilde: DMatrix<f64>,
    /// `K̃ e^{Aθ} S_ξ` with `K_φ` on the filters' columns; `K̃ e^{Aθ} S_y`.
    pub k_xi: DMatrix<f64>,
    pub k_y: DMatrix<f64>,
    /// `e^{Aθ} S_ξ`, `e^{Aθ} S_y`: the prediction `z = e^{Aθ} x + I` of `ξ` and `y`.
    pub z_xi: DMatrix<f64>,
    pub z_y: DMatrix<f64>,
    /// `Ā`, and `B̄`'s columns `[y | u_r | u_a | u]` ([`PredictionMatrices::columns`]).
    pub a_bar: DMatrix<f64>,
    pub b_bar: DMatrix<f64>,
}

impl PredictionMatrices {
    pub fn new(p: &PredictorBlocks, theta: f64) -> Result<Self, ExpError> {
        let e = expm(&(p.a * theta))?;
        let (nxi, n, ny, nu) = (p.a_xi.nrows(), p.a.nrows(), p.b_xi.ncols(), p.k.nrows());
        let (k_tilde, k_own) = split_gain(p.k, nxi, p.own);
        let (z_xi, z_y) = (&e * p.s_xi, &e * p.s_y);
        let (k_xi, k_y) = (&k_tilde * &z_xi + &k_own, &k_tilde * &z_y);
        // The applied force reaches the car's rows through what they read, `B_ξ D_yu`
        // (`B_ξu` is zero off the filters).
        let mut b_applied = p.b_xi * p.d_yu;
        for &(j, _, _) in p.own {
            b_applied.row_mut(j).fill(0.0);
        }
        let (cy, cr, ca, cu) = Self::columns(ny, nu);
        let mut a_bar = DMatrix::zeros(nxi + n, nxi + n);
        a_bar
            .view_mut((0, 0), (nxi, nxi))
            .copy_from(&(p.a_xi + p.b_xiu * &k_own));
        a_bar
            .view_mut((0, nxi), (nxi, n))
            .copy_from(&(p.b_xiu * &k_tilde));
        a_bar.view_mut((nxi, nxi), (n, n)).copy_from(p.a);
        let mut b_bar = DMatrix::zeros(nxi + n, ny + 3 * nu);
        b_bar.view_mut((0, cy), (nxi, ny)).copy_from(p.b_xi);
        b_bar
            .view_mut((0, cr), (nxi, nu))
            .copy_from(&(-p.b_xi * p.d_yu));
        b_bar.view_mut((0, ca), (nxi, nu)).copy_from(&b_applied);
        b_bar.view_mut((nxi, cu), (n, nu)).copy_from(p.b);
        Ok(PredictionMatrices {
            k_tilde,
            k_xi,
            k_y,
            z_xi,
            z_y,
            a_bar,
            b_bar,
        })
    }

    /// The first columns of `B̄`'s inputs `y`, `u_r`, `u_a`, `u`, for `ny` inputs and `nu`
    /// commands.
    pub fn columns(ny: usize, nu: usize) -> (usize, usize, usize, usize) {
        (0, ny, ny + nu, ny + 2 * nu)
    }
}

/// The gain `k` split at the command's own filters `own`: `K̃`, without their columns of the
/// design state, and `K_φ`, theirs on their rows of `ξ` (`nxi` rows): `u = K̃ z + K_φ φ`.
pub fn split_gain(
    k: &DMatrix<f64>,
    nxi: usize,
    own: &[(usize, usize, f64)],
) -> (DMatrix<f64>, DMatrix<f64>) {
    let (mut k_tilde, mut k_own) = (k.clone(), DMatrix::zeros(k.nrows(), nxi));
    for &(j, i, s) in own {
        k_own.column_mut(j).copy_from(&(k.column(i) * s));
        k_tilde.column_mut(i).fill(0.0);
    }
    (k_tilde, k_own)
}

/// The delay a predictor told `tau` predicts over when stepped at `h`: never less than one
/// step. A master reads the plant's outputs before it sets the new command, so at any actuator
/// delay `θ ≤ h` they carry the previous command's force; predicting over `h` counts exactly
/// that command (the car at the step's end under it), where predicting over `θ < h` leaves in
/// the inputs a force the prediction does not count, which the filters must correct. The
/// rule's only error is the new command acting over `[t_k + θ, t_k + h)`, and at `θ = h` it is
/// the matched predictor. Measured on `delay_sf` (held `W_k` seat on the design road, the
/// predictor over `θ` → over `max(θ, h)`): at 1 ms and no delay 0.0102 → 0.0089 (`hinf_sf`
/// 0.0103), at 2.5 ms 0.0145 → 0.0102, at 5 ms 0.0272 → 0.0142, better at every `θ` in
/// `[0, h)`.
pub fn predicted_delay(tau: f64, h: f64) -> f64 {
    tau.max(h)
}
