//! The thesis's designs ([`THESIS`], one typed entry each): synthesis, certificate and
//! `controller.json`.
//!
//! A `Synthesiser` keeps every design it has made, so a robust variant compares itself with
//! its nominal counterpart without synthesising it twice.

use crate::numerics::hinf_norm::{Analysis, Controller};
use crate::shipping::controller_file::{
    controller_json, matrix_rows, AntiWindup, ControllerFile, Guarantee,
};
use crate::shipping::design::{Design, RoadModel};
use crate::thesis::anti_windup::{circle_check, mraw};
use crate::thesis::certificate::{
    certify, certify_h2, certify_peaks, closed_loop, matrix_json, Certificate,
};
use crate::thesis::delay::{delay_margin, delay_sf, delayed_hinf_sweep};
use crate::thesis::fault::{
    certify_faults, observer_for_faults, with_detection, with_effectiveness, DetectionResidual,
    FaultBox,
};
use crate::thesis::generalized::FORCE_UNIT;
use crate::thesis::generalized::{GeneralizedPlant, Measurement, MEASUREMENTS};
use crate::thesis::output_feedback::{
    hinf_of, hinf_of_common_x, hinf_of_constrained, optimal_gamma, OfPlant, OfSettings,
    OutputFeedback,
};
use crate::thesis::robust::{mass_grid_certificate, MassGrid, MassUncertainty};
use crate::thesis::state_feedback::{
    best_constraint_peak, hinf_sf_mixed, hinf_sf_robust, StateFeedback,
};
use crate::SynthError;
use nalgebra::DMatrix;
use std::collections::BTreeMap;
use vehicle::model::STATES;
use vehicle::VehicleParams;

/// How a thesis design is made: on its own, or from the design it adds to (its controller plus
/// more, whose design-file overrides are that one's).
#[derive(Clone, Copy)]
pub enum Making {
    Alone(fn(&VehicleParams, &Design) -> Result<Synthesised, SynthError>),
    Adds {
        to: &'static str,
        with: fn(&Synthesised, &VehicleParams, &Design) -> Result<Synthesised, SynthError>,
    },
}

/// How a nominal design fares against a robust variant's uncertainty: the certificate's key and
/// value ([`nominal_comparison`]).
type Comparison = fn(&Controller, &VehicleParams, &Design) -> (&'static str, serde_json::Value);

/// One thesis design, everything the synthesis knows of it: a new design is one entry of
/// [`THESIS`] (and, if `make` ships it, one of the comfort registry).
pub struct ThesisVariant {
    pub name: &'static str,
    pub making: Making,
    /// The nominal design it is compared with over its uncertainty, and how.
    pub compared_with: Option<(&'static str, Comparison)>,
    /// It imposes the constraint LMIs when asked (`"constraints": true`).
    pub constrained: bool,
    /// It takes the shaped road's states ([`RoadModel::Shaped`]).
    pub road_states: bool,
    /// Its place when designs run in parallel, longest (measured) first.
    pub cost_rank: usize,
}

impl ThesisVariant {
    /// The design it is built on: its own, or the one it adds to.
    fn base(&self) -> &'static str {
        match self.making {
            Making::Alone(_) => self.name,
            Making::Adds { to, .. } => to,
        }
    }
}

/// The thesis's designs. `robust_of` stops on the shaped road with a coupling LMI violated by
/// 2e-6 and `ft_of` ran over 5 minutes there (not investigated): they refuse its states.
pub const THESIS: [ThesisVariant; 7] = [
    ThesisVariant {
        name: "hinf_sf",
        making: Making::Alone(hinf_sf_variant),
        compared_with: None,
        constrained: true,
        road_states: true,
        cost_rank: 6,
    },
    ThesisVariant {
        name: "hinf_of",
        making: Making::Alone(hinf_of_variant),
        compared_with: None,
        constrained: true,
        road_states: true,
        cost_rank: 2,
    },
    ThesisVariant {
        name: "hinf_of_aw",
        making: Making::Adds {
            to: "hinf_of",
            with: hinf_of_aw,
        },
        compared_with: None,
        constrained: true,
        road_states: true,
        cost_rank: 5,
    },
    ThesisVariant {
        name: "robust_sf",
        making: Making::Alone(robust_sf),
        compared_with: Some(("hinf_sf", over_masses)),
        constrained: true,
        road_states: true,
        cost_rank: 4,
    },
    ThesisVariant {
        name: "robust_of",
        making: Making::Alone(robust_of),
        compared_with: Some(("hinf_of", over_masses_measured)),
        constrained: false,
        road_states: false,
        cost_rank: 0,
    },
    ThesisVariant {
        name: "delay_sf",
        making: Making::Alone(delay_sf_variant),
        compared_with: Some(("hinf_sf", delay_margin_of)),
        constrained: false,
        road_states: true,
        cost_rank: 3,
    },
    ThesisVariant {
        name: "ft_of",
        making: Making::Alone(ft_of),
        compared_with: Some(("hinf_of", over_faults)),
        constrained: false,
        road_states: false,
        cost_rank: 1,
    },
];

/// The names of [`THESIS`].
pub fn names() -> Vec<&'static str> {
    THESIS.iter().map(|v| v.name).collect()
}

/// The thesis design `name`, or a usage error naming them all.
pub fn variant(name: &str) -> Result<&'static ThesisVariant, SynthError> {
    THESIS.iter().find(|v| v.name == name).ok_or_else(|| {
        SynthError::Usage(format!(
            "unknown variant '{name}', expected one of {:?}",
            names()
        ))
    })
}

/// Relative γ back-off before choosing the controller (output feedback, SPEC §5: before
/// reconstructing; `hinf_sf`: before minimising the H2 bound), and the bound on `X, Y`.
const GAMMA_BACKOFF: f64 = 0.02;
const OF_XY_BOUND: f64 = 1e3;
/// The output-feedback syntheses' settings at the LMI margin `eps`.
fn of_settings(eps: f64) -> OfSettings {
    OfSettings {
        eps,
        delta: GAMMA_BACKOFF,
        beta: OF_XY_BOUND,
    }
}

/// Robust output feedback: half-width, in decades, of the multiplier search.
const LAMBDA_DECADES: f64 = 1.0;

