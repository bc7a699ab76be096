//! Hostile files and values (issue 14): header sizes that overflow or cannot fit
//! in the file, endless files, gzip bombs, NaN spacing, finite but huge noise
//! parameters, worlds over the budget, failed writes. Each is refused with a
//! message that names what is wrong and what would be valid, never a panic, a
//! hang or an allocation the budget does not allow.

use glam::{UVec3, Vec3};
use kdcontour::field::volume::Inside;
use kdcontour::io::input::Input;
use kdcontour::io::mesh::{mesh_from_bytes, MeshFormat};
use kdcontour::io::volume::{self, load_raw, raw_from_bytes, read_nifti, VoxelType};
use kdcontour::{Budget, CsgNode, Error, Grid, IndexedMesh, KdTree, Settings, World};
use std::io::Read;
use std::path::PathBuf;

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("kdcontour-hostile-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// A NIfTI-1 header (little endian) for `dims` voxels of u8, `pixdim` spacing.
fn nifti_header(dims: [i16; 3], pixdim: [f32; 3]) -> Vec<u8> {
    let mut h = vec![0u8; 352];
    h[0..4].copy_from_slice(&348i32.to_le_bytes());
    for (i, d) in [3, dims[0], dims[1], dims[2], 1, 1, 1, 1]
        .iter()
        .enumerate()
    {
        h[40 + 2 * i..42 + 2 * i].copy_from_slice(&d.to_le_bytes());
    }
    h[70..72].copy_from_slice(&2i16.to_le_bytes());
    for (i, p) in pixdim.iter().enumerate() {
        h[80 + 4 * i..84 + 4 * i].copy_from_slice(&p.to_le_bytes());
    }
    h[108..112].copy_from_slice(&352f32.to_le_bytes());
    h[344..348].copy_from_slice(b"n+1\0");
    h
}

#[test]
fn raw_dims_that_overflow_or_exceed_the_budget_are_refused_before_reading() {
    let path = tmp("small.raw");
    std::fs::write(&path, [0u8; 1000]).unwrap();
    // 65536 * 65536 * 4097 * 2 bytes wraps a 32-bit product; u32::MAX^3 overflows
    // u64. Both are refused by size, naming the budget.
    for dims in [UVec3::new(65536, 65536, 4097), UVec3::splat(u32::MAX)] {
        let e = load_raw(&path, dims, VoxelType::U16, Vec3::ONE, 0.5, Inside::Above)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with(&path.display().to_string()), "{e}");
        assert!(e.contains("over the memory budget"), "{e}");
        assert!(e.contains("use a smaller input"), "{e}");
    }
}

#[test]
fn an_endless_raw_file_is_read_no_further_than_its_dims() {
    let e = load_raw(
        std::path::Path::new("/dev/zero"),
        UVec3::splat(10),
        VoxelType::U8,
        Vec3::ONE,
        0.5,
        Inside::Above,
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("longer than 1000 bytes") && e.contains("check --dims and --type"),
        "{e}"
    );
}

#[test]
fn nifti_reads_only_what_its_header_needs() {
    // 4^3 voxels, then 64 MiB of zeros gzip-compressed to a few hundred KB: only
    // the 64 voxel bytes after the header may be inflated.
    let mut plain = nifti_header([4, 4, 4], [1.0; 3]);
    plain.extend((0..64u8).map(|i| i % 7));
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::best());
    use std::io::Write;
    gz.write_all(&plain).unwrap();
    let zeros = vec![0u8; 1 << 20];
    for _ in 0..64 {
        gz.write_all(&zeros).unwrap();
    }
    let bomb = gz.finish().unwrap();
    /// Counts the compressed bytes the loader pulls.
    struct Counting<'a>(&'a [u8], usize);
    impl Read for Counting<'_> {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            let n = self.0.read(buf)?;
            self.1 += n;
            Ok(n)
        }
    }
    let mut r = Counting(&bomb, 0);
    let (dims, _, data) =
        read_nifti(std::io::BufReader::new(&mut r), Budget::bytes(1 << 20)).unwrap();
    assert_eq!((dims, data.len()), (UVec3::splat(4), 64));
    assert!(r.1 < bomb.len() / 4, "read {} of {} bytes", r.1, bomb.len());
    // A header whose volume exceeds the budget is refused before inflating it.
    let big = nifti_header([2048, 2048, 2048], [1.0; 3]);
    let e = read_nifti(&big[..], Budget::bytes(1 << 30)).unwrap_err();
    assert!(
        e.contains("2048x2048x2048 voxels") && e.contains("memory budget"),
        "{e}"
    );
}

