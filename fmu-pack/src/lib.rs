//! `fmu-pack`'s library: the FMU archive ([`package`]), what a built library is and needs
//! ([`binary`]), the README's platform table, and markdown sections for splicing.

pub mod binary;
pub mod package;

use binary::Inspected;
use object::BinaryFormat;

/// The glibc of the distributions engineers run FMI tools on (their release notes).
const DISTRIBUTIONS: [(&str, (u32, u32)); 9] = [
    ("RHEL/CentOS 7", (2, 17)),
    ("Ubuntu 18.04", (2, 27)),
    ("RHEL/Rocky 8", (2, 28)),
    ("Debian 11", (2, 31)),
    ("Ubuntu 20.04", (2, 31)),
    ("RHEL/Rocky 9", (2, 34)),
    ("Ubuntu 22.04", (2, 35)),
    ("Debian 12", (2, 36)),
    ("Ubuntu 24.04", (2, 39)),
];

/// Where a library of `glibc` loads: `glibc ≥ 2.17: loads on …; not on …`.
fn glibc_note(glibc: (u32, u32)) -> String {
    let names = |ok: bool| {
        DISTRIBUTIONS
            .iter()
            .filter(|(_, v)| (*v >= glibc) == ok)
            .map(|(n, _)| *n)
            .collect::<Vec<_>>()
            .join(", ")
    };
    let (on, not_on) = (names(true), names(false));
    let not_on = if not_on.is_empty() {
        String::new()
    } else {
        format!("; not on {not_on}")
    };
    format!("glibc ≥ {}.{}: loads on {on}{not_on}", glibc.0, glibc.1)
}

/// What one library needs of the machine that loads it.
fn runs_on(lib: &Inspected) -> String {
    match lib.format {
        BinaryFormat::Elf => match lib.glibc {
            Some(v) => format!("Linux with {}", glibc_note(v)),
            None => "Linux (imports no versioned glibc symbol)".into(),
        },
        BinaryFormat::Pe => format!(
            "Windows 10 or later (the minimum of Rust's standard library); imports only {}",
            lib.dlls.join(", ")
        ),
        other => format!("{other:?}"),
    }
}

/// The README's table of platforms: one row per library of each FMU (`(path, [(folder,
/// library)])`), the FMU standing for every `.fmu` of its folder.
pub fn platform_note(fmus: &[(String, Vec<(String, Inspected)>)]) -> String {
    let mut out = String::from(
        "| FMUs | `binaries/` folder | in `dist/fmi3/*.fmu` | library | runs on |\n\
         |---|---|---|---|---|\n",
    );
    for (path, libs) in fmus {
        let dir = std::path::Path::new(path)
            .parent()
            .map(|d| d.display().to_string())
            .unwrap_or_default();
        for (folder, lib) in libs {
            // The FMI 3.0 folder of a library of this format and architecture.
            let fmi3 = package::PLATFORMS3
                .iter()
                .find(|p| p.format == lib.format && p.architectures.contains(&lib.architecture))
                .map_or("none".to_string(), |p| format!("`{}`", p.folder));
            out += &format!(
                "| `{dir}/*.fmu` | `{folder}` | {fmi3} | {} | {} |\n",
                lib.kind(),
                runs_on(lib)
            );
        }
    }
    out += "\nRead from the packed libraries by `make descriptions` (`fmu-pack platforms`); a \
            test fails while this table is stale. Each FMI 3.0 archive of `dist/fmi3/` carries \
            the same libraries, byte for byte (a test checks), all three in one archive under \
            FMI 3.0's folder names.\n";
    out
}

/// The body of the markdown section headed by the line `heading` (e.g. `## Summary`): the
/// lines after it up to the next heading of the same or a higher level, blank lines at either
/// end trimmed, ending in one newline. `None` if no line equals `heading`.
pub fn markdown_section(text: &str, heading: &str) -> Option<String> {
    let level = heading.chars().take_while(|c| *c == '#').count();
    let mut lines = text
        .lines()
        .skip_while(|l| l.trim_end() != heading.trim_end());
    lines.next()?;
    let body: Vec<&str> = lines
        .take_while(|l| {
            let hashes = l.chars().take_while(|c| *c == '#').count();
            !(hashes > 0 && hashes <= level && l[hashes..].starts_with(' '))
        })
        .collect();
    let start = body.iter().position(|l| !l.trim().is_empty())?;
    let end = body.iter().rposition(|l| !l.trim().is_empty())? + 1;
    Some(body[start..end].join("\n") + "\n")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_markdown_section_ends_at_the_next_heading_of_its_level() {
        let doc = "# T\n\n## Summary\n\n| a |\n|---|\n\n### Detail\nx\n\n## Next\ny\n";
        assert_eq!(
            markdown_section(doc, "## Summary").unwrap(),
            "| a |\n|---|\n\n### Detail\nx\n"
        );
        assert_eq!(markdown_section(doc, "## Next").unwrap(), "y\n");
        assert_eq!(markdown_section(doc, "## Missing"), None);
        assert_eq!(markdown_section("## Empty\n\n## Next\n", "## Empty"), None);
    }

    #[test]
    fn the_glibc_note_names_the_distributions_on_each_side() {
        let note = glibc_note((2, 34));
        assert!(
            note.starts_with("glibc ≥ 2.34: loads on RHEL/Rocky 9, Ubuntu 22.04"),
            "{note}"
        );
        assert!(
            note.contains("not on RHEL/CentOS 7, Ubuntu 18.04, RHEL/Rocky 8"),
            "{note}"
        );
        assert!(!glibc_note((2, 17)).contains("not on"));
    }
}
