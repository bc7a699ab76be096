//! An input as a field with bounds: a built-in scene, a JSON scene file, a loaded
//! volume or a triangle mesh file, and the grid it is meshed on; and the text form
//! of an input's vectors (raw-volume dims and spacing, `X,Y,Z`).

use super::{bad, cut, mesh::load_mesh_within, read_limited};
use crate::budget::Budget;
use crate::error::{Error, Result};
use crate::field::csg::CsgNode;
use crate::field::mesh_sdf::MeshSdf;
use crate::field::volume::SampledVolume;
use crate::field::Field;
use crate::grid::{Grid, MAX_CELLS_PER_AXIS};
use crate::scenes;
use glam::{UVec3, Vec3};
use std::path::Path;

/// A loaded input: its name, its field, and the world box it fills.
pub struct Input {
    /// The scene's name or the file's path, for reports.
    pub name: String,
    /// The field to mesh.
    pub field: Box<dyn Field>,
    /// The box the field fills (volumes and meshes); `None` for scenes, which live
    /// in `[-1, 1]^3`.
    pub bounds: Option<(Vec3, Vec3)>,
    /// Whether the field exists only inside `bounds` (a volume), so every axis of
    /// the box needs cells of its own.
    pub sampled: bool,
    /// Cells along the longest side that give one cell per voxel (volumes, see
    /// [`SampledVolume::native_res`]): the resolution a volume is meshed at unless
    /// one is asked for; `None` for other inputs.
    pub native_res: Option<u32>,
    /// Bytes the field holds (a volume's voxels, a mesh's triangles and tree; 0
    /// for scenes): taken off the budget of whatever meshes it
    /// ([`Budget::less`]), so one budget covers the whole command.
    pub held_bytes: u64,
    /// What the loader fixed and the user should hear about (an inside-out mesh
    /// turned outward).
    pub warnings: Vec<String>,
}

/// The largest scene file read (64 MiB).
pub const MAX_SCENE_FILE: u64 = 64 << 20;

impl Input {
    /// A built-in scene by name (see [`scenes::SCENES`]).
    pub fn scene(name: &str) -> Result<Input> {
        let s = scenes::scene(name)?;
        Ok(Input {
            name: s.name.to_string(),
            field: s.field,
            bounds: None,
            sampled: false,
            native_res: None,
            held_bytes: 0,
            warnings: Vec::new(),
        })
    }

    /// A JSON CSG scene file (at most [`MAX_SCENE_FILE`] bytes), compiled; errors
    /// name the file.
    pub fn scene_file(path: &Path) -> Result<Input> {
        let text = read_scene_text(path)?;
        let node = CsgNode::from_json(&text).map_err(|e| bad(path, e.to_string()))?;
        let field = node.compile().map_err(|e| bad(path, e.to_string()))?;
        Ok(Input {
            name: path.display().to_string(),
            field: Box::new(field),
            bounds: None,
            sampled: false,
            native_res: None,
            held_bytes: 0,
            warnings: Vec::new(),
        })
    }

    /// A volume loaded from `path` (see [`super::volume`]), bounded by its voxels.
    pub fn volume(path: &Path, volume: SampledVolume) -> Input {
        let bounds = volume.bounds();
        Input {
            name: path.display().to_string(),
            native_res: Some(volume.native_res()),
            held_bytes: volume.data.capacity() as u64 * 4,
            field: Box::new(volume),
            bounds: Some(bounds),
            sampled: true,
            warnings: Vec::new(),
        }
    }

    /// An `.obj` or `.ply` triangle mesh as a signed distance field, bounded by its
    /// vertices, within the default budget (see [`Input::mesh_within`]). An
    /// inside-out mesh is turned outward, with a warning ([`MeshSdf::new`]).
    pub fn mesh(path: &Path) -> Result<Input> {
        Input::mesh_within(path, Budget::DEFAULT)
    }

    /// An `.obj` or `.ply` triangle mesh as a signed distance field, bounded by its
    /// vertices; the file and its element counts are checked against `budget`
    /// before they are read ([`load_mesh_within`]).
    pub fn mesh_within(path: &Path, budget: Budget) -> Result<Input> {
        let sdf = MeshSdf::new(&load_mesh_within(path, budget)?);
        let bounds = sdf.bounds();
        let mut warnings = Vec::new();
        if sdf.inside_out() {
            warnings.push(format!(
                "{}: every face of the mesh faces inward (its enclosed volume is negative), so it was meshed turned outward",
                path.display()
            ));
        }
        Ok(Input {
            name: path.display().to_string(),
            held_bytes: sdf.held_bytes(),
            field: Box::new(sdf),
            bounds: Some(bounds),
            sampled: false,
            native_res: None,
            warnings,
        })
    }

    /// The grid to mesh the input on: `[-1, 1]^3` at `res` cells per axis for
    /// scenes; for volumes and meshes, [`Grid::fit`] to the bounds (`res` cells along
    /// the longest side, one cell of margin all round). A volume whose shortest side
    /// would get fewer than 2 cells (its surface would be lost between samples) is
    /// an error naming the `res` that would do.
    pub fn grid(&self, res: u32) -> Result<Grid> {
        let Some((lo, hi)) = self.bounds else {
            return Ok(Grid::cube(1.0, res));
        };
        let grid = Grid::fit(lo, hi, res);
        let size = hi - lo;
        if self.sampled && res > 0 && (size / grid.cell_size).min_element() < 2.0 {
            let need = (2.0 * size.max_element() / size.min_element()).ceil();
            let fix = if need <= MAX_CELLS_PER_AXIS as f32 {
                format!("use res {need} or more, or check the voxel spacing")
            } else {
                "no res can mesh it: check the voxel spacing".to_string()
            };
            return Err(Error::Input {
                path: self.name.clone(),
                message: format!(
                    "the volume spans {:e} x {:e} x {:e} world units; at res {res} its shortest side gets {:.2} cells and at least 2 are needed: {fix}",
                    size.x,
                    size.y,
                    size.z,
                    size.min_element() / grid.cell_size
                ),
            });
        }
        Ok(grid)
    }
}

