//! The README states the glibc the built libraries need (those `make` packs into `dist/`).

use std::path::Path;

#[test]
fn readme_states_the_glibc_the_libraries_need() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut newest = None;
    for lib in ["plant", "road", "controller"] {
        let path = root.join(format!("target/release/libfmu_{lib}.so"));
        let bytes = std::fs::read(&path)
            .unwrap_or_else(|e| panic!("{}: {e} (`make fmus` builds it)", path.display()));
        newest = newest.max(fmu_pack::glibc_needed(&bytes).unwrap());
    }
    let note = fmu_pack::platform_note(newest.expect("the libraries import glibc"));
    let readme = std::fs::read_to_string(root.join("README.md")).unwrap();
    assert!(
        readme.contains(&format!(
            "<!-- platform:begin -->\n{note}<!-- platform:end -->"
        )),
        "README.md states another platform than the built libraries need: run `make descriptions`"
    );
}
