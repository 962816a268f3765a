//! `launch` config files (TOML): any text either is rejected or gives a
//! config that validates or not without panicking, serialises back to TOML,
//! and reads back to the same config (compared as TOML text, so NaN, which
//! `validate` rejects, does not break equality).
#![no_main]

use bycoms_orchestrator::launch::LaunchConfig;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let Ok(config) = LaunchConfig::parse(text) else { return };
    let valid = config.validate().is_ok();
    let written = toml::to_string(&config).expect("a parsed config serialises");
    let back = LaunchConfig::parse(&written).expect("serialised config parses");
    assert_eq!(toml::to_string(&back).expect("serialises"), written, "TOML round trip is stable");
    if valid {
        assert_eq!(back, config, "a valid config survives the round trip");
        assert!(back.validate().is_ok());
    }
});
