//! Side by side, in one run on one machine: the k-d tree against the Rust meshers a
//! user would pick instead, on the same grids.
//!
//! `skeleton-climbing` (Adaptive Skeleton Climbing, in the core) samples through
//! `kdcontour` like ours; its time is sample + Hermite data + meshing, its box size
//! limit the one `--threshold` picks.
//!
//! Every mesher meshes the scene over `[-1, 1]^3` at `res` cells per axis (the
//! scene `chunk` is the Bevy plugin's terrain chunk instead: the terrain demo's
//! field, with materials, over `res`^3 cells of one world unit). The
//! uniform peers (fast-surface-nets, isosurface's Marching Cubes, transvoxel, and
//! Marching Cubes + meshoptimizer) mesh the same densely sampled grid; their time
//! is that sampling plus their meshing. Ours (`kdtree`, `octree`) sample through
//! `kdcontour` (block skipping, crossings refined on the field) and build; their
//! time is sample + build + contour. `kdtree-full` is our mesh at full resolution
//! (every cell a leaf: the tree's mesh below threshold 0), which needs no tree
//! (`kdcontour::pipeline::full`): its time is sample + Hermite data + quads. `discrete-planes` (Boada and
//! Navazo) meshes the same Hermite data; its time is sample + code + merge. fidget meshes its own expression
//! of the scene (it cannot take a sampled grid), at the octree depth of `res`, and
//! emits 4 triangles per crossing edge where the others emit 2, so its count is
//! halved. Where fidget runs, `kdtree-at-fidget-error` is ours at the coarsest
//! threshold (powers of two around `--threshold`) whose mesh is within fidget's max
//! error: the fewer-triangles-at-the-same-error comparison. Max error is
//! |f| / |grad f| at vertices and triangle centroids, in cells, on the scene's field
//! (`kdcontour::validate`).
//!
//! ```text
//! cargo run --release -p kdcontour-bench -- [--json] [--scenes sphere,disk_pole,terrain,chunk] [--res 32,64,128]
//! ```

use clap::Parser;
use fidget_core::context::Tree;
use fidget_core::vm::VmShape;
use glam::{UVec3, Vec3};
use kdcontour::{
    discrete_planes, hermite, mc, scenes, skeleton_climbing, validate, Field, Grid, IndexedMesh,
    KdTree, Partition, Settings,
};
use std::time::Instant;

/// Compare kdcontour with fast-surface-nets, isosurface, transvoxel, fidget and
/// Marching Cubes + meshoptimizer.
#[derive(Parser, Debug)]
struct Args {
    /// One JSON line per scene, resolution and mesher instead of tables.
    #[arg(long)]
    json: bool,
    /// Scenes (built-in names, and `chunk`: the Bevy plugin's terrain chunk).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "sphere,disk_pole,terrain,chunk"
    )]
    scenes: Vec<String>,
    /// Cells per axis.
    #[arg(long, value_delimiter = ',', default_value = "32,64,128")]
    res: Vec<u32>,
    /// Error threshold of the adaptive k-d tree and octree (squared cells).
    #[arg(long, default_value_t = 0.01)]
    threshold: f32,
    /// Threads for every mesher that can use more than one.
    #[arg(long, default_value_t = 1)]
    threads: usize,
    /// Repetitions per mesher; the fastest is reported.
    #[arg(long, default_value_t = 3)]
    reps: usize,
}

/// One mesher's result.
struct Row {
    mesher: &'static str,
    triangles: usize,
    max_error: f32,
    total_ms: f64,
    note: String,
}

/// The fastest of `reps` runs of `f` (ms) and its last output.
fn time<T>(reps: usize, mut f: impl FnMut() -> T) -> (f64, T) {
    let mut best = f64::INFINITY;
    let mut out = None;
    for _ in 0..reps.max(1) {
        let t = Instant::now();
        let o = f();
        best = best.min(t.elapsed().as_secs_f64() * 1e3);
        out = Some(o);
    }
    (best, out.expect("at least one rep"))
}

