//! Certificates: every design is checked independently of its LMI solution before it may
//! become an FMU — closed-loop eigenvalues and the closed-loop H∞ norm by Hamiltonian bisection
//! ([`crate::numerics::hinf_norm`]), which must not exceed the claimed γ by more than 1e-6 relative.
//! The JSON written beside the FMU holds everything needed to re-check the claim elsewhere.

use crate::numerics::hinf_norm::{Analysis, Controller, Lti, NormError};
use crate::thesis::generalized::{GeneralizedPlant, Measurement, FORCE_UNIT};
use nalgebra::DMatrix;
use serde::Serialize;

/// Relative slack allowed between the certified norm and the claimed γ.
pub const NORM_TOLERANCE: f64 = 1e-6;

/// The closed loop of the generalised plant with `controller` on the measurement `y = C x + D w`
/// (the full state for state feedback), in the scaled `w → z` channels.
pub fn closed_loop(g: &GeneralizedPlant, meas: &Measurement, k: &Controller) -> Lti {
    let (c_meas, d_meas) = (&meas.c, &meas.d);
    let (n, nc) = (g.n(), k.order());
    // In ũ (kN) units.
    let cc = &k.c / FORCE_UNIT;
    let dc = &k.d / FORCE_UNIT;
    let mut a = DMatrix::zeros(n + nc, n + nc);
    a.view_mut((0, 0), (n, n))
        .copy_from(&(&g.a + &g.b_u * &dc * c_meas));
    a.view_mut((0, n), (n, nc)).copy_from(&(&g.b_u * &cc));
    a.view_mut((n, 0), (nc, n)).copy_from(&(&k.b * c_meas));
    a.view_mut((n, n), (nc, nc)).copy_from(&k.a);
    let mut b = DMatrix::zeros(n + nc, g.b_w.ncols());
    b.view_mut((0, 0), (n, g.b_w.ncols()))
        .copy_from(&(&g.b_w + &g.b_u * &dc * d_meas));
    b.view_mut((n, 0), (nc, g.b_w.ncols()))
        .copy_from(&(&k.b * d_meas));
    let mut c = DMatrix::zeros(g.c_z.nrows(), n + nc);
    c.view_mut((0, 0), (g.c_z.nrows(), n))
        .copy_from(&(&g.c_z + &g.d_zu * &dc * c_meas));
    c.view_mut((0, n), (g.c_z.nrows(), nc))
        .copy_from(&(&g.d_zu * &cc));
    let d = &g.d_zw + &g.d_zu * &dc * d_meas;
    Lti::new(a, b, c, d)
}

#[derive(Debug, Clone, Serialize)]
pub struct Certificate {
    pub variant: String,
    pub gamma: f64,
    pub norm_lower: f64,
    pub norm_upper: f64,
    /// `‖T_zw‖∞` of the same generalised plant without a controller: the passive car's score
    /// on the measure γ bounds (`None` where that open loop is unstable). Every design's norm
    /// peaks at the wheel hop, as this one does, so it is the floor γ cannot go far below.
    pub passive_norm: Option<f64>,
    pub peak_frequency_rad_s: f64,
    pub spectral_abscissa: f64,
    pub closed_loop_poles: Vec<[f64; 2]>,
    pub scaling: serde_json::Value,
    pub generalized_plant: serde_json::Value,
    pub controller: serde_json::Value,
    pub measurements: Vec<String>,
    pub notes: Vec<String>,
    /// Variant-specific figures (e.g. the output-feedback optimum γ*).
    #[serde(skip_serializing_if = "serde_json::Value::is_null")]
    pub details: serde_json::Value,
}

#[derive(Debug, thiserror::Error)]
pub enum CertificateError {
    #[error("{variant}: closed loop is not stable: {source}")]
    Unstable { variant: String, source: NormError },
    #[error("{variant}: the anti-windup loop fails its check: A + B_u F spectral abscissa {abscissa:e}, circle-criterion margin {margin:e}")]
    AntiWindup {
        variant: String,
        abscissa: f64,
        margin: f64,
    },
    #[error("{variant}: the fault-tolerance certificate fails: {reason}")]
    Fault { variant: String, reason: String },
    #[error("{variant}: the delay certificate fails: {reason}")]
    Delay { variant: String, reason: String },
    #[error("{variant}: at m_s = {mass} kg the closed-loop norm {norm:.9} (inf = unstable) exceeds the claimed γ = {gamma:.9}")]
    NotRobust {
        variant: String,
        mass: f64,
        norm: f64,
        gamma: f64,
    },
    #[error("{variant}: certified closed-loop norm {norm:.9} exceeds the claimed γ = {gamma:.9} by more than {NORM_TOLERANCE:e} relative")]
    NormAboveGamma {
        variant: String,
        norm: f64,
        gamma: f64,
    },
    #[error("{variant}: the energy-to-peak bound of {name} for the design energy, {peak} (computed from the Gramian), is not finite and below the LMI's {claimed} and the limit 1: {reason}")]
    PeakAboveBound {
        variant: String,
        name: String,
        peak: f64,
        claimed: f64,
        reason: String,
    },
    #[error("{variant}: the closed-loop H2 norm {norm} of the H2 rows is not finite and below the claimed bound {bound}: {reason}")]
    H2AboveBound {
        variant: String,
        norm: f64,
        bound: f64,
        reason: String,
    },
}

