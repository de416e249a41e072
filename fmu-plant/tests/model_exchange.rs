//! The plant FMU as Model Exchange, through its exported C functions: its derivatives are the
//! car's matrices, an integrator driven through them reproduces the exact Co-Simulation steps,
//! and the Model Exchange state machine refuses what FMI 2.0.4 §3.2.3 forbids.

mod common;

use fmi_test_logger::LogCapture;
use fmu_core::types::*;
use fmu_plant::*;
use nalgebra::{DMatrix, DVector};
use std::ptr::null_mut;
use vehicle::model::{StateSpace, FORCE_PORTS, N_ACTUATORS, N_ROAD, N_STATES, ROAD_PORTS};
use vehicle::VehicleParams;

const OK: i32 = 0;
const ERROR: i32 = 3;

struct Fmu<'a> {
    c: Fmi2Component,
    desc: fmu_core::ModelDescription,
    kind: Fmi2Type,
    log: &'a LogCapture,
    _cb: Box<fmi_test_logger::Callbacks>,
}

impl<'a> Fmu<'a> {
    fn new(log: &'a LogCapture, kind: Fmi2Type) -> Self {
        let (c, desc, cb) = common::instantiate(log, kind);
        Fmu {
            c,
            desc,
            kind,
            log,
            _cb: cb,
        }
    }
    fn vr(&self, name: &str) -> u32 {
        self.desc
            .variable(name)
            .unwrap_or_else(|| panic!("no variable {name}"))
            .value_reference
    }
    fn set(&self, name: &str, v: f64) -> i32 {
        let vr = self.vr(name);
        unsafe { fmi2SetReal(self.c, &vr, 1, &v) }
    }
    fn get(&self, name: &str) -> f64 {
        let vr = self.vr(name);
        let mut v = f64::NAN;
        assert_eq!(unsafe { fmi2GetReal(self.c, &vr, 1, &mut v) }, OK);
        v
    }
    /// Setup, parameters and inputs, initialisation; for Model Exchange also the first event
    /// iteration and Continuous-Time Mode. Returns the next time event.
    fn start(&self, values: &[(&str, f64)], booleans: &[(&str, bool)]) -> Option<f64> {
        unsafe {
            assert_eq!(fmi2SetupExperiment(self.c, 0, 0.0, 0.0, 0, 0.0), OK);
            assert_eq!(fmi2EnterInitializationMode(self.c), OK);
        }
        for (name, v) in values {
            assert_eq!(self.set(name, *v), OK, "{name}");
        }
        for (name, b) in booleans {
            let vr = self.vr(name);
            let v = *b as Fmi2Boolean;
            assert_eq!(unsafe { fmi2SetBoolean(self.c, &vr, 1, &v) }, OK);
        }
        assert_eq!(
            unsafe { fmi2ExitInitializationMode(self.c) },
            OK,
            "{:?}",
            self.log.messages()
        );
        if self.kind == FMI2_CO_SIMULATION {
            return None;
        }
        let next = self.event();
        assert_eq!(unsafe { fmi2EnterContinuousTimeMode(self.c) }, OK);
        next
    }
    fn nx(&self) -> usize {
        self.desc.number_of_states()
    }
    /// One event iteration (from Event Mode): the next time event.
    fn event(&self) -> Option<f64> {
        let mut info = EventInfo::default();
        assert_eq!(unsafe { fmi2NewDiscreteStates(self.c, &mut info) }, OK);
        assert_eq!(info.new_discrete_states_needed, FMI2_FALSE);
        (info.next_event_time_defined != FMI2_FALSE).then_some(info.next_event_time)
    }
    fn states(&self) -> Vec<f64> {
        let mut x = vec![f64::NAN; self.nx()];
        assert_eq!(
            unsafe { fmi2GetContinuousStates(self.c, x.as_mut_ptr(), x.len()) },
            OK
        );
        x
    }
    fn derivatives(&self, t: f64, x: &[f64]) -> Vec<f64> {
        let mut dx = vec![f64::NAN; x.len()];
        unsafe {
            assert_eq!(fmi2SetTime(self.c, t), OK, "{:?}", self.log.messages());
            assert_eq!(fmi2SetContinuousStates(self.c, x.as_ptr(), x.len()), OK);
            assert_eq!(fmi2GetDerivatives(self.c, dx.as_mut_ptr(), dx.len()), OK);
        }
        dx
    }
    fn indicators(&self) -> Vec<f64> {
        let n = self
            .desc
            .model_exchange
            .as_ref()
            .unwrap()
            .number_of_event_indicators;
        let mut z = vec![f64::NAN; n];
        assert_eq!(
            unsafe { fmi2GetEventIndicators(self.c, z.as_mut_ptr(), n) },
            OK
        );
        z
    }
    fn completed(&self) {
        let (mut event, mut terminate) = (FMI2_TRUE, FMI2_TRUE);
        let status =
            unsafe { fmi2CompletedIntegratorStep(self.c, FMI2_TRUE, &mut event, &mut terminate) };
        assert_eq!((status, event, terminate), (OK, FMI2_FALSE, FMI2_FALSE));
    }
}