#[test]
fn nifti_spacing_must_be_finite_and_non_zero() {
    for pix in [
        [f32::NAN, 1.0, 1.0],
        [1.0, f32::INFINITY, 1.0],
        [1.0, 1.0, 0.0],
    ] {
        let mut b = nifti_header([2, 2, 2], pix);
        b.extend([0u8; 8]);
        let e = volume::parse_nifti(&b).unwrap_err();
        assert!(
            e.contains("pixdim") && e.contains("finite and non-zero"),
            "{e}"
        );
    }
}

#[test]
fn a_volume_axis_with_fewer_than_two_cells_is_an_error() {
    let data: Vec<u8> = (0..1000).map(|i| (i % 250) as u8).collect();
    let vol = raw_from_bytes(
        &data,
        UVec3::splat(10),
        VoxelType::U8,
        Vec3::new(100.0, 1.0, 1.0),
        100.0,
        Inside::Above,
    )
    .unwrap();
    let input = Input::volume(std::path::Path::new("thin.raw"), vol.clone());
    let e = input.grid(64).unwrap_err().to_string();
    assert!(e.starts_with("thin.raw: "), "{e}");
    assert!(
        e.contains("0.64 cells") && e.contains("use res 200 or more"),
        "{e}"
    );
    assert!(input.grid(200).is_ok());
    // The iso value must lie inside the voxel values.
    assert!(vol.check_iso(100.0).is_ok());
    let e = vol.check_iso(-5.0).unwrap_err();
    assert!(e.contains("outside the voxel values (0 to 249)"), "{e}");
}

#[test]
fn ply_counts_that_cannot_fit_are_refused_at_once() {
    let cases: [(&str, &str); 4] = [
        // No properties: nothing to read, whatever the count says (this hung).
        (
            "ply\nformat ascii 1.0\nelement junk 18446744073709551615\nend_header\n",
            "the mesh has no faces",
        ),
        (
            "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\nend_header\n",
            "the vertex element needs x, y and z properties",
        ),
        (
            "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n",
            "element vertex claims 1000000000000 rows of at least 12 bytes, but only 0 bytes follow",
        ),
        (
            "ply\nformat ascii 1.0\nelement vertex 18446744073709551615\nproperty float x\nproperty float y\nproperty float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n",
            "the header claims more than 2^64 rows",
        ),
    ];
    for (text, needle) in cases {
        let e = mesh_from_bytes(text.as_bytes(), MeshFormat::Ply).unwrap_err();
        assert!(e.contains(needle), "{text}\n{e}");
    }
    let long = format!(
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty {} x\nend_header\n",
        "t".repeat(1 << 20)
    );
    let e = mesh_from_bytes(long.as_bytes(), MeshFormat::Ply).unwrap_err();
    assert!(e.len() < 300 && e.contains("1048576 bytes in all"), "{e}");
}

