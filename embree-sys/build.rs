//! Finds the system Embree (4 or 3), generates bindings with bindgen and links it.
//!
//! Search order: pkg-config `embree4`, pkg-config `embree3`, then the headers
//! `include/embree4/rtcore.h` / `include/embree3/rtcore.h` under `$EMBREE_DIR` and `/usr`.
//! Emits `cargo:rustc-cfg=embree3|embree4` and the metadata `DEP_EMBREE_VERSION`
//! so that dependent crates can select the matching query API.

use std::env;
use std::path::{Path, PathBuf};

const INSTALL_HINT: &str = "install the Debian packages libembree-dev and libclang-dev \
     (apt-get install -y libembree-dev libclang-dev), or set EMBREE_DIR to an Embree 3/4 prefix";

struct Found {
    major: u32,
    include_dirs: Vec<PathBuf>,
    link_dirs: Vec<PathBuf>,
}

fn from_pkg_config(name: &str, major: u32) -> Option<Found> {
    let lib = pkg_config::Config::new()
        .cargo_metadata(false)
        .probe(name)
        .ok()?;
    Some(Found {
        major,
        include_dirs: lib.include_paths,
        link_dirs: lib.link_paths,
    })
}

fn from_prefix(prefix: &Path) -> Option<Found> {
    for major in [4u32, 3] {
        let header = prefix.join(format!("include/embree{major}/rtcore.h"));
        if header.is_file() {
            let mut link_dirs = vec![];
            for sub in [
                "lib",
                "lib64",
                "lib/x86_64-linux-gnu",
                "lib/aarch64-linux-gnu",
            ] {
                let d = prefix.join(sub);
                if d.is_dir() {
                    link_dirs.push(d);
                }
            }
            return Some(Found {
                major,
                include_dirs: vec![prefix.join("include")],
                link_dirs,
            });
        }
    }
    None
}

fn fail(msg: &str) -> ! {
    // One clear sentence, then stop the build.
    eprintln!("error: {msg}");
    println!("cargo:warning={msg}");
    std::process::exit(1);
}

fn main() {
    println!("cargo:rerun-if-env-changed=EMBREE_DIR");
    println!("cargo:rerun-if-changed=wrapper3.h");
    println!("cargo:rerun-if-changed=wrapper4.h");
    println!("cargo::rustc-check-cfg=cfg(embree3)");
    println!("cargo::rustc-check-cfg=cfg(embree4)");

    let mut found = from_pkg_config("embree4", 4).or_else(|| from_pkg_config("embree3", 3));
    if found.is_none() {
        let mut prefixes = vec![];
        if let Ok(dir) = env::var("EMBREE_DIR") {
            prefixes.push(PathBuf::from(dir));
        }
        prefixes.push(PathBuf::from("/usr"));
        prefixes.push(PathBuf::from("/usr/local"));
        found = prefixes.iter().find_map(|p| from_prefix(p));
    }
    let Some(found) = found else {
        fail(&format!(
            "embree-sys: no Embree 3 or 4 headers were found; {INSTALL_HINT}."
        ));
    };

    for dir in &found.link_dirs {
        println!("cargo:rustc-link-search=native={}", dir.display());
    }
    println!("cargo:rustc-link-lib=dylib=embree{}", found.major);
    println!("cargo:rustc-cfg=embree{}", found.major);
    println!("cargo:version={}", found.major);

    let wrapper = format!("wrapper{}.h", found.major);
    let mut builder = bindgen::Builder::default()
        .header(wrapper)
        .allowlist_function("rtc.*")
        .allowlist_type("RTC.*")
        .allowlist_var("RTC.*")
        .layout_tests(true)
        .derive_default(true)
        .derive_debug(true)
        .prepend_enum_name(false)
        .default_enum_style(bindgen::EnumVariation::Consts)
        .parse_callbacks(Box::new(bindgen::CargoCallbacks::new()));
    for dir in &found.include_dirs {
        builder = builder.clang_arg(format!("-I{}", dir.display()));
    }

    // bindgen panics (inside clang-sys) when libclang cannot be loaded: turn that into
    // the same one-sentence hint as a missing Embree.
    let generated =
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(move || builder.generate()));
    let bindings = match generated {
        Ok(Ok(b)) => b,
        Ok(Err(e)) => fail(&format!(
            "embree-sys: bindgen could not parse the Embree {} headers ({e}); {INSTALL_HINT}.",
            found.major
        )),
        Err(_) => fail(&format!(
            "embree-sys: bindgen could not load libclang; {INSTALL_HINT}."
        )),
    };
    let out = PathBuf::from(env::var("OUT_DIR").unwrap()).join("bindings.rs");
    bindings
        .write_to_file(&out)
        .unwrap_or_else(|e| fail(&format!("embree-sys: cannot write {}: {e}", out.display())));
}
