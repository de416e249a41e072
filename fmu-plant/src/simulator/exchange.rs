//! The plant as Model Exchange sees it (FMI 2.0.4 §3): the integrator owns the continuous
//! states and asks for their derivatives, `ẋ = A x + B [r; v]` in the matrices of the current
//! contact mode (plus the constant a mode carries), exactly the system the Co-Simulation steps
//! integrate in closed form. A contact opening or closing is a state event: its guard is an
//! event indicator, and the mode changes only in Event Mode. The fault's onset is a time event.
//!
//! What an integrator cannot carry is refused by the plant before it starts
//! ([`Simulator::model_exchange_refusal`]): a transport delay (no finite state holds it) and
//! the sampled sensor noise.

use super::*;

/// How far past its switching point a contact's event indicator falls through zero
/// ([`Simulator::exchange_event_indicators`]): 0.1 nm of penetration or 0.1 nN of force, well
/// above their round-off (a stop's force sums terms of 10⁴ N, good to 10⁻¹¹ N) and small enough
/// that a switch moves by about 10⁻⁹ s at the speeds a suspension reaches.
pub const HYSTERESIS: f64 = 1e-10;

/// Number of continuous states Model Exchange declares: the car's 16, the 5 actuator-lag
/// states (constant, and unused, with an ideal actuator: the number of states of an FMU is
/// fixed by its description), then the vibration meter's.
pub fn model_exchange_states() -> usize {
    N_STATES + N_ACTUATORS + ComfortMeter::order()
}

impl Simulator {
    /// Why Model Exchange cannot run these parameters, if it cannot.
    pub fn model_exchange_refusal(&self) -> Option<String> {
        (self.actuator.tau > 0.0).then(|| {
            format!(
                "tau = {} s: a transport delay has no finite set of states, so Model Exchange cannot integrate it (set it to 0, or use Co-Simulation, which steps it exactly)",
                self.actuator.tau
            )
        })
    }

    /// Map between Model Exchange's state vector and the simulator's `[x; f_lag?; meter]`:
    /// for each of the simulator's states, its index in Model Exchange's.
    fn exchange_index(&mut self, k: usize) -> usize {
        let lag = self.system().lag;
        if k < N_STATES || lag {
            k
        } else {
            k + N_ACTUATORS
        }
    }

    /// `from`, in the simulator's order, into `out` in Model Exchange's (the lag slots zero
    /// with an ideal actuator).
    fn scatter_exchange(&mut self, from: &[f64], out: &mut [f64]) {
        out.fill(0.0);
        for (k, v) in from.iter().enumerate() {
            out[self.exchange_index(k)] = *v;
        }
    }

    /// `x`, in Model Exchange's order, in the simulator's (the lag slots dropped with an
    /// ideal actuator).
    fn gather_exchange(&mut self, x: &[f64]) -> DVector<f64> {
        self.system();
        let n = self.xi.len();
        DVector::from_fn(n, |k, _| x[self.exchange_index(k)])
    }

    /// The continuous states now, in Model Exchange's order.
    pub fn exchange_states(&mut self, out: &mut [f64]) {
        // Built first: building sizes the state, which is taken out meanwhile.
        self.system();
        let xi = std::mem::take(&mut self.xi);
        self.scatter_exchange(xi.as_slice(), out);
        self.xi = xi;
    }

    /// Set the continuous states from Model Exchange's order (the lag slots are ignored with
    /// an ideal actuator).
    pub fn set_exchange_states(&mut self, x: &[f64]) {
        self.xi = self.gather_exchange(x);
    }

    /// The integrator's time: what the actuators' effectiveness and the outputs read.
    pub fn set_exchange_time(&mut self, t: f64) {
        self.time = t;
    }

    /// The contact mode the derivatives use until the next event.
    fn exchange_mode(&self) -> Mode {
        if self.contact.physical {
            self.mode
        } else {
            Mode::LINEAR
        }
    }

    /// `ẋ` in Model Exchange's order, at the current time, states and inputs. `faulted`:
    /// whether the fault has started, a discrete state that changes at its time event only,
    /// so that an integrator reaching the onset still integrates the car before it.
    pub fn exchange_derivatives(&mut self, out: &mut [f64], faulted: bool) {
        let inputs = self.applied_inputs(faulted);
        self.system();
        let xi = std::mem::take(&mut self.xi);
        let dx = self.in_mode(&xi, &inputs, true);
        self.xi = xi;
        self.scatter_exchange(dx.as_slice(), out);
    }

    /// `A x + B [r; v]` (and the mode's constant, if `constant`) in the derivatives' mode.
    fn in_mode(
        &mut self,
        x: &DVector<f64>,
        inputs: &[f64; N_INPUTS],
        constant: bool,
    ) -> DVector<f64> {
        let mode = self.exchange_mode();
        let (a, b) = self.system().matrices(mode);
        let mut dx = a * x;
        for (j, column) in b.column_iter().enumerate() {
            let input = match j {
                j if j < N_INPUTS => inputs[j],
                _ if constant => 1.0,
                _ => 0.0,
            };
            if input != 0.0 {
                dx.axpy(input, &column, 1.0);
            }
        }
        dx
    }

