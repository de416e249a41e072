//! The sensors a production car has, as the plant FMU's `sensor_*` outputs read them: height
//! sensors on the four suspensions and the seat, vertical accelerometers on the body above
//! each wheel and on the seat, roll and pitch rate gyros. None gives an absolute height or
//! velocity. Each reads one physical output ([`crate::model::physical_outputs`]), exactly while
//! the plant's sensor model (noise and bias, `fmu-plant`) is off.

/// The kind of a sensor: which noise and bias it has.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    Height,
    Accelerometer,
    Gyro,
}

/// Number of sensors.
pub const N_SENSORS: usize = 12;

/// The sensors: the physical output each reads (its own output is `sensor_<name>`) and its kind.
pub const SENSORS: [(&str, Kind); N_SENSORS] = [
    ("stroke_fl", Kind::Height),
    ("stroke_fr", Kind::Height),
    ("stroke_rl", Kind::Height),
    ("stroke_rr", Kind::Height),
    ("stroke_seat", Kind::Height),
    ("a_body_fl", Kind::Accelerometer),
    ("a_body_fr", Kind::Accelerometer),
    ("a_body_rl", Kind::Accelerometer),
    ("a_body_rr", Kind::Accelerometer),
    ("a_seat", Kind::Accelerometer),
    ("omega_roll", Kind::Gyro),
    ("omega_pitch", Kind::Gyro),
];

/// The prefix of a sensor's output: `sensor_<physical output>`.
pub const PREFIX: &str = "sensor_";

/// The physical output a plant output reads: `x` for a sensor's `sensor_x`, the name itself
/// otherwise. A model of the car (a design, a prediction) reads a sensor as its physical
/// output: bias and noise are the plant's sensor model, not the car's dynamics.
pub fn physical_name(name: &str) -> &str {
    match name.strip_prefix(PREFIX) {
        Some(rest) if SENSORS.iter().any(|(s, _)| *s == rest) => rest,
        _ => name,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sensor_reads_its_physical_output_and_nothing_else_is_renamed() {
        assert_eq!(physical_name("sensor_a_body_fl"), "a_body_fl");
        assert_eq!(physical_name("sensor_stroke_seat"), "stroke_seat");
        assert_eq!(physical_name("a_body_fl"), "a_body_fl");
        // Not a sensor: left as it is, for the caller to refuse.
        assert_eq!(physical_name("sensor_v_body"), "sensor_v_body");
        assert_eq!(physical_name("sensor_"), "sensor_");
    }

    #[test]
    fn every_sensor_reads_a_physical_output() {
        let rows = crate::model::physical_outputs(&crate::VehicleParams::default());
        for (name, _) in SENSORS {
            assert!(rows.iter().any(|r| r.name == name), "{name}");
        }
    }
}
