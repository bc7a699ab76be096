//! The options subcommands share: the input (`mesh`, `compare`, `world`), the
//! meshing run (`mesh`, `compare`) and the memory budget (every command that
//! allocates).

use kdcontour::boundary::CappedField;
use kdcontour::budget::Size;
use kdcontour::field::volume::Inside;
use kdcontour::io::input::{parse_uvec3, parse_vec3, Input as Loaded};
use kdcontour::io::volume::{self, VoxelType};
use kdcontour::validate::Checks;
use kdcontour::{Boundary, Budget, Error, Field, Grid, Settings};
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
    #[arg(
        long,
        value_parser = parse_vec3,
        default_value = "1,1,1",
        allow_hyphen_values = true
    )]
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

/// A scene input only (`world`, which meshes [-1, 1]^3): no volume or mesh
/// options, so its help lists only what it accepts.
#[derive(clap::Args)]
#[group(required = true, multiple = false)]
pub struct SceneInput {
    /// A built-in scene (see `kdcontour scenes`).
    #[arg(long)]
    scene: Option<String>,
    /// A JSON CSG scene file (format: assets/scenes/README.md).
    #[arg(long)]
    scene_file: Option<PathBuf>,
}

/// `--memory-budget`, on every command that allocates.
#[derive(clap::Args)]
pub struct Memory {
    /// The most memory the command may use, for everything it holds at once (a
    /// loaded volume or mesh and the grid meshed from it; every chunk of a world
    /// together), checked before anything is allocated: bytes, or a size with a
    /// unit, e.g. 512MB or 4GiB (KB, MB, GB, TB are powers of 1000; KiB, MiB,
    /// GiB, TiB of 1024).
    #[arg(
        long = "memory-budget",
        value_name = "SIZE",
        default_value = "4GiB",
        value_parser = Budget::parse,
        allow_negative_numbers = true
    )]
    pub budget: Budget,
}

impl SceneInput {
    /// The scene or scene file named on the command line.
    pub fn load(&self) -> Result<Loaded, String> {
        load_scene(self.scene.as_deref(), self.scene_file.as_deref())
            .expect("clap requires one input")
    }
}

/// The built-in scene `name` or the scene file `file`, whichever is given.
fn load_scene(name: Option<&str>, file: Option<&Path>) -> Option<Result<Loaded, String>> {
    let loaded = match (name, file) {
        (Some(name), _) => Loaded::scene(name),
        (_, Some(path)) => Loaded::scene_file(path),
        _ => return None,
    };
    Some(loaded.map_err(|e| e.to_string()))
}

impl Input {
    /// The scene, scene file, volume or mesh named on the command line, loaded
    /// within `budget`.
    pub fn load(&self, budget: Budget) -> Result<Loaded, String> {
        let src = &self.source;
        if let Some(loaded) = load_scene(src.scene.as_deref(), src.scene_file.as_deref()) {
            loaded
        } else if let Some(path) = &src.volume {
            self.volume(path, budget)
        } else {
            Loaded::mesh_within(src.mesh.as_ref().expect("clap requires one input"), budget)
                .map_err(|e| e.to_string())
        }
    }

    /// The volume at `path`: NIfTI-1 by its extension, else raw voxels laid out as
    /// `--dims`, `--type` and `--spacing` say. An `--iso` outside the voxels'
    /// values is an error (there would be no surface).
    fn volume(&self, path: &Path, budget: Budget) -> Result<Loaded, String> {
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
            volume::load_nifti_within(path, iso, inside, budget)
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
            let spacing = self.spacing;
            let layout = volume::RawLayout { dims, ty, spacing };
            volume::load_raw_within(path, layout, iso, inside, budget)
        }
        .map_err(|e| e.to_string())?;
        vol.check_iso(iso)
            .map_err(|m| format!("{}: --iso: {m}", path.display()))?;
        Ok(Loaded::volume(path, vol))
    }
}

/// Options `mesh` and `compare` share.
#[derive(clap::Args)]
pub struct RunArgs {
    /// Cells per axis (along the longest side for volumes and meshes) [default:
    /// one cell per voxel for volumes, 64 for everything else].
    #[arg(long = "res", value_name = "RES")]
    asked_res: Option<u32>,
    /// The resolution meshed at: `--res`, or the default for the input, once
    /// [`RunArgs::prepare`] has seen it.
    #[arg(skip)]
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
    /// What a surface does where it leaves the grid: `open` (ends half a cell
    /// inside) or `capped` (closed by caps on the grid's faces; checked against
    /// the field cut by the grid's box).
    #[arg(long, default_value = "open")]
    pub boundary: String,
    /// How much to check the mesh: `quick` (topology, faces, the error of
    /// vertices and centroids), `standard` (also crossing and overlapping
    /// triangles, the two-sided distance and the lost surface, sampled on the
    /// grid and the grid shifted by half a cell: a few times the meshing's own
    /// field samples), or `full` (the surface also sampled on lattices 3 and 12
    /// times finer than the grid, where the grid may miss it: tens of times the
    /// meshing's samples).
    #[arg(long, default_value = "standard", value_parser = ["quick", "standard", "full"])]
    pub checks: String,
    /// The same as `--checks quick`.
    #[arg(long)]
    pub quick_checks: bool,
    /// Let the tree merge nodes across material borders (for a field with
    /// materials: fewer triangles, blurred borders). Borders are kept crisp by
    /// default.
    #[arg(long)]
    pub no_material_borders: bool,
    #[command(flatten)]
    pub memory: Memory,
}

