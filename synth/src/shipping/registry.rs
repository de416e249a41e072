//! The shipped controllers, one typed definition each: its name (the FMU's), the design it is
//! compared with in its own uncertainty, what it is robust to, and how it is synthesised for
//! each kind of design file. The CLI (`synth --list`, the Makefile's list), the summary table
//! and the comparisons all derive from [`VARIANTS`].
//!
//! Two kinds of design file ([`DesignFile`]): the comfort designs ([`crate::comfort::designs`],
//! `synth/designs/comfort.json`, what `make` ships) and the thesis's H∞ designs
//! ([`crate::thesis::synthesis`], `synth/designs/thesis.json`, `constrained.json`).
//!
//! To add a variant: one entry in [`VARIANTS`] with its comfort synthesis (a function of the
//! [`Context`] and the [`Shared`] designs it builds on) and, if it has a thesis design, one in
//! [`crate::thesis::synthesis::THESIS`] (a variant may exist in one family only); the Makefile,
//! the tables and the comparisons follow.

use crate::comfort::designs::{
    anti_windup_design, held_at, model_recovery_design, nominal_gain, robust_gain,
    robust_state_feedback_design, state_feedback_design, Comfort, ComfortDesignResult,
    ComfortError, Context, Held, InOrder, Role, Uncertainty,
};
use crate::comfort::guaranteed::StateFeedback;
use crate::comfort::skyhook::skyhook_design;
use crate::predict::continuous::{predict, Conditions, ControlLaw, Figures};
use crate::shipping::controller_file::{controller_json, ControllerFile, Guarantee};
use crate::shipping::design::{ComfortDesign, Design, DesignError};
use crate::{comfort::plant::ComfortPlant, SynthError};
use serde::Serialize;
use std::collections::BTreeMap;
use std::sync::OnceLock;
use vehicle::VehicleParams;

/// Designs several variants build on, made once per run.
#[derive(Default)]
pub struct Shared {
    nominal: OnceLock<Result<(ComfortPlant, StateFeedback), String>>,
    robust: OnceLock<Result<(ComfortPlant, StateFeedback), String>>,
    hinf_of: OnceLock<Result<ComfortDesignResult, String>>,
}

impl Shared {
    fn nominal(&self, ctx: &Context) -> Result<&(ComfortPlant, StateFeedback), ComfortError> {
        shared(&self.nominal, || nominal_gain(ctx), "hinf_sf")
    }
    fn robust(&self, ctx: &Context) -> Result<&(ComfortPlant, StateFeedback), ComfortError> {
        shared(&self.robust, || robust_gain(ctx), "robust_sf")
    }
    fn hinf_of(&self, ctx: &Context) -> Result<&ComfortDesignResult, ComfortError> {
        shared(
            &self.hinf_of,
            || crate::comfort::car::car_design(ctx),
            "hinf_of",
        )
    }
}

fn shared<'a, T>(
    cell: &'a OnceLock<Result<T, String>>,
    make: impl FnOnce() -> Result<T, ComfortError>,
    variant: &str,
) -> Result<&'a T, ComfortError> {
    cell.get_or_init(|| make().map_err(|e| e.to_string()))
        .as_ref()
        .map_err(|reason| ComfortError::Synthesis {
            variant: variant.into(),
            reason: reason.clone(),
        })
}

type ComfortSynthesis = fn(&Context, &Shared) -> Result<ComfortDesignResult, ComfortError>;

/// The design model a variant is synthesised on: the state feedbacks'
/// ([`ComfortDesign::for_state_feedback`]: every state measured, the car's long waves and seat
/// stroke limit), or the car's ([`ComfortDesign::for_car`]: its sensors too).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DesignModel {
    StateFeedback = 0,
    Car = 1,
}

/// One shipped controller.
pub struct Variant {
    /// The FMU's model identifier.
    pub name: &'static str,
    /// The design it is compared with in its own uncertainty.
    pub nominal: Option<&'static str>,
    pub robust_to: Uncertainty,
    /// The design model it is synthesised on.
    pub model: DesignModel,
    /// What it is, in a line, with the thesis result it implements.
    pub summary: &'static str,
    pub comfort: ComfortSynthesis,
    /// A design of ours or a classical baseline (`Variant::accept`).
    pub role: Role,
}

impl Variant {
    /// `r` as this variant's, if it is what its role may ship: a predicted W_k seat below
    /// [`Role::comfort_bound`] times the passive car's.
    fn accept(&self, mut r: ComfortDesignResult) -> Result<ComfortDesignResult, ComfortError> {
        r.certificate.role = self.role;
        let c = &r.certificate.comfort;
        let (seat, passive) = (c.predicted_wk_rms_seat_m_s2, c.passive_wk_rms_seat_m_s2);
        if seat < self.role.comfort_bound() * passive {
            return Ok(r);
        }
        Err(ComfortError::Certificate {
            variant: self.name.into(),
            reason: format!(
                "predicted W_k seat {seat:.4} m/s² is not even {} times the passive car's \
                 {passive:.4}",
                self.role.comfort_bound()
            ),
        })
    }
}

