//! The memory budget (issue 14): one [`Budget`] reaches every loader and every
//! grid and world build, a budget too small for the input refuses it before
//! anything is allocated with a message naming the budget and how to raise it,
//! and the default budget still takes the normal inputs.

use glam::{IVec3, UVec3, Vec3};
use kdcontour::field::mesh_sdf::MeshSdf;
use kdcontour::field::volume::Inside;
use kdcontour::io::input::Input;
use kdcontour::io::mesh::{load_mesh, load_mesh_within, mesh_from_bytes_within, MeshFormat};
use kdcontour::io::volume::{self, load_raw_within, RawLayout, VoxelType};
use kdcontour::world::Layout;
use kdcontour::{Budget, Error, Grid, IndexedMesh, KdTree, Settings, World};
use std::path::PathBuf;

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("kdcontour-budget-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// Checks that `e` refuses `what` over the budget `budget`, naming the flag.
fn over(e: impl std::fmt::Display, what: &str, budget: &str) {
    let e = e.to_string();
    for needle in [
        what,
        &format!("over the memory budget of {budget}"),
        "--memory-budget",
    ] {
        assert!(e.contains(needle), "missing `{needle}` in {e}");
    }
}

#[test]
fn a_small_budget_refuses_a_volume_before_reading_it() {
    // /dev/zero never ends: only a check before reading can answer at once.
    let dims = UVec3::new(100, 100, 100);
    let small = Budget::bytes(1 << 20);
    let load = |budget| {
        let layout = RawLayout {
            dims,
            ty: VoxelType::U16,
            spacing: Vec3::ONE,
        };
        load_raw_within("/dev/zero".as_ref(), layout, 0.5, Inside::Above, budget)
    };
    over(load(small).unwrap_err(), "100x100x100 voxels", "1 MiB");
    // The default reads it (and finds it longer than the dims say).
    let e = load(Budget::DEFAULT).unwrap_err().to_string();
    assert!(e.contains("longer than 2000000 bytes"), "{e}");
    // NIfTI: the header's volume, after inflation, against the budget.
    let nii = tmp("head.nii.gz");
    volume::write_nifti(&nii, &volume::phantom(32).unwrap()).unwrap();
    let e = volume::load_nifti_within(&nii, 1.5, Inside::Above, Budget::bytes(100_000));
    over(e.unwrap_err(), "32x32x32 voxels", "97.7 KiB");
    let vol = volume::load_nifti(&nii, 1.5, Inside::Above).unwrap();
    assert_eq!(vol.dims, UVec3::splat(32));
    // The loaded volume holds its voxels: what meshes it gets the rest.
    let input = Input::volume(&nii, vol);
    assert_eq!(input.held_bytes, 32 * 32 * 32 * 4);
}

#[test]
fn a_small_budget_refuses_a_mesh_by_its_element_counts() {
    let sphere = kdcontour::mesh(
        &*kdcontour::scenes::scene("sphere").unwrap().field,
        &Grid::cube(1.0, 16),
        0.01,
        &Settings::default(),
    )
    .unwrap();
    let (v, t) = (sphere.positions.len(), sphere.triangle_count());
    // What the parsed mesh and its distance field take.
    let needed = 12 * (v + t) as u64 + MeshSdf::estimate_bytes(v as u64, t as u64);
    for (name, format) in [
        ("sphere.ply", MeshFormat::Ply),
        ("sphere.obj", MeshFormat::Obj),
    ] {
        let path = tmp(name);
        sphere.save(&path).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let e = mesh_from_bytes_within(&bytes, format, Budget::bytes(needed - 1)).unwrap_err();
        over(
            e,
            &format!("a mesh of {v} vertices and {t} faces"),
            &Budget::bytes(needed - 1).to_string(),
        );
        let fits = mesh_from_bytes_within(&bytes, format, Budget::bytes(needed)).unwrap();
        assert_eq!(fits.triangles.len(), t, "{name}");
        // A file over an eighth of the budget is not read whole.
        let e = load_mesh_within(&path, Budget::bytes(bytes.len() as u64 * 4)).unwrap_err();
        assert!(
            e.to_string().contains("an eighth of the memory budget"),
            "{e}"
        );
        assert_eq!(load_mesh(&path).unwrap().triangles.len(), t, "{name}");
        let input = Input::mesh_within(&path, Budget::DEFAULT).unwrap();
        assert!(input.held_bytes >= 12 * (v + t) as u64, "{name}");
    }
    // A PLY header's counts are checked before any row is read: the rows of a
    // million vertices are not there, the budget answers first.
    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    let e = mesh_from_bytes_within(ply.as_bytes(), MeshFormat::Ply, Budget::bytes(64));
    over(
        e.unwrap_err(),
        "a mesh of 3 vertices and 1 faces",
        "64 bytes",
    );
    assert!(mesh_from_bytes_within(ply.as_bytes(), MeshFormat::Ply, Budget::DEFAULT).is_ok());
}

#[test]
fn a_small_budget_refuses_grids_and_whole_worlds_before_building() {
    let small = Settings {
        memory_budget: Budget::bytes(8 << 20),
        threads: 1,
        ..Default::default()
    };
    let field = kdcontour::scenes::scene("sphere").unwrap().field;
    let e = KdTree::build(&*field, &Grid::cube(1.0, 128), &small)
        .err()
        .unwrap();
    assert!(matches!(e, Error::MemoryBudget { .. }), "{e:?}");
    over(e, "a grid of 2097152 cells", "8 MiB");
    assert!(KdTree::build(&*field, &Grid::cube(1.0, 16), &small).is_ok());
    // The world's chunks together: 3x3x3 chunks of 32 cells need more than one
    // chunk of them does.
    let world = |settings: &Settings| {
        World::bounded(
            Vec3::splat(-1.0),
            2.0 / 96.0,
            32,
            UVec3::splat(3),
            0.01,
            settings.clone(),
        )
    };
    over(
        world(&small).err().unwrap(),
        "a world of 3x3x3 chunks of 32^3 cells",
        "8 MiB",
    );
    let one = Settings {
        threads: 1,
        ..Default::default()
    };
    let mut w = world(&one).unwrap();
    w.build_all(&*field).unwrap();
    assert!(w.retained_bytes() > 0);
    // A level world: its level-0 chunk count, before any layout is built.
    over(
        World::check_chunk_count(1 << 30, 4, &one).unwrap_err(),
        "a world of 1073741824 chunks of 4^3 cells",
        "4 GiB",
    );
    let layout = Layout::uniform(IVec3::ZERO, IVec3::splat(8), 1).unwrap();
    let tiny = Settings {
        memory_budget: Budget::bytes(1 << 10),
        ..one.clone()
    };
    let e = World::new(Vec3::ZERO, 0.1, 8, layout.clone(), 0.01, tiny)
        .err()
        .unwrap();
    over(e, "a world of 64 chunks of 8^3 cells", "1 KiB");
    assert!(World::new(Vec3::ZERO, 0.1, 8, layout, 0.01, one).is_ok());
}

#[test]
fn the_default_budget_meshes_the_normal_inputs() {
    let s = Settings::default();
    assert_eq!(s.memory_budget, Budget::DEFAULT);
    assert_eq!(s.memory_budget.get(), 4 << 30);
    let nii = tmp("normal.nii");
    volume::write_nifti(&nii, &volume::phantom(48).unwrap()).unwrap();
    let input = Input::volume(&nii, volume::load_nifti(&nii, 1.5, Inside::Above).unwrap());
    let grid = input.grid(48).unwrap();
    let left = Settings {
        memory_budget: s.memory_budget.less(input.held_bytes),
        ..s
    };
    let mesh: IndexedMesh = kdcontour::mesh(&*input.field, &grid, 0.01, &left).unwrap();
    assert!(mesh.triangle_count() > 0);
}
