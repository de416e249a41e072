//! ISO 2631-1:1997 frequency weightings for whole-body vibration (Annex A), as the cascades of
//! second-order sections the standard defines them by: what a seated person feels of the seat's
//! vertical acceleration (`W_k`) and of the seat's roll and pitch acceleration (`W_e`). One
//! definition for the master's comfort metrics and for the synthesis's comfort objective.
//!
//! `W = H_h H_l H_t H_s` (parameters of ISO 8041 Table 3.1 / ISO 2631-1 Table A.2):
//! band-limiting second-order Butterworth high-pass `s²/(s² + ω₁s/Q₁ + ω₁²)` and low-pass
//! `ω₂²/(s² + ω₂s/Q₂ + ω₂²)` (`Q₁ = Q₂ = 1/√2`), the acceleration–velocity transition
//! `(ω₄²/ω₃ s + ω₄²)/(s² + ω₄s/Q₄ + ω₄²)` and, for `W_k`, the upward step
//! `(s² + ω₅s/Q₅ + ω₅²)/(s² + ω₆s/Q₆ + ω₆²)` (`ωᵢ = 2π fᵢ`).

use crate::model::{OutputRow, N_ACTUATORS, N_ROAD, N_STATES};
use nalgebra::{Complex, DMatrix};
use std::f64::consts::{FRAC_1_SQRT_2, PI};

/// ISO 2631-1 §8.2.3 multiplying factors for comfort, seated person, rotational vibration of
/// the seat surface: the roll and pitch accelerations (rad/s², weighted by `W_e`) times these
/// count as m/s² in the vibration total value `a_v = √(a_wz² + (k_x a_wφ)² + (k_y a_wθ)²)`.
pub const ROLL_FACTOR: f64 = 0.63;
/// [m/rad], see [`ROLL_FACTOR`].
pub const PITCH_FACTOR: f64 = 0.40;

/// `(b₂ s² + b₁ s + b₀) / (s² + a₁ s + a₀)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Section {
    pub b: [f64; 3],
    pub a: [f64; 2],
}

impl Section {
    fn response(&self, s: Complex<f64>) -> Complex<f64> {
        (s * s * self.b[2] + s * self.b[1] + self.b[0]) / (s * s + s * self.a[1] + self.a[0])
    }
}

/// A frequency weighting: the product of its sections.
#[derive(Debug, Clone, PartialEq)]
pub struct Weighting {
    pub name: &'static str,
    pub sections: Vec<Section>,
}

/// The band-limiting low-pass is the second section of every weighting here.
const LOW_PASS: usize = 1;

fn w(f: f64) -> f64 {
    2.0 * PI * f
}

/// High-pass, low-pass and a–v transition of the standard's parameters `f₁ … Q₄` [Hz].
fn band_and_transition(f1: f64, f2: f64, f3: f64, f4: f64, q4: f64) -> Vec<Section> {
    let (w1, w2, w3, w4) = (w(f1), w(f2), w(f3), w(f4));
    vec![
        Section {
            b: [0.0, 0.0, 1.0],
            a: [w1 * w1, w1 / FRAC_1_SQRT_2],
        },
        Section {
            b: [w2 * w2, 0.0, 0.0],
            a: [w2 * w2, w2 / FRAC_1_SQRT_2],
        },
        Section {
            b: [w4 * w4, w4 * w4 / w3, 0.0],
            a: [w4 * w4, w4 / q4],
        },
    ]
}

impl Weighting {
    /// `W_k`: vertical acceleration of the seat surface (comfort and health, seated).
    pub fn wk() -> Self {
        let mut sections = band_and_transition(0.4, 100.0, 12.5, 12.5, 0.63);
        let (w5, w6) = (w(2.37), w(3.35));
        sections.push(Section {
            b: [w5 * w5, w5 / 0.91, 1.0],
            a: [w6 * w6, w6 / 0.91],
        });
        Weighting {
            name: "W_k",
            sections,
        }
    }

    /// `W_e`: rotational (roll, pitch, yaw) acceleration of the seat surface (comfort, seated).
    pub fn we() -> Self {
        Weighting {
            name: "W_e",
            sections: band_and_transition(0.4, 100.0, 1.0, 1.0, 0.63),
        }
    }