/// The text of a scene file: at most [`MAX_SCENE_FILE`] bytes (an endless file
/// such as `/dev/zero` is refused after that), UTF-8; errors name the file.
pub fn read_scene_text(path: &Path) -> Result<String> {
    let bytes = read_limited(path, MAX_SCENE_FILE, "a scene file may have")?;
    String::from_utf8(bytes).map_err(|e| {
        bad(
            path,
            format!("byte {} is not UTF-8 text", e.utf8_error().valid_up_to()),
        )
    })
}

/// Parses three comma-separated finite numbers, `X,Y,Z` (spaces allowed).
pub fn parse_triple(s: &str) -> std::result::Result<[f32; 3], String> {
    triple(s, |t| {
        t.parse::<f32>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| format!("`{}` is not a finite number", cut(t)))
    })
}

/// Three comma-separated values parsed by `one`.
fn triple<T: std::fmt::Debug>(
    s: &str,
    one: impl Fn(&str) -> std::result::Result<T, String>,
) -> std::result::Result<[T; 3], String> {
    let v: Vec<T> = s
        .split(',')
        .map(|t| one(t.trim()))
        .collect::<std::result::Result<_, _>>()?;
    <[T; 3]>::try_from(v)
        .map_err(|_| format!("`{}`: expected three comma-separated values", cut(s)))
}

/// Parses a vector `X,Y,Z` (a raw volume's voxel spacing, a position).
pub fn parse_vec3(s: &str) -> std::result::Result<Vec3, String> {
    parse_triple(s).map(Vec3::from)
}

/// Parses whole counts `X,Y,Z` (a raw volume's dims, a chunk count), each a
/// whole number from 0 to 4294967295, parsed as an integer (never through a float).
pub fn parse_uvec3(s: &str) -> std::result::Result<UVec3, String> {
    triple(s, |t| {
        t.parse::<u32>()
            .map_err(|_| format!("`{}` is not a whole number from 0 to {}", cut(t), u32::MAX))
    })
    .map(UVec3::from)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::volume::phantom;

    #[test]
    fn triples_parse_or_say_what_is_wrong() {
        assert_eq!(parse_triple(" 1, 2.5 ,-3"), Ok([1.0, 2.5, -3.0]));
        assert_eq!(parse_vec3("0.5,0.5,1"), Ok(Vec3::new(0.5, 0.5, 1.0)));
        assert_eq!(parse_uvec3("256,256,128"), Ok(UVec3::new(256, 256, 128)));
        assert!(parse_triple("1,x,3")
            .unwrap_err()
            .contains("`x` is not a finite number"));
        assert!(parse_triple("1,2").unwrap_err().contains("three"));
        assert!(parse_triple("1,2,3,4").unwrap_err().contains("three"));
        assert!(parse_uvec3("1,2.5,3").unwrap_err().contains("whole"));
        assert!(parse_uvec3("1,-2,3").unwrap_err().contains("whole"));
        // Non-finite numbers are refused, counts are integers (no f32 rounding).
        for bad in ["NaN,0,0", "0,inf,0", "0,0,-infinity", "1e39,0,0"] {
            let e = parse_vec3(bad).unwrap_err();
            assert!(e.contains("is not a finite number"), "{bad}: {e}");
        }
        assert_eq!(
            parse_uvec3("16777217,2,2"),
            Ok(UVec3::new(16_777_217, 2, 2))
        );
        assert!(parse_uvec3("4294967296,2,2")
            .unwrap_err()
            .contains("4294967295"));
        let long = format!("1,2,{}", "9".repeat(10_000));
        assert!(parse_uvec3(&long).unwrap_err().len() < 200);
    }

    #[test]
    fn scenes_fill_the_unit_cube() {
        let input = Input::scene("torus").unwrap();
        assert_eq!((input.name.as_str(), input.bounds), ("torus", None));
        assert_eq!(input.grid(24).unwrap(), Grid::cube(1.0, 24));
        assert!(Input::scene("teapot").is_err());
    }

    #[test]
    fn volumes_are_fitted_to_their_voxels() {
        let vol = phantom(9).unwrap();
        let (lo, hi) = vol.bounds();
        let input = Input::volume(Path::new("head.nii"), vol);
        assert_eq!(input.name, "head.nii");
        assert_eq!(input.bounds, Some((lo, hi)));
        assert_eq!(input.native_res, Some(8));
        let g = input.grid(16).unwrap();
        assert_eq!(g, Grid::fit(lo, hi, 16));
        assert_eq!(g.cells, UVec3::splat(18));
        assert!(input.field.value(Vec3::ZERO).is_finite());
    }

    #[test]
    fn file_errors_name_the_file() {
        let missing = Path::new("/nonexistent/scene.json");
        let e = Input::scene_file(missing).err().unwrap().to_string();
        assert!(e.starts_with("/nonexistent/scene.json: "), "{e}");
        let e = Input::mesh(Path::new("/nonexistent/m.obj")).err().unwrap();
        assert!(e.to_string().contains("/nonexistent/m.obj"), "{e}");
    }
}
