//! The sensor model of the sensors a production car has ([`vehicle::sensors`]). Each reads its
//! physical output exactly while the sensor model is off (the default);
//! switched on, each adds a bias and white noise, deterministic from a seed, so that a master
//! tests a controller with the signals a car gives it and a run repeats to the last bit.
//!
//! The noise is what a sensor averaging over the communication step reads: a density `N`
//! (one-sided, per √Hz) gives samples of standard deviation `N / √(2h)` at step `h`, a new one
//! after each step, held until the next. A height sensor's figure is its resolution, a
//! standard deviation per sample. Biases are constant: each sensor's is drawn once, uniform in
//! `[−b, b]`, when initialisation ends. Before the first step the noise is 0.

use fmu_core::fmu_state::{StateReader, StateWriter};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

pub use vehicle::sensors::{Kind, N_SENSORS, PREFIX, SENSORS};

/// The sensor model's parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorParams {
    /// Bias and noise on (`sensor_model`).
    pub on: bool,
    /// Height sensors' resolution, standard deviation per sample \[m\].
    pub noise_height: f64,
    /// Accelerometers' noise density [m/s²/√Hz].
    pub noise_acceleration: f64,
    /// Gyros' noise density [rad/s/√Hz].
    pub noise_rate: f64,
    /// Accelerometers' largest bias [m/s²].
    pub bias_acceleration: f64,
    /// Gyros' largest bias [rad/s].
    pub bias_rate: f64,
    /// Seed of the biases and the noise.
    pub seed: u64,
}

/// Production figures (`../shared/notes/real-car.md`): height sensors 0.3 mm, MEMS
/// accelerometers 2·10⁻³ m/s²/√Hz (about 200 µg/√Hz) with a bias up to 20 mg, gyros
/// 0.01 °/s/√Hz with a bias up to 0.2 °/s.
impl Default for SensorParams {
    fn default() -> Self {
        SensorParams {
            on: false,
            noise_height: 3e-4,
            noise_acceleration: 2e-3,
            noise_rate: 0.01f64.to_radians(),
            bias_acceleration: 0.02 * 9.81,
            bias_rate: 0.2f64.to_radians(),
            seed: 1,
        }
    }
}

impl SensorParams {
    /// The standard deviation of a sample of a sensor of `kind` held over a step `h` \[s\].
    pub fn sigma(&self, kind: Kind, h: f64) -> f64 {
        match kind {
            Kind::Height => self.noise_height,
            Kind::Accelerometer => self.noise_acceleration / (2.0 * h).sqrt(),
            Kind::Gyro => self.noise_rate / (2.0 * h).sqrt(),
        }
    }

    fn bias_bound(&self, kind: Kind) -> f64 {
        match kind {
            Kind::Height => 0.0,
            Kind::Accelerometer => self.bias_acceleration,
            Kind::Gyro => self.bias_rate,
        }
    }
}

/// The sensors' state: the stream of draws, each sensor's bias and its current noise sample.
#[derive(Debug, Clone)]
pub struct Sensors {
    pub params: SensorParams,
    rng: ChaCha8Rng,
    bias: [f64; N_SENSORS],
    sample: [f64; N_SENSORS],
}

impl Sensors {
    pub fn new(params: SensorParams) -> Self {
        Sensors {
            params,
            rng: ChaCha8Rng::seed_from_u64(params.seed),
            bias: [0.0; N_SENSORS],
            sample: [0.0; N_SENSORS],
        }
    }

    /// Initialisation ended: the stream from the seed, the biases drawn, no noise yet.
    pub fn start(&mut self) {
        *self = Sensors::new(self.params);
        if self.params.on {
            for (b, (_, kind)) in self.bias.iter_mut().zip(SENSORS) {
                let bound = self.params.bias_bound(kind);
                *b = bound * self.rng.gen_range(-1.0..=1.0);
            }
        }
    }

    /// A step of `h` \[s\] was taken: the next noise samples.
    pub fn advance(&mut self, h: f64) {
        if self.params.on {
            for (s, (_, kind)) in self.sample.iter_mut().zip(SENSORS) {
                let n: f64 = self.rng.sample(StandardNormal);
                *s = self.params.sigma(kind, h) * n;
            }
        }
    }