    /// The weighting without its 100 Hz band-limiting low-pass: within 0.1 % of the full one
    /// below 16 Hz and 1 % at 31.5 Hz, two states fewer and none at 628 rad/s, which would only
    /// stiffen a design model. The comfort figures are always computed with the full weighting.
    pub fn without_low_pass(&self) -> Self {
        let mut sections = self.sections.clone();
        sections.remove(LOW_PASS);
        Weighting {
            name: self.name,
            sections,
        }
    }

    /// `W(j 2π f)`.
    pub fn response(&self, f: f64) -> Complex<f64> {
        let s = Complex::new(0.0, w(f));
        self.sections.iter().map(|x| x.response(s)).product()
    }

    /// `|W(j 2π f)|`.
    pub fn gain(&self, f: f64) -> f64 {
        self.response(f).norm()
    }

    /// A state-space realisation `(A, B, C, D)` of the cascade (single input, single output):
    /// each section in controllable canonical form `x' = [[0, 1], [−a₀, −a₁]] x + [0; 1] v`,
    /// `y = [b₀ − b₂a₀, b₁ − b₂a₁] x + b₂ v`, feeding the next.
    pub fn state_space(&self) -> [DMatrix<f64>; 4] {
        let n = 2 * self.sections.len();
        let (mut a, mut b) = (DMatrix::zeros(n, n), DMatrix::zeros(n, 1));
        let (mut c, mut d) = (DMatrix::zeros(1, n), DMatrix::from_element(1, 1, 1.0));
        for (k, sec) in self.sections.iter().enumerate() {
            let i = 2 * k;
            // This section's input is the previous output `c x + d v`.
            a[(i, i + 1)] = 1.0;
            a[(i + 1, i)] = -sec.a[0];
            a[(i + 1, i + 1)] = -sec.a[1];
            for j in 0..i {
                a[(i + 1, j)] = c[(0, j)];
            }
            b[(i + 1, 0)] = d[(0, 0)];
            let out = [
                sec.b[0] - sec.b[2] * sec.a[0],
                sec.b[1] - sec.b[2] * sec.a[1],
            ];
            c.iter_mut().for_each(|v| *v *= sec.b[2]);
            c[(0, i)] = out[0];
            c[(0, i + 1)] = out[1];
            d[(0, 0)] *= sec.b[2];
        }
        [a, b, c, d]
    }
}

/// The weighted comfort signals of the seat's vibration meter: `(output, signal it weights,
/// unit, description)`, the weighting being `W_k` for the first and `W_e` for the others
/// ([`ComfortMeter::weightings`]).
pub const METER_OUTPUTS: [(&str, &str, &str, &str); 3] = [
    (
        "a_seat_wk",
        "a_seat",
        "m/s2",
        "Seat vertical acceleration weighted by ISO 2631-1 W_k (the full weighting, band limits included), integrated exactly with the car (sample it: its RMS is the comfort figure; do not weight the samples of a_seat)",
    ),
    (
        "alpha_roll_we",
        "alpha_roll",
        "rad/s2",
        "Body roll acceleration weighted by ISO 2631-1 W_e (the full weighting, band limits included), integrated exactly with the car",
    ),
    (
        "alpha_pitch_we",
        "alpha_pitch",
        "rad/s2",
        "Body pitch acceleration weighted by ISO 2631-1 W_e (the full weighting, band limits included), integrated exactly with the car",
    ),
];

/// Where a system keeps the applied forces the meter reads ([`ComfortMeter::place`]): the inputs
/// or the states from this index on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Forces {
    Inputs(usize),
    States(usize),
}

/// The seat's vibration meter: the ISO 2631-1 weightings of the comfort signals as one linear
/// block driven by the car, `ẇ = A w + B [x; r; f]`, weighted signals `C w`.
///
/// A weighted signal sampled from a master is not the weighting of the sampled signal: under
/// held commands the seat acceleration jumps at every communication point (the force feeds
/// through), so a weighting run on the samples (joined by lines) misjudges the RMS: by up to
/// a sixth for the shipped designs at 1 ms. Integrated with the car, the weighted signal is
/// continuous (every weighting's band-limiting low-pass has no feedthrough, so `D = 0`) and
/// its samples' mean square is the time average's (`synth::predict::sampled` predicts both).
#[derive(Debug, Clone)]
pub struct ComfortMeter {
    /// `n_w × n_w`: the weightings' cascades, one diagonal block per signal.
    pub a: DMatrix<f64>,
    /// `n_w × (N_STATES + N_ROAD + N_ACTUATORS)`: each filter's input is its signal's row
    /// `c x + d_r r + d_u f`.
    pub b: DMatrix<f64>,
    /// `3 × n_w`: the weighted signals in the order of [`METER_OUTPUTS`].
    pub c: DMatrix<f64>,
    /// `n_w × 3`: the filters' inputs per unit of each signal of [`METER_OUTPUTS`]
    /// (`b` is this times the signals' rows).
    pub gain: DMatrix<f64>,
}