/// One synthesised, certified design.
pub struct Synthesised {
    pub controller: Controller,
    pub certificate: Certificate,
    pub controller_json: ControllerFile,
    /// What the design is robust to (for the summary table).
    pub robust_to: &'static str,
    /// Wall time of this design alone (its nominal counterpart excluded) \[s\].
    pub seconds: f64,
}

/// A state-feedback gain on `g`'s state as the controller on [`GeneralizedPlant::state_measurement`].
fn sf_controller(g: &GeneralizedPlant, k: &DMatrix<f64>) -> Controller {
    Controller::static_gain(g.gain_on_measurement(k))
}

/// The H∞ level a thesis design guarantees, as its FMU reports it.
fn gamma_guarantee(gamma: f64) -> Guarantee {
    Guarantee {
        name: "gamma".into(),
        value: gamma,
        unit: "1".into(),
        description:
            "H-infinity level the synthesis guarantees (scaled w to z, see the certificate)".into(),
    }
}

fn of_inputs() -> Vec<String> {
    MEASUREMENTS.iter().map(|s| s.to_string()).collect()
}

fn state_order_note() -> String {
    format!(
        "State order: {}",
        STATES.iter().map(|s| s.0).collect::<Vec<_>>().join(", ")
    )
}

/// The nominal design a robust variant is compared with.
pub fn nominal_of(name: &str) -> Option<&'static str> {
    variant(name).ok()?.compared_with.map(|(n, _)| n)
}

/// Synthesise and certify each of `variants`, in parallel (longest first), then record in each
/// robust design's certificate how its nominal counterpart, when also synthesised, fares against
/// the same uncertainty (`nominal_comparison`).
pub fn synthesise_all(
    variants: &[&str],
    params: &VehicleParams,
    design: &Design,
) -> Result<Vec<(String, Synthesised)>, SynthError> {
    use rayon::prelude::*;
    for name in design.overrides.keys() {
        let v = variant(name).map_err(|_| {
            SynthError::Usage(format!(
                "the design overrides unknown variant '{name}', expected one of {:?}",
                names()
            ))
        })?;
        if v.base() != v.name {
            return Err(SynthError::Usage(format!(
                "the design overrides '{name}', which is {0}'s controller plus more: override '{0}'",
                v.base()
            )));
        }
    }
    let chosen = variants
        .iter()
        .map(|n| variant(n))
        .collect::<Result<Vec<_>, _>>()?;
    // The designs made alone first, in parallel (with those the others add to); then the rest.
    let mut alone: Vec<&ThesisVariant> = Vec::new();
    for v in &chosen {
        let base = variant(v.base())?;
        if !alone.iter().any(|a| a.name == base.name) {
            alone.push(base);
        }
    }
    // Longest first (measured), one design per task so an idle thread takes the next one.
    alone.sort_by_key(|v| v.cost_rank);
    let done: Vec<(String, Synthesised)> = alone
        .par_iter()
        .with_max_len(1)
        .map(|v| synthesise(v.name, params, design).map(|s| (v.name.to_string(), s)))
        .collect::<Result<_, _>>()?;
    let mut by_name: BTreeMap<String, Synthesised> = done.into_iter().collect();
    for v in &chosen {
        if let Making::Adds { to, with } = v.making {
            let t = std::time::Instant::now();
            let mut s = with(&by_name[to], params, &design_for(v.name, design)?)?;
            s.seconds = t.elapsed().as_secs_f64();
            by_name.insert(v.name.into(), s);
        }
    }
    for v in &chosen {
        if let Some((n, compare)) = v.compared_with {
            if let Some(nominal) = by_name.get(n).map(|s| s.controller.clone()) {
                let (key, value) = compare(&nominal, params, &design_for(v.name, design)?);
                let details = &mut by_name
                    .get_mut(v.name)
                    .expect("synthesised above")
                    .certificate
                    .details;
                details["nominal_design"] = serde_json::json!(n);
                details[key] = value;
            }
        }
    }
    Ok(variants
        .iter()
        .map(|v| {
            (
                v.to_string(),
                by_name.remove(*v).expect("synthesised above"),
            )
        })
        .collect())
}

/// One design in the summary of a run (`dist/synthesis.json`, and the rows of
/// `summary_table`).
#[derive(Debug, Clone, serde::Serialize)]
pub struct SummaryRow {
    pub variant: String,
    pub robust_to: String,
    pub gamma: f64,
    /// The certified norm, worst over the design's uncertainty, with how it was obtained.
    pub certified: String,
    /// The nominal design the variant is compared with, if any, and its figure over the same
    /// uncertainty.
    pub nominal_design: Option<String>,
    pub nominal_figure: Option<String>,
    pub seconds: f64,
}

pub fn summary_rows(results: &[(String, Synthesised)]) -> Vec<SummaryRow> {
    results
        .iter()
        .map(|(name, s)| {
            let c = &s.certificate;
            let worst = c
                .details
                .get("worst_norm_over_masses")
                .and_then(|v| v.as_f64());
            let nominal = ["nominal_design_over_masses", "nominal_design_over_faults"]
                .iter()
                .find_map(|k| c.details.get(*k))
                .map(|g| match g.get("worst_norm").and_then(|v| v.as_f64()) {
                    Some(x) => format!("{x:.6}"),
                    None => "unstable".into(),
                });
            let delay = c.details.get("delay_margin_s").and_then(|v| v.as_f64());
            let nominal = match c
                .details
                .get("nominal_delay_margin_s")
                .and_then(|v| v.as_f64())
            {
                Some(m) => Some(format!("delay margin {:.1} ms", 1e3 * m)),
                None => nominal,
            };
            let faults = c
                .details
                .get("worst_norm_over_faults")
                .and_then(|v| v.as_f64());
            let certified = match (worst, delay, faults) {
                (_, Some(margin), _) => format!(
                    "{:.6} with τ = {:.0} ms (sweep); delay margin {:.1} ms",
                    c.details["delayed_hinf_norm_sweep"]
                        .as_f64()
                        .unwrap_or(f64::NAN),
                    1e3 * c.details["design_delay_s"].as_f64().unwrap_or(f64::NAN),
                    1e3 * margin
                ),
                (_, _, Some(w)) => format!(
                    "{w:.6} (32 effectiveness vertices; small-gain {:.4} < 1 on the box)",
                    c.details["fault_box"]["scaled_small_gain_norm"]
                        .as_f64()
                        .unwrap_or(f64::NAN)
                ),
                (Some(w), None, None) => {
                    let points = c.details["mass_grid"]["masses"]
                        .as_array()
                        .map_or(0, |m| m.len());
                    format!(
                        "{w:.6} ({points}-mass grid; {:.6} at the nominal car)",
                        c.norm_upper
                    )
                }
                (None, None, None) => format!("{:.6}", c.norm_upper),
            };
            let nominal_design = variant(name).ok().and_then(|v| match v.making {
                Making::Adds { to, .. } => Some(to),
                Making::Alone(_) => v.compared_with.map(|(n, _)| n),
            });
            SummaryRow {
                variant: name.clone(),
                robust_to: s.robust_to.into(),
                gamma: c.gamma,
                certified,
                nominal_design: nominal_design.map(String::from),
                nominal_figure: nominal,
                seconds: s.seconds,
            }
        })
        .collect()
}

