//! `controller.json`, the resource every controller FMU reads: the controller in the plant's
//! units, and the plant outputs it reads (its inputs) by name, with units.

use crate::certificate::{matrix_json, Controller};
use serde::Serialize;
use serde_json::json;

/// What a controller's synthesis guarantees; its FMU reports it as a calculated parameter of
/// this name (`gamma` for the thesis's H∞ designs, `guaranteed_wk_rms_seat` for the comfort
/// designs).
#[derive(Debug, Clone, Serialize)]
pub struct Guarantee {
    pub name: &'static str,
    pub value: f64,
    pub unit: &'static str,
    pub description: String,
}

/// Unit of a plant output by name (states `x[k]`, physical outputs, applied forces).
pub fn plant_output_unit(name: &str) -> &'static str {
    if let Some(k) = name
        .strip_prefix("x[")
        .and_then(|s| s.strip_suffix(']'))
        .and_then(|s| s.parse::<usize>().ok())
    {
        return vehicle::model::STATES[k - 1].1;
    }
    vehicle::model::physical_outputs(&vehicle::VehicleParams::default())
        .into_iter()
        .chain(vehicle::model::applied_force_rows())
        .find(|r| r.name == name)
        .map(|r| r.unit)
        .unwrap_or_else(|| panic!("the plant has no output {name}"))
}

pub fn controller_json(
    variant: &str,
    description: &str,
    guarantee: &Guarantee,
    inputs: &[String],
    k: &Controller,
) -> serde_json::Value {
    json!({
        "format": "suspension-controller/2",
        "variant": variant,
        "description": description,
        "guarantee": guarantee,
        "inputs": inputs.iter().map(|n| json!({"name": n, "unit": plant_output_unit(n)})).collect::<Vec<_>>(),
        "outputs": vehicle::model::FORCE_PORTS.iter().map(|u| json!({"name": u, "unit": "N"})).collect::<Vec<_>>(),
        "A": matrix_json(&k.a),
        "B": matrix_json(&k.b),
        "C": matrix_json(&k.c),
        "D": matrix_json(&k.d),
    })
}
