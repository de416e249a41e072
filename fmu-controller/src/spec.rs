//! `resources/controller.json`, written by `synth`: the controller `ẋc = A xc + B y`,
//! `u = C xc + D y` in the plant's units, and the names and units of its inputs (plant outputs)
//! and outputs (plant inputs `u_*`).

use fmu_core::fmu_state;
use linsys::Lti;
use nalgebra::DMatrix;

pub use controller_file::DetectorInput;
pub use controller_file::{CommunicationSteps, Guarantee, Signal, FORMAT};
use controller_file::{ControllerFile as Raw, Predictor as RawPredictor};

/// A fault detector (thesis ch. 8): `ξ̇ = A ξ + B y + B_u u` with `u` the command sent (N),
/// the residual `r = C ξ + D y` (N, the estimated actuator force deficit); `fault_detected`
/// latches when `‖r‖` exceeds `threshold`.
#[derive(Debug, Clone)]
pub struct FaultDetection {
    pub a: DMatrix<f64>,
    pub b: DMatrix<f64>,
    pub b_u: DMatrix<f64>,
    pub c: DMatrix<f64>,
    pub d: DMatrix<f64>,
    /// Default threshold \[N\] (parameter `fault_threshold`).
    pub threshold: f64,
    /// What drives `B_u`: the command sent, or the accommodation's modelled applied force.
    pub input: DetectorInput,
}

/// A state feedback behind a predictor over the actuators' known delay `θ` (synth's
/// `predictor.rs`): the design state `x = S_y y + S_ξ ξ` from the inputs `y` and the
/// controller's own states `ξ̇ = A_ξ ξ + B_ξ y + B_ξu u(t − θ)`, and the command
/// `u(t) = K [e^{Aθ} x(t) + ∫_{t−θ}^{t} e^{A(t−r)} B u(r) dr]`: the design state `θ` ahead.
/// The rows of `ξ` that `B_ξu` drives (the command's own filters, [`Predictor::own`]) are kept
/// in controller time by the runtime, as the filter of `u` up to `t`: their part of that
/// prediction ([`crate::predictor`]).
/// With `θ = 0` it is the controller `A, B, C, D` of the file (checked on reading). `D_yu` is
/// how the applied force reaches the inputs at once (the accelerations), so that the runtime,
/// which holds `y` over a step, can drive `ξ` by the force as the actuators apply it.
/// `u_max`, when given, are the actuators' force limits the commands are clamped to.
#[derive(Debug, Clone)]
pub struct Predictor {
    pub a: DMatrix<f64>,
    pub b: DMatrix<f64>,
    pub k: DMatrix<f64>,
    pub s_y: DMatrix<f64>,
    pub s_xi: DMatrix<f64>,
    pub a_xi: DMatrix<f64>,
    pub b_xi: DMatrix<f64>,
    pub b_xiu: DMatrix<f64>,
    /// `D_yu` (ny × nu; zero when the file has none).
    pub d_yu: DMatrix<f64>,
    /// The command's own filters: `(j, i, s)` for each row `j` of `ξ` that `B_ξu` drives,
    /// read by `S_ξ` into the design state `i` alone (`x_i = s ξ_j`). Checked on reading: they
    /// read nothing else and nothing else reads them (`A`, `A_ξ`, `B_ξ`, `S_y`), so the
    /// runtime can keep them in controller time ([`crate::predictor`]).
    pub own: Vec<(usize, usize, f64)>,
    /// The largest delay it is certified for \[s\] (the parameter `tau`'s maximum).
    pub delay_max: f64,
    /// Default force limit of each output \[N\] (parameters `u_max`, `u_max_seat`), if any.
    pub u_max: Option<Vec<f64>>,
}

/// Fault accommodation (`controller_file::Accommodation`): the effectiveness of each actuator
/// estimated from the input that measures its applied force, the command divided by it.
#[derive(Debug, Clone)]
pub struct Accommodation {
    /// Per output, the index of the input measuring its applied force.
    pub force_inputs: Vec<usize>,
    pub rho_min: f64,
    pub time_constant: f64,
    /// Default force limit of each output \[N\] (parameters `u_max`, `u_max_seat`).
    pub u_max: Vec<f64>,
    /// Default bandwidth of the actuators' lag \[Hz\] (parameter `actuator_bandwidth`; 0:
    /// ideal).
    pub actuator_bandwidth: f64,
}

