//! The design files: every weight, scale and limit of a synthesis, JSON. The comfort designs
//! `make` ships are `synth/designs/comfort.json` ([`ComfortDesign`]); the thesis's H∞ designs
//! (`make thesis`) are `synth/designs/thesis.json` ([`Design`]), and
//! `synth/designs/constrained.json` is the same with the thesis's limits imposed as LMIs
//! (`make constrained`).

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

pub const THESIS_DESIGN_FILE: &str = include_str!("../../designs/thesis.json");
pub const CONSTRAINED_DESIGN_FILE: &str = include_str!("../../designs/constrained.json");

/// How the road enters the generalised plant's disturbance `w`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum RoadModel {
    /// `w` = the four road heights over `road_height_scale` and the four road velocities over
    /// `road_velocity_scale`, as eight independent channels (no road states). The worst case
    /// may then move a height without its velocity, so the tyre load, which carries the height
    /// straight through, has no energy-to-peak bound in this model.
    Independent,
    /// `w` = four road-velocity channels over `road_velocity_scale`; each road height is their
    /// leaky integral, a state: `ż_r = −corner·z_r + road_velocity_scale·w` (the first-order
    /// road-roughness filter of ISO 8608 practice, `corner = 2π n₀ V`, `n₀ ≈ 0.01 cycle/m`).
    /// Height and velocity are then one signal, and the tyre deflection a state. The four filters
    /// are independent, so they hold a static road warp of `road_velocity_scale / corner` per unit
    /// `w` whose strokes no controller moves: at ISO's ~1 rad/s it alone sets γ (5.53 for every
    /// controller, `synth/tests/constraints.rs`); `synth/designs/constrained.json` uses 5.
    Shaped {
        /// [rad/s], > 0.
        corner: f64,
    },
}

/// The bump whose energy bounds the disturbance in the peak (constraint) LMIs.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Bump {
    /// \[m\]
    pub height: f64,
    /// \[m\]
    pub length: f64,
    /// Vehicle speed [m/s].
    pub speed: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Design {
    #[serde(default)]
    pub description: String,
    /// Road height giving a unit disturbance \[m\].
    pub road_height_scale: f64,
    /// Road vertical velocity giving a unit disturbance [m/s].
    pub road_velocity_scale: f64,
    /// Weight of the seat heave acceleration in z [per m/s²].
    pub weight_a_seat: f64,
    /// Weight of the body roll acceleration in z [per rad/s²].
    pub weight_alpha_roll: f64,
    /// Weight of the body pitch acceleration in z [per rad/s²].
    pub weight_alpha_pitch: f64,
    /// Weight of the body heave acceleration in z [per m/s²] (keeps the body no worse than passive).
    pub weight_a_body: f64,
    /// Weight of each suspension stroke relative to `stroke_max` in z (a soft stroke limit).
    pub weight_stroke: f64,
    /// Weight of each dynamic tyre load relative to its static load in z (road holding: the
    /// thesis's "dynamic tyre load < static load", as a soft limit).
    pub weight_tyre_load: f64,
    /// Weight of each actuator force relative to its limit, `ρ u_i / u_max,i`, in z.
    pub control_penalty: f64,
    /// Output feedback: sensor noise on the measured strokes \[m\], a regularisation that makes the
    /// filtering problem non-singular (the measurements have no road feed-through otherwise).
    pub noise_stroke: f64,
    /// Output feedback: sensor noise on the measured body heave velocity and roll/pitch rates
    /// [m/s, rad/s].
    pub noise_rate: f64,
    /// Corner actuator force limit \[N\].
    pub u_max: f64,
    /// Seat actuator force limit \[N\].
    pub u_max_seat: f64,
    /// Suspension stroke limit \[m\].
    pub stroke_max: f64,
    /// Road model of `w` ([`RoadModel`]).
    pub road_model: RoadModel,
    /// Impose the force, stroke and tyre-load limits as energy-to-peak LMIs (`hinf_sf`,
    /// `robust_sf`, `hinf_of`; needs [`RoadModel::Shaped`], in which the tyre load has a bound).
    pub constraints: bool,
    pub design_bump: Bump,
    /// Robust designs (thesis ch. 6): lightest sprung mass \[kg\].
    pub mass_min: f64,
    /// Robust designs: heaviest sprung mass \[kg\].
    pub mass_max: f64,
    /// `delay_sf`: the actuator + processing delay the design must tolerate \[s\].
    pub delay_tau: f64,
    /// `delay_sf`: the descriptor multiplier `P₃ = ε P₂` of the Lyapunov–Krasovskii LMI.
    pub delay_epsilon: f64,
    /// `ft_of`: lowest actuator effectiveness the design must tolerate (each actuator in
    /// `[fault_rho_min, 1]`; 0.5 = half its force lost).
    pub fault_rho_min: f64,
    /// `ft_of`: weight of the H2 bound on the estimation error in the observer LMI's objective
    /// (`γ + w ν`; 0 = γ alone).
    pub fault_h2_weight: f64,
    /// `ft_of`: time constant of the detection residual's filter \[s\].
    pub fault_time_constant: f64,
    /// `ft_of`: force deficit above which `fault_detected` is raised \[N\] (an FMU parameter too).
    pub fault_threshold: f64,
    /// Robust certificates: number of masses of the uniform check grid over the range (≥ 61).
    pub mass_grid_points: usize,
    /// Strictness margin ε of every LMI.
    pub lmi_margin: f64,
    /// Where given, the summary predicts each design's W_k seat RMS on this road beside the
    /// passive car's (what γ says nothing about: README "Why not γ").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub comfort_road: Option<IsoRoad>,
    /// Per-variant changes to the fields above, e.g. `{"hinf_of": {"weight_alpha_roll": 0.8}}`:
    /// each design has its own weights where one set does not suit all ([`Design::with_overrides`]).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub overrides: BTreeMap<String, serde_json::Map<String, serde_json::Value>>,
}

