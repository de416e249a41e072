//! Writing a `.fmu` archive (FMI 2.0.4 §2.3): `modelDescription.xml`, the shared library as
//! `binaries/<platform>/<modelIdentifier>.so`, and `resources/`.

use std::io::Write;
use std::path::Path;

/// FMI platform folder of the machine we build on.
pub fn platform_folder() -> Result<&'static str, String> {
    match (std::env::consts::OS, std::env::consts::ARCH) {
        ("linux", "x86_64") => Ok("linux64"),
        // FMI 2.0 has no aarch64 name; FMPy and the fmi crate look in linux64 too.
        ("linux", "aarch64") => Ok("linux64"),
        ("linux", "x86") => Ok("linux32"),
        (os, arch) => Err(format!("no FMI 2.0 platform folder for {os}/{arch}")),
    }
}

/// Write `out` from the `modelDescription.xml` text, the compiled library (stored as
/// `<model_identifier>.so`) and resource files (`(path inside resources/, contents)`).
pub fn write_fmu(
    out: &Path,
    xml: &str,
    model_identifier: &str,
    library: &Path,
    resources: &[(String, Vec<u8>)],
) -> Result<(), String> {
    let binary =
        std::fs::read(library).map_err(|e| format!("cannot read {}: {e}", library.display()))?;
    if let Some(parent) = out.parent() {
        std::fs::create_dir_all(parent)
            .map_err(|e| format!("cannot create {}: {e}", parent.display()))?;
    }
    // Write to a temporary name and rename, so a failed build never leaves a half FMU.
    let tmp = out.with_extension("fmu.partial");
    let file =
        std::fs::File::create(&tmp).map_err(|e| format!("cannot create {}: {e}", tmp.display()))?;
    let mut zip = zip::ZipWriter::new(file);
    let options = zip::write::SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Deflated);
    let io = |e: std::io::Error| format!("writing {}: {e}", tmp.display());
    let zerr = |e: zip::result::ZipError| format!("writing {}: {e}", tmp.display());
    zip.start_file("modelDescription.xml", options)
        .map_err(zerr)?;
    zip.write_all(xml.as_bytes()).map_err(io)?;
    let so = format!("binaries/{}/{}.so", platform_folder()?, model_identifier);
    zip.start_file(so, options.unix_permissions(0o755))
        .map_err(zerr)?;
    zip.write_all(&binary).map_err(io)?;
    zip.add_directory("resources/", options).map_err(zerr)?;
    for (name, contents) in resources {
        zip.start_file(format!("resources/{name}"), options)
            .map_err(zerr)?;
        zip.write_all(contents).map_err(io)?;
    }
    zip.finish().map_err(zerr)?;
    std::fs::rename(&tmp, out)
        .map_err(|e| format!("cannot move {} to {}: {e}", tmp.display(), out.display()))
}
