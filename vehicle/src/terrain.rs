//! The long waves of a road: a grade, hills and a crossfall, under both tracks, added to any
//! profile of [`crate::road`]. The profiles are roughness; the terrain is what a road also has
//! and a design road cut off at 0.011 cycles/m (about 90 m) hides: elevation that keeps
//! rising, so that the whole car rises with it. A controller with a nonzero gain at s = 0 from
//! an absolute height fights it with a force that never ends.
//!
//! Every term is a function of the distance `d` a wheel has travelled from the front wheels'
//! position at `t = 0` (the rear wheels start a wheelbase behind, at `d = −wheelbase`), zero for
//! `d ≤ 0`, so the car starts at rest on a level road whatever the terrain.

use std::f64::consts::PI;

/// The terrain's parameters. The default is level: no grade, no hills, no crossfall.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Terrain {
    /// The road rises by `ramp_rise` \[m\] over `ramp_length` \[m\] (a constant grade
    /// `ramp_rise / ramp_length`, with a kink at each end), then stays at that height.
    pub ramp_rise: f64,
    /// \[m\], > 0.
    pub ramp_length: f64,
    /// Periodic hills `½ h (1 − cos(2π d / λ))`: peak-to-peak height `h` \[m\] …
    pub hill_height: f64,
    /// … and wavelength `λ` \[m\], > 0.
    pub hill_length: f64,
    /// The left track ends `crossfall` \[m\] above the right one (each `crossfall / 2` from the
    /// centre line, so the heave is untouched), reached with a half-cosine over …
    pub crossfall: f64,
    /// … `crossfall_length` \[m\], > 0.
    pub crossfall_length: f64,
}

impl Default for Terrain {
    fn default() -> Self {
        Terrain {
            ramp_rise: 0.0,
            ramp_length: 100.0,
            hill_height: 0.0,
            hill_length: 200.0,
            crossfall: 0.0,
            crossfall_length: 20.0,
        }
    }
}

impl Terrain {
    /// No elevation anywhere: the profile alone.
    pub fn is_level(&self) -> bool {
        self.ramp_rise == 0.0 && self.hill_height == 0.0 && self.crossfall == 0.0
    }

    /// Finite heights and positive lengths, or which is not.
    pub fn validate(&self) -> Result<(), String> {
        for (name, v) in [
            ("ramp_rise", self.ramp_rise),
            ("hill_height", self.hill_height),
            ("crossfall", self.crossfall),
        ] {
            if !v.is_finite() {
                return Err(format!("{name} must be finite, got {v}"));
            }
        }
        for (name, v) in [
            ("ramp_length", self.ramp_length),
            ("hill_length", self.hill_length),
            ("crossfall_length", self.crossfall_length),
        ] {
            if !(v > 0.0 && v.is_finite()) {
                return Err(format!("{name} must be finite and > 0, got {v}"));
            }
        }
        Ok(())
    }

    /// `(z, dz/dd)` of track 0 (left) or 1 (right) at distance `d` [m, m/m].
    pub fn at(&self, track: usize, d: f64) -> (f64, f64) {
        if d <= 0.0 {
            return (0.0, 0.0);
        }
        let (mut z, mut slope) = (0.0, 0.0);
        if self.ramp_rise != 0.0 {
            let grade = self.ramp_rise / self.ramp_length;
            if d < self.ramp_length {
                (z, slope) = (grade * d, grade);
            } else {
                z = self.ramp_rise;
            }
        }
        if self.hill_height != 0.0 {
            let k = 2.0 * PI / self.hill_length;
            z += 0.5 * self.hill_height * (1.0 - (k * d).cos());
            slope += 0.5 * self.hill_height * k * (k * d).sin();
        }
        if self.crossfall != 0.0 {
            let half = if track == 0 { 0.5 } else { -0.5 } * self.crossfall;
            if d < self.crossfall_length {
                let a = PI / self.crossfall_length;
                z += half * 0.5 * (1.0 - (a * d).cos());
                slope += half * 0.5 * a * (a * d).sin();
            } else {
                z += half;
            }
        }
        (z, slope)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn terrain() -> Terrain {
        Terrain {
            ramp_rise: 0.5,
            ramp_length: 100.0,
            hill_height: 1.0,
            hill_length: 200.0,
            crossfall: 0.06,
            crossfall_length: 20.0,
        }
    }

    /// The slope is the derivative of the height: central differences of the height agree
    /// with it to the differences' own error away from the ramp's kinks.
    #[test]
    fn the_slope_is_the_derivative_of_the_height() {
        let t = terrain();
        for track in 0..2 {
            for k in 1..3000 {
                let d = k as f64 * 0.1 + 0.05;
                if (d - 100.0).abs() < 0.01 {
                    continue;
                }
                let e = 1e-4;
                let numeric = (t.at(track, d + e).0 - t.at(track, d - e).0) / (2.0 * e);
                let (_, slope) = t.at(track, d);
                assert!(
                    (numeric - slope).abs() < 1e-8,
                    "d = {d}: {numeric} vs {slope}"
                );
            }
        }
    }

    /// Closed forms at chosen distances: level before the start; half the ramp, a hill's crest
    /// and the whole crossfall where each is reached; the grade forever after, nothing else.
    #[test]
    fn heights_at_known_distances() {
        let t = terrain();
        assert_eq!(t.at(0, 0.0), (0.0, 0.0));
        assert_eq!(t.at(1, -3.0), (0.0, 0.0));
        let only = |f: fn(&mut Terrain)| {
            let mut x = Terrain::default();
            f(&mut x);
            x
        };
        let ramp = only(|x| x.ramp_rise = 0.5);
        assert_eq!(ramp.at(0, 50.0), (0.25, 0.005));
        assert_eq!(ramp.at(1, 1e4), (0.5, 0.0));
        let hills = only(|x| x.hill_height = 1.0);
        assert!((hills.at(0, 100.0).0 - 1.0).abs() < 1e-15);
        assert!(hills.at(0, 200.0).0.abs() < 1e-15);
        let cross = only(|x| x.crossfall = 0.06);
        assert_eq!(cross.at(0, 30.0), (0.03, 0.0));
        assert_eq!(cross.at(1, 30.0), (-0.03, 0.0));
        assert!((cross.at(0, 10.0).0 - 0.015).abs() < 1e-15);
        assert!(Terrain::default().is_level() && !ramp.is_level());
    }

    #[test]
    fn bad_terrain_is_refused_with_its_name() {
        let mut t = terrain();
        t.hill_length = 0.0;
        assert!(t.validate().unwrap_err().contains("hill_length"));
        t = terrain();
        t.ramp_rise = f64::NAN;
        assert!(t.validate().unwrap_err().contains("ramp_rise"));
        assert!(terrain().validate().is_ok());
    }
}
