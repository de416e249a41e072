//! What the plant's FMI tests share: an instance of the plant through its C functions.

use fmi_test_logger::{Callbacks, LogCapture};
use fmu_core::types::*;
use std::ffi::CString;
use std::ptr::null;

/// A plant instance of `kind` (`FMI2_CO_SIMULATION` or `FMI2_MODEL_EXCHANGE`) logging into
/// `log`, with its description and the callbacks it keeps a pointer to.
pub fn instantiate(
    log: &LogCapture,
    kind: Fmi2Type,
) -> (Fmi2Component, fmu_core::ModelDescription, Box<Callbacks>) {
    let desc = fmu_plant::Plant::model_description();
    let cb = Box::new(log.callbacks());
    let name = CString::new("plant").unwrap();
    let guid = CString::new(desc.guid.clone()).unwrap();
    let c = unsafe {
        fmu_plant::fmi2Instantiate(
            name.as_ptr(),
            kind,
            guid.as_ptr(),
            null(),
            &*cb as *const _ as *const CallbackFunctions,
            0,
            0,
        )
    };
    assert!(!c.is_null(), "{:?}", log.messages());
    (c, desc, cb)
}