impl Drop for Fmu<'_> {
    fn drop(&mut self) {
        unsafe { fmi2FreeInstance(self.c) }
    }
}

/// A deterministic spread of values in [-1, 1].
fn spread(k: usize) -> f64 {
    ((k as f64 * 0.618_034 + 0.1).fract() - 0.5) * 2.0
}

/// On the linear car, with and without the actuators' lag, the derivatives the FMU gives for
/// any state and inputs are `A x + B_r r + B_u f` of `vehicle::model::StateSpace`, built from
/// the parameters apart from the plant's matrices, with `f` the saturated commands (the lag
/// states behind a lag, which move at `2π f_a (sat u − f)`).
#[test]
fn the_derivatives_are_the_cars_matrices() {
    let ss = StateSpace::new(&VehicleParams::default());
    for bandwidth in [0.0, 10.0] {
        let log = LogCapture::default();
        let fmu = Fmu::new(&log, FMI2_MODEL_EXCHANGE);
        let road: Vec<f64> = (0..N_ROAD).map(|j| 0.03 * spread(j + 40)).collect();
        // The FR command beyond its limit: the car gets the limit.
        let command = [800.0, 4000.0, -300.0, 150.0, 400.0];
        let mut values = vec![("actuator_bandwidth", bandwidth)];
        let names = ROAD_PORTS;
        values.extend(names.iter().copied().zip(road.iter().copied()));
        values.extend(FORCE_PORTS.iter().copied().zip(command));
        fmu.start(&values, &[("contact_model", false)]);
        let x: Vec<f64> = (0..fmu.nx()).map(|k| 0.01 * spread(k)).collect();
        let dx = fmu.derivatives(0.0, &x);
        // The default limits: 2500 N at the corners, 1000 N at the seat.
        let limits = [2500.0, 2500.0, 2500.0, 2500.0, 1000.0];
        let saturated: [f64; N_ACTUATORS] =
            std::array::from_fn(|i| command[i].clamp(-limits[i], limits[i]));
        let lag = N_STATES..N_STATES + N_ACTUATORS;
        let force: Vec<f64> = if bandwidth > 0.0 {
            x[lag.clone()].to_vec()
        } else {
            saturated.to_vec()
        };
        let expected = &ss.a * DVector::from_column_slice(&x[..N_STATES])
            + &ss.b_r * DVector::from_vec(road.clone())
            + &ss.b_u * DVector::from_vec(force);
        let scale = expected.amax();
        for i in 0..N_STATES {
            assert!(
                (dx[i] - expected[i]).abs() <= 1e-13 * scale,
                "bandwidth {bandwidth}: der(x[{}]) = {} != {}",
                i + 1,
                dx[i],
                expected[i]
            );
        }
        for (k, i) in lag.enumerate() {
            let want = if bandwidth > 0.0 {
                2.0 * std::f64::consts::PI * bandwidth * (saturated[k] - x[i])
            } else {
                0.0
            };
            assert!(
                (dx[i] - want).abs() <= 1e-12 * want.abs().max(1.0),
                "lag {k}"
            );
        }
        // The derivatives are variables too, and read the same.
        assert_eq!(fmu.get("der(x[9])"), dx[8]);
        assert_eq!(
            fmu.get("der(meter_state[3])"),
            dx[N_STATES + N_ACTUATORS + 2]
        );
    }
}