/// Every corner of `grid` sampled (x fastest), for the uniform peers.
fn dense(field: &dyn Field, grid: &Grid) -> Vec<f32> {
    let mut out = vec![0f32; grid.corner_count() as usize];
    field.sample_grid(grid, 0..grid.corners().z, &mut out);
    out
}

fn from_triangles(positions: Vec<Vec3>, tris: impl Iterator<Item = [u32; 3]>) -> IndexedMesh {
    let mut m = IndexedMesh {
        normals: vec![Vec3::Y; positions.len()],
        positions,
        ..Default::default()
    };
    for t in tris {
        m.indices.extend_from_slice(&t);
    }
    m
}

fn fast_surface_nets(values: &[f32], grid: &Grid) -> IndexedMesh {
    use fast_surface_nets::ndshape::{RuntimeShape, Shape};
    let c = grid.corners();
    let shape = RuntimeShape::<u32, 3>::new([c.x, c.y, c.z]);
    debug_assert_eq!(shape.size() as usize, values.len());
    let mut buf = fast_surface_nets::SurfaceNetsBuffer::default();
    fast_surface_nets::surface_nets(
        values,
        &shape,
        [0; 3],
        [c.x - 1, c.y - 1, c.z - 1],
        &mut buf,
    );
    let pos = buf
        .positions
        .iter()
        .map(|p| grid.to_world(Vec3::from_array(*p)))
        .collect();
    from_triangles(pos, buf.indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]))
}

/// isosurface 0.1.0-alpha.0's Marching Cubes reading the shared samples (it asks
/// for points in `[0, 1]^3` at the corners).
fn isosurface_mc(values: &[f32], grid: &Grid) -> IndexedMesh {
    use isosurface::{distance::Signed, extractor::IndexedVertices, math::Vec3 as V};
    use isosurface::{sampler::Sampler, source::ScalarSource, MarchingCubes};
    struct Lookup<'a> {
        values: &'a [f32],
        n: UVec3,
    }
    impl ScalarSource for Lookup<'_> {
        fn sample_scalar(&self, p: V) -> Signed {
            let r = (self.n - UVec3::ONE).as_vec3();
            let i = (Vec3::new(p.x, p.y, p.z) * r)
                .round()
                .as_uvec3()
                .min(self.n - UVec3::ONE);
            Signed(self.values[(i.x + self.n.x * (i.y + self.n.y * i.z)) as usize])
        }
    }
    let n = grid.corners();
    let source = Lookup { values, n };
    let sampler = Sampler::new(&source);
    let (mut verts, mut idx) = (Vec::new(), Vec::new());
    let mut extractor = IndexedVertices::new(&mut verts, &mut idx);
    MarchingCubes::<Signed>::new(n.x as usize).extract(&sampler, &mut extractor);
    let side = (n - UVec3::ONE).as_vec3();
    let pos = verts
        .chunks_exact(3)
        .map(|v| grid.to_world(Vec3::new(v[0], v[1], v[2]) * side))
        .collect();
    from_triangles(pos, idx.chunks_exact(3).map(|t| [t[0], t[1], t[2]]))
}

/// transvoxel 2.0 (regular cells, no transition faces) on the shared samples. It
/// treats values above the threshold as inside, so it reads the negated field.
fn transvoxel_mesh(values: &[f32], grid: &Grid) -> IndexedMesh {
    use transvoxel::prelude::*;
    let n = grid.corners();
    let res = n.x - 1;
    let density = |x: f32, y: f32, z: f32| -> f32 {
        let i = Vec3::new(x, y, z).round().as_uvec3().min(n - UVec3::ONE);
        -values[(i.x + n.x * (i.y + n.y * i.z)) as usize]
    };
    let block = Block::new([0.0, 0.0, 0.0], res as f32, res as usize);
    let mesh = extract_from_field(
        &density,
        FieldCaching::CacheNothing,
        block,
        TransitionSide::none(),
        0.0,
        GenericMeshBuilder::new(),
    )
    .build();
    let pos = mesh
        .positions
        .chunks_exact(3)
        .map(|p| grid.to_world(Vec3::new(p[0], p[1], p[2])))
        .collect();
    from_triangles(
        pos,
        mesh.triangle_indices
            .chunks_exact(3)
            .map(|t| [t[0] as u32, t[1] as u32, t[2] as u32]),
    )
}

