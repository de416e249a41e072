//! OpenBLAS's thread count is global to the process: this test sets it, so it runs alone in a
//! binary of its own rather than beside the unit tests whose decompositions would then use it.

extern "C" {
    fn openblas_set_num_threads(n: std::os::raw::c_int);
    fn openblas_get_num_threads() -> std::os::raw::c_int;
}

/// A synthesis sets OpenBLAS to one thread before anything else it does, even one refused at
/// once (an unknown variant): the certificates' decompositions come before any SDP.
#[test]
fn a_synthesis_runs_blas_on_one_thread() {
    // SAFETY: OpenBLAS's plain setter and getter of its global thread count.
    unsafe { openblas_set_num_threads(2) };
    let file =
        synth::shipping::registry::DesignFile::from_json(include_str!("../designs/comfort.json"))
            .unwrap();
    let refused = synth::shipping::registry::synthesise_all(
        &["no_such_variant"],
        &vehicle::VehicleParams::default(),
        &file,
    );
    assert!(refused.is_err());
    // SAFETY: as above.
    assert_eq!(unsafe { openblas_get_num_threads() }, 1);
}