    /// What the sensors read when the physical outputs they measure are `truth`.
    pub fn read(&self, truth: &[f64; N_SENSORS]) -> [f64; N_SENSORS] {
        std::array::from_fn(|i| truth[i] + self.bias[i] + self.sample[i])
    }

    /// The stream's position, the biases and the samples (the parameters are saved with the
    /// plant's).
    pub fn save(&self, out: &mut StateWriter) {
        let pos = self.rng.get_word_pos();
        out.u64((pos >> 64) as u64);
        out.u64(pos as u64);
        out.f64s(&self.bias);
        out.f64s(&self.sample);
    }

    /// What [`Sensors::save`] wrote, for `params`.
    pub fn restored(params: SensorParams, input: &mut StateReader) -> Result<Sensors, String> {
        let pos = (u128::from(input.u64()?) << 64) | u128::from(input.u64()?);
        let bias = input.f64s_exact(N_SENSORS, "sensor biases")?;
        let sample = input.f64s_exact(N_SENSORS, "sensor noise")?;
        if !bias.iter().chain(&sample).all(|v| v.is_finite()) {
            return Err("FMU state holds non-finite sensor values".into());
        }
        let mut s = Sensors::new(params);
        s.rng.set_word_pos(pos);
        s.bias.copy_from_slice(&bias);
        s.sample.copy_from_slice(&sample);
        Ok(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn on() -> SensorParams {
        SensorParams {
            on: true,
            ..SensorParams::default()
        }
    }

    /// Over many steps each sensor's samples have the mean of its bias and the standard
    /// deviation its density gives at that step (within their sampling error, 4 sigma).
    #[test]
    fn samples_have_the_bias_and_the_deviation_the_density_gives() {
        let (h, n) = (1e-3, 40_000);
        let mut s = Sensors::new(on());
        s.start();
        let mut sum = [0.0; N_SENSORS];
        let mut sum2 = [0.0; N_SENSORS];
        for _ in 0..n {
            s.advance(h);
            let r = s.read(&[0.0; N_SENSORS]);
            for i in 0..N_SENSORS {
                sum[i] += r[i];
                sum2[i] += (r[i] - s.bias[i]).powi(2);
            }
        }
        for (i, (name, kind)) in SENSORS.iter().enumerate() {
            let sigma = on().sigma(*kind, h);
            let mean = sum[i] / n as f64;
            let sd = (sum2[i] / n as f64).sqrt();
            let bound = on().bias_bound(*kind);
            assert!(s.bias[i].abs() <= bound, "{name}");
            assert!(
                (mean - s.bias[i]).abs() < 4.0 * sigma / (n as f64).sqrt(),
                "{name} mean"
            );
            assert!(
                (sd / sigma - 1.0).abs() < 4.0 / (2.0 * n as f64).sqrt(),
                "{name} sd"
            );
        }
        // Accelerometer at 1 ms: 2e-3 / √(2e-3) = 0.0447 m/s².
        assert!((on().sigma(Kind::Accelerometer, h) - 0.044721).abs() < 1e-6);
    }

    /// Off, a sensor reads its physical output to the last bit; on, the same seed gives the
    /// same readings, another seed others, and a saved state continues identically.
    #[test]
    fn readings_are_exact_when_off_and_repeat_from_a_seed_and_a_saved_state() {
        let truth: [f64; N_SENSORS] = std::array::from_fn(|i| i as f64 * 0.37 - 1.1);
        let mut off = Sensors::new(SensorParams::default());
        off.start();
        off.advance(1e-3);
        assert_eq!(off.read(&truth), truth);
        let run = |seed: u64, steps: usize| {
            let mut s = Sensors::new(SensorParams { seed, ..on() });
            s.start();
            for _ in 0..steps {
                s.advance(1e-3);
            }
            s
        };
        let (a, b) = (run(7, 100), run(7, 100));
        assert_eq!(a.read(&truth), b.read(&truth));
        assert_ne!(a.read(&truth), run(8, 100).read(&truth));
        let mut saved = StateWriter::default();
        a.save(&mut saved);
        let bytes = saved.into_bytes();
        let mut c = Sensors::restored(a.params, &mut StateReader::new(&bytes)).unwrap();
        let mut a = a;
        for _ in 0..50 {
            a.advance(2e-3);
            c.advance(2e-3);
        }
        assert_eq!(
            a.read(&truth).map(f64::to_bits),
            c.read(&truth).map(f64::to_bits)
        );
    }
}