/// `delay_sf`'s nominal design: its delay margin.
fn delay_margin_of(
    nominal: &Controller,
    params: &VehicleParams,
    design: &Design,
) -> (&'static str, serde_json::Value) {
    let g = GeneralizedPlant::new(params, design);
    (
        "nominal_delay_margin_s",
        serde_json::json!(delay_margin(&g.a, &(&g.b_u / FORCE_UNIT), &nominal.d).ok()),
    )
}

/// `ft_of`'s nominal design: its norm at each vertex of the fault box.
fn over_faults(
    nominal: &Controller,
    params: &VehicleParams,
    design: &Design,
) -> (&'static str, serde_json::Value) {
    let g = GeneralizedPlant::new(params, design).with_sensor_noise(design);
    let norms: Vec<Option<f64>> = FaultBox {
        rho_min: design.fault_rho_min,
    }
    .vertices()
    .iter()
    .map(|rho| {
        closed_loop(
            &with_effectiveness(&g, rho),
            &g.output_measurement(),
            nominal,
        )
        .hinf_norm(1e-8)
        .ok()
        .map(|n| n.upper)
    })
    .collect();
    let worst = norms
        .iter()
        .map(|n| n.unwrap_or(f64::INFINITY))
        .fold(0.0, f64::max);
    (
        "nominal_design_over_faults",
        serde_json::json!({"vertex_norms": norms, "worst_norm": if worst.is_finite() { Some(worst) } else { None }}),
    )
}

/// `robust_of`'s nominal design: its norm over the mass grid on the output-feedback
/// measurements.
fn over_masses_measured(
    nominal: &Controller,
    params: &VehicleParams,
    design: &Design,
) -> (&'static str, serde_json::Value) {
    let unc = MassUncertainty::new(params, design).with_sensor_noise();
    (
        "nominal_design_over_masses",
        serde_json::to_value(MassGrid::evaluate(
            &unc,
            &unc.center.output_measurement(),
            nominal,
        ))
        .expect("serialisable"),
    )
}

/// `robust_sf`'s nominal design: its norm over the mass grid on the full state.
fn over_masses(
    nominal: &Controller,
    params: &VehicleParams,
    design: &Design,
) -> (&'static str, serde_json::Value) {
    let unc = MassUncertainty::new(params, design);
    (
        "nominal_design_over_masses",
        serde_json::to_value(MassGrid::evaluate(
            &unc,
            &unc.center.state_measurement(),
            nominal,
        ))
        .expect("serialisable"),
    )
}

/// The design `variant` is synthesised with: the file's values with the variant's overrides
/// ([`Design::with_overrides`]); `hinf_of_aw`, `hinf_of`'s controller plus a compensator, with
/// `hinf_of`'s.
pub fn design_for(variant: &str, design: &Design) -> Result<Design, SynthError> {
    Ok(design.with_overrides(overridden_as(variant))?)
}

/// The key of `name`'s overrides in the design file: those of the design it is built on.
fn overridden_as(name: &str) -> &str {
    variant(name).map_or(name, |v| v.base())
}

/// Synthesise and certify one design (with its overrides, [`design_for`], which its certificate
/// notes).
pub fn synthesise(
    variant: &str,
    params: &VehicleParams,
    design: &Design,
) -> Result<Synthesised, SynthError> {
    let t = std::time::Instant::now();
    let mut s = synthesise_untimed(variant, params, &design_for(variant, design)?)?;
    if let Some(changes) = design.overrides.get(overridden_as(variant)) {
        s.certificate.notes.push(format!(
            "Design values overridden for {}: {}",
            overridden_as(variant),
            serde_json::Value::Object(changes.clone())
        ));
    }
    s.seconds = t.elapsed().as_secs_f64();
    Ok(s)
}

fn synthesise_untimed(
    name: &str,
    params: &VehicleParams,
    design: &Design,
) -> Result<Synthesised, SynthError> {
    let v = variant(name)?;
    if design.road_model != RoadModel::Independent && !v.road_states {
        let takes: Vec<&str> = THESIS
            .iter()
            .filter(|v| v.road_states)
            .map(|v| v.name)
            .collect();
        return Err(SynthError::Usage(format!("{name} is synthesised on the independent road model only (only {takes:?} take the shaped road's states): set \"road_model\" per variant with overrides")));
    }
    if design.constraints && !v.constrained {
        let impose: Vec<&str> = THESIS
            .iter()
            .filter(|v| v.constrained)
            .map(|v| v.name)
            .collect();
        return Err(SynthError::Usage(format!("{name} does not impose the constraint LMIs (only {impose:?} do): ask for them per variant, e.g. \"overrides\": {{\"hinf_sf\": {{\"constraints\": true, \"road_model\": {{\"shaped\": {{\"corner\": 5.0}}}}}}}} (synth/designs/constrained.json)")));
    }
    match v.making {
        Making::Alone(make) => make(params, design),
        Making::Adds { to, with } => with(&synthesise(to, params, design)?, params, design),
    }
}

