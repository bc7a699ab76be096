//! `--memory-budget` (issue 14): on every command that allocates, documented in
//! its help; a bad size is refused with what is valid; a budget too small for a
//! volume, a mesh, a grid, a world or a phantom refuses it before allocating,
//! naming the flag; one budget covers the whole command (a loaded volume and the
//! grid meshed from it); the default still meshes the normal cases.

mod common;

use common::{cat, dir, kdcontour, refused, s, WORLD};
use std::path::{Path, PathBuf};

/// A phantom of `res`^3 voxels written by the command as `d/name`.
fn phantom(d: &Path, name: &str, res: &str) -> PathBuf {
    let path = d.join(name);
    let (code, _, err) = kdcontour(&["phantom", "--res", res, "--out", s(&path)]);
    assert_eq!(code, 0, "{err}");
    path
}

#[test]
fn every_command_that_allocates_documents_the_flag() {
    for cmd in ["mesh", "compare", "world", "phantom"] {
        let (code, out, _) = kdcontour(&[cmd, "--help"]);
        assert_eq!(code, 0);
        for needle in ["--memory-budget <SIZE>", "512MB or 4GiB", "[default: 4GiB]"] {
            assert!(
                out.contains(needle),
                "{cmd} --help lacks `{needle}`:\n{out}"
            );
        }
    }
    let (_, out, _) = kdcontour(&["scenes", "--help"]);
    assert!(!out.contains("--memory-budget"), "{out}");
}

#[test]
fn a_bad_size_is_refused_with_what_is_valid() {
    for (size, says) in [
        ("0", "no memory at all"),
        ("0MB", "no memory at all"),
        ("lots", "not a size"),
        ("-5", "not a size"),
        ("4G", "unknown size unit"),
    ] {
        refused(
            &["mesh", "--scene", "sphere", "--memory-budget", size],
            &["--memory-budget", says, "512MB or 4GiB"],
        );
    }
}

#[test]
fn a_small_budget_refuses_each_input_before_allocating() {
    let d = dir("budget");
    let head = phantom(&d, "head.nii.gz", "32");
    // Many elements in few bytes: 1,000 vertices and 10,000 faces in 86 KB.
    let sphere = d.join("many.ply");
    let mut ply = "ply\nformat ascii 1.0\nelement vertex 1000\nproperty float x\nproperty float y\nproperty float z\nelement face 10000\nproperty list uchar int vertex_indices\nend_header\n".to_string();
    ply += &"0 0 0\n".repeat(1000);
    ply += &"3 0 1 2\n".repeat(10_000);
    std::fs::write(&sphere, ply).unwrap();
    let budget = |size| ["--memory-budget", size];
    // A volume: its voxels after inflation.
    refused(
        &cat(
            &["mesh", "--volume", s(&head), "--iso", "1.5"],
            &budget("100KB"),
        ),
        &[
            "head.nii.gz",
            "32x32x32 voxels",
            "over the memory budget of 97.7 KiB",
            "--memory-budget",
        ],
    );
    // A mesh: its element counts (the file is within an eighth of the budget).
    refused(
        &cat(&["mesh", "--mesh", s(&sphere)], &budget("1MiB")),
        &[
            "many.ply",
            "a mesh of 1000 vertices and 10000 faces",
            "over the memory budget of 1 MiB",
            "--memory-budget",
        ],
    );
    // A grid, for mesh and compare alike.
    for cmd in ["mesh", "compare"] {
        refused(
            &cat(&[cmd, "--scene", "sphere", "--res", "128"], &budget("8MiB")),
            &[
                "a grid of",
                "over the memory budget of 8 MiB",
                "--memory-budget",
            ],
        );
    }
    // A whole world, with and without levels.
    refused(
        &cat(&WORLD, &budget("1MB")),
        &[
            "a world of 3x3x3 chunks of 16^3 cells",
            "over the memory budget of 977 KiB",
        ],
    );
    refused(
        &cat(
            &["world", "--scene", "sphere", "--levels", "random:1"],
            &budget("100KB"),
        ),
        &[
            "a world of 4096 chunks",
            "over the memory budget of 97.7 KiB",
        ],
    );
    // A phantom: checked before it is computed; nothing is written.
    let big = d.join("big.nii");
    refused(
        &cat(
            &["phantom", "--res", "512", "--out", s(&big)],
            &budget("100MB"),
        ),
        &[
            "a phantom of 512^3 voxels",
            "over the memory budget of 95.4 MiB",
        ],
    );
    assert!(!big.exists());
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn one_budget_covers_the_loaded_input_and_its_grid() {
    let d = dir("whole");
    let head = phantom(&d, "head.nii", "64");
    let mesh = ["mesh", "--volume", s(&head), "--iso", "1.5", "--res", "32"];
    // The volume (1 MiB of voxels) loads within 20 MB; its grid does not fit
    // in what is left, and the message says the input holds part of it.
    refused(
        &cat(&mesh, &["--memory-budget", "20MB"]),
        &[
            "a grid of",
            "--memory-budget",
            "leaves once the input's 1 MiB are held",
        ],
    );
    // The default budget meshes it.
    let (code, out, err) = kdcontour(&mesh);
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("triangles") && !out.contains(" 0 triangles"),
        "{out}"
    );
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn a_large_budget_is_taken_and_the_normal_cases_pass() {
    let torus = ["mesh", "--scene", "torus", "--res", "24", "--memory-budget"];
    let sphere = [
        "compare",
        "--scene",
        "sphere",
        "--res",
        "16",
        "--memory-budget",
    ];
    for args in [
        cat(&torus, &["512MB"]),
        cat(&torus, &["1.5 GiB"]),
        cat(&sphere, &["64MiB"]),
        cat(&WORLD, &["--memory-budget", "1073741824"]),
    ] {
        let (code, _, err) = kdcontour(&args);
        assert_eq!(code, 0, "{args:?}: {err}");
    }
}

/// A budget larger than the machine can give is held to what it can: a build
/// or load that would not fit is an error naming the limit, not an abort
/// (`memory allocation of ... failed`, signal 6).
#[cfg(target_os = "linux")]
#[test]
fn budgets_above_the_machine_end_in_an_error_not_an_abort() {
    let dir = std::env::temp_dir().join(format!("kdcontour-machine-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let nii = dir.join("p.nii");
    let cases: [&[&str]; 3] = [
        &[
            "mesh",
            "--scene",
            "sphere",
            "--res",
            "1000",
            "--memory-budget",
            "1000TB",
        ],
        &[
            "phantom",
            "--res",
            "1024",
            "--memory-budget",
            "16GiB",
            "--out",
            nii.to_str().unwrap(),
        ],
        &[
            "world",
            "--scene",
            "torus",
            "--chunk-res",
            "2000",
            "--chunks",
            "2,2,2",
            "--thresholds",
            "random:1",
            "--memory-budget",
            "1000TB",
        ],
    ];
    for args in cases {
        // 2 GiB of address space: each of these needs far more.
        let (code, _, err) = common::kdcontour_under("-v 2097152", args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(
            err.contains("more than this machine can give now"),
            "{args:?}: {err}"
        );
        assert!(err.contains("ulimit -v"), "{args:?}: {err}");
    }
    assert!(!nii.exists());
    std::fs::remove_dir_all(&dir).ok();
}
