//! Logging through the importer's `fmi2CallbackLogger` or `fmi3LogMessageCallback`, honouring
//! `loggingOn` and the log categories (FMI 2.0.4 §2.1.5, FMI 3.0.2 §2.3.1). FMI 2.0's message is
//! always passed as the argument of a `"%s"` format, so a `%` in a message can never be
//! interpreted by the importer's `printf`; FMI 3.0's callback takes the text itself.

use crate::types::{fmi3, CallbackFunctions, LoggerFn, Status};
use std::ffi::CString;

/// The log categories every FMU of this project declares in its `modelDescription.xml`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Category {
    /// Calls that return `fmi2Error` or `fmi2Fatal`, with the reason. On by default, even
    /// with `loggingOn = false`, so that an importer always learns why a call failed.
    StatusError,
    /// Calls that return `fmi2Warning`.
    StatusWarning,
    /// Calls that return `fmi2Discard` (a step not taken), with the reason. On by default
    /// like errors: the importer must learn why its step was refused.
    StatusDiscard,
    /// Noteworthy events: instantiation, initialisation, step-size changes, FMU state use.
    Events,
    /// The standard's recommended name for every category (FMI 2.0.4 §2.2.4): switching it on
    /// switches on all of them. Nothing is logged under it.
    All,
}

impl Category {
    pub const ALL: [Category; 5] = [
        Category::StatusError,
        Category::StatusWarning,
        Category::StatusDiscard,
        Category::Events,
        Category::All,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Category::StatusError => "logStatusError",
            Category::StatusWarning => "logStatusWarning",
            Category::StatusDiscard => "logStatusDiscard",
            Category::Events => "logEvents",
            Category::All => "logAll",
        }
    }

    pub fn description(self) -> &'static str {
        match self {
            Category::StatusError => {
                "Why a call returned fmi2Error (always logged, whatever loggingOn and the categories)"
            }
            Category::StatusWarning => "Why a call returned fmi2Warning",
            Category::StatusDiscard => {
                "Why a call returned fmi2Discard (always logged, whatever loggingOn and the categories)"
            }
            Category::Events => {
                "Instantiation, initialisation, FMU state save/restore and other events"
            }
            Category::All => "Every category above",
        }
    }

    fn index(self) -> usize {
        self as usize
    }

    pub fn from_name(name: &str) -> Option<Category> {
        Category::ALL.into_iter().find(|c| c.name() == name)
    }
}

/// Where an instance's messages go: the importer's callback of its FMI version, with the
/// environment pointer it gave us.
#[derive(Clone, Copy)]
enum Sink {
    None,
    Fmi2(LoggerFn, *mut std::os::raw::c_void),
    Fmi3(fmi3::LogMessage, fmi3::InstanceEnvironment),
}

/// One instance's logger. Owns a copy of the instance name.
pub struct Logger {
    sink: Sink,
    instance_name: CString,
    logging_on: bool,
    enabled: [bool; Category::ALL.len()],
}

// The environment pointer is the importer's opaque token; FMI lets an instance be used from
// any thread (one at a time), so the logger moves with its instance.
unsafe impl Send for Logger {}

impl Logger {
    pub fn new(callbacks: &CallbackFunctions, instance_name: &str, logging_on: bool) -> Self {
        Logger {
            sink: match callbacks.logger {
                Some(f) => Sink::Fmi2(f, callbacks.component_environment),
                None => Sink::None,
            },
            instance_name: to_cstring(instance_name),
            logging_on,
            enabled: [true; Category::ALL.len()],
        }
    }

    /// An FMI 3.0 instance's logger (`logMessage` may be NULL: nothing is logged).
    pub fn fmi3(
        callback: Option<fmi3::LogMessage>,
        environment: fmi3::InstanceEnvironment,
        instance_name: &str,
        logging_on: bool,
    ) -> Self {
        Logger {
            sink: match callback {
                Some(f) => Sink::Fmi3(f, environment),
                None => Sink::None,
            },
            instance_name: to_cstring(instance_name),
            logging_on,
            enabled: [true; Category::ALL.len()],
        }
    }

    /// A logger that drops everything (for models used outside an FMU, e.g. in tests).
    pub fn silent() -> Self {
        Logger {
            sink: Sink::None,
            instance_name: CString::default(),
            logging_on: false,
            enabled: [false; Category::ALL.len()],
        }
    }

    /// `fmi2SetDebugLogging`: no categories, or `logAll`, means all of them.
    pub fn configure(&mut self, logging_on: bool, categories: &[&str]) -> Result<(), String> {
        let mut enabled = [categories.is_empty(); Category::ALL.len()];
        for name in categories {
            let c = Category::from_name(name).ok_or_else(|| {
                let known: Vec<_> = Category::ALL.iter().map(|c| c.name()).collect();
                format!("unknown log category '{name}', expected one of {known:?}")
            })?;
            if c == Category::All {
                enabled = [true; Category::ALL.len()];
            }
            enabled[c.index()] = true;
        }
        self.logging_on = logging_on;
        self.enabled = enabled;
        Ok(())
    }

    /// Errors, discards and warnings always: an importer must learn why a call failed, a step
    /// was refused or a call returned `fmi2Warning` (whose meaning in FMI 2.0 is that the
    /// logger has been called), whatever it switched off.
    pub fn is_enabled(&self, category: Category) -> bool {
        match category {
            Category::StatusError | Category::StatusDiscard | Category::StatusWarning => true,
            _ => self.enabled[category.index()] && self.logging_on,
        }
    }

    pub fn log(&self, status: Status, category: Category, message: &str) {
        if !self.is_enabled(category) {
            return;
        }
        let category_c = to_cstring(category.name());
        match self.sink {
            Sink::None => {}
            Sink::Fmi2(callback, environment) => {
                // FMI 2.0.4 §2.1.5: in a logged message `#` starts a value-reference escape
                // (`#r12#`), and `##` is a literal `#`. Our messages name variables, never
                // escape them, so every `#` (a URI's fragment, a user's instance name) is
                // literal.
                let message_c = to_cstring(&message.replace('#', "##"));
                // SAFETY: the importer gave us this callback for exactly this signature; every
                // pointer is a valid NUL-terminated string for the duration of the call.
                unsafe {
                    callback(
                        environment,
                        self.instance_name.as_ptr(),
                        status as i32,
                        category_c.as_ptr(),
                        c"%s".as_ptr(),
                        message_c.as_ptr(),
                    );
                }
            }
            Sink::Fmi3(callback, environment) => {
                // FMI 3.0 has no escapes in a message: the text goes as it is.
                let message_c = to_cstring(message);
                // SAFETY: as above, for `fmi3LogMessageCallback`.
                unsafe {
                    callback(
                        environment,
                        status as i32,
                        category_c.as_ptr(),
                        message_c.as_ptr(),
                    );
                }
            }
        }
    }

    pub fn error(&self, message: &str) {
        self.log(Status::Error, Category::StatusError, message);
    }

    pub fn event(&self, message: &str) {
        self.log(Status::Ok, Category::Events, message);
    }

    pub fn instance_name(&self) -> &str {
        self.instance_name.to_str().unwrap_or("")
    }
}

/// A C string from any Rust string: interior NULs (which C cannot carry) become spaces.
pub fn to_cstring(s: &str) -> CString {
    CString::new(s.replace('\0', " ")).expect("interior NULs were replaced")
}