impl ComfortMeter {
    /// The weighting of each of [`METER_OUTPUTS`].
    pub fn weightings() -> [Weighting; 3] {
        [Weighting::wk(), Weighting::we(), Weighting::we()]
    }

    /// The meter on the outputs `rows` (those of [`crate::model::physical_outputs`]).
    pub fn new(rows: &[OutputRow]) -> Self {
        let filters = Self::weightings().map(|w| w.state_space());
        let n: usize = filters.iter().map(|f| f[0].nrows()).sum();
        let inputs = N_STATES + N_ROAD + N_ACTUATORS;
        let (mut a, mut b, mut c) = (
            DMatrix::zeros(n, n),
            DMatrix::zeros(n, inputs),
            DMatrix::zeros(METER_OUTPUTS.len(), n),
        );
        let mut gain = DMatrix::zeros(n, METER_OUTPUTS.len());
        let mut at = 0;
        for (k, ([a_w, b_w, c_w, d_w], (_, signal, _, _))) in
            filters.iter().zip(METER_OUTPUTS).enumerate()
        {
            assert_eq!(
                d_w[(0, 0)],
                0.0,
                "a band-limited weighting has no feedthrough"
            );
            let row = rows
                .iter()
                .find(|r| r.name == signal)
                .unwrap_or_else(|| panic!("the car has no output {signal}"));
            let over_inputs: Vec<f64> = row.coefficients().copied().collect();
            let nw = a_w.nrows();
            a.view_mut((at, at), (nw, nw)).copy_from(a_w);
            b.view_mut((at, 0), (nw, inputs))
                .copy_from(&(b_w * DMatrix::from_row_slice(1, inputs, &over_inputs)));
            c.view_mut((k, at), (1, nw)).copy_from(c_w);
            gain.view_mut((at, k), (nw, 1)).copy_from(b_w);
            at += nw;
        }
        ComfortMeter { a, b, c, gain }
    }

    /// Writes the meter into a system `ẋ = A x + B v` whose first 16 states are the car's and
    /// whose first 8 inputs are the road's: the meter's states from `at` on, reading the applied
    /// forces where `forces` says they are.
    pub fn place(&self, a: &mut DMatrix<f64>, b: &mut DMatrix<f64>, at: usize, forces: Forces) {
        let n = self.a.nrows();
        a.view_mut((at, at), (n, n)).copy_from(&self.a);
        a.view_mut((at, 0), (n, N_STATES))
            .copy_from(&self.b.columns(0, N_STATES));
        b.view_mut((at, 0), (n, N_ROAD))
            .copy_from(&self.b.columns(N_STATES, N_ROAD));
        let on_forces = self.b.columns(N_STATES + N_ROAD, N_ACTUATORS);
        match forces {
            Forces::Inputs(k) => b.view_mut((at, k), (n, N_ACTUATORS)).copy_from(&on_forces),
            Forces::States(k) => a.view_mut((at, k), (n, N_ACTUATORS)).copy_from(&on_forces),
        }
    }