/// How the comfort designs model the rear wheels' road.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum RearWheels {
    /// Four independent tracks: the design ignores that the rear wheels follow the front ones.
    Independent,
    /// The front track delayed by the wheelbase over the speed, as a `[p/p]` Padé approximant.
    Pade {
        /// `p` ≥ 1.
        order: usize,
    },
}

impl std::fmt::Display for RearWheels {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RearWheels::Independent => write!(f, "independent tracks"),
            RearWheels::Pade { order } => write!(f, "the front track, Padé order {order}"),
        }
    }
}

/// The ISO 8608 road the comfort designs are optimised for.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ComfortRoad {
    /// ISO 8608 class, `"A"` … `"H"`.
    pub iso_class: IsoClass,
    /// Vehicle speed [m/s].
    pub speed: f64,
    /// The rear wheels' road in the state-feedback designs, which measure each wheel's road
    /// height and so can preview the front track's.
    pub rear_wheels: RearWheels,
    /// The same in the output-feedback designs (`None`: as `rear_wheels`). Their Kalman filter
    /// takes the model for exact: with a Padé rear track it predicts the rear road from the
    /// front one and hardly corrects it from the sensors, so every error of the approximant
    /// (large at wheel-hop frequencies) and of the design speed is estimation error.
    /// `"independent"` makes the rear road an unknown the filter estimates (README "Comfort
    /// designs" has the measurements).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub output_feedback_rear_wheels: Option<RearWheels>,
    /// Long waves under all four wheels at once in the design model (hills, a grade: `hinf_of`,
    /// [`CarDesign`]); `None`: the ISO roughness alone.
    #[serde(skip)]
    pub long_waves: Option<LongWaves>,
}

/// An ISO 8608 road class, written as its letter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(try_from = "String", into = "String")]
pub struct IsoClass(pub u8);

impl TryFrom<String> for IsoClass {
    type Error = String;
    fn try_from(s: String) -> Result<Self, String> {
        match s.as_bytes() {
            [c @ b'A'..=b'H'] => Ok(IsoClass(c - b'A' + 1)),
            _ => Err(format!(
                "ISO 8608 class must be one of \"A\" … \"H\", got {s:?}"
            )),
        }
    }
}

impl From<IsoClass> for String {
    fn from(c: IsoClass) -> String {
        ((b'A' + c.0 - 1) as char).to_string()
    }
}

impl ComfortRoad {
    /// The temporal band \[Hz\] the road FMU's ISO profile covers at this speed, over which the
    /// certificates predict the comfort figures.
    pub fn band_hz(&self) -> (f64, f64) {
        let (lo, hi) = vehicle::road::ISO_BAND;
        (lo * self.speed, hi * self.speed)
    }
}

/// An ISO 8608 road on which a thesis design's comfort is predicted beside the passive car's
/// (its summary's W_k columns): the rear wheels on the front track exactly the wheelbase over
/// the speed later, the two tracks independent.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IsoRoad {
    pub iso_class: IsoClass,
    /// Vehicle speed [m/s].
    pub speed: f64,
}

impl IsoRoad {
    /// The same road as a comfort design's (whose `rear_wheels`, the design model's, no
    /// prediction reads).
    pub fn as_comfort_road(&self) -> ComfortRoad {
        ComfortRoad {
            iso_class: self.iso_class,
            speed: self.speed,
            rear_wheels: RearWheels::Independent,
            output_feedback_rear_wheels: None,
            long_waves: None,
        }
    }
}

