//! Road profiles under the four wheels (FL, FR, RL, RR): heights and their exact time
//! derivatives, the rear wheels on the front track delayed by the wheelbase. Used by the road
//! FMU, the tests and the master, so every one of them drives the car over the same road.
//!
//! Every profile is a function of the distance `s` a wheel has travelled past the profile's
//! origin: the front wheels are at `s = V t − start_distance`, the rear wheels `wheelbase`
//! behind. `road_v = V dz/ds` exactly (closed form, no differencing).

use crate::terrain::Terrain;
use std::f64::consts::PI;

/// Which track a single feature is on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    Left,
    Right,
    Both,
}

impl Side {
    fn has(self, track: usize) -> bool {
        matches!(
            (self, track),
            (Side::Both, _) | (Side::Left, 0) | (Side::Right, 1)
        )
    }
}

#[derive(Debug, Clone, PartialEq)]
pub enum Profile {
    /// `½ h (1 − cos(2π s / L))` for `0 ≤ s ≤ L`.
    Bump {
        height: f64,
        length: f64,
        side: Side,
    },
    /// ISO 8608 random road of class 1 (A) … 8 (H): `G_d(n) = G_d(n₀)(n/n₀)⁻²`, `n₀ = 0.1`
    /// cycles/m, `G_d(n₀) = 16·4^(class−1)·10⁻⁶ m³`, as a sum of cosines over 0.011–2.83
    /// cycles/m with seeded phases; the tracks independent or identical. Faded in over `fade_in`
    /// seconds (`½(1 − cos)` window) so that the car, at rest on a flat road at t = 0, is not hit
    /// by a step.
    Iso {
        class: u8,
        seed: u64,
        identical_tracks: bool,
        fade_in: f64,
    },
    /// `A w(τ) sin φ(τ)`, `τ = s / V ∈ [0, T]`: a linear sweep in time from `f_start` to `f_end` Hz
    /// over `duration` T seconds at the front wheels (the rear wheels see it `wheelbase / V`
    /// later), `w` a half-cosine taper over the first and last `min(0.5 s, T/4)` so that the
    /// road stays continuous and differentiable where the sweep starts and ends.
    SineSweep {
        amplitude: f64,
        f_start: f64,
        f_end: f64,
        duration: f64,
        side: Side,
    },
    /// A step of `depth` (negative: down) with half-cosine ramps of length `ramp`, and back after
    /// `length` (a pothole); `length = ∞` is a permanent step.
    Pothole {
        depth: f64,
        length: f64,
        ramp: f64,
        side: Side,
    },
}

/// ISO 8608 `G_d(n₀)` \[m³\] of class 1 (A) … 8 (H): the geometric means of the class bounds.
pub fn iso_g_d_n0(class: u8) -> f64 {
    16e-6 * 4f64.powi(class as i32 - 1)
}

/// ISO 8608's reference spatial frequency `n₀` [cycles/m].
pub const ISO_N0: f64 = 0.1;

/// One-sided PSD [m²/s² per Hz] of the road's vertical velocity under a wheel of a vehicle at
/// `speed` [m/s] on an ISO 8608 road of class 1 (A) … 8 (H) with waviness 2: white, since the
/// height's temporal PSD `G_d(n₀) n₀² V / f²` times `(2π f)²` is `4π² n₀² G_d(n₀) V`.
pub fn iso_velocity_psd(class: u8, speed: f64) -> f64 {
    4.0 * PI * PI * ISO_N0 * ISO_N0 * iso_g_d_n0(class) * speed
}

/// Spatial band of the ISO road [cycles/m] and its number of cosines per track.
pub const ISO_BAND: (f64, f64) = (0.011, 2.83);
const ISO_COMPONENTS: usize = 400;

#[derive(Debug, Clone, PartialEq)]
pub struct Road {
    pub profile: Profile,
    /// Vehicle speed [m/s].
    pub speed: f64,
    /// Front-to-rear axle distance \[m\].
    pub wheelbase: f64,
    /// Distance from the front wheels at t = 0 to the profile's origin \[m\].
    pub start_distance: f64,
    /// ISO road: per track (left, right), `(amplitude [m], spatial frequency [cycles/m], phase)`.
    tracks: [Vec<(f64, f64, f64)>; 2],
    /// ISO road: each track sampled on a grid, what [`Road::track`] reads.
    grids: Option<[IsoTrack; 2]>,
    /// The long waves added to the profile (level by default): [`Road::with_terrain`], which
    /// checks them.
    terrain: Terrain,
}

