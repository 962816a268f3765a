//! Links with esp-hal's linker script (`linkall.x`, which esp-hal's build
//! script puts on the linker's search path), so that a build needs no
//! `.cargo/config.toml` and works from any directory.
fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rustc-link-arg-bins=-Tlinkall.x");
}
