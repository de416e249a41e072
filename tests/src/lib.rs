//! Helpers for the integration tests: locate the FMUs that `make` built into `dist/`.

use std::path::PathBuf;

/// `dist/<name>.fmu`, or a panic that says how to build it.
pub fn dist_fmu(name: &str) -> PathBuf {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..").join("dist").join(format!("{name}.fmu"));
    assert!(path.exists(), "{} not found: run `make` (or `make test`, which builds it first)", path.display());
    path
}
