//! A horizon volume's layouts: the chunk levels around a camera
//! ([`horizon_layout`]), which of them are kept ([`HorizonKeep`]), and what a
//! level change needs to know of a new one, worked out off the main thread
//! ([`NextLayout`]).

use super::motion::CameraMotion;
use bevy::prelude::*;
use bevy::tasks::Task;
use kdcontour::world::{ChunkKey, ChunkMap, ChunkSet, Layout, PreparedLayout};

/// Level-0 chunk rows `min_y..=max_y`.
pub(crate) type Rows = (i32, i32);

/// The top level: the smallest whose chunks are at least `view_cells` wide.
pub(crate) fn top_level(chunk_res: u32, view_cells: u32) -> u32 {
    let chunks = view_cells.div_ceil(chunk_res.max(1)).max(1);
    chunks.next_power_of_two().trailing_zeros()
}

/// The layout of a horizon volume of `chunk_res`-cell chunks with the camera at
/// `cam` (level-0 chunk units): see the module docs.
pub fn horizon_layout(
    chunk_res: u32,
    cam: Vec3,
    (view_cells, level0_cells): (u32, u32),
    (min_y, max_y): Rows,
) -> kdcontour::Result<Layout> {
    let top = top_level(chunk_res, view_cells);
    let side = 1i32 << top;
    let held = (cam / side as f32).floor().as_ivec3();
    let lo = IVec3::new(
        (held.x - 1) * side,
        min_y.div_euclid(side) * side,
        (held.z - 1) * side,
    );
    let hi = IVec3::new(
        (held.x + 2) * side,
        (max_y.div_euclid(side) + 1) * side,
        (held.z + 2) * side,
    );
    Layout::around(lo, hi, top, cam, ring(chunk_res, level0_cells))
}

/// The ring of [`Layout::around`] that puts level-0 chunks about
/// `level0_cells` from the camera.
pub(crate) fn ring(chunk_res: u32, level0_cells: u32) -> f32 {
    level0_cells as f32 / (2 * chunk_res.max(1)) as f32
}

/// Whether chunk `k` reaches into level-0 chunk rows `rows`.
pub(crate) fn in_rows(k: &ChunkKey, (min_y, max_y): Rows) -> bool {
    k.lo().y <= max_y && k.hi().y > min_y
}

/// Which chunks of a horizon layout are built and shown: those that reach into
/// the rows and come within the view distance of the camera along x and z.
/// Every point of the rows within `reach` of the camera lies in a kept chunk.
#[derive(Clone, Debug, PartialEq)]
pub struct HorizonKeep {
    /// The camera position the layout was made for (level-0 chunk units):
    /// where the camera was expected to be while the layout is shown (see
    /// `horizon::motion`).
    pub camera: Vec3,
    /// The view distance along x and z (level-0 chunks).
    pub reach: f32,
    /// Level-0 chunk rows `min_y..=max_y`.
    pub rows: (i32, i32),
}

impl HorizonKeep {
    /// Whether chunk `k` is built and shown.
    pub fn keeps(&self, k: &ChunkKey) -> bool {
        let c = self.camera.xz();
        let nearest = c.clamp(k.lo().as_vec3().xz(), k.hi().as_vec3().xz());
        in_rows(k, self.rows) && nearest.distance(c) <= self.reach
    }
}

/// What a level change needs to know of its new layout, worked out on a task
/// thread so the main thread only does the bookkeeping.
pub(crate) struct NextLayout {
    pub(crate) prepared: PreparedLayout,
    pub(crate) keep: HorizonKeep,
    /// The chunks the view keeps, in layout order.
    pub(crate) kept: Vec<ChunkKey>,
    /// For each kept chunk, the chunks whose owned seams touch it.
    pub(crate) owners: ChunkMap<Vec<ChunkKey>>,
    /// For each kept chunk, the chunks of the seams it owns.
    pub(crate) partners: ChunkMap<Vec<ChunkKey>>,
}

