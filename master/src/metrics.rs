//! Ride-comfort metrics of recorded signals: RMS, peak, vibration dose value and PSD.
//!
//! The ISO 2631-1 weighted signals are not weighted here: the plant outputs them, integrated
//! with the car (`vehicle::iso2631::ComfortMeter`). A weighting run on samples would misjudge
//! a signal that jumps at every communication point, as the seat acceleration does under held
//! commands.

use num_complex::Complex64;
use std::f64::consts::PI;

pub fn rms(x: &[f64]) -> f64 {
    (x.iter().map(|v| v * v).sum::<f64>() / x.len().max(1) as f64).sqrt()
}

pub fn peak(x: &[f64]) -> f64 {
    x.iter().fold(0.0, |m, v| m.max(v.abs()))
}

/// Vibration dose value `(∫ a⁴ dt)^¼` [m/s^1.75].
pub fn vdv(x: &[f64], h: f64) -> f64 {
    (x.iter().map(|v| v.powi(4)).sum::<f64>() * h).powf(0.25)
}

/// One-sided PSD by Welch's method (Hann windows of `segment` samples, half overlap):
/// `(frequencies [Hz], PSD [unit²/Hz])`.
pub fn welch_psd(x: &[f64], h: f64, segment: usize) -> (Vec<f64>, Vec<f64>) {
    let n = segment.min(x.len()).max(8);
    let window: Vec<f64> = (0..n)
        .map(|k| 0.5 - 0.5 * (2.0 * PI * k as f64 / n as f64).cos())
        .collect();
    let norm: f64 = window.iter().map(|w| w * w).sum::<f64>();
    let fft = rustfft::FftPlanner::new().plan_fft_forward(n);
    let mut psd = vec![0.0; n / 2 + 1];
    let mut count = 0;
    let mut start = 0;
    while start + n <= x.len() {
        let mean = x[start..start + n].iter().sum::<f64>() / n as f64;
        let mut buf: Vec<Complex64> = (0..n)
            .map(|k| Complex64::new((x[start + k] - mean) * window[k], 0.0))
            .collect();
        fft.process(&mut buf);
        for (k, p) in psd.iter_mut().enumerate() {
            let scale = if k == 0 || k == n / 2 { 1.0 } else { 2.0 };
            *p += scale * buf[k].norm_sqr() * h / norm;
        }
        count += 1;
        start += n / 2;
    }
    let freqs = (0..psd.len()).map(|k| k as f64 / (n as f64 * h)).collect();
    (
        freqs,
        psd.into_iter().map(|p| p / count.max(1) as f64).collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vdv_rms_and_psd_of_known_signals() {
        let h = 1e-3;
        let x: Vec<f64> = (0..100_000)
            .map(|k| 2.0 * (2.0 * PI * 5.0 * k as f64 * h).sin())
            .collect();
        assert!((rms(&x) - 2f64.sqrt()).abs() < 1e-6);
        // ∫ (A sin)^4 = 3/8 A^4 T.
        assert!((vdv(&x, h) - (3.0 / 8.0 * 16.0 * 100.0f64).powf(0.25)).abs() < 1e-3);
        // Parseval: the PSD integrates to the variance.
        let (f, p) = welch_psd(&x, h, 4096);
        let df = f[1] - f[0];
        let var: f64 = p.iter().sum::<f64>() * df;
        assert!((var - 2.0).abs() < 0.02, "{var}");
        let k = p
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .unwrap()
            .0;
        assert!((f[k] - 5.0).abs() <= df);
    }
}
