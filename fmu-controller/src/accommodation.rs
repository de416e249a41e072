//! Fault accommodation from measured applied forces: the runtime of `controller.json`'s
//! `accommodation` block.
//!
//! A load cell measures what actuator `i` applies, `fᵢ = ρᵢ uᵢ` for the command `uᵢ` it was
//! sent (one communication step earlier: the plant applies the held command over the step and
//! reports its force at the next point). The effectiveness is estimated as
//! `ρ̂ᵢ = √(Eᵢ[f²] / Eᵢ[u²])`, both means exponentially weighted over `time_constant`, and the
//! command sent is the controller's `yᵢ / ρ̂ᵢ`: the force applied is then the one the controller
//! asked for. The ratio of the two means is a weighted average of the instantaneous ratios
//! `fᵢ²/uᵢ² = ρᵢ²` (weights `uᵢ²` times the forgetting factor), so after a loss of effectiveness
//! `ρ̂ᵢ` falls monotonically from its healthy value to the new `ρᵢ`, never below it: the loop
//! meanwhile sees a gain `ρᵢ/ρ̂ᵢ` between `ρᵢ` and 1, inside the effectiveness box the synthesis
//! certifies every frozen loop of. It is clamped to `[rho_min, 1]`. A saturating actuator
//! applies `ρ sat(u)`: the estimate reads the command saturated at the actuator's limit (the
//! parameters `u_max`, `u_max_seat`, set equal to the plant's), so saturation is not mistaken
//! for a loss. A lagging actuator applies its saturated command through a first-order lag of
//! bandwidth `f_a` (the parameter `actuator_bandwidth`, set equal to the plant's; 0, ideal):
//! the force compared is the command through the same lag, stepped exactly as the plant steps
//! it (the command held over each step), so a lag is not mistaken for a loss either. That
//! modelled force is also what a load-cell fault detector compares its measurement with
//! ([`Estimator::modelled`]).

use crate::spec::Accommodation;
use fmu_core::fmu_state::{StateReader, StateWriter};

/// Below this mean square command [N²] (1 µN RMS) the ratio says nothing: the estimate holds.
const MIN_ENERGY: f64 = 1e-12;

#[derive(Debug, Clone)]
pub struct Estimator {
    spec: Accommodation,
    /// Weighted means of `f²` and of the modelled force's square per actuator, and the force
    /// each actuator applies now as modelled: the commands sent before, saturated, through the
    /// lag.
    force_energy: Vec<f64>,
    command_energy: Vec<f64>,
    modelled: Vec<f64>,
    /// The actuators' lag \[Hz\] (0: ideal).
    bandwidth: f64,
}

impl Estimator {
    pub fn new(spec: Accommodation) -> Self {
        let n = spec.force_inputs.len();
        Estimator {
            bandwidth: spec.actuator_bandwidth,
            spec,
            force_energy: vec![0.0; n],
            command_energy: vec![0.0; n],
            modelled: vec![0.0; n],
        }
    }

    pub fn reset(&mut self) {
        for v in [
            &mut self.force_energy,
            &mut self.command_energy,
            &mut self.modelled,
        ] {
            v.fill(0.0);
        }
    }

    /// `ρ̂ᵢ` (1 until the actuator has been commanded).
    pub fn rho_hat(&self, i: usize) -> f64 {
        let (f, u) = (self.force_energy[i], self.command_energy[i]);
        if u > MIN_ENERGY {
            (f / u).sqrt().clamp(self.spec.rho_min, 1.0)
        } else {
            1.0
        }
    }

    /// The commands to send for the controller's `y`: `yᵢ / ρ̂ᵢ`, in place.
    pub fn compensate(&self, u: &mut [f64]) {
        for (i, u) in u.iter_mut().enumerate() {
            *u /= self.rho_hat(i);
        }
    }

    /// The actuators' lag \[Hz\].
    pub fn bandwidth(&self) -> f64 {
        self.bandwidth
    }

    /// Set the actuators' lag \[Hz\] (0: ideal), checked by the caller.
    pub fn set_bandwidth(&mut self, hz: f64) {
        self.bandwidth = hz;
    }

    /// The force each actuator applies now, as modelled from the commands sent before.
    pub fn modelled(&self) -> &[f64] {
        &self.modelled
    }

