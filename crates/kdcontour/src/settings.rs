//! Build settings: the one struct every stage of the pipeline reads (threads, memory
//! budget, crossing refinement, partition).
//!
//! This module sits below everything else in the core (it depends on
//! [`crate::error`] and [`crate::budget`] only), so the Hermite stage can take
//! `Settings` without depending on the tree.
//! [`Partition`] lives here rather than in [`crate::kdtree`] for the same reason: it
//! is a plain choice the settings carry, not tree code, and keeping it here stops
//! `settings -> kdtree -> hermite -> settings` from forming a cycle. It is
//! re-exported as `kdtree::Partition` and `crate::Partition`.

use crate::error::{Error, Result};

pub use crate::budget::{check_budget, Budget, DEFAULT_MEMORY_BUDGET};

/// Build settings. Construct with `Settings { threads: 1, ..Default::default() }`.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// Worker threads; 0 uses the ambient rayon pool.
    pub threads: usize,
    /// Refuse grids, and worlds (all their chunks together), whose build would
    /// need more bytes than this (default [`Budget::DEFAULT`], 4 GiB).
    pub memory_budget: Budget,
    /// Most Illinois false-position steps that refine each edge crossing on the field
    /// (0 = linear interpolation only, right for sampled volumes); each edge stops
    /// early once |f| < 1e-5 cells. Linear interpolation is exact where the field is
    /// planar along the edge, but near a box corner the SDF has a kink: on `box` at
    /// res 32, 4 steps left a corner vertex 0.2 cells off, 8 put it on the corner;
    /// 12 leaves margin.
    pub root_iterations: u32,
    /// How boxes are split: the paper's k-d tree (default) or the octree baseline.
    pub partition: Partition,
    /// What a surface that leaves the grid does there: ends open half a cell
    /// inside (default) or is closed by caps on the grid's faces (see [`Boundary`]).
    pub boundary: Boundary,
    /// Keep material borders crisp (default on): for a field with materials, a
    /// node whose surface spans a border between dominant materials is never a
    /// leaf, and one beside a border only where its vertex keeps the border
    /// where the cells put it (a quarter of a cell across it), so no polygon
    /// spans more than about a cell across a border ([`crate::material`]).
    /// Fields without materials are not affected.
    pub material_borders: bool,
    /// Carry the field's materials (default on): every tree keeps its
    /// components' material blends and meshes get one per vertex. Off, a field
    /// with materials is meshed as one without (no cost in time or memory, no
    /// border clustering), for apps that do not show materials.
    pub materials: bool,
    /// The largest threshold a tree is cut at (default: none, `f32::INFINITY`).
    /// A clustered node whose error is above it is never a leaf, so the fold
    /// guard checks no merge above it and painting skips those nodes; a tree cut
    /// at a higher threshold gives the mesh it gives at this one, folded nowhere.
    /// Below it, every cut is checked as with no limit; only merges that a fold
    /// above it would have refused stay. A world whose chunks' thresholds stay
    /// below a known bound (camera levels) builds faster with it.
    pub max_threshold: f32,
    /// The smallest threshold a tree is cut at (default: none,
    /// `f32::NEG_INFINITY`). A cut asked for a lower one (full resolution's -1
    /// too) is the cut at it, so the fold guard checks no polygon only a lower
    /// cut shows and painting skips the components only such cuts reach. At
    /// and above it every cut is checked as with no limit. A world whose
    /// chunks are never cut finer than a known threshold (the LOD curve's
    /// lowest, its colliders') builds faster with it.
    pub min_threshold: f32,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            threads: 0,
            memory_budget: Budget::DEFAULT,
            root_iterations: 12,
            partition: Partition::KdTree,
            boundary: Boundary::Open,
            material_borders: true,
            materials: true,
            max_threshold: f32::INFINITY,
            min_threshold: f32::NEG_INFINITY,
        }
    }
}

/// The stack of each worker thread [`Settings::run`] starts (Rust's default).
const THREAD_STACK: u64 = 2 << 20;
/// What a thread reserves besides its stack (guard page, signal stack), as
/// [`Settings::run`] counts it.
const THREAD_STACK_MARGIN: u64 = 256 << 10;

impl Settings {
    /// These settings for a tree cut at `threshold` alone (a one-off mesh):
    /// [`Settings::min_threshold`] and [`Settings::max_threshold`] both
    /// `threshold`, so the build skips the work only other cuts need. Its mesh
    /// at `threshold` is checked as any cut is, but its polygons are seen as
    /// they stand at it, not as they grew from lower cuts: where one folds the
    /// guard may refuse another node than a tree for every threshold does, so
    /// the two meshes differ by a few merges either way (mostly fewer
    /// triangles), neither folded. A threshold that is not finite changes
    /// nothing.
    pub fn for_one_cut(&self, threshold: f32) -> Settings {
        let mut s = self.clone();
        if threshold.is_finite() {
            s.min_threshold = threshold;
            s.max_threshold = threshold;
        }
        s
    }

