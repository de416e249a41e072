//! The controller FMUs (`dist/hinf_sf.fmu`, …): one generic runtime on `fmu-core`. Each variant
//! is this library packaged with its own `resources/controller.json` (from `synth`), under its
//! own `modelIdentifier`; the variable table, and so the GUID, derive from that file, so a
//! missing, corrupt or mismatched `controller.json` makes `fmi2Instantiate` fail with a message.
//!
//! Inputs have exactly the names of the plant outputs the controller reads; outputs are
//! `u_fl … u_seat`: a master connects any controller FMU by name and swaps one for another.
//! A dynamic controller is stepped exactly (matrix exponential, measurements held over the
//! communication step, which is what a sampled-data implementation does).

pub mod accommodation;
pub mod predictor;
pub mod schur;
pub mod spec;

use fmu_core::description::{ArrayParameter, SampleClock};
use fmu_core::fmu_state::{StateReader, StateWriter};
use fmu_core::{
    Capabilities, Causality, DefaultExperiment, DependencyKind, Model, ModelDescription,
    ModelError, ValueReference, Variable,
};
use linsys::{discretize, mat_vec_sum, mat_vec_sum_quasi_upper, Discretization};
use nalgebra::DVector;
use spec::Spec;
use std::path::Path;

/// Value references: inputs from 0, outputs from 1000, the guarantee at 2000, force limits of an
/// anti-windup controller from 3000, a fault detector's variables from 4000, a predictor's
/// delay at 5000 and its master order at 5001, the effectiveness estimates of fault accommodation from 6000 and its actuators'
/// bandwidth at 7000, FMI 3.0's sample clock at 8000 and its matrices (arrays) from 9000.
pub mod vr {
    pub const INPUT: u32 = 0;
    pub const OUTPUT: u32 = 1000;
    pub const GUARANTEE: u32 = 2000;
    pub const LIMIT: u32 = 3000;
    pub const RESIDUAL_NORM: u32 = 4000;
    pub const FAULT_DETECTED: u32 = 4001;
    pub const FAULT_THRESHOLD: u32 = 4002;
    pub const DELAY: u32 = 5000;
    pub const MASTER_ORDER: u32 = 5001;
    pub const RHO_HAT: u32 = 6000;
    pub const ACTUATOR_BANDWIDTH: u32 = 7000;
    pub const SAMPLE_CLOCK: u32 = 8000;
    pub const MATRICES: u32 = 9000;
}

/// The sample period of FMI 3.0's clock, in seconds: the communication step the certificates predict
/// the loop at (`DefaultExperiment`'s step).
pub const SAMPLE_PERIOD: f64 = 1e-3;

/// The order in which the master exchanges values at a communication point `t_k`, as a
/// predictor must know it: its commands in flight are those the plant applies, and when each
/// reaches the plant depends on the order (parameter `master_order`). With it set to the
/// master's order the loop is the Gauss–Seidel one's: bit for bit in the controller-first
/// order, and in the Jacobi order that of a Gauss–Seidel master with every command one step
/// later (a delay of `tau` plus the step), which the certificate predicts
/// (`synth::predict::sampled::order_check`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MasterOrder {
    /// The plant's outputs to the controller, its command read and set, then every FMU steps:
    /// the command read at `t_k` is computed from the inputs at `t_k`.
    GaussSeidel = 0,
    /// Every output read before any input is set: the command read at `t_k` is the one the
    /// predictor computed at `t_{k−1}`, predicting over `tau` plus that step.
    Jacobi = 1,
    /// The controller given the plant's outputs and stepped first, its command then driving the
    /// plant over the step it took: the command read after a step is the one it computed at
    /// the step's start.
    ControllerFirst = 2,
}