/// The comfort designs (`synth/designs/comfort.json`, what `make` ships): every variant
/// minimises the ISO 2631-1 comfort norm on one ISO 8608 road, subject to its own guarantee
/// ([`crate::comfort::designs`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ComfortDesign {
    /// `"comfort"` (what tells the file from a thesis design file; optional here).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub objective: Option<String>,
    #[serde(default)]
    pub description: String,
    pub road: ComfortRoad,
    /// Corner actuator force limit \[N\].
    pub u_max: f64,
    /// Seat actuator force limit \[N\].
    pub u_max_seat: f64,
    /// Suspension stroke limit \[m\].
    pub stroke_max: f64,
    /// The limits are met as `limit_sigmas` standard deviations on the design road.
    pub limit_sigmas: f64,
    /// Actuator delay every design tolerates without being told \[s\]: the lag of the actuators
    /// and of the co-simulation's hold, as an input-multiplicative uncertainty.
    pub unmodelled_delay: f64,
    /// Robust designs: the sprung-mass range \[kg\].
    pub mass_min: f64,
    pub mass_max: f64,
    /// Robust certificates: number of masses of the uniform check grid (≥ 2).
    pub mass_grid_points: usize,
    /// `delay_sf`: the largest actuator delay its predictor is certified for \[s\].
    pub delay_max: f64,
    /// `ft_of`: lowest actuator effectiveness the design must tolerate.
    pub fault_rho_min: f64,
    /// `ft_of`: time constant of the detection residual's filter \[s\].
    pub fault_time_constant: f64,
    /// `ft_of`: force deficit above which `fault_detected` is raised \[N\].
    pub fault_threshold: f64,
    /// `ft_of`: averaging time of the effectiveness estimate its commands are divided by \[s\]
    /// (fault accommodation).
    pub accommodation_time_constant: f64,
    /// The communication step a master runs the controllers at \[s\]; the certificates predict
    /// the co-simulation at it too (`comfort.held`, [`crate::predict::sampled`]). Default: the
    /// scenarios' 1 ms.
    #[serde(default = "default_communication_step")]
    pub communication_step: f64,
    /// `skyhook`: the corner of its velocity estimators, each accelerometer integrated and
    /// high-passed twice there \[Hz\] ([`crate::comfort::skyhook`]).
    #[serde(default = "default_skyhook_highpass_hz")]
    pub skyhook_highpass_hz: f64,
    /// The state feedbacks (`hinf_sf`, `robust_sf`, `delay_sf`): the corner of the frame they
    /// measure heights and velocities from \[Hz\] ([`crate::comfort::plant::Frame`]); absent: from
    /// the equilibrium at `t = 0`, as designed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub state_feedback_frame_hz: Option<f64>,
    /// `hinf_of`: the design on the sensors a car has ([`CarDesign`]; absent: no `hinf_of`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub car: Option<CarDesign>,
    /// A limit on the seat stroke \[m\] (3 σ like the others), imposed by the design built on
    /// [`CarDesign`] only (`None` elsewhere).
    #[serde(skip)]
    pub seat_stroke_max: Option<f64>,
}

/// `hinf_of`: an output feedback on the sensors a production car has (`sensor_*`: five height
/// sensors, four body accelerometers and one on the seat, the roll and pitch gyros) and the
/// actuators' load cells, designed on a road with long waves and with the seat stroke limited.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CarDesign {
    /// Noise densities of the sensors (one-sided, per √Hz).
    pub noise: CarSensorNoise,
    /// The long waves of the design road ([`ComfortRoad::long_waves`]).
    pub long_waves: LongWaves,
    /// The seat stroke limit \[m\].
    pub seat_stroke_max: f64,
    /// The corner of the washout `s / (s + ω)` each inertial sensor (accelerometer and gyro)
    /// passes before the Kalman filter \[Hz\]: a bias (up to 0.2 m/s² and 0.2 °/s in
    /// production) would otherwise read as a lasting acceleration or rate and hold the actuators
    /// against it (1000 N measured without the accelerometers' washout; 370 N from the gyros'
    /// biases without theirs, `robust_of`). Also read as `accelerometer_washout_hz`, its name
    /// when it washed out the accelerometers alone.
    #[serde(alias = "accelerometer_washout_hz")]
    pub inertial_washout_hz: f64,
    /// The Kalman filter's doubt about where the car is ([`RigidDrift`]); absent, the
    /// production default.
    #[serde(default)]
    pub rigid_drift: RigidDrift,
    /// The actuators `hinf_of`'s gain is designed behind: first-order, of this bandwidth \[Hz\]
    /// (a hydraulic unit: about 10), the controller carrying its own model of their forces
    /// (`crate::comfort::car`); absent, ideal actuators.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub actuator_bandwidth_hz: Option<f64>,
    /// Behind `actuator_bandwidth_hz`: the controller's model of each force corrected towards
    /// the load cell's measured force at this rate \[Hz\] (`ḟ̂ = ω_a (u − f̂) + ω_c (f − f̂)`),
    /// so that a force the actuator does not give (lost, saturated, faster than modelled) stops
    /// being fed back; absent, the model runs on the command alone.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub force_correction_hz: Option<f64>,
}

/// Fictitious process noise in the Kalman filter of the designs on the car's sensors that moves
/// the car and the road under it together, as a rigid body: a random walk of the height, roll
/// and pitch (`position`, intensity `position²`, m/√s or rad/√s) and of their rates
/// (`velocity`, m/s/√s or rad/s/√s). Only integrated accelerations tell the filter where the
/// car is; without the doubt it trusted its own integral for minutes (its slowest modes −0.0085
/// and −0.011 ± 0.011j rad/s), and a grade's onset or a sensor's bias held the actuators for as
/// long (up to 305 N over 40–60 s after a bias, `robust_of`). Zero: no doubt.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RigidDrift {
    pub position: f64,
    pub velocity: f64,
}

impl Default for RigidDrift {
    /// 1 mm/√s and 1 cm/s/√s: the slowest modes at about −0.064 rad/s, for 4 % of the
    /// predicted W_k seat on the design road (`hinf_of` 0.0620 → 0.0644 m/s²).
    fn default() -> Self {
        RigidDrift {
            position: 1e-3,
            velocity: 1e-2,
        }
    }
}

/// Long waves of a road, the same under every wheel: a height `h = q w / (s + b)²`, `b = 2π V /
/// wavelength`, of RMS `height_rms` (`q = 2 height_rms b^{3/2}`; second order, so that their
/// velocity, unlike the ISO roughness's, fades above `b`): hills and grades, whose wavelengths
/// dwarf the wheelbase and the track.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LongWaves {
    /// \[m\].
    pub height_rms: f64,
    /// \[m\].
    pub wavelength: f64,
}