/// Marching Cubes (ours, same samples) simplified by meshoptimizer to `target`
/// triangles.
fn mc_meshopt(mc: &IndexedMesh, target: usize) -> IndexedMesh {
    let verts: Vec<[f32; 3]> = mc.positions.iter().map(|p| p.to_array()).collect();
    let adapter = meshopt::VertexDataAdapter::new(
        meshopt::typed_to_bytes(&verts),
        std::mem::size_of::<[f32; 3]>(),
        0,
    )
    .expect("vertex layout");
    let idx = meshopt::simplify(
        &mc.indices,
        &adapter,
        target * 3,
        1.0,
        meshopt::SimplifyOptions::None,
        None,
    );
    from_triangles(
        mc.positions.clone(),
        idx.chunks_exact(3).map(|t| [t[0], t[1], t[2]]),
    )
}

/// The scene as a fidget expression, where it has one (fidget evaluates its own
/// expression trees, not Rust closures or noise).
fn fidget_tree(scene: &str) -> Option<Tree> {
    let (x, y, z) = Tree::axes();
    match scene {
        "sphere" => {
            let c = [0.013f32, 0.021, -0.017];
            Some(((x - c[0]).square() + (y - c[1]).square() + (z - c[2]).square()).sqrt() - 0.7)
        }
        "disk_pole" => {
            // Capped cylinders along x: (axial half-length, radius, center x).
            let cyl = |h: f32, r: f32, cx: f32| -> Tree {
                let (x, y, z) = Tree::axes();
                let radial = (y.square() + z.square()).sqrt() - r;
                let axial = (x - cx).abs() - h;
                let inside = radial.max(axial.clone()).min(0.0);
                let outside = (radial.max(0.0).square() + axial.max(0.0).square()).sqrt();
                inside + outside
            };
            let mut t = cyl(0.9, 0.06, 0.0);
            for i in 0..7 {
                t = t.min(cyl(0.02, 0.55, -0.75 + 0.25 * i as f32));
            }
            Some(t)
        }
        _ => None,
    }
}

fn fidget_mesh(tree: Tree, res: u32, threads: usize) -> Option<IndexedMesh> {
    let depth = res.ilog2() as u8;
    let shape = VmShape::from(tree);
    let bound = shape.try_into().ok()?;
    let pool = fidget_core::render::ThreadPool::Global;
    let settings = fidget_mesh::Settings {
        depth,
        threads: (threads > 1).then_some(&pool),
        ..Default::default()
    };
    let octree = fidget_mesh::Octree::build(&bound, &settings)?;
    let mesh = octree.walk_dual();
    let pos = mesh
        .vertices
        .iter()
        .map(|v| Vec3::new(v.x, v.y, v.z))
        .collect();
    Some(from_triangles(
        pos,
        mesh.triangles
            .iter()
            .map(|t| [t.x as u32, t.y as u32, t.z as u32]),
    ))
}

/// The machine's 1-minute load average, for reading the times.
fn load() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|s| s.split_whitespace().next().map(str::to_string))
        .unwrap_or_else(|| "?".into())
}

/// Ours: `KdTree::build` (sample, Hermite data, build) with `partition`, then
/// `then` on the tree (contouring), all on `settings`' one pool. The build is told
/// to use the ambient pool (`threads: 0`), which inside `settings.run` is that pool,
/// so a timed run starts one pool, as when the stages were written out here.
fn build_then<T: Send>(
    field: &dyn Field,
    grid: &Grid,
    settings: &Settings,
    partition: Partition,
    then: impl FnOnce(&KdTree) -> T + Send,
) -> Result<T, String> {
    let ambient = Settings {
        threads: 0,
        partition,
        ..settings.clone()
    };
    settings
        .run(|| KdTree::build(field, grid, &ambient).map(|tree| then(&tree)))
        .and_then(|r| r)
        .map_err(|e| e.to_string())
}