impl MasterOrder {
    const DESCRIPTION: &'static str = "The order in which the master exchanges values, which the predictor's commands in flight depend on: 0 Gauss-Seidel (the plant's outputs set on the controller before its command is read; FMPy's fixed-step master), 1 Jacobi (every output read before any input is set, as libcosim's fixed-step algorithm does: the command read at t is the one computed at the previous communication point, predicted over tau plus that step; exact at a constant step), 2 controller first (stepped before the plant: the command read after a step is the one computed at its start)";

    fn from_i32(v: i32) -> Result<Self, String> {
        match v {
            0 => Ok(MasterOrder::GaussSeidel),
            1 => Ok(MasterOrder::Jacobi),
            2 => Ok(MasterOrder::ControllerFirst),
            _ => Err(format!(
                "master_order must be 0 (Gauss-Seidel), 1 (Jacobi) or 2 (controller first), got {v}"
            )),
        }
    }
}

/// An anti-windup controller's force-limit parameters, named like the plant's (`u_max` for the
/// corner actuators, `u_max_seat` for the seat), so a master sets both by the same name.
fn limit_groups(spec: &Spec) -> Vec<(&'static str, Vec<usize>)> {
    let mut groups: Vec<(&'static str, Vec<usize>)> = Vec::new();
    for (i, s) in spec.outputs.iter().enumerate() {
        let name = if s.name.ends_with("seat") {
            "u_max_seat"
        } else {
            "u_max"
        };
        match groups.iter_mut().find(|g| g.0 == name) {
            Some(g) => g.1.push(i),
            None => groups.push((name, vec![i])),
        }
    }
    groups
}

/// Each command within `±` its force limit (every command, when there are limits).
fn clamp(u: &mut DVector<f64>, limits: &[f64]) {
    for (u, l) in u.iter_mut().zip(limits) {
        *u = u.clamp(-l, *l);
    }
}

/// A predictor's command `yc` for inputs `y` and own states `x`, and `u` the command sent:
/// clamped to the actuators' limits (when the file gives them), so that the commands in flight
/// the predictor integrates are the forces the actuators apply.
fn predicted_command(
    p: &predictor::Runtime,
    y: &DVector<f64>,
    x: &DVector<f64>,
    limits: &[f64],
    yc: &mut DVector<f64>,
    u: &mut DVector<f64>,
) {
    p.command(y, x.as_slice(), yc);
    u.copy_from(yc);
    clamp(u, limits);
}

pub const RESOURCE_FILE: &str = "controller.json";

/// Read and check `resources/controller.json`.
pub fn load_spec(resources: Option<&Path>) -> Result<Spec, String> {
    let dir = resources.ok_or("this controller FMU needs its resources/controller.json, but the importer passed no resource location")?;
    let path = dir.join(RESOURCE_FILE);
    let text = std::fs::read_to_string(&path)
        .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    Spec::from_json(&text).map_err(|e| format!("{}: {e}", path.display()))
}

/// The variable table of a controller FMU.
pub fn description_for(spec: &Spec) -> ModelDescription {
    let mut vars = signal_variables(spec);
    let g = &spec.guarantee;
    vars.push(Variable::real(
        g.name.clone(),
        vr::GUARANTEE,
        Causality::CalculatedParameter,
        unit(&g.unit),
        g.description.clone(),
    ));
    vars.extend(parameter_variables(spec));
    ModelDescription {
        model_name: spec.variant.clone(),
        model_identifier: spec.variant.clone(),
        guid: String::new(),
        description: spec.description.clone(),
        version: format!("{}+{:016x}", env!("CARGO_PKG_VERSION"), spec.content_hash),
        capabilities: Capabilities::exact_stepping(false),
        model_exchange: None,
        default_experiment: DefaultExperiment {
            start_time: 0.0,
            stop_time: 10.0,
            step_size: SAMPLE_PERIOD,
            tolerance: 1e-6,
        },
        variables: vars,
        arrays: matrices(spec),
        terminals: Vec::new(),
        sample_clock: Some(sample_clock()),
    }
    .with_suspension_terminals()
    .with_derived_guid()
}

/// The inputs (the plant outputs read) and the commands, with their dependencies.
fn signal_variables(spec: &Spec) -> Vec<Variable> {
    let mut vars = Vec::new();
    for (i, s) in spec.inputs.iter().enumerate() {
        vars.push(
            Variable::real(
                s.name.clone(),
                vr::INPUT + i as u32,
                Causality::Input,
                unit(&s.unit),
                format!("Plant output {} read by the controller", s.name),
            )
            .with_start(0.0),
        );
    }
    // How a measurement enters a command: through the predictor's `K e^{Aθ} S_y` (θ the fixed
    // parameter `tau`; clamped when it has force limits), through the anti-windup saturation,
    // or as the constant `D` of the resource file (divided by the effectiveness estimate, a
    // state, with accommodation). In Initialization Mode the state is zero, so a command also
    // reads its saturation limit or the delay and the master's order, and nothing else.
    let clamped = spec.predictor.as_ref().is_some_and(|p| p.u_max.is_some());
    let kind = if spec.predictor.is_some() && !clamped {
        DependencyKind::Fixed
    } else if spec.anti_windup.is_some() || spec.accommodation.is_some() || clamped {
        DependencyKind::Dependent
    } else {
        DependencyKind::Constant
    };
    let limits = limit_groups(spec);
    let initial = |i: usize| -> Vec<String> {
        let limit = || {
            limits
                .iter()
                .filter(|g| g.1.contains(&i))
                .map(|g| g.0.to_string())
        };
        // A predictor's command at the start: over `tau`, and none yet in the Jacobi order.
        let predicted = || ["tau", "master_order"].map(String::from).into_iter();
        match &spec.predictor {
            Some(_) if clamped => predicted().chain(limit()).collect(),
            Some(_) => predicted().collect(),
            None if spec.anti_windup.is_some() => limit().collect(),
            None => Vec::new(),
        }
    };
    for (i, s) in spec.outputs.iter().enumerate() {
        // A predictor's feedthrough is K e^{Aθ} S_y, θ a parameter: every input S_y reads.
        let feeds = |j: usize| match &spec.predictor {
            Some(p) => p.s_y.column(j).iter().any(|v| *v != 0.0),
            None => spec.lti.d[(i, j)] != 0.0,
        };
        let deps: Vec<String> = (0..spec.inputs.len())
            .filter(|&j| feeds(j))
            .map(|j| spec.inputs[j].name.clone())
            .collect();
        vars.push(
            Variable::real(
                s.name.clone(),
                vr::OUTPUT + i as u32,
                Causality::Output,
                unit(&s.unit),
                format!("Force command for plant input {}", s.name),
            )
            .depending_on(deps, kind)
            .initially_depending_on(initial(i)),
        );
    }
    vars
}

/// The parameters a part of the controller file brings: force limits, the fault detector's
/// threshold, the predictor's delay and master order, the actuators' bandwidth.
fn parameter_variables(spec: &Spec) -> Vec<Variable> {
    let mut vars = Vec::new();
    if let Some(u_max) = spec.default_limits() {
        for (k, (name, outputs)) in limit_groups(spec).into_iter().enumerate() {
            let what = outputs
                .iter()
                .map(|&i| spec.outputs[i].name.as_str())
                .collect::<Vec<_>>()
                .join(", ");
            let role = if spec.anti_windup.is_some() && spec.accommodation.is_some() {
                format!("the anti-windup compensator saturates {what} at, and the effectiveness estimate reads their commands saturated at")
            } else if spec.anti_windup.is_some() {
                format!("the anti-windup compensator saturates {what} at")
            } else if spec.predictor.is_some() {
                format!("{what} are clamped to, the forces the predictor integrates as in flight")
            } else {
                format!("of the actuators {what} drive: the effectiveness estimate reads their commands saturated at it")
            };
            vars.push(
                Variable::real(
                    name,
                    vr::LIMIT + k as u32,
                    Causality::Parameter,
                    "N",
                    format!("Force limit {role} (set it equal to the plant's {name})"),
                )
                .with_start(u_max[outputs[0]])
                .with_min(0.0),
            );
        }
    }
    if let Some(fd) = &spec.fault_detection {
        let deps: Vec<String> = (0..spec.inputs.len())
            .filter(|&j| fd.d.column(j).iter().any(|v| *v != 0.0))
            .map(|j| spec.inputs[j].name.clone())
            .collect();
        let residual = match fd.input {
            spec::DetectorInput::Command => "Detection residual: the smallest actuator force deficit consistent with the measurements (0 when healthy, whatever the road)",
            spec::DetectorInput::ModelledForce => "Detection residual: the actuators' force deficits, the forces their commands make through the actuator model (actuator_bandwidth, u_max, u_max_seat) less the load cells' readings, low-passed (0 when healthy, whatever the road)",
        };
        vars.push(
            Variable::real(
                "residual_norm",
                vr::RESIDUAL_NORM,
                Causality::Output,
                "N",
                residual,
            )
            .depending_on(deps.clone(), DependencyKind::Dependent),
        );
        vars.push(Variable::boolean("fault_detected", vr::FAULT_DETECTED, Causality::Output, "True from the first communication point at which residual_norm exceeded fault_threshold (latched until re-initialisation)").depending_on(deps, DependencyKind::Dependent).initially_depending_on(vec!["fault_threshold".into()]));
        vars.push(
            Variable::real(
                "fault_threshold",
                vr::FAULT_THRESHOLD,
                Causality::Parameter,
                "N",
                "Residual norm above which fault_detected is raised",
            )
            .with_start(fd.threshold)
            .with_min(0.0),
        );
    }
    if let Some(p) = &spec.predictor {
        vars.push(
            Variable::real(
                "tau",
                vr::DELAY,
                Causality::Parameter,
                "s",
                "Actuator delay the predictor compensates (set it equal to the plant's tau); it predicts over at least one communication step",
            )
            .with_start(0.0)
            .with_min(0.0)
            .with_max(p.delay_max),
        );
        vars.push(Variable::integer(
            "master_order",
            vr::MASTER_ORDER,
            Causality::Parameter,
            MasterOrder::GaussSeidel as i32,
            MasterOrder::DESCRIPTION,
        ));
    }
    if let Some(acc) = &spec.accommodation {
        for (i, &k) in acc.force_inputs.iter().enumerate() {
            let (out, force) = (&spec.outputs[i].name, &spec.inputs[k].name);
            vars.push(
                Variable::real(
                    spec.rho_hat_name(i),
                    vr::RHO_HAT + i as u32,
                    Causality::Output,
                    "1",
                    format!(
                        "Estimated effectiveness of the actuator {out} drives: sqrt of the mean \
                         square of {force} over that of {out}, averaged over {} s, in [{}, 1]; \
                         {out} is the controller's command divided by it",
                        acc.time_constant, acc.rho_min
                    ),
                )
                .depending_on(Vec::new(), DependencyKind::Dependent),
            );
        }
        vars.push(
            Variable::real(
                "actuator_bandwidth",
                vr::ACTUATOR_BANDWIDTH,
                Causality::Parameter,
                "Hz",
                "Bandwidth of the actuators' first-order lag, which the effectiveness estimate \
                 (and a load-cell fault detector) model between command and applied force; set \
                 it equal to the plant's actuator_bandwidth (0 = ideal actuators)",
            )
            .with_start(acc.actuator_bandwidth)
            .with_min(0.0)
            .with_max(spec::MAX_ACTUATOR_BANDWIDTH),
        );
    }
    vars
}

/// FMI 3.0's sample clock: periodic, every [`SAMPLE_PERIOD`].
fn sample_clock() -> SampleClock {
    SampleClock {
        name: "sample".into(),
        value_reference: vr::SAMPLE_CLOCK,
        interval: SAMPLE_PERIOD,
        description: format!(
            "The controller's sample clock (FMI 3.0, eventModeUsed = true): at each tick the \
             inputs are sampled and the commands computed and held until the next, {} ms \
             later. Without Event Mode (and in FMI 2.0) the controller is sampled at every \
             communication point instead",
            SAMPLE_PERIOD * 1e3
        ),
    }
}

/// FMI 3.0's view of the controller's matrices, `A_c`, `B_c`, `C_c`, `D_c` (value references
/// 9000 to 9003; those with elements), as the resource file gives them: arrays a control engineer reads from the FMU
/// (`fmi3GetFloat64`) to check a design without unpacking it.
fn matrices(spec: &Spec) -> Vec<ArrayParameter> {
    let (n, ny, nu) = (spec.order(), spec.inputs.len(), spec.outputs.len());
    let names = |count: usize, what: &str| -> String {
        let signals = match what {
            "inputs" => &spec.inputs,
            _ => &spec.outputs,
        };
        let listed: Vec<&str> = signals
            .iter()
            .take(count)
            .map(|s| s.name.as_str())
            .collect();
        format!("{what} {}", listed.join(", "))
    };
    let lti = &spec.lti;
    [
        ("A_c", &lti.a, format!("the state matrix ({n} × {n})")),
        ("B_c", &lti.b, format!("the input matrix ({n} × {ny}; columns: {})", names(ny, "inputs"))),
        ("C_c", &lti.c, format!("the output matrix ({nu} × {n}; rows: {})", names(nu, "outputs"))),
        ("D_c", &lti.d, format!("the feedthrough ({nu} × {ny}): rows the outputs, columns the inputs, in the variables' order")),
    ]
    .into_iter()
    .enumerate()
    .filter(|(_, (_, m, _))| !m.is_empty())
    .map(|(k, (name, m, what))| ArrayParameter {
        name: name.into(),
        value_reference: vr::MATRICES + k as u32,
        description: format!(
            "The controller's {what}, from controller.json: dx_c/dt = A_c x_c + B_c y, \
             y_c = C_c x_c + D_c y (before anti-windup, prediction or accommodation act), \
             row-major"
        ),
        dimensions: vec![m.nrows(), m.ncols()],
        values: m.transpose().as_slice().to_vec(),
    })
    .collect()
}

/// Units the runtime knows, as `'static` strings.
fn unit(u: &str) -> &'static str {
    match u {
        "m" => "m",
        "m/s" => "m/s",
        "m/s2" => "m/s2",
        "rad" => "rad",
        "rad/s" => "rad/s",
        "rad/s2" => "rad/s2",
        "N" => "N",
        "s" => "s",
        "1" => "1",
        _ => "",
    }
}

pub struct Controller {
    spec: Spec,
    /// The state: the controller's, then the anti-windup compensator's `η`, then the fault
    /// detector's `ξ`; in the real Schur basis of [`Readout`] where it has one (`z = Qᵀ x`).
    x: DVector<f64>,
    y: DVector<f64>,
    /// Force limit of each output (anti-windup and accommodation only), and the parameters that
    /// set them.
    limits: Vec<f64>,
    limit_groups: Vec<(&'static str, Vec<usize>)>,
    /// Fault detector: its threshold and the latched flag.
    threshold: f64,
    detected: bool,
    /// The stepped system `ẋ = A x + B v`, `v = y`, or `v = [y; u − y_c]` with anti-windup, in
    /// the state's basis.
    a: nalgebra::DMatrix<f64>,
    b: nalgebra::DMatrix<f64>,
    cache: Option<Stepped>,
    /// Where the anti-windup compensator can rest and its products be skipped ([`Rest`]).
    rest: Option<Rest>,
    /// What reads the state (every controller without a predictor), and its basis.
    readout: Option<Readout>,
    /// The controller's own output `y_c` and the command sent `u` for the current state and
    /// inputs (`valid` until an input, a limit or the state changes): a master reading the five
    /// outputs one by one costs one evaluation.
    yc: DVector<f64>,
    u: DVector<f64>,
    valid: bool,
    /// What the controller reads: `y`, or `y − C η` with anti-windup.
    w: DVector<f64>,
    /// Work vectors (a step allocates nothing): the stepped input, the next state, the
    /// detector's residual.
    v: DVector<f64>,
    next: DVector<f64>,
    r: DVector<f64>,
    /// A predictor over the actuators' delay, with the delay set for the next run.
    predictor: Option<predictor::Runtime>,
    /// The last communication step warned about (by its bits): a master that keeps its step
    /// hears it once.
    warned_step: Option<u64>,
    /// The last step taken: a step within the rounding of its time points of it is taken as
    /// it ([`linsys::same_step`]), so the discretisations keyed on it are reused.
    last_step: Option<f64>,
    tau: f64,
    /// The order the master exchanges values in (parameter `master_order`, as set: checked with
    /// the parameters), for a predictor.
    order: i32,
    /// In the Jacobi and controller-first orders, the command the predictor computed at the
    /// last step's start, which the master reads after the step (`None` before the first), and
    /// the one before it.
    sent: Option<DVector<f64>>,
    sent_before: Option<DVector<f64>>,
    /// Fault accommodation: the effectiveness estimator the commands are divided by.
    estimator: Option<accommodation::Estimator>,
}

/// An anti-windup compensator at rest: with no actuator saturated its input `u_a − y_c` is
/// exactly zero, so from `η = 0` its state stays exactly zero, and every product with `η` or
/// with its input is a product of exact zeros. Where the compensator's states and inputs come
/// last in the stepped system (no fault detector after them), a step at rest is the leading
/// block's: the filter's rows, its own states' columns and the measurements'. The same values
/// as the whole product, bit for bit (an accumulator that starts at `+0` and adds `±0` is
/// unchanged), at 61 % of its multiply-adds for `hinf_of` (the filter's 50 states and 17
/// inputs out of 66 and 22: `docs/performance.md`).
#[derive(Debug, Clone, Copy)]
struct Rest {
    /// The filter's states, which lead the state.
    states: usize,
    /// The measurements, which lead the stepped input.
    inputs: usize,
}

impl Rest {
    /// Where `spec`'s compensator can rest: it has one, and no fault detector follows it.
    fn of(spec: &Spec) -> Option<Rest> {
        (spec.anti_windup.is_some() && spec.fault_detection.is_none()).then(|| Rest {
            states: spec.order(),
            inputs: spec.inputs.len(),
        })
    }

