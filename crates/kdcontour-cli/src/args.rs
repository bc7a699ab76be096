//! The options subcommands share: the input (`mesh`, `compare`, `world`) and the
//! meshing run (`mesh`, `compare`).

use kdcontour::field::volume::Inside;
use kdcontour::io::input::{parse_uvec3, parse_vec3, Input as Loaded};
use kdcontour::io::volume::{self, VoxelType};
use kdcontour::validate::Checks;
use kdcontour::{Field, Grid, Settings};
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct Input {
    #[command(flatten)]
    source: Source,
    /// Raw volumes: voxels along x, y, z (e.g. 256,256,128).
    #[arg(long, value_parser = parse_uvec3)]
    dims: Option<glam::UVec3>,
    /// Raw volumes: voxel type, u8 | u16 | i16 | f32 (little endian).
    #[arg(long = "type")]
    voxel_type: Option<String>,
    /// Raw volumes: voxel spacing along x, y, z (world units).
    #[arg(long, value_parser = parse_vec3, default_value = "1,1,1")]
    spacing: glam::Vec3,
    /// Volumes: the iso value of the surface.
    #[arg(long, allow_negative_numbers = true)]
    iso: Option<f32>,
    /// Volumes: values `above` (CT: bone) or `below` the iso value are inside.
    #[arg(long, default_value = "above")]
    inside: String,
}

#[derive(clap::Args)]
#[group(required = true, multiple = false)]
struct Source {
    /// A built-in scene (see `kdcontour scenes`).
    #[arg(long)]
    scene: Option<String>,
    /// A JSON CSG scene file (format: assets/scenes/README.md).
    #[arg(long)]
    scene_file: Option<PathBuf>,
    /// A volume: NIfTI-1 (.nii, .nii.gz) or raw voxels (with --dims and --type).
    #[arg(long)]
    volume: Option<PathBuf>,
    /// A triangle mesh (.obj, .ply) meshed as a signed distance field.
    #[arg(long)]
    mesh: Option<PathBuf>,
}

impl Input {
    /// The scene, scene file, volume or mesh named on the command line.
    pub fn load(&self) -> Result<Loaded, String> {
        let src = &self.source;
        let loaded = if let Some(name) = &src.scene {
            Loaded::scene(name)
        } else if let Some(path) = &src.scene_file {
            Loaded::scene_file(path)
        } else if let Some(path) = &src.volume {
            return self.volume(path);
        } else {
            Loaded::mesh(src.mesh.as_ref().expect("clap requires one input"))
        };
        loaded.map_err(|e| e.to_string())
    }

    /// The volume at `path`: NIfTI-1 by its extension, else raw voxels laid out as
    /// `--dims`, `--type` and `--spacing` say. Warns when `--iso` is outside the
    /// voxels' values.
    fn volume(&self, path: &Path) -> Result<Loaded, String> {
        let inside = match self.inside.as_str() {
            "above" => Inside::Above,
            "below" => Inside::Below,
            other => {
                return Err(format!(
                    "--inside must be `above` or `below`, got `{other}`"
                ))
            }
        };
        let iso = self
            .iso
            .ok_or("--iso is required with --volume (the value the surface is drawn at)")?;
        let vol = if volume::is_nifti(path) {
            volume::load_nifti(path, iso, inside)
        } else {
            let dims = self
                .dims
                .ok_or("a raw volume needs --dims X,Y,Z (or use a .nii / .nii.gz file)")?;
            let ty = self
                .voxel_type
                .as_deref()
                .ok_or("a raw volume needs --type u8|u16|i16|f32")?;
            let ty = VoxelType::parse(ty)
                .ok_or(format!("--type must be u8, u16, i16 or f32, got `{ty}`"))?;
            volume::load_raw(path, dims, ty, self.spacing, iso, inside)
        }
        .map_err(|e| e.to_string())?;
        let (lo, hi) = vol.range();
        if !(lo..=hi).contains(&iso) {
            eprintln!("warning: iso {iso} is outside the volume's values [{lo}, {hi}]: the mesh will be empty");
        }
        Ok(Loaded::volume(path, vol))
    }
}

/// Options `mesh` and `compare` share.
#[derive(clap::Args)]
pub struct RunArgs {
    /// Cells per axis (along the longest side for volumes and meshes).
    #[arg(long, default_value_t = 64)]
    pub res: u32,
    /// Error threshold in squared cells (negative = uniform Dual Marching Cubes).
    #[arg(long, default_value_t = 0.01, allow_negative_numbers = true)]
    pub threshold: f32,
    /// Worker threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Print JSON lines instead of a summary (one line for `mesh`, one per mesher
    /// for `compare`).
    #[arg(long)]
    pub json: bool,
    /// Skip the costly checks (crossing and overlapping triangles, the two-sided
    /// distance and the lost surface); the others always run.
    #[arg(long)]
    pub quick_checks: bool,
}

impl RunArgs {
    /// Checks the threshold, loads the input and fits its grid: the set-up `mesh`
    /// and `compare` share.
    pub fn prepare(&self, input: &Input) -> Result<(Loaded, Grid, Settings), String> {
        if !self.threshold.is_finite() {
            return Err(format!(
                "--threshold must be a finite number, got {}",
                self.threshold
            ));
        }
        let loaded = input.load()?;
        let grid = loaded.grid(self.res);
        Ok((loaded, grid, threads(self.threads)))
    }

    /// What to check a mesh of `field` on `grid` for.
    pub fn checks<'a>(&self, field: &'a dyn Field, grid: &'a Grid) -> Checks<'a> {
        if self.quick_checks {
            Checks {
                field: Some((field, grid.cell_size)),
                ..Default::default()
            }
        } else {
            Checks::all(field, grid)
        }
    }
}

/// Default settings on `threads` worker threads (0 = all cores).
pub fn threads(threads: usize) -> Settings {
    Settings {
        threads,
        ..Default::default()
    }
}
