//! `synth`: synthesise every controller, certify it, and write for each variant
//! `dist/<variant>.certificate.json` and `dist/<variant>/controller.json` (the FMU's resource).
//! A design that fails its certificate never gets a controller: a thesis design stops the run
//! with an error; a refused comfort design is reported in `synthesis.md`, the others are
//! written, and `synth` exits with failure (so `make` ships no partial set).

use clap::Parser;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use synth::shipping::registry::{self, DesignFile};
use synth::SynthError;
use vehicle::VehicleParams;

#[derive(Parser)]
#[command(about = "Synthesise and certify the suspension controllers")]
struct Cli {
    /// Design file: the comfort designs (`"objective": "comfort"`, the default, the FMUs `make`
    /// ships) or the thesis's H∞ designs (`thesis.json`, `constrained.json`).
    #[arg(long, default_value = "synth/designs/comfort.json")]
    design: PathBuf,
    /// The car to design for: a vehicle parameter file of the schema of
    /// `vehicle/params/default.json` (every parameter, with its unit). Default: that file.
    /// Each controller.json records the car (`designed_for`), and the master warns when a
    /// scenario's plant differs from it.
    #[arg(long)]
    vehicle: Option<PathBuf>,
    /// Output directory for the certificates and controller.json files.
    #[arg(long, default_value = "dist")]
    out: PathBuf,
    /// Print the variants' names, one per line, and exit.
    #[arg(long)]
    list: bool,
    /// Print the names of the variants with a thesis design (`thesis.json`), and exit.
    #[arg(long)]
    list_thesis: bool,
    /// Variants to synthesise (all when none is given).
    variants: Vec<String>,
}

fn run(cli: Cli) -> Result<(), SynthError> {
    if cli.list || cli.list_thesis {
        let names = match cli.list_thesis {
            true => registry::thesis_names(),
            false => registry::names(),
        };
        for name in names {
            println!("{name}");
        }
        return Ok(());
    }
    let text = std::fs::read_to_string(&cli.design).map_err(|e| io_error(&cli.design, e))?;
    let file = DesignFile::from_json(&text)?;
    let params = match &cli.vehicle {
        None => VehicleParams::default(),
        Some(path) => {
            let text = std::fs::read_to_string(path).map_err(|e| io_error(path, e))?;
            VehicleParams::from_parameter_file(&text)
                .map_err(|e| SynthError::Usage(format!("{}: {e}", path.display())))?
        }
    };
    let started = std::time::Instant::now();
    let names: Vec<&str> = cli.variants.iter().map(|s| s.as_str()).collect();
    let outcome = registry::synthesise_all(&names, &params, &file)?;
    let results = &outcome.designs;
    let out = &cli.out;
    std::fs::create_dir_all(out).map_err(|e| io_error(out, e))?;
    let write = |path: PathBuf, value: &serde_json::Value| {
        write_text(&path, &serde_json::to_string_pretty(value).expect("JSON"))
    };
    for (name, s) in results {
        let dir = out.join(name);
        std::fs::create_dir_all(&dir).map_err(|e| io_error(&dir, e))?;
        let mut cert = s.certificate.clone();
        cert["synthesis_seconds"] = serde_json::json!(s.seconds);
        write(out.join(format!("{name}.certificate.json")), &cert)?;
        write_text(&dir.join("controller.json"), &s.controller_json.to_json())?;
        println!("{name:<10} {} ({:.2} s)", s.row.certified, s.seconds);
    }
    let wall = started.elapsed().as_secs_f64();
    let rows: Vec<_> = results.iter().map(|(_, s)| s.row.clone()).collect();
    let mut table = registry::summary_table(&rows, wall);
    for (name, why) in &outcome.refused {
        table += &format!("\nRefused `{name}` (no controller written): {why}\n");
    }
    // The car designed for, in the README's words (spliced there by `make readme`).
    write_text(
        &out.join("car.md"),
        &format!(
            "Modal frequencies of the car the controllers are designed for (undamped, \
             `MechanicalModel::modes`): {}.\n",
            vehicle::model::MechanicalModel::new(&params).modes_in_words()
        ),
    )?;
    // What γ says about comfort, in words (spliced into the README by `make readme`).
    if let registry::DesignFile::Thesis(d) = &file {
        if let Some(words) = d
            .comfort_road
            .and_then(|road| registry::gamma_in_words(&rows, &road))
        {
            write_text(&out.join("gamma.md"), &words)?;
        }
    }
    let path = out.join("synthesis.md");
    write_text(&path, &table)?;
    // The same, for tools (the master's design table).
    write(
        out.join("synthesis.json"),
        &serde_json::json!({
            "designs": rows,
            "refused": outcome.refused.iter().map(|(n, why)| serde_json::json!({"variant": n, "reason": why})).collect::<Vec<_>>(),
            "wall_seconds": wall,
        }),
    )?;
    println!("\n{table}");
    match outcome.refused.len() {
        0 => Ok(()),
        n => Err(SynthError::Refused(format!(
            "{n} design(s) refused (see {}); the others are written",
            path.display()
        ))),
    }
}

/// An I/O failure on `path`, named.
fn io_error(path: &Path, e: std::io::Error) -> SynthError {
    SynthError::Io(format!("{}: {e}", path.display()))
}

/// Write `text` to `path`.
fn write_text(path: &Path, text: &str) -> Result<(), SynthError> {
    std::fs::write(path, text).map_err(|e| io_error(path, e))
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
