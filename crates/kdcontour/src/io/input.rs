//! An input as a field with bounds: a built-in scene, a JSON scene file, a loaded
//! volume or a triangle mesh file, and the grid it is meshed on; and the text form
//! of an input's vectors (raw-volume dims and spacing, `X,Y,Z`).

use super::{bad, mesh::load_mesh};
use crate::error::{Error, Result};
use crate::field::csg::CsgNode;
use crate::field::mesh_sdf::MeshSdf;
use crate::field::volume::SampledVolume;
use crate::field::Field;
use crate::grid::Grid;
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
}

impl Input {
    /// A built-in scene by name (see [`scenes::SCENES`]).
    pub fn scene(name: &str) -> Result<Input> {
        let s = scenes::scene(name)?;
        Ok(Input {
            name: s.name.to_string(),
            field: s.field,
            bounds: None,
        })
    }

    /// A JSON CSG scene file, compiled; errors name the file.
    pub fn scene_file(path: &Path) -> Result<Input> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::Io {
            path: path.display().to_string(),
            message: e.to_string(),
        })?;
        let node = CsgNode::from_json(&text).map_err(|e| bad(path, e.to_string()))?;
        let field = node.compile().map_err(|e| bad(path, e.to_string()))?;
        Ok(Input {
            name: path.display().to_string(),
            field: Box::new(field),
            bounds: None,
        })
    }

    /// A volume loaded from `path` (see [`super::volume`]), bounded by its voxels.
    pub fn volume(path: &Path, volume: SampledVolume) -> Input {
        let bounds = volume.bounds();
        Input {
            name: path.display().to_string(),
            field: Box::new(volume),
            bounds: Some(bounds),
        }
    }

    /// An `.obj` or `.ply` triangle mesh as a signed distance field, bounded by its
    /// vertices.
    pub fn mesh(path: &Path) -> Result<Input> {
        let sdf = MeshSdf::new(&load_mesh(path)?);
        let bounds = sdf.bounds();
        Ok(Input {
            name: path.display().to_string(),
            field: Box::new(sdf),
            bounds: Some(bounds),
        })
    }

    /// The grid to mesh the input on: `[-1, 1]^3` at `res` cells per axis for
    /// scenes; for volumes and meshes, [`Grid::fit`] to the bounds (`res` cells along
    /// the longest side, one cell of margin all round).
    pub fn grid(&self, res: u32) -> Grid {
        match self.bounds {
            None => Grid::cube(1.0, res),
            Some((lo, hi)) => Grid::fit(lo, hi, res),
        }
    }
}

/// Parses three comma-separated numbers, `X,Y,Z` (spaces allowed).
pub fn parse_triple(s: &str) -> std::result::Result<[f32; 3], String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|t| {
            t.trim()
                .parse::<f32>()
                .map_err(|_| format!("`{t}` is not a number"))
        })
        .collect::<std::result::Result<_, _>>()?;
    <[f32; 3]>::try_from(v).map_err(|_| format!("`{s}`: expected three comma-separated numbers"))
}

/// Parses a vector `X,Y,Z` (a raw volume's voxel spacing, a position).
pub fn parse_vec3(s: &str) -> std::result::Result<Vec3, String> {
    parse_triple(s).map(Vec3::from)
}

/// Parses whole counts `X,Y,Z` (a raw volume's dims, a chunk count).
pub fn parse_uvec3(s: &str) -> std::result::Result<UVec3, String> {
    let t = parse_triple(s)?;
    if t.iter().any(|v| *v < 0.0 || v.fract() != 0.0) {
        return Err(format!("`{s}`: dims must be whole numbers"));
    }
    Ok(UVec3::new(t[0] as u32, t[1] as u32, t[2] as u32))
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
            .contains("`x` is not a number"));
        assert!(parse_triple("1,2").unwrap_err().contains("three"));
        assert!(parse_triple("1,2,3,4").unwrap_err().contains("three"));
        assert!(parse_uvec3("1,2.5,3").unwrap_err().contains("whole"));
        assert!(parse_uvec3("1,-2,3").unwrap_err().contains("whole"));
    }

    #[test]
    fn scenes_fill_the_unit_cube() {
        let input = Input::scene("torus").unwrap();
        assert_eq!((input.name.as_str(), input.bounds), ("torus", None));
        assert_eq!(input.grid(24), Grid::cube(1.0, 24));
        assert!(Input::scene("teapot").is_err());
    }

    #[test]
    fn volumes_are_fitted_to_their_voxels() {
        let vol = phantom(9);
        let (lo, hi) = vol.bounds();
        let input = Input::volume(Path::new("head.nii"), vol);
        assert_eq!(input.name, "head.nii");
        assert_eq!(input.bounds, Some((lo, hi)));
        let g = input.grid(16);
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
