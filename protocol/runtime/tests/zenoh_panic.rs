//! The zenoh panic hook once a result is decided (`cli::result_decided`):
//! a panic in a zenoh runtime thread is then a warning and the process goes
//! on (before it, the hook ends the process with exit 1, which would end
//! this test binary: the test fails if the hook does not tell them apart).
//! A binary of its own: the hook is the process's.

#[test]
fn a_zenoh_thread_panicking_after_the_result_is_decided_does_not_end_the_process() {
    bycoms_runtime::cli::tune_zenoh_runtime();
    bycoms_runtime::cli::result_decided();
    let panicked = std::thread::Builder::new()
        .name("net-0".into())
        .spawn(|| std::panic::panic_any("called `Option::unwrap()` on a `None` value"))
        .expect("a thread")
        .join();
    assert!(panicked.is_err(), "the thread panicked, and this process goes on");
}