/// Classical RK4 from `x` over `[t, t + h]`.
fn rk4(fmu: &Fmu, t: f64, h: f64, x: &[f64]) -> Vec<f64> {
    let add = |a: &[f64], k: &[f64], s: f64| -> Vec<f64> {
        a.iter().zip(k).map(|(a, k)| a + s * k).collect()
    };
    let k1 = fmu.derivatives(t, x);
    let k2 = fmu.derivatives(t + h / 2.0, &add(x, &k1, h / 2.0));
    let k3 = fmu.derivatives(t + h / 2.0, &add(x, &k2, h / 2.0));
    let k4 = fmu.derivatives(t + h, &add(x, &k3, h));
    (0..x.len())
        .map(|i| x[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]))
        .collect()
}

/// A second algorithm: RK4 on the FMU's derivatives, stopping at the fault's time event, against
/// the same plant's Co-Simulation, whose steps are matrix exponentials. The car has its
/// actuators' 10 Hz lag, the physical contacts (which the inputs keep closed: no state event)
/// and the seat's vibration meter, and the seat actuator loses half its force at 0.25 s.
#[test]
fn integrating_the_derivatives_reproduces_the_exact_co_simulation() {
    let log = LogCapture::default();
    let setup = [
        ("actuator_bandwidth", 10.0),
        ("fault_time", 0.25),
        ("fault_loss_seat", 0.5),
        ("road_z_fl", 0.02),
        ("road_z_rr", -0.01),
        ("u_seat", 150.0),
        ("u_fr", -900.0),
    ];
    let me = Fmu::new(&log, FMI2_MODEL_EXCHANGE);
    let next = me.start(&setup, &[]);
    assert_eq!(next, Some(0.25), "the fault's onset is a time event");
    let cs = Fmu::new(&log, FMI2_CO_SIMULATION);
    cs.start(&setup, &[]);
    let (h, steps) = (1e-4, 5000);
    let mut x = me.states();
    let mut exact = Vec::new();
    let mut integrated = Vec::new();
    let signs = me
        .indicators()
        .iter()
        .map(|z| z.signum())
        .collect::<Vec<_>>();
    for k in 0..steps {
        let t = k as f64 * h;
        x = rk4(&me, t, h, &x);
        unsafe {
            assert_eq!(fmi2SetTime(me.c, t + h), OK);
            assert_eq!(fmi2SetContinuousStates(me.c, x.as_ptr(), x.len()), OK);
        }
        me.completed();
        if ((t + h) - 0.25).abs() < 1e-12 {
            unsafe { assert_eq!(fmi2EnterEventMode(me.c), OK) };
            assert_eq!(me.event(), None, "no event is left after the fault");
            unsafe { assert_eq!(fmi2EnterContinuousTimeMode(me.c), OK) };
        }
        let now: Vec<f64> = me.indicators().iter().map(|z| z.signum()).collect();
        assert_eq!(
            now,
            signs,
            "no contact switches in this run (t = {})",
            t + h
        );
        assert_eq!(unsafe { fmi2DoStep(cs.c, t, h, 1) }, OK);
        if (k + 1) % 100 == 0 {
            let outputs = [
                "x[1]",
                "x[4]",
                "stroke_fl",
                "f_seat",
                "a_seat_wk",
                "tire_force_fl",
            ];
            exact.push(outputs.map(|n| cs.get(n)));
            integrated.push(outputs.map(|n| me.get(n)));
        }
    }
    for o in 0..6 {
        let column = |rows: &[[f64; 6]]| rows.iter().map(|r| r[o]).collect::<Vec<_>>();
        let (a, b) = (column(&integrated), column(&exact));
        let range =
            b.iter().cloned().fold(f64::MIN, f64::max) - b.iter().cloned().fold(f64::MAX, f64::min);
        let error = a
            .iter()
            .zip(&b)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(range > 0.0, "output {o} moves");
        assert!(
            error <= 1e-9 * range,
            "output {o}: RK4 on the derivatives is {error} off the exact steps (range {range})"
        );
    }
}