    /// Whether the compensator's part of the state `x` is exact zeros.
    fn state_at_rest(&self, x: &[f64]) -> bool {
        x[self.states..].iter().all(|v| *v == 0.0)
    }

    /// The compensator's rows of `d` off its own block set to the exact zeros they are: it
    /// reads neither the filter nor the measurements (rounding could leave a `±0` only).
    fn decouple(&self, d: &mut Discretization) {
        let (n, ny) = (self.states, self.inputs);
        d.phi.view_mut((n, 0), (d.phi.nrows() - n, n)).fill(0.0);
        let rows = d.gamma_hold.nrows() - n;
        d.gamma_hold.view_mut((n, 0), (rows, ny)).fill(0.0);
    }
}

/// A step's discretisation of the stepped system and, with a compensator that can rest, the
/// leading blocks a step at rest reads (`Φ`'s and `Γ`'s filter rows over the filter's states
/// and the measurements).
struct Stepped {
    d: Discretization,
    rest: Option<(nalgebra::DMatrix<f64>, nalgebra::DMatrix<f64>)>,
}

/// What reads the stepped system's state `x = [xc; η; ξ]` (or, in its real Schur basis, `z`,
/// `x = Q z`): the controller's own output `y_c = [C, −D C_aw, 0] x + D y` (it reads
/// `w = y − C_aw η`), the compensator's gain `F η = [0, F, 0] x` (absent where `F = 0`, the
/// plain model recovery), the detector's residual `r = [0, 0, C_d] x + D_d y`.
#[derive(Debug, Clone)]
struct Readout {
    basis: Option<schur::SchurBasis>,
    yc: nalgebra::DMatrix<f64>,
    /// `yc`'s columns over the filter's states: what reads a state whose compensator rests.
    yc_rest: Option<nalgebra::DMatrix<f64>>,
    f: Option<nalgebra::DMatrix<f64>>,
    residual: Option<nalgebra::DMatrix<f64>>,
}

impl Readout {
    /// For the stepped system of `total` states, in `basis` ([`schur::SchurBasis`]) or, with
    /// none, in its own.
    fn new(spec: &Spec, total: usize, basis: Option<schur::SchurBasis>) -> Readout {
        let (n, nu) = (spec.order(), spec.outputs.len());
        let m = spec.anti_windup.as_ref().map_or(0, |aw| aw.a.nrows());
        let mut yc = nalgebra::DMatrix::zeros(nu, total);
        yc.view_mut((0, 0), (nu, n)).copy_from(&spec.lti.c);
        let mut f = None;
        if let Some(aw) = &spec.anti_windup {
            yc.view_mut((0, n), (nu, m))
                .copy_from(&(-&spec.lti.d * &aw.c));
            if aw.f.iter().any(|v| *v != 0.0) {
                let mut rows = nalgebra::DMatrix::zeros(nu, total);
                rows.view_mut((0, n), (nu, m)).copy_from(&aw.f);
                f = Some(rows);
            }
        }
        let residual = spec.fault_detection.as_ref().map(|fd| {
            let mut rows = nalgebra::DMatrix::zeros(fd.c.nrows(), total);
            rows.view_mut((0, n + m), (fd.c.nrows(), fd.c.ncols()))
                .copy_from(&fd.c);
            rows
        });
        let (yc, f, residual) = match &basis {
            Some(s) => (
                s.reading(&yc),
                f.map(|f| s.reading(&f)),
                residual.map(|r| s.reading(&r)),
            ),
            None => (yc, f, residual),
        };
        let yc_rest = Rest::of(spec).map(|rest| yc.columns(0, rest.states).into_owned());
        Readout {
            basis,
            yc,
            yc_rest,
            f,
            residual,
        }
    }
}

/// `(A, B)` of the stepped system, its state `[xc; η; ξ]` and its input `[y; u_a − y_c; d]`,
/// each block present where its part of the file is: the controller `ẋc = A_K xc + B_K w`
/// reading `w = y − C η − D (u_a − y_c)` with the anti-windup compensator
/// `η̇ = A_aw η + B_aw (u_a − y_c)` (`u_a` the force it counts as applied:
/// [`Controller::anti_windup_input`]), and the fault detector `ξ̇ = A_d ξ + B_d y + B_du d`
/// (`d` the command sent, or the force the actuator model says is applied).
fn stepped_system(spec: &Spec) -> (nalgebra::DMatrix<f64>, nalgebra::DMatrix<f64>) {
    let (n, ny, nu) = (spec.order(), spec.inputs.len(), spec.outputs.len());
    let m = spec.anti_windup.as_ref().map_or(0, |aw| aw.a.nrows());
    let q = spec.fault_detection.as_ref().map_or(0, |fd| fd.a.nrows());
    let (na, nd) = (
        if spec.anti_windup.is_some() { nu } else { 0 },
        if spec.fault_detection.is_some() {
            nu
        } else {
            0
        },
    );
    let mut a = nalgebra::DMatrix::zeros(n + m + q, n + m + q);
    let mut b = nalgebra::DMatrix::zeros(n + m + q, ny + na + nd);
    a.view_mut((0, 0), (n, n)).copy_from(&spec.lti.a);
    b.view_mut((0, 0), (n, ny)).copy_from(&spec.lti.b);
    if let Some(aw) = &spec.anti_windup {
        a.view_mut((0, n), (n, m))
            .copy_from(&(-&spec.lti.b * &aw.c));
        a.view_mut((n, n), (m, m)).copy_from(&aw.a);
        b.view_mut((0, ny), (n, nu))
            .copy_from(&(-&spec.lti.b * &aw.d));
        b.view_mut((n, ny), (m, nu)).copy_from(&aw.b);
    }
    if let Some(fd) = &spec.fault_detection {
        a.view_mut((n + m, n + m), (q, q)).copy_from(&fd.a);
        b.view_mut((n + m, 0), (q, ny)).copy_from(&fd.b);
        b.view_mut((n + m, ny + na), (q, nu)).copy_from(&fd.b_u);
    }
    (a, b)
}

/// The sizes of the stepped system's diagonal blocks, `[n, m, q]`: the controller's, the
/// compensator's, the detector's (zero where absent). Below them `A` is zero
/// ([`stepped_system`]).
fn stepped_blocks(spec: &Spec) -> [usize; 3] {
    [
        spec.order(),
        spec.anti_windup.as_ref().map_or(0, |aw| aw.a.nrows()),
        spec.fault_detection.as_ref().map_or(0, |fd| fd.a.nrows()),
    ]
}

impl Controller {
    /// What the saved state's numbers are: the state in the real Schur basis, or in the
    /// stepped system's own (a predictor's, or where the Schur iteration did not converge).
    fn basis_tag(&self) -> u64 {
        match self.readout.as_ref().and_then(|r| r.basis.as_ref()) {
            Some(_) => 0x5343_4855_5242_414c, // "SCHURBAL": balanced, taken block by block
            None => 0x4f57_4e42_4153_4953,    // "OWNBASIS"
        }
    }