impl Road {
    /// Check the parameters and build the road (the ISO road's cosines are drawn here).
    pub fn new(
        profile: Profile,
        speed: f64,
        wheelbase: f64,
        start_distance: f64,
    ) -> Result<Road, String> {
        let positive = |name: &str, v: f64| {
            if v > 0.0 && v.is_finite() {
                Ok(())
            } else {
                Err(format!("{name} must be finite and > 0, got {v}"))
            }
        };
        positive("speed", speed)?;
        positive("wheelbase", wheelbase)?;
        if !start_distance.is_finite() {
            return Err(format!(
                "start_distance must be finite, got {start_distance}"
            ));
        }
        let mut tracks = [Vec::new(), Vec::new()];
        let mut grids = None;
        match &profile {
            Profile::Bump { height, length, .. } => {
                positive("bump_length", *length)?;
                if !height.is_finite() {
                    return Err(format!("bump_height must be finite, got {height}"));
                }
            }
            Profile::Iso {
                class,
                seed,
                identical_tracks,
                fade_in,
            } => {
                if !(1..=8).contains(class) {
                    return Err(format!("iso_class must be 1 (A) … 8 (H), got {class}"));
                }
                if !(*fade_in >= 0.0 && fade_in.is_finite()) {
                    return Err(format!("fade_in must be finite and >= 0, got {fade_in}"));
                }
                let mut rand = linsys::lcg(*seed);
                let g_d_n0 = iso_g_d_n0(*class);
                let mut track = || iso_track(g_d_n0, &mut rand);
                let left = track();
                let right = if *identical_tracks {
                    left.clone()
                } else {
                    track()
                };
                grids = Some([IsoTrack::new(&left), IsoTrack::new(&right)]);
                tracks = [left, right];
            }
            Profile::SineSweep {
                amplitude,
                f_start,
                f_end,
                duration,
                ..
            } => {
                positive("sweep_f_start", *f_start)?;
                positive("sweep_f_end", *f_end)?;
                positive("sweep_duration", *duration)?;
                if !amplitude.is_finite() {
                    return Err(format!("sweep_amplitude must be finite, got {amplitude}"));
                }
            }
            Profile::Pothole {
                depth,
                length,
                ramp,
                ..
            } => {
                positive("pothole_ramp", *ramp)?;
                if !(depth.is_finite() && *length >= 2.0 * ramp) {
                    return Err(format!("pothole: depth must be finite and length >= 2 ramp (got depth {depth}, length {length}, ramp {ramp})"));
                }
            }
        }
        Ok(Road {
            profile,
            speed,
            wheelbase,
            start_distance,
            tracks,
            grids,
            terrain: Terrain::default(),
        })
    }

    /// This road with the long waves of `terrain` under it, checked.
    pub fn with_terrain(self, terrain: Terrain) -> Result<Road, String> {
        terrain.validate()?;
        Ok(Road { terrain, ..self })
    }

    /// The times at which a height or a velocity under a wheel may jump or kink, sorted: the
    /// ends of a bump, of a pothole's ramps (a step where they have no length), of a sweep, of
    /// a terrain ramp or crossfall, at the front and then the rear wheels, and the end of an ISO
    /// road's fade-in. Between them every output is smooth: an integrator (the road as Model
    /// Exchange) takes each as a time event.
    pub fn breakpoints(&self) -> Vec<f64> {
        let along_profile: Vec<f64> = match self.profile {
            Profile::Bump { length, .. } => vec![0.0, length],
            Profile::Pothole { length, ramp, .. } if length.is_finite() => {
                vec![0.0, ramp, length - ramp, length]
            }
            Profile::Pothole { ramp, .. } => vec![0.0, ramp],
            Profile::SineSweep { duration, .. } => vec![0.0, self.speed * duration],
            Profile::Iso { .. } => Vec::new(),
        };
        let t = &self.terrain;
        let mut along_terrain = Vec::new();
        if t.ramp_rise != 0.0 {
            along_terrain.extend([0.0, t.ramp_length]);
        }
        if t.crossfall != 0.0 {
            along_terrain.extend([0.0, t.crossfall_length]);
        }
        if t.hill_height != 0.0 {
            along_terrain.push(0.0);
        }
        let mut times: Vec<f64> = along_profile
            .iter()
            .map(|s| s + self.start_distance)
            .chain(along_terrain)
            .flat_map(|d| [d / self.speed, (d + self.wheelbase) / self.speed])
            .collect();
        if let Profile::Iso { fade_in, .. } = self.profile {
            times.push(fade_in);
        }
        times.retain(|t| t.is_finite() && *t >= 0.0);
        times.sort_by(f64::total_cmp);
        times.dedup();
        times
    }

    /// `[z_fl, z_fr, z_rl, z_rr, v_fl, v_fr, v_rl, v_rr]` at time `t` [m, m/s].
    pub fn at(&self, t: f64) -> [f64; 8] {
        let s_front = self.speed * t - self.start_distance;
        let mut r = [0.0; 8];
        // Wheels FL, FR, RL, RR: the front ones on tracks 0 and 1, the rear ones a wheelbase
        // behind on the same tracks.
        for track in 0..2 {
            let wheels = self.track_each(track, [s_front, s_front - self.wheelbase]);
            for (wheel, (z, dz_ds)) in [track, 2 + track].into_iter().zip(wheels) {
                r[wheel] = z;
                r[4 + wheel] = self.speed * dz_ds;
            }
        }
        if let Profile::Iso { fade_in, .. } = self.profile {
            if t < fade_in {
                let a = PI / fade_in;
                let (w, dw) = (0.5 * (1.0 - (a * t).cos()), 0.5 * a * (a * t).sin());
                for k in 0..4 {
                    r[4 + k] = w * r[4 + k] + dw * r[k];
                    r[k] *= w;
                }
            }
        }
        if !self.terrain.is_level() {
            // The terrain's distance runs from the front wheels' position at t = 0.
            let d_front = self.speed * t;
            for (k, d) in [
                d_front,
                d_front,
                d_front - self.wheelbase,
                d_front - self.wheelbase,
            ]
            .into_iter()
            .enumerate()
            {
                let (z, dz_dd) = self.terrain.at(k % 2, d);
                r[k] += z;
                r[4 + k] += self.speed * dz_dd;
            }
        }
        r
    }