/// Every shipped controller, in the order of the tables.
pub const VARIANTS: [Variant; 9] = [
    Variant {
        name: "hinf_sf",
        nominal: None,
        robust_to: Uncertainty::None,
        model: DesignModel::StateFeedback,
        summary: "state feedback (thesis Th. 5.1), recovering from the seat's end stops, with hinf_of_aw's anti-windup (Th. 5.3)",
        comfort: |ctx, s| {
            let notes = vec![state_feedback_note(ctx.design, "the unmodelled delay")];
            let sf = state_feedback_design(ctx, "hinf_sf", Uncertainty::None, s.nominal(ctx)?, notes)?;
            anti_windup_design(ctx, &sf, "hinf_sf", Uncertainty::None)
        },
        role: Role::Design,
    },
    Variant {
        name: "hinf_of",
        nominal: None,
        robust_to: Uncertainty::None,
        model: DesignModel::Car,
        summary: "output feedback on the sensors a car has and load cells, designed for long waves (the guaranteed-cost gain on a Kalman filter), with the plain model-recovery anti-windup (Th. 5.3's compensator, F = 0)",
        comfort: |ctx, s| model_recovery_design(ctx, s.hinf_of(ctx)?, "hinf_of"),
        role: Role::Design,
    },
    Variant {
        name: "hinf_of_aw",
        nominal: Some("hinf_of"),
        robust_to: Uncertainty::Saturation,
        model: DesignModel::Car,
        summary: "hinf_of with anti-windup for actuator saturation (thesis Th. 5.3)",
        comfort: |ctx, s| {
            anti_windup_design(ctx, s.hinf_of(ctx)?, "hinf_of_aw", Uncertainty::Saturation)
        },
        role: Role::Design,
    },
    Variant {
        name: "robust_sf",
        nominal: Some("hinf_sf"),
        robust_to: Uncertainty::SprungMass,
        model: DesignModel::StateFeedback,
        summary: "state feedback robust to the sprung mass (thesis Th. 6.1), recovering from the seat's end stops, with hinf_of_aw's anti-windup (Th. 5.3)",
        comfort: |ctx, s| {
            let robust = state_feedback_note(
                ctx.design,
                &format!(
                    "every sprung mass in [{}, {}] kg (rank-one channel at the harmonic-mean mass) and the unmodelled delay",
                    ctx.design.mass_min, ctx.design.mass_max
                ),
            );
            let nominal = state_feedback_note(ctx.design, "the unmodelled delay");
            robust_state_feedback_design(ctx, (s.robust(ctx)?, robust), (s.nominal(ctx)?, nominal))
        },
        role: Role::Design,
    },
    Variant {
        name: "robust_of",
        nominal: Some("hinf_of"),
        robust_to: Uncertainty::SprungMass,
        model: DesignModel::Car,
        summary: "output feedback on hinf_of's sensors robust to the sprung mass (thesis Th. 6.2), with hinf_of_aw's anti-windup (Th. 5.3)",
        comfort: |ctx, s| {
            let of = crate::comfort::car::robust_design(ctx, s.robust(ctx)?, s.hinf_of(ctx)?)?;
            anti_windup_design(ctx, &of, "robust_of", Uncertainty::SprungMass)
        },
        role: Role::Design,
    },
    Variant {
        name: "delay_sf",
        nominal: Some("hinf_sf"),
        robust_to: Uncertainty::InputDelay,
        model: DesignModel::StateFeedback,
        summary: "state feedback for a known actuator delay (thesis Prop. 7.1), recovering from the seat's end stops",
        comfort: |ctx, s| crate::comfort::predictor::predictor_design(ctx, s.nominal(ctx)?),
        role: Role::Design,
    },
    Variant {
        name: "ft_of",
        nominal: Some("hinf_of"),
        robust_to: Uncertainty::ActuatorFaults,
        model: DesignModel::Car,
        summary: "fault-tolerant output feedback on hinf_of's sensors with fault accommodation, a load-cell fault detector (thesis Th. 8.1) and hinf_of_aw's anti-windup (Th. 5.3)",
        comfort: |ctx, s| {
            let ft = crate::comfort::car::fault_tolerant_design(ctx, s.hinf_of(ctx)?)?;
            anti_windup_design(ctx, &ft, "ft_of", Uncertainty::ActuatorFaults)
        },
        role: Role::Design,
    },
    Variant {
        name: "skyhook",
        nominal: None,
        robust_to: Uncertainty::None,
        model: DesignModel::Car,
        summary: "baseline: skyhook dampers on the body and the seat from accelerometers (not H∞)",
        comfort: |ctx, s| skyhook_design(ctx, s.hinf_of(ctx)?),
        role: Role::Baseline,
    },
    Variant {
        name: "lqg",
        nominal: None,
        robust_to: Uncertainty::None,
        model: DesignModel::Car,
        summary:
            "baseline: LQG (LQR on the comfort cost, Kalman filter) on hinf_of's sensors (not H∞)",
        comfort: |ctx, _| crate::comfort::car::lqg_design(ctx),
        role: Role::Baseline,
    },
];

