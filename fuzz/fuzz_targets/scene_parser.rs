//! Fuzzes the scene loader: any text must give a scene or an error, never a panic.
//!
//! Relative file names resolve against `scenes/`, so inputs derived from the repository's
//! scenes load their OBJ and CSV files. Seed the corpus with them:
//!
//! ```sh
//! mkdir -p fuzz/corpus/scene_parser && cp scenes/*.toml tests/bad_scenes/*.toml fuzz/corpus/scene_parser/
//! RUSTC_BOOTSTRAP=1 cargo fuzz run scene_parser -- -max_total_time=60 -rss_limit_mb=4096
//! ```
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::PathBuf;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../scenes/fuzz.toml");
    if let Err(e) = stokes::scene::Scene::from_str(text, &path) {
        assert!(!e.is_empty());
    }
});