impl RunArgs {
    /// Checks the threshold, loads the input and fits its grid: the set-up `mesh`
    /// and `compare` share. The grid's build gets what is left of the budget once
    /// the input is held. Sets [`RunArgs::res`]: `--res`, else one cell per voxel
    /// for a volume (refused before anything is allocated, with the `--res` that
    /// fits, when that grid is over the budget), else 64.
    pub fn prepare(&mut self, input: &Input) -> Result<(Loaded, Grid, Settings), String> {
        if !self.threshold.is_finite() {
            return Err(format!(
                "--threshold must be a finite number, got {}",
                self.threshold
            ));
        }
        let boundary = Boundary::parse(&self.boundary).ok_or(format!(
            "--boundary must be `open` or `capped`, got `{}`",
            self.boundary
        ))?;
        let budget = self.memory.budget;
        let loaded = input.load(budget)?;
        for w in &loaded.warnings {
            eprintln!("warning: {w}");
        }
        let left = budget.less(loaded.held_bytes);
        self.res = self.asked_res.or(loaded.native_res).unwrap_or(DEFAULT_RES);
        let grid = loaded.grid(self.res).map_err(|e| e.to_string())?;
        if self.asked_res.is_none() {
            check_native(&loaded, &grid, self.res, left)?;
        }
        Ok((
            loaded,
            grid,
            Settings {
                boundary,
                material_borders: !self.no_material_borders,
                ..settings(self.threads, left)
            },
        ))
    }

    /// What to check a mesh of `field` on `grid` for (`--checks`).
    pub fn checks<'a>(&self, field: &'a dyn Field, grid: &'a Grid) -> Checks<'a> {
        match (self.quick_checks, self.checks.as_str()) {
            (true, _) | (_, "quick") => Checks {
                field: Some((field, grid.cell_size)),
                ..Default::default()
            },
            (_, "full") => Checks::all(field, grid),
            _ => Checks::standard(field, grid),
        }
    }
}

/// Cells per axis of scenes and meshes when `--res` is not given.
const DEFAULT_RES: u32 = 64;

/// Refuses a volume's native-resolution grid (`res` cells along its longest side)
/// that would not fit in `left` bytes, before anything is allocated, naming the
/// finest `--res` that fits.
fn check_native(loaded: &Loaded, grid: &Grid, res: u32, left: Budget) -> Result<(), String> {
    let needed = kdcontour::hermite::estimate_bytes(grid);
    if grid.validate().is_err() || needed <= left.get() {
        return Ok(()); // the build says what is wrong with an invalid grid
    }
    let fits = |r: u32| {
        loaded
            .grid(r)
            .is_ok_and(|g| kdcontour::hermite::estimate_bytes(&g) <= left.get())
    };
    // The estimate grows with res: the finest fitting res by bisection.
    let (mut lo, mut hi) = (0, res);
    while hi - lo > 1 {
        let mid = lo + (hi - lo) / 2;
        if fits(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let fix = if lo >= 1 && fits(lo) {
        format!("pass --res {lo} or less to mesh it coarser, or raise --memory-budget")
    } else {
        "raise --memory-budget".to_string()
    };
    let c = grid.cells;
    Err(format!(
        "{}: at its native resolution (one cell per voxel, res {res}: {}x{}x{} cells) the grid needs about {}, over the {} --memory-budget leaves once the volume's {} are held; {fix}",
        loaded.name,
        c.x,
        c.y,
        c.z,
        Size(needed),
        Size(left.get()),
        Size(loaded.held_bytes)
    ))
}

/// The field a capped mesh of `field` on `grid` is checked against (the field cut
/// by the grid's box), or `None` for open meshes (checked against `field`).
pub fn capped<'a>(field: &'a dyn Field, grid: &Grid, s: &Settings) -> Option<CappedField<'a>> {
    (s.boundary == Boundary::Capped).then(|| CappedField::new(field, grid))
}

/// Default settings on `threads` worker threads (0 = all cores) within `budget`.
pub fn settings(threads: usize, budget: Budget) -> Settings {
    Settings {
        threads,
        memory_budget: budget,
        ..Default::default()
    }
}

/// A failed build of `loaded`, named; a grid over the budget says how much of
/// `--memory-budget` the input itself already holds.
pub fn build_error(loaded: &Loaded, e: Error) -> String {
    match e {
        Error::MemoryBudget { .. } if loaded.held_bytes > 0 => format!(
            "{}: {e} (that is what --memory-budget leaves once the input's {} are held)",
            loaded.name,
            Size(loaded.held_bytes)
        ),
        e => format!("{}: {e}", loaded.name),
    }
}

/// Checks `--out` before any work: a mesh name the writer knows, in a directory
/// that takes new files (an existing file is not touched; it is replaced only
/// once the new mesh is complete).
pub fn check_out(out: Option<&Path>) -> Result<(), String> {
    match out {
        Some(p) => kdcontour::IndexedMesh::check_path(p).map_err(|e| format!("--out {e}")),
        None => Ok(()),
    }
}