fn state_feedback_note(d: &ComfortDesign, guarantee: &str) -> String {
    format!(
        "Guaranteed-cost state feedback: the gain minimising the bound of the ISO 2631-1 comfort \
         norm (plus the limits' weights where needed) valid for {guarantee} (actuator delay up to \
         {} s as an input-multiplicative uncertainty), from the game Riccati equation with the \
         multipliers searched. It reads the car's states, the road heights as z_u - tire_defl, \
         and the accelerations a_seat, alpha_roll, alpha_pitch; its own states are the rear \
         road's Pade preview, copies of the ISO weightings and the delay weight.",
        d.unmodelled_delay
    )
}

/// The names of [`VARIANTS`].
pub fn names() -> Vec<&'static str> {
    VARIANTS.iter().map(|v| v.name).collect()
}

/// The names of the variants with a thesis design ([`crate::thesis::synthesis::THESIS`]).
pub fn thesis_names() -> Vec<&'static str> {
    crate::thesis::synthesis::names()
}

pub fn variant(name: &str) -> Option<&'static Variant> {
    VARIANTS.iter().find(|v| v.name == name)
}

/// A design file: the comfort designs (`"objective": "comfort"`) or the thesis's H∞ designs
/// (no `objective`, or `"objective": "hinf"`).
#[derive(Debug, Clone)]
pub enum DesignFile {
    Comfort(ComfortDesign),
    Thesis(Design),
}

impl DesignFile {
    /// The sprung-mass range `[mass_min, mass_max]` the robust designs cover \[kg\].
    pub fn mass_range(&self) -> (f64, f64) {
        match self {
            DesignFile::Comfort(d) => (d.mass_min, d.mass_max),
            DesignFile::Thesis(d) => (d.mass_min, d.mass_max),
        }
    }

    pub fn from_json(text: &str) -> Result<Self, DesignError> {
        let mut value: serde_json::Value =
            serde_json::from_str(text).map_err(|e| DesignError::Syntax(e.to_string()))?;
        let objective = value
            .as_object_mut()
            .and_then(|o| o.remove("objective"))
            .unwrap_or_else(|| "hinf".into());
        let rest = value.to_string();
        match objective.as_str() {
            Some("comfort") => Ok(DesignFile::Comfort(ComfortDesign::from_json(&rest)?)),
            Some("hinf") => Ok(DesignFile::Thesis(Design::from_json(&rest)?)),
            _ => Err(DesignError::Syntax(format!(
                "\"objective\" must be \"comfort\" or \"hinf\", got {objective}"
            ))),
        }
    }
}

/// One synthesised, certified design, whatever its kind.
pub struct Synthesised {
    pub law: ControlLaw,
    pub certificate: serde_json::Value,
    pub controller_json: ControllerFile,
    pub row: SummaryRow,
    /// Wall time of this design alone \[s\].
    pub seconds: f64,
}

/// One design in the summary of a run (`dist/synthesis.json`, [`summary_table`]).
#[derive(Debug, Clone, Serialize)]
pub struct SummaryRow {
    pub variant: String,
    pub objective: &'static str,
    pub robust_to: String,
    /// Comfort designs: W_k RMS seat acceleration on the design road [m/s²], predicted at the
    /// nominal car, the passive car's, and guaranteed over the design's uncertainty.
    pub predicted_wk_rms_seat: Option<f64>,
    pub passive_wk_rms_seat: Option<f64>,
    pub guaranteed_wk_rms_seat: Option<f64>,
    /// Comfort designs: the predicted W_k RMS seat acceleration as a master runs the loop at
    /// its communication step (the certificate's `comfort.held`), at the nominal car and worst
    /// over the design's uncertainty: `0.0103 at 1 ms (stable at steps to 5 ms, unstable at
    /// 7.5 ms); worst 0.0105` (the cell of both tables, `master`'s read from `synthesis.json`).
    pub held: Option<String>,
    /// Comfort designs: the held `W_k` seat at each checked communication step from the
    /// design file's up (`comfort.communication_steps`), as `(step [s], cell)`:
    /// [`step_cells`].
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub steps: Vec<(f64, String)>,
    /// Comfort designs: the held loop in each master order (`comfort.master_orders`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub master_orders: Vec<InOrder>,
    /// Thesis designs: the γ the LMI claims, the certified `‖T_zw‖∞` at the nominal car, and
    /// the passive car's on the same generalised plant.
    pub gamma: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub norm: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub passive_norm: Option<f64>,
    /// The headline certified figure over the design's uncertainty.
    pub certified: String,
    pub nominal_design: Option<String>,
    /// The nominal design's figure over the same uncertainty.
    pub nominal_figure: Option<String>,
    pub seconds: f64,
}