pub fn matrix_json(m: &DMatrix<f64>) -> serde_json::Value {
    serde_json::json!(crate::shipping::controller_file::matrix_rows(m))
}

/// The mixed H2/H∞ designs' second claim: the closed loop's H2 norm on the rows `rows` of `z`
/// ([`Lti::h2_norm`], from the Gramian) is at most the bound the LMI proves. Returns the norm.
pub fn certify_h2(
    variant: &str,
    g: &GeneralizedPlant,
    meas: &Measurement,
    k: &Controller,
    rows: &[usize],
    bound: f64,
) -> Result<f64, CertificateError> {
    let fail = |norm: f64, reason: String| CertificateError::H2AboveBound {
        variant: variant.into(),
        norm,
        bound,
        reason,
    };
    let norm = closed_loop(g, meas, k)
        .select_outputs(rows)
        .h2_norm()
        .map_err(|e| fail(f64::INFINITY, e.to_string()))?;
    if norm > bound * (1.0 + NORM_TOLERANCE) {
        return Err(fail(
            norm,
            format!("exceeds it by more than {NORM_TOLERANCE:e} relative"),
        ));
    }
    Ok(norm)
}

/// One constraint's peak bound for the design disturbance energy: the LMI's and the exact one.
#[derive(Debug, Clone, Serialize)]
pub struct PeakCheck {
    pub name: String,
    /// `max_t |cᵢ(t)|` over `‖w‖₂² ≤ E` (limit 1) that the LMI proves.
    pub lmi_bound: f64,
    /// The same from the closed loop's controllability Gramian ([`Lti::energy_to_peak`]).
    pub gramian: f64,
}

/// The constraint LMIs' claim: for every disturbance of energy `energy`, each constraint output
/// `cᵢ` of the closed loop stays within its limit 1. Checked with the exact energy-to-peak gain
/// of the closed loop, which must be at most the LMI's bound (1e-6 relative) and at most 1.
pub fn certify_peaks(
    variant: &str,
    g: &GeneralizedPlant,
    meas: &Measurement,
    k: &Controller,
    energy: f64,
    claimed: &[(String, f64)],
) -> Result<Vec<PeakCheck>, CertificateError> {
    let cl = closed_loop(&g.constraint_plant(), meas, k);
    let gains = cl.energy_to_peak();
    let mut checks = Vec::new();
    for (i, (name, bound)) in claimed.iter().enumerate() {
        let fail = |peak: f64, reason: String| CertificateError::PeakAboveBound {
            variant: variant.into(),
            name: name.clone(),
            peak,
            claimed: *bound,
            reason,
        };
        let peak = match &gains {
            Ok(gains) => gains[i] * energy.sqrt(),
            Err(e) => return Err(fail(f64::INFINITY, e.to_string())),
        };
        if peak > bound * (1.0 + NORM_TOLERANCE) || peak > 1.0 + NORM_TOLERANCE {
            return Err(fail(peak, "exceeds it".into()));
        }
        checks.push(PeakCheck {
            name: name.clone(),
            lmi_bound: *bound,
            gramian: peak,
        });
    }
    Ok(checks)
}