/// A contact switches in Event Mode only, and its indicator falls through zero just past its
/// switching point on either side: a root finder that stops exactly on the guard's zero still
/// finds the switch. Here the FL wheel, pushed up against its bump stop by a road step.
#[test]
fn a_stop_engages_at_the_event_its_indicator_announces() {
    let log = LogCapture::default();
    let me = Fmu::new(&log, FMI2_MODEL_EXCHANGE);
    me.start(&[("road_z_fl", 0.15)], &[]);
    let bump_fl = 4;
    let (h, mut x, mut t) = (1e-5, me.states(), 0.0);
    let before = me.indicators()[bump_fl];
    assert!(before < 0.0);
    while me.indicators()[bump_fl] < 0.0 {
        assert!(t < 0.05, "the bump stop is reached within 50 ms");
        x = rk4(&me, t, h, &x);
        t += h;
        unsafe {
            assert_eq!(fmi2SetTime(me.c, t), OK);
            assert_eq!(fmi2SetContinuousStates(me.c, x.as_ptr(), x.len()), OK);
        }
        // Past the guard's zero the force stays off until the event.
        assert_eq!(me.get("stop_force_fl"), 0.0);
    }
    me.completed();
    unsafe { assert_eq!(fmi2EnterEventMode(me.c), OK) };
    me.event();
    unsafe { assert_eq!(fmi2EnterContinuousTimeMode(me.c), OK) };
    assert!(
        me.indicators()[bump_fl] > 0.0,
        "engaged, its indicator has jumped"
    );
    assert!(me.get("stop_force_fl") > 0.0);
    assert!(me.get("stop_time_fl") == 0.0);
    let x = rk4(&me, t, h, &x);
    unsafe {
        assert_eq!(fmi2SetTime(me.c, t + h), OK);
        assert_eq!(fmi2SetContinuousStates(me.c, x.as_ptr(), x.len()), OK);
    }
    me.completed();
    assert!(
        (me.get("stop_time_fl") - h).abs() < 1e-15,
        "the time at the stop counts"
    );
}

/// What Model Exchange cannot integrate is refused at the end of initialisation with a message
/// naming the parameter: a transport delay, the sampled sensor noise. Co-Simulation runs both.
#[test]
fn a_delay_or_the_sensor_model_is_refused_with_a_reason() {
    for (values, booleans, needle) in [
        (vec![("tau", 0.01)], vec![], "tau = 0.01 s"),
        (vec![], vec![("sensor_model", true)], "sensor_model = true"),
    ] {
        let log = LogCapture::default();
        let me = Fmu::new(&log, FMI2_MODEL_EXCHANGE);
        unsafe {
            assert_eq!(fmi2SetupExperiment(me.c, 0, 0.0, 0.0, 0, 0.0), OK);
            assert_eq!(fmi2EnterInitializationMode(me.c), OK);
        }
        for (name, v) in &values {
            assert_eq!(me.set(name, *v), OK);
        }
        for (name, b) in &booleans {
            let vr = me.vr(name);
            assert_eq!(unsafe { fmi2SetBoolean(me.c, &vr, 1, &(*b as i32)) }, OK);
        }
        assert_eq!(unsafe { fmi2ExitInitializationMode(me.c) }, ERROR);
        assert!(log.contains(needle), "{:?}", log.messages());
        let cs = Fmu::new(&log, FMI2_CO_SIMULATION);
        cs.start(
            &values,
            &booleans.iter().map(|(n, b)| (*n, *b)).collect::<Vec<_>>(),
        );
    }
}