/// What a run made: the certified designs, and (comfort designs only) those refused, with why.
pub struct Outcome {
    pub designs: Vec<(String, Synthesised)>,
    pub refused: Vec<(String, String)>,
}

/// Synthesise and certify `names` (all when empty). A thesis design that fails stops the run (its
/// FMUs are the default build); a comfort design that fails is refused and reported, the others
/// go on.
pub fn synthesise_all(
    names: &[&str],
    params: &VehicleParams,
    file: &DesignFile,
) -> Result<Outcome, SynthError> {
    // Before any LAPACK call, not only the SDPs': the eigen- and Schur decompositions of the
    // certificates reach OpenBLAS's threaded kernels too, whose idle workers then spin beside
    // the designs' own threads (`delay_sf` alone: 43.4 s wall, 12 s of it in the kernel, against
    // 32.0 s), and whose sums' order depends on the core count.
    crate::single_threaded_blas();
    for n in names {
        if variant(n).is_none() {
            return Err(SynthError::Usage(format!(
                "unknown variant '{n}', expected one of {:?}",
                self::names()
            )));
        }
    }
    let (mass_min, mass_max) = file.mass_range();
    if !(mass_min..=mass_max).contains(&params.m_s) {
        return Err(SynthError::Usage(format!(
            "the car's sprung mass m_s = {} kg is outside the design file's range [{mass_min}, \
             {mass_max}] kg that the robust designs cover and are designed around: give a \
             design file (--design) whose mass_min and mass_max bracket it",
            params.m_s
        )));
    }
    let all = match file {
        DesignFile::Comfort(_) => self::names(),
        DesignFile::Thesis(_) => thesis_names(),
    };
    if let Some(n) = names.iter().find(|n| !all.contains(n)) {
        return Err(SynthError::Usage(format!(
            "'{n}' has no thesis design (it is a comfort baseline); the thesis's are {all:?}"
        )));
    }
    let names = if names.is_empty() { &all[..] } else { names };
    let mut outcome = match file {
        DesignFile::Thesis(design) => Outcome {
            designs: thesis_all(names, params, design)?,
            refused: Vec::new(),
        },
        DesignFile::Comfort(design) => comfort_all(names, params, design)?,
    };
    // Every controller file records the car it is for, and a mass-robust design its range.
    for (name, s) in &mut outcome.designs {
        let robust_to_mass = variant(name).is_some_and(|v| v.robust_to == Uncertainty::SprungMass);
        s.controller_json.designed_for = Some(crate::shipping::controller_file::DesignedFor {
            mass_range_kg: robust_to_mass.then_some([mass_min, mass_max]),
            vehicle: vehicle::params::PARAMETERS
                .iter()
                .map(|p| (p.name.to_string(), (p.get)(params)))
                .collect(),
        });
    }
    Ok(outcome)
}

fn thesis_all(
    names: &[&str],
    params: &VehicleParams,
    design: &Design,
) -> Result<Vec<(String, Synthesised)>, SynthError> {
    let results = crate::thesis::synthesis::synthesise_all(names, params, design)?;
    let rows = crate::thesis::synthesis::summary_rows(&results);
    // The road the design file names for comfort, and the passive car's figure on it.
    let comfort = match design.comfort_road {
        None => None,
        Some(r) => {
            let road = r.as_comfort_road();
            let passive = predict(None, Conditions::nominal(*params), &road)
                .map_err(|e| SynthError::Usage(format!("the passive car on comfort_road: {e}")))?;
            Some((road, passive.wk_rms_seat_m_s2))
        }
    };
    Ok(results
        .into_iter()
        .zip(rows)
        .map(|((name, s), r)| {
            let law = ControlLaw {
                lti: s.controller,
                inputs: s.certificate.measurements.clone(),
                accommodation: None,
                predictor: None,
            };
            let predicted = comfort.as_ref().map(|(road, _)| {
                predict(Some(&law), Conditions::nominal(*params), road)
                    .map_or(f64::INFINITY, |f| f.wk_rms_seat_m_s2)
            });
            let row = SummaryRow {
                variant: r.variant,
                objective: "hinf",
                robust_to: r.robust_to,
                predicted_wk_rms_seat: predicted,
                passive_wk_rms_seat: comfort.as_ref().map(|(_, passive)| *passive),
                guaranteed_wk_rms_seat: None,
                held: None,
                steps: Vec::new(),
                master_orders: Vec::new(),
                gamma: Some(r.gamma),
                norm: Some(s.certificate.norm_upper),
                passive_norm: s.certificate.passive_norm,
                certified: r.certified,
                nominal_design: r.nominal_design,
                nominal_figure: r.nominal_figure,
                seconds: r.seconds,
            };
            let certificate = serde_json::to_value(&s.certificate).expect("serialisable");
            (
                name,
                Synthesised {
                    law,
                    certificate,
                    controller_json: s.controller_json,
                    row,
                    seconds: s.seconds,
                },
            )
        })
        .collect())
}

