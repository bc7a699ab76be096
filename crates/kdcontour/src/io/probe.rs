//! Every byte-level loader by name: the entry points the fuzz targets in `fuzz/`
//! call, and that the stable test `tests/fuzz_regressions.rs` replays the inputs
//! they found through, so both exercise exactly the same code.

use super::input::Input;
use super::mesh::{mesh_from_bytes, MeshFormat};
use super::volume::{parse_nifti, raw_from_bytes, VoxelType};
use crate::field::mesh_sdf::MeshSdf;
use crate::field::volume::{Inside, SampledVolume};
use crate::{validate, CsgNode, KdTree, MeshReport, Settings};
use glam::{UVec3, Vec3};

/// The loader targets, by the name of their fuzz target.
pub const TARGETS: [&str; 6] = [
    "scene_json",
    "raw_volume",
    "nifti",
    "obj",
    "ply",
    "mesh_any",
];

/// Bytes of the layout prefix [`load`] reads before a raw volume's voxels: dims
/// (three little-endian `u16`), voxel type (low two bits; bit 2 fits the voxel
/// bytes to the dims), spacing (three `i8`, in 1/8 units) and the iso value (`u8`).
pub const RAW_PREFIX: usize = 11;

/// Loads `data` with the loader `target` (one of [`TARGETS`] but `mesh_any`),
/// as the command line would: a refusal is a message, never a panic.
pub fn load(target: &str, data: &[u8]) -> Result<Input, String> {
    let named = |field, bounds, sampled| Input {
        name: target.to_string(),
        field,
        bounds,
        sampled,
        native_res: None,
        held_bytes: 0,
        warnings: Vec::new(),
    };
    match target {
        "scene_json" => {
            let text = std::str::from_utf8(data).map_err(|e| e.to_string())?;
            let node = CsgNode::from_json(text).map_err(|e| e.to_string())?;
            let field = node.compile().map_err(|e| e.to_string())?;
            Ok(named(Box::new(field), None, false))
        }
        "raw_volume" => {
            if data.len() < RAW_PREFIX {
                return Err("shorter than the layout prefix".into());
            }
            let (p, voxels) = data.split_at(RAW_PREFIX);
            let u16_at = |i: usize| u16::from_le_bytes([p[i], p[i + 1]]) as u32;
            let dims = UVec3::new(u16_at(0), u16_at(2), u16_at(4));
            let ty = [
                VoxelType::U8,
                VoxelType::U16,
                VoxelType::I16,
                VoxelType::F32,
            ][p[6] as usize % 4];
            let spacing = Vec3::new(p[7] as i8 as f32, p[8] as i8 as f32, p[9] as i8 as f32) / 8.0;
            // Bit 2 of the type byte fits the voxel bytes to the dims (cut, or
            // padded with zeros up to 1 MiB), so decoding and meshing are reached
            // without the fuzzer having to guess the exact length.
            let mut fitted;
            let mut voxels = voxels;
            let need = dims.as_u64vec3().element_product() * ty.size() as u64;
            if p[6] & 4 != 0 && need <= 1 << 20 {
                fitted = voxels.to_vec();
                fitted.resize(need as usize, 0);
                voxels = &fitted;
            }
            let vol = raw_from_bytes(voxels, dims, ty, spacing, p[10] as f32, Inside::Above)?;
            volume_input(vol, named)
        }
        "nifti" => {
            let (dims, spacing, data) = parse_nifti(data)?;
            let vol = SampledVolume {
                dims,
                spacing,
                origin: Vec3::ZERO,
                data,
                iso: 0.0,
                inside: Inside::Above,
            };
            let (lo, hi) = vol.range();
            let vol = SampledVolume {
                iso: lo + (hi - lo) / 2.0,
                ..vol
            };
            if !vol.iso.is_finite() {
                return Err("the voxel range is not finite".into());
            }
            volume_input(vol, named)
        }
        "obj" | "ply" => {
            let format = if target == "obj" {
                MeshFormat::Obj
            } else {
                MeshFormat::Ply
            };
            let sdf = MeshSdf::new(&mesh_from_bytes(data, format)?);
            let bounds = sdf.bounds();
            Ok(named(Box::new(sdf), Some(bounds), false))
        }
        other => Err(format!("unknown target `{other}`")),
    }
}

/// A volume as an input, once a surface at its iso value can exist.
fn volume_input(
    vol: SampledVolume,
    named: impl FnOnce(Box<dyn crate::Field>, Option<(Vec3, Vec3)>, bool) -> Input,
) -> Result<Input, String> {
    vol.check_iso(vol.iso)?;
    let bounds = vol.bounds();
    Ok(named(Box::new(vol), Some(bounds), true))
}

/// The `mesh_any` target: the first byte picks a loader, the rest is its input;
/// whatever loads is meshed at res 8 on one thread (budget 256 MiB) and checked
/// with [`validate()`]. `None` when the input or its meshing was refused (every
/// refusal is an error value; a panic is a bug).
pub fn mesh_any(data: &[u8]) -> Option<MeshReport> {
    let (&pick, rest) = data.split_first()?;
    let target = TARGETS[pick as usize % (TARGETS.len() - 1)];
    let input = load(target, rest).ok()?;
    let grid = input.grid(8).ok()?;
    let settings = Settings {
        threads: 1,
        memory_budget: crate::Budget::bytes(256 << 20),
        ..Default::default()
    };
    let tree = KdTree::build(&*input.field, &grid, &settings).ok()?;
    let mesh = tree.mesh(0.01);
    Some(validate(&mesh, Some((&*input.field, grid.cell_size))))
}