/// A decoupled anti-windup compensator (thesis Th. 5.3): the plant model `η̇ = A η + B (u − y_c)`
/// with `u = sat(y_c + F η)`; the controller reads `y − C η − D (u − y_c)`. Forces in N.
#[derive(Debug, Clone)]
pub struct AntiWindup {
    pub a: DMatrix<f64>,
    pub b: DMatrix<f64>,
    pub c: DMatrix<f64>,
    pub f: DMatrix<f64>,
    /// The inputs' feed-through of the forces (zero when the file gives none).
    pub d: DMatrix<f64>,
    /// Default force limit of each output \[N\] (parameters `u_max`, `u_max_seat`).
    pub u_max: Vec<f64>,
}

/// A checked controller description.
#[derive(Debug, Clone)]
pub struct Spec {
    pub variant: String,
    pub description: String,
    pub guarantee: Guarantee,
    pub inputs: Vec<Signal>,
    pub outputs: Vec<Signal>,
    /// The controller `ẋc = A xc + B y`, `u = C xc + D y` (N).
    pub lti: Lti,
    pub accommodation: Option<Accommodation>,
    pub anti_windup: Option<AntiWindup>,
    pub fault_detection: Option<FaultDetection>,
    pub predictor: Option<Predictor>,
    /// Where its certificate found the loop as a master runs it stable (absent: not checked).
    pub communication_steps: Option<CommunicationSteps>,
    /// FNV-1a of the file's bytes: enters the version string, hence the GUID.
    pub content_hash: u64,
}

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SpecError {
    #[error("controller.json is not valid: {0}")]
    Syntax(String),
    #[error("controller.json has format '{0}', expected '{FORMAT}'")]
    Format(String),
    #[error("controller.json: matrix {name} should be {rows}×{cols}, found {found}")]
    Shape {
        name: &'static str,
        rows: usize,
        cols: usize,
        found: String,
    },
    #[error("controller.json: matrix {0} contains a non-finite number")]
    NonFinite(&'static str),
    #[error("controller.json: {0}")]
    Invalid(String),
}

fn matrix(
    name: &'static str,
    rows: &[Vec<f64>],
    r: usize,
    c: usize,
) -> Result<DMatrix<f64>, SpecError> {
    if let Some(found) = controller_file::shape_mismatch(rows, r, c) {
        return Err(SpecError::Shape {
            name,
            rows: r,
            cols: c,
            found,
        });
    }
    if rows.iter().flatten().any(|v| !v.is_finite()) {
        return Err(SpecError::NonFinite(name));
    }
    Ok(DMatrix::from_fn(r, c, |i, j| rows[i][j]))
}

fn predictor(p: &RawPredictor, ny: usize, nu: usize) -> Result<Predictor, SpecError> {
    let (n, m) = (p.a.len(), p.a_xi.len());
    if !(p.delay_max >= 0.0 && p.delay_max.is_finite()) {
        return Err(SpecError::Invalid(format!(
            "predictor.delay_max must be finite and >= 0, found {}",
            p.delay_max
        )));
    }
    let mut predictor = Predictor {
        a: matrix("predictor.A", &p.a, n, n)?,
        b: matrix("predictor.B", &p.b, n, nu)?,
        k: matrix("predictor.K", &p.k, nu, n)?,
        s_y: matrix("predictor.S_y", &p.s_y, n, ny)?,
        s_xi: matrix("predictor.S_xi", &p.s_xi, n, m)?,
        a_xi: matrix("predictor.A_xi", &p.a_xi, m, m)?,
        b_xi: matrix("predictor.B_xi", &p.b_xi, m, ny)?,
        b_xiu: matrix("predictor.B_xiu", &p.b_xiu, m, nu)?,
        d_yu: match &p.d_yu {
            Some(rows) => matrix("predictor.D_yu", rows, ny, nu)?,
            None => DMatrix::zeros(ny, nu),
        },
        delay_max: p.delay_max,
        u_max: p
            .u_max
            .as_ref()
            .map(|u| force_limits("predictor.u_max", u, nu))
            .transpose()?,
        own: Vec::new(),
    };
    predictor.own = own_filters(&predictor)?;
    Ok(predictor)
}

/// [`Predictor::own`], or why the file's filters of the command cannot run in controller time.
fn own_filters(p: &Predictor) -> Result<Vec<(usize, usize, f64)>, SpecError> {
    let invalid = |what: String| {
        SpecError::Invalid(format!(
            "predictor: {what}; the rows of xi that B_xiu drives must be filters of the command \
             alone, each read by S_xi into one design state that no other state reads or drives"
        ))
    };
    let (n, m) = (p.a.nrows(), p.a_xi.nrows());
    let rows: Vec<usize> = (0..m)
        .filter(|&j| p.b_xiu.row(j).iter().any(|v| *v != 0.0))
        .collect();
    let mut own = Vec::new();
    for &j in &rows {
        let read: Vec<usize> = (0..n).filter(|&i| p.s_xi[(i, j)] != 0.0).collect();
        let [i] = read[..] else {
            return Err(invalid(format!(
                "S_xi reads xi row {j} into {} design states",
                read.len()
            )));
        };
        own.push((j, i, p.s_xi[(i, j)]));
    }
    let states: Vec<usize> = own.iter().map(|o| o.1).collect();
    for &(j, i, _) in &own {
        if p.b_xi.row(j).iter().any(|v| *v != 0.0) || p.s_y.row(i).iter().any(|v| *v != 0.0) {
            return Err(invalid(format!(
                "xi row {j} (state {i}) is also driven by or read from y"
            )));
        }
        if (0..m).any(|k| !rows.contains(&k) && (p.a_xi[(j, k)] != 0.0 || p.a_xi[(k, j)] != 0.0))
            || (0..m).any(|k| k != j && p.s_xi[(i, k)] != 0.0)
            || (0..n).any(|k| !states.contains(&k) && (p.a[(i, k)] != 0.0 || p.a[(k, i)] != 0.0))
        {
            return Err(invalid(format!(
                "xi row {j} (state {i}) is coupled to the other states"
            )));
        }
    }
    // Their dynamics are the design model's (`x_i = s ξ_j`), or the filter of the commands is
    // not that state's prediction.
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1.0);
    for &(j, i, s) in &own {
        let same_a = own
            .iter()
            .all(|&(j2, i2, s2)| close(p.a_xi[(j, j2)], p.a[(i, i2)] * s2 / s));
        let same_b = (0..p.b.ncols()).all(|c| close(p.b_xiu[(j, c)], p.b[(i, c)] / s));
        if !(same_a && same_b) {
            return Err(invalid(format!(
                "xi row {j} does not follow the design model's state {i} (A_xi, B_xiu against A, B)"
            )));
        }
    }
    Ok(own)
}

