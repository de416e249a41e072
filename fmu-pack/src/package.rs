//! Writing a `.fmu` archive (FMI 2.0.4 §2.3, FMI 3.0.2 §2.5): `modelDescription.xml`, one
//! shared library per platform as `binaries/<platform>/<modelIdentifier>.<so|dll>`, and
//! `resources/`. FMI 2.0 and FMI 3.0 name the platform folders differently
//! ([`PLATFORMS`], [`PLATFORMS3`]).

use crate::binary::{read_library, Inspected};
use object::{Architecture, BinaryFormat};
use std::io::Write;
use std::path::Path;

/// An FMI 2.0 platform folder (`binaries/<folder>/`) and what a library in it must be.
#[derive(Debug)]
pub struct Platform {
    pub folder: &'static str,
    pub extension: &'static str,
    pub format: BinaryFormat,
    /// `linux64` takes AArch64 too: FMI 2.0 names no ARM folder, and the FMI 2 importers that
    /// run on ARM Linux look in `linux64` there (FMPy 0.3: `platform` is `linux64` on aarch64;
    /// fmusim's `FMIPlatformBinaryPath` builds `linux` + `64` for FMI 2). So an ARM library goes
    /// in `linux64` of an FMU of its own (`dist/linux-aarch64/`), never beside the x86-64 one.
    pub architectures: &'static [Architecture],
}

pub const PLATFORMS: [Platform; 2] = [
    Platform {
        folder: "linux64",
        extension: "so",
        format: BinaryFormat::Elf,
        architectures: &[Architecture::X86_64, Architecture::Aarch64],
    },
    Platform {
        folder: "win64",
        extension: "dll",
        format: BinaryFormat::Pe,
        architectures: &[Architecture::X86_64],
    },
];

/// FMI 3.0's platform folders (`<arch>-<sys>`, FMI 3.0.2 §2.5.1.4): one architecture each,
/// so an x86-64 and an AArch64 Linux library share one FMU.
pub const PLATFORMS3: [Platform; 3] = [
    Platform {
        folder: "x86_64-linux",
        extension: "so",
        format: BinaryFormat::Elf,
        architectures: &[Architecture::X86_64],
    },
    Platform {
        folder: "aarch64-linux",
        extension: "so",
        format: BinaryFormat::Elf,
        architectures: &[Architecture::Aarch64],
    },
    Platform {
        folder: "x86_64-windows",
        extension: "dll",
        format: BinaryFormat::Pe,
        architectures: &[Architecture::X86_64],
    },
];

/// The platform of a `binaries/` folder name, of either FMI version.
pub fn platform(folder: &str) -> Result<&'static Platform, String> {
    PLATFORMS
        .iter()
        .chain(PLATFORMS3.iter())
        .find(|p| p.folder == folder)
        .ok_or_else(|| {
            let known: Vec<&str> = PLATFORMS
                .iter()
                .chain(PLATFORMS3.iter())
                .map(|p| p.folder)
                .collect();
            format!(
                "no platform folder '{folder}' (known: {})",
                known.join(", ")
            )
        })
}

/// The FMI platform folder of the machine we run on (where a library loaded here belongs), in
/// FMI version `fmi` (2 or 3).
pub fn host_platform(fmi: u8) -> Result<&'static Platform, String> {
    match (fmi, std::env::consts::OS, std::env::consts::ARCH) {
        (2, "linux", "x86_64" | "aarch64") => platform("linux64"),
        (2, "windows", "x86_64") => platform("win64"),
        (3, "linux", "x86_64") => platform("x86_64-linux"),
        (3, "linux", "aarch64") => platform("aarch64-linux"),
        (3, "windows", "x86_64") => platform("x86_64-windows"),
        (fmi, os, arch) => Err(format!("no FMI {fmi}.0 platform folder for {os}/{arch}")),
    }
}

/// One library of the FMU, checked against the folder it goes in.
pub struct Binary {
    pub platform: &'static Platform,
    pub bytes: Vec<u8>,
}

impl Binary {
    /// Read `path` for `folder`: it must be a library of that folder's format and architecture
    /// that exports the 44 FMI 2.0 and the 75 FMI 3.0 functions.
    pub fn read(folder: &str, path: &Path) -> Result<Self, String> {
        let platform = platform(folder)?;
        let (bytes, found) = read_library(path)?;
        if found.format != platform.format || !platform.architectures.contains(&found.architecture)
        {
            return Err(format!(
                "{} is a {} library, not one for binaries/{folder}",
                path.display(),
                found.kind()
            ));
        }
        found.require_exports(path)?;
        Ok(Binary { platform, bytes })
    }
}