    /// The compensator's blocks where it rests now: its state is exact zeros.
    fn resting(&self) -> Option<Rest> {
        self.rest
            .filter(|rest| rest.state_at_rest(self.x.as_slice()))
    }

    /// Bring `y_c` and `u` up to date. With anti-windup the controller reads `y − C η` (less
    /// `D_aw (u − y_c)`, which only its state sees: the controller's `D` reads no input `D_aw`
    /// feeds, `D D_aw = 0`) and `u = sat(y_c + F η)`, with fault accommodation
    /// `sat((y_c + F η) / ρ̂)`; otherwise `u = y_c = C xc + D y` (divided by `ρ̂` with
    /// accommodation).
    fn update_commands(&mut self) {
        if self.valid {
            return;
        }
        if let Some(p) = &self.predictor {
            predicted_command(p, &self.y, &self.x, &self.limits, &mut self.yc, &mut self.u);
            self.valid = true;
            return;
        }
        let r = self
            .readout
            .as_ref()
            .expect("a controller without a predictor");
        let resting = self.resting();
        let (yc, x) = match (resting, &r.yc_rest) {
            (Some(rest), Some(yc)) => (yc, &self.x.as_slice()[..rest.states]),
            _ => (&r.yc, self.x.as_slice()),
        };
        mat_vec_sum(
            self.yc.as_mut_slice(),
            &[(yc, x), (&self.spec.lti.d, self.y.as_slice())],
        );
        self.u.copy_from(&self.yc);
        // `F η`, zero at rest.
        if let (Some(f), None) = (&r.f, resting) {
            self.u.gemv(1.0, f, &self.x, 1.0);
        }
        if let Some(e) = &self.estimator {
            e.compensate(self.u.as_mut_slice());
        }
        if self.spec.anti_windup.is_some() {
            clamp(&mut self.u, &self.limits);
        }
        self.valid = true;
    }