    /// Take in the step that starts now: the measured forces among the `inputs` answer the
    /// modelled ones, which the commands sent before make; `sent` are the ones sent for this
    /// step, saturated at the actuators' `limits` and held over it.
    pub fn step(&mut self, inputs: &[f64], sent: &[f64], limits: &[f64], step: f64) {
        let keep = (-step / self.spec.time_constant).exp();
        // The lag over the step, exact for a held command (an ideal actuator: the command).
        let lag = if self.bandwidth > 0.0 {
            (-2.0 * std::f64::consts::PI * self.bandwidth * step).exp()
        } else {
            0.0
        };
        for (i, &k) in self.spec.force_inputs.iter().enumerate() {
            let (f, m) = (inputs[k], self.modelled[i]);
            self.force_energy[i] = keep * self.force_energy[i] + (1.0 - keep) * f * f;
            self.command_energy[i] = keep * self.command_energy[i] + (1.0 - keep) * m * m;
            let u = sent[i].clamp(-limits[i], limits[i]);
            self.modelled[i] = if lag > 0.0 {
                lag * m + (1.0 - lag) * u
            } else {
                u
            };
        }
    }

    pub fn save(&self, out: &mut StateWriter) {
        out.f64s(&self.force_energy);
        out.f64s(&self.command_energy);
        out.f64s(&self.modelled);
        out.f64(self.bandwidth);
    }

    /// This estimator with a saved state, checked (means finite and ≥ 0), or why not.
    pub fn restored(&self, input: &mut StateReader) -> Result<Self, String> {
        let n = self.force_inputs();
        let mut e = self.clone();
        e.force_energy = input.f64s_exact(n, "accommodation force means")?;
        e.command_energy = input.f64s_exact(n, "accommodation command means")?;
        e.modelled = input.f64s_exact(n, "accommodation modelled forces")?;
        e.bandwidth = input.f64()?;
        let means_ok = e
            .force_energy
            .iter()
            .chain(&e.command_energy)
            .all(|v| v.is_finite() && *v >= 0.0);
        let bandwidth_ok = crate::spec::actuator_bandwidth_ok(e.bandwidth);
        if !means_ok || !bandwidth_ok || !e.modelled.iter().all(|v| v.is_finite()) {
            return Err("FMU state holds an invalid effectiveness estimate".into());
        }
        Ok(e)
    }

