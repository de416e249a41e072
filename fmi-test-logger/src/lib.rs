//! A recording FMI 2.0 logger for tests. [`LogCapture::callbacks`] gives an
//! `fmi2CallbackFunctions`-compatible struct whose logger is real C (variadic, `vsnprintf`).

use std::ffi::CStr;
use std::os::raw::{c_char, c_int, c_void};
use std::sync::Mutex;

extern "C" {
    /// The C logger; its type is exactly `fmi2CallbackLogger`.
    pub fn fmi_test_logger(
        env: *mut c_void,
        instance: *const c_char,
        status: c_int,
        category: *const c_char,
        format: *const c_char,
        ...
    );
}

/// One logged message.
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    pub instance: String,
    pub status: i32,
    pub category: String,
    pub message: String,
}

/// Collects the messages of every instance that uses its callbacks.
#[derive(Default)]
pub struct LogCapture {
    entries: Mutex<Vec<Entry>>,
}

/// Layout-compatible with `fmi2CallbackFunctions`.
#[repr(C)]
#[derive(Clone, Copy)]
pub struct Callbacks {
    pub logger: Option<
        unsafe extern "C" fn(*mut c_void, *const c_char, c_int, *const c_char, *const c_char, ...),
    >,
    pub allocate_memory: Option<unsafe extern "C" fn(usize, usize) -> *mut c_void>,
    pub free_memory: Option<unsafe extern "C" fn(*mut c_void)>,
    pub step_finished: Option<unsafe extern "C" fn(*mut c_void, c_int)>,
    pub component_environment: *mut c_void,
}

impl LogCapture {
    /// Callbacks whose environment points at `self` (which must outlive the instances).
    pub fn callbacks(&self) -> Callbacks {
        Callbacks {
            logger: Some(fmi_test_logger),
            allocate_memory: Some(calloc_shim),
            free_memory: Some(free_shim),
            step_finished: None,
            component_environment: self as *const LogCapture as *mut c_void,
        }
    }

    pub fn entries(&self) -> Vec<Entry> {
        self.entries.lock().unwrap().clone()
    }

    pub fn messages(&self) -> Vec<String> {
        self.entries().into_iter().map(|e| e.message).collect()
    }

    pub fn clear(&self) {
        self.entries.lock().unwrap().clear();
    }

    /// Does any message contain `needle`?
    pub fn contains(&self, needle: &str) -> bool {
        self.messages().iter().any(|m| m.contains(needle))
    }
}

unsafe extern "C" fn calloc_shim(n: usize, size: usize) -> *mut c_void {
    libc_calloc(n, size)
}

unsafe extern "C" fn free_shim(p: *mut c_void) {
    libc_free(p)
}

extern "C" {
    #[link_name = "calloc"]
    fn libc_calloc(n: usize, size: usize) -> *mut c_void;
    #[link_name = "free"]
    fn libc_free(p: *mut c_void);
}

#[no_mangle]
unsafe extern "C" fn fmi_test_record(
    env: *mut c_void,
    instance: *const c_char,
    status: c_int,
    category: *const c_char,
    message: *const c_char,
) {
    let text = |p: *const c_char| {
        if p.is_null() {
            String::new()
        } else {
            CStr::from_ptr(p).to_string_lossy().into_owned()
        }
    };
    if let Some(capture) = (env as *const LogCapture).as_ref() {
        capture.entries.lock().unwrap().push(Entry {
            instance: text(instance),
            status,
            category: text(category),
            message: text(message),
        });
    }
}

/// A serialised FMU state with one parameter value replaced and the checksum made right again:
/// what a buggy tool or a hand-edited file hands an FMU. `old` must occur exactly once (as
/// little-endian f64 bytes). The checksum (FNV-1a 64 over everything before the last 8 bytes)
/// is written from the format's documentation in `fmu_core::fmu_state`, independently of it.
pub fn forge_state(bytes: &[u8], old: f64, new: f64) -> Vec<u8> {
    let pattern = old.to_le_bytes();
    let body_len = bytes.len() - 8;
    let hits: Vec<usize> = (0..body_len - 7)
        .filter(|&i| bytes[i..i + 8] == pattern)
        .collect();
    assert_eq!(hits.len(), 1, "{old} must occur once in the state");
    let mut forged = bytes.to_vec();
    forged[hits[0]..hits[0] + 8].copy_from_slice(&new.to_le_bytes());
    let sum = forged[..body_len]
        .iter()
        .fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
            (h ^ *b as u64).wrapping_mul(0x0000_0100_0000_01b3)
        });
    forged[body_len..].copy_from_slice(&sum.to_le_bytes());
    forged
}
