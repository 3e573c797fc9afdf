//! Forwards the Embree major version found by `embree-sys` as a cfg for `src/accel`.
fn main() {
    println!("cargo::rustc-check-cfg=cfg(embree3)");
    println!("cargo::rustc-check-cfg=cfg(embree4)");
    match std::env::var("DEP_EMBREE_VERSION").as_deref() {
        Ok("4") => println!("cargo:rustc-cfg=embree4"),
        _ => println!("cargo:rustc-cfg=embree3"),
    }
}