#[test]
fn huge_noise_parameters_are_errors_not_panics() {
    let e = CsgNode::from_json(r#"{"type":"heightfield","amplitude":1,"frequency":1e19}"#)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("`root.frequency`: must be > 0 and at most 1000000"),
        "{e}"
    );
    // Cave noise faster than any other frequency: refused at its node path.
    let e = CsgNode::from_json(
        r#"{"type":"density","amplitude":1,"frequency":1,"caves":{"frequency":1e30,"radius":0.1}}"#,
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("`root.caves.frequency`") && e.contains("at most 1000000"),
        "{e}"
    );
    // A finite translate or a tiny scale that puts the noise beyond its reach: a
    // non-finite sample error naming the point, the noise node's path and what
    // would be valid, instead of a panic inside the noise crate.
    for (child, path) in [
        (
            r#"{"type":"transform","translate":[1e20,0,0],"child":{"type":"heightfield","amplitude":1,"frequency":1}}"#,
            "root.children[1].child` (heightfield)",
        ),
        (
            r#"{"type":"transform","translate":[0,0,-1e20],"child":{"type":"density","amplitude":1,"frequency":1,"caves":{"frequency":1,"radius":0.1}}}"#,
            "root.children[1].child` (density)",
        ),
        (
            r#"{"type":"transform","scale":1e-30,"child":{"type":"heightfield","amplitude":1,"frequency":1}}"#,
            "root.children[1].child` (heightfield)",
        ),
    ] {
        let text =
            format!(r#"{{"type":"union","children":[{{"type":"sphere","radius":0.5}},{child}]}}"#);
        let f = CsgNode::from_json(&text).unwrap().compile().unwrap();
        let e = KdTree::build(&f, &Grid::cube(1.0, 8), &Settings::default())
            .expect_err("out of the noise's reach");
        assert!(
            matches!(&e, Error::NonFiniteSample { cause: Some(_), .. }),
            "{e:?}"
        );
        let msg = e.to_string();
        for needle in [
            "the field returned NaN at (",
            path,
            "noise evaluated too far from its origin",
            "past 1e15",
            "keep the node within",
        ] {
            assert!(msg.contains(needle), "missing `{needle}` in {msg}");
        }
    }
}

#[test]
fn a_world_over_the_budget_is_refused_before_any_chunk_exists() {
    let s = Settings::default();
    let e = World::bounded(
        Vec3::splat(-1.0),
        2.0 / 4096.0,
        16,
        UVec3::splat(256),
        0.01,
        s.clone(),
    )
    .err()
    .unwrap();
    assert!(matches!(e, Error::TooLarge { .. }), "{e:?}");
    let msg = e.to_string();
    assert!(
        msg.contains("a world of 256x256x256 chunks of 16^3 cells"),
        "{msg}"
    );
    assert!(msg.contains("memory budget"), "{msg}");
    // The default world of the command line fits.
    assert!(World::bounded(Vec3::splat(-1.0), 2.0 / 48.0, 16, UVec3::splat(3), 0.01, s).is_ok());
}

#[test]
fn a_failed_save_leaves_the_existing_file_alone() {
    // A directory of its own: other tests write files concurrently.
    let dir = tmp("save");
    std::fs::create_dir_all(&dir).unwrap();
    let keep = dir.join("keep.stl");
    std::fs::write(&keep, "keep").unwrap();
    let mesh = IndexedMesh::default();
    let e = mesh.save(&keep).unwrap_err().to_string();
    assert!(e.contains("use a .obj or .ply extension"), "{e}");
    assert!(IndexedMesh::check_path(&keep).is_err());
    assert_eq!(std::fs::read_to_string(&keep).unwrap(), "keep");
    // A good save replaces the file whole and leaves no temporary behind.
    let obj = dir.join("good.obj");
    std::fs::write(&obj, "old").unwrap();
    IndexedMesh::check_path(&obj).unwrap();
    mesh.save(&obj).unwrap();
    assert_ne!(std::fs::read_to_string(&obj).unwrap(), "old");
    let stray: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(stray.is_empty(), "{stray:?}");
    let e = IndexedMesh::check_path(std::path::Path::new("/nonexistent/dir/m.obj"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("does not exist"), "{e}");
}

#[test]
fn nifti_is_written_only_under_a_nifti_name() {
    let raw = tmp("p.raw");
    let e = volume::write_nifti(&raw, &volume::phantom(8).unwrap())
        .unwrap_err()
        .to_string();
    assert!(e.contains(".nii or .nii.gz"), "{e}");
    assert!(!raw.exists());
    let upper = tmp("P.NII.GZ");
    volume::write_nifti(&upper, &volume::phantom(8).unwrap()).unwrap();
    let vol = volume::load_nifti(&upper, 1.5, Inside::Above).unwrap();
    assert_eq!(vol.dims, UVec3::splat(8));
    // Too few voxels are raised to 2 per axis (0 used to underflow), all finite.
    let tiny = volume::phantom(0).unwrap();
    assert_eq!(tiny.dims, UVec3::splat(2));
    assert!(tiny.data.iter().all(|v| v.is_finite()));
}

#[test]
fn a_phantom_too_large_for_memory_is_an_error() {
    // More voxels than memory can hold (or than a u64 counts): an error that
    // names them, not an abort.
    for n in [1 << 20, u32::MAX] {
        for scanned in [false, true] {
            let made = if scanned {
                volume::phantom_scanned(n)
            } else {
                volume::phantom(n)
            };
            let Err(e) = made else {
                panic!("a phantom of {n}^3 voxels was made");
            };
            let e = e.to_string();
            assert!(e.contains(&format!("the phantom's {n}^3 voxels")), "{e}");
        }
    }
}

#[test]
fn an_endless_scene_file_is_refused_at_its_limit() {
    let e = Input::scene_file(std::path::Path::new("/dev/zero"))
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.starts_with("/dev/zero: ") && e.contains("longer than 67108864 bytes"),
        "{e}"
    );
}