/// One-sided noise densities of a car's sensors.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CarSensorNoise {
    /// Height sensors [m/√Hz].
    pub height: f64,
    /// Accelerometers [m/s²/√Hz].
    pub acceleration: f64,
    /// Gyros [rad/s/√Hz].
    pub rate: f64,
}

fn default_communication_step() -> f64 {
    1e-3
}

fn default_skyhook_highpass_hz() -> f64 {
    0.3
}

impl ComfortDesign {
    /// The design the output-feedback variants are synthesised on: this one with their rear-wheel
    /// model ([`ComfortRoad::output_feedback_rear_wheels`]).
    /// The design `hinf_of` is synthesised on ([`CarDesign`]): the output-feedback road model with
    /// its long waves, and its seat stroke limit. `None` without a `car` block.
    pub fn for_car(&self) -> Option<ComfortDesign> {
        let car = self.car?;
        let mut d = self.for_output_feedback();
        d.road.long_waves = Some(car.long_waves);
        d.seat_stroke_max = Some(car.seat_stroke_max);
        Some(d)
    }

    /// The design the state feedbacks (`hinf_sf`, `robust_sf`, `delay_sf`) are synthesised on:
    /// this one with the car's long waves and seat stroke limit ([`CarDesign`]), their rear
    /// wheels still on the front track's preview. A state feedback isolates the body and seat by
    /// cancelling their springs; on the ISO road alone it chose loops so soft against the road's
    /// pose that 1 m hills over 200 m put its seat on its stops. Itself without a `car` block.
    pub fn for_state_feedback(&self) -> ComfortDesign {
        let mut d = self.clone();
        if let Some(car) = self.car {
            d.road.long_waves = Some(car.long_waves);
            d.seat_stroke_max = Some(car.seat_stroke_max);
        }
        d
    }

    /// (Without the state feedbacks' frame, `state_feedback_frame_hz`, which no observer reads.)
    pub fn for_output_feedback(&self) -> ComfortDesign {
        let mut d = self.clone();
        d.state_feedback_frame_hz = None;
        if let Some(rear) = self.road.output_feedback_rear_wheels {
            d.road.rear_wheels = rear;
        }
        d
    }

    pub fn from_json(json: &str) -> Result<Self, DesignError> {
        let d: ComfortDesign =
            serde_json::from_str(json).map_err(|e| DesignError::Syntax(e.to_string()))?;
        d.validate()?;
        Ok(d)
    }

    pub fn validate(&self) -> Result<(), DesignError> {
        if self.objective.as_deref().is_some_and(|o| o != "comfort") {
            return Err(DesignError::Syntax(format!(
                "objective '{}' in a comfort design file: expected \"comfort\"",
                self.objective.as_deref().unwrap_or_default()
            )));
        }
        let positive = [
            ("road.speed", self.road.speed),
            ("u_max", self.u_max),
            ("u_max_seat", self.u_max_seat),
            ("stroke_max", self.stroke_max),
            ("limit_sigmas", self.limit_sigmas),
            ("unmodelled_delay", self.unmodelled_delay),
            ("delay_max", self.delay_max),
            ("communication_step", self.communication_step),
            ("skyhook_highpass_hz", self.skyhook_highpass_hz),
            (
                "state_feedback_frame_hz",
                self.state_feedback_frame_hz.unwrap_or(1.0),
            ),
            ("fault_time_constant", self.fault_time_constant),
            ("fault_threshold", self.fault_threshold),
            (
                "accommodation_time_constant",
                self.accommodation_time_constant,
            ),
        ];
        require_positive(&positive)?;
        if let Some(car) = &self.car {
            require_positive(&[
                ("car.noise.height", car.noise.height),
                ("car.noise.acceleration", car.noise.acceleration),
                ("car.noise.rate", car.noise.rate),
                ("car.long_waves.height_rms", car.long_waves.height_rms),
                ("car.long_waves.wavelength", car.long_waves.wavelength),
                ("car.seat_stroke_max", car.seat_stroke_max),
                ("car.inertial_washout_hz", car.inertial_washout_hz),
            ])?;
            if let Some(hz) = car.actuator_bandwidth_hz {
                require_positive(&[("car.actuator_bandwidth_hz", hz)])?;
            }
            if let Some(hz) = car.force_correction_hz {
                require_positive(&[("car.force_correction_hz", hz)])?;
                if car.actuator_bandwidth_hz.is_none() {
                    return Err(DesignError::Value {
                        name: "car.force_correction_hz",
                        expected: "absent without car.actuator_bandwidth_hz (ideal actuators have no force model)",
                        value: hz,
                    });
                }
            }
            for (name, value) in [
                ("car.rigid_drift.position", car.rigid_drift.position),
                ("car.rigid_drift.velocity", car.rigid_drift.velocity),
            ] {
                if !(value >= 0.0 && value.is_finite()) {
                    return Err(DesignError::Value {
                        name,
                        expected: "a finite number >= 0",
                        value,
                    });
                }
            }
        }
        for (name, rear) in [
            ("road.rear_wheels.pade.order", Some(self.road.rear_wheels)),
            (
                "road.output_feedback_rear_wheels.pade.order",
                self.road.output_feedback_rear_wheels,
            ),
        ] {
            if let Some(RearWheels::Pade { order }) = rear {
                if !(1..=8).contains(&order) {
                    return Err(DesignError::Value {
                        name,
                        expected: "1 … 8",
                        value: order as f64,
                    });
                }
            }
        }
        require_mass_range(self.mass_min, self.mass_max)?;
        if self.mass_grid_points < 2 {
            return Err(DesignError::Value {
                name: "mass_grid_points",
                expected: "at least 2",
                value: self.mass_grid_points as f64,
            });
        }
        require_effectiveness(self.fault_rho_min)?;
        Ok(())
    }
}

