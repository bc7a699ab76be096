//! The `kdcontour` command as a user runs it.

mod common;

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
        "zero_area_triangles",
        "coincident_vertices",
        "sliver_triangles",
        "flipped_triangles",
        "crossing_pairs",
        "crossing_triangles",
        "crossing_depth",
        "overlapping_pairs",
        "overlapping_triangles",
        "mesh_to_surface_max",
        "mesh_to_surface_mean",
        "surface_to_mesh_max",
        "surface_to_mesh_mean",
        "surface_points",
        "lost_surface",
        "surface_refined",
        "fold_bucket_degrees",
        "fold_histogram",
        "fold_max_degrees",
        "fold_mean_degrees",
        "folded_triangles",
        "folded_share",
        "folds_near_creases",
        "fold_no_gradient",
    ] {
        assert!(v.get(key).is_some(), "missing {key}: {out}");
    }
    // Every check ran: the torus has no defect and loses nothing.
    assert_eq!(v["crossing_pairs"], 0);
    assert_eq!(v["flipped_triangles"], 0);
    assert_eq!(v["folded_triangles"], 0);
    let histogram = v["fold_histogram"].as_array().unwrap();
    let sum: u64 = histogram.iter().map(|n| n.as_u64().unwrap()).sum();
    assert_eq!(sum, v["triangles"].as_u64().unwrap());
    assert_eq!(v["lost_surface"], 0.0);
    assert!(v["surface_points"].as_u64().unwrap() > 100);
    assert_eq!(v["mesher"], "kdtree");
    assert_eq!(v["scene"], "torus");
    assert_eq!(v["watertight"], true);
    assert_eq!(v["manifold"], true);
    assert_eq!(v["euler"], 0);
    assert!(v["triangles"].as_u64().unwrap() > 100);
}