/// The comfort figure a controller FMU reports: the guaranteed one, or where the design's
/// uncertainty has no certified bound, the nominal prediction under its own name.
fn comfort_guarantee(d: &ComfortDesign, comfort: &Comfort, robust_to: Uncertainty) -> Guarantee {
    let road = format!(
        "on an ISO 8608 class {} road at {} m/s (left and right independent)",
        String::from(d.road.iso_class),
        d.road.speed
    );
    match comfort.guaranteed_wk_rms_seat_m_s2 {
        Some(value) => Guarantee {
            name: "guaranteed_wk_rms_seat".into(),
            value,
            unit: "m/s2".into(),
            description: format!(
                "W_k RMS seat acceleration the design guarantees {road}{} (see the certificate)",
                match robust_to {
                    Uncertainty::SprungMass => " for every sprung mass of its range",
                    Uncertainty::ActuatorFaults => " for every actuator effectiveness of its box",
                    _ => " at the nominal car",
                }
            ),
        },
        None => Guarantee {
            name: "predicted_wk_rms_seat".into(),
            value: comfort.predicted_wk_rms_seat_m_s2,
            unit: "m/s2".into(),
            description: format!(
                "W_k RMS seat acceleration predicted {road} at the nominal car; no bound over the \
                 design's uncertainty is certified (see the certificate)"
            ),
        },
    }
}

fn comfort_all(
    names: &[&str],
    params: &VehicleParams,
    design: &ComfortDesign,
) -> Result<Outcome, SynthError> {
    // The state-feedback designs and those on the car's sensors, each on its design model and
    // with the designs they share. Without a `car` block the car's design is the
    // output-feedback road model's, which the designs on the car's sensors refuse.
    let car_design = design
        .for_car()
        .unwrap_or_else(|| design.for_output_feedback());
    let sf_design = design.for_state_feedback();
    let contexts = [
        Context {
            params,
            design: &sf_design,
        },
        Context {
            params,
            design: &car_design,
        },
    ];
    let names: Vec<&str> = if names.is_empty() {
        self::names()
    } else {
        names.to_vec()
    };
    let (mut by_name, refused) = synthesise_each(&names, &contexts);
    let names: Vec<&str> = names
        .into_iter()
        .filter(|n| by_name.contains_key(*n))
        .collect();
    beside_their_nominal_designs(&mut by_name, &contexts);
    let designs = names
        .iter()
        .map(|name| {
            let (r, seconds) = by_name.remove(*name).expect("synthesised above");
            (name.to_string(), shipped(name, r, seconds, design))
        })
        .collect();
    Ok(Outcome { designs, refused })
}

/// Each of `names` on its design model's context, each on its own task (the designs others
/// build on first, through their contexts' shared results), with its time; the refused ones
/// with why.
#[allow(clippy::type_complexity)]
fn synthesise_each(
    names: &[&str],
    contexts: &[Context; 2],
) -> (
    BTreeMap<String, (ComfortDesignResult, f64)>,
    Vec<(String, String)>,
) {
    use rayon::prelude::*;
    let shared = [Shared::default(), Shared::default()];
    let done: Vec<(String, Result<ComfortDesignResult, ComfortError>, f64)> = names
        .par_iter()
        .with_max_len(1)
        .map(|name| {
            let v = variant(name).expect("checked above");
            let t = std::time::Instant::now();
            let k = v.model as usize;
            let r = (v.comfort)(&contexts[k], &shared[k]).and_then(|r| v.accept(r));
            (name.to_string(), r, t.elapsed().as_secs_f64())
        })
        .collect();
    let mut refused = Vec::new();
    let mut by_name = BTreeMap::new();
    for (n, r, t) in done {
        match r {
            Ok(r) => {
                by_name.insert(n, (r, t));
            }
            Err(e) => refused.push((n, e.to_string())),
        }
    }
    (by_name, refused)
}

/// Each robust design's nominal counterpart at the same conditions, when both were made,
/// into the robust design's certificate. Every pair's every condition in one parallel pass
/// (after every design is made this is all that runs; pair by pair, the two threads idled
/// between the pairs' few conditions), each on the robust design's own design model.
fn beside_their_nominal_designs(
    by_name: &mut BTreeMap<String, (ComfortDesignResult, f64)>,
    contexts: &[Context; 2],
) {
    use rayon::prelude::*;
    let pairs: Vec<(String, String)> = by_name
        .keys()
        .filter_map(|n| {
            variant(n)
                .and_then(|v| v.nominal)
                .filter(|nom| by_name.contains_key(*nom))
                .map(|nom| (n.clone(), nom.to_string()))
        })
        .collect();
    let jobs: Vec<(&ControlLaw, Conditions, &ComfortDesign)> = pairs
        .iter()
        .filter_map(|(robust, nominal)| {
            let u = by_name[robust].0.certificate.comfort.uncertainty.as_ref()?;
            let law = &by_name[nominal].0.law;
            let on = contexts[variant(robust).expect("checked").model as usize].design;
            Some(u.conditions.iter().map(move |c| (law, *c, on)))
        })
        .flatten()
        .collect();
    let done: Vec<(Option<Figures>, Option<Held>)> = jobs
        .par_iter()
        .map(|(law, c, on)| {
            rayon::join(
                || predict(Some(law), *c, &on.road).ok(),
                || held_at(law, *c, on),
            )
        })
        .collect();
    let mut done = done.into_iter();
    for (robust, nominal) in &pairs {
        let entry = &mut by_name.get_mut(robust).expect("present").0;
        let Some(u) = entry.certificate.comfort.uncertainty.as_mut() else {
            continue;
        };
        let (continuous, held): (Vec<_>, Vec<_>) = done.by_ref().take(u.conditions.len()).unzip();
        u.nominal_design = u
            .predictions
            .iter()
            .map(|(l, _)| l.clone())
            .zip(continuous)
            .collect();
        u.nominal_held = held;
        u.nominal_name = Some(nominal.clone());
    }
}

