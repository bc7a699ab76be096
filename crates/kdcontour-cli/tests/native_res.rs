//! Volumes mesh at their native resolution (issue 17): one cell per voxel unless
//! `--res` asks otherwise; a native grid over `--memory-budget` is refused before
//! anything is allocated, naming the `--res` that fits.

mod common;

use common::{cat, dir, kdcontour, refused, s};
use std::path::PathBuf;

/// The `"res"` of a `--json` line.
fn json_res(out: &str) -> u64 {
    let v: serde_json::Value = serde_json::from_str(out.lines().next().unwrap()).unwrap();
    v["res"].as_u64().unwrap()
}

/// A phantom of `res`^3 voxels written by the command into a fresh directory
/// `name`: the directory and the file.
fn phantom(name: &str, res: &str) -> (PathBuf, PathBuf) {
    let d = dir(name);
    let head = d.join("head.nii");
    let (code, _, err) = kdcontour(&["phantom", "--res", res, "--out", s(&head)]);
    assert_eq!(code, 0, "{err}");
    (d, head)
}

#[test]
fn a_volume_meshes_at_one_cell_per_voxel_unless_res_is_given() {
    let (d, head) = phantom("native", "40");
    let mesh = ["mesh", "--volume", s(&head), "--iso", "1.5", "--json"];
    // 40 voxels per axis span 39 voxel steps: 39 cells along the longest side.
    let (code, out, err) = kdcontour(&cat(&mesh, &["--threshold", "-1"]));
    assert_eq!(code, 0, "{err}");
    assert_eq!(json_res(&out), 39, "{out}");
    let (code, out, err) = kdcontour(&cat(&mesh, &["--res", "16"]));
    assert_eq!(code, 0, "{err}");
    assert_eq!(json_res(&out), 16, "{out}");
    // compare takes the same default; scenes keep 64.
    let (code, out, err) = kdcontour(&["compare", "--volume", s(&head), "--iso", "1.5", "--json"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.lines().all(|l| json_res(l) == 39), "{out}");
    let (code, out, err) = kdcontour(&["mesh", "--scene", "sphere", "--json"]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(json_res(&out), 64, "{out}");
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn a_native_grid_over_the_budget_is_refused_with_the_res_that_fits() {
    let (d, head) = phantom("native-budget", "128");
    // 8 MiB of voxels load within 40 MB; their native grid of 129^3 cells does not
    // fit in what is left.
    let mesh = ["mesh", "--volume", s(&head), "--iso", "1.5"];
    let budget = ["--memory-budget", "40MB"];
    refused(
        &cat(&mesh, &budget),
        &[
            "native resolution",
            "one cell per voxel, res 127: 129x129x129 cells",
            "once the volume's 8 MiB are held",
            "pass --res",
        ],
    );
    // The res the message names fits.
    let (_, _, err) = kdcontour(&cat(&mesh, &budget));
    let res = err
        .split("pass --res ")
        .nth(1)
        .and_then(|t| t.split(' ').next())
        .expect("names a res");
    let (code, out, err) = kdcontour(&cat(
        &cat(&mesh, &budget),
        &["--res", res, "--quick-checks"],
    ));
    assert_eq!(code, 0, "--res {res}: {err}");
    assert!(out.contains("triangles"), "{out}");
    std::fs::remove_dir_all(&d).ok();
}