/// Write `out` from the `modelDescription.xml` text, the libraries (one per platform folder),
/// resource files (`(path inside resources/, contents)`) and other files at their paths in the
/// archive (FMI 3.0's terminals).
pub fn write_fmu(
    out: &Path,
    xml: &str,
    model_identifier: &str,
    binaries: &[Binary],
    resources: &[(String, Vec<u8>)],
    others: &[(String, Vec<u8>)],
) -> Result<(), String> {
    for (i, b) in binaries.iter().enumerate() {
        if binaries[..i]
            .iter()
            .any(|o| o.platform.folder == b.platform.folder)
        {
            return Err(format!("two libraries for binaries/{}", b.platform.folder));
        }
    }
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
    for b in binaries {
        let name = format!(
            "binaries/{}/{model_identifier}.{}",
            b.platform.folder, b.platform.extension
        );
        zip.start_file(name, options.unix_permissions(0o755))
            .map_err(zerr)?;
        zip.write_all(&b.bytes).map_err(io)?;
    }
    zip.add_directory("resources/", options).map_err(zerr)?;
    for (name, contents) in resources {
        zip.start_file(format!("resources/{name}"), options)
            .map_err(zerr)?;
        zip.write_all(contents).map_err(io)?;
    }
    for (name, contents) in others {
        zip.start_file(name.as_str(), options).map_err(zerr)?;
        zip.write_all(contents).map_err(io)?;
    }
    zip.finish().map_err(zerr)?;
    std::fs::rename(&tmp, out)
        .map_err(|e| format!("cannot move {} to {}: {e}", tmp.display(), out.display()))
}

/// The libraries an `.fmu` carries: `(platform folder, what the library is)` per
/// `binaries/<folder>/<file>`, in archive order.
pub fn fmu_binaries(fmu: &Path) -> Result<Vec<(String, Inspected)>, String> {
    let file =
        std::fs::File::open(fmu).map_err(|e| format!("cannot open {}: {e}", fmu.display()))?;
    let mut zip =
        zip::ZipArchive::new(file).map_err(|e| format!("{} is not an FMU: {e}", fmu.display()))?;
    let mut out = Vec::new();
    for i in 0..zip.len() {
        let mut entry = zip
            .by_index(i)
            .map_err(|e| format!("{}: {e}", fmu.display()))?;
        let name = entry.name().to_string();
        let mut parts = name.split('/');
        let (Some("binaries"), Some(folder), Some(file)) =
            (parts.next(), parts.next(), parts.next())
        else {
            continue;
        };
        if file.is_empty() {
            continue;
        }
        let mut bytes = Vec::new();
        std::io::Read::read_to_end(&mut entry, &mut bytes)
            .map_err(|e| format!("{}: {name}: {e}", fmu.display()))?;
        let lib =
            Inspected::parse(&bytes).map_err(|e| format!("{}: {name}: {e}", fmu.display()))?;
        out.push((folder.to_string(), lib));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn platform_folders_are_the_fmi2_and_fmi3_names() {
        assert_eq!(platform("win64").unwrap().extension, "dll");
        assert!(platform("linux64")
            .unwrap()
            .architectures
            .contains(&Architecture::Aarch64));
        // FMI 3.0 gives ARM a folder of its own.
        assert_eq!(
            platform("aarch64-linux").unwrap().architectures,
            &[Architecture::Aarch64]
        );
        assert_eq!(platform("x86_64-windows").unwrap().format, BinaryFormat::Pe);
        let e = platform("linux32").unwrap_err();
        assert!(
            e.contains("known: linux64, win64, x86_64-linux, aarch64-linux, x86_64-windows"),
            "{e}"
        );
        assert_eq!(host_platform(2).unwrap().folder, "linux64");
        assert!(host_platform(3).unwrap().folder.ends_with("-linux"));
    }

    #[test]
    fn a_library_of_another_platform_or_without_the_exports_is_refused() {
        // This test binary is an x86-64 (or AArch64) ELF executable without fmi2 exports.
        let me = std::env::current_exe().unwrap();
        let e = Binary::read("win64", &me).err().unwrap();
        assert!(e.contains("not one for binaries/win64"), "{e}");
        let e = Binary::read("linux64", &me).err().unwrap();
        assert!(e.contains("does not export"), "{e}");
        let e = Binary::read("linux64", Path::new("/nonexistent.so"))
            .err()
            .unwrap();
        assert!(e.contains("cannot read"), "{e}");
    }
}
