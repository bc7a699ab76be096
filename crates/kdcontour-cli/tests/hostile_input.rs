//! Issue 14 from the command line: every hostile input ends with exit status 2
//! and one line that names what is wrong and what to do; `--out` is checked
//! before any work and never touched by a failed command; a closed stdout ends a
//! command quietly. Every run has its memory capped (about 100 MB) and a hang
//! guard (see `common`).

mod common;

use common::{cat, dir, kdcontour, nifti_header, refused, s, BIN, WORLD};
use std::process::{Command, Stdio};

#[test]
fn raw_volume_sizes_are_checked_before_reading() {
    let d = dir("raw");
    let small = d.join("small.raw");
    std::fs::write(&small, [0u8; 1000]).unwrap();
    let vol = |dims: &str| {
        [
            "mesh",
            "--volume",
            s(&small),
            "--dims",
            dims,
            "--type",
            "u16",
            "--iso",
            "0.5",
        ]
        .map(String::from)
    };
    let run = |dims: &str, needles: &[&str]| {
        let a = vol(dims);
        refused(&a.iter().map(String::as_str).collect::<Vec<_>>(), needles)
    };
    // Wrapping products and sizes past the budget: refused by size.
    run(
        "65536,65536,4097",
        &["65536x65536x4097 voxels", "over the memory budget"],
    );
    run(
        "4294967295,4294967295,4294967295",
        &["over the memory budget"],
    );
    // Dims are integers: no f32 rounding (16777217 stays 16777217), no wrapping.
    run("16777217,2,2", &["16777217x2x2"]);
    run(
        "4294967296,2,2",
        &["`4294967296` is not a whole number from 0 to 4294967295"],
    );
    // An endless file is read no further than the dims need.
    refused(
        &[
            "mesh",
            "--volume",
            "/dev/zero",
            "--dims",
            "10,10,10",
            "--type",
            "u8",
            "--iso",
            "0.5",
        ],
        &[
            "/dev/zero",
            "longer than 1000 bytes",
            "check --dims and --type",
        ],
    );
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn silent_garbage_is_now_an_error() {
    let d = dir("garbage");
    let ramp = d.join("ramp.raw");
    std::fs::write(
        &ramp,
        (0..1000).map(|i| (i % 250) as u8).collect::<Vec<_>>(),
    )
    .unwrap();
    let r = s(&ramp);
    let base = ["mesh", "--volume", r, "--dims", "10,10,10", "--type", "u8"];
    // An axis thinner than 2 cells at res 64 (the default res, one cell per
    // voxel, gives every axis a cell per voxel of the finest spacing).
    refused(
        &cat(
            &base,
            &["--iso", "100", "--spacing", "100,1,1", "--res", "64"],
        ),
        &["ramp.raw", "0.64 cells", "use res 200 or more"],
    );
    // --iso outside the data: an error, and no mesh written.
    let out = d.join("iso.obj");
    refused(
        &cat(&base, &["--iso", "1000", "--out", s(&out)]),
        &[
            "--iso",
            "outside the voxel values (0 to 249)",
            "strictly between",
        ],
    );
    assert!(!out.exists());
    // NaN anywhere a vector is parsed.
    refused(
        &cat(&base, &["--iso", "100", "--spacing", "NaN,1,1"]),
        &["`NaN` is not a finite number"],
    );
    refused(
        &["world", "--scene", "sphere", "--camera", "NaN,0,0"],
        &["`NaN` is not a finite number"],
    );
    refused(
        &["world", "--scene", "sphere", "--levels", "camera:0,inf,0"],
        &["`inf` is not a finite number"],
    );
    // --iso below the data: an error too, not a box.
    refused(
        &cat(&base, &["--iso", "-5", "--out", s(&out)]),
        &["--iso", "outside the voxel values (0 to 249)"],
    );
    assert!(!out.exists());
    // 256,256,4 voxels at res 64: the thin axis gets 0.75 cells.
    let flat = d.join("flat.raw");
    let ramp: Vec<u8> = (0..256 * 256 * 4).map(|i| (i % 250) as u8).collect();
    std::fs::write(&flat, ramp).unwrap();
    refused(
        &[
            "mesh",
            "--volume",
            s(&flat),
            "--dims",
            "256,256,4",
            "--type",
            "u8",
            "--iso",
            "3",
            "--res",
            "64",
        ],
        &["flat.raw", "0.75 cells", "use res 170 or more"],
    );
    // A NIfTI whose pixdim is NaN, and one whose pixdim is 1e-30.
    let nii = d.join("nan.nii");
    let mut h = nifti_header([2, 2, 2], [f32::NAN, 1.0, 1.0]);
    h.extend([0, 1, 2, 3, 4, 5, 6, 7]);
    std::fs::write(&nii, h).unwrap();
    refused(
        &["mesh", "--volume", s(&nii), "--iso", "3"],
        &["nan.nii", "pixdim", "finite and non-zero"],
    );
    let thin = d.join("thin.nii");
    let mut h = nifti_header([2, 2, 2], [1e-30, 1.0, 1.0]);
    h.extend([0, 1, 2, 3, 4, 5, 6, 7]);
    std::fs::write(&thin, h).unwrap();
    refused(
        &["mesh", "--volume", s(&thin), "--iso", "3"],
        &["thin.nii", "at least 2 are needed", "no res can mesh it"],
    );
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn a_gzip_bomb_inflates_no_further_than_its_header_says() {
    use std::io::Write;
    let d = dir("bomb");
    // 4x4x4 voxels (a ramp, a surface at 30), then 256 MiB of zeros that
    // compress to about 256 KB: only the header's 64 voxels are inflated (all of
    // it would pass the memory cap the run is held under).
    let mut body = nifti_header([4, 4, 4], [1.0; 3]);
    body.extend(0..64u8);
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::best());
    gz.write_all(&body).unwrap();
    let zeros = vec![0u8; 1 << 20];
    for _ in 0..256 {
        gz.write_all(&zeros).unwrap();
    }
    let bomb = d.join("bomb.nii.gz");
    std::fs::write(&bomb, gz.finish().unwrap()).unwrap();
    assert!(std::fs::metadata(&bomb).unwrap().len() < 1 << 20);
    let (code, out, err) = kdcontour(&["mesh", "--volume", s(&bomb), "--iso", "30", "--res", "8"]);
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("triangles") && !out.contains(" 0 triangles"),
        "{out}"
    );
    // A header whose volume is past the budget: refused before inflating.
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::best());
    gz.write_all(&nifti_header([2048, 2048, 2048], [1.0; 3]))
        .unwrap();
    for _ in 0..64 {
        gz.write_all(&zeros).unwrap();
    }
    let big = d.join("big.nii.gz");
    std::fs::write(&big, gz.finish().unwrap()).unwrap();
    refused(
        &["mesh", "--volume", s(&big), "--iso", "1"],
        &[
            "big.nii.gz",
            "2048x2048x2048 voxels",
            "over the memory budget of 4 GiB",
        ],
    );
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn hostile_meshes_and_scenes() {
    let d = dir("mesh");
    let write = |name: &str, text: &str| {
        let p = d.join(name);
        std::fs::write(&p, text).unwrap();
        p
    };
    let junk = write(
        "junk.ply",
        "ply\nformat ascii 1.0\nelement junk 18446744073709551615\nend_header\n",
    );
    refused(&["mesh", "--mesh", s(&junk)], &["junk.ply", "no faces"]);
    let big = write(
        "big.ply",
        "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n",
    );
    refused(
        &["mesh", "--mesh", s(&big)],
        &["claims 1000000000000 rows", "fix the element count"],
    );
    let freq = write(
        "freq.json",
        r#"{"type":"heightfield","amplitude":1,"frequency":1e19}"#,
    );
    refused(
        &["mesh", "--scene-file", s(&freq)],
        &["freq.json", "root", "at most 1000000"],
    );
    let far = write(
        "far.json",
        r#"{"type":"transform","translate":[1e20,0,0],"child":{"type":"heightfield","amplitude":1,"frequency":1}}"#,
    );
    refused(
        &["mesh", "--scene-file", s(&far), "--res", "8"],
        &[
            "far.json: ",
            "scene node `root.child` (heightfield)",
            "noise evaluated too far",
            "keep the node within",
        ],
    );
    let node = write(
        "node.json",
        r#"{"type":"union","children":[{"type":"sphere","radius":1},{"type":"sphere"}]}"#,
    );
    refused(
        &["mesh", "--scene-file", s(&node)],
        &["root.children[1]", "missing field `radius`"],
    );
    // The issue's 50 MB type name: one short line, within the memory cap.
    let long = write(
        "long.json",
        &format!(r#"{{"type":"{}"}}"#, "x".repeat(50 << 20)),
    );
    refused(
        &["mesh", "--scene-file", s(&long)],
        &[
            "long.json: ",
            "line 1, column 9: a string of 52428800 bytes",
        ],
    );
    let (_, _, err) = kdcontour(&["mesh", "--scene-file", s(&long)]);
    assert!(err.len() < 400, "{} bytes", err.len());
    let mut deep = r#"{"type":"sphere","radius":1}"#.to_string();
    for _ in 0..40 {
        deep = format!(r#"{{"type":"union","children":[{deep}]}}"#);
    }
    let deep = write("deep.json", &deep);
    refused(
        &["mesh", "--scene-file", s(&deep)],
        &["deeper than 32 nodes", "flatten"],
    );
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn a_world_over_the_budget_is_refused_at_once() {
    refused(
        &cat(&WORLD, &["--chunks", "256,256,256"]),
        &[
            "a world of 256x256x256 chunks of 16^3 cells",
            "over the memory budget",
        ],
    );
}

#[test]
fn out_is_checked_first_and_never_truncated() {
    let d = dir("out");
    for name in ["keep.stl", "keep.obj"] {
        let keep = d.join(name);
        std::fs::write(&keep, "keep").unwrap();
        // A bad extension, or a failure after the check: the file stays as it was.
        refused(
            &["mesh", "--scene", "sphere", "--out", s(&keep), "--res", "0"],
            &[],
        );
        refused(&["mesh", "--scene", "nosuch", "--out", s(&keep)], &[]);
        assert_eq!(std::fs::read_to_string(&keep).unwrap(), "keep", "{name}");
    }
    refused(
        &["mesh", "--scene", "sphere", "--out", s(&d.join("keep.stl"))],
        &["--out", "use a .obj or .ply extension"],
    );
    refused(
        &cat(&WORLD, &["--out", "/nonexistent/dir/w.obj"]),
        &["--out", "does not exist"],
    );
    // The phantom is NIfTI: any other name is refused; .NII.GZ is recognised.
    let raw = d.join("p.raw");
    refused(
        &["phantom", "--res", "8", "--out", s(&raw)],
        &["name it .nii or .nii.gz"],
    );
    assert!(!raw.exists());
    let upper = d.join("P.NII.GZ");
    let (code, _, err) = kdcontour(&["phantom", "--res", "16", "--out", s(&upper)]);
    assert_eq!(code, 0, "{err}");
    let (code, _, err) = kdcontour(&["mesh", "--volume", s(&upper), "--iso", "1.5", "--res", "16"]);
    assert_eq!(code, 0, "{err}");
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn world_help_lists_only_what_world_accepts() {
    let (code, out, _) = kdcontour(&["world", "--help"]);
    assert_eq!(code, 0);
    assert!(out.contains("--scene-file"), "{out}");
    for absent in [
        "--volume",
        "--mesh",
        "--dims",
        "--type",
        "--spacing",
        "--iso",
        "--inside",
    ] {
        assert!(!out.contains(absent), "world --help lists {absent}:\n{out}");
    }
}

#[test]
fn a_reader_that_closes_early_ends_every_command_quietly() {
    let d = dir("pipe");
    let head = d.join("head.nii");
    for args in [
        &["phantom", "--res", "8", "--out", s(&head)][..],
        &["scenes"],
        &["mesh", "--scene", "sphere", "--res", "8"],
        &["mesh", "--scene", "sphere", "--res", "8", "--json"],
        &["compare", "--scene", "sphere", "--res", "8"],
        &["world", "--scene", "sphere", "--camera", "0,0,0"],
        &[
            "world",
            "--scene",
            "sphere",
            "--levels",
            "random:1",
            "--chunks",
            "4,4,4",
            "--chunk-res",
            "4",
        ],
    ] {
        let mut child = Command::new(BIN)
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        drop(child.stdout.take());
        let out = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(0), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
    std::fs::remove_dir_all(&d).ok();
}