impl NextLayout {
    pub(crate) fn new(layout: Layout, keep: HorizonKeep) -> kdcontour::Result<Self> {
        let prepared = PreparedLayout::new(layout)?;
        let l = prepared.layout();
        let kept: Vec<ChunkKey> = l.chunks().into_iter().filter(|k| keep.keeps(k)).collect();
        let owners = kept
            .iter()
            .map(|k| (*k, l.seam_owners_touching(k)))
            .collect();
        let partners = kept
            .iter()
            .map(|k| {
                let mut v: Vec<ChunkKey> =
                    l.owned_seams(k).iter().flat_map(|s| s.chunks()).collect();
                v.sort_by_key(|c| c.order());
                v.dedup();
                (*k, v)
            })
            .collect();
        Ok(NextLayout {
            prepared,
            keep,
            kept,
            owners,
            partners,
        })
    }
}

/// A level change in progress (see `horizon`).
pub(crate) struct Transition {
    /// The chunks whose new meshes it waits for.
    pub(crate) waiting: Vec<ChunkKey>,
    /// Their meshes are held back and shown together (false for a first load,
    /// which replaces nothing).
    pub(crate) hold: bool,
    /// Which chunks of the new layout are built and shown.
    pub(crate) keep: HorizonKeep,
    /// The chunks whose re-extraction would re-extract a held chunk (those
    /// that meet a seam a held chunk owns): their thresholds wait.
    pub(crate) blocked: ChunkSet,
    /// The dropped chunks, still shown until the change is complete.
    pub(crate) retired: Vec<(ChunkKey, Entity)>,
}

/// A horizon volume's level changes and layouts: written by the horizon
/// subsystem only; the others read it through its methods.
#[derive(Default)]
pub(crate) struct HorizonState {
    /// The level change in progress, if any.
    pub(super) transition: Option<Transition>,
    /// The next layout, being prepared on a task thread.
    pub(super) pending_layout: Option<Task<kdcontour::Result<NextLayout>>>,
    /// The kept chunks and the chunks whose owned seams touch each (from the
    /// last layout).
    pub(super) seam_owners: ChunkMap<Vec<ChunkKey>>,
    /// For each kept chunk, the chunks of the seams it owns (its extraction
    /// reads their trees), from the layout task.
    pub(super) seam_partners: ChunkMap<Vec<ChunkKey>>,
    /// The layout whose chunks are shown, and which of them.
    pub(super) shown: Option<(Layout, HorizonKeep)>,
    /// The camera's motion and how long level changes take (the layouts'
    /// look-ahead).
    pub(super) motion: CameraMotion,
    /// When (real seconds) the layout of the level change being prepared or
    /// running was requested.
    pub(super) requested_at: Option<f64>,
}

impl HorizonState {
    /// No level change running or layout being prepared.
    pub(crate) fn is_settled(&self) -> bool {
        self.transition.is_none() && self.pending_layout.is_none()
    }

    /// Whether a level change waits for its meshes.
    pub(crate) fn level_change_in_progress(&self) -> bool {
        self.transition.is_some()
    }

    /// Whether a level change holds its meshes back to show them together.
    pub(crate) fn holds(&self) -> bool {
        self.transition.as_ref().is_some_and(|t| t.hold)
    }

    /// Whether a chunk whose mesh shows part of `c` is held for a level change.
    pub(crate) fn blocks(&self, c: &ChunkKey) -> bool {
        self.transition
            .as_ref()
            .is_some_and(|t| t.blocked.contains(c))
    }

    /// The chunks a level change replaces, still shown until it ends.
    pub(crate) fn retired(&self) -> &[(ChunkKey, Entity)] {
        self.transition.as_ref().map_or(&[], |t| &t.retired)
    }

    /// How long the last level change took, from its layout's request to its
    /// meshes shown (seconds; zero before the first).
    pub(crate) fn change_seconds(&self) -> f64 {
        self.motion.change_seconds()
    }

    /// The chunks of the seams kept chunk `c` owns, when known.
    pub(crate) fn seam_partners(&self, c: &ChunkKey) -> Option<&Vec<ChunkKey>> {
        self.seam_partners.get(c)
    }

    /// The layout whose chunks are shown, and which of them.
    pub(crate) fn shown(&self) -> Option<(&Layout, &HorizonKeep)> {
        self.shown.as_ref().map(|(l, k)| (l, k))
    }
}