/// Thesis Th. 5.1: the H∞ state feedback, at the mixed H2/H∞ point.
fn hinf_sf_variant(params: &VehicleParams, design: &Design) -> Result<Synthesised, SynthError> {
    let variant = "hinf_sf";
    let lmi = |e| SynthError::Lmi(variant.into(), e);

    let g = GeneralizedPlant::new(params, design);
    let energy = design.constraints.then(|| design.design_energy());
    let mixed = hinf_sf_mixed(&g, design.lmi_margin, energy, GAMMA_BACKOFF)
        .map_err(|e| constraint_diagnosis(variant, &[&g], design, lmi(e)))?;
    let sf = &mixed.sf;
    let notes = vec![
        "Thesis Th. 5.1 (eq. 5.4) corrected: the D_zu Y term (accelerations respond directly to the actuator forces) is included.".to_string(),
        format!("gamma* = {:.6}; shipped: the (Q, Y) meeting Th. 5.1 at gamma = (1 + {GAMMA_BACKOFF}) gamma* that minimises the H2 bound of the z rows without feed-through from w (all but the tyre loads), with the same Lyapunov matrix: bound {:.4} (it was {:.4} at the gamma-optimal point, which the LMI leaves non-unique).", mixed.gamma_opt, mixed.h2_bound, mixed.h2_bound_at_optimum),
        state_order_note(),
        format!("LMI solver status {} after {} iterations", sf.solver_status, sf.iterations),
    ];
    let controller = sf_controller(&g, &sf.k);
    let meas = g.state_measurement();
    let mut certificate = certify(variant, &g, &meas, &controller, sf.gamma, notes)?;
    let h2_rows = g.h2_rows();
    let h2_norm = certify_h2(variant, &g, &meas, &controller, &h2_rows, mixed.h2_bound)?;
    certificate.details = serde_json::json!({
        "gamma_opt": mixed.gamma_opt,
        "gamma_backoff": GAMMA_BACKOFF,
        "h2_rows": h2_rows,
        "h2_bound": mixed.h2_bound,
        "h2_norm": h2_norm,
        "h2_bound_at_gamma_opt": mixed.h2_bound_at_optimum,
    });
    certify_constraints(
        &mut certificate,
        variant,
        &g,
        params.m_s,
        &meas,
        &controller,
        design,
        &sf.peak_bounds,
    )?;
    let json = controller_json(variant, "H-infinity state feedback u = K x (thesis Th. 5.1, corrected; mixed H2/H-infinity point at 1.02 gamma*)", &gamma_guarantee(sf.gamma), &meas.names, &controller);
    Ok(Synthesised {
        controller,
        certificate,
        controller_json: json,
        robust_to: "-",
        seconds: 0.0,
    })
}

/// Thesis Th. 5.2: the H∞ dynamic output feedback (Gahinet–Apkarian).
fn hinf_of_variant(params: &VehicleParams, design: &Design) -> Result<Synthesised, SynthError> {
    let variant = "hinf_of";
    let lmi = |e| SynthError::Lmi(variant.into(), e);

    let g = GeneralizedPlant::new(params, design).with_sensor_noise(design);
    let (of, peak_bounds) = if design.constraints {
        let energy = design.design_energy();
        let (of, bounds) = hinf_of_constrained(
            &OfPlant::of(&g),
            &g.c_c,
            &g.d_cu,
            energy,
            of_settings(design.lmi_margin),
        )
        .map_err(|e| constraint_diagnosis(variant, &[&g], design, lmi(e)))?;
        (of, g.constraint_names.iter().cloned().zip(bounds).collect())
    } else {
        (
            hinf_of(&OfPlant::of(&g), of_settings(design.lmi_margin)).map_err(lmi)?,
            Vec::new(),
        )
    };
    let mut notes = vec![
        "Thesis Th. 5.2 (eq. 5.9, which lacks blocks) replaced by the Scherer-Gahinet-Chilali / Gahinet-Apkarian LMI; controller rebuilt as in Remark 5.1 with M = I - XY, N = I.".to_string(),
        format!("Measurements: {} (plant outputs of the same names).", MEASUREMENTS.join(", ")),
        format!("w is extended by one sensor-noise channel per measurement (strokes {} m, rates {}), which regularises the filtering problem.", design.noise_stroke, design.noise_rate),
        reconstruction_note(&of),
    ];
    if design.constraints {
        notes.push("With the constraint LMIs: a strictly proper controller (D_K = 0, else the sensor noise would reach the forces directly), all controller variables in the SDP (they cannot be eliminated), stage 2's variables rebuilt directly.".into());
    }
    let mut certificate = certify(
        variant,
        &g,
        &g.output_measurement(),
        &of.controller,
        of.gamma,
        notes,
    )?;
    certificate.details = of_details(&of);
    certify_constraints(
        &mut certificate,
        variant,
        &g,
        params.m_s,
        &g.output_measurement(),
        &of.controller,
        design,
        &peak_bounds,
    )?;
    let json = controller_json(
        variant,
        "H-infinity dynamic output feedback (thesis Th. 5.2, Gahinet-Apkarian)",
        &gamma_guarantee(of.gamma),
        &of_inputs(),
        &of.controller,
    );
    Ok(Synthesised {
        controller: of.controller,
        certificate,
        controller_json: json,
        robust_to: "-",
        seconds: 0.0,
    })
}

/// A constrained synthesis that failed: if no state feedback can prove the constraints for the
/// design bump ([`best_constraint_peak`] > 1), say so — no output feedback can then either (its
/// energy and peak LMIs contain the state-feedback ones with `Q = X`, `Y = Ĉ` as principal
/// blocks); otherwise `error`.
fn constraint_diagnosis(
    variant: &str,
    plants: &[&GeneralizedPlant],
    design: &Design,
    error: SynthError,
) -> SynthError {
    if !design.constraints {
        return error;
    }
    match best_constraint_peak(plants, design.design_energy(), design.lmi_margin) {
        Ok(best) if best > 1.0 => SynthError::ConstraintsInfeasible {
            variant: variant.into(),
            best,
            bump: design.design_bump,
        },
        _ => error,
    }
}

