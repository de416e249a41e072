//! `fmu-pack`: package FMUs and write their `modelDescription.xml` from the variable tables.
//!
//! ```text
//! fmu-pack fmu plant --lib target/release/libfmu_plant.so --out dist/plant.fmu
//! fmu-pack descriptions --dir modelDescription
//! ```

use clap::{Parser, Subcommand};
use fmu_core::ffi::EXPORTED_FUNCTIONS;
use fmu_core::{Model, ModelDescription};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Parser)]
#[command(about = "Package the project's FMUs")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Build one .fmu from its compiled shared library.
    Fmu {
        /// Which FMU: plant.
        name: String,
        /// The cdylib cargo built (lib<crate>.so).
        #[arg(long)]
        lib: PathBuf,
        #[arg(long)]
        out: PathBuf,
    },
    /// Rewrite the variable tables in the README (between `<!-- <name>-variables:begin/end -->`).
    Readme {
        path: PathBuf,
    },
    /// Write modelDescription/<name>.xml for every FMU.
    Descriptions {
        #[arg(long, default_value = "modelDescription")]
        dir: PathBuf,
    },
}

/// Every FMU the project ships, by name.
fn descriptions() -> Vec<(&'static str, ModelDescription)> {
    vec![("plant", fmu_plant::Plant::description())]
}

/// Load the library and check it exports all 34 FMI 2.0 functions: `fmpy validate` never
/// loads the binary, so a missing symbol would otherwise be found by a user.
fn check_exports(lib: &Path) -> Result<(), String> {
    // SAFETY: loading our own freshly built library, which has no initialisers with effects.
    let library = unsafe { libloading::Library::new(lib) }.map_err(|e| format!("cannot load {}: {e}", lib.display()))?;
    let missing: Vec<&str> = EXPORTED_FUNCTIONS
        .iter()
        .copied()
        .filter(|name| unsafe { library.get::<*const ()>(name.as_bytes()) }.is_err())
        .collect();
    if missing.is_empty() {
        Ok(())
    } else {
        Err(format!("{} does not export {missing:?}", lib.display()))
    }
}

fn run(cli: Cli) -> Result<(), String> {
    match cli.command {
        Command::Fmu { name, lib, out } => {
            let (_, description) = descriptions()
                .into_iter()
                .find(|(n, _)| *n == name)
                .ok_or_else(|| format!("unknown FMU '{name}'"))?;
            check_exports(&lib)?;
            fmu_core::package::write_fmu(&out, &description, &lib, &[])?;
            println!("wrote {} (GUID {})", out.display(), description.guid);
            Ok(())
        }
        Command::Readme { path } => {
            let mut doc = std::fs::read_to_string(&path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
            for (name, d) in descriptions() {
                doc = ModelDescription::splice_into(&doc, &format!("{name}-variables"), &d.to_markdown_table()).map_err(|e| e.to_string())?;
            }
            std::fs::write(&path, doc).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
            println!("updated {}", path.display());
            Ok(())
        }
        Command::Descriptions { dir } => {
            std::fs::create_dir_all(&dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
            for (name, d) in descriptions() {
                d.check().map_err(|e| format!("{name}: {e}"))?;
                let path = dir.join(format!("{name}.xml"));
                std::fs::write(&path, d.to_xml()).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
                println!("wrote {}", path.display());
            }
            Ok(())
        }
    }
}

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("fmu-pack: {e}");
            ExitCode::FAILURE
        }
    }
}