/// The Model Exchange calling sequence (FMI 2.0.4 §3.2.3): each illegal call answers
/// `fmi2Error` with a message naming the function, and an instance of one interface refuses the
/// other's functions.
#[test]
fn the_calling_sequence_is_enforced() {
    let log = LogCapture::default();
    // Co-Simulation functions on a Model Exchange instance, and the reverse.
    let me = Fmu::new(&log, FMI2_MODEL_EXCHANGE);
    me.start(&[], &[]);
    assert_eq!(unsafe { fmi2DoStep(me.c, 0.0, 1e-3, 1) }, ERROR);
    assert!(log.contains("fmi2DoStep: a function of Co-Simulation only"));
    let cs = Fmu::new(&log, FMI2_CO_SIMULATION);
    cs.start(&[], &[]);
    assert_eq!(unsafe { fmi2SetTime(cs.c, 0.1) }, ERROR);
    assert!(log.contains("fmi2SetTime: a function of Model Exchange only"));

    type Call = Box<dyn Fn(&Fmu) -> i32>;
    let cases: Vec<(&str, Call)> = vec![
        (
            "continuous states in Event Mode",
            Box::new(|f: &Fmu| {
                let x = f.states();
                unsafe {
                    fmi2EnterEventMode(f.c);
                    fmi2SetContinuousStates(f.c, x.as_ptr(), x.len())
                }
            }),
        ),
        (
            "a parameter in Continuous-Time Mode",
            Box::new(|f: &Fmu| f.set("m_s", 1500.0)),
        ),
        (
            "the wrong number of states",
            Box::new(|f: &Fmu| {
                let x = [0.0; 3];
                unsafe { fmi2SetContinuousStates(f.c, x.as_ptr(), 3) }
            }),
        ),
        (
            "a non-finite state",
            Box::new(|f: &Fmu| {
                let mut x = f.states();
                x[2] = f64::NAN;
                unsafe { fmi2SetContinuousStates(f.c, x.as_ptr(), x.len()) }
            }),
        ),
        (
            "time before the last accepted",
            Box::new(|f: &Fmu| unsafe {
                fmi2SetTime(f.c, 0.5);
                let (mut e, mut t) = (0, 0);
                fmi2CompletedIntegratorStep(f.c, 1, &mut e, &mut t);
                fmi2SetTime(f.c, 0.25)
            }),
        ),
        (
            "an event iteration in Continuous-Time Mode",
            Box::new(|f: &Fmu| {
                let mut info = EventInfo::default();
                unsafe { fmi2NewDiscreteStates(f.c, &mut info) }
            }),
        ),
    ];
    for (what, call) in cases {
        let log = LogCapture::default();
        let f = Fmu::new(&log, FMI2_MODEL_EXCHANGE);
        f.start(&[], &[]);
        assert_eq!(call(&f), ERROR, "{what}");
        assert!(!log.messages().is_empty(), "{what}: a message says why");
    }
    // A continuous input may change in Continuous-Time Mode.
    let f = Fmu::new(&log, FMI2_MODEL_EXCHANGE);
    f.start(&[], &[]);
    assert_eq!(f.set("road_z_fl", 0.01), OK);
}

