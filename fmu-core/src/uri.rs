//! `fmuResourceLocation` → a directory path (FMI 2.0.4 §2.1.6: an RFC 3986 URI).
//!
//! Importers differ: FMPy passes `file:///dir/resources` (no trailing slash), others
//! `file:/dir/resources/`, `file://localhost/dir/resources/`, percent-encode spaces and
//! non-ASCII, or pass NULL when the FMU has no resources. On Windows the path carries a drive
//! (`file:///C:/Users/x/resources`, FMPy and fmusim) or a share (`file://server/share/x`, a UNC
//! path): `windows_path` turns both into a Windows path, and is compiled and tested everywhere.

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

/// A `file:` URI taken apart: the host (`None` for none or `localhost`) and the decoded path,
/// which starts with `/`.
struct FileUri {
    host: Option<String>,
    path: Vec<u8>,
}

fn parse(uri: &str) -> Result<FileUri, UriError> {
    let rest = match uri.get(..5) {
        Some(s) if s.eq_ignore_ascii_case("file:") => &uri[5..],
        _ => return Err(UriError::NotFileScheme(uri.to_string())),
    };
    let (host, path) = if let Some(after) = rest.strip_prefix("//") {
        let slash = after.find('/').unwrap_or(after.len());
        let host = &after[..slash];
        let local = host.is_empty() || host.eq_ignore_ascii_case("localhost");
        ((!local).then(|| host.to_string()), &after[slash..])
    } else {
        (None, rest)
    };
    if !path.starts_with('/') {
        return Err(UriError::NotFileScheme(uri.to_string()));
    }
    let path = percent_decode(path).ok_or_else(|| UriError::BadPercentEncoding(uri.to_string()))?;
    Ok(FileUri { host, path })
}

/// Parse a resource location into this platform's path. POSIX: `file:///p`, `file:/p` and
/// `file://localhost/p` give `/p`, another host is refused. Windows: see `windows_path`.
pub fn resource_path(uri: &str) -> Result<PathBuf, UriError> {
    let parsed = parse(uri)?;
    #[cfg(windows)]
    {
        windows_path(uri, parsed).map(PathBuf::from)
    }
    #[cfg(not(windows))]
    {
        if parsed.host.is_some() {
            return Err(UriError::RemoteHost(uri.to_string()));
        }
        let os: std::ffi::OsString = std::os::unix::ffi::OsStringExt::from_vec(parsed.path);
        Ok(PathBuf::from(os))
    }
}

/// The Windows path of a parsed `file:` URI: `file:///C:/a/b` (and `file:/C:/a/b`,
/// `file://localhost/C:/a/b`, `file:///C|/a/b` of old importers) gives `C:\a\b`; a host gives
/// the UNC path `\\host\a\b`. The decoded bytes must be UTF-8 (RFC 3987), as Windows paths are
/// Unicode. A path with neither a drive nor a host is refused: it has no meaning on Windows.
#[cfg(any(windows, test))]
fn windows_path(uri: &str, parsed: FileUri) -> Result<String, UriError> {
    let path = String::from_utf8(parsed.path)
        .map_err(|_| UriError::BadPercentEncoding(uri.to_string()))?;
    let path = path.replace('/', "\\");
    if let Some(host) = parsed.host {
        return Ok(format!("\\\\{host}{path}"));
    }
    let b = path.as_bytes();
    // `\C:\…`: drop the slash that separates the drive from the (empty) authority.
    if b.len() >= 3 && b[1].is_ascii_alphabetic() && (b[2] == b':' || b[2] == b'|') {
        return Ok(format!("{}:{}", &path[1..2], &path[3..]));
    }
    Err(UriError::NotFileScheme(uri.to_string()))
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
        #[cfg(not(windows))]
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

    fn win(uri: &str) -> Result<String, UriError> {
        windows_path(uri, parse(uri)?)
    }

    #[test]
    fn windows_drive_letters_and_shares_become_windows_paths() {
        for uri in [
            "file:///C:/Users/x/fmu/resources",
            "file:/C:/Users/x/fmu/resources",
            "file://localhost/C:/Users/x/fmu/resources",
            "file:///C|/Users/x/fmu/resources",
        ] {
            assert_eq!(win(uri).unwrap(), r"C:\Users\x\fmu\resources", "{uri}");
        }
        assert_eq!(
            win("file:///d:/my%20fmu/r%C3%A9sources/").unwrap(),
            r"d:\my fmu\résources\"
        );
        assert_eq!(
            win("file://server/share/fmu/resources").unwrap(),
            r"\\server\share\fmu\resources"
        );
    }

    #[test]
    fn windows_refuses_paths_without_a_drive_and_non_utf8_escapes() {
        assert!(matches!(
            win("file:///tmp/fmu/resources"),
            Err(UriError::NotFileScheme(_))
        ));
        assert!(matches!(
            win("file:///C:/%FF"),
            Err(UriError::BadPercentEncoding(_))
        ));
    }
}
