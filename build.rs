//! Forwards the Embree major version found by `embree-sys` as a cfg for `src/accel`.
fn main() {
    // Without this, cargo reruns the script (and rebuilds the crate) whenever any file of
    // the package changes, docs and scripts included.
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo::rustc-check-cfg=cfg(embree3)");
    println!("cargo::rustc-check-cfg=cfg(embree4)");
    match std::env::var("DEP_EMBREE_VERSION").as_deref() {
        Ok("4") => println!("cargo:rustc-cfg=embree4"),
        _ => println!("cargo:rustc-cfg=embree3"),
    }
}