/// Every `(name, value)` finite and > 0: the checks both design files share.
fn require_positive(values: &[(&'static str, f64)]) -> Result<(), DesignError> {
    for &(name, value) in values {
        if !(value > 0.0 && value.is_finite()) {
            return Err(DesignError::Value {
                name,
                expected: "a finite number > 0",
                value,
            });
        }
    }
    Ok(())
}

fn require_mass_range(mass_min: f64, mass_max: f64) -> Result<(), DesignError> {
    if !(mass_min > 0.0 && mass_min < mass_max && mass_max.is_finite()) {
        return Err(DesignError::Value {
            name: "mass_min, mass_max",
            expected: "0 < mass_min < mass_max < inf",
            value: mass_min,
        });
    }
    Ok(())
}

fn require_effectiveness(rho_min: f64) -> Result<(), DesignError> {
    if !(rho_min > 0.0 && rho_min < 1.0) {
        return Err(DesignError::Value {
            name: "fault_rho_min",
            expected: "in (0, 1)",
            value: rho_min,
        });
    }
    Ok(())
}

#[derive(Debug, thiserror::Error)]
pub enum DesignError {
    #[error("design file is not valid: {0}")]
    Syntax(String),
    #[error("design value '{name}' must be {expected}, got {value}")]
    Value {
        name: &'static str,
        expected: &'static str,
        value: f64,
    },
    #[error("design: {0}")]
    Inconsistent(&'static str),
    #[error("design override for '{variant}' is not valid: {reason}")]
    Override { variant: String, reason: String },
}

impl Default for Design {
    fn default() -> Self {
        Design::from_json(THESIS_DESIGN_FILE)
            .expect("the checked-in default design is valid (tested)")
    }
}

impl Design {
    pub fn from_json(json: &str) -> Result<Self, DesignError> {
        let d: Design =
            serde_json::from_str(json).map_err(|e| DesignError::Syntax(e.to_string()))?;
        d.validate()?;
        for variant in d.overrides.keys() {
            d.with_overrides(variant)?;
        }
        Ok(d)
    }

    /// This design with the fields of `overrides[variant]` replaced (the others, and the
    /// overrides themselves, kept), validated like the whole file. A variant without overrides
    /// gets the design unchanged.
    pub fn with_overrides(&self, variant: &str) -> Result<Design, DesignError> {
        let Some(changes) = self.overrides.get(variant) else {
            return Ok(self.clone());
        };
        let fail = |reason: String| DesignError::Override {
            variant: variant.into(),
            reason,
        };
        if changes.contains_key("overrides") || changes.contains_key("description") {
            return Err(fail("only design values can be overridden".into()));
        }
        let mut value = serde_json::to_value(self).expect("a design serialises");
        let fields = value.as_object_mut().expect("a design is an object");
        for (key, v) in changes {
            if !fields.contains_key(key) {
                return Err(fail(format!("unknown field '{key}'")));
            }
            fields.insert(key.clone(), v.clone());
        }
        let d: Design = serde_json::from_value(value).map_err(|e| fail(e.to_string()))?;
        d.validate().map_err(|e| fail(e.to_string()))?;
        Ok(d)
    }

    pub fn validate(&self) -> Result<(), DesignError> {
        let positive = [
            ("road_height_scale", self.road_height_scale),
            ("road_velocity_scale", self.road_velocity_scale),
            ("control_penalty", self.control_penalty),
            ("u_max", self.u_max),
            ("u_max_seat", self.u_max_seat),
            ("stroke_max", self.stroke_max),
            ("design_bump.height", self.design_bump.height),
            ("design_bump.length", self.design_bump.length),
            ("design_bump.speed", self.design_bump.speed),
            ("lmi_margin", self.lmi_margin),
            ("noise_stroke", self.noise_stroke),
            ("noise_rate", self.noise_rate),
            ("delay_tau", self.delay_tau),
            ("delay_epsilon", self.delay_epsilon),
            ("fault_time_constant", self.fault_time_constant),
            ("fault_threshold", self.fault_threshold),
            (
                "comfort_road.speed",
                self.comfort_road.map_or(1.0, |r| r.speed),
            ),
        ];
        require_positive(&positive)?;
        require_mass_range(self.mass_min, self.mass_max)?;
        if !(self.fault_h2_weight >= 0.0 && self.fault_h2_weight.is_finite()) {
            return Err(DesignError::Value {
                name: "fault_h2_weight",
                expected: "a finite number >= 0",
                value: self.fault_h2_weight,
            });
        }
        require_effectiveness(self.fault_rho_min)?;
        if let RoadModel::Shaped { corner } = self.road_model {
            if !(corner > 0.0 && corner.is_finite()) {
                return Err(DesignError::Value {
                    name: "road_model.shaped.corner",
                    expected: "a finite number > 0",
                    value: corner,
                });
            }
        }
        if self.constraints && self.road_model == RoadModel::Independent {
            return Err(DesignError::Inconsistent("\"constraints\": true needs \"road_model\": {\"shaped\": {\"corner\": ...}}: with independent road heights the dynamic tyre load carries the height straight through and has no energy-to-peak bound"));
        }
        if self.mass_grid_points < 2 {
            return Err(DesignError::Value {
                name: "mass_grid_points",
                expected: "at least 2",
                value: self.mass_grid_points as f64,
            });
        }
        for (name, value) in [
            ("weight_a_seat", self.weight_a_seat),
            ("weight_alpha_roll", self.weight_alpha_roll),
            ("weight_alpha_pitch", self.weight_alpha_pitch),
            ("weight_a_body", self.weight_a_body),
            ("weight_stroke", self.weight_stroke),
            ("weight_tyre_load", self.weight_tyre_load),
        ] {
            if !(value >= 0.0 && value.is_finite()) {
                return Err(DesignError::Value {
                    name,
                    expected: "a finite number >= 0",
                    value,
                });
            }
        }
        Ok(())
    }

    /// `∫ ‖w‖² dt` of the design bump on the two left wheels (rear delayed), in scaled units:
    /// the disturbance energy the peak LMIs guarantee the limits for. Closed form of
    /// `∫ r² = ∫ (h/2)²(1 − cos)²` and `∫ ṙ² = ∫ (h/2 · 2π/L · V)² sin²` over the bump's
    /// duration `L/V`; independent road: `∫ r²/s_h² + ṙ²/s_v²`; shaped road (`w = (ṙ + a r)/s_v`):
    /// `∫ (ṙ² + a² r²)/s_v²` (the cross term `a [r²]` vanishes, `r` being 0 at both ends).
    pub fn design_energy(&self) -> f64 {
        let b = &self.design_bump;
        let duration = b.length / b.speed;
        let height = (0.5 * b.height).powi(2) * 1.5 * duration;
        let amp = 0.5 * b.height * 2.0 * std::f64::consts::PI / b.length * b.speed;
        let velocity = amp * amp * 0.5 * duration;
        let per_wheel = match self.road_model {
            RoadModel::Independent => {
                height / self.road_height_scale.powi(2)
                    + velocity / self.road_velocity_scale.powi(2)
            }
            RoadModel::Shaped { corner } => {
                (velocity + corner * corner * height) / self.road_velocity_scale.powi(2)
            }
        };
        2.0 * per_wheel
    }

    /// `max_t |ṙ(t) + a r(t)|` of the design bump (`a` the shaped road's corner, 0 if
    /// independent), bounded by `π h V / L + a h`: the largest road velocity the shaped road's
    /// `w` carries straight into the tyre damper force.
    pub fn design_bump_peak_velocity(&self) -> f64 {
        let b = &self.design_bump;
        let corner = match self.road_model {
            RoadModel::Independent => 0.0,
            RoadModel::Shaped { corner } => corner,
        };
        std::f64::consts::PI * b.height * b.speed / b.length + corner * b.height
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The state feedbacks' design road has the car's long waves and their design its seat
    /// stroke limit; the rear wheels stay on the front track's preview. Without a `car` block
    /// it is the file's design.
    #[test]
    fn state_feedbacks_are_designed_with_the_long_waves_and_the_seat_stroke_limit() {
        let text = include_str!("../../designs/comfort.json");
        let d = ComfortDesign::from_json(text).unwrap();
        let car = d.car.expect("the shipped file has a car block");
        let sf = d.for_state_feedback();
        assert_eq!(sf.road.long_waves, Some(car.long_waves));
        assert_eq!(sf.seat_stroke_max, Some(car.seat_stroke_max));
        assert_eq!(sf.road.rear_wheels, d.road.rear_wheels);
        assert_eq!(sf.state_feedback_frame_hz, d.state_feedback_frame_hz);
        let plain = ComfortDesign { car: None, ..d };
        assert_eq!(plain.for_state_feedback(), plain);
    }

    /// `car.force_correction_hz` corrects a model of the actuators' forces: without
    /// `car.actuator_bandwidth_hz` there is none, and the file is refused by the name; so is a
    /// rate that is not positive. With both it parses; the shipped file has lagging actuators
    /// (30 Hz) and no correction.
    #[test]
    fn a_force_correction_needs_lagging_actuators_and_a_positive_rate() {
        let shipped_text = include_str!("../../designs/comfort.json");
        let shipped = ComfortDesign::from_json(shipped_text).unwrap().car.unwrap();
        assert_eq!(
            (shipped.actuator_bandwidth_hz, shipped.force_correction_hz),
            (Some(30.0), None)
        );
        let lag = r#""actuator_bandwidth_hz": 30.0, "#;
        assert!(shipped_text.contains(lag));
        let text = shipped_text.replace(lag, "");
        let drift = r#""rigid_drift": { "position": 1e-3, "velocity": 1e-2 }"#;
        assert!(text.contains(drift));
        let with = |extra: &str| text.replace(drift, &format!("{drift}, {extra}"));
        let refused = |extra: &str| match ComfortDesign::from_json(&with(extra)) {
            Err(DesignError::Value { name, .. }) => name,
            other => panic!("{extra}: {other:?}"),
        };
        assert_eq!(
            refused(r#""force_correction_hz": 5"#),
            "car.force_correction_hz"
        );
        for bad in ["0", "-5"] {
            let extra = format!(r#""actuator_bandwidth_hz": 10, "force_correction_hz": {bad}"#);
            assert_eq!(refused(&extra), "car.force_correction_hz");
        }
        let car = ComfortDesign::from_json(&with(
            r#""actuator_bandwidth_hz": 10, "force_correction_hz": 5"#,
        ))
        .unwrap()
        .car
        .unwrap();
        assert_eq!(
            (car.actuator_bandwidth_hz, car.force_correction_hz),
            (Some(10.0), Some(5.0))
        );
    }

    #[test]
    fn output_feedback_designs_get_their_own_rear_wheel_model() {
        let text = include_str!("../../designs/comfort.json");
        let d = ComfortDesign::from_json(text).unwrap();
        assert_eq!(d.road.rear_wheels, RearWheels::Pade { order: 2 });
        let of = d.for_output_feedback();
        assert_eq!(of.road.rear_wheels, RearWheels::Independent);
        assert_eq!(of.state_feedback_frame_hz, None);
        assert_eq!(
            ComfortDesign {
                road: d.road,
                state_feedback_frame_hz: d.state_feedback_frame_hz,
                ..of.clone()
            },
            d,
            "only the rear-wheel model and the frame change"
        );
        // Absent: as the state-feedback designs.
        let same = text.replace(r#", "output_feedback_rear_wheels": "independent""#, "");
        assert_ne!(same, text);
        let d = ComfortDesign::from_json(&same).unwrap();
        assert_eq!(d.road.output_feedback_rear_wheels, None);
        assert_eq!(
            d.for_output_feedback(),
            ComfortDesign {
                state_feedback_frame_hz: None,
                ..d.clone()
            }
        );
        // A Padé order out of range is refused by its name.
        let bad = text.replace(
            r#""output_feedback_rear_wheels": "independent""#,
            r#""output_feedback_rear_wheels": {"pade": {"order": 9}}"#,
        );
        assert!(matches!(
            ComfortDesign::from_json(&bad),
            Err(DesignError::Value {
                name: "road.output_feedback_rear_wheels.pade.order",
                ..
            })
        ));
    }

    #[test]
    fn default_design_parses_and_bad_values_are_rejected() {
        let d = Design::default();
        assert_eq!(d.u_max, 2500.0);
        let bad = THESIS_DESIGN_FILE.replace("\"stroke_max\": 0.08", "\"stroke_max\": -0.08");
        assert!(matches!(
            Design::from_json(&bad),
            Err(DesignError::Value {
                name: "stroke_max",
                ..
            })
        ));
        assert!(matches!(
            Design::from_json("{\"u_max\": 1}"),
            Err(DesignError::Syntax(_))
        ));
    }

    #[test]
    fn overrides_change_only_their_variant_and_bad_ones_are_refused() {
        let d = Design::default();
        let base = Design {
            overrides: BTreeMap::new(),
            ..d.clone()
        };
        for (variant, changes) in &d.overrides {
            let o = d.with_overrides(variant).unwrap();
            let mut expected = serde_json::to_value(&base).unwrap();
            for (k, v) in changes {
                expected[k] = v.clone();
            }
            assert_eq!(
                serde_json::to_value(Design {
                    overrides: BTreeMap::new(),
                    ..o
                })
                .unwrap(),
                expected,
                "{variant}"
            );
        }
        assert_eq!(d.with_overrides("no_such_variant_overridden").unwrap(), d);
        let parse = |o: &str| {
            let mut v: serde_json::Value = serde_json::from_str(THESIS_DESIGN_FILE).unwrap();
            v["overrides"] =
                serde_json::json!({ "x": serde_json::from_str::<serde_json::Value>(o).unwrap() });
            Design::from_json(&v.to_string())
        };
        assert!(parse(r#"{"weight_alpha_roll": 0.9}"#).is_ok());
        for bad in [
            r#"{"weight_alpha_rol": 0.9}"#,
            r#"{"weight_alpha_roll": -1}"#,
            r#"{"weight_alpha_roll": "high"}"#,
            r#"{"overrides": {}}"#,
        ] {
            assert!(
                matches!(parse(bad), Err(DesignError::Override { .. })),
                "{bad}"
            );
        }
    }

    #[test]
    fn design_energy_and_peak_velocity_match_quadrature() {
        for road_model in [RoadModel::Independent, RoadModel::Shaped { corner: 1.3 }] {
            let d = Design {
                road_model,
                ..Design::default()
            };
            let b = d.design_bump;
            let n = 200_000;
            let dt = b.length / b.speed / n as f64;
            let w = 2.0 * std::f64::consts::PI / b.length;
            let (mut e, mut peak) = (0.0, 0.0f64);
            for k in 0..n {
                let x = b.speed * (k as f64 + 0.5) * dt;
                let r = 0.5 * b.height * (1.0 - (w * x).cos());
                let v = 0.5 * b.height * w * b.speed * (w * x).sin();
                let (channels, velocity) = match road_model {
                    RoadModel::Independent => (
                        (r / d.road_height_scale).powi(2) + (v / d.road_velocity_scale).powi(2),
                        v,
                    ),
                    RoadModel::Shaped { corner } => (
                        ((v + corner * r) / d.road_velocity_scale).powi(2),
                        v + corner * r,
                    ),
                };
                e += 2.0 * channels * dt;
                peak = peak.max(velocity.abs());
            }
            assert!(
                (e - d.design_energy()).abs() < 1e-8 * e,
                "{road_model:?}: {e} vs {}",
                d.design_energy()
            );
            // The closed-form bound is an upper bound, and within 10 % of the sampled peak.
            let bound = d.design_bump_peak_velocity();
            assert!(
                peak <= bound && peak > 0.9 * bound,
                "{road_model:?}: {peak} vs {bound}"
            );
        }
    }

    /// The constrained design is the default one with the limits imposed: it differs in nothing
    /// else, so its comparison with the shipped designs measures the constraints (and the road
    /// model they need), not a drift between two files.
    #[test]
    fn constrained_design_is_the_default_with_the_limits_imposed() {
        let (d, c) = (
            Design::default(),
            Design::from_json(CONSTRAINED_DESIGN_FILE).unwrap(),
        );
        assert!(c.constraints && matches!(c.road_model, RoadModel::Shaped { .. }));
        assert!(c.design_bump.height < d.design_bump.height);
        let same = Design {
            road_model: d.road_model,
            constraints: d.constraints,
            design_bump: d.design_bump,
            ..c.clone()
        };
        let strip = |d: &Design| {
            let mut v = serde_json::to_value(d).unwrap();
            v.as_object_mut().unwrap().remove("description");
            v
        };
        assert_eq!(strip(&same), strip(&d));
    }

    /// The thesis file's comfort road is checked like a comfort design's: a speed that is not
    /// positive and an unknown class are refused by name.
    #[test]
    fn a_bad_comfort_road_is_refused_by_name() {
        let road = r#""comfort_road": { "iso_class": "C", "speed": 20.0 }"#;
        assert!(THESIS_DESIGN_FILE.contains(road));
        let speed = THESIS_DESIGN_FILE
            .replace(road, r#""comfort_road": { "iso_class": "C", "speed": -1 }"#);
        assert!(matches!(
            Design::from_json(&speed),
            Err(DesignError::Value {
                name: "comfort_road.speed",
                ..
            })
        ));
        let class = THESIS_DESIGN_FILE
            .replace(road, r#""comfort_road": { "iso_class": "Z", "speed": 20 }"#);
        let e = Design::from_json(&class).unwrap_err().to_string();
        assert!(e.contains('Z'), "{e}");
        let without = THESIS_DESIGN_FILE.replace(&format!("  {road},\n"), "");
        assert_eq!(Design::from_json(&without).unwrap().comfort_road, None);
    }

    /// The car's rigid drift: zero is allowed (no doubt), a negative or missing-a-field one is
    /// refused by name, and a file without it takes the production default.
    #[test]
    fn the_car_s_rigid_drift_is_checked_and_defaults() {
        const COMFORT_DESIGN_FILE: &str = include_str!("../../designs/comfort.json");
        let drift = r#""rigid_drift": { "position": 1e-3, "velocity": 1e-2 }"#;
        assert!(COMFORT_DESIGN_FILE.contains(drift));
        let with = |text: &str| COMFORT_DESIGN_FILE.replace(drift, text);
        let zero =
            ComfortDesign::from_json(&with(r#""rigid_drift": { "position": 0, "velocity": 0 }"#))
                .unwrap();
        assert_eq!(zero.car.unwrap().rigid_drift.position, 0.0);
        assert!(matches!(
            ComfortDesign::from_json(&with(
                r#""rigid_drift": { "position": -1e-3, "velocity": 1e-2 }"#
            )),
            Err(DesignError::Value {
                name: "car.rigid_drift.position",
                ..
            })
        ));
        let e = ComfortDesign::from_json(&with(r#""rigid_drift": { "position": 1e-3 }"#))
            .unwrap_err()
            .to_string();
        assert!(e.contains("velocity"), "{e}");
        let without = COMFORT_DESIGN_FILE.replace(&format!(", {drift}"), "");
        assert_eq!(
            ComfortDesign::from_json(&without)
                .unwrap()
                .car
                .unwrap()
                .rigid_drift,
            RigidDrift::default()
        );
    }

    #[test]
    fn constraints_need_the_shaped_road_and_a_valid_corner() {
        let on = THESIS_DESIGN_FILE.replace("\"constraints\": false", "\"constraints\": true");
        assert!(matches!(
            Design::from_json(&on),
            Err(DesignError::Inconsistent(_))
        ));
        let shaped = |corner: &str| {
            on.replace(
                "\"road_model\": \"independent\"",
                &format!("\"road_model\": {{\"shaped\": {{\"corner\": {corner}}}}}"),
            )
        };
        assert_eq!(
            Design::from_json(&shaped("1.2")).unwrap().road_model,
            RoadModel::Shaped { corner: 1.2 }
        );
        assert!(matches!(
            Design::from_json(&shaped("-1")),
            Err(DesignError::Value {
                name: "road_model.shaped.corner",
                ..
            })
        ));
        assert!(matches!(
            Design::from_json(&on.replace(
                "\"road_model\": \"independent\"",
                "\"road_model\": \"filtered\""
            )),
            Err(DesignError::Syntax(_))
        ));
    }
}