    /// Number of filter states (two per second-order section).
    pub fn order() -> usize {
        Self::weightings()
            .iter()
            .map(|w| 2 * w.sections.len())
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ISO 2631-1 Table 3 (`W_k`) and Table 4 (`W_e`), factors × 1000 at the nominal
    /// one-third-octave band centres, given to three significant figures (some rounded, some
    /// cut: 768.7 is listed as 768, 938.7 as 939).
    const WK_TABLE: [(f64, f64); 10] = [
        (0.5, 418.0),
        (1.0, 482.0),
        (2.0, 531.0),
        (4.0, 967.0),
        (6.3, 1054.0),
        (8.0, 1036.0),
        (12.5, 902.0),
        (16.0, 768.0),
        (31.5, 405.0),
        (80.0, 132.0),
    ];
    const WE_TABLE: [(f64, f64); 10] = [
        (0.5, 862.0),
        (0.63, 939.0),
        (1.0, 880.0),
        (2.0, 512.0),
        (4.0, 253.0),
        (8.0, 125.0),
        (10.0, 100.0),
        (16.0, 62.5),
        (31.5, 31.6),
        (80.0, 10.5),
    ];

    #[test]
    fn weightings_match_the_standards_tables() {
        for (weighting, table) in [(Weighting::wk(), WK_TABLE), (Weighting::we(), WE_TABLE)] {
            for (f, factor) in table {
                let g = 1000.0 * weighting.gain(f);
                // One unit of the third significant figure.
                let tolerance = 10f64.powf(factor.log10().floor() - 2.0);
                assert!(
                    (g - factor).abs() <= tolerance,
                    "{} at {f} Hz: {g:.2} vs the table's {factor}",
                    weighting.name
                );
            }
        }
    }

    #[test]
    fn state_space_realises_the_cascade_and_the_low_pass_only_matters_above_the_body_band() {
        for full in [Weighting::wk(), Weighting::we()] {
            for weighting in [full.clone(), full.without_low_pass()] {
                let [a, b, c, d] = weighting.state_space();
                for f in [0.1, 0.7, 2.0, 5.0, 11.0, 40.0, 300.0] {
                    let s = Complex::new(0.0, w(f));
                    let n = a.nrows();
                    let m = DMatrix::<Complex<f64>>::identity(n, n) * s
                        - a.map(|v| Complex::new(v, 0.0));
                    let x = m.lu().solve(&b.map(|v| Complex::new(v, 0.0))).unwrap();
                    let g = (c.map(|v| Complex::new(v, 0.0)) * x)[(0, 0)] + d[(0, 0)];
                    let exact = weighting.response(f);
                    assert!((g - exact).norm() <= 1e-9 * exact.norm(), "{f} Hz");
                }
            }
            let reduced = full.without_low_pass();
            assert_eq!(reduced.sections.len() + 1, full.sections.len());
            for f in [0.5, 1.0, 4.0, 8.0, 16.0] {
                let rel = (reduced.gain(f) - full.gain(f)).abs() / full.gain(f);
                assert!(rel < 1e-3, "{} at {f} Hz: {rel}", full.name);
            }
        }
    }

    /// Each meter output is its weighting times its signal: `C (sI − A)⁻¹ B v = W(s) (row · v)`
    /// for any direction `v` of `[x; r; f]`, and no other signal reaches it.
    #[test]
    fn the_meter_weights_each_comfort_signal_by_its_weighting() {
        let rows = crate::model::physical_outputs(&crate::VehicleParams::default());
        let meter = ComfortMeter::new(&rows);
        assert_eq!(ComfortMeter::order(), 8 + 6 + 6);
        assert_eq!(meter.a.nrows(), ComfortMeter::order());
        let inputs = N_STATES + N_ROAD + N_ACTUATORS;
        let v: Vec<f64> = (0..inputs)
            .map(|i| ((i * 37 % 11) as f64 - 5.0) * 0.3)
            .collect();
        let cx = |m: &DMatrix<f64>| m.map(|x| Complex::new(x, 0.0));
        for f in [0.3, 1.0, 4.0, 11.0, 60.0] {
            let s = Complex::new(0.0, w(f));
            let n = ComfortMeter::order();
            let m = DMatrix::<Complex<f64>>::identity(n, n) * s - cx(&meter.a);
            let x = m
                .lu()
                .solve(
                    &(cx(&meter.b)
                        * DMatrix::from_column_slice(inputs, 1, &v).map(|x| Complex::new(x, 0.0))),
                )
                .unwrap();
            let y = cx(&meter.c) * x;
            for (k, ((_, signal, _, _), weighting)) in METER_OUTPUTS
                .iter()
                .zip(ComfortMeter::weightings())
                .enumerate()
            {
                let row = rows.iter().find(|r| r.name == *signal).unwrap();
                let direct: f64 = row.coefficients().zip(&v).map(|(a, b)| a * b).sum();
                let exact = weighting.response(f) * direct;
                assert!(
                    (y[(k, 0)] - exact).norm() <= 1e-9 * exact.norm(),
                    "{signal} at {f} Hz: {} vs {exact}",
                    y[(k, 0)]
                );
            }
        }
    }
}