/// With `"constraints": true`: check the constraint LMIs' peak bounds against the closed loop's
/// Gramian ([`certify_peaks`]) and record both in the certificate (appended per call: the robust
/// design checks each vertex).
#[allow(clippy::too_many_arguments)]
fn certify_constraints(
    certificate: &mut Certificate,
    variant: &str,
    g: &GeneralizedPlant,
    mass: f64,
    meas: &Measurement,
    controller: &Controller,
    design: &Design,
    claimed: &[(String, f64)],
) -> Result<(), SynthError> {
    if !design.constraints {
        return Ok(());
    }
    let energy = design.design_energy();
    let checks = certify_peaks(variant, g, meas, controller, energy, claimed)?;
    if certificate.details["constraints"].is_null() {
        certificate.notes.push(format!(
            "Constraint LMIs (energy-to-peak, common Lyapunov matrix): for every road input of energy <= {energy:.4} (the design bump's: {} m high, {} m long, at {} m/s, left wheels), each actuator force stays below its limit, each stroke below {} m and each dynamic tyre load below the static load (the limit of its part without road feed-through is the static load less the tyre-damper force c_t * {:.3} m/s the bump can feed straight through). Each bound re-checked with the closed loop's controllability Gramian.",
            design.design_bump.height, design.design_bump.length, design.design_bump.speed, design.stroke_max, design.design_bump_peak_velocity()
        ));
        certificate.details["constraints"] = serde_json::json!({"design_energy": energy, "design_bump": design.design_bump, "road_model": design.road_model, "checks": []});
    }
    let entry = serde_json::json!({"sprung_mass": mass, "peaks": checks});
    certificate.details["constraints"]["checks"]
        .as_array_mut()
        .expect("an array")
        .push(entry);
    Ok(())
}

/// Thesis §5.1.4, Th. 5.3 (corrected): `hinf_of` plus a decoupled anti-windup compensator whose
/// `F` comes from the sector LMI of [`crate::thesis::anti_windup`]; the linear behaviour (and so γ) is
/// `hinf_of`'s whenever nothing saturates.
fn hinf_of_aw(
    of: &Synthesised,
    params: &VehicleParams,
    design: &Design,
) -> Result<Synthesised, SynthError> {
    let variant = "hinf_of_aw";
    let g = GeneralizedPlant::new(params, design);
    let aw = mraw(&g, design.lmi_margin).map_err(|e| SynthError::Lmi(variant.into(), e))?;
    let check = circle_check(&g.a, &g.b_u, &aw.f, &aw.w);
    if !check.holds() {
        return Err(SynthError::Certificate(
            crate::thesis::certificate::CertificateError::AntiWindup {
                variant: variant.into(),
                abscissa: check.spectral_abscissa,
                margin: check.min_margin,
            },
        ));
    }
    let mut certificate = of.certificate.clone();
    certificate.variant = variant.into();
    certificate.notes.insert(0, format!(
        "Thesis Th. 5.3 corrected (eq. 5.15 mixes P and Q and puts Q^-1 on the wrong side of phi): decoupled model-recovery anti-windup, eta' = (A + B_u F) eta - B_u dz(u_lin), u = sat(u_lin), u_lin = y_c + F eta, the controller reads y - C_y eta. F from the generalised-sector LMI; L2 gain from the controller output to the saturation-induced performance deviation gamma_aw = {:.6}. Re-checked: A + B_u F spectral abscissa {:.4}, circle criterion with the LMI's multiplier holds on {} frequencies (min margin {:.4e}). The linear closed loop, and so the gamma below, is hinf_of's.",
        aw.gamma, check.spectral_abscissa, check.frequencies, check.min_margin
    ));
    certificate.details["anti_windup"] = serde_json::json!({
        "F": matrix_json(&(&aw.f * FORCE_UNIT)),
        "gamma_aw": aw.gamma,
        "sector_multiplier_W": aw.w.as_slice(),
        "a_plus_bf_spectral_abscissa": check.spectral_abscissa,
        "circle_criterion_min_margin": check.min_margin,
        "circle_criterion_frequencies": check.frequencies,
    });
    let json = ControllerFile {
        variant: variant.into(),
        description:
            "H-infinity output feedback with decoupled anti-windup (thesis Th. 5.3, corrected)"
                .into(),
        anti_windup: Some(AntiWindup {
            a: matrix_rows(&g.a),
            b: matrix_rows(&(&g.b_u / FORCE_UNIT)),
            c: matrix_rows(&g.c_y),
            f: matrix_rows(&(&aw.f * FORCE_UNIT)),
            d: Vec::new(),
            u_max: vec![
                design.u_max,
                design.u_max,
                design.u_max,
                design.u_max,
                design.u_max_seat,
            ],
        }),
        ..of.controller_json.clone()
    };
    Ok(Synthesised {
        controller: of.controller.clone(),
        certificate,
        controller_json: json,
        robust_to: "actuator saturation",
        seconds: 0.0,
    })
}

/// Thesis Prop. 7.1 (its proof is unfinished; its 50 µs is trivially small): delay-dependent
/// state feedback for `design.delay_tau`, certified in the frequency domain.
fn delay_sf_variant(params: &VehicleParams, design: &Design) -> Result<Synthesised, SynthError> {
    let variant = "delay_sf";
    let g = GeneralizedPlant::new(params, design);
    let (tau, epsilon) = (design.delay_tau, design.delay_epsilon);
    let sf = delay_sf(&g, tau, epsilon, design.lmi_margin)
        .map_err(|e| SynthError::Lmi(variant.into(), e))?;
    let fail = |reason: String| {
        SynthError::Certificate(crate::thesis::certificate::CertificateError::Delay {
            variant: variant.into(),
            reason,
        })
    };
    let margin = delay_margin(&g.a, &(&g.b_u / FORCE_UNIT), &sf.k).map_err(fail)?;
    if margin < tau {
        return Err(fail(format!(
            "delay margin {margin} s is below the design delay {tau} s"
        )));
    }
    let delayed_norm = delayed_hinf_sweep(&g, &sf.k, tau);
    if delayed_norm > sf.gamma * (1.0 + crate::thesis::certificate::NORM_TOLERANCE) {
        return Err(fail(format!(
            "H-infinity norm {delayed_norm} with the delay exceeds gamma {}",
            sf.gamma
        )));
    }
    let controller = sf_controller(&g, &sf.k);
    let notes = vec![
        format!("Thesis Prop. 7.1 replaced by the descriptor Lyapunov-Krasovskii LMI with Jensen's inequality (Fridman & Shaked 2002), u(t) = K x(t) applied at t + tau, tau = {tau} s, descriptor multiplier epsilon = {epsilon}."),
        format!("Certified with the delay e^(-s tau): delay margin {margin:.6} s >= {tau} s (unit-modulus eigenvalues of K (jwI - A)^-1 B_u); H-infinity norm of the delayed loop by frequency sweep {delayed_norm:.6} <= gamma. The norm fields below are those of the loop without delay."),
        state_order_note(),
    ];
    let meas = g.state_measurement();
    let mut certificate = certify(variant, &g, &meas, &controller, sf.gamma, notes)?;
    certificate.details = serde_json::json!({
        "design_delay_s": tau,
        "descriptor_epsilon": epsilon,
        "delay_margin_s": margin,
        "delayed_hinf_norm_sweep": delayed_norm,
    });
    let json = controller_json(variant, "Delay-dependent H-infinity state feedback (thesis Prop. 7.1, Lyapunov-Krasovskii with Jensen)", &gamma_guarantee(sf.gamma), &meas.names, &controller);
    Ok(Synthesised {
        controller,
        certificate,
        controller_json: json,
        robust_to: "input delay",
        seconds: 0.0,
    })
}