/// An FMU state of a Model Exchange instance (in Continuous-Time Mode, with a contact closed)
/// restores into a fresh Model Exchange instance, which then gives the same derivatives; a
/// Co-Simulation instance refuses it.
#[test]
fn a_model_exchange_state_restores_by_value() {
    let log = LogCapture::default();
    let me = Fmu::new(&log, FMI2_MODEL_EXCHANGE);
    me.start(&[("road_z_fl", 0.01), ("u_seat", 200.0)], &[]);
    let x: Vec<f64> = (0..me.nx()).map(|k| 1e-3 * spread(k)).collect();
    let dx = me.derivatives(0.125, &x);
    let mut state: Fmi2FmuState = null_mut();
    assert_eq!(unsafe { fmi2GetFMUstate(me.c, &mut state) }, OK);
    let mut size = 0;
    assert_eq!(
        unsafe { fmi2SerializedFMUstateSize(me.c, state, &mut size) },
        OK
    );
    let mut bytes = vec![0 as Fmi2Byte; size];
    assert_eq!(
        unsafe { fmi2SerializeFMUstate(me.c, state, bytes.as_mut_ptr(), size) },
        OK
    );
    unsafe { fmi2FreeFMUstate(me.c, &mut state) };
    let restore = |f: &Fmu| -> i32 {
        let mut s: Fmi2FmuState = null_mut();
        assert_eq!(
            unsafe { fmi2DeSerializeFMUstate(f.c, bytes.as_ptr(), bytes.len(), &mut s) },
            OK
        );
        let status = unsafe { fmi2SetFMUstate(f.c, s) };
        unsafe { fmi2FreeFMUstate(f.c, &mut s) };
        status
    };
    let other = Fmu::new(&log, FMI2_MODEL_EXCHANGE);
    assert_eq!(restore(&other), OK, "{:?}", log.messages());
    let mut again = vec![f64::NAN; dx.len()];
    assert_eq!(
        unsafe { fmi2GetDerivatives(other.c, again.as_mut_ptr(), again.len()) },
        OK
    );
    assert_eq!(again, dx);
    let cs = Fmu::new(&log, FMI2_CO_SIMULATION);
    assert_eq!(restore(&cs), ERROR);
    assert!(log.contains("which a Co-Simulation instance never reaches"));
}

/// The linearisation an engineer takes first: finite differences of the derivatives through the
/// FMU at the equilibrium are the car's `A` (its first 16 states) to round-off, whatever the
/// step (the model is linear there).
#[test]
fn finite_differences_through_the_fmu_give_the_cars_a() {
    let log = LogCapture::default();
    let me = Fmu::new(&log, FMI2_MODEL_EXCHANGE);
    me.start(&[], &[]);
    let ss = StateSpace::new(&VehicleParams::default());
    let x0 = me.states();
    let mut a = DMatrix::zeros(N_STATES, N_STATES);
    for j in 0..N_STATES {
        let delta = 1e-4;
        let mut up = x0.clone();
        up[j] += delta;
        let mut down = x0.clone();
        down[j] -= delta;
        let (f1, f0) = (me.derivatives(0.0, &up), me.derivatives(0.0, &down));
        for i in 0..N_STATES {
            a[(i, j)] = (f1[i] - f0[i]) / (2.0 * delta);
        }
    }
    let error = (&a - &ss.a).amax();
    assert!(error <= 1e-9 * ss.a.amax(), "|A_fd − A| = {error}");
}

impl Fmu<'_> {
    fn directional(&self, unknowns: &[&str], knowns: &[&str], seed: &[f64]) -> (i32, Vec<f64>) {
        let u: Vec<u32> = unknowns.iter().map(|n| self.vr(n)).collect();
        let k: Vec<u32> = knowns.iter().map(|n| self.vr(n)).collect();
        let mut out = vec![f64::NAN; u.len()];
        let status = unsafe {
            fmi2GetDirectionalDerivative(
                self.c,
                u.as_ptr(),
                u.len(),
                k.as_ptr(),
                k.len(),
                seed.as_ptr(),
                out.as_mut_ptr(),
            )
        };
        (status, out)
    }
}