    /// The cosines of an ISO road's track 0 (left) or 1 (right): `(amplitude [m], spatial
    /// frequency [cycles/m], phase)`; empty for the other profiles.
    pub fn iso_components(&self, track: usize) -> &[(f64, f64, f64)] {
        &self.tracks[track]
    }

    /// The sampled ISO track 0 (left) or 1 (right); `None` for the other profiles.
    pub fn iso_grid(&self, track: usize) -> Option<&IsoTrack> {
        self.grids.as_ref().map(|g| &g[track])
    }

    /// `(z, dz/ds)` of track 0 (left) or 1 (right) at distance `s`: exact for every profile but
    /// the ISO road, whose track is interpolated within [`IsoTrack::error_bounds`] of
    /// [`Road::track_exact`].
    pub fn track(&self, track: usize, s: f64) -> (f64, f64) {
        self.track_each(track, [s])[0]
    }

    /// [`Road::track`] at each distance of `s`.
    pub fn track_each<const N: usize>(&self, track: usize, s: [f64; N]) -> [(f64, f64); N] {
        match &self.grids {
            Some(g) => g[track].at_each(s),
            None => s.map(|s| self.track_exact(track, s)),
        }
    }

    /// `(z, dz/ds)` of track 0 (left) or 1 (right) at distance `s`, the ISO road summed
    /// directly (`ISO_COMPONENTS` cosines and sines).
    pub fn track_exact(&self, track: usize, s: f64) -> (f64, f64) {
        match self.profile {
            Profile::Bump {
                height,
                length,
                side,
            } if side.has(track) && (0.0..=length).contains(&s) => {
                let k = 2.0 * PI / length;
                (
                    0.5 * height * (1.0 - (k * s).cos()),
                    0.5 * height * k * (k * s).sin(),
                )
            }
            Profile::Iso { .. } => {
                self.tracks[track]
                    .iter()
                    .fold((0.0, 0.0), |(z, dz), (a, n, p)| {
                        let arg = 2.0 * PI * n * s + p;
                        (z + a * arg.cos(), dz - a * 2.0 * PI * n * arg.sin())
                    })
            }
            Profile::SineSweep {
                amplitude,
                f_start,
                f_end,
                duration,
                side,
            } if side.has(track) && (0.0..=self.speed * duration).contains(&s) => {
                // φ(s) = 2π (f₀ τ + (f₁ − f₀) τ² / (2T)), τ = s / V.
                let tau = s / self.speed;
                let phase =
                    2.0 * PI * (f_start * tau + (f_end - f_start) * tau * tau / (2.0 * duration));
                let dphase_dtau = 2.0 * PI * (f_start + (f_end - f_start) * tau / duration);
                let taper = (0.5f64).min(duration / 4.0);
                let edge = tau.min(duration - tau);
                let (w, dw_dtau) = if edge < taper {
                    let sign = if tau < duration - tau { 1.0 } else { -1.0 };
                    (
                        0.5 * (1.0 - (PI * edge / taper).cos()),
                        sign * 0.5 * PI / taper * (PI * edge / taper).sin(),
                    )
                } else {
                    (1.0, 0.0)
                };
                (
                    amplitude * w * phase.sin(),
                    amplitude * (dw_dtau * phase.sin() + w * phase.cos() * dphase_dtau)
                        / self.speed,
                )
            }
            Profile::Pothole {
                depth,
                length,
                ramp,
                side,
            } if side.has(track) && s >= 0.0 => {
                let edge = |x: f64| -> (f64, f64) {
                    if x <= 0.0 {
                        (0.0, 0.0)
                    } else if x >= ramp {
                        (1.0, 0.0)
                    } else {
                        (
                            0.5 * (1.0 - (PI * x / ramp).cos()),
                            0.5 * PI / ramp * (PI * x / ramp).sin(),
                        )
                    }
                };
                let (up, dup) = edge(s);
                let (down, ddown) = if length.is_finite() {
                    edge(s - length + ramp)
                } else {
                    (0.0, 0.0)
                };
                (depth * (up - down), depth * (dup - ddown))
            }
            _ => (0.0, 0.0),
        }
    }
}

/// Grid spacing of a sampled ISO track \[m\]: a power of two, so every node `k h` is exact.
/// The shortest wave (2.83 cycles/m) spans 5.7 nodes; see [`IsoTrack::error_bounds`].
pub const ISO_GRID: f64 = 1.0 / 16.0;
/// Nodes per block of a sampled track (32 m); a block is computed when first needed.
const BLOCK: usize = 512;
/// Blocks kept per track: the front and rear wheels' (one wheelbase apart) and spares.
const BLOCKS_KEPT: usize = 4;