/// A block's default force limits: one per output, finite and > 0.
fn force_limits(name: &str, u_max: &[f64], nu: usize) -> Result<Vec<f64>, SpecError> {
    if u_max.len() != nu || !u_max.iter().all(|u| *u > 0.0 && u.is_finite()) {
        return Err(SpecError::Invalid(format!(
            "{name} must hold {nu} finite limits > 0, found {u_max:?}"
        )));
    }
    Ok(u_max.to_vec())
}

/// The largest actuator bandwidth \[Hz\] (the plant's bound).
pub const MAX_ACTUATOR_BANDWIDTH: f64 = 1e5;

/// An actuator bandwidth the runtime takes: in `[0, MAX_ACTUATOR_BANDWIDTH]` Hz (NaN is not).
pub fn actuator_bandwidth_ok(hz: f64) -> bool {
    (0.0..=MAX_ACTUATOR_BANDWIDTH).contains(&hz)
}

fn accommodation(
    a: &controller_file::Accommodation,
    inputs: &[Signal],
    nu: usize,
) -> Result<Accommodation, SpecError> {
    if a.forces.len() != nu {
        return Err(SpecError::Invalid(format!(
            "accommodation.forces must name {nu} inputs, one per output, found {}",
            a.forces.len()
        )));
    }
    let force_inputs = a
        .forces
        .iter()
        .map(|f| {
            inputs.iter().position(|s| s.name == *f).ok_or_else(|| {
                SpecError::Invalid(format!("accommodation.forces: '{f}' is not an input"))
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    if !(a.rho_min > 0.0 && a.rho_min <= 1.0) {
        return Err(SpecError::Invalid(format!(
            "accommodation.rho_min must be in (0, 1], found {}",
            a.rho_min
        )));
    }
    if !(a.time_constant > 0.0 && a.time_constant.is_finite()) {
        return Err(SpecError::Invalid(format!(
            "accommodation.time_constant must be finite and > 0, found {}",
            a.time_constant
        )));
    }
    if !actuator_bandwidth_ok(a.actuator_bandwidth) {
        return Err(SpecError::Invalid(format!(
            "accommodation.actuator_bandwidth must be in [0, {MAX_ACTUATOR_BANDWIDTH}] Hz, found {}",
            a.actuator_bandwidth
        )));
    }
    Ok(Accommodation {
        force_inputs,
        rho_min: a.rho_min,
        time_constant: a.time_constant,
        actuator_bandwidth: a.actuator_bandwidth,
        u_max: force_limits("accommodation.u_max", &a.u_max, nu)?,
    })
}

/// The file's format, its variant and guarantee names, and that it has inputs and outputs.
fn check_header(raw: &Raw) -> Result<(), SpecError> {
    if raw.format != FORMAT {
        return Err(SpecError::Format(raw.format.clone()));
    }
    if raw.variant.is_empty()
        || !raw
            .variant
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_')
    {
        return Err(SpecError::Invalid(format!(
            "variant '{}' is not a valid model identifier",
            raw.variant
        )));
    }
    let g = &raw.guarantee;
    if g.name.is_empty()
        || !g
            .name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_')
        || !g.value.is_finite()
    {
        return Err(SpecError::Invalid(format!(
            "guarantee must have a variable name of letters, digits and _ and a finite value, \
             got '{}' = {}",
            g.name, g.value
        )));
    }
    if raw.inputs.is_empty() || raw.outputs.is_empty() {
        return Err(SpecError::Invalid(
            "a controller needs inputs and outputs".into(),
        ));
    }
    Ok(())
}

/// The blocks go together: a predictor forms the command alone; accommodation (dividing by the
/// effectiveness estimate), anti-windup (the compensator) and the detector (which only watches)
/// in any combination, the first two with the same limits.
fn check_blocks(raw: &Raw) -> Result<(), SpecError> {
    let blocks: Vec<&str> = [
        ("accommodation", raw.accommodation.is_some()),
        ("anti_windup", raw.anti_windup.is_some()),
        ("fault_detection", raw.fault_detection.is_some()),
        ("predictor", raw.predictor.is_some()),
    ]
    .into_iter()
    .filter_map(|(name, present)| present.then_some(name))
    .collect();
    if blocks.len() > 1 && blocks.contains(&"predictor") {
        return Err(SpecError::Invalid(format!(
            "a controller with a predictor has no other block (accommodation, anti_windup, \
             fault_detection); this one has {blocks:?}"
        )));
    }
    if let (Some(acc), Some(aw)) = (&raw.accommodation, &raw.anti_windup) {
        if acc.u_max != aw.u_max {
            return Err(SpecError::Invalid(format!(
                "accommodation.u_max {:?} and anti_windup.u_max {:?} differ: both are the \
                 actuators' limits (the parameters u_max, u_max_seat)",
                acc.u_max, aw.u_max
            )));
        }
    }
    Ok(())
}

/// The anti-windup block of a controller whose `D` is `d_k` (`nu × ny`).
fn anti_windup(
    aw: &controller_file::AntiWindup,
    d_k: &[Vec<f64>],
    ny: usize,
    nu: usize,
) -> Result<AntiWindup, SpecError> {
    let m = aw.a.len();
    let d = if aw.d.is_empty() {
        DMatrix::zeros(ny, nu)
    } else {
        matrix("anti_windup.D", &aw.d, ny, nu)?
    };
    // The command would depend on itself where the controller's D reads an input that `D`
    // feeds the forces through to (a state feedback's D on the states beside accelerometers
    // only its filters read is fine: `D_K D = 0`).
    let d_k = matrix("D", d_k, nu, ny)?;
    if (&d_k * &d).iter().any(|v| *v != 0.0) {
        return Err(SpecError::Invalid(
            "anti_windup.D feeds the forces through to inputs the controller's D reads \
             (D_K anti_windup.D is not zero): the command would depend on itself"
                .into(),
        ));
    }
    Ok(AntiWindup {
        a: matrix("anti_windup.A", &aw.a, m, m)?,
        b: matrix("anti_windup.B", &aw.b, m, nu)?,
        c: matrix("anti_windup.C", &aw.c, ny, m)?,
        f: matrix("anti_windup.F", &aw.f, nu, m)?,
        d,
        u_max: force_limits("anti_windup.u_max", &aw.u_max, nu)?,
    })
}

/// The fault detection block.
fn fault_detection(
    fd: &controller_file::FaultDetection,
    ny: usize,
    nu: usize,
) -> Result<FaultDetection, SpecError> {
    if !(fd.threshold > 0.0 && fd.threshold.is_finite()) {
        return Err(SpecError::Invalid(format!(
            "fault_detection.threshold must be finite and > 0, found {}",
            fd.threshold
        )));
    }
    let (m, nr) = (fd.a.len(), fd.c.len());
    if nr == 0 {
        return Err(SpecError::Invalid(
            "fault_detection needs at least one residual".into(),
        ));
    }
    Ok(FaultDetection {
        a: matrix("fault_detection.A", &fd.a, m, m)?,
        b: matrix("fault_detection.B", &fd.b, m, ny)?,
        b_u: matrix("fault_detection.B_u", &fd.b_u, m, nu)?,
        c: matrix("fault_detection.C", &fd.c, nr, m)?,
        d: matrix("fault_detection.D", &fd.d, nr, ny)?,
        threshold: fd.threshold,
        input: fd.input,
    })
}

/// The steps the certificate found stable, and the first it did not (above them).
fn check_communication_steps(c: &controller_file::CommunicationSteps) -> Result<(), SpecError> {
    let positive = |v: f64| v.is_finite() && v > 0.0;
    if !positive(c.stable_up_to_s)
        || c.unstable_at_s
            .is_some_and(|u| !(positive(u) && u > c.stable_up_to_s))
    {
        return Err(SpecError::Invalid(format!(
            "communication_steps: stable_up_to_s must be finite and > 0 and unstable_at_s \
             above it, found {} and {:?}",
            c.stable_up_to_s, c.unstable_at_s
        )));
    }
    Ok(())
}

/// At `θ = 0` the predictor is the file's controller: `C = K S_ξ`, `D = K S_y`,
/// `A = A_ξ + B_ξu K S_ξ`, `B = B_ξ + B_ξu K S_y` (to rounding). A file whose blocks disagree
/// was edited or corrupted.
fn check_undelayed(spec: &Spec, p: &Predictor) -> Result<(), SpecError> {
    let ks = &p.k * &p.s_xi;
    let ky = &p.k * &p.s_y;
    let pairs = [
        ("C", &spec.lti.c, ks.clone()),
        ("D", &spec.lti.d, ky.clone()),
        ("A", &spec.lti.a, &p.a_xi + &p.b_xiu * &ks),
        ("B", &spec.lti.b, &p.b_xi + &p.b_xiu * &ky),
    ];
    for (name, given, implied) in pairs {
        if given.shape() != implied.shape() {
            return Err(SpecError::Invalid(format!(
                "predictor: {name} is {:?}, the predictor's blocks imply {:?}",
                given.shape(),
                implied.shape()
            )));
        }
        let scale = given.amax().max(implied.amax()).max(1.0);
        let error = (given - &implied).amax();
        // NaN-aware: a NaN difference fails too.
        if error.is_nan() || error > 1e-9 * scale {
            return Err(SpecError::Invalid(format!(
                "predictor: without delay it should be the controller A, B, C, D, but {name} \
                 differs by {error:e} (largest entry {scale:e})"
            )));
        }
    }
    Ok(())
}

impl Spec {
    pub fn from_json(text: &str) -> Result<Spec, SpecError> {
        let raw = Raw::from_json(text).map_err(|e| SpecError::Syntax(e.to_string()))?;
        check_header(&raw)?;
        let (n, ny, nu) = (raw.a.len(), raw.inputs.len(), raw.outputs.len());
        check_blocks(&raw)?;
        let anti_windup = raw
            .anti_windup
            .as_ref()
            .map(|aw| anti_windup(aw, &raw.d, ny, nu))
            .transpose()?;
        let fault_detection = raw
            .fault_detection
            .as_ref()
            .map(|fd| fault_detection(fd, ny, nu))
            .transpose()?;
        if fault_detection
            .as_ref()
            .is_some_and(|fd| fd.input == DetectorInput::ModelledForce)
            && raw.accommodation.is_none()
        {
            return Err(SpecError::Invalid(
                "fault_detection.input \"modelled_force\" needs the accommodation block, whose \
                 actuator model it reads"
                    .into(),
            ));
        }
        let predictor = raw
            .predictor
            .as_ref()
            .map(|p| predictor(p, ny, nu))
            .transpose()?;
        let accommodation = raw
            .accommodation
            .as_ref()
            .map(|a| accommodation(a, &raw.inputs, nu))
            .transpose()?;
        if let Some(c) = &raw.communication_steps {
            check_communication_steps(c)?;
        }
        let spec = Spec {
            communication_steps: raw.communication_steps,
            accommodation,
            anti_windup,
            fault_detection,
            predictor,
            lti: Lti::new(
                matrix("A", &raw.a, n, n)?,
                matrix("B", &raw.b, n, ny)?,
                matrix("C", &raw.c, nu, n)?,
                matrix("D", &raw.d, nu, ny)?,
            ),
            variant: raw.variant,
            description: raw.description,
            guarantee: raw.guarantee,
            inputs: raw.inputs,
            outputs: raw.outputs,
            content_hash: fmu_state::fnv1a(fmu_state::FNV_OFFSET, text.bytes()),
        };
        if let Some(p) = &spec.predictor {
            check_undelayed(&spec, p)?;
        }
        spec.check_names()?;
        Ok(spec)
    }

    /// Every signal's name once, none of them a name of a variable the runtime adds.
    fn check_names(&self) -> Result<(), SpecError> {
        let mut names: Vec<&str> = self
            .inputs
            .iter()
            .chain(&self.outputs)
            .map(|s| s.name.as_str())
            .collect();
        names.sort_unstable();
        if let Some(w) = names.windows(2).find(|w| w[0] == w[1]) {
            return Err(SpecError::Invalid(format!(
                "signal name '{}' appears twice",
                w[0]
            )));
        }
        // The variables the runtime adds must not share a name with a signal.
        let generated = self.generated_names();
        if let Some(clash) = names.iter().find(|n| generated.iter().any(|g| g == *n)) {
            return Err(SpecError::Invalid(format!(
                "signal name '{clash}' is also the name of a variable the controller FMU adds \
                 (reserved here: {generated:?})"
            )));
        }
        Ok(())
    }

    /// The names of the variables the runtime adds beside the signals: the guarantee, the
    /// anti-windup limits, the fault detector's, the predictor's delay, the effectiveness estimates.
    pub fn generated_names(&self) -> Vec<String> {
        let mut names = vec![self.guarantee.name.clone()];
        let mut add = |more: &[&str]| names.extend(more.iter().map(|n| n.to_string()));
        if self.default_limits().is_some() {
            add(&["u_max", "u_max_seat"]);
        }
        if self.fault_detection.is_some() {
            add(&["residual_norm", "fault_detected", "fault_threshold"]);
        }
        if self.predictor.is_some() {
            add(&["tau"]);
        }
        if self.accommodation.is_some() {
            names.extend((0..self.outputs.len()).map(|i| self.rho_hat_name(i)));
            names.push("actuator_bandwidth".into());
        }
        names
    }

    /// The default force limits of a controller that has them as parameters (`u_max`,
    /// `u_max_seat`): anti-windup and fault accommodation.
    pub fn default_limits(&self) -> Option<&[f64]> {
        match (&self.anti_windup, &self.accommodation, &self.predictor) {
            (Some(aw), _, _) => Some(&aw.u_max),
            (None, Some(acc), _) => Some(&acc.u_max),
            (None, None, Some(p)) => p.u_max.as_deref(),
            (None, None, None) => None,
        }
    }

    /// The effectiveness estimate's variable name for output `i` (`u_fl` → `rho_hat_fl`).
    pub fn rho_hat_name(&self, i: usize) -> String {
        let o = &self.outputs[i].name;
        format!("rho_hat_{}", o.strip_prefix("u_").unwrap_or(o))
    }

    pub fn order(&self) -> usize {
        self.lti.order()
    }
}
