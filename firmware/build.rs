//! Link setup for the Cortex-M4F build only: `memory.x` (at the workspace root) and an empty
//! `device.x` on the linker search path, cortex-m-rt's `link.x` and defmt's `defmt.x` for the
//! binaries. The host stub links normally.

use std::env;
use std::path::PathBuf;

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    if env::var("CARGO_CFG_TARGET_OS").as_deref() != Ok("none") {
        return;
    }
    let manifest =
        PathBuf::from(env::var("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"));
    let root = manifest
        .parent()
        .expect("firmware/ sits in the workspace root");
    println!("cargo:rerun-if-changed={}", root.join("memory.x").display());
    println!("cargo:rustc-link-search={}", root.display());
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    // defmt's interned-string sections; the firmware binary always logs with defmt.
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
    // The board image's vector table and `device.x` come from embassy-stm32 (stm32-metapac).
    if env::var_os("CARGO_FEATURE_HARDWARE").is_some() {
        return;
    }
    // cortex-m-rt's `device` feature includes `device.x` (the device crate's weak handler
    // names); our vector table (src/vectors.rs) names `DefaultHandler` itself, so it is empty.
    let out = PathBuf::from(env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    std::fs::write(
        out.join("device.x"),
        "/* STM32F405 vectors: firmware/src/vectors.rs */\n",
    )
    .expect("OUT_DIR is writable");
    println!("cargo:rustc-link-search={}", out.display());
}