#[test]
fn quick_checks_skip_the_costly_ones() {
    let (code, out, err) = kdcontour(&[
        "mesh",
        "--scene",
        "torus",
        "--res",
        "16",
        "--quick-checks",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    assert!(
        v["crossing_pairs"].is_null() && v["lost_surface"].is_null(),
        "{out}"
    );
    assert_eq!(v["flipped_triangles"], 0);
}

#[test]
fn checks_default_to_the_grids_and_full_adds_the_finer_lattices() {
    let run = |checks: Option<&str>| {
        let mut args = vec!["mesh", "--scene", "csg_mix", "--res", "24", "--json"];
        if let Some(c) = checks {
            args.extend(["--checks", c]);
        }
        let (code, out, err) = kdcontour(&args);
        assert_eq!(code, 0, "{err}");
        serde_json::from_str::<serde_json::Value>(out.trim()).unwrap()
    };
    let (standard, full, explicit) = (run(None), run(Some("full")), run(Some("standard")));
    assert_eq!(standard["surface_refined"], false);
    assert_eq!(explicit["surface_refined"], false);
    assert_eq!(full["surface_refined"], true);
    // The same mesh, the same crossings counted; the finer lattices can only
    // find surface farther from the mesh.
    assert_eq!(standard["triangles"], full["triangles"]);
    assert_eq!(standard["surface_points"], full["surface_points"]);
    assert_eq!(standard["crossing_pairs"], full["crossing_pairs"]);
    let max = |v: &serde_json::Value| v["surface_to_mesh_max"].as_f64().unwrap();
    assert!(max(&full) >= max(&standard), "{full} {standard}");
    // The summary says what was sampled, and how to sample more.
    let (code, out, _) = kdcontour(&["mesh", "--scene", "torus", "--res", "16"]);
    assert_eq!(code, 0);
    assert!(out.contains("--checks full adds finer lattices"), "{out}");
    // Anything else is refused with the choices.
    let (code, _, err) = kdcontour(&["mesh", "--scene", "torus", "--checks", "most"]);
    assert_eq!(code, 2);
    assert!(
        err.contains("quick") && err.contains("standard") && err.contains("full"),
        "{err}"
    );
}

#[test]
fn mesh_exports_every_mesher() {
    let dir = std::env::temp_dir().join(format!("kdcontour-meshers-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut triangles = Vec::new();
    for name in ["kdtree", "octree", "dmc", "marching-cubes"] {
        let path = dir.join(format!("{name}.obj"));
        let (code, out, err) = kdcontour(&[
            "mesh",
            "--scene",
            "torus",
            "--res",
            "24",
            "--threshold",
            "0.1",
            "--mesher",
            name,
            "--json",
            "--out",
            path.to_str().unwrap(),
        ]);
        assert_eq!(code, 0, "{name}: {err}");
        let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
        assert_eq!(v["mesher"], name);
        assert_eq!(v["watertight"], true, "{name}: {out}");
        assert_eq!(v["euler"], 0, "{name}: {out}");
        // The file holds the mesh the report describes.
        let text = std::fs::read_to_string(&path).unwrap();
        let faces = text.lines().filter(|l| l.starts_with("f ")).count() as u64;
        assert_eq!(faces, v["triangles"].as_u64().unwrap(), "{name}");
        triangles.push(faces);
    }
    // Different meshers, different meshes: the k-d tree is the smallest, the
    // uniform ones ignore the threshold.
    assert!(
        triangles[0] < triangles[1] && triangles[1] < triangles[2],
        "{triangles:?}"
    );
    std::fs::remove_dir_all(&dir).ok();
    let (code, _, err) = kdcontour(&["mesh", "--scene", "torus", "--mesher", "voxels"]);
    assert_eq!(code, 2);
    assert!(
        err.contains("--mesher must be one of marching-cubes, dmc, octree, kdtree"),
        "{err}"
    );
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
            "assets/scenes/example.json",
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

    let stl = dir.join("x.stl");
    let (code, _, err) = kdcontour(&[
        "mesh",
        "--scene",
        "sphere",
        "--res",
        "16",
        "--out",
        stl.to_str().unwrap(),
    ]);
    assert_eq!(code, 2);
    assert!(err.contains(".obj or .ply"), "{err}");
    assert!(!stl.exists(), "a refused --out must not create the file");
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

#[test]
fn compare_prints_every_mesher_and_json_lines() {
    let (code, out, err) = kdcontour(&[
        "compare",
        "--scene",
        "disk_pole",
        "--res",
        "48",
        "--threshold",
        "0.01",
    ]);
    assert_eq!(code, 0, "{err}");
    let every = kdcontour::meshers::Mesher::ALL.map(kdcontour::meshers::Mesher::name);
    for m in every.iter().chain(&["k-d / octree triangles"]) {
        assert!(out.contains(m), "{out}");
    }
    let (code, out, err) = kdcontour(&["compare", "--scene", "torus", "--res", "32", "--json"]);
    assert_eq!(code, 0, "{err}");
    let lines: Vec<serde_json::Value> = out
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let names: Vec<&str> = lines
        .iter()
        .map(|v| v["mesher"].as_str().unwrap())
        .collect();
    assert_eq!(names, every);
    for v in &lines {
        assert_eq!(v["watertight"], true, "{v}");
        assert_eq!(v["manifold"], true, "{v}");
        assert_eq!(v["euler"], 0, "{v}");
    }
}

#[test]
fn an_inside_out_mesh_is_meshed_with_a_warning() {
    let dir = std::env::temp_dir().join(format!("kdcontour-cli-flip-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (fwd, rev) = (dir.join("torus.obj"), dir.join("reversed.obj"));
    let (code, _, err) = kdcontour(&[
        "mesh",
        "--scene",
        "torus",
        "--res",
        "20",
        "--quick-checks",
        "--out",
        fwd.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    // Every face reversed.
    let text: String = std::fs::read_to_string(&fwd)
        .unwrap()
        .lines()
        .map(|l| match l.strip_prefix("f ") {
            Some(f) => {
                let v: Vec<&str> = f.split_whitespace().collect();
                format!("f {} {} {}\n", v[0], v[2], v[1])
            }
            None => format!("{l}\n"),
        })
        .collect();
    std::fs::write(&rev, text).unwrap();
    let mut triangles = Vec::new();
    for (path, warned) in [(&fwd, false), (&rev, true)] {
        let (code, out, err) = kdcontour(&[
            "mesh",
            "--mesh",
            path.to_str().unwrap(),
            "--res",
            "24",
            "--quick-checks",
            "--json",
        ]);
        assert_eq!(code, 0, "{err}");
        assert_eq!(
            err.contains("warning: ") && err.contains("faces inward"),
            warned,
            "{err}"
        );
        let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
        assert_eq!(v["watertight"], true, "{out}");
        assert_eq!(v["euler"], 0, "{out}");
        triangles.push(v["triangles"].as_u64().unwrap());
    }
    // The same solid either way.
    assert_eq!(triangles[0], triangles[1]);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_scanned_phantom_has_a_whole_skull_at_its_iso() {
    let dir = std::env::temp_dir().join(format!("kdcontour-cli-scanned-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let nii = dir.join("scanned.nii.gz");
    let (code, out, err) = kdcontour(&[
        "phantom",
        "--res",
        "96",
        "--scanned",
        "--out",
        nii.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("--iso 1.3"), "{out}");
    let (code, out, err) = kdcontour(&[
        "mesh",
        "--volume",
        nii.to_str().unwrap(),
        "--iso",
        "1.3",
        "--threshold",
        "-1",
        "--quick-checks",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    assert_eq!(v["watertight"], true, "{v}");
    assert_eq!(v["manifold"], true, "{v}");
    // The skull's outer and inner surfaces, each a sphere: no hole, no piece.
    assert_eq!(v["euler"], 4, "{v}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn volumes_and_meshes_from_the_command_line() {
    let dir = std::env::temp_dir().join(format!("kdcontour-cli-vol-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let nii = dir.join("head.nii.gz");
    let (code, out, err) = kdcontour(&["phantom", "--res", "48", "--out", nii.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("--iso 1.5"), "{out}");
    let (code, out, err) = kdcontour(&[
        "mesh",
        "--volume",
        nii.to_str().unwrap(),
        "--iso",
        "1.5",
        "--res",
        "48",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    assert_eq!(v["watertight"], true);
    assert_eq!(v["manifold"], true);

    // A raw volume: 16^3 u8 ball.
    let raw = dir.join("ball.raw");
    let bytes: Vec<u8> = (0..16 * 16 * 16)
        .map(|i: i32| {
            let (x, y, z) = (i % 16, (i / 16) % 16, i / 256);
            let d = (((x - 8) * (x - 8) + (y - 8) * (y - 8) + (z - 8) * (z - 8)) as f32).sqrt();
            (200.0 - 30.0 * d).max(0.0) as u8
        })
        .collect();
    std::fs::write(&raw, &bytes).unwrap();
    let r = raw.to_str().unwrap();
    let (code, out, err) = kdcontour(&[
        "compare",
        "--volume",
        r,
        "--dims",
        "16,16,16",
        "--type",
        "u8",
        "--iso",
        "100",
        "--spacing",
        "1,1,2",
        "--res",
        "24",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    // One JSON line per mesher.
    assert_eq!(
        out.lines().count(),
        kdcontour::meshers::Mesher::ALL.len(),
        "{out}"
    );
    let (code, _, err) = kdcontour(&[
        "mesh", "--volume", r, "--dims", "16,16,15", "--type", "u8", "--iso", "100",
    ]);
    assert_eq!(code, 2);
    assert!(err.contains("--dims"), "{err}");
    let (code, _, err) = kdcontour(&["mesh", "--volume", r, "--type", "u8", "--iso", "100"]);
    assert_eq!(code, 2);
    assert!(err.contains("needs --dims"), "{err}");
    let (code, _, err) = kdcontour(&[
        "mesh", "--volume", r, "--dims", "16,16,16", "--type", "u7", "--iso", "100",
    ]);
    assert_eq!(code, 2);
    assert!(err.contains("u8, u16, i16 or f32"), "{err}");
    let (code, _, err) = kdcontour(&["mesh", "--volume", r, "--dims", "16,16,16", "--type", "u8"]);
    assert_eq!(code, 2);
    assert!(err.contains("--iso is required"), "{err}");

    // A mesh written by `mesh --out`, read back with `--mesh`.
    let obj = dir.join("torus.obj");
    let (code, _, err) = kdcontour(&[
        "mesh",
        "--scene",
        "torus",
        "--res",
        "24",
        "--threshold",
        "-1",
        "--out",
        obj.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let (code, out, err) = kdcontour(&[
        "mesh",
        "--mesh",
        obj.to_str().unwrap(),
        "--res",
        "32",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    assert_eq!(v["euler"], 0, "{v}");
    assert_eq!(v["watertight"], true);
    let bad = dir.join("bad.obj");
    std::fs::write(&bad, "v 0 0 0\nf 1 2 3\n").unwrap();
    let (code, _, err) = kdcontour(&["mesh", "--mesh", bad.to_str().unwrap()]);
    assert_eq!(code, 2);
    assert!(err.contains("line 2"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn world_writes_a_welded_closed_mesh() {
    let dir = std::env::temp_dir().join(format!("kdcontour-cli-world-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("world.ply");
    // A negative vector may follow its flag.
    for extra in [
        ["--thresholds", "random:3"],
        ["--camera", "0.2,0.9,-1.5"],
        ["--camera", "-0.2,0.9,-1.5"],
    ] {
        let (code, stdout, err) = kdcontour(&[
            "world",
            "--scene",
            "torus",
            "--chunks",
            "3,3,3",
            "--chunk-res",
            "12",
            extra[0],
            extra[1],
            "--out",
            out.to_str().unwrap(),
            "--json",
        ]);
        assert_eq!(code, 0, "{err}");
        let v: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
        assert_eq!(v["watertight"], true, "{v}");
        assert_eq!(v["manifold"], true, "{v}");
        assert_eq!(v["euler"], 0, "{v}");
        assert!(v["seam_triangles"].as_u64().unwrap() > 0, "{v}");
        assert!(std::fs::metadata(&out).unwrap().len() > 1000);
    }
    let (code, _, err) = kdcontour(&["world", "--scene", "torus", "--thresholds", "sometimes"]);
    assert_eq!(code, 2);
    assert!(err.contains("random:SEED"), "{err}");
    let (code, _, err) = kdcontour(&["world", "--scene", "torus"]);
    assert_eq!(code, 2);
    assert!(err.contains("--camera"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn world_levels_weld_closed_and_report_each_level() {
    let dir = std::env::temp_dir().join(format!("kdcontour-cli-levels-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("levels.obj");
    for extra in [
        ["--levels", "random:1", "--thresholds", "random:3"],
        [
            "--levels",
            "camera:0.3,0.5,-0.6",
            "--camera",
            "0.3,0.5,-0.6",
        ],
    ] {
        let mut args = vec![
            "world",
            "--scene",
            "torus",
            "--chunks",
            "16,16,16",
            "--chunk-res",
            "4",
            "--out",
            out.to_str().unwrap(),
            "--json",
        ];
        args.extend(extra);
        let (code, stdout, err) = kdcontour(&args);
        assert_eq!(code, 0, "{err}");
        assert_eq!(stdout.lines().count(), 1, "{stdout}");
        let v: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
        assert_eq!(v["watertight"], true, "{v}");
        assert_eq!(v["manifold"], true, "{v}");
        assert_eq!(v["oriented"], true, "{v}");
        assert_eq!(v["euler"], 0, "{v}");
        assert_eq!(v["levels"], extra[1], "{v}");
        assert_eq!(v["top_level"], 2, "{v}");
        // The geometric checks, as `mesh --json` reports them: no crossing on a
        // conformed face sits on its forced end.
        assert_eq!(v["zero_area_triangles"], 0, "{v}");
        assert!(v["flipped_triangles"].is_u64(), "{v}");
        // Every level from 0 to 2 holds chunks, and the levels add up.
        let levels = v["per_level"].as_array().unwrap();
        assert_eq!(levels.len(), 3, "{v}");
        let sum = |key: &str| -> u64 { levels.iter().map(|l| l[key].as_u64().unwrap()).sum() };
        for (i, l) in levels.iter().enumerate() {
            assert_eq!(l["level"], i as u64, "{v}");
            assert!(l["chunks"].as_u64().unwrap() > 0, "{v}");
            assert!(l["build_ms"].as_f64().unwrap() >= 0.0, "{v}");
        }
        assert_eq!(sum("chunks"), v["chunk_count"].as_u64().unwrap(), "{v}");
        assert_eq!(
            sum("retained_bytes"),
            v["retained_bytes"].as_u64().unwrap(),
            "{v}"
        );
        assert_eq!(sum("triangles"), v["triangles"].as_u64().unwrap(), "{v}");
        assert_eq!(
            v["thresholds"].as_array().unwrap().len() as u64,
            sum("chunks")
        );
        assert!(std::fs::metadata(&out).unwrap().len() > 1000);
    }
    // The summary has a line per level (default grid: 16,16,16).
    let (code, stdout, err) = kdcontour(&[
        "world",
        "--scene",
        "sphere",
        "--chunk-res",
        "4",
        "--levels",
        "random:0",
    ]);
    assert_eq!(code, 0, "{err}");
    for line in [
        "level 0 ",
        "level 1 ",
        "level 2 ",
        "watertight true, manifold true",
    ] {
        assert!(stdout.contains(line), "{line}: {stdout}");
    }
    for (bad, says) in [
        (vec!["--levels", "sometimes"], "random:SEED or camera:X,Y,Z"),
        (vec!["--levels", "random:x"], "random:SEED or camera:X,Y,Z"),
        (vec!["--levels", "camera:1,2"], "three"),
        (
            vec!["--levels", "random:1", "--chunks", "3,3,3"],
            "divisible by 2",
        ),
        (
            vec!["--levels", "random:1", "--chunk-res", "7"],
            "--chunk-res must be even with --levels",
        ),
        (
            vec!["--levels", "random:1", "--chunks", "0,0,0"],
            "--chunks must be at least 1 along every axis, got 0,0,0",
        ),
        (
            vec!["--chunks", "4,0,4", "--thresholds", "random:1"],
            "--chunks must be at least 1 along every axis",
        ),
    ] {
        let mut args = vec!["world", "--scene", "torus"];
        args.extend(bad);
        let (code, _, err) = kdcontour(&args);
        assert_eq!(code, 2, "{args:?}");
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(err.contains(says), "{args:?}: {err}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A camera however far out (but finite) lays out the coarsest chunks only, as
/// one just past the world does; the message never speaks of chunk units.
#[test]
fn a_far_level_camera_lays_out_the_top_level() {
    let mut counts = Vec::new();
    for cam in ["camera:-3.4e38,0,0", "camera:0,3e38,-3e38", "camera:0,0,50"] {
        let (code, stdout, err) = kdcontour(&[
            "world",
            "--scene",
            "torus",
            "--chunks",
            "8,8,8",
            "--chunk-res",
            "4",
            "--levels",
            cam,
            "--thresholds",
            "random:3",
            "--json",
        ]);
        assert_eq!(code, 0, "{cam}: {err}");
        let v: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
        assert_eq!(v["watertight"], true, "{cam}: {v}");
        counts.push(v["chunk_count"].as_u64().unwrap());
    }
    // 8,8,8 level-0 chunks are 2,2,2 of level 2.
    assert_eq!(counts, [8, 8, 8]);
}

/// A write past the file-size limit (`ulimit -f`) ends in an error naming the
/// file, the existing file stays whole, and no temporary file is left behind.
#[cfg(target_os = "linux")]
#[test]
fn a_write_past_the_file_size_limit_is_an_error_and_leaves_the_old_file() {
    let dir = std::env::temp_dir().join(format!("kdcontour-cli-fsize-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("sphere.obj");
    std::fs::write(&path, b"the old mesh").unwrap();
    // 64 blocks of 512 bytes: far less than a sphere at res 64 as text.
    let out = path.to_str().unwrap();
    let args = [
        "mesh",
        "--scene",
        "sphere",
        "--res",
        "64",
        "--threshold",
        "-1",
        "--out",
        out,
    ];
    let (code, _, err) = common::kdcontour_under("-f 64", &args);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("sphere.obj"), "{err}");
    assert_eq!(std::fs::read(&path).unwrap(), b"the old mesh");
    let names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 1, "{names:?}");
    std::fs::remove_dir_all(&dir).ok();
}

/// Threads the system will not start (under a memory limit) are a clear error
/// that says what to do, not an operating system's message alone.
#[cfg(target_os = "linux")]
#[test]
fn threads_the_system_refuses_are_a_clear_error() {
    // 1 GiB of address space: the command runs, 1,024 thread stacks do not fit.
    let args = [
        "mesh",
        "--scene",
        "sphere",
        "--res",
        "16",
        "--threads",
        "1024",
    ];
    let (code, _, err) = common::kdcontour_under("-v 1048576", &args);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("would not start 1024 worker threads"), "{err}");
    assert!(err.contains("ask for fewer"), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
}

/// `kdcontour` on a pseudo-terminal (util-linux `script` runs it on one):
/// everything it wrote, progress included.
#[cfg(target_os = "linux")]
fn kdcontour_on_a_terminal(args: &[&str]) -> String {
    let line = std::iter::once(env!("CARGO_BIN_EXE_kdcontour"))
        .chain(args.iter().copied())
        .collect::<Vec<_>>()
        .join(" ");
    let out = Command::new("script")
        .args(["-qec", &line, "/dev/null"])
        .current_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
        .output()
        .expect("util-linux `script` runs (it gives the command a terminal)");
    assert!(out.status.success(), "{out:?}");
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Long work shows its stages, the chunks done and the time so far on a
/// terminal; piped, or with --json, the output is exactly the results.
#[cfg(target_os = "linux")]
#[test]
fn progress_shows_on_a_terminal_and_nowhere_else() {
    let world = [
        "world",
        "--scene",
        "gyroid",
        "--chunks",
        "16,16,16",
        "--levels",
        "camera:0,0,0",
    ];
    let shown = kdcontour_on_a_terminal(&world);
    for stage in [
        "building level 0: ",
        "/64 chunks",
        "building level 2: ",
        "cutting and welding 176 chunks",
        "checking ",
        "about ",
    ] {
        assert!(shown.contains(stage), "no `{stage}` in {shown:?}");
    }
    // The line is cleared (erase-line) before the results print.
    let results = shown.find("world      gyroid").expect("the results");
    assert!(shown[..results].contains("\u{1b}[2K"), "{shown:?}");
    let mesh = kdcontour_on_a_terminal(&["mesh", "--scene", "sphere", "--res", "64"]);
    assert!(
        mesh.contains("sampling and building, 262144 cells"),
        "{mesh:?}"
    );
    assert!(mesh.contains("checking "), "{mesh:?}");
    // Piped: nothing but the results, on stdout.
    let (code, out, err) = kdcontour(&world);
    assert_eq!((code, err.as_str()), (0, ""));
    assert!(
        out.starts_with("world      gyroid") && !out.contains('\u{1b}'),
        "{out}"
    );
    // --json on a terminal: the one JSON line, no progress.
    let json: Vec<&str> = world.iter().copied().chain(["--json"]).collect();
    let line = kdcontour_on_a_terminal(&json);
    assert!(
        !line.contains("chunks:") && !line.contains('\u{1b}'),
        "{line:?}"
    );
    assert_eq!(line.trim_end().lines().count(), 1, "{line:?}");
}