/// `fmi2GetDirectionalDerivative` on Model Exchange: the Jacobians of the derivatives are the
/// car's matrices of `vehicle::model::StateSpace` (built apart from the plant's): `A` along each
/// state, `B_r` along each road input, `B_u` along a command inside its limit, nothing along
/// one beyond it.
#[test]
fn directional_derivatives_are_the_cars_matrices() {
    let log = LogCapture::default();
    let me = Fmu::new(&log, FMI2_MODEL_EXCHANGE);
    me.start(
        &[("u_fr", 3000.0), ("u_fl", 100.0)],
        &[("contact_model", false)],
    );
    let ss = StateSpace::new(&VehicleParams::default());
    let ders: Vec<String> = (1..=N_STATES).map(|k| format!("der(x[{k}])")).collect();
    let ders: Vec<&str> = ders.iter().map(String::as_str).collect();
    let column = |known: &str| {
        let (status, out) = me.directional(&ders, &[known], &[1.0]);
        assert_eq!(status, OK, "{:?}", log.messages());
        DVector::from_vec(out)
    };
    let close = |a: DVector<f64>, b: DVector<f64>, what: &str| {
        let scale = b.amax().max(1e-300);
        assert!((&a - &b).amax() <= 1e-14 * scale, "{what}: {a} != {b}");
    };
    for j in 0..N_STATES {
        close(column(&format!("x[{}]", j + 1)), ss.a.column(j).into(), "A");
    }
    for (j, name) in ROAD_PORTS.iter().enumerate() {
        close(column(name), ss.b_r.column(j).into(), "B_r");
    }
    close(
        column("u_fl"),
        ss.b_u.column(0).into(),
        "B_u inside the limit",
    );
    assert_eq!(
        column("u_fr").amax(),
        0.0,
        "a saturated command moves nothing"
    );
    // Linear in the seed: two knowns at once are the sum of their columns.
    let (_, both) = me.directional(&ders, &["x[1]", "road_z_rl"], &[2.0, -3.0]);
    let sum = ss.a.column(0) * 2.0 - ss.b_r.column(2) * 3.0;
    close(DVector::from_vec(both), sum, "a combination");
    // A state's own derivative along itself is 1; an unknown that is not an output, a state or
    // a derivative, a known that is not an input or a state, are refused.
    assert_eq!(
        me.directional(&["x[3]"], &["x[3]"], &[1.0]),
        (OK, vec![1.0])
    );
    assert_eq!(me.directional(&["u_fl"], &["x[1]"], &[1.0]).0, ERROR);
    assert!(log.contains("unknown 'u_fl' is not an output"));
    assert_eq!(me.directional(&["der(x[1])"], &["m_s"], &[1.0]).0, ERROR);
    assert!(log.contains("known 'm_s' is not an input"));
}

