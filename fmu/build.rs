//! The shared library an FMU carries is linked without its symbol table (`--strip-all`): an
//! importer resolves the FMI functions through the dynamic symbol table, which stays; the
//! static one only names the library's internal functions, for a debugger.

fn main() {
    let os = std::env::var("CARGO_CFG_TARGET_OS").unwrap_or_default();
    if os == "linux" {
        println!("cargo:rustc-cdylib-link-arg=-Wl,--strip-all");
    }
    println!("cargo:rerun-if-changed=build.rs");
}