/// Thesis Th. 8.1, corrected (see [`crate::thesis::fault`]): observer-based output feedback robust to
/// every actuator's effectiveness in `[fault_rho_min, 1]`, with a road-decoupled detection residual.
fn ft_of(params: &VehicleParams, design: &Design) -> Result<Synthesised, SynthError> {
    let variant = "ft_of";
    let lmi = |e| SynthError::Lmi(variant.into(), e);
    let g = GeneralizedPlant::new(params, design);
    let gn = g.with_sensor_noise(design);
    let faults = FaultBox {
        rho_min: design.fault_rho_min,
    };
    let (center, nb) = faults.norm_bounded(&g);
    let sf = hinf_sf_robust(&[&center], Some(&nb), design.lmi_margin, None).map_err(lmi)?;
    let ob = observer_for_faults(
        &gn,
        &faults,
        &(&sf.k / FORCE_UNIT),
        design.lmi_margin,
        design.fault_h2_weight,
    )
    .map_err(lmi)?;
    let det = DetectionResidual::new(&g, design.fault_time_constant);
    let control = ob.controller(&gn);
    let (k, c_r, d_r) = with_detection(&control, &det);
    let fc = certify_faults(variant, &gn, &faults, &ob, &det, &k, &c_r, &d_r)?;
    let notes = vec![
        format!("Thesis Th. 8.1 corrected: LMIs 8.6/8.8 have a 0 on the diagonal (the fault input without -gamma^2 I) and cannot be strictly feasible. Here the fault is the loss of effectiveness the plant FMU models, each actuator's applied force rho_i u_i with rho_i in [{}, 1]; the box is a diagonal norm-bounded uncertainty around its centre (one S-procedure multiplier per actuator), so gamma holds for every rho(t) in it, switching faults included.", design.fault_rho_min),
        format!("Scheme of thesis fig. 8.1 made consistent: observer x_hat' = A x_hat + B_u u + L r driven by the residual r = y - C_y x_hat, control u = F x_hat. F from the robust state-feedback LMI over the box (gamma_sf = {:.6}); L and gamma from the observer LMI with P = diag(P1, P2), Lambda = P2 L (gamma = {:.6}), minimising gamma + {} nu, nu an H2 bound on the estimation error F e (sqrt nu = {:.4}).", sf.gamma, ob.gamma, design.fault_h2_weight, ob.estimation_h2.unwrap_or(f64::NAN)),
        format!("Certified: closed-loop norm at all {} effectiveness vertices (worst {:.6}); scaled small-gain norm of the fault loop {:.6} < 1 (the LMI's claim on the whole box, re-checked without the LMI). The norms are those of the loop with the observer-based controller; the detector states do not reach u.", fc.vertex_norms.len(), fc.worst_vertex_norm, fc.scaled_small_gain_norm),
        format!("Detection: {} parity relations of the measurements that the road cannot excite (the body's momentum balance), filtered with T = {} s and reported as the smallest actuator force deficit consistent with them (N); road-to-residual gain {:.2e} N per unit road over {} frequencies; DC gain per unit deficit {:?}. fault_detected latches when the residual norm exceeds fault_threshold (default {} N).", det.order(), design.fault_time_constant, fc.road_to_residual, fc.frequencies, fc.residual_dc_per_actuator.iter().map(|v| (v * 1000.0).round() / 1000.0).collect::<Vec<_>>(), design.fault_threshold),
        format!("Measurements: {}.", MEASUREMENTS.join(", ")),
    ];
    let mut certificate = certify(
        variant,
        &gn,
        &gn.output_measurement(),
        &control,
        ob.gamma,
        notes,
    )?;
    certificate.details = serde_json::json!({
        "fault_rho_min": design.fault_rho_min,
        "state_feedback_gamma": sf.gamma,
        "fault_multiplier_S": ob.multiplier,
        "estimation_error_h2_bound": ob.estimation_h2,
        "h2_weight": design.fault_h2_weight,
        "observer_gain_L": matrix_json(&ob.l),
        "state_feedback_F_newton": matrix_json(&(&ob.f * FORCE_UNIT)),
        "fault_box": fc,
        "worst_norm_over_faults": fc.worst_vertex_norm,
        "detection": {"time_constant_s": det.time_constant, "threshold_n": design.fault_threshold, "pi": matrix_json(&det.pi), "kappa": matrix_json(&det.kappa), "G_per_newton": matrix_json(&det.g)},
    });
    let mut json = controller_json(variant, "Fault-tolerant H-infinity output feedback with observer and residual (thesis Th. 8.1, corrected)", &gamma_guarantee(ob.gamma), &of_inputs(), &control);
    json.fault_detection = Some(
        det.detector()
            .file_block(json.inputs.len(), design.fault_threshold),
    );
    Ok(Synthesised {
        controller: k,
        certificate,
        controller_json: json,
        robust_to: "actuator faults",
        seconds: 0.0,
    })
}

fn mass_range(design: &Design) -> String {
    format!("m_s in [{}, {}] kg", design.mass_min, design.mass_max)
}

