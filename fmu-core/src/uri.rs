//! `fmuResourceLocation` → a directory path (FMI 2.0.4 §2.1.6: an RFC 3986 URI).
//!
//! Importers differ: FMPy passes `file:///dir/resources` (no trailing slash), others
//! `file:/dir/resources/`, `file://localhost/dir/resources/`, percent-encode spaces and
//! non-ASCII, or pass NULL when the FMU has no resources.

use std::path::PathBuf;

/// Why a resource location was rejected.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum UriError {
    NotFileScheme(String),
    RemoteHost(String),
    BadPercentEncoding(String),
}

impl std::fmt::Display for UriError {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        match self {
            UriError::NotFileScheme(u) => write!(f, "resource location '{u}' is not a file: URI"),
            UriError::RemoteHost(u) => write!(
                f,
                "resource location '{u}' names a remote host; only local files are supported"
            ),
            UriError::BadPercentEncoding(u) => {
                write!(f, "resource location '{u}' has an invalid percent-encoding")
            }
        }
    }
}

/// Parse a resource location. `file:///p`, `file:/p` and `file://localhost/p` give `/p`.
pub fn resource_path(uri: &str) -> Result<PathBuf, UriError> {
    let rest = match uri.get(..5) {
        Some(s) if s.eq_ignore_ascii_case("file:") => &uri[5..],
        _ => return Err(UriError::NotFileScheme(uri.to_string())),
    };
    let path = if let Some(after) = rest.strip_prefix("//") {
        // Authority present: empty or "localhost".
        let slash = after.find('/').unwrap_or(after.len());
        let host = &after[..slash];
        if !(host.is_empty() || host.eq_ignore_ascii_case("localhost")) {
            return Err(UriError::RemoteHost(uri.to_string()));
        }
        &after[slash..]
    } else {
        rest
    };
    if !path.starts_with('/') {
        return Err(UriError::NotFileScheme(uri.to_string()));
    }
    let decoded =
        percent_decode(path).ok_or_else(|| UriError::BadPercentEncoding(uri.to_string()))?;
    let os: std::ffi::OsString = std::os::unix::ffi::OsStringExt::from_vec(decoded);
    Ok(PathBuf::from(os))
}

/// Decode `%XX` escapes. Written here rather than taken from a crate: it is ten lines and the
/// only URI feature we need.
fn percent_decode(s: &str) -> Option<Vec<u8>> {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = std::str::from_utf8(bytes.get(i + 1..i + 3)?).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn accepts_the_three_local_forms_with_and_without_trailing_slash() {
        for uri in [
            "file:///tmp/fmu/resources",
            "file:/tmp/fmu/resources",
            "file://localhost/tmp/fmu/resources",
            "FILE:///tmp/fmu/resources",
        ] {
            assert_eq!(
                resource_path(uri).unwrap(),
                PathBuf::from("/tmp/fmu/resources"),
                "{uri}"
            );
        }
        assert_eq!(
            resource_path("file:///tmp/fmu/resources/").unwrap(),
            PathBuf::from("/tmp/fmu/resources/")
        );
    }

    #[test]
    fn decodes_percent_escapes_including_utf8() {
        assert_eq!(
            resource_path("file:///tmp/my%20fmu/r%C3%A9sources").unwrap(),
            PathBuf::from("/tmp/my fmu/résources")
        );
    }

    #[test]
    fn rejects_other_schemes_hosts_and_bad_escapes() {
        assert!(matches!(
            resource_path("http://x/res"),
            Err(UriError::NotFileScheme(_))
        ));
        assert!(matches!(
            resource_path("/tmp/res"),
            Err(UriError::NotFileScheme(_))
        ));
        assert!(matches!(
            resource_path("file:relative/res"),
            Err(UriError::NotFileScheme(_))
        ));
        assert!(matches!(
            resource_path("file://server/share"),
            Err(UriError::RemoteHost(_))
        ));
        assert!(matches!(
            resource_path("file:///tmp/%zz"),
            Err(UriError::BadPercentEncoding(_))
        ));
        assert!(matches!(
            resource_path("file:///tmp/%2"),
            Err(UriError::BadPercentEncoding(_))
        ));
    }
}