    fn force_inputs(&self) -> usize {
        self.spec.force_inputs.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn estimator() -> Estimator {
        Estimator::new(Accommodation {
            force_inputs: vec![1, 0],
            rho_min: 0.5,
            time_constant: 0.1,
            u_max: vec![1e9, 1e9],
            actuator_bandwidth: 0.0,
        })
    }

    /// An actuator that applies `ρ u` of the command held over the step before: the estimate
    /// is exact from its first commanded step, tracks a loss from above without undershooting,
    /// settles on it, and the compensated command makes the applied force the asked one.
    #[test]
    fn the_estimate_falls_to_the_effectiveness_from_above_and_compensates_it() {
        let mut e = estimator();
        let h = 1e-3;
        let (mut sent, mut last) = ([0.0; 2], [1.0f64; 2]);
        for k in 0..2000 {
            let t = k as f64 * h;
            let rho = [if t < 0.5 { 0.8 } else { 0.5 }, 1.0];
            // The forces measured now answer the commands sent the step before.
            let forces = [rho[0] * sent[0], rho[1] * sent[1]];
            let asked = [100.0 * (40.0 * t).sin(), 50.0 * (13.0 * t).cos()];
            let mut u = asked;
            e.compensate(&mut u);
            if k > 1 {
                // Applied (next point) over asked equals ρ/ρ̂ of the estimate the command used.
                let r0 = e.rho_hat(0);
                assert!(
                    r0 >= rho[0] - 1e-12 && r0 <= last[0] + 1e-12,
                    "t = {t}: {r0}"
                );
                last[0] = r0;
                assert!((e.rho_hat(1) - 1.0).abs() < 1e-12);
            }
            if (0.05..0.5).contains(&t) {
                assert!((e.rho_hat(0) - 0.8).abs() < 1e-12, "t = {t}");
                assert!((rho[0] * u[0] - asked[0]).abs() < 1e-9 * 100.0);
            }
            e.step(&[forces[1], forces[0]], &u, &[1e9, 1e9], h);
            sent = u;
        }
        assert!((e.rho_hat(0) - 0.5).abs() < 1e-6, "{}", e.rho_hat(0));
    }

    /// A healthy actuator behind a first-order lag, simulated exactly as the plant steps it (the
    /// command held over each step, `ḟ = 2π f_a (u − f)`): with the lag modelled the estimate
    /// stays at 1 to rounding and the modelled force is the applied one; with the lag not
    /// modelled (an ideal actuator assumed) the lag reads as a loss, as it did before the model.
    #[test]
    fn a_modelled_lag_is_not_a_loss() {
        let (h, hz) = (1e-3, 10.0);
        let run = |modelled_hz: f64| {
            let mut e = estimator();
            e.set_bandwidth(modelled_hz);
            let (mut applied, mut sent) = ([0.0f64; 2], [0.0f64; 2]);
            let decay = (-2.0 * std::f64::consts::PI * hz * h).exp();
            for k in 0..3000 {
                let t = k as f64 * h;
                // The plant stepped over the last step with the command held.
                for (f, u) in applied.iter_mut().zip(sent) {
                    *f = decay * *f + (1.0 - decay) * u;
                }
                if modelled_hz > 0.0 {
                    for (m, f) in e.modelled().iter().zip(applied) {
                        assert!((m - f).abs() <= 1e-9 * 300.0);
                    }
                }
                let u = [300.0 * (2.0 * t).sin() + 200.0 * (60.0 * t).sin(), 50.0];
                e.step(&[applied[1], applied[0]], &u, &[1e9, 1e9], h);
                sent = u;
            }
            e.rho_hat(0)
        };
        let modelled = run(hz);
        assert!((modelled - 1.0).abs() < 1e-9, "{modelled}");
        let unmodelled = run(0.0);
        assert!(unmodelled < 0.95, "{unmodelled}");
    }

    #[test]
    fn the_estimate_holds_without_commands_and_stays_in_the_box() {
        let mut e = estimator();
        assert_eq!(e.rho_hat(0), 1.0);
        e.step(&[0.0, 0.0], &[0.0, 0.0], &[1e9, 1e9], 1e-3);
        e.step(&[0.0, 0.0], &[0.0, 0.0], &[1e9, 1e9], 1e-3);
        assert_eq!(e.rho_hat(0), 1.0);
        // A force ratio below the box (a saturated or dead actuator) is clamped to its edge,
        // one above 1 to 1.
        e.step(&[0.0, 0.0], &[10.0, 10.0], &[1e9, 1e9], 1e-3);
        e.step(&[20.0, 1.0], &[10.0, 10.0], &[1e9, 1e9], 1e-3);
        assert_eq!(e.rho_hat(0), 0.5);
        assert_eq!(e.rho_hat(1), 1.0);
        // A healthy actuator saturating at 40 N applies 40 N of a 100 N command: read against
        // the saturated command, that is no loss.
        let mut e = estimator();
        for _ in 0..3 {
            e.step(&[40.0, 40.0], &[100.0, 100.0], &[40.0, 1e9], 1e-3);
        }
        assert_eq!(e.rho_hat(0), 1.0);
        // The same read against an unsaturated command is a loss (clamped to the box).
        assert_eq!(e.rho_hat(1), 0.5);
    }

    #[test]
    fn a_saved_estimate_restores_and_a_corrupt_one_is_refused() {
        let mut e = estimator();
        e.step(&[0.0, 0.0], &[10.0, 4.0], &[1e9, 1e9], 1e-3);
        e.step(&[3.0, 7.0], &[10.0, 4.0], &[1e9, 1e9], 1e-3);
        let mut w = StateWriter::default();
        e.save(&mut w);
        let bytes = w.into_bytes();
        let back = estimator().restored(&mut StateReader::new(&bytes)).unwrap();
        assert_eq!(back.rho_hat(0).to_bits(), e.rho_hat(0).to_bits());
        assert_eq!(back.rho_hat(1).to_bits(), e.rho_hat(1).to_bits());
        let mut w = StateWriter::default();
        w.f64s(&[f64::NAN, 0.0]);
        w.f64s(&[1.0, 1.0]);
        w.f64s(&[0.0, 0.0]);
        w.f64(0.0);
        let bytes = w.into_bytes();
        assert!(estimator().restored(&mut StateReader::new(&bytes)).is_err());
    }
}