/// Certify `controller` against the claimed `gamma`; an error is never an FMU.
pub fn certify(
    variant: &str,
    g: &GeneralizedPlant,
    meas: &Measurement,
    k: &Controller,
    gamma: f64,
    notes: Vec<String>,
) -> Result<Certificate, CertificateError> {
    let cl = closed_loop(g, meas, k);
    let norm = cl
        .hinf_norm(1e-9)
        .map_err(|source| CertificateError::Unstable {
            variant: variant.into(),
            source,
        })?;
    if norm.upper > gamma * (1.0 + NORM_TOLERANCE) {
        return Err(CertificateError::NormAboveGamma {
            variant: variant.into(),
            norm: norm.upper,
            gamma,
        });
    }
    let poles = crate::numerics::eig::eigenvalues(&cl.a);
    let mut poles: Vec<[f64; 2]> = poles.iter().map(|l| [l.re, l.im]).collect();
    poles.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    Ok(Certificate {
        variant: variant.into(),
        gamma,
        norm_lower: norm.lower,
        norm_upper: norm.upper,
        passive_norm: Lti::new(g.a.clone(), g.b_w.clone(), g.c_z.clone(), g.d_zw.clone())
            .hinf_norm(1e-9)
            .ok()
            .map(|n| n.upper),
        peak_frequency_rad_s: norm.peak_frequency,
        spectral_abscissa: cl.spectral_abscissa(),
        closed_loop_poles: poles,
        scaling: serde_json::json!({
            "w": g.w_description(),
            "road_model": g.road_model,
            "road_scale": g.road_scale,
            "u": format!("actuator forces in units of {FORCE_UNIT} N inside the generalised plant; the controller below is in N"),
        }),
        generalized_plant: serde_json::json!({
            "A": matrix_json(&g.a), "B_w": matrix_json(&g.b_w), "B_u": matrix_json(&g.b_u),
            "C_z": matrix_json(&g.c_z), "D_zw": matrix_json(&g.d_zw), "D_zu": matrix_json(&g.d_zu),
            "C_y": matrix_json(&meas.c), "D_yw": matrix_json(&meas.d),
        }),
        controller: serde_json::json!({
            "A": matrix_json(&k.a), "B": matrix_json(&k.b), "C": matrix_json(&k.c), "D": matrix_json(&k.d),
        }),
        measurements: meas.names.clone(),
        notes,
        details: serde_json::Value::Null,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shipping::design::Design;
    use crate::thesis::state_feedback::hinf_sf;
    use nalgebra::DMatrix;

    fn sf() -> (GeneralizedPlant, Controller, f64) {
        let d = Design::default();
        let g = GeneralizedPlant::new(&vehicle::VehicleParams::default(), &d);
        let s = hinf_sf(&g, d.lmi_margin, None).unwrap();
        (g, Controller::static_gain(s.k), s.gamma)
    }

    fn certify_sf(
        g: &GeneralizedPlant,
        k: &Controller,
        gamma: f64,
    ) -> Result<Certificate, CertificateError> {
        certify("test", g, &g.state_measurement(), k, gamma, vec![])
    }

    #[test]
    fn a_true_claim_is_certified_and_an_overclaim_is_refused() {
        let (g, k, gamma) = sf();
        let c = certify_sf(&g, &k, gamma).expect("the LMI's own claim holds");
        assert!(c.norm_upper <= gamma * (1.0 + NORM_TOLERANCE) && c.spectral_abscissa < 0.0);
        // Claiming 1 % less than the true norm must fail.
        match certify_sf(&g, &k, c.norm_lower * 0.99) {
            Err(CertificateError::NormAboveGamma { norm, .. }) => {
                assert!((norm - c.norm_upper).abs() < 1e-9 * norm)
            }
            other => panic!("expected NormAboveGamma, got {other:?}"),
        }
    }

    #[test]
    fn an_h2_claim_is_checked_against_the_gramian() {
        let (g, k, _) = sf();
        let meas = g.state_measurement();
        let rows = g.h2_rows();
        let norm = certify_h2("test", &g, &meas, &k, &rows, 1e6).unwrap();
        assert!(norm > 0.0);
        assert!(matches!(
            certify_h2("test", &g, &meas, &k, &rows, norm * 0.99),
            Err(CertificateError::H2AboveBound { .. })
        ));
        // A tyre-load row feeds the road height through: no finite H2 norm, refused.
        let with_tyre: Vec<usize> = (0..g.c_z.nrows()).collect();
        assert!(matches!(
            certify_h2("test", &g, &meas, &k, &with_tyre, 1e6),
            Err(CertificateError::H2AboveBound { .. })
        ));
    }

    #[test]
    fn peak_claims_are_checked_against_the_gramian() {
        let d = Design {
            road_model: crate::shipping::design::RoadModel::Shaped { corner: 1.0 },
            constraints: true,
            ..Design::default()
        };
        let g = GeneralizedPlant::new(&vehicle::VehicleParams::default(), &d);
        let meas = g.state_measurement();
        // Passive: the forces are 0, the strokes and tyre loads reach ~1.5–2 limits for the
        // 5 cm bump's energy; at 1 % of that energy they are within the limits.
        let passive = Controller::static_gain(DMatrix::zeros(5, g.n()));
        let energy = d.design_energy() * 1e-2;
        let generous: Vec<(String, f64)> = g
            .constraint_names
            .iter()
            .map(|n| (n.clone(), 1.0))
            .collect();
        let checks = certify_peaks("test", &g, &meas, &passive, energy, &generous).unwrap();
        assert!(
            checks[..5].iter().all(|c| c.gramian == 0.0)
                && checks[5..]
                    .iter()
                    .all(|c| c.gramian > 0.05 && c.gramian < 1.0),
            "{checks:?}"
        );
        // A claimed bound 1 % below the true peak is refused, and so is a true peak above 1.
        let mut under = generous.clone();
        under[5].1 = checks[5].gramian * 0.99;
        assert!(matches!(
            certify_peaks("test", &g, &meas, &passive, energy, &under),
            Err(CertificateError::PeakAboveBound { .. })
        ));
        assert!(matches!(
            certify_peaks("test", &g, &meas, &passive, d.design_energy(), &generous),
            Err(CertificateError::PeakAboveBound { .. })
        ));
    }

    #[test]
    fn a_destabilising_controller_is_refused() {
        let (g, k, gamma) = sf();
        let bad = Controller::static_gain(-&k.d * 50.0);
        assert!(matches!(
            certify_sf(&g, &bad, gamma),
            Err(CertificateError::Unstable { .. })
        ));
    }
}