    /// The compensator's input for actuator `i`, `u_a − y_c`: the force counted as applied less
    /// the linear command. That is the command sent, `sat(y_c + F η)`, or with fault
    /// accommodation the design's force it makes, `ρ̂ sat((y_c + F η) / ρ̂)` (the actuator of
    /// effectiveness `ρ̂` saturates at `ρ̂` times its limit in the design's units), which the load
    /// cells measure once the estimate has settled.
    fn anti_windup_input(&self, i: usize) -> f64 {
        let rho = self.estimator.as_ref().map_or(1.0, |e| e.rho_hat(i));
        rho * self.u[i] - self.yc[i]
    }

    /// The effectiveness estimator takes in the step that starts now (the inputs and the
    /// commands sent, both as of its start); the commands are stale after it.
    fn step_estimator(&mut self, step: f64) {
        if let Some(e) = &mut self.estimator {
            e.step(self.y.as_slice(), self.u.as_slice(), &self.limits, step);
        }
        self.valid = false;
    }

    /// `‖r‖` of the fault detector (0 without one).
    fn residual_norm(&mut self) -> f64 {
        let (Some(fd), Some(rows)) = (
            &self.spec.fault_detection,
            self.readout.as_ref().and_then(|r| r.residual.as_ref()),
        ) else {
            return 0.0;
        };
        mat_vec_sum(
            self.r.as_mut_slice(),
            &[(rows, self.x.as_slice()), (&fd.d, self.y.as_slice())],
        );
        self.r.norm()
    }

    fn fault_detected(&mut self) -> bool {
        self.detected || self.residual_norm() > self.threshold
    }

    /// Command `i` sent to the plant.
    fn output(&mut self, i: usize) -> f64 {
        if self.predictor.is_some() {
            match (self.master_order(), &self.sent) {
                (MasterOrder::GaussSeidel, _) | (MasterOrder::ControllerFirst, None) => {}
                (_, Some(sent)) => return sent[i],
                // Jacobi before the first step: nothing computed yet, as with the car at rest.
                (MasterOrder::Jacobi, None) => return 0.0,
            }
        }
        self.update_commands();
        self.u[i]
    }

    /// `master_order` (Gauss–Seidel while it is not a valid order: the parameters' check
    /// refuses it before a step).
    fn master_order(&self) -> MasterOrder {
        MasterOrder::from_i32(self.order).unwrap_or(MasterOrder::GaussSeidel)
    }

    /// A predictor's step: the command for the inputs now, predicted over `tau` (over `tau`
    /// plus this step in the Jacobi order, where it acts one step later), held over the step.
    /// In the Jacobi and controller-first orders the master reads it after the step.
    fn step_predictor(&mut self, step: f64) -> Result<(), String> {
        let order = self.master_order();
        let p = self.predictor.as_mut().expect("a predictor");
        let mut retargeted = None;
        if order == MasterOrder::Jacobi && p.tau().to_bits() != (self.tau + step).to_bits() {
            let mut q = p.clone();
            q.retarget(self.tau + step).map_err(|e| {
                format!(
                    "in the Jacobi order (master_order = 1) a command acts one step after it is \
                     computed, so it is predicted over tau + step = {} s: {e}; the step was \
                     discarded",
                    self.tau + step
                )
            })?;
            retargeted = Some(q);
        }
        let p = retargeted.as_mut().unwrap_or(p);
        // In the Jacobi order with no delay the inputs are read before the command taking over
        // now is set: they carry the force of the one before it, where the Gauss–Seidel loop
        // with a step more delay (the one the predictor runs) has the new one taking over. Read
        // as that loop's plant reads them: plus the feedthrough `D_yu` of the difference.
        self.w.copy_from(&self.y);
        if order == MasterOrder::Jacobi && self.tau == 0.0 {
            if let (Some(spec), Some(now)) = (&self.spec.predictor, &self.sent) {
                self.w.gemv(1.0, &spec.d_yu, now, 1.0);
                if let Some(before) = &self.sent_before {
                    self.w.gemv(-1.0, &spec.d_yu, before, 1.0);
                }
            }
        }
        predicted_command(p, &self.w, &self.x, &self.limits, &mut self.yc, &mut self.u);
        let next = p.step(self.x.as_slice(), &self.w, &self.yc, &self.u, step)?;
        if let Some(q) = retargeted {
            self.predictor = Some(q);
        }
        self.x = next;
        if order != MasterOrder::GaussSeidel {
            self.sent_before = self.sent.replace(self.u.clone());
        }
        self.valid = false;
        Ok(())
    }

    /// One step of `step` s, or why not with nothing changed.
    fn step_or_keep(&mut self, step: f64) -> Result<(), String> {
        if self.predictor.is_some() {
            return self.step_predictor(step);
        }
        if self.a.nrows() == 0 {
            self.update_commands();
            self.step_estimator(step);
            return Ok(());
        }
        if self.cache.as_ref().map(|c| c.d.step.to_bits()) != Some(step.to_bits()) {
            let mut d = discretize(&self.a, &self.b, step).map_err(|e| step_refused(step, e))?;
            if let Some(basis) = self.readout.as_ref().and_then(|r| r.basis.as_ref()) {
                d.phi = basis.quasi_upper(d.phi);
            }
            let rest = self.rest.map(|rest| {
                rest.decouple(&mut d);
                let n = rest.states;
                (
                    d.phi.view((0, 0), (n, n)).into_owned(),
                    d.gamma_hold.view((0, 0), (n, rest.inputs)).into_owned(),
                )
            });
            self.cache = Some(Stepped { d, rest });
        }
        // The detector latches on the values at the start of the step (what a master read).
        let detected_before = self.detected;
        self.detected = self.fault_detected();
        // Measurements held over the step; with anti-windup the saturation excess u_a − y_c
        // too, with a detector the command sent (evaluated at the start of the step, as a
        // sampled-data implementation does and as the plant receives it) or the force the
        // actuator model says is applied now, which a load cell read now measures.
        self.update_commands();
        let ny = self.y.len();
        self.v.rows_mut(0, ny).copy_from(&self.y);
        let mut at = ny;
        if self.spec.anti_windup.is_some() {
            for i in 0..self.u.len() {
                self.v[at + i] = self.anti_windup_input(i);
            }
            at += self.u.len();
        }
        if let Some(fd) = &self.spec.fault_detection {
            let drive = match (fd.input, &self.estimator) {
                (spec::DetectorInput::ModelledForce, Some(e)) => e.modelled(),
                _ => self.u.as_slice(),
            };
            self.v.as_mut_slice()[at..].copy_from_slice(drive);
        }
        let resting = self.resting();
        let cache = self.cache.as_ref().unwrap();
        let (x, v, next) = (
            self.x.as_slice(),
            self.v.as_slice(),
            self.next.as_mut_slice(),
        );
        // At rest (no actuator saturated, none since the compensator last moved) the leading
        // block's product, the compensator's part staying exact zeros.
        let (terms, next) = match (&cache.rest, resting) {
            (Some((phi, gamma)), Some(rest)) if v[rest.inputs..].iter().all(|v| *v == 0.0) => {
                let (filter, compensator) = next.split_at_mut(rest.states);
                compensator.fill(0.0);
                let terms = [(phi, &x[..rest.states]), (gamma, &v[..rest.inputs])];
                (terms, filter)
            }
            _ => ([(&cache.d.phi, x), (&cache.d.gamma_hold, v)], next),
        };
        if self.readout.as_ref().is_some_and(|r| r.basis.is_some()) {
            mat_vec_sum_quasi_upper(next, &terms);
        } else {
            mat_vec_sum(next, &terms);
        }
        if !self.next.iter().all(|v| v.is_finite()) {
            self.detected = detected_before;
            return Err("controller state became non-finite; the step was discarded".into());
        }
        std::mem::swap(&mut self.x, &mut self.next);
        self.step_estimator(step);
        Ok(())
    }
}

impl Model for Controller {
    fn description(resources: Option<&Path>) -> Result<ModelDescription, ModelError> {
        Ok(description_for(&load_spec(resources)?))
    }