    /// The time the actuators' effectiveness is read at: after the fault's onset, or before.
    fn fault_time_of(faulted: bool) -> f64 {
        if faulted {
            f64::INFINITY
        } else {
            f64::NEG_INFINITY
        }
    }

    /// The road and the actuators' outputs before their lag, `[r; v]`, now (the delayed
    /// command in Co-Simulation, which reads the derivatives as outputs too).
    fn applied_inputs(&self, faulted: bool) -> [f64; N_INPUTS] {
        let now = self.time;
        let seg = self.segment_now();
        let rho_time = Self::fault_time_of(faulted);
        std::array::from_fn(|j| {
            if j < N_ROAD {
                self.road[j]
            } else {
                self.actuator_output(&seg, j - N_ROAD, now, rho_time)
            }
        })
    }

    /// One indicator per unilateral element ([`Unilateral::ALL`]): its guard `min(p, F)`,
    /// positive exactly while it is in contact and pressing, shifted by [`HYSTERESIS`] towards
    /// the side the element is on, so that it changes sign just past where the element
    /// switches. An integrator's root finder may stop exactly on a zero of the guard itself,
    /// where the mode cannot tell which way it is crossing; after the event CVODE takes an
    /// indicator that starts at zero for inactive and would miss the switch (it did, on the
    /// first run through FMPy). Shifted, the indicator is `±HYSTERESIS` (not zero) on the
    /// switching side at the event and jumps to the other sign as the mode switches. The
    /// linear car switches nothing: every indicator is 1.
    pub fn exchange_event_indicators(&mut self, out: &mut [f64]) {
        if !self.contact.physical {
            out.fill(1.0);
            return;
        }
        let z = contact::point(self.state(), &self.road);
        let mode = self.mode;
        let sys = self.system();
        for (k, o) in out.iter_mut().enumerate() {
            let guard = sys.contacts.guard(k, &z);
            *o = if mode.engaged(k) {
                guard + HYSTERESIS
            } else {
                guard - HYSTERESIS
            };
        }
    }

    /// Count the time since `since` in the current mode (an accepted integrator step, or the
    /// run up to an event).
    pub fn account_exchange_time(&mut self, since: f64) {
        let dt = self.time - since;
        if dt > 0.0 {
            self.dwell.add(self.exchange_mode(), dt);
        }
    }

    /// Event Mode: the contacts take the mode the state and road give them. The states do not
    /// jump (a contact changes forces, not positions or velocities). Returns whether the fault
    /// has started (the discrete state of [`Self::exchange_derivatives`]) and the next time
    /// event: the fault's onset, if it is still ahead and changes anything.
    pub fn exchange_event(&mut self) -> (bool, Option<f64>) {
        if self.contact.physical {
            let z = contact::point(self.state(), &self.road);
            let mode = self.mode;
            self.mode = self.system().contacts.reconcile(mode, &z);
        }
        let onset = self.actuator.fault_time;
        let fault = self.actuator.fault_loss.iter().any(|&l| l != 0.0);
        let faulted = self.time >= onset;
        (faulted, (fault && !faulted).then_some(onset))
    }
}

/// The linear part of everything the plant computes, for one direction of its states and
/// inputs ([`Simulator::linear_response`]).
#[derive(Debug, Clone, PartialEq)]
pub struct LinearResponse {
    /// The derivatives, in Model Exchange's order.
    pub derivatives: Vec<f64>,
    /// The physical outputs (the rows of [`vehicle::model::physical_outputs`]).
    pub outputs: Vec<f64>,
    /// The applied forces.
    pub forces: [f64; N_ACTUATORS],
    /// The vibration meter's weighted accelerations.
    pub meter: [f64; N_METER],
    /// The tyres' and stops' forces (the times off the road and at a stop do not move).
    pub contact: ContactState,
}