/// `[z, dz/ds, d²z/ds²]` at the nodes of one block.
type Nodes = Vec<[f64; 3]>;

/// One ISO track, summed exactly at the nodes of a uniform grid and interpolated between them.
///
/// Why not the direct sum at every query: it is `ISO_COMPONENTS` cosines and sines, and a 1 kHz
/// co-simulation asks for four per step. Why not an FFT: the components sit on a log grid of
/// frequencies (every octave carries as many), which the uniform grid of an FFT cannot hold
/// without changing the road. So the sum is evaluated at the nodes by rotating each component's
/// phasor from node to node (six flops per component instead of a cosine and a sine;
/// re-anchored by a direct evaluation at each block's start), heights, slopes and curvatures
/// together, and a query is the quintic Hermite interpolant of the two nodes around it: its
/// slope is the exact derivative of its height, and both are within
/// [`IsoTrack::error_bounds`] of the direct sum. Quintic on a 1/16 m grid rather than cubic on a
/// 1/64 m one: as accurate (the bounds hold the same test), a quarter of the nodes, and the
/// nodes are the road's whole cost.
#[derive(Debug)]
pub struct IsoTrack {
    cosines: Cosines,
    /// The blocks computed last: `(block index, [z, dz/ds, d²z/ds²] at its BLOCK + 1 nodes)`.
    blocks: std::sync::Mutex<Vec<(i64, Nodes)>>,
}

/// Per cosine `a cos(k s + φ)`: `a`, `k = 2π n`, `φ`, the slope's weight `−a k`, the
/// curvature's `−a k²` and one node's rotation `(cos k h, sin k h)`; in lanes of four, padded with zero cosines, so that the node
/// loop runs on whole vector registers.
#[derive(Debug, Clone, PartialEq)]
struct Cosines {
    amplitude: Vec<Lanes>,
    wavenumber: Vec<Lanes>,
    phase: Vec<Lanes>,
    slope: Vec<Lanes>,
    curvature: Vec<Lanes>,
    rotation_cos: Vec<Lanes>,
    rotation_sin: Vec<Lanes>,
}

/// Four cosines' values of one quantity.
type Lanes = [f64; 4];

/// A copy starts with no block computed.
impl Clone for IsoTrack {
    fn clone(&self) -> Self {
        IsoTrack::of(self.cosines.clone())
    }
}

/// Two tracks are equal when their cosines are (whatever each has computed so far).
impl PartialEq for IsoTrack {
    fn eq(&self, other: &Self) -> bool {
        self.cosines == other.cosines
    }
}

/// `(z, dz/ds)` at `t ∈ [0, 1]` of the way from node `[z0, d0, c0]` to node `[z1, d1, c1]`
/// (values, slopes and curvatures in `s`, [`ISO_GRID`] apart): the quintic Hermite basis on
/// `[0, 1]` (values, first and second derivatives in `t` at each end) and its derivatives in
/// `t`; `d/ds = (1/h) d/dt`.
fn quintic_hermite([z0, d0, c0]: [f64; 3], [z1, d1, c1]: [f64; 3], t: f64) -> (f64, f64) {
    let h = ISO_GRID;
    let (t2, t3) = (t * t, t * t * t);
    let (t4, t5) = (t3 * t, t3 * t2);
    let z = (1.0 - 10.0 * t3 + 15.0 * t4 - 6.0 * t5) * z0
        + (t - 6.0 * t3 + 8.0 * t4 - 3.0 * t5) * h * d0
        + 0.5 * (t2 - 3.0 * t3 + 3.0 * t4 - t5) * h * h * c0
        + (10.0 * t3 - 15.0 * t4 + 6.0 * t5) * z1
        + (-4.0 * t3 + 7.0 * t4 - 3.0 * t5) * h * d1
        + 0.5 * (t3 - 2.0 * t4 + t5) * h * h * c1;
    let dz = (-30.0 * t2 + 60.0 * t3 - 30.0 * t4) * (z0 - z1) / h
        + (1.0 - 18.0 * t2 + 32.0 * t3 - 15.0 * t4) * d0
        + 0.5 * (2.0 * t - 9.0 * t2 + 12.0 * t3 - 5.0 * t4) * h * c0
        + (-12.0 * t2 + 28.0 * t3 - 15.0 * t4) * d1
        + 0.5 * (3.0 * t2 - 8.0 * t3 + 5.0 * t4) * h * c1;
    (z, dz)
}

impl IsoTrack {
    /// The track of `components`, `(amplitude [m], spatial frequency [cycles/m], phase)`.
    pub fn new(components: &[(f64, f64, f64)]) -> IsoTrack {
        let padded = |f: &dyn Fn(&(f64, f64, f64)) -> f64, zero: f64| -> Vec<Lanes> {
            components
                .chunks(4)
                .map(|chunk| std::array::from_fn(|l| chunk.get(l).map_or(zero, f)))
                .collect()
        };
        let k = |c: &(f64, f64, f64)| 2.0 * PI * c.1;
        IsoTrack::of(Cosines {
            amplitude: padded(&|c| c.0, 0.0),
            wavenumber: padded(&k, 0.0),
            phase: padded(&|c| c.2, 0.0),
            slope: padded(&|c| -c.0 * k(c), 0.0),
            curvature: padded(&|c| -c.0 * k(c) * k(c), 0.0),
            rotation_cos: padded(&|c| (k(c) * ISO_GRID).cos(), 1.0),
            rotation_sin: padded(&|c| (k(c) * ISO_GRID).sin(), 0.0),
        })
    }

