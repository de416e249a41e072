//! What the FMUs said: their `fmi2CallbackLogger` and `fmi3LogMessageCallback` messages, quoted
//! in the master's errors.
//!
//! The `fmi` crate forwards every logger call of an FMU to the `log` facade: FMI 2.0's with the
//! instance name as target and module path `"logger"`, FMI 3.0's with the category as target
//! and module path `"fmu"` (FMI 3.0's callback names no instance: those messages are kept under
//! [`UNNAMED`]). [`install`] registers a `log::Log` that keeps the
//! recent messages of the calling thread: all FMUs of one run are called from the thread that
//! runs it, so an error in that run can quote its own FMU's explanation (e.g. why a parameter
//! was refused) and parallel runs do not see each other's messages. The logger itself holds no
//! state; the messages live in a bounded thread-local buffer.

use std::cell::RefCell;
use std::collections::VecDeque;

/// Messages kept per thread: enough for the one error being explained.
const KEPT: usize = 32;

thread_local! {
    static MESSAGES: RefCell<VecDeque<(String, String)>> = const { RefCell::new(VecDeque::new()) };
}

/// The instance FMI 3.0 messages are kept under: its logger does not say whose they are.
pub const UNNAMED: &str = "";

struct FmuLog;

impl log::Log for FmuLog {
    fn enabled(&self, _: &log::Metadata) -> bool {
        true
    }

    fn log(&self, record: &log::Record) {
        let instance = match record.module_path() {
            Some("logger") => record.target(),
            Some("fmu") => UNNAMED,
            _ => return,
        };
        MESSAGES.with_borrow_mut(|m| {
            if m.len() == KEPT {
                m.pop_front();
            }
            m.push_back((instance.to_string(), record.args().to_string()));
        });
    }

    fn flush(&self) {}
}

/// Register the logger (once per process; later calls, and a process whose logger is already
/// set by someone else, change nothing).
pub fn install() {
    static LOGGER: FmuLog = FmuLog;
    if log::set_logger(&LOGGER).is_ok() {
        log::set_max_level(log::LevelFilter::Trace);
    }
}

/// Forget this thread's messages (a run starts).
pub fn clear() {
    MESSAGES.with_borrow_mut(|m| m.clear());
}

/// This thread's messages from instance `instance` since the last [`clear`] or [`said`] call
/// for it, oldest first, joined by "; "; `None` when it said nothing.
pub fn said(instance: &str) -> Option<String> {
    MESSAGES.with_borrow_mut(|m| {
        let (mine, others): (Vec<_>, Vec<_>) = m.drain(..).partition(|(i, _)| i == instance);
        m.extend(others);
        (!mine.is_empty()).then(|| {
            mine.into_iter()
                .map(|(_, message)| message)
                .collect::<Vec<_>>()
                .join("; ")
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn emit(instance: &str, message: &str) {
        log::logger().log(
            &log::Record::builder()
                .args(format_args!("{message}"))
                .level(log::Level::Error)
                .module_path(Some("logger"))
                .target(instance)
                .build(),
        );
    }

    #[test]
    fn messages_are_kept_per_instance_and_thread_and_taken_once() {
        install();
        clear();
        emit("plant", "m_s must be positive");
        emit("road", "speed must be positive");
        emit("plant", "second");
        log::error!(target: "plant", "not an FMU's message: the crate's own");
        assert_eq!(
            said("plant").as_deref(),
            Some("m_s must be positive; second")
        );
        assert_eq!(said("plant"), None);
        std::thread::spawn(|| assert_eq!(said("road"), None))
            .join()
            .unwrap();
        assert_eq!(said("road").as_deref(), Some("speed must be positive"));
        for k in 0..2 * KEPT {
            emit("plant", &k.to_string());
        }
        let kept = said("plant").unwrap();
        assert!(kept.starts_with(&KEPT.to_string()) && kept.ends_with(&(2 * KEPT - 1).to_string()));
    }
}