/// The field and grid of a scene: a built-in scene over `[-1, 1]^3`, or
/// `chunk`, the Bevy plugin's terrain chunk (the terrain demo's field, 3-D noise
/// with caves and materials, over `res`^3 cells of one world unit).
fn scene_grid(scene_name: &str, res: u32) -> Result<(Box<dyn Field>, Grid), String> {
    if scene_name == "chunk" {
        let (field, grid) = scenes::demo_chunk(res);
        return Ok((Box::new(field), grid));
    }
    let scene = scenes::scene(scene_name).map_err(|e| e.to_string())?;
    Ok((scene.field, Grid::cube(1.0, res)))
}

fn run(args: &Args, scene_name: &str, res: u32) -> Result<Vec<Row>, String> {
    let (field, grid) = scene_grid(scene_name, res)?;
    let field = &*field;
    let cell = grid.cell_size;
    let settings = Settings {
        threads: args.threads,
        ..Default::default()
    };
    let check = |m: &IndexedMesh| validate(m, Some((field, cell))).max_error;
    let mut rows = Vec::new();
    let mut push = |mesher, m: &IndexedMesh, ms, note: String| {
        rows.push(Row {
            mesher,
            triangles: m.triangle_count(),
            max_error: check(m),
            total_ms: ms,
            note,
        })
    };

    // Ours: sample + build + contour, the tree built for the one cut it is
    // timed at (as any one-off mesh is; `Settings::for_one_cut`).
    let ours = |partition: Partition, threshold: f32| {
        build_then(
            field,
            &grid,
            &settings.for_one_cut(threshold),
            partition,
            |tree| tree.mesh(threshold),
        )
    };
    let (ms, kd) = time(args.reps, || ours(Partition::KdTree, args.threshold));
    let kd = kd?;
    push("kdtree", &kd, ms, format!("threshold {}", args.threshold));
    // Full resolution needs no tree: the mesh a tree gives below zero, from the
    // Hermite data (`pipeline::full`).
    let (ms, full) = time(args.reps, || {
        let ambient = Settings {
            threads: 0,
            ..settings.clone()
        };
        settings
            .run(|| kdcontour::pipeline::full(field, &grid, &ambient))
            .and_then(|m| m)
            .map_err(|e| e.to_string())
    });
    push("kdtree-full", &full?, ms, "full resolution, no tree".into());
    let (ms, oct) = time(args.reps, || ours(Partition::Octree, args.threshold));
    push("octree", &oct?, ms, format!("threshold {}", args.threshold));

    // The uniform peers share one dense sampling.
    let (sample_ms, values) = time(args.reps, || settings.run(|| dense(field, &grid)).unwrap());
    let (ms, m) = time(args.reps, || fast_surface_nets(&values, &grid));
    push(
        "fast-surface-nets",
        &m,
        sample_ms + ms,
        format!("sampling {sample_ms:.1} ms"),
    );
    let (ms, m) = time(args.reps, || isosurface_mc(&values, &grid));
    push(
        "isosurface-mc",
        &m,
        sample_ms + ms,
        format!("sampling {sample_ms:.1} ms"),
    );
    let (ms, m) = time(args.reps, || transvoxel_mesh(&values, &grid));
    push(
        "transvoxel",
        &m,
        sample_ms + ms,
        format!("sampling {sample_ms:.1} ms"),
    );
    // MC + meshoptimizer down to the k-d tree's count. MC from the same Hermite
    // data as ours (crossings refined on the field), then simplified.
    let (ms, m) = time(args.reps, || {
        let h = hermite::Hermite::from_field(field, &grid, &settings).unwrap();
        let mc = mc::marching_cubes(&h);
        mc_meshopt(&mc, kd.triangle_count())
    });
    push(
        "mc+meshopt",
        &m,
        ms,
        format!("target {} triangles", kd.triangle_count()),
    );

    if let Some(tree) = fidget_tree(scene_name) {
        if res.is_power_of_two() {
            let (ms, m) = time(args.reps, || {
                settings
                    .run(|| fidget_mesh(tree.clone(), res, args.threads))
                    .unwrap()
            });
            if let Some(m) = m {
                let r = Row {
                    mesher: "fidget-mdc",
                    // 4 triangles per crossing edge where the others make 2.
                    triangles: m.triangle_count() / 2,
                    max_error: check(&m),
                    total_ms: ms,
                    note: format!(
                        "depth {}, {} raw triangles halved",
                        res.ilog2(),
                        m.triangle_count()
                    ),
                };
                let (fidget_err, fidget_tris, fidget_ms) = (r.max_error, r.triangles, r.total_ms);
                let fidget_row = r;
                // Ours at fidget's error: the coarsest threshold (powers of two
                // around --threshold) whose mesh is within fidget's max error,
                // picked by re-extracting one retained tree (a threshold change is
                // a walk, no rebuild), then timed from the samples like the rows
                // above. "Fewer triangles at the same error" is this row.
                let picked = build_then(field, &grid, &settings, Partition::KdTree, |tree| {
                    let mut best = None;
                    for k in -6..=12 {
                        let t = args.threshold * 2f32.powi(k);
                        let m = tree.mesh(t);
                        if check(&m) <= fidget_err {
                            best = Some((t, m));
                        }
                    }
                    best
                })?;
                if let Some((t, _)) = picked {
                    let (ms, m) = time(args.reps, || ours(Partition::KdTree, t));
                    let m = m?;
                    let tris = m.triangle_count();
                    rows.push(fidget_row);
                    rows.push(Row {
                        mesher: "kdtree-at-fidget-error",
                        triangles: tris,
                        max_error: check(&m),
                        total_ms: ms,
                        note: format!(
                            "threshold {t}: {:.2} of fidget's triangles, {:.2} of its time",
                            tris as f64 / fidget_tris.max(1) as f64,
                            ms / fidget_ms.max(1e-9)
                        ),
                    });
                } else {
                    rows.push(fidget_row);
                }
            }
        }
    }

    // Adaptive Skeleton Climbing from the same Hermite data as ours, its box size
    // limit picked by the threshold (`block_for_threshold`).
    let block = skeleton_climbing::block_for_threshold(args.threshold);
    let (ms, m) = time(args.reps, || {
        settings.run(|| {
            let h = hermite::Hermite::from_field(field, &grid, &settings).unwrap();
            skeleton_climbing::skeleton_climbing(&h, block).unwrap()
        })
    });
    let m = m.map_err(|e| e.to_string())?;
    rows.push(Row {
        mesher: "skeleton-climbing",
        triangles: m.triangle_count(),
        max_error: check(&m),
        total_ms: ms,
        note: format!("block {block}"),
    });
    // Boada and Navazo's discrete planes on the same Hermite data as ours:
    // sample, then code the cells and merge coplanar ones bottom up.
    let (ms, dp) = time(args.reps, || {
        settings.run(|| {
            hermite::Hermite::from_field(field, &grid, &settings)
                .map(|h| discrete_planes::extract(&h))
        })
    });
    let dp = dp.and_then(|r| r).map_err(|e| e.to_string())?;
    rows.push(Row {
        mesher: "discrete-planes",
        triangles: dp.mesh.triangle_count(),
        max_error: check(&dp.mesh),
        total_ms: ms,
        note: format!("{} polygons", dp.stats.polygons),
    });
    Ok(rows)
}

