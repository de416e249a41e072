//! The slowest actuators a loop tolerates: the nominal loop with first-order actuators of a
//! common bandwidth (the plant FMU's `actuator_bandwidth`), its spectral abscissa at bandwidths
//! log-spaced from 1 kHz down to 0.5 Hz. The loop with ideal actuators is the design's, stable;
//! as the bandwidth falls the roots move continuously, and the bound is the lowest bandwidth
//! down to which every one checked is stable. Exact at each bandwidth checked (the loop's
//! eigenvalues, [`crate::predict::continuous::abscissa_with_actuator_lag`]); between them
//! nothing is claimed beyond the roots' continuity, as for the other grids of a certificate.
//! Every actuator has the same bandwidth here (a car's units are alike); the delay is the
//! unmodelled delay's business (`unmodelled_delay`), the point checks at 10 and 5 Hz carry
//! both to the predicted figures (`actuator_lag`).

use crate::predict::continuous::{abscissa_with_actuator_lag, Conditions, ControlLaw};
use serde::Serialize;
use vehicle::VehicleParams;

/// Bandwidths per decade, and the range.
const PER_DECADE: usize = 25;
const HIGHEST_HZ: f64 = 1000.0;
const LOWEST_HZ: f64 = 0.5;

/// [`lag_bound`]'s answer (`actuator_lag_bound` in a comfort certificate).
#[derive(Debug, Clone, Serialize)]
pub struct ActuatorLagBound {
    /// Stable with every actuator a first-order lag of any checked bandwidth from 1 kHz down to
    /// this \[Hz\]; none where the loop is unstable already at 1 kHz.
    pub stable_down_to_hz: Option<f64>,
    /// The highest checked bandwidth at which the loop is unstable, if any \[Hz\].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub first_unstable_hz: Option<f64>,
    pub bandwidths_checked: usize,
    #[serde(skip_serializing_if = "String::is_empty")]
    pub why: String,
}

/// The bandwidths checked, from the highest down \[Hz\].
fn bandwidths() -> Vec<f64> {
    let decades = (HIGHEST_HZ / LOWEST_HZ).log10();
    let n = (decades * PER_DECADE as f64).ceil() as usize;
    (0..=n)
        .map(|k| HIGHEST_HZ * (LOWEST_HZ / HIGHEST_HZ).powf(k as f64 / n as f64))
        .collect()
}

/// Down the bandwidths, the last stable one before the first that is not, and that one.
fn scan(bandwidths: &[f64], stable: impl Fn(f64) -> bool) -> (Option<f64>, Option<f64>) {
    let mut last = None;
    for &hz in bandwidths {
        if !stable(hz) {
            return (last, Some(hz));
        }
        last = Some(hz);
    }
    (last, None)
}

/// The slowest common actuator bandwidth the nominal loop of `law` tolerates (the module's
/// scan). A predictor's loop is not rational: it is checked at the sampling instants at 10 and
/// 5 Hz only (`actuator_lag`), and says so here.
pub fn lag_bound(law: &ControlLaw, params: &VehicleParams) -> ActuatorLagBound {
    let grid = bandwidths();
    if law.predictor.is_some() {
        return ActuatorLagBound {
            stable_down_to_hz: None,
            first_unstable_hz: None,
            bandwidths_checked: 0,
            why: "a predictor's loop is not rational: checked at the sampling instants at the \
                  bandwidths of actuator_lag only"
                .into(),
        };
    }
    let stable = |hz: f64| {
        abscissa_with_actuator_lag(law, Conditions::nominal(*params), hz)
            .ok()
            .flatten()
            .is_some_and(|a| a < 0.0)
    };
    let (down_to, unstable) = scan(&grid, stable);
    ActuatorLagBound {
        stable_down_to_hz: down_to,
        first_unstable_hz: unstable,
        bandwidths_checked: grid.len(),
        why: String::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The grid spans 1 kHz … 0.5 Hz at 25 bandwidths a decade, highest first; the scan stops
    /// at the first unstable bandwidth and reports the one before.
    #[test]
    fn the_scan_reports_the_last_stable_bandwidth_before_the_first_unstable_one() {
        let grid = bandwidths();
        assert_eq!(grid[0], HIGHEST_HZ);
        assert!((grid.last().unwrap() - LOWEST_HZ).abs() < 1e-12);
        assert!(grid.windows(2).all(|w| w[1] < w[0] && w[0] / w[1] < 1.1));
        // Unstable below 3 Hz, and again (not reached) below 1 Hz.
        let (down_to, unstable) = scan(&grid, |hz| hz >= 3.0);
        assert!(down_to.unwrap() >= 3.0 && unstable.unwrap() < 3.0);
        assert!(down_to.unwrap() / unstable.unwrap() < 1.1);
        assert_eq!(scan(&grid, |_| true), (Some(*grid.last().unwrap()), None));
        assert_eq!(scan(&grid, |_| false), (None, Some(HIGHEST_HZ)));
    }
}
