//! `kdcontour mesh`: one input through one mesher (the k-d tree unless
//! `--mesher` names another), with size, times and checks.

use crate::args::{Input, RunArgs};
use crate::output::{json_line, print_checks};
use crate::progress::Progress;
use kdcontour::meshers::{self, Mesher, Timings};
use kdcontour::validate::validate_with;
use kdcontour::{pipeline, Field, Grid, IndexedMesh, KdTree, Partition, Settings};
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args)]
pub struct Mesh {
    #[command(flatten)]
    input: Input,
    #[command(flatten)]
    run: RunArgs,
    /// The mesher: `kdtree`, `octree`, `dmc` (uniform Dual Marching Cubes),
    /// `marching-cubes`, `skeleton-climbing` or `discrete-planes` (Boada and
    /// Navazo's octree of coplanar Discretized Marching Cubes polygons), all on
    /// the same Hermite data.
    #[arg(long, default_value = "kdtree")]
    mesher: String,
    /// Write the mesh to this .obj or .ply file. A field with materials adds
    /// them: PLY vertex properties `material0..3` (uchar ids, heaviest first)
    /// and `weight0..3` (float), OBJ vertex colours (`v x y z r g b`) of each
    /// vertex's dominant material (`kdcontour::material::PALETTE`).
    #[arg(long)]
    out: Option<PathBuf>,
}

pub fn run(args: Mesh) -> Result<(), String> {
    let Mesh {
        input,
        mut run,
        mesher,
        out,
    } = args;
    let names = Mesher::ALL.map(Mesher::name).join(", ");
    let mesher =
        Mesher::parse(&mesher).ok_or(format!("--mesher must be one of {names}, got `{mesher}`"))?;
    crate::args::check_out(out.as_deref())?;
    let (loaded, grid, settings) = run.prepare(&input)?;
    let (scene, field) = (&loaded.name, &*loaded.field);
    let capped = crate::args::capped(field, &grid, &settings);
    let checked = capped
        .as_ref()
        .map_or(field, |c| c as &dyn kdcontour::Field);
    let checks = run.checks(checked, &grid);
    let RunArgs {
        res,
        threshold,
        json,
        ..
    } = run;
    let progress = Progress::new(json);
    let t0 = Instant::now();
    let (mesh, times, tree) = make(mesher, field, &grid, threshold, &settings, &progress)
        .map_err(|e| crate::args::build_error(&loaded, e))?;
    let t1 = Instant::now();
    progress.stage(format!("checking {} triangles", mesh.triangle_count()));
    let report = validate_with(&mesh, &checks);
    let t2 = Instant::now();
    if let Some(path) = &out {
        progress.stage(format!("writing {}", path.display()));
        mesh.save(path).map_err(|e| e.to_string())?;
    }
    progress.finish();
    if json {
        let line = json_line(mesher.name(), scene, res, threshold, &report, &times);
        say!("{line}");
    } else {
        let by = match mesher {
            Mesher::KdTree => String::new(),
            other => format!(", mesher {}", other.name()),
        };
        say!("scene      {scene} at res {res}, threshold {threshold}{by}");
        say!(
            "mesh       {} triangles, {} vertices, {} components, Euler {}",
            report.triangles,
            report.vertices,
            report.components,
            report.euler
        );
        print_checks(&report);
        say!(
            "time       sample {:.2} ms, build {:.2} ms, contour {:.2} ms, total {:.2} ms (checks {:.2} ms)",
            times.sample_ms,
            times.build_ms,
            times.contour_ms,
            (t1 - t0).as_secs_f64() * 1e3,
            (t2 - t1).as_secs_f64() * 1e3
        );
        if let Some(tree) = tree {
            say!(
                "tree       {} nodes, {} components, {} bytes retained ({:.1} per node)",
                tree.node_count(),
                tree.component_count(),
                tree.retained_bytes(),
                tree.retained_bytes() as f64 / tree.node_count().max(1) as f64
            );
        }
        if let Some(p) = out {
            say!("wrote      {}", p.display());
        }
    }
    Ok(())
}

/// Meshes `field` with `mesher`: the trees through [`KdTree::build`] (returned,
/// for their size), below threshold 0 at full resolution with no tree
/// ([`pipeline::full_from`]), the uniform meshers through [`meshers::run`].
fn make(
    mesher: Mesher,
    field: &dyn Field,
    grid: &Grid,
    threshold: f32,
    settings: &Settings,
    progress: &Progress,
) -> kdcontour::Result<(IndexedMesh, Timings, Option<KdTree>)> {
    progress.stage(format!(
        "sampling and building, {} cells",
        grid.cell_count()
    ));
    let partition = match mesher {
        Mesher::KdTree => Partition::KdTree,
        Mesher::Octree => Partition::Octree,
        Mesher::MarchingCubes
        | Mesher::UniformDmc
        | Mesher::SkeletonClimbing
        | Mesher::DiscretePlanes => {
            let sampled = meshers::sample(field, grid, settings)?;
            progress.stage(format!("meshing ({})", mesher.name()));
            let (mut mesh, times) = meshers::run(mesher, &sampled, threshold, settings)?;
            settings.run(|| kdcontour::material::attach(&mut mesh, field))?;
            return Ok((mesh, times, None));
        }
    };
    if threshold < 0.0 {
        // Full resolution: every cell is its own leaf, and the tree's mesh is
        // the Hermite data's quads; no tree is built (`pipeline::full`, whose
        // crossings skip the materials only a tree's clustering reads).
        let cells_only = Settings {
            material_borders: false,
            ..settings.clone()
        };
        let sampled = meshers::sample(field, grid, &cells_only)?;
        progress.stage("meshing at full resolution".to_string());
        let t = Instant::now();
        let mesh = settings.run(|| pipeline::full_from(&sampled.hermite, field, settings))?;
        let times = Timings {
            sample_ms: sampled.sample_ms,
            build_ms: 0.0,
            contour_ms: t.elapsed().as_secs_f64() * 1e3,
        };
        return Ok((mesh, times, None));
    }
    // One mesh: the tree is built for this cut alone.
    let settings = Settings {
        partition,
        ..settings.for_one_cut(threshold)
    };
    let tree = KdTree::build(field, grid, &settings)?;
    progress.stage(format!("contouring {} nodes", tree.node_count()));
    let t = Instant::now();
    let mut mesh = IndexedMesh::default();
    settings.run(|| tree.extract(threshold, &mut mesh))?;
    let times = Timings {
        sample_ms: tree.stats().sample_ms,
        build_ms: tree.stats().build_ms,
        contour_ms: t.elapsed().as_secs_f64() * 1e3,
    };
    Ok((mesh, times, Some(tree)))
}