    fn instantiate(resources: Option<&Path>) -> Result<Self, ModelError> {
        let spec = load_spec(resources)?;
        let (mut a, mut b) = stepped_system(&spec);
        // Every controller without a predictor steps in the real Schur basis where one exists.
        let readout = spec.predictor.is_none().then(|| {
            let basis = schur::SchurForm::new(&a, &b, &stepped_blocks(&spec)).map(|stepped| {
                (a, b) = (stepped.a, stepped.b);
                stepped.basis
            });
            Readout::new(&spec, a.nrows(), basis)
        });
        let limits = spec
            .default_limits()
            .map(<[f64]>::to_vec)
            .unwrap_or_default();
        let limit_groups = if limits.is_empty() {
            Vec::new()
        } else {
            limit_groups(&spec)
        };
        let threshold = spec
            .fault_detection
            .as_ref()
            .map_or(f64::INFINITY, |fd| fd.threshold);
        let (nx, nv, nu, ny) = (a.nrows(), b.ncols(), spec.outputs.len(), spec.inputs.len());
        let nr = spec.fault_detection.as_ref().map_or(0, |fd| fd.c.nrows());
        let predictor = spec
            .predictor
            .clone()
            .map(predictor::Runtime::new)
            .transpose()?;
        let estimator = spec
            .accommodation
            .clone()
            .map(accommodation::Estimator::new);
        // Only in the stepped system's blocks: a predictor has its own state.
        let rest = readout.as_ref().and_then(|_| Rest::of(&spec));
        Ok(Controller {
            predictor,
            warned_step: None,
            last_step: None,
            tau: 0.0,
            order: MasterOrder::GaussSeidel as i32,
            sent: None,
            sent_before: None,
            estimator,
            x: DVector::zeros(nx),
            y: DVector::zeros(ny),
            limits,
            limit_groups,
            threshold,
            detected: false,
            a,
            b,
            readout,
            spec,
            cache: None,
            rest,
            yc: DVector::zeros(nu),
            u: DVector::zeros(nu),
            valid: false,
            w: DVector::zeros(ny),
            v: DVector::zeros(nv),
            next: DVector::zeros(nx),
            r: DVector::zeros(nr),
        })
    }

    fn check_real(&self, vr: ValueReference, value: f64) -> Result<(), ModelError> {
        match (&self.predictor, vr) {
            (Some(p), vr::DELAY) => p.check(value).map_err(ModelError::from),
            _ => Ok(()),
        }
    }

    fn set_real(&mut self, vr: ValueReference, value: f64) {
        self.valid = false;
        if vr == vr::DELAY {
            self.tau = value;
        } else if vr == vr::FAULT_THRESHOLD {
            self.threshold = value;
        } else if vr == vr::ACTUATOR_BANDWIDTH {
            if let Some(e) = &mut self.estimator {
                e.set_bandwidth(value);
            }
        } else if vr >= vr::LIMIT {
            if let Some((_, outputs)) = self.limit_groups.get((vr - vr::LIMIT) as usize) {
                for &i in outputs {
                    self.limits[i] = value;
                }
            }
        } else if let Some(slot) = self.y.get_mut((vr - vr::INPUT) as usize) {
            *slot = value;
        }
    }

    fn get_real(&mut self, vr: ValueReference) -> f64 {
        match vr {
            vr::RESIDUAL_NORM => self.residual_norm(),
            vr::FAULT_THRESHOLD => self.threshold,
            vr::DELAY => self.tau,
            vr::ACTUATOR_BANDWIDTH => self
                .estimator
                .as_ref()
                .map_or(f64::NAN, accommodation::Estimator::bandwidth),
            v if v >= vr::RHO_HAT => self
                .estimator
                .as_ref()
                .map_or(f64::NAN, |e| e.rho_hat((v - vr::RHO_HAT) as usize)),
            v if v >= vr::LIMIT => self
                .limit_groups
                .get((v - vr::LIMIT) as usize)
                .map_or(f64::NAN, |(_, o)| self.limits[o[0]]),
            vr::GUARANTEE => self.spec.guarantee.value,
            v if v >= vr::OUTPUT => self.output((v - vr::OUTPUT) as usize),
            v => self.y[(v - vr::INPUT) as usize],
        }
    }

    fn set_integer(&mut self, vr: ValueReference, value: i32) {
        if vr == vr::MASTER_ORDER {
            self.order = value;
            self.valid = false;
        }
    }

    fn get_integer(&mut self, vr: ValueReference) -> i32 {
        match vr {
            vr::MASTER_ORDER => self.order,
            _ => 0,
        }
    }

    fn get_boolean(&mut self, vr: ValueReference) -> bool {
        vr == vr::FAULT_DETECTED && self.fault_detected()
    }

    fn check_parameters(&self) -> Result<(), ModelError> {
        // FMI's bounds are inclusive: the declared minimum 0 is allowed (a limit of 0 is an
        // actuator that gives no force; a threshold of 0 flags any residual).
        if let Some(bad) = self.limits.iter().find(|l| !(**l >= 0.0 && l.is_finite())) {
            return Err(format!("force limits must be finite and >= 0, got {bad}").into());
        }
        if self.spec.fault_detection.is_some()
            && !(self.threshold >= 0.0 && self.threshold.is_finite())
        {
            return Err(format!(
                "fault_threshold must be finite and >= 0, got {}",
                self.threshold
            )
            .into());
        }
        if let Some(e) = &self.estimator {
            let hz = e.bandwidth();
            if !spec::actuator_bandwidth_ok(hz) {
                return Err(format!(
                    "actuator_bandwidth must be in [0, {}] Hz, got {hz}",
                    spec::MAX_ACTUATOR_BANDWIDTH
                )
                .into());
            }
        }
        match &self.predictor {
            Some(p) => {
                MasterOrder::from_i32(self.order)?;
                p.check(self.tau).map_err(ModelError::from)
            }
            None => Ok(()),
        }
    }

    /// The commands read in Initialization Mode are those of the first step: predicted over the
    /// delay set (no step length is known yet).
    fn prepare_initial_outputs(&mut self, _start_time: f64) -> Result<(), ModelError> {
        self.check_parameters()?;
        let tau = self.tau.to_bits();
        match &mut self.predictor {
            Some(p) if p.tau().to_bits() != tau || p.theta().to_bits() != tau => {
                self.valid = false;
                p.reset(self.tau).map_err(ModelError::from)
            }
            _ => Ok(()),
        }
    }