/// `fmi2GetDirectionalDerivative` on Co-Simulation: the outputs' feed-through from the inputs,
/// against a second algorithm: the outputs read before and after moving one input (the plant is
/// affine in them at a point, so the difference quotient is the derivative to round-off). The
/// physical car with a tyre load, a stroke, an acceleration and the seat actuator's force.
#[test]
fn directional_derivatives_in_co_simulation_are_the_outputs_feed_through() {
    let log = LogCapture::default();
    let cs = Fmu::new(&log, FMI2_CO_SIMULATION);
    cs.start(&[("road_z_fl", 0.01), ("u_seat", 200.0)], &[]);
    // One step on: the car moving, off its equilibrium.
    assert_eq!(unsafe { fmi2DoStep(cs.c, 0.0, 1e-3, 1) }, OK);
    let outputs = [
        "tire_load_fl",
        "a_seat",
        "a_body",
        "stroke_fl",
        "f_seat",
        "tire_force_fl",
        "sensor_a_seat",
    ];
    for (input, delta) in [
        ("road_z_fl", 1e-3),
        ("road_v_fr", 1e-2),
        ("u_seat", 10.0),
        ("u_rl", 10.0),
    ] {
        let (status, jacobian) = cs.directional(&outputs, &[input], &[1.0]);
        assert_eq!(status, OK, "{:?}", log.messages());
        let before: Vec<f64> = outputs.iter().map(|o| cs.get(o)).collect();
        let base = cs.get(input);
        assert_eq!(cs.set(input, base + delta), OK);
        let after: Vec<f64> = outputs.iter().map(|o| cs.get(o)).collect();
        assert_eq!(cs.set(input, base), OK);
        for (k, o) in outputs.iter().enumerate() {
            let quotient = (after[k] - before[k]) / delta;
            let scale = quotient.abs().max(jacobian[k].abs()).max(1.0);
            assert!(
                (quotient - jacobian[k]).abs() <= 1e-7 * scale,
                "∂{o}/∂{input}: {} (directional) against {quotient} (difference)",
                jacobian[k]
            );
        }
    }
    // States are not knowns in Co-Simulation.
    assert_eq!(cs.directional(&["a_seat"], &["x[1]"], &[1.0]).0, ERROR);
}

/// The `<Derivatives>` dependencies an importer sorts equations by must cover every entry of
/// the Jacobian, whatever the parameters and the contacts: here an asymmetric car (the defaults'
/// symmetric track cancels roll-heave terms) with a 7 Hz lag, at the equilibrium and with the
/// FL bump stop engaged, every nonzero directional derivative of a derivative along a state or
/// an input is declared.
#[test]
fn the_declared_dependencies_cover_every_jacobian_entry() {
    let log = LogCapture::default();
    let me = Fmu::new(&log, FMI2_MODEL_EXCHANGE);
    let setup = [
        ("actuator_bandwidth", 7.0),
        ("w1", 0.65),
        ("w2", 0.8),
        ("L1", 1.3),
        ("c_t", 250.0),
    ];
    me.start(&setup, &[]);
    let desc = &me.desc;
    let states: Vec<String> = desc
        .continuous_states()
        .iter()
        .map(|(s, _)| s.name.clone())
        .collect();
    let inputs: Vec<String> = desc
        .variables
        .iter()
        .filter(|v| v.causality == fmu_core::Causality::Input)
        .map(|v| v.name.clone())
        .collect();
    let derivatives: Vec<(String, Vec<String>)> = desc
        .continuous_states()
        .iter()
        .map(|(_, d)| {
            (
                d.name.clone(),
                d.depends_on.iter().map(|(k, _)| k.clone()).collect(),
            )
        })
        .collect();
    let check = |fmu: &Fmu, when: &str| {
        let names: Vec<&str> = derivatives.iter().map(|(d, _)| d.as_str()).collect();
        let mut entries = 0;
        for known in states.iter().chain(&inputs) {
            let (status, column) = fmu.directional(&names, &[known], &[1.0]);
            assert_eq!(status, OK);
            for (i, v) in column.iter().enumerate() {
                if *v != 0.0 {
                    entries += 1;
                    assert!(
                        derivatives[i].1.contains(known),
                        "{when}: {} moves with {known} ({v}) but does not declare it",
                        derivatives[i].0
                    );
                }
            }
        }
        assert!(entries > 100, "{when}: {entries} entries");
    };
    check(&me, "at the equilibrium");
    // Push the FL corner into its bump stop and switch it in an event.
    let mut x = me.states();
    x[4] = 0.09;
    unsafe {
        assert_eq!(fmi2SetContinuousStates(me.c, x.as_ptr(), x.len()), OK);
        assert_eq!(fmi2EnterEventMode(me.c), OK);
    }
    me.event();
    unsafe { assert_eq!(fmi2EnterContinuousTimeMode(me.c), OK) };
    assert!(me.get("stop_force_fl") > 0.0, "the bump stop is engaged");
    check(&me, "on the FL bump stop");
}