/// Thesis Th. 6.1: both formulations, the less conservative shipped.
fn robust_sf(params: &VehicleParams, design: &Design) -> Result<Synthesised, SynthError> {
    let variant = "robust_sf";
    let lmi = |e| SynthError::Lmi(variant.into(), e);
    let unc = MassUncertainty::new(params, design);
    let energy = design.constraints.then(|| design.design_energy());
    let vertices = [&unc.vertices[0], &unc.vertices[1]];
    let vertex = hinf_sf_robust(&vertices, None, design.lmi_margin, energy)
        .map_err(|e| constraint_diagnosis(variant, &vertices, design, lmi(e)))?;
    let nb = hinf_sf_robust(
        &[&unc.center],
        Some(&unc.norm_bounded),
        design.lmi_margin,
        None,
    )
    .map_err(lmi)?;
    // The constraint LMIs are imposed in the vertex form only: with them, it is the one shipped.
    let (shipped, name): (&StateFeedback, &str) = if vertex.gamma <= nb.gamma || design.constraints
    {
        (&vertex, "vertex")
    } else {
        (&nb, "norm-bounded")
    };
    let controller = sf_controller(&unc.center, &shipped.k);
    let meas = unc.center.state_measurement();
    let grid = mass_grid_certificate(variant, &unc, &meas, &controller, shipped.gamma)?;
    let notes = vec![
        format!("Thesis Th. 6.1, robust to {}. Vertex form: the corrected Th. 5.1 LMI at both vertices with one (Q, Y): gamma = {:.6}. Norm-bounded (COG) form, thesis Lemma 1 with epsilon a decision variable (the thesis fixes it): gamma = {:.6}. Shipped: {name}.", mass_range(design), vertex.gamma, nb.gamma),
        "Not a BMI: for state feedback B_u(m) Y is affine in 1/m for the common Y = K Q, so each vertex LMI is linear and, affine in the plant data, holds between the vertices.".to_string(),
        state_order_note(),
    ];
    let mut certificate = robust_certificate(
        variant,
        params,
        &unc,
        &meas,
        &controller,
        shipped.gamma,
        notes,
        &grid,
        serde_json::json!({"vertex_gamma": vertex.gamma, "norm_bounded_gamma": nb.gamma, "shipped": name}),
    )?;
    // The constraints' claim is checked at both vertices (the LMI's bounds hold with one Lyapunov
    // matrix for the whole range; the Gramian check is per plant).
    if design.constraints {
        for (v, mass) in unc.vertices.iter().zip([unc.m_min, unc.m_max]) {
            certify_constraints(
                &mut certificate,
                variant,
                v,
                mass,
                &meas,
                &controller,
                design,
                &shipped.peak_bounds,
            )?;
        }
    }
    let json = controller_json(
        variant,
        "H-infinity state feedback robust to the sprung mass (thesis Th. 6.1)",
        &gamma_guarantee(shipped.gamma),
        &meas.names,
        &controller,
    );
    Ok(Synthesised {
        controller,
        certificate,
        controller_json: json,
        robust_to: "sprung mass",
        seconds: 0.0,
    })
}

/// Thesis Th. 6.2: norm-bounded with the multiplier searched; the vertex form by a fixed
/// robust state-feedback `X` (see [`hinf_of_common_x`]); the less conservative shipped.
fn robust_of(params: &VehicleParams, design: &Design) -> Result<Synthesised, SynthError> {
    let variant = "robust_of";
    let lmi = |e| SynthError::Lmi(variant.into(), e);
    let unc = MassUncertainty::new(params, design).with_sensor_noise();
    let eps = design.lmi_margin;
    // Norm-bounded: γ*(λ) by the projected LMIs, λ by golden section in log λ over two
    // decades around the optimal multiplier of the state-feedback problem (λ = 1/ε).
    let sf_nb = hinf_sf_robust(&[&unc.center], Some(&unc.norm_bounded), eps, None).map_err(lmi)?;
    let center = -sf_nb.multiplier.expect("norm-bounded design").log10();
    let gamma_at = |log_lambda: f64| {
        let g = norm_bounded_plant(&unc, 10f64.powf(log_lambda));
        optimal_gamma(&norm_bounded_of_plant(&g, &unc), eps).unwrap_or(f64::INFINITY)
    };
    let (lo, hi) = (center - LAMBDA_DECADES, center + LAMBDA_DECADES);
    let (log_lambda, nb_gamma_opt, evaluations) = golden_section(gamma_at, lo, hi, 0.3);
    let lambda = 10f64.powf(log_lambda);
    // Vertex form with X, Ĉ of the robust (vertex) state feedback.
    let sf_v =
        hinf_sf_robust(&[&unc.vertices[0], &unc.vertices[1]], None, eps, None).map_err(lmi)?;
    let vertex = hinf_of_common_x(
        &[OfPlant::of(&unc.vertices[0]), OfPlant::of(&unc.vertices[1])],
        &OfPlant::of(&unc.center),
        &sf_v.q,
        &sf_v.y,
        of_settings(eps),
    )
    .map_err(lmi)?;
    // The norm-bounded controller is reconstructed only if it is the one shipped.
    let (shipped, name) = if vertex.gamma_opt <= nb_gamma_opt {
        (vertex.clone(), "vertex")
    } else {
        let g = norm_bounded_plant(&unc, lambda);
        (
            hinf_of(&norm_bounded_of_plant(&g, &unc), of_settings(eps)).map_err(lmi)?,
            "norm-bounded",
        )
    };
    let shipped = &shipped;
    let c = &unc.center;
    let grid = mass_grid_certificate(
        variant,
        &unc,
        &c.output_measurement(),
        &shipped.controller,
        shipped.gamma,
    )?;
    let notes = vec![
        format!("Thesis Th. 6.2, robust to {}. Norm-bounded (COG) form: the uncertainty channel p = delta q, |delta| <= 1, as an extra normalised input/output of the Gahinet-Apkarian LMI (S-procedure multiplier lambda searched by golden section over log10 lambda in [{lo:.2}, {hi:.2}], {evaluations} evaluations): lambda = {lambda:.4e}, gamma* = {nb_gamma_opt:.6}. Vertex form (common X fixed to the robust state-feedback Q, see hinf_of_common_x): gamma* = {:.6}. Shipped: {name}, reconstructed at gamma = (1 + {GAMMA_BACKOFF}) gamma*.", mass_range(design), vertex.gamma_opt),
        "The vertex form is a BMI (A_hat contains Y A(m) X and Y B_u(m) C_K); fixing X and C_hat to a robust state-feedback solution makes it linear, and each vertex LMI is still an exact congruence of the closed-loop bounded-real LMI with one Lyapunov matrix, so the guarantee holds on the whole mass range.".to_string(),
        format!("Measurements: {}.", MEASUREMENTS.join(", ")),
        reconstruction_note(shipped),
    ];
    let mut details = of_details(shipped);
    details["norm_bounded_gamma_opt"] = serde_json::json!(nb_gamma_opt);
    details["norm_bounded_lambda"] = serde_json::json!(lambda);
    details["vertex_gamma_opt"] = serde_json::json!(vertex.gamma_opt);
    details["shipped"] = serde_json::json!(name);
    let certificate = robust_certificate(
        variant,
        params,
        &unc,
        &c.output_measurement(),
        &shipped.controller,
        shipped.gamma,
        notes,
        &grid,
        details,
    )?;
    let json = controller_json(
        variant,
        "H-infinity output feedback robust to the sprung mass (thesis Th. 6.2)",
        &gamma_guarantee(shipped.gamma),
        &of_inputs(),
        &shipped.controller,
    );
    Ok(Synthesised {
        controller: shipped.controller.clone(),
        certificate,
        controller_json: json,
        robust_to: "sprung mass",
        seconds: 0.0,
    })
}