    /// Ticked by its clock, a predictor computes each command at the tick from the inputs there
    /// and the plant applies it from then on: the Gauss–Seidel order's timing, whatever the
    /// master's order.
    fn check_clocked(&self) -> Result<(), ModelError> {
        match self.master_order() {
            MasterOrder::GaussSeidel => Ok(()),
            order => Err(format!(
                "master_order = {}: ticked by its clock (eventModeUsed = true) the command \
                 computed at a tick acts from that tick whatever order the master steps in, \
                 which is master_order = 0; leave it at 0",
                order as i32
            )
            .into()),
        }
    }

    fn exit_initialization(&mut self, _start_time: f64) -> Result<(), ModelError> {
        self.check_parameters()?;
        if let Some(p) = &mut self.predictor {
            p.reset(self.tau)?;
        }
        (self.sent, self.sent_before) = (None, None);
        self.x.fill(0.0);
        if let Some(e) = &mut self.estimator {
            e.reset();
        }
        self.detected = false;
        self.valid = false;
        Ok(())
    }

    fn step_warning(&mut self, step: f64) -> Option<String> {
        let steps = self.spec.communication_steps.as_ref()?;
        // The step as taken (once per step size, not once per rounding of it).
        let step = self.last_step.unwrap_or(step);
        // 10⁻⁹ relative: a step the certificate checked, as a master computes it, is not beyond.
        if step <= steps.stable_up_to_s * (1.0 + 1e-9) || self.warned_step == Some(step.to_bits()) {
            return None;
        }
        self.warned_step = Some(step.to_bits());
        let unstable = match steps.unstable_at_s {
            Some(u) => format!(", and unstable at {u} s"),
            None => String::new(),
        };
        Some(format!(
            "communication step {step} s: {}'s loop as a master runs it (commands and \
             measurements held over each step) was found stable at the steps checked up to {} s \
             on the car it was designed for{unstable} (its certificate's \
             comfort.communication_steps); use a step of at most {} s",
            self.spec.variant, steps.stable_up_to_s, steps.stable_up_to_s
        ))
    }

    /// Every failure of a step leaves the controller as it was and comes from the step's
    /// length (an exponential or a state that overflows): `fmi2Discard`, after which a master
    /// may go on in shorter steps, as with the plant.
    fn do_step(&mut self, time: f64, step: f64) -> Result<(), ModelError> {
        let step = match self.last_step {
            Some(last) if linsys::same_step(last, step, time) => last,
            _ => step,
        };
        self.step_or_keep(step).map_err(ModelError::discard)?;
        self.last_step = Some(step);
        Ok(())
    }

    fn save(&self, out: &mut StateWriter) {
        out.u64(self.spec.content_hash);
        out.u64(self.basis_tag());
        out.f64s(self.x.as_slice());
        out.f64s(self.y.as_slice());
        out.f64s(&self.limits);
        out.f64s(&[self.threshold, if self.detected { 1.0 } else { 0.0 }]);
        if let Some(p) = &self.predictor {
            out.f64(self.tau);
            out.f64s(&p.save());
            out.f64(f64::from(self.order));
            for sent in [&self.sent, &self.sent_before] {
                out.f64s(sent.as_ref().map_or(&[][..], |u| u.as_slice()));
            }
        }
        if let Some(e) = &self.estimator {
            e.save(out);
        }
    }

    fn restore(&mut self, input: &mut StateReader) -> Result<(), ModelError> {
        let hash = input.u64()?;
        if hash != self.spec.content_hash {
            return Err("FMU state was saved with a different controller.json".into());
        }
        if input.u64()? != self.basis_tag() {
            return Err(
                "FMU state was saved by a controller stepping its state in another \
                        basis (another build of this FMU)"
                    .into(),
            );
        }
        let x = input.f64s_exact(self.x.len(), "controller states")?;
        let y = input.f64s_exact(self.spec.inputs.len(), "controller inputs")?;
        let limits = input.f64s_exact(self.limits.len(), "force limits")?;
        let detector = input.f64s_exact(2, "fault detector")?;
        let predictor = match &self.predictor {
            Some(p) => {
                let tau = input.f64()?;
                let mut p = p.clone();
                p.restore(tau, &input.f64s()?)?;
                let order = input.f64()?;
                if !MasterOrder::from_i32(order as i32).is_ok_and(|o| f64::from(o as i32) == order)
                {
                    return Err(format!("FMU state: master_order {order} is not an order").into());
                }
                let nu = self.spec.outputs.len();
                let mut sent = || -> Result<Option<DVector<f64>>, ModelError> {
                    let u = input.f64s()?;
                    if !(u.is_empty() || u.len() == nu && u.iter().all(|v| v.is_finite())) {
                        return Err(format!(
                            "FMU state: a command sent has {} values, not {nu} finite ones or none",
                            u.len()
                        )
                        .into());
                    }
                    Ok((!u.is_empty()).then(|| DVector::from_vec(u)))
                };
                let (now, before) = (sent()?, sent()?);
                Some((tau, p, order as i32, now, before))
            }
            None => None,
        };
        let estimator = match &self.estimator {
            Some(e) => Some(e.restored(input)?),
            None => None,
        };
        input.finish()?;
        if estimator.is_some() {
            self.estimator = estimator;
        }
        if let Some((tau, p, order, now, before)) = predictor {
            self.tau = tau;
            self.predictor = Some(p);
            (self.order, self.sent, self.sent_before) = (order, now, before);
        }
        self.threshold = detector[0];
        self.detected = detector[1] != 0.0;
        self.x = DVector::from_vec(x);
        self.y = DVector::from_vec(y);
        self.limits = limits;
        self.valid = false;
        Ok(())
    }
}

/// Why a step was refused when its matrix exponential was (the controller's own dynamics or
/// the predictor's blocks over a step far too long, or a corrupt `controller.json`).
fn step_refused(step: f64, e: linsys::ExpError) -> String {
    format!("cannot discretise the controller over {step} s: {e}; the step was discarded")
}

fmu_core::export_fmi2!(Controller);
fmu_core::export_fmi3!(Controller);

#[cfg(test)]
mod tests {
    use super::*;

    impl Controller {
        /// The same controller stepping its state in the stepped system's own basis.
        fn in_own_basis(mut self) -> Self {
            let (a, b) = stepped_system(&self.spec);
            self.readout = Some(Readout::new(&self.spec, a.nrows(), None));
            (self.a, self.b, self.cache) = (a, b, None);
            self
        }
    }

    /// A controller with every part a real one has (a filter with lightly damped complex modes,
    /// an anti-windup compensator with a gain, a fault detector), its numbers from a small LCG.
    fn spec_json() -> String {
        spec_json_with(true)
    }