    /// Checks every setting's range.
    pub fn check(&self) -> Result<()> {
        if self.threads > 1024 {
            return Err(Error::InvalidSetting {
                name: "threads",
                reason: format!("{} is more than 1024", self.threads),
            });
        }
        if self.root_iterations > 64 {
            return Err(Error::InvalidSetting {
                name: "root_iterations",
                reason: format!(
                    "{} is more than 64 (8 already reaches f32 precision)",
                    self.root_iterations
                ),
            });
        }
        if self.max_threshold.is_nan() {
            return Err(Error::InvalidSetting {
                name: "max_threshold",
                reason: "NaN: give a number (f32::INFINITY for no limit)".into(),
            });
        }
        if self.min_threshold.is_nan() {
            return Err(Error::InvalidSetting {
                name: "min_threshold",
                reason: "NaN: give a number (f32::NEG_INFINITY for no limit)".into(),
            });
        }
        if self.min_threshold > self.max_threshold {
            return Err(Error::InvalidSetting {
                name: "min_threshold",
                reason: format!(
                    "{} is above max_threshold ({}): no threshold is left to cut at",
                    self.min_threshold, self.max_threshold
                ),
            });
        }
        Ok(())
    }

    /// Runs `f` on the configured number of threads. One thread uses a pool cached
    /// per calling thread, so many small builds (chunk tasks on an engine's task
    /// pool) neither oversubscribe the cores nor pay for a new pool each time.
    pub fn run<T: Send>(&self, f: impl FnOnce() -> T + Send) -> Result<T> {
        self.check()?;
        if self.threads == 0 {
            return Ok(f());
        }
        if self.threads == 1 {
            thread_local! {
                static ONE: Option<rayon::ThreadPool> =
                    rayon::ThreadPoolBuilder::new().num_threads(1).build().ok();
            }
            return ONE.with(|pool| match pool {
                Some(p) => Ok(p.install(f)),
                None => Err(Error::InvalidSetting {
                    name: "threads",
                    reason: "the system would not start one worker thread: its limits on \
                             memory or processes are too low"
                        .into(),
                }),
            });
        }
        let refused = |why: String| Error::InvalidSetting {
            name: "threads",
            reason: format!(
                "the system would not start {} worker threads ({why}): its limits on \
                 memory or processes are too low for them; ask for fewer (0 uses one per core)",
                self.threads
            ),
        };
        // Stacks are reserved as threads start: checked first, so a limit they
        // pass is an error here, not a thread that aborts the process when it
        // cannot map its signal stack.
        let stacks = self.threads as u64 * (THREAD_STACK + THREAD_STACK_MARGIN);
        if let Some(left) = crate::budget::address_space_left().filter(|&l| stacks > l) {
            return Err(refused(format!(
                "their stacks reserve {} MiB and {} leaves {} MiB",
                stacks >> 20,
                crate::budget::ADDRESS_SPACE,
                left >> 20
            )));
        }
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(self.threads)
            .stack_size(THREAD_STACK as usize)
            .build()
            .map_err(|e| refused(e.to_string()))?;
        Ok(pool.install(f))
    }
}

/// How a node's box is split.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Partition {
    /// The discrete k-d tree: axis of largest `E2`, plane of equal `E1` halves.
    #[default]
    KdTree,
    /// The octree baseline: midpoint splits cycling x, y, z; only every third level
    /// (whole octree cells) may become a leaf. Everything else is shared, so a
    /// comparison measures the partition alone.
    Octree,
}

/// What a surface that runs out through the grid's faces does there. A surface
/// closed inside the grid gives the same mesh either way.
///
/// Applies to single-grid builds ([`crate::KdTree::build`], [`crate::mesh()`],
/// [`crate::meshers`]); a chunk world has no grid boundary inside it (its chunks
/// meet at seams) and ignores it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Boundary {
    /// The mesh ends where the dual mesh of the grid ends: half a cell inside the
    /// grid's faces, at every threshold (adaptive meshes keep the boundary cells
    /// thin across the face, so they cover what the uniform mesh covers). The
    /// mesh has holes (boundary edges) where the surface leaves the grid. The
    /// default: it adds nothing the field does not hold, as a terrain or a cut
    /// through a larger shape wants.
    #[default]
    Open,
    /// The solid is cut by the grid's box and closed along its faces: the mesh is
    /// the surface of `field ∩ box` (scans cut by the volume's edge, 3-D
    /// printing), watertight and 2-manifold. The grid is grown by one cell of
    /// caps on every side ([`crate::boundary`]) when the solid reaches a face.
    Capped,
}

impl Boundary {
    /// The name used on the command line (`open`, `capped`).
    pub fn name(self) -> &'static str {
        match self {
            Boundary::Open => "open",
            Boundary::Capped => "capped",
        }
    }

    /// The boundary called `name` on the command line.
    pub fn parse(name: &str) -> Option<Boundary> {
        match name {
            "open" => Some(Boundary::Open),
            "capped" => Some(Boundary::Capped),
            _ => None,
        }
    }
}