/// The nominal certificate (at the design's own car) plus the mass grid.
#[allow(clippy::too_many_arguments)]
fn robust_certificate(
    variant: &str,
    params: &VehicleParams,
    unc: &MassUncertainty,
    meas: &Measurement,
    k: &Controller,
    gamma: f64,
    notes: Vec<String>,
    grid: &MassGrid,
    mut details: serde_json::Value,
) -> Result<Certificate, SynthError> {
    let mut certificate = certify(variant, &unc.at(params.m_s), meas, k, gamma, notes)?;
    details["mass_grid"] = serde_json::to_value(grid).expect("serialisable");
    // The mass-dependent matrices at both vertices: every mass of the range is their
    // combination affine in 1/m_s, so another tool can re-check the grid.
    details["vertices"] = serde_json::json!(unc.vertices.iter().zip([unc.m_min, unc.m_max]).map(|(v, m)| serde_json::json!({
        "mass": m, "A": matrix_json(&v.a), "B_u": matrix_json(&v.b_u), "C_z": matrix_json(&v.c_z), "D_zu": matrix_json(&v.d_zu),
    })).collect::<Vec<_>>());
    details["worst_norm_over_masses"] = serde_json::json!(grid.worst_norm);
    certificate.details = details;
    Ok(certificate)
}

/// The generalised plant of the norm-bounded form with multiplier `λ`: the centre plant with `w`
/// extended by `p̂ = √λ p` (column `H/√λ`) and `z` by `q̂ = √λ q` (rows `√λ E`); the last
/// `H.ncols()` channels are the normalised uncertainty channel ([`OfPlant::unit_channels`]).
fn norm_bounded_plant(unc: &MassUncertainty, lambda: f64) -> GeneralizedPlant {
    let c = &unc.center;
    let (h, e, n) = (&unc.norm_bounded.h, &unc.norm_bounded.e, c.n());
    let s = lambda.sqrt();
    c.with_uncertainty_channel(
        &(h.rows(0, n) / s),
        &(h.rows(n, c.c_z.nrows()) / s),
        &(e.columns(0, n) * s),
        &(e.columns(n, c.b_u.ncols()) * s),
    )
}

/// The output-feedback view of [`norm_bounded_plant`].
fn norm_bounded_of_plant<'a>(g: &'a GeneralizedPlant, unc: &MassUncertainty) -> OfPlant<'a> {
    OfPlant {
        unit_channels: unc.norm_bounded.h.ncols(),
        ..OfPlant::of(g)
    }
}

/// Minimise a unimodal `f` on `[a, b]` to width `tol`: `(argmin, min, evaluations)`.
fn golden_section(f: impl Fn(f64) -> f64, mut a: f64, mut b: f64, tol: f64) -> (f64, f64, usize) {
    let r = (5f64.sqrt() - 1.0) / 2.0;
    let (mut c, mut d) = (b - r * (b - a), a + r * (b - a));
    let (mut fc, mut fd) = (f(c), f(d));
    let mut evaluations = 2;
    while b - a > tol {
        if fc <= fd {
            b = d;
            (d, fd) = (c, fc);
            c = b - r * (b - a);
            fc = f(c);
        } else {
            a = c;
            (c, fc) = (d, fd);
            d = a + r * (b - a);
            fd = f(d);
        }
        evaluations += 1;
    }
    if fc <= fd {
        (c, fc, evaluations)
    } else {
        (d, fd, evaluations)
    }
}

fn reconstruction_note(of: &OutputFeedback) -> String {
    format!(
        "Stage 1 optimum gamma* = {:.6}; reconstruction at gamma = (1 + {GAMMA_BACKOFF}) gamma* with X, Y <= {OF_XY_BOUND} I and coupling margin t = {:.3e}; cond(I - XY) = {:.3e}.",
        of.gamma_opt, of.coupling_margin, of.coupling_condition
    )
}

fn of_details(of: &OutputFeedback) -> serde_json::Value {
    serde_json::json!({
        "gamma_opt": of.gamma_opt,
        "gamma_backoff": GAMMA_BACKOFF,
        "xy_bound": OF_XY_BOUND,
        "coupling_margin": of.coupling_margin,
        "coupling_condition": of.coupling_condition,
        "controller_spectral_abscissa": of.controller.spectral_abscissa(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn overrides_of_unknown_or_derived_variants_are_refused_before_any_synthesis() {
        for (name, expected) in [
            ("hinf_off", "unknown variant 'hinf_off'"),
            ("hinf_of_aw", "override 'hinf_of'"),
        ] {
            let mut design = Design::default();
            design.overrides.insert(
                name.into(),
                serde_json::Map::from_iter([(
                    "weight_alpha_roll".to_string(),
                    serde_json::json!(0.9),
                )]),
            );
            match synthesise_all(&names(), &VehicleParams::default(), &design) {
                Err(SynthError::Usage(m)) => assert!(m.contains(expected), "{m}"),
                other => panic!("expected a usage error, got {:?}", other.map(|_| ())),
            }
        }
    }

    #[test]
    fn golden_section_finds_the_minimum_of_a_parabola() {
        let (x, fx, _) = golden_section(|x| (x - 0.7).powi(2) + 2.0, -3.0, 3.0, 1e-6);
        assert!((x - 0.7).abs() < 1e-5 && (fx - 2.0).abs() < 1e-9);
    }
}
