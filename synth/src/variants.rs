//! The designs the project ships, by variant name: synthesis, certificate and `controller.json`.

use crate::certificate::{certify, Certificate, Controller};
use crate::controller_file::controller_json;
use crate::design::Design;
use crate::generalized::{GeneralizedPlant, MEASUREMENTS};
use crate::output_feedback::hinf_of;
use crate::state_feedback::hinf_sf;
use crate::SynthError;
use nalgebra::DMatrix;
use vehicle::model::{N_ROAD, N_STATES, STATES};
use vehicle::VehicleParams;

pub const ALL: [&str; 2] = ["hinf_sf", "hinf_of"];

/// Output feedback: relative γ back-off and bound on `X, Y` (SPEC §5).
const OF_GAMMA_BACKOFF: f64 = 0.02;
const OF_XY_BOUND: f64 = 1e3;

pub struct Synthesised {
    pub controller: Controller,
    pub certificate: Certificate,
    pub controller_json: serde_json::Value,
}

pub fn synthesise(variant: &str, params: &VehicleParams, design: &Design) -> Result<Synthesised, SynthError> {
    let g = GeneralizedPlant::new(params, design);
    match variant {
        "hinf_sf" => {
            let energy = design.constraints.then(|| design.design_energy());
            let sf = hinf_sf(&g, design.lmi_margin, energy).map_err(|e| SynthError::Lmi(variant.into(), e))?;
            let controller = Controller::static_gain(sf.k.clone());
            let inputs: Vec<String> = (1..=N_STATES).map(|k| format!("x[{k}]")).collect();
            let mut notes = vec![
                "Thesis Th. 5.1 (eq. 5.4) corrected: the D_zu Y term (accelerations respond directly to the actuator forces) is included.".to_string(),
                format!("State order: {}", STATES.iter().map(|s| s.0).collect::<Vec<_>>().join(", ")),
                format!("LMI solver status {} after {} iterations", sf.solver_status, sf.iterations),
            ];
            for (name, bound) in &sf.peak_bounds {
                notes.push(format!("guaranteed peak of {name} for the design bump energy: {bound:.4} of its limit"));
            }
            let certificate = certify(variant, &g, &DMatrix::identity(N_STATES, N_STATES), &DMatrix::zeros(N_STATES, N_ROAD), inputs.clone(), &controller, sf.gamma, notes)?;
            let json = controller_json(variant, "H-infinity state feedback u = K x (thesis Th. 5.1, corrected)", sf.gamma, &inputs, &controller);
            Ok(Synthesised { controller, certificate, controller_json: json })
        }
        "hinf_of" => {
            let g = g.with_sensor_noise(design);
            let of = hinf_of(&g.of_plant(), design.lmi_margin, OF_GAMMA_BACKOFF, OF_XY_BOUND).map_err(|e| SynthError::Lmi(variant.into(), e))?;
            let inputs: Vec<String> = MEASUREMENTS.iter().map(|s| s.to_string()).collect();
            let notes = vec![
                "Thesis Th. 5.2 (eq. 5.9, which lacks blocks) replaced by the Scherer-Gahinet-Chilali / Gahinet-Apkarian LMI; controller rebuilt as in Remark 5.1 with M = I - XY, N = I.".to_string(),
                format!("Measurements: {} (plant outputs of the same names).", MEASUREMENTS.join(", ")),
                format!("w is extended by one sensor-noise channel per measurement (strokes {} m, rates {}), which regularises the filtering problem.", design.noise_stroke, design.noise_rate),
                format!("Stage 1 optimum gamma* = {:.6}; reconstruction at gamma = (1 + {OF_GAMMA_BACKOFF}) gamma* with X, Y <= {OF_XY_BOUND} I and coupling margin t = {:.3e}; cond(I - XY) = {:.3e}.", of.gamma_opt, of.coupling_margin, of.coupling_condition),
            ];
            let mut certificate = certify(variant, &g, &g.c_y, &g.d_yw, inputs.clone(), &of.controller, of.gamma, notes)?;
            certificate.details = serde_json::json!({
                "gamma_opt": of.gamma_opt,
                "gamma_backoff": OF_GAMMA_BACKOFF,
                "xy_bound": OF_XY_BOUND,
                "coupling_margin": of.coupling_margin,
                "coupling_condition": of.coupling_condition,
                "controller_spectral_abscissa": of.controller.spectral_abscissa(),
            });
            let json = controller_json(variant, "H-infinity dynamic output feedback (thesis Th. 5.2, Gahinet-Apkarian)", of.gamma, &inputs, &of.controller);
            Ok(Synthesised { controller: of.controller, certificate, controller_json: json })
        }
        other => Err(SynthError::Usage(format!("unknown variant '{other}', expected one of {ALL:?}"))),
    }
}
