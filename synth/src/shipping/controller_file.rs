//! `controller.json`, the resource every controller FMU reads: the controller in the plant's
//! units, and the plant outputs it reads (its inputs) by name, with units.

use crate::numerics::hinf_norm::Controller;
pub use controller_file::{
    Accommodation, AntiWindup, CommunicationSteps, ControllerFile, DesignedFor, DetectorInput,
    Extensions, FaultDetection, Guarantee, Predictor, Rows, Signal, FORMAT,
};
use nalgebra::DMatrix;

/// A matrix as the file's rows.
pub fn matrix_rows(m: &DMatrix<f64>) -> Rows {
    m.row_iter().map(|r| r.iter().copied().collect()).collect()
}

/// A matrix of `r × c` from the file's rows, the inverse of [`matrix_rows`] (the shape rule
/// is the controller FMU's, [`controller_file::shape_mismatch`]). Another shape or a
/// non-finite number is refused by the matrix's `name`.
pub fn matrix(name: &str, rows: &Rows, r: usize, c: usize) -> Result<DMatrix<f64>, String> {
    if let Some(found) = controller_file::shape_mismatch(rows, r, c) {
        return Err(format!(
            "controller.json: {name} must be {r}×{c}, found {found}"
        ));
    }
    if rows.iter().flatten().any(|v| !v.is_finite()) {
        return Err(format!(
            "controller.json: {name} contains a non-finite number"
        ));
    }
    Ok(DMatrix::from_fn(r, c, |i, j| rows[i][j]))
}

/// Unit of a plant output by name (states `x[k]`, physical outputs, sensors, applied forces).
pub fn plant_output_unit(name: &str) -> &'static str {
    if let Some(k) = name
        .strip_prefix("x[")
        .and_then(|s| s.strip_suffix(']'))
        .and_then(|s| s.parse::<usize>().ok())
    {
        return vehicle::model::STATES[k - 1].1;
    }
    vehicle::model::readable_outputs(&vehicle::VehicleParams::default())
        .into_iter()
        .find(|r| r.name == vehicle::sensors::physical_name(name))
        .map(|r| r.unit)
        .unwrap_or_else(|| panic!("the plant has no output {name}"))
}

pub fn controller_json(
    variant: &str,
    description: &str,
    guarantee: &Guarantee,
    inputs: &[String],
    k: &Controller,
) -> ControllerFile {
    let signal = |name: &str, unit: &str| Signal {
        name: name.into(),
        unit: unit.into(),
    };
    ControllerFile {
        a: matrix_rows(&k.a),
        b: matrix_rows(&k.b),
        c: matrix_rows(&k.c),
        d: matrix_rows(&k.d),
        accommodation: None,
        anti_windup: None,
        communication_steps: None,
        description: description.into(),
        designed_for: None,
        fault_detection: None,
        format: FORMAT.into(),
        guarantee: guarantee.clone(),
        inputs: inputs
            .iter()
            .map(|n| signal(n, plant_output_unit(n)))
            .collect(),
        outputs: vehicle::model::FORCE_PORTS
            .iter()
            .map(|u| signal(u, "N"))
            .collect(),
        predictor: None,
        variant: variant.into(),
    }
}
