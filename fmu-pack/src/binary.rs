//! What a built FMU library is and needs, read from its bytes without loading it (so for every
//! platform on any machine): format, architecture, the fmi2 and fmi3 functions it fails to export, the
//! newest glibc symbol version it imports (ELF) and the DLLs it imports (PE).

use fmu_core::{ffi, ffi3};
use object::elf::{FileHeader64, SHT_GNU_VERNEED};
use object::read::elf::{FileHeader, SectionHeader};
use object::{Architecture, BinaryFormat, Endianness, Object};
use std::path::Path;

pub struct Inspected {
    pub format: BinaryFormat,
    pub architecture: Architecture,
    pub missing_exports: Vec<&'static str>,
    /// ELF: the newest `GLIBC_x.y` it imports, so the oldest glibc that loads it.
    pub glibc: Option<(u32, u32)>,
    /// PE: the DLLs it imports, as named in its import table, sorted case-insensitively.
    pub dlls: Vec<String>,
}

impl Inspected {
    pub fn parse(bytes: &[u8]) -> Result<Self, String> {
        let file = object::File::parse(bytes).map_err(|e| format!("not a library: {e}"))?;
        let exports: Vec<Vec<u8>> = file
            .exports()
            .map_err(|e| format!("unreadable export table: {e}"))?
            .iter()
            .map(|e| e.name().to_vec())
            .collect();
        let missing_exports = ffi::EXPORTED_FUNCTIONS
            .iter()
            .chain(ffi3::EXPORTED_FUNCTIONS.iter())
            .copied()
            .filter(|f| !exports.iter().any(|e| e == f.as_bytes()))
            .collect();
        let (glibc, dlls) = match file.format() {
            BinaryFormat::Elf => (glibc_needed(bytes)?, Vec::new()),
            _ => {
                let mut dlls: Vec<String> = Vec::new();
                for import in file
                    .imports()
                    .map_err(|e| format!("unreadable imports: {e}"))?
                {
                    let dll = String::from_utf8_lossy(import.library()).into_owned();
                    if !dlls.contains(&dll) {
                        dlls.push(dll);
                    }
                }
                // Sorted: the linker's order of the import table varies between builds.
                dlls.sort_by_key(|d| d.to_ascii_lowercase());
                (None, dlls)
            }
        };
        Ok(Inspected {
            format: file.format(),
            architecture: file.architecture(),
            missing_exports,
            glibc,
            dlls,
        })
    }

    /// Refuse the library at `path` (this one) unless it exports all 44 FMI 2.0 functions
    /// (Co-Simulation and Model Exchange) and all 75 of FMI 3.0: every library of this project
    /// carries both, so one build serves an FMU of either version.
    pub fn require_exports(&self, path: &Path) -> Result<(), String> {
        if self.missing_exports.is_empty() {
            Ok(())
        } else {
            Err(format!(
                "{} does not export {:?}",
                path.display(),
                self.missing_exports
            ))
        }
    }

    /// `x86-64 ELF`, `AArch64 ELF`, `x86-64 PE`.
    pub fn kind(&self) -> String {
        let arch = match self.architecture {
            Architecture::X86_64 => "x86-64".to_string(),
            Architecture::Aarch64 => "AArch64".to_string(),
            other => format!("{other:?}"),
        };
        let format = match self.format {
            BinaryFormat::Elf => "ELF".to_string(),
            BinaryFormat::Pe => "PE".to_string(),
            other => format!("{other:?}"),
        };
        format!("{arch} {format}")
    }
}

/// Read and inspect the library at `path`.
pub fn read_library(path: &Path) -> Result<(Vec<u8>, Inspected), String> {
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let found = Inspected::parse(&bytes).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok((bytes, found))
}

/// The newest `GLIBC_x.y` symbol version a 64-bit ELF shared library imports — so the oldest
/// glibc that loads it — or `None` if it imports no versioned glibc symbol.
pub fn glibc_needed(elf: &[u8]) -> Result<Option<(u32, u32)>, String> {
    let bad = |e: object::Error| format!("not a 64-bit ELF library: {e}");
    let header = FileHeader64::<Endianness>::parse(elf).map_err(bad)?;
    let endian = header.endian().map_err(bad)?;
    let sections = header.sections(endian, elf).map_err(bad)?;
    let mut newest = None;
    for section in sections.iter() {
        if section.sh_type(endian) != SHT_GNU_VERNEED {
            continue;
        }
        let Some((mut needs, link)) = section.gnu_verneed(endian, elf).map_err(bad)? else {
            continue;
        };
        let strings = sections.strings(endian, elf, link).map_err(bad)?;
        while let Some((_, mut aux)) = needs.next().map_err(bad)? {
            while let Some(a) = aux.next().map_err(bad)? {
                let name = a.name(endian, strings).map_err(bad)?;
                if let Some(v) = parse_glibc(name) {
                    newest = newest.max(Some(v));
                }
            }
        }
    }
    Ok(newest)
}

/// `GLIBC_2.34` → `(2, 34)`; `GLIBC_2.2.5` → `(2, 2)`; anything else → `None`.
fn parse_glibc(name: &[u8]) -> Option<(u32, u32)> {
    let rest = std::str::from_utf8(name).ok()?.strip_prefix("GLIBC_")?;
    let mut parts = rest.split('.').map(|p| p.parse::<u32>().ok());
    Some((parts.next()??, parts.next()??))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn glibc_versions_parse_and_order_numerically() {
        assert_eq!(parse_glibc(b"GLIBC_2.34"), Some((2, 34)));
        assert_eq!(parse_glibc(b"GLIBC_2.2.5"), Some((2, 2)));
        assert_eq!(parse_glibc(b"GCC_3.0"), None);
        assert!(Some((2, 34)) > Some((2, 9)));
    }

    #[test]
    fn this_test_binary_is_read_and_garbage_is_refused() {
        let me = std::fs::read(std::env::current_exe().unwrap()).unwrap();
        let found = Inspected::parse(&me).unwrap();
        assert_eq!(found.format, BinaryFormat::Elf);
        assert_eq!(
            found.missing_exports.len(),
            ffi::EXPORTED_FUNCTIONS.len() + ffi3::EXPORTED_FUNCTIONS.len()
        );
        let v = found.glibc.expect("a Linux test binary imports glibc");
        assert!(v >= (2, 2), "{v:?}");
        assert!(Inspected::parse(b"not a library").is_err());
        assert!(glibc_needed(b"not an elf").is_err());
    }
}