/// What ships of a design made in `seconds`: its controller file, its certificate and its row
/// of the summary.
fn shipped(
    name: &str,
    r: ComfortDesignResult,
    seconds: f64,
    design: &ComfortDesign,
) -> Synthesised {
    let v = variant(name).expect("checked");
    let c = &r.certificate;
    let comfort = &c.comfort;
    let guarantee = comfort_guarantee(design, comfort, c.robust_to);
    let mut json = controller_json(
        name,
        &format!("{} — comfort design: {}", name, v.summary),
        &guarantee,
        &r.law.inputs,
        &r.law.lti,
    )
    .with(r.extensions.clone());
    json.communication_steps = comfort.communication_steps.for_the_fmu();
    let (certified, nominal_figure) = headline(c);
    let row = SummaryRow {
        variant: name.to_string(),
        objective: "comfort",
        robust_to: c.robust_to.label().to_string(),
        predicted_wk_rms_seat: Some(comfort.predicted_wk_rms_seat_m_s2),
        passive_wk_rms_seat: Some(comfort.passive_wk_rms_seat_m_s2),
        guaranteed_wk_rms_seat: comfort.guaranteed_wk_rms_seat_m_s2,
        held: Some(held(comfort)),
        steps: step_cells(&comfort.communication_steps),
        master_orders: comfort.master_orders.clone(),
        gamma: None,
        norm: None,
        passive_norm: None,
        certified,
        nominal_design: v.nominal.map(String::from),
        nominal_figure,
        seconds,
    };
    Synthesised {
        certificate: serde_json::to_value(c).expect("serialisable"),
        law: r.law,
        controller_json: json,
        row,
        seconds,
    }
}

/// The certified figure over the design's uncertainty and the nominal design's over the same.
fn headline(c: &crate::comfort::designs::ComfortCertificate) -> (String, Option<String>) {
    let comfort = &c.comfort;
    match &comfort.uncertainty {
        None => (
            format!(
                "W_k seat {:.4} (passive {:.4}); delay margin {:.1} ms",
                comfort.predicted_wk_rms_seat_m_s2,
                comfort.passive_wk_rms_seat_m_s2,
                1e3 * c.unmodelled_delay.delay_margin_s
            ),
            None,
        ),
        Some(u) => {
            let nominal = (!u.nominal_design.is_empty()).then(|| {
                let worst = u
                    .nominal_design
                    .iter()
                    .map(|(_, f)| f.as_ref().map_or(f64::INFINITY, |f| f.wk_rms_seat_m_s2))
                    .fold(0.0, f64::max);
                let continuous = if worst.is_finite() {
                    format!("worst W_k seat {worst:.4}")
                } else {
                    "unstable somewhere".into()
                };
                format!(
                    "{continuous}; at {} ms {}",
                    comfort.held.step_s * 1e3,
                    held_over(&u.nominal_held, &u.predictions)
                )
            });
            (
                format!(
                    "worst W_k seat {:.4} over {} conditions; {}",
                    u.worst_predicted_wk_rms_seat_m_s2,
                    u.predictions.len(),
                    match (
                        &u.bound_wk_rms_seat,
                        u.over_delays,
                        u.bound_model_grid_worst_wk_rms_seat,
                        u.accommodated_down_to,
                    ) {
                        (Some(b), _, _, _) => format!("car-model bound {:.4}", b.value),
                        (None, Some(o), _, _) => format!(
                            "car-model bound {:.4} over every delay of [0, {} ms]",
                            o.bound,
                            1e3 * o.delay_max_s
                        ),
                        (None, None, Some(g), Some(r)) => format!(
                            "accommodated down to ρ = {r}: the nominal loop once the estimate \
                             settles; the transient's frozen loops stable (car-model worst \
                             {g:.4})"
                        ),
                        (None, None, Some(g), None) =>
                            format!("car-model grid worst {g:.4} (no bound)"),
                        (None, None, None, _) => "-".into(),
                    }
                ),
                nominal,
            )
        }
    }
}

