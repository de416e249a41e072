//! The co-simulation master: road, plant and controller FMUs through the `fmi` crate.

pub mod certified;
pub mod cosim;
pub mod fmu_log;
pub mod metrics;
pub mod report;
pub mod slave;
pub mod structure;
pub mod sweep;
pub mod sweep_out;

/// The JSON Schemas of the master's input files, generated from the types that read them, so the
/// documented format is the accepted one. Checked in as `schemas/scenario.schema.json` and
/// `schemas/sweep.schema.json` (`master schema scenario|sweep`; a test keeps them equal).
pub mod schema {
    /// The schema of a scenario file.
    pub fn scenario() -> String {
        pretty(schemars::schema_for!(crate::cosim::Scenario))
    }

    /// The schema of a sweep file.
    pub fn sweep() -> String {
        pretty(schemars::schema_for!(crate::sweep::SweepSpec))
    }

    fn pretty(schema: schemars::Schema) -> String {
        serde_json::to_string_pretty(&schema).expect("a schema is JSON") + "\n"
    }

    #[cfg(test)]
    mod tests {
        use std::path::Path;

        #[test]
        fn the_checked_in_schemas_are_the_generated_ones() {
            let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
            for (file, generated) in [
                ("schemas/scenario.schema.json", super::scenario()),
                ("schemas/sweep.schema.json", super::sweep()),
            ] {
                let checked_in = std::fs::read_to_string(root.join(file)).unwrap_or_default();
                assert!(
                    checked_in == generated,
                    "{file} is stale: run `make schemas`"
                );
            }
        }
    }
}