fn main() {
    let args = Args::parse();
    if args.threads == 0 || args.reps == 0 {
        eprintln!("error: --threads and --reps must be at least 1");
        std::process::exit(2);
    }
    for r in &args.res {
        if !(4..=512).contains(r) {
            eprintln!("error: --res {r}: allowed 4 to 512");
            std::process::exit(2);
        }
    }
    for scene in &args.scenes {
        for &res in &args.res {
            let rows = match run(&args, scene, res) {
                Ok(r) => r,
                Err(e) => {
                    eprintln!("error: {scene} at {res}: {e}");
                    std::process::exit(1);
                }
            };
            let load = load();
            if args.json {
                for r in &rows {
                    println!(
                        "{}",
                        serde_json::json!({
                            "scene": scene, "res": res, "mesher": r.mesher,
                            "threads": args.threads, "triangles": r.triangles,
                            "max_error": r.max_error, "total_ms": r.total_ms,
                            "load": load,
                        })
                    );
                }
                continue;
            }
            let kd = rows
                .iter()
                .find(|r| r.mesher == "kdtree")
                .expect("always run");
            let full = rows
                .iter()
                .find(|r| r.mesher == "kdtree-full")
                .expect("always run");
            println!(
                "\n{scene} at res {res}, {} thread(s), load {load} (ratios: ours / peer; full-res rows against kdtree-full)",
                args.threads
            );
            println!(
                "{:<18} {:>10} {:>10} {:>10} {:>9} {:>9}  note",
                "mesher", "triangles", "max err", "ms", "tri ratio", "ms ratio"
            );
            for r in &rows {
                let ours = if matches!(
                    r.mesher,
                    "fast-surface-nets" | "isosurface-mc" | "transvoxel"
                ) {
                    full
                } else {
                    kd
                };
                println!(
                    "{:<18} {:>10} {:>10.3} {:>10.2} {:>9.2} {:>9.2}  {}",
                    r.mesher,
                    r.triangles,
                    r.max_error,
                    r.total_ms,
                    ours.triangles as f64 / r.triangles.max(1) as f64,
                    ours.total_ms / r.total_ms.max(1e-9),
                    r.note
                );
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_mesher_meshes_the_same_sphere_closely() {
        let args = Args::parse_from(["kdcontour-bench", "--reps", "1"]);
        let rows = run(&args, "sphere", 16).unwrap();
        let names: Vec<&str> = rows.iter().map(|r| r.mesher).collect();
        assert_eq!(
            names,
            [
                "kdtree",
                "kdtree-full",
                "octree",
                "fast-surface-nets",
                "isosurface-mc",
                "transvoxel",
                "mc+meshopt",
                "fidget-mdc",
                "kdtree-at-fidget-error",
                "skeleton-climbing",
                "discrete-planes"
            ]
        );
        let full = rows[1].triangles;
        for r in &rows {
            assert!(r.triangles > 0, "{} made nothing", r.mesher);
            // Every mesher finds the same sphere: vertices within a cell of it.
            assert!(r.max_error < 1.0, "{}: max error {}", r.mesher, r.max_error);
            assert!(r.total_ms > 0.0);
        }
        // The uniform meshers agree on the count (one quad per crossing edge, or
        // Marching Cubes' equivalent), and the k-d tree is below it.
        assert_eq!(rows[3].triangles, full, "fast-surface-nets vs uniform DMC");
        assert!((rows[4].triangles as i64 - full as i64).abs() <= 8);
        assert!(rows[0].triangles < full);
        // meshopt was asked for the k-d tree's count.
        assert!(rows[6].triangles <= rows[0].triangles);
        // At fidget's error: no worse than it, from a coarser or equal threshold.
        assert!(rows[8].max_error <= rows[7].max_error);
        assert!(rows[8].triangles < full);
        // Skeleton climbing's boxes make fewer triangles than the uniform mesh.
        assert!(rows[9].triangles < full);
    }

    #[test]
    fn scenes_without_an_expression_skip_fidget() {
        assert!(fidget_tree("terrain").is_none());
        assert!(fidget_tree("disk_pole").is_some());
    }
}
