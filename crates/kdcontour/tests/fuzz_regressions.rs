//! Replays, on stable Rust, every input the fuzz targets in `fuzz/` crashed on
//! (`tests/fuzz_regressions/<target>/`) and their corpus (`fuzz/corpus/<target>/`)
//! through the same entry points ([`kdcontour::io::probe`]): each must load or be
//! refused with a message, never panic.

use kdcontour::io::probe::{self, TARGETS};
use std::path::{Path, PathBuf};

/// The files under `dir/<target>/`, for every target.
fn inputs(dir: &Path) -> Vec<(&'static str, PathBuf)> {
    let mut out = Vec::new();
    for target in TARGETS {
        let Ok(entries) = std::fs::read_dir(dir.join(target)) else {
            continue;
        };
        let mut files: Vec<PathBuf> = entries.filter_map(|e| Some(e.ok()?.path())).collect();
        files.sort();
        out.extend(
            files
                .into_iter()
                .filter(|p| p.is_file())
                .map(|p| (target, p)),
        );
    }
    out
}

/// Runs `target` on the file's bytes as its fuzz target does.
fn replay(target: &str, path: &Path) {
    let data = std::fs::read(path).unwrap();
    if target == "mesh_any" {
        if let Some(r) = probe::mesh_any(&data) {
            assert!(
                r.max_error.is_finite() && r.mean_error.is_finite(),
                "{}: {r:?}",
                path.display()
            );
        }
    } else if let Err(message) = probe::load(target, &data) {
        assert!(
            !message.is_empty(),
            "{}: a refusal must say why",
            path.display()
        );
    }
}

#[test]
fn crashes_the_fuzzers_found_stay_fixed() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz_regressions");
    let found = inputs(&dir);
    assert!(
        !found.is_empty(),
        "no regression inputs under {}",
        dir.display()
    );
    for (target, path) in found {
        replay(target, &path);
    }
}

#[test]
fn the_fuzz_corpus_loads_or_is_refused() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/corpus");
    let found = inputs(&dir);
    // Every target has its seeds in the repository.
    for target in TARGETS {
        assert!(
            found.iter().any(|(t, _)| *t == target),
            "no corpus for {target} under {}",
            dir.display()
        );
    }
    for (target, path) in found {
        replay(target, &path);
    }
}