/// A comfort design's prediction as a master runs it: `0.0103 at 1 ms`, the communication
/// steps its loop is stable at over the checked conditions (`(stable at steps to 5 ms,
/// unstable at 7.5 ms)`, [`crate::comfort::designs::StepStability`]), and
/// for a robust design its worst over the uncertainty's conditions (`; worst 0.0105`, or where
/// it is unstable at the step).
fn held(comfort: &crate::comfort::designs::Comfort) -> String {
    let h = &comfort.held;
    let nominal = format!(
        "{:.4} at {} ms ({})",
        h.predicted_wk_rms_seat_m_s2,
        h.step_s * 1e3,
        steps(&comfort.communication_steps)
    );
    match &comfort.uncertainty {
        None => nominal,
        Some(u) => format!("{nominal}; {}", held_over(&u.held, &u.predictions)),
    }
}

/// Below this relative half-width a held loop's resonance is marked in the per-step table: a
/// mode that barely decays, whose narrow peak decides the figure.
const SHARP: f64 = 0.01;

/// The per-step table's cells of a design: from the design file's step up, the nominal car's
/// held `W_k` seat, the worst over the checked conditions in brackets where it differs, `*`
/// where its sharpest resonance is under `SHARP` wide; `unstable` where a checked loop is.
pub fn step_cells(s: &crate::comfort::designs::StepStability) -> Vec<(f64, String)> {
    s.checked
        .iter()
        .filter_map(|c| {
            let cell = match (&c.comfort, c.spectral_radius) {
                (Some(k), _) => {
                    let (n, w) = (
                        k.nominal.predicted_wk_rms_seat_m_s2,
                        k.worst_predicted_wk_rms_seat_m_s2,
                    );
                    let mut cell = format!("{n:.4}");
                    if w > n * (1.0 + 1e-9) {
                        cell += &format!(" ({w:.4})");
                    }
                    if k.nominal
                        .sharpest_resonance
                        .is_some_and(|r| r.relative_half_width < SHARP)
                    {
                        cell += "*";
                    }
                    cell
                }
                (None, Some(r)) if r >= 1.0 => "unstable".into(),
                (None, None) => "-".into(),
                // Below the design file's step: stability alone is checked there.
                (None, Some(_)) => return None,
            };
            Some((c.step_s, cell))
        })
        .collect()
}

/// Where the nominal loop as a master runs it is stable over the checked communication steps:
/// `stable at steps to 10 ms`, `stable at steps to 1 ms, unstable at 1.25 ms`.
fn steps(s: &crate::comfort::designs::StepStability) -> String {
    let ms = |h: f64| format!("{} ms", h * 1e3);
    match (s.stable_up_to_s, s.first_unstable_s()) {
        (Some(up), None) => format!("stable at steps to {}", ms(up)),
        (Some(up), Some(h)) => format!("stable at steps to {}, unstable at {}", ms(up), ms(h)),
        (None, Some(h)) => format!("unstable at {}", ms(h)),
        (None, None) => "no step checked".into(),
    }
}

/// Held predictions over an uncertainty's conditions: `worst 0.0105`, or the conditions where
/// the loop is unstable at the step (the first and last of them beyond two).
fn held_over(
    held: &[Option<crate::comfort::designs::Held>],
    conditions: &[(String, crate::predict::continuous::Figures)],
) -> String {
    let unstable: Vec<&str> = held
        .iter()
        .zip(conditions)
        .filter(|(h, _)| h.is_none())
        .map(|(_, (label, _))| label.as_str())
        .collect();
    match unstable[..] {
        [] => format!("worst {:.4}", crate::comfort::designs::worst_held(held)),
        [_] | [_, _] => format!("unstable at {}", unstable.join(", ")),
        [first, .., last] => format!(
            "unstable at {} of {} conditions ({first} … {last})",
            unstable.len(),
            held.len()
        ),
    }
}

