//! `synth`: synthesise every controller, certify it, and write for each variant
//! `dist/<variant>.certificate.json` and `dist/<variant>/controller.json` (the FMU's resource).
//! A design that fails its certificate stops the run with an error: it never becomes an FMU.

use clap::Parser;
use std::path::PathBuf;
use std::process::ExitCode;
use synth::design::Design;
use synth::{variants, SynthError};
use vehicle::VehicleParams;

#[derive(Parser)]
#[command(about = "Synthesise and certify the H-infinity controllers")]
struct Cli {
    /// Design file (weights, scales, limits).
    #[arg(long, default_value = "synth/designs/default.json")]
    design: PathBuf,
    /// Output directory for the certificates and controller.json files.
    #[arg(long, default_value = "dist")]
    out: PathBuf,
    /// Variants to synthesise (all when none is given).
    #[arg(value_parser = clap::builder::PossibleValuesParser::new(variants::ALL))]
    variants: Vec<String>,
}

fn run(cli: Cli) -> Result<(), SynthError> {
    let Cli {
        design: design_path,
        out,
        variants: only,
    } = cli;
    let text = std::fs::read_to_string(&design_path)
        .map_err(|e| SynthError::Io(format!("{}: {e}", design_path.display())))?;
    let design = Design::from_json(&text)?;
    let params = VehicleParams::default();
    let started = std::time::Instant::now();
    let names: Vec<&str> = if only.is_empty() {
        variants::ALL.to_vec()
    } else {
        only.iter().map(|s| s.as_str()).collect()
    };
    let results = variants::synthesise_all(&names, &params, &design)?;
    for (name, result) in &results {
        let elapsed = result.seconds;
        let dir = out.join(name);
        std::fs::create_dir_all(&dir)
            .map_err(|e| SynthError::Io(format!("{}: {e}", dir.display())))?;
        let write = |path: PathBuf, value: &serde_json::Value| {
            std::fs::write(&path, serde_json::to_string_pretty(value).unwrap())
                .map_err(|e| SynthError::Io(format!("{}: {e}", path.display())))
        };
        let mut cert = serde_json::to_value(&result.certificate).unwrap();
        cert["synthesis_seconds"] = serde_json::json!(elapsed);
        write(out.join(format!("{name}.certificate.json")), &cert)?;
        write(dir.join("controller.json"), &result.controller_json)?;
        println!(
            "{name:<10} γ = {:.6}  certified ‖T_zw‖∞ ∈ [{:.6}, {:.6}]  spectral abscissa {:.3}  ({elapsed:.2} s)",
            result.certificate.gamma, result.certificate.norm_lower, result.certificate.norm_upper, result.certificate.spectral_abscissa
        );
    }
    let wall = started.elapsed().as_secs_f64();
    let rows = variants::summary_rows(&results);
    let table = variants::summary_table(&rows, wall);
    let path = out.join("synthesis.md");
    std::fs::write(&path, &table)
        .map_err(|e| SynthError::Io(format!("{}: {e}", path.display())))?;
    // The same, for tools (the master's design table).
    let path = out.join("synthesis.json");
    std::fs::write(
        &path,
        serde_json::to_string_pretty(&serde_json::json!({"designs": rows, "wall_seconds": wall}))
            .unwrap(),
    )
    .map_err(|e| SynthError::Io(format!("{}: {e}", path.display())))?;
    println!("\n{table}");
    Ok(())
}

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("synth: {e}");
            ExitCode::FAILURE
        }
    }
}
