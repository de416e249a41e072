//! The designs the project ships, by variant name: synthesis, certificate and `controller.json`.

use crate::certificate::{certify, Certificate, Controller};
use crate::controller_file::controller_json;
use crate::design::Design;
use crate::generalized::GeneralizedPlant;
use crate::state_feedback::hinf_sf;
use crate::SynthError;
use nalgebra::DMatrix;
use vehicle::model::{N_ROAD, N_STATES, STATES};
use vehicle::VehicleParams;

pub const ALL: [&str; 1] = ["hinf_sf"];

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
        other => Err(SynthError::Usage(format!("unknown variant '{other}', expected one of {ALL:?}"))),
    }
}