    fn of(cosines: Cosines) -> IsoTrack {
        IsoTrack {
            cosines,
            blocks: std::sync::Mutex::new(Vec::with_capacity(BLOCKS_KEPT)),
        }
    }

    /// `(height, slope)` bounds of the interpolation error against the direct sum. The quintic
    /// Hermite interpolant of `z` on `[s₀, s₀ + h]` errs by `e(s) = z[s₀,s₀,s₀,s₁,s₁,s₁,s] w(s)`
    /// with `w = (s − s₀)³(s − s₁)³`, `max|w| = h⁶/64`, `max|w′| = 3h⁵/(25√5)`; a divided
    /// difference over `n + 1` points is at most `max|z⁽ⁿ⁾|/n!`, so `|e| ≤ M₆ h⁶/(720·64)` and
    /// `|e′| ≤ M₇ h⁶/(5040·64) + M₆ 3h⁵/(720·25√5)`, where `M_n = Σ a kⁿ ≥ max|z⁽ⁿ⁾|`.
    pub fn error_bounds(&self) -> (f64, f64) {
        let moment = |n: i32| -> f64 {
            let x = &self.cosines;
            let (a, k) = (x.amplitude.iter().flatten(), x.wavenumber.iter().flatten());
            a.zip(k).map(|(a, k)| a * k.powi(n)).sum()
        };
        let (m6, m7, h) = (moment(6), moment(7), ISO_GRID);
        let w_max = h.powi(6) / 64.0;
        let dw_max = 3.0 * h.powi(5) / (25.0 * 5f64.sqrt());
        (
            m6 / 720.0 * w_max,
            m7 / 5040.0 * w_max + m6 / 720.0 * dw_max,
        )
    }

    /// `(z, dz/ds)` at each distance of `s`, under one lock of the kept blocks (a road asks
    /// for a front and a rear wheel on each track at every step).
    pub fn at_each<const N: usize>(&self, s: [f64; N]) -> [(f64, f64); N] {
        // A poisoned lock only means another thread panicked while holding it; the cache is
        // still a list of finished blocks.
        let mut kept = self.blocks.lock().unwrap_or_else(|e| e.into_inner());
        s.map(|s| {
            let x = s / ISO_GRID;
            let k = x.floor();
            let t = x - k;
            let k = k as i64;
            let (block, j) = (
                k.div_euclid(BLOCK as i64),
                k.rem_euclid(BLOCK as i64) as usize,
            );
            let nodes = self.block(&mut kept, block);
            quintic_hermite(nodes[j], nodes[j + 1], t)
        })
    }

    /// The nodes of block `b`, computed if not among the `kept`.
    fn block<'a>(&self, kept: &'a mut Vec<(i64, Nodes)>, b: i64) -> &'a Nodes {
        let at = match kept.iter().position(|(i, _)| *i == b) {
            Some(at) => at,
            None => {
                if kept.len() == BLOCKS_KEPT {
                    kept.remove(0);
                }
                kept.push((b, self.compute(b)));
                kept.len() - 1
            }
        };
        &kept[at].1
    }

    /// `[z, dz/ds, d²z/ds²]` at the `BLOCK + 1` nodes of block `b`.
    fn compute(&self, b: i64) -> Vec<[f64; 3]> {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx") {
            // SAFETY: the CPU has AVX, checked just above.
            return unsafe { self.compute_avx(b) };
        }
        self.compute_lanes(b)
    }

    /// [`Self::compute_lanes`] in AVX's four-wide registers where the CPU has them (the FMUs
    /// are built for the x86-64 baseline, two-wide SSE2). Bit-identical: the same operations
    /// in the same order per lane, and Rust never fuses a multiply and an add.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    unsafe fn compute_avx(&self, b: i64) -> Vec<[f64; 3]> {
        self.compute_lanes(b)
    }

    #[inline(always)]
    fn compute_lanes(&self, b: i64) -> Vec<[f64; 3]> {
        let x = &self.cosines;
        let s0 = (b * BLOCK as i64) as f64 * ISO_GRID;
        let (mut c, mut s): (Vec<Lanes>, Vec<Lanes>) = x
            .wavenumber
            .iter()
            .zip(&x.phase)
            .map(|(k4, p4)| {
                let sin_cos: [(f64, f64); 4] =
                    std::array::from_fn(|l| (k4[l] * s0 + p4[l]).sin_cos());
                (sin_cos.map(|(_, cos)| cos), sin_cos.map(|(sin, _)| sin))
            })
            .unzip();
        let mut nodes = Vec::with_capacity(BLOCK + 1);
        for _ in 0..=BLOCK {
            // Partial sums per lane: the loop vectorises without reordering any one sum.
            let (mut z, mut dz, mut ddz) = ([0.0; 4], [0.0; 4], [0.0; 4]);
            for ((((c4, s4), w4), d4), e4) in c
                .iter()
                .zip(&s)
                .zip(&x.amplitude)
                .zip(&x.slope)
                .zip(&x.curvature)
            {
                for l in 0..4 {
                    z[l] += w4[l] * c4[l];
                    dz[l] += d4[l] * s4[l];
                    ddz[l] += e4[l] * c4[l];
                }
            }
            // Then every phasor one node on (a loop of its own, which the compiler vectorises).
            let (rc, rs) = (x.rotation_cos.as_flattened(), x.rotation_sin.as_flattened());
            for (((c, s), rc), rs) in c
                .as_flattened_mut()
                .iter_mut()
                .zip(s.as_flattened_mut())
                .zip(rc)
                .zip(rs)
            {
                (*c, *s) = (*c * rc - *s * rs, *s * rc + *c * rs);
            }
            nodes.push([z.iter().sum(), dz.iter().sum(), ddz.iter().sum()]);
        }
        nodes
    }
}

