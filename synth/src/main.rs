//! `synth`: synthesise every controller, certify it, and write for each variant
//! `dist/<variant>.certificate.json` and `dist/<variant>/controller.json` (the FMU's resource).
//! A design that fails its certificate stops the run with an error: it never becomes an FMU.

use std::path::PathBuf;
use std::process::ExitCode;
use synth::design::Design;
use synth::{variants, SynthError};
use vehicle::VehicleParams;

fn run() -> Result<(), SynthError> {
    let mut args = std::env::args().skip(1);
    let mut design_path = PathBuf::from("synth/designs/default.json");
    let mut out = PathBuf::from("dist");
    let mut only: Vec<String> = Vec::new();
    while let Some(a) = args.next() {
        match a.as_str() {
            "--design" => design_path = args.next().ok_or(SynthError::Usage("--design needs a path".into()))?.into(),
            "--out" => out = args.next().ok_or(SynthError::Usage("--out needs a directory".into()))?.into(),
            "-h" | "--help" => {
                println!("usage: synth [--design FILE] [--out DIR] [VARIANT ...]\nvariants: {}", variants::ALL.join(", "));
                return Ok(());
            }
            v if !v.starts_with('-') => only.push(v.to_string()),
            other => return Err(SynthError::Usage(format!("unknown option {other}"))),
        }
    }
    let text = std::fs::read_to_string(&design_path).map_err(|e| SynthError::Io(format!("{}: {e}", design_path.display())))?;
    let design = Design::from_json(&text)?;
    let params = VehicleParams::default();
    let names: Vec<&str> = if only.is_empty() { variants::ALL.to_vec() } else { only.iter().map(|s| s.as_str()).collect() };
    for name in names {
        let t = std::time::Instant::now();
        let result = variants::synthesise(name, &params, &design)?;
        let elapsed = t.elapsed().as_secs_f64();
        let dir = out.join(name);
        std::fs::create_dir_all(&dir).map_err(|e| SynthError::Io(format!("{}: {e}", dir.display())))?;
        let write = |path: PathBuf, value: &serde_json::Value| {
            std::fs::write(&path, serde_json::to_string_pretty(value).unwrap()).map_err(|e| SynthError::Io(format!("{}: {e}", path.display())))
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
    Ok(())
}

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("synth: {e}");
            ExitCode::FAILURE
        }
    }
}
