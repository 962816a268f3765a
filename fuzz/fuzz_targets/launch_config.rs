//! `launch` config files (TOML): the property is
//! `LaunchConfig::check_round_trip` (any text is rejected or gives a config
//! that validates or not without panicking, serialises back to TOML and
//! reads back to the same config). Needs the `config` feature (it builds
//! the whole orchestrator): `cargo +nightly fuzz run --features config
//! launch_config`.
#![no_main]

use bycoms_launch::LaunchConfig;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Err(e) = LaunchConfig::check_round_trip(data) {
        panic!("{e}");
    }
});
