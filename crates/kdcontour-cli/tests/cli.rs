//! The `kdcontour` command as a user runs it.

use std::process::Command;

fn kdcontour(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_kdcontour"))
        .args(args)
        .current_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
        .output()
        .expect("runs");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn json_is_exactly_one_line_with_every_key() {
    let (code, out, err) = kdcontour(&[
        "mesh",
        "--scene",
        "torus",
        "--res",
        "24",
        "--threshold",
        "0.01",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(out.lines().count(), 1, "{out}");
    let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    for key in [
        "mesher",
        "scene",
        "res",
        "threshold",
        "triangles",
        "vertices",
        "sample_ms",
        "build_ms",
        "contour_ms",
        "total_ms",
        "watertight",
        "manifold",
        "euler",
        "max_error",
        "mean_error",
    ] {
        assert!(v.get(key).is_some(), "missing {key}: {out}");
    }
    assert_eq!(v["mesher"], "kdtree");
    assert_eq!(v["scene"], "torus");
    assert_eq!(v["watertight"], true);
    assert_eq!(v["manifold"], true);
    assert_eq!(v["euler"], 0);
    assert!(v["triangles"].as_u64().unwrap() > 100);
}

#[test]
fn negative_threshold_and_thread_count() {
    let (code, out, err) = kdcontour(&[
        "mesh",
        "--scene",
        "sphere",
        "--res",
        "16",
        "--threshold",
        "-1",
        "--threads",
        "2",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    assert_eq!(v["threshold"], -1.0);
}

#[test]
fn scene_file_to_obj_and_ply() {
    let dir = std::env::temp_dir().join(format!("kdcontour-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for ext in ["obj", "ply"] {
        let path = dir.join(format!("example.{ext}"));
        let (code, out, err) = kdcontour(&[
            "mesh",
            "--scene-file",
            "scenes/example.json",
            "--res",
            "32",
            "--out",
            path.to_str().unwrap(),
        ]);
        assert_eq!(code, 0, "{err}");
        assert!(out.contains("watertight true, manifold true"), "{out}");
        let bytes = std::fs::read(&path).unwrap();
        match ext {
            "obj" => assert!(bytes.starts_with(b"# kdcontour")),
            _ => assert!(bytes.starts_with(b"ply\nformat binary_little_endian 1.0")),
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn errors_exit_2_with_a_message() {
    let dir = std::env::temp_dir().join(format!("kdcontour-cli-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.json");
    std::fs::write(&bad, "{\n  \"type\": \"sphere\",\n  \"radius\": -0.5\n}\n").unwrap();
    let (code, _, err) = kdcontour(&["mesh", "--scene-file", bad.to_str().unwrap()]);
    assert_eq!(code, 2);
    assert!(err.contains("root.radius") && err.contains("> 0"), "{err}");

    std::fs::write(&bad, "{\n  \"type\": \"sphere\",\n  \"radius\": 0.5,,\n}\n").unwrap();
    let (code, _, err) = kdcontour(&["mesh", "--scene-file", bad.to_str().unwrap()]);
    assert_eq!(code, 2);
    assert!(err.contains("line 3"), "{err}");

    let (code, _, err) = kdcontour(&["mesh", "--scene-file", "/nonexistent/scene.json"]);
    assert_eq!(code, 2);
    assert!(err.contains("/nonexistent/scene.json"), "{err}");

    let (code, _, err) = kdcontour(&["mesh", "--scene", "teapot"]);
    assert_eq!(code, 2);
    assert!(err.contains("disk_pole"), "{err}");

    let (code, _, err) = kdcontour(&["mesh", "--scene", "sphere", "--res", "0"]);
    assert_eq!(code, 2);
    assert!(err.contains("res must be >= 1"), "{err}");

    let (code, _, err) = kdcontour(&["mesh", "--scene", "sphere", "--res", "16", "--out", "x.stl"]);
    assert_eq!(code, 2);
    assert!(err.contains(".obj or .ply"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn scenes_lists_every_builtin() {
    let (code, out, _) = kdcontour(&["scenes"]);
    assert_eq!(code, 0);
    for name in kdcontour::scenes::SCENES {
        assert!(out.contains(name), "{out}");
    }
}