    /// [`spec_json`], with or without its fault detector.
    fn spec_json_with(detector: bool) -> String {
        let mut uniform = linsys::lcg(99);
        let mut rand = || uniform() - 0.5;
        let (n, ny, nu, m, q) = (24, 6, 5, 4, 3);
        let mut matrix = |r: usize, c: usize, scale: f64, diag: &dyn Fn(usize, usize) -> f64| {
            let rows: Vec<Vec<f64>> = (0..r)
                .map(|i| (0..c).map(|j| scale * rand() + diag(i, j)).collect())
                .collect();
            format!("{rows:?}")
        };
        let none = |_: usize, _: usize| 0.0;
        // Pairs of rows coupled as oscillators (ω up to 60 rad/s), each pole well left.
        let filter = |i: usize, j: usize| match (i == j, i / 2 == j / 2, i % 2) {
            (true, _, _) => -(5.0 + 3.0 * i as f64),
            (false, true, 0) => 10.0 + 2.0 * i as f64,
            (false, true, _) => -(10.0 + 2.0 * i as f64),
            _ => 0.0,
        };
        let stable = |i: usize, j: usize| if i == j { -(2.0 + i as f64) } else { 0.0 };
        let inputs: Vec<String> = ["fl", "fr", "rl", "rr", "seat"]
            .iter()
            .map(|c| format!(r#"{{"name": "sensor_stroke_{c}", "unit": "m"}}"#))
            .chain(std::iter::once(
                r#"{"name": "sensor_a_body_fl", "unit": "m/s2"}"#.to_string(),
            ))
            .collect();
        let outputs: Vec<String> = ["fl", "fr", "rl", "rr", "seat"]
            .iter()
            .map(|c| format!(r#"{{"name": "u_{c}", "unit": "N"}}"#))
            .collect();
        format!(
            r#"{{"format": "suspension-controller/2", "variant": "test_schur", "description": "test",
              "guarantee": {{"name": "gamma", "value": 1.0, "unit": "1", "description": "test"}},
              "inputs": [{}], "outputs": [{}],
              "A": {}, "B": {}, "C": {}, "D": {},
              "anti_windup": {{"A": {}, "B": {}, "C": {}, "D": {}, "F": {}, "u_max": [300.0, 300.0, 300.0, 300.0, 200.0]}}{}}}"#,
            inputs.join(", "),
            outputs.join(", "),
            matrix(n, n, 2.0, &filter),
            matrix(n, ny, 50.0, &none),
            matrix(nu, n, 200.0, &none),
            matrix(nu, ny, 100.0, &none),
            matrix(m, m, 0.5, &stable),
            matrix(m, nu, 0.01, &none),
            matrix(ny, m, 0.1, &none),
            matrix(ny, nu, 0.0, &none),
            matrix(nu, m, 20.0, &none),
            if detector {
                format!(
                    r#", "fault_detection": {{"A": {}, "B": {}, "B_u": {}, "C": {}, "D": {},
                       "threshold": 1e9}}"#,
                    matrix(q, q, 0.5, &stable),
                    matrix(q, ny, 1.0, &none),
                    matrix(q, nu, 0.01, &none),
                    matrix(2, q, 1.0, &none),
                    matrix(2, ny, 0.5, &none),
                )
            } else {
                String::new()
            },
        )
    }

    /// A compensator at rest is skipped exactly: the controller gives the commands and states
    /// of the whole product bit for bit, below its limits (where it rests), saturated (where it
    /// does not) and after (where it decays but never rests again), in the Schur basis and in
    /// its own.
    #[test]
    fn a_compensator_at_rest_is_skipped_bit_for_bit() {
        let dir = std::env::temp_dir().join(format!("compensator-rest-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("controller.json"), spec_json_with(false)).unwrap();
        for own_basis in [false, true] {
            let make = || {
                let c = Controller::instantiate(Some(&dir)).unwrap();
                if own_basis {
                    c.in_own_basis()
                } else {
                    c
                }
            };
            let skipping = make();
            assert!(skipping.rest.is_some());
            let mut whole = make();
            whole.rest = None;
            let mut pair = [skipping, whole];
            for c in &mut pair {
                c.exit_initialization(0.0).unwrap();
            }
            let (ny, nu) = (pair[0].spec.inputs.len(), pair[0].spec.outputs.len());
            let mut at_rest = [0, 0, 0];
            for k in 0..3000 {
                let t = k as f64 * 1e-3;
                // Small inputs, then large ones (saturated) from 1 s to 1.5 s, small again.
                let scale = if (1000..1500).contains(&k) {
                    40.0
                } else {
                    0.02
                };
                let mut outs = [vec![0.0; nu], vec![0.0; nu]];
                for (c, out) in pair.iter_mut().zip(&mut outs) {
                    for i in 0..ny {
                        let y = scale * ((7.0 * t + i as f64).sin() + (31.0 * t * i as f64).cos());
                        c.set_real(vr::INPUT + i as u32, y);
                    }
                    for (i, o) in out.iter_mut().enumerate() {
                        *o = c.get_real(vr::OUTPUT + i as u32);
                    }
                    c.do_step(t, 1e-3).unwrap();
                }
                at_rest[k / 1000] += usize::from(pair[0].resting().is_some());
                let bits = |v: &[f64]| v.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&outs[0]), bits(&outs[1]), "commands at step {k}");
                assert_eq!(
                    bits(pair[0].x.as_slice()),
                    bits(pair[1].x.as_slice()),
                    "state after step {k}"
                );
            }
            // Resting until the inputs saturate it, never after.
            assert_eq!(at_rest, [1000, 0, 0], "own basis {own_basis}");
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    /// Stepped in its real Schur basis a controller gives the commands and the residual of its
    /// own basis to rounding, saturated or not, at two step sizes; and a state saved in one
    /// basis is refused by the other.
    #[test]
    fn the_schur_basis_gives_the_commands_of_the_controllers_own() {
        let dir = std::env::temp_dir().join(format!("schur-basis-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("controller.json"), spec_json()).unwrap();
        let schur = Controller::instantiate(Some(&dir)).unwrap();
        assert!(schur.readout.as_ref().unwrap().basis.is_some());
        let own = Controller::instantiate(Some(&dir)).unwrap().in_own_basis();
        let mut pair = [schur, own];
        for c in &mut pair {
            c.exit_initialization(0.0).unwrap();
        }
        let (ny, nu) = (pair[0].spec.inputs.len(), pair[0].spec.outputs.len());
        let (mut worst, mut largest, mut saturated) = (0.0f64, 0.0f64, 0);
        for k in 0..2000 {
            let t = k as f64 * 1e-3;
            let step = if k < 1000 { 1e-3 } else { 4e-4 };
            let mut outs = [vec![0.0; nu + 1], vec![0.0; nu + 1]];
            for (c, out) in pair.iter_mut().zip(&mut outs) {
                for i in 0..ny {
                    let y = 2.0 * (7.0 * t + i as f64).sin() + (31.0 * t * i as f64).cos();
                    c.set_real(vr::INPUT + i as u32, y);
                }
                for (i, o) in out.iter_mut().take(nu).enumerate() {
                    *o = c.get_real(vr::OUTPUT + i as u32);
                }
                out[nu] = c.get_real(vr::RESIDUAL_NORM);
                c.do_step(t, step).unwrap();
            }
            saturated += outs[0].iter().take(4).filter(|u| u.abs() == 300.0).count();
            for (a, b) in outs[0].iter().zip(&outs[1]) {
                worst = worst.max((a - b).abs());
                largest = largest.max(b.abs());
            }
        }
        assert!(largest > 100.0 && saturated > 0, "{largest}, {saturated}");
        println!(
            "largest command {largest:.1} N, {saturated} saturated, worst difference {worst:e}"
        );
        assert!(worst <= 1e-11 * largest, "{worst:e} of {largest}");
        let mut bytes = StateWriter::default();
        pair[0].save(&mut bytes);
        let err = pair[1]
            .restore(&mut StateReader::new(&bytes.into_bytes()))
            .unwrap_err();
        assert!(err.message.contains("another basis"), "{err}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