/// What γ says about comfort, in the README's words (`make readme` splices it under "Why not
/// γ"): the thesis design γ favours most beside the passive car on the same generalised plant,
/// and its predicted comfort on `road` beside the passive car's; then the range over every
/// design. `None` without a design that has all four figures.
pub fn gamma_in_words(
    rows: &[SummaryRow],
    road: &crate::shipping::design::IsoRoad,
) -> Option<String> {
    // Per design: how far below the passive car's its certified norm and its predicted W_k
    // seat RMS are [%], and the four figures.
    struct Scores<'a> {
        name: &'a str,
        norm: [f64; 2],
        seat: [f64; 2],
    }
    let below = |[x, passive]: [f64; 2]| 100.0 * (1.0 - x / passive);
    let scores: Vec<Scores> = rows
        .iter()
        .filter_map(|r| {
            Some(Scores {
                name: &r.variant,
                norm: [r.norm?, r.passive_norm?],
                seat: [
                    r.predicted_wk_rms_seat.filter(|p| p.is_finite())?,
                    r.passive_wk_rms_seat?,
                ],
            })
        })
        .collect();
    let best = scores
        .iter()
        .max_by(|a, b| below(a.norm).total_cmp(&below(b.norm)))?;
    let range = |of: fn(&Scores) -> [f64; 2]| {
        scores
            .iter()
            .map(|s| below(of(s)))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                (lo.min(v), hi.max(v))
            })
    };
    let (norm_lo, norm_hi) = range(|s| s.norm);
    // Whole percents: the least comfortable thesis design (`delay_sf`, whose γ-suboptimal LMI
    // solution the BLAS kernels move: 0.2291–0.2329 m/s² measured on two kernels of one
    // machine, 48.7 and 47.8 %) differs by a point between machines.
    let (seat_lo, seat_hi) = range(|s| s.seat);
    Some(format!(
        "The thesis design whose certified norm is furthest below the passive car's is \
         `{}`: on its generalised plant the passive car scores ‖T_zw‖∞ = {:.2} and the design \
         {:.2} ({:.1} % lower), while on an ISO 8608 class {} road at {} m/s its predicted W_k \
         seat RMS is {:.4} m/s² against the passive car's {:.4} ({:.1} % lower). Over the {} \
         thesis designs the certified norm at the nominal car is {norm_lo:.1}–{norm_hi:.1} % \
         below the passive car's on the same plant, and the predicted comfort \
         {seat_lo:.0}–{seat_hi:.0} % better (`make thesis`, `dist/thesis/synthesis.md`).\n",
        best.name,
        best.norm[1],
        best.norm[0],
        below(best.norm),
        String::from(road.iso_class),
        road.speed,
        best.seat[0],
        best.seat[1],
        below(best.seat),
        scores.len(),
    ))
}

/// The summary table (Markdown) of a run.
pub fn summary_table(rows: &[SummaryRow], wall_seconds: f64) -> String {
    let comfort = rows.iter().any(|r| r.objective == "comfort");
    let mut t = if comfort {
        String::from(
            "| variant | robust to | predicted W_k seat [m/s²] | as a master runs it | passive | guaranteed (car) | over its uncertainty | nominal design, same conditions | synthesis |\n|---|---|---|---|---|---|---|---|---|\n",
        )
    } else {
        String::from(
            "| variant | robust to | γ | certified ‖T_zw‖∞ (worst over its uncertainty) | passive car, same plant | nominal design, worst over the same | predicted W_k seat [m/s²] | passive | synthesis |\n|---|---|---|---|---|---|---|---|---|\n",
        )
    };
    let f = |v: Option<f64>| v.map_or("-".into(), |v| format!("{v:.4}"));
    for r in rows {
        if comfort {
            t += &format!(
                "| `{}` | {} | {} | {} | {} | {} | {} | {} | {:.2} s |\n",
                r.variant,
                r.robust_to,
                f(r.predicted_wk_rms_seat),
                r.held.as_deref().unwrap_or("-"),
                f(r.passive_wk_rms_seat),
                f(r.guaranteed_wk_rms_seat),
                r.certified,
                r.nominal_figure.as_deref().unwrap_or("-"),
                r.seconds
            );
        } else {
            t += &format!(
                "| `{}` | {} | {:.6} | {} | {} | {} | {} | {} | {:.2} s |\n",
                r.variant,
                r.robust_to,
                r.gamma.unwrap_or(f64::NAN),
                r.certified,
                r.passive_norm
                    .map_or("unstable".into(), |n| format!("{n:.6}")),
                r.nominal_figure.as_deref().unwrap_or("-"),
                f(r.predicted_wk_rms_seat),
                f(r.passive_wk_rms_seat),
                r.seconds
            );
        }
    }
    t += &format!(
        "\nAll {} designs in {wall_seconds:.2} s wall time (designs in parallel, one BLAS thread each). A design several variants build on (the nominal gain, `hinf_of`) is timed in the synthesis of whichever variant built it first: `hinf_of` shows next to nothing when `hinf_of_aw` made it.\n",
        rows.len()
    );
    if let Some(first) = rows.iter().find(|r| !r.steps.is_empty()) {
        let ms = |h: f64| format!("{} ms", h * 1e3);
        let passive = first
            .passive_wk_rms_seat
            .map_or("-".into(), |p| format!("{p:.4}"));
        t += &format!(
            "\nPredicted W_k seat [m/s²] as a master runs the loop at each communication step \
              (`comfort.communication_steps`): the nominal car, in brackets the worst over the \
              step check's conditions where it differs; `*` a mode of the held loop under {} % \
              wide in the road's band. The passive car: {passive}.\n\n| variant |",
            100.0 * SHARP
        );
        for (h, _) in &first.steps {
            t += &format!(" {} |", ms(*h));
        }
        t += &format!("\n|---|{}\n", "---|".repeat(first.steps.len()));
        for r in rows.iter().filter(|r| !r.steps.is_empty()) {
            t += &format!("| `{}` |", r.variant);
            for (_, cell) in &r.steps {
                t += &format!(" {cell} |");
            }
            t += "\n";
        }
    }
    t
}