/// One track: `ISO_COMPONENTS` cosines on log-spaced bands, each carrying the band's variance
/// `∫ G_d dn` (amplitude `√(2 G_d(n_c) Δn)`), random phases.
fn iso_track(g_d_n0: f64, rand: &mut impl FnMut() -> f64) -> Vec<(f64, f64, f64)> {
    let (n_lo, n_hi) = ISO_BAND;
    let k = ISO_COMPONENTS;
    (0..k)
        .map(|i| {
            let a = (n_lo.ln() + (n_hi / n_lo).ln() * i as f64 / k as f64).exp();
            let b = (n_lo.ln() + (n_hi / n_lo).ln() * (i + 1) as f64 / k as f64).exp();
            let n = (a * b).sqrt();
            let g = g_d_n0 * (n / ISO_N0).powi(-2);
            ((2.0 * g * (b - a)).sqrt(), n, 2.0 * PI * rand())
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every kink of a road (a jump of a velocity) lies on one of its breakpoints, and the
    /// heights never jump: on a pothole, a bump, a terrain ramp (a kink at each end) and a
    /// crossfall, sampled every 0.1 ms, a velocity that moves by more than the smooth parts'
    /// accelerations allow (under 0.01 m/s a sample here) does so within a sample of a
    /// breakpoint. The ramp's kinks are 0.17 m/s.
    #[test]
    fn every_kink_is_a_breakpoint() {
        let terrain = Terrain {
            ramp_rise: 0.5,
            ramp_length: 30.0,
            crossfall: 0.06,
            crossfall_length: 10.0,
            ..Terrain::default()
        };
        let profiles = [
            Profile::Pothole {
                depth: -0.05,
                length: 3.0,
                ramp: 0.5,
                side: Side::Left,
            },
            Profile::Bump {
                height: 0.05,
                length: 5.0,
                side: Side::Both,
            },
        ];
        for profile in profiles {
            let road = Road::new(profile, 10.0, 2.4, 5.0)
                .unwrap()
                .with_terrain(terrain)
                .unwrap();
            let breaks = road.breakpoints();
            assert!(breaks.windows(2).all(|w| w[0] < w[1]), "{breaks:?}");
            let dt = 1e-4;
            let mut kinks = 0;
            for k in 1..60_000 {
                let t = k as f64 * dt;
                let (a, b) = (road.at(t - dt), road.at(t));
                assert!(
                    (0..4).all(|j| (b[j] - a[j]).abs() < 0.01),
                    "a height jumps at {t}"
                );
                if (4..8).any(|j| (b[j] - a[j]).abs() > 0.05) {
                    kinks += 1;
                    assert!(
                        breaks
                            .iter()
                            .any(|s| *s >= t - dt * 1.000001 && *s <= t * 1.000001),
                        "a kink at {t} s with no breakpoint in its sample ({breaks:?})"
                    );
                }
            }
            // The ramp's two ends under the front wheels, then under the rear ones.
            assert!(kinks >= 4, "{kinks} kinks seen");
        }
    }

    fn roads() -> Vec<Road> {
        let profiles = [
            Profile::Bump {
                height: 0.05,
                length: 5.0,
                side: Side::Left,
            },
            Profile::Iso {
                class: 3,
                seed: 7,
                identical_tracks: false,
                fade_in: 1.0,
            },
            Profile::SineSweep {
                amplitude: 0.01,
                f_start: 0.5,
                f_end: 20.0,
                duration: 10.0,
                side: Side::Both,
            },
            Profile::Pothole {
                depth: -0.04,
                length: 0.8,
                ramp: 0.1,
                side: Side::Right,
            },
            Profile::Pothole {
                depth: 0.03,
                length: f64::INFINITY,
                ramp: 0.2,
                side: Side::Both,
            },
        ];
        profiles
            .into_iter()
            .map(|p| Road::new(p, 15.0, 2.4, 1.5).unwrap())
            .collect()
    }

    /// An ISO road at 20 m/s with independent tracks, not faded in.
    fn iso_road(class: u8, seed: u64) -> Road {
        let profile = Profile::Iso {
            class,
            seed,
            identical_tracks: false,
            fade_in: 0.0,
        };
        Road::new(profile, 20.0, 2.4, 0.0).unwrap()
    }

    /// The sampled track is the direct sum within its error bounds — over negative and positive
    /// distances, across block boundaries, for the smoothest and the roughest class — and the
    /// bounds are small: under 1e-6 of the height's RMS and 1e-4 of the slope's.
    #[test]
    fn sampled_iso_tracks_are_the_direct_sum_within_their_bounds() {
        for (class, seed) in [(1u8, 3u64), (3, 1), (8, 99)] {
            let road = iso_road(class, seed);
            for track in 0..2 {
                let grid = road.iso_grid(track).unwrap();
                let (ez, ed) = grid.error_bounds();
                let comps = road.iso_components(track);
                let rms_z = (comps.iter().map(|c| c.0 * c.0 / 2.0).sum::<f64>()).sqrt();
                let rms_d = (comps
                    .iter()
                    .map(|c| (c.0 * 2.0 * PI * c.1).powi(2) / 2.0)
                    .sum::<f64>())
                .sqrt();
                assert!(
                    ez < 1e-5 * rms_z && ed < 1e-3 * rms_d,
                    "{ez} {rms_z} {ed} {rms_d}"
                );
                let (mut worst_z, mut worst_d) = (0.0f64, 0.0f64);
                for k in 0..20_000 {
                    // Irrational steps: every phase within a cell; −30 m … 370 m.
                    let s = -30.0 + k as f64 * 0.020_000_7 * std::f64::consts::SQRT_2;
                    let (z, d) = road.track(track, s);
                    let (ze, de) = road.track_exact(track, s);
                    worst_z = worst_z.max((z - ze).abs());
                    worst_d = worst_d.max((d - de).abs());
                }
                assert!(
                    worst_z <= ez && worst_d <= ed,
                    "class {class}: {worst_z} > {ez} or {worst_d} > {ed}"
                );
                eprintln!(
                    "class {class}: height {:.1e} (bound {:.1e}), slope {:.1e} (bound {:.1e}) of RMS",
                    worst_z / rms_z,
                    ez / rms_z,
                    worst_d / rms_d,
                    ed / rms_d
                );
                // The baseline node loop (where the CPU has no AVX) gives the same nodes.
                for b in [-1, 0, 7] {
                    let (fast, baseline) = (grid.compute(b), grid.compute_lanes(b));
                    let bits = |v: &Vec<[f64; 3]>| -> Vec<u64> {
                        v.iter().flatten().map(|x| x.to_bits()).collect()
                    };
                    assert_eq!(bits(&fast), bits(&baseline), "block {b}");
                }
                // At the nodes, the sum itself (rotation drift only).
                for k in [-2048i64, -1, 0, 1023, 1024, 1025, 40_000] {
                    let s = k as f64 * ISO_GRID;
                    let (z, d) = road.track(track, s);
                    let (ze, de) = road.track_exact(track, s);
                    assert!(
                        (z - ze).abs() < 1e-12 * rms_z * 1e3 && (d - de).abs() < 1e-9 * rms_d,
                        "node {k}"
                    );
                }
            }
        }
    }

    #[test]
    fn road_velocity_is_the_exact_derivative_of_the_height() {
        for road in roads() {
            for k in 1..4000 {
                let t = k as f64 * 0.0025 + 1.234e-4; // off the profiles' joints
                let h = 1e-6;
                let (zp, zm, v) = (road.at(t + h), road.at(t - h), road.at(t));
                for w in 0..4 {
                    let fd = (zp[w] - zm[w]) / (2.0 * h);
                    assert!(
                        (fd - v[4 + w]).abs() < 1e-5 * (1.0 + v[4 + w].abs()),
                        "{:?} t = {t} wheel {w}: {fd} vs {}",
                        road.profile,
                        v[4 + w]
                    );
                }
            }
        }
    }

    #[test]
    fn the_rear_wheels_follow_the_front_track_one_wheelbase_later() {
        for road in roads() {
            let delay = road.wheelbase / road.speed;
            for k in 0..2000 {
                let t = 1.2 + k as f64 * 0.003; // after the ISO fade-in
                let (now, before) = (road.at(t), road.at(t - delay));
                for (rear, front) in [(2, 0), (3, 1), (6, 4), (7, 5)] {
                    assert!(
                        (now[rear] - before[front]).abs() <= 1e-12 * (1.0 + before[front].abs()),
                        "{:?} at {t}",
                        road.profile
                    );
                }
            }
        }
    }

    #[test]
    fn single_features_are_on_their_side_only_and_end_where_they_should() {
        let r = roads();
        let bump = &r[0];
        let peak = bump.at((1.5 + 2.5) / 15.0);
        assert!((peak[0] - 0.05).abs() < 1e-12 && peak[1] == 0.0);
        assert_eq!(bump.at((1.5 + 5.01) / 15.0)[0], 0.0);
        let pothole = &r[3];
        let inside = pothole.at((1.5 + 0.4) / 15.0);
        assert!((inside[1] + 0.04).abs() < 1e-12 && inside[0] == 0.0);
        assert_eq!(pothole.at((1.5 + 0.81) / 15.0)[1], 0.0);
        let step = &r[4];
        assert!((step.at(100.0)[2] - 0.03).abs() < 1e-12);
        // Identical tracks: left = right; independent: not.
        let same = Road::new(
            Profile::Iso {
                class: 3,
                seed: 1,
                identical_tracks: true,
                fade_in: 0.0,
            },
            20.0,
            2.4,
            0.0,
        )
        .unwrap();
        assert_eq!(same.at(3.0)[0], same.at(3.0)[1]);
        assert_ne!(r[1].at(3.0)[0], r[1].at(3.0)[1]);
    }

    /// The cosines of an ISO track carry, in road velocity at speed `V`, exactly the white PSD of
    /// [`iso_velocity_psd`] over the temporal band `V [n_lo, n_hi]`: `(2π n V)² G_d(n) Δn` is
    /// `4π² n₀² G_d(n₀) V² Δn` for every band, whatever its centre.
    #[test]
    fn road_velocity_has_the_white_psd_of_the_class_over_the_band() {
        for (class, speed) in [(1u8, 10.0), (3, 20.0), (5, 33.0)] {
            let road = Road::new(
                Profile::Iso {
                    class,
                    seed: 3,
                    identical_tracks: false,
                    fade_in: 0.0,
                },
                speed,
                2.4,
                0.0,
            )
            .unwrap();
            let expected = iso_velocity_psd(class, speed) * speed * (ISO_BAND.1 - ISO_BAND.0);
            for track in &road.tracks {
                let variance: f64 = track
                    .iter()
                    .map(|(a, n, _)| 0.5 * (a * 2.0 * PI * n * speed).powi(2))
                    .sum();
                assert!(
                    (variance - expected).abs() <= 1e-9 * expected,
                    "class {class}: {variance} vs {expected}"
                );
            }
        }
    }

    /// The periodogram of a 2 km sample of each track (0.2 m spacing), averaged over the octave
    /// bands 0.02–1.28 cycles/m, against `G_d` of the class (direct DFT at the bins of each band).
    #[test]
    fn iso_road_psd_matches_its_class() {
        for class in [1u8, 3, 6] {
            let road = iso_road(class, 11 + class as u64);
            let (length, ds) = (2000.0, 0.2);
            let n = (length / ds) as usize;
            for track in 0..2 {
                let z: Vec<f64> = (0..n).map(|k| road.track(track, k as f64 * ds).0).collect();
                let mut band_lo = 0.02;
                while band_lo < 1.0 {
                    let band_hi = band_lo * 2.0;
                    let bins: Vec<f64> = ((band_lo * length).ceil() as usize
                        ..(band_hi * length) as usize)
                        .map(|j| j as f64 / length)
                        .collect();
                    let mean_psd = bins
                        .iter()
                        .map(|f| {
                            let (mut re, mut im) = (0.0, 0.0);
                            for (k, zk) in z.iter().enumerate() {
                                let arg = 2.0 * PI * f * k as f64 * ds;
                                re += zk * arg.cos();
                                im -= zk * arg.sin();
                            }
                            2.0 * (re * re + im * im) * ds * ds / length
                        })
                        .sum::<f64>()
                        / bins.len() as f64;
                    // ∫ G_d over the band / its width.
                    let expected = iso_g_d_n0(class) * 0.01 * (1.0 / band_lo - 1.0 / band_hi)
                        / (band_hi - band_lo);
                    let ratio = mean_psd / expected;
                    assert!(
                        (0.8..1.25).contains(&ratio),
                        "class {class} track {track} band {band_lo}-{band_hi}: PSD ratio {ratio}"
                    );
                    band_lo = band_hi;
                }
            }
        }
    }

    /// The terrain adds to any profile, the rear wheels a wheelbase later, its velocity `V`
    /// times its slope; a level terrain leaves the road bit for bit as it was.
    #[test]
    fn terrain_adds_under_every_wheel_with_the_wheelbase_delay() {
        let terrain = Terrain {
            ramp_rise: 0.5,
            hill_height: 1.0,
            crossfall: 0.06,
            ..Terrain::default()
        };
        let plain = iso_road(3, 5);
        let hilly = plain.clone().with_terrain(terrain).unwrap();
        let (v, wb) = (plain.speed, plain.wheelbase);
        for k in 0..400 {
            let t = k as f64 * 0.037;
            let (a, b) = (plain.at(t), hilly.at(t));
            for wheel in 0..4 {
                let d = v * t - if wheel >= 2 { wb } else { 0.0 };
                let (z, slope) = terrain.at(wheel % 2, d);
                assert_eq!(b[wheel], a[wheel] + z, "t = {t}, wheel {wheel}");
                assert_eq!(
                    b[4 + wheel],
                    a[4 + wheel] + v * slope,
                    "t = {t}, wheel {wheel}"
                );
            }
        }
        let level = plain.clone().with_terrain(Terrain::default()).unwrap();
        for k in 0..100 {
            let t = k as f64 * 0.11;
            assert_eq!(level.at(t).map(f64::to_bits), plain.at(t).map(f64::to_bits));
        }
        let bad = Terrain {
            ramp_length: -1.0,
            ..terrain
        };
        assert!(plain.with_terrain(bad).unwrap_err().contains("ramp_length"));
    }
}
