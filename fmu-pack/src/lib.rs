//! What `fmu-pack` knows about a built FMU library beyond its description: the platform it
//! needs.

use object::elf::{FileHeader64, SHT_GNU_VERNEED};
use object::read::elf::{FileHeader, SectionHeader};
use object::Endianness;

/// The newest `GLIBC_x.y` symbol version an x86-64 ELF shared library imports — so the oldest
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

/// The glibc of the distributions engineers run FMI tools on (their release notes).
const DISTRIBUTIONS: [(&str, (u32, u32)); 7] = [
    ("RHEL/Rocky 8", (2, 28)),
    ("Debian 11", (2, 31)),
    ("Ubuntu 20.04", (2, 31)),
    ("RHEL/Rocky 9", (2, 34)),
    ("Ubuntu 22.04", (2, 35)),
    ("Debian 12", (2, 36)),
    ("Ubuntu 24.04", (2, 39)),
];

/// The README's statement of the platform, for the newest glibc version the libraries need.
pub fn platform_note(glibc: (u32, u32)) -> String {
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
    format!(
        "Every FMU carries one binary, `binaries/linux64` (x86-64 Linux), which needs \
         **glibc ≥ {}.{}**: the newest `GLIBC_` symbol version the three libraries import. It \
         loads on {on}{not_on}. Measured from the built libraries by `make descriptions` \
         (`fmu-pack glibc`); a test fails while this sentence is stale.\n",
        glibc.0, glibc.1
    )
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
    fn glibc_versions_parse_and_order_numerically() {
        assert_eq!(parse_glibc(b"GLIBC_2.34"), Some((2, 34)));
        assert_eq!(parse_glibc(b"GLIBC_2.2.5"), Some((2, 2)));
        assert_eq!(parse_glibc(b"GCC_3.0"), None);
        assert!(Some((2, 34)) > Some((2, 9)));
    }

    #[test]
    fn this_test_binary_needs_a_glibc_and_garbage_is_refused() {
        let me = std::fs::read(std::env::current_exe().unwrap()).unwrap();
        let v = glibc_needed(&me)
            .unwrap()
            .expect("a Linux test binary imports glibc");
        assert!(v >= (2, 2), "{v:?}");
        assert!(glibc_needed(b"not an elf").is_err());
    }

    #[test]
    fn the_note_names_the_distributions_on_each_side() {
        let note = platform_note((2, 34));
        assert!(note.contains("glibc ≥ 2.34"), "{note}");
        assert!(
            note.contains("loads on RHEL/Rocky 9, Ubuntu 22.04"),
            "{note}"
        );
        assert!(
            note.contains("not on RHEL/Rocky 8, Debian 11, Ubuntu 20.04."),
            "{note}"
        );
        assert!(!platform_note((2, 17)).contains("not on"));
    }
}