impl Simulator {
    /// The directional derivative of every derivative and output along `seed_states` (in Model
    /// Exchange's order) and `seed_inputs` (`[r; u]`): between events the plant is affine in
    /// its states and inputs, in the matrices of its contact mode with each actuator inside or
    /// beyond its limit, so this is its linear part computed as such (the mode's matrices
    /// applied to the seed), not a difference: the Jacobians are the model's matrices. A
    /// command at or beyond its limit, or not acting yet behind a transport delay, moves
    /// nothing. `faulted` as in [`Self::exchange_derivatives`].
    pub fn linear_response(
        &mut self,
        seed_states: &[f64],
        seed_inputs: &[f64; N_INPUTS],
        faulted: bool,
    ) -> LinearResponse {
        let seed = self.gather_exchange(seed_states);
        let rho_time = Self::fault_time_of(faulted);
        let mut inputs = *seed_inputs;
        for i in 0..N_ACTUATORS {
            let limit = self.actuator.limit(i);
            let acting = self.actuator.tau == 0.0 && self.command[i].abs() < limit;
            inputs[N_ROAD + i] = if acting {
                self.actuator.effectiveness(i, rho_time) * seed_inputs[N_ROAD + i]
            } else {
                0.0
            };
        }
        let dx = self.in_mode(&seed, &inputs, false);
        let mut derivatives = vec![0.0; model_exchange_states()];
        self.scatter_exchange(dx.as_slice(), &mut derivatives);
        let forces: [f64; N_ACTUATORS] = if self.system().lag {
            std::array::from_fn(|i| seed[N_STATES + i])
        } else {
            std::array::from_fn(|i| inputs[N_ROAD + i])
        };
        // The outputs in the mode they are read in (the tyres reconciled with the road now).
        let at = contact::point(self.state(), &self.road);
        let out_mode = self.mode_at(&at);
        let sys = self.system.as_ref().expect("built above");
        let mut z = [0.0; N_STATES + N_ROAD + N_ACTUATORS];
        z[..N_STATES].copy_from_slice(&seed.as_slice()[..N_STATES]);
        z[N_STATES..N_STATES + N_ROAD].copy_from_slice(&seed_inputs[..N_ROAD]);
        z[N_STATES + N_ROAD..].copy_from_slice(&forces);
        let mut outputs = vec![0.0; sys.output_per_contact.nrows()];
        sys.outputs.apply(&z, &mut outputs);
        let point = contact::point(&z[..N_STATES], &z[N_STATES..]);
        // A contact's force without its constant (the static load, a stop's free travel).
        let linear_force = |k: usize| -> f64 {
            let row = &sys.contacts.elements[k].force;
            row.iter().zip(&point).map(|(a, b)| a * b).sum()
        };
        for (k, sign) in contact::corrections(out_mode) {
            let force = sign * linear_force(k);
            for (y, per) in outputs
                .iter_mut()
                .zip(sys.output_per_contact.column(k).iter())
            {
                *y += per * force;
            }
        }
        let contact = ContactState::in_mode(out_mode, Dwell::default(), linear_force);
        let mut meter = [0.0; N_METER];
        sys.meter_c
            .apply(&seed.as_slice()[sys.meter_at..], &mut meter);
        LinearResponse {
            derivatives,
            outputs,
            forces,
            meter,
            contact,
        }
    }
}

/// What each of Model Exchange's derivatives can depend on, for any parameters and in any
/// contact mode: `(states, inputs)`, indices into Model Exchange's states and into `[r; u]`.
/// The union of the patterns of `[A B]` with and without the actuators' lag, in the linear
/// car's mode and with each contact switched alone (a mode's matrices are the linear car's
/// plus one correction per switched contact, so any mode's pattern lies in that union), for
/// the default parameters and for generic ones (each scaled apart, so that no entry vanishes
/// by a coincidence of the defaults, such as a symmetric track).
pub fn derivative_dependencies() -> Vec<(Vec<usize>, Vec<usize>)> {
    let n = model_exchange_states();
    let mut states = vec![std::collections::BTreeSet::new(); n];
    let mut inputs = vec![std::collections::BTreeSet::new(); n];
    let mut generic = VehicleParams::default();
    for (k, spec) in vehicle::params::PARAMETERS.iter().enumerate() {
        let value = (spec.get)(&generic) * (1.0 + 0.0137 * (k + 1) as f64);
        // A value outside its admissible range keeps the default.
        let _ = generic.set(spec.name, value);
    }
    for params in [VehicleParams::default(), generic] {
        for bandwidth in [0.0, 10.0] {
            let actuator = ActuatorParams {
                bandwidth,
                ..ActuatorParams::default()
            };
            let mut sim = Simulator::new(params, actuator);
            let modes = std::iter::once(Mode::LINEAR)
                .chain((0..N_UNILATERAL).map(|k| Mode::LINEAR.with(k, !Mode::LINEAR.engaged(k))));
            for mode in modes {
                let rows: Vec<usize> = (0..sim.xi.len()).map(|k| sim.exchange_index(k)).collect();
                let (a, b) = sim.system().matrices(mode);
                for (i, &row) in rows.iter().enumerate() {
                    for (j, &column) in rows.iter().enumerate() {
                        if a[(i, j)] != 0.0 {
                            states[row].insert(column);
                        }
                    }
                    for j in 0..N_INPUTS {
                        if b[(i, j)] != 0.0 {
                            inputs[row].insert(j);
                        }
                    }
                }
            }
        }
    }
    states
        .into_iter()
        .zip(inputs)
        .map(|(s, i)| (s.into_iter().collect(), i.into_iter().collect()))
        .collect()
}
