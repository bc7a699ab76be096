//! The examples reject bad input with a message a user can act on (and exit code
//! 2) instead of panicking. `cargo test` builds the examples before it runs this,
//! next to the test binary; none of these cases opens a window.

use std::path::PathBuf;
use std::process::Command;

fn example(name: &str) -> PathBuf {
    // target/<profile>/deps/<this test> -> target/<profile>/examples/<name>
    let mut p = std::env::current_exe().unwrap();
    p.pop();
    p.pop();
    p.push("examples");
    p.push(name);
    assert!(
        p.exists(),
        "{} is not built (run through `cargo test`)",
        p.display()
    );
    p
}

fn rejects(name: &str, args: &[&str], says: &[&str]) {
    let out = Command::new(example(name)).args(args).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{name} {args:?}: {err}");
    assert!(!err.contains("panicked"), "{name} {args:?} panicked: {err}");
    for s in says {
        assert!(
            err.contains(s),
            "{name} {args:?}: {err:?} does not say {s:?}"
        );
    }
}

#[test]
fn volume_files_that_are_missing_or_malformed() {
    let dir = std::env::temp_dir().join(format!("kdc-ex-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let missing = dir.join("missing.nii");
    rejects(
        "volume",
        &["--file", missing.to_str().unwrap()],
        &["missing.nii"],
    );
    let bad = dir.join("bad.nii");
    std::fs::write(&bad, b"not a nifti file at all").unwrap();
    rejects("volume", &["--file", bad.to_str().unwrap()], &["bad.nii"]);
    let raw = dir.join("scan.raw");
    std::fs::write(&raw, vec![0u8; 100]).unwrap();
    rejects("volume", &["--file", raw.to_str().unwrap()], &["--dims"]);
    rejects(
        "volume",
        &["--file", raw.to_str().unwrap(), "--dims", "8,8,8"],
        &["scan.raw"],
    );
    rejects("volume", &["--phantom", "3"], &["--phantom"]);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn scene_files_that_are_malformed_or_impossible() {
    let dir = std::env::temp_dir().join(format!("kdc-csg-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let syntax = dir.join("syntax.json");
    std::fs::write(
        &syntax,
        "{\n  \"type\": \"sphere\",\n  \"radius\": 1.0,,\n}",
    )
    .unwrap();
    rejects(
        "csg_editor",
        &["--scene", syntax.to_str().unwrap()],
        &["syntax.json", "line 3"],
    );
    let wrong = dir.join("wrong.json");
    std::fs::write(
        &wrong,
        r#"{"type":"union","children":[{"type":"sphere","radius":-1}]}"#,
    )
    .unwrap();
    rejects(
        "csg_editor",
        &["--scene", wrong.to_str().unwrap()],
        &["root.children[0].radius"],
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn settings_out_of_range() {
    rejects("terrain", &["--view-distance=-5"], &["--view-distance"]);
    rejects("terrain", &["--chunk-res", "1000"], &["--chunk-res"]);
    rejects("compare", &["--scene", "nope"], &["nope", "disk_pole"]);
    rejects("compare", &["--res", "0"], &["--res"]);
    rejects("lod", &["--chunks", "0"], &["--chunks"]);
}
