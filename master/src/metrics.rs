//! Ride-comfort metrics: a signal weighted by an ISO 2631-1 frequency weighting
//! ([`vehicle::iso2631`]), its RMS and vibration dose value, and the figures of a run against the
//! passive car.
//!
//! The weighting runs on the sampled signal as its cascade of second-order sections, each
//! discretised exactly for the sample step with the signal linear between samples (first-order
//! hold).

use nalgebra::DVector;
use num_complex::Complex64;
use std::f64::consts::PI;
use vehicle::iso2631::Weighting;

/// `signal` sampled every `h` seconds, filtered by `weighting`, starting at rest.
pub fn weighted(signal: &[f64], h: f64, weighting: &Weighting) -> Vec<f64> {
    let mut out = signal.to_vec();
    for sec in &weighting.sections {
        let (a, b, c, b2) = sec.canonical();
        let d = vehicle::exact::discretize(&a, &b, h).expect("a fixed ISO 2631 filter section");
        let mut x = DVector::zeros(2);
        let input = out.clone();
        for k in 0..input.len() {
            out[k] = c[0] * x[0] + c[1] * x[1] + b2 * input[k];
            let next = input.get(k + 1).copied().unwrap_or(input[k]);
            x = &d.phi * &x + &d.gamma_hold * input[k] + &d.gamma_ramp * (next - input[k]);
        }
    }
    out
}

/// `signal` weighted by `W_k` (seat, vertical).
pub fn wk_filter(signal: &[f64], h: f64) -> Vec<f64> {
    weighted(signal, h, &Weighting::wk())
}

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

    /// A sine through the discrete filter comes out with the analogue gain (steady state).
    #[test]
    fn discrete_filter_has_the_analogue_gain() {
        let h = 1e-3;
        let wk_gain = |f: f64| Weighting::wk().gain(f);
        for f in [1.0, 4.0, 12.5] {
            let x: Vec<f64> = (0..20000)
                .map(|k| (2.0 * PI * f * k as f64 * h).sin())
                .collect();
            let y = wk_filter(&x, h);
            let steady = rms(&y[10000..]) * 2f64.sqrt();
            assert!(
                (steady - wk_gain(f)).abs() < 2e-3 * wk_gain(f),
                "{f} Hz: {steady} vs {}",
                wk_gain(f)
            );
        }
    }

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
