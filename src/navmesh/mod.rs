//! Navmesh (crate feature `navmesh`): [`NavmeshPlugin`] gives every chunk within
//! [`NavmeshSettings::distance`] of the [`LodCamera`] or of any [`NavAnchor`] a
//! navmesh tile of the floor its mesh shows, and keeps each volume's tiles,
//! linked across chunk seams and level boundaries, in a [`VolumeNavMesh`] to
//! ask for paths.
//!
//! - **Built in the meshing task.** The extraction that makes a chunk's mesh
//!   also builds its tile ([`kdcontour_nav::NavTile::build`]: Recast's steps
//!   through rerecast) from the same buffers, on the chunk workers; the main
//!   thread only links it in ([`NavStats::built_on_main_thread`] counts any
//!   that were not, and stays 0).
//! - **Never stale.** Mesh and tile travel together and land in the same frame;
//!   an edit's re-extraction replaces both, so only the tiles of the chunks an
//!   edit re-meshes are rebuilt ([`NavStats::tiles_built`]).
//! - **Linked within a budget.** Linking a tile to its neighbours is the main
//!   thread's part (about 0.01 ms for a level-0 chunk's tile, 0.2 to 0.4 ms for
//!   a coarser one). Tiles are linked in the order they land until
//!   [`NavmeshSettings::link_budget_ms`] is spent in a frame (at least one a
//!   frame); the rest wait for the next frames ([`VolumeNavMesh::waiting`]),
//!   the chunk's old tile kept meanwhile. An edit's few tiles are linked in
//!   the frame they land; a level change's dozens over a few frames.
//! - **Where they are needed.** Chunks near the camera or an anchor (and the
//!   chunks that own seams touching them) carry a tile, cut at no coarser than
//!   [`NavmeshSettings::threshold`]; a chunk that leaves the distance is
//!   extracted again without one, and a dropped chunk's tile goes with it.
//! - **Paths.** [`VolumeNavMesh::find_path`] (volume-local) and
//!   [`VolumeNavMesh::find_path_world`]: A* over the linked polygons and the
//!   funnel, or a [`PathError`] that says why there is none (a goal in rock or
//!   in the air, floors that do not connect).
//!
//! Changing the agent in [`NavmeshSettings`] (radius, height, slope, climb,
//! cell), the threshold or turning tiles on or off rebuilds every tile; the
//! distance and the linking budget take effect without.

use crate::mesh::{ChunkExtra, ExtraKind, ExtraPayload, MeshExtra};
use crate::state::VolumeState;
use crate::stats::{MainThreadClock, Stopwatch};
use crate::volume::{to_volume, KdChunk, LodCamera};
use crate::{KdContourStep, KdContourSystems};
use bevy::ecs::system::EntityCommands;
use bevy::prelude::*;
use kdcontour::world::ChunkKey;
use kdcontour::IndexedMesh;
pub use kdcontour_nav::{NavMesh, NavSettings, NavTile, Path, PathError};
use std::collections::VecDeque;
use std::sync::Arc;
use std::thread::ThreadId;
use std::time::Instant;

/// Navmesh tiles for chunks near the camera and anchors.
pub struct NavmeshPlugin;

impl Plugin for NavmeshPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<MainThreadClock>()
            .init_resource::<NavClock>()
            .init_resource::<NavmeshSettings>()
            .init_resource::<NavStats>()
            .register_type::<NavmeshSettings>()
            .register_type::<NavAnchor>()
            .register_type::<NavStats>()
            .add_systems(
                PostUpdate,
                (
                    want_tiles.in_set(KdContourStep::ChooseChunks),
                    (drop_stale_tiles, link_waiting)
                        .chain()
                        .in_set(KdContourStep::AfterUpload),
                    publish_time.in_set(KdContourSystems::Stats),
                ),
            );
    }
}

/// Where chunks get navmesh tiles, and the agent they are built for.
#[derive(Resource, Clone, Debug, Reflect)]
#[reflect(Resource)]
pub struct NavmeshSettings {
    /// Tiles at all.
    pub enabled: bool,
    /// Chunks within this distance (the volume's local units) of the
    /// [`LodCamera`] or a [`NavAnchor`] get a tile.
    pub distance: f32,
    /// Chunks with a tile are cut at no coarser threshold than this (squared
    /// cells of the chunk's level, as [`crate::LodSettings`]).
    pub threshold: f32,
    /// The agent's radius: paths keep this far from walls and ledges.
    pub agent_radius: f32,
    /// The agent's height: floors with less room above are left out.
    pub agent_height: f32,
    /// The steepest walkable slope, in degrees (0 to 89).
    pub max_slope_degrees: f32,
    /// The highest step the agent climbs.
    pub max_climb: f32,
    /// Recast's cell on the ground plane (smaller: closer to walls, slower).
    pub cell_size: f32,
    /// Main-thread time for linking tiles in, per frame, in milliseconds: once
    /// it is spent, the tiles left wait for the next frame (at least one is
    /// linked every frame).
    pub link_budget_ms: f32,
}

impl Default for NavmeshSettings {
    fn default() -> Self {
        let agent = NavSettings::default();
        NavmeshSettings {
            enabled: true,
            distance: 48.0,
            threshold: 0.02,
            agent_radius: agent.agent_radius,
            agent_height: agent.agent_height,
            max_slope_degrees: agent.max_slope_degrees,
            max_climb: agent.max_climb,
            cell_size: agent.cell_size,
            link_budget_ms: 0.3,
        }
    }
}

impl NavmeshSettings {
    /// The agent as the navmesh crate takes it.
    pub fn agent(&self) -> NavSettings {
        NavSettings {
            agent_radius: self.agent_radius,
            agent_height: self.agent_height,
            max_slope_degrees: self.max_slope_degrees,
            max_climb: self.max_climb,
            cell_size: self.cell_size,
            ..NavSettings::default()
        }
    }
}

/// Chunks near this entity get navmesh tiles (the agents, their goals), as
/// near the [`LodCamera`].
#[derive(Component, Clone, Copy, Debug, Default, Reflect)]
#[reflect(Component)]
pub struct NavAnchor;

/// What the navmesh subsystem did, summed since the app started.
#[derive(Resource, Clone, Debug, Default, Reflect)]
#[reflect(Resource)]
pub struct NavStats {
    /// Tiles built (in meshing tasks) and handed to their navmesh.
    pub tiles_built: u64,
    /// Tiles taken out (a chunk without floor, out of reach or dropped).
    pub tiles_removed: u64,
    /// Tiles built on the thread that linked them in (the main thread): 0.
    pub built_on_main_thread: u64,
    /// Tile builds that failed (logged; the chunk has no tile).
    pub failures: u64,
    /// Milliseconds spent building tiles, in all (on the chunk workers).
    pub build_ms: f64,
    /// The slowest tile build, in milliseconds.
    pub build_ms_max: f64,
    /// Milliseconds spent on the main thread linking tiles in (or taking them
    /// out), in all: processor time where it is known (Linux), else the
    /// clock's.
    pub link_ms: f64,
    /// The slowest linking of one tile, in milliseconds (as
    /// [`NavStats::link_ms`]).
    pub link_ms_max: f64,
    /// Tiles held now, over all volumes.
    pub tiles: usize,
    /// Tiles built and waiting to be linked in (the frame's linking budget
    /// was spent), over all volumes.
    pub waiting: usize,
    /// Their polygons.
    pub polygons: usize,
    /// Links between tiles.
    pub links: usize,
    /// The last error (a tile that failed, settings out of range).
    pub last_error: Option<String>,
    /// The navmesh subsystem's main-thread time last frame, in milliseconds
    /// (its systems and the linking of tiles; part of
    /// [`crate::KdContourStats::main_thread_ms`]).
    pub main_thread_ms: f64,
    /// The processor time of the same, ms (part of
    /// [`crate::KdContourStats::main_thread_cpu_ms`]).
    pub main_thread_cpu_ms: f64,
}

/// The navmesh subsystem's own share of the plugin's main-thread clock.
#[derive(Resource, Default)]
struct NavClock(MainThreadClock);

/// Publishes the frame's navmesh main-thread time ([`NavStats::main_thread_ms`]).
fn publish_time(clock: Res<NavClock>, mut stats: ResMut<NavStats>) {
    (stats.main_thread_ms, stats.main_thread_cpu_ms) = clock.0.take_ms();
}

/// A volume's navmesh: the tiles of its chunks, linked (added to every volume
/// by [`NavmeshPlugin`]).
#[derive(Component)]
pub struct VolumeNavMesh {
    navmesh: NavMesh,
    /// The settings it was built for; a tile built for others is dropped.
    generation: u64,
    /// Tiles built and waiting to be linked in, oldest first, at most one a
    /// chunk (a newer one replaces it).
    waiting: VecDeque<(ChunkKey, Arc<NavTile>)>,
    /// Counts the tiles linked in and taken out.
    version: u64,
}

impl VolumeNavMesh {
    /// Tiles built and waiting to be linked in: the chunk's old tile (or none)
    /// answers paths until then.
    pub fn waiting(&self) -> usize {
        self.waiting.len()
    }

    /// A number that changes whenever a tile is linked in or taken out: paths
    /// planned at another may be out of date.
    pub fn version(&self) -> u64 {
        self.version
    }

    /// Takes chunk `key`'s tile out of the navmesh; whether it had one.
    fn remove(&mut self, key: &ChunkKey) -> bool {
        let had = self.navmesh.remove(key);
        self.version += had as u64;
        had
    }

    /// Takes chunk `key`'s waiting tile out, if it has one.
    fn unqueue(&mut self, key: &ChunkKey) {
        self.waiting.retain(|(k, _)| k != key);
    }

    /// The tiles and their links.
    pub fn navmesh(&self) -> &NavMesh {
        &self.navmesh
    }

    /// The path from `start` to `goal` (volume-local points, as the chunk
    /// meshes), on the floor.
    pub fn find_path(&self, start: Vec3, goal: Vec3) -> Result<Path, PathError> {
        self.navmesh.find_path(start, goal)
    }

    /// Whether the floor is open along the straight line from `start` to
    /// `goal` in world space, for a volume placed by `volume`: an agent can
    /// walk straight there ([`NavMesh::is_open_between`]).
    pub fn is_open_between_world(
        &self,
        volume: &GlobalTransform,
        start: Vec3,
        goal: Vec3,
    ) -> Result<bool, PathError> {
        let local = to_volume(volume);
        self.navmesh.is_open_between(local(start), local(goal))
    }

    /// The path from `start` to `goal` in world space, for a volume placed by
    /// `volume`: its points in world space.
    pub fn find_path_world(
        &self,
        volume: &GlobalTransform,
        start: Vec3,
        goal: Vec3,
    ) -> Result<Vec<Vec3>, PathError> {
        let local = to_volume(volume);
        let path = self.navmesh.find_path(local(start), local(goal))?;
        Ok(path
            .points
            .into_iter()
            .map(|p| volume.transform_point(p))
            .collect())
    }
}

/// The navmesh subsystem's mesh extra: a chunk's tile, built in its extraction
/// task, or the removal of an old one.
struct TileExtra {
    agent: NavSettings,
    generation: u64,
}

/// A tile built in a task, or its lack, and where and how long.
struct Built {
    tile: Option<Result<NavTile, kdcontour_nav::NavError>>,
    ms: f64,
    thread: ThreadId,
    generation: u64,
}

impl MeshExtra for TileExtra {
    fn name(&self) -> &'static str {
        "navmesh tile"
    }

    fn build(&self, mesh: Option<&IndexedMesh>) -> ExtraPayload {
        let t = Instant::now();
        let built = Built {
            tile: mesh.map(|m| NavTile::build(m, &self.agent)),
            ms: t.elapsed().as_secs_f64() * 1e3,
            thread: std::thread::current().id(),
            generation: self.generation,
        };
        Box::new(move |chunk: &mut EntityCommands| {
            chunk.queue(move |e: EntityWorldMut| put_tile(e, built));
        })
    }
}

/// Queues a built tile for linking into its volume's navmesh (or takes the
/// chunk's old one out), in the frame its mesh is shown; its main-thread time
/// counts on the plugin's clock.
fn put_tile(mut chunk: EntityWorldMut, built: Built) {
    let watch = Stopwatch::start();
    link_tile(&mut chunk, built);
    chunk.world_scope(|world| {
        let ms = match world.get_resource::<MainThreadClock>() {
            Some(clock) => watch.add_to(clock),
            None => watch.ms(),
        };
        if let Some(clock) = world.get_resource::<NavClock>() {
            watch.add_to(&clock.0);
        }
        if let Some(mut stats) = world.get_resource_mut::<NavStats>() {
            stats.link_ms += ms;
        }
    });
}

/// What [`put_tile`] does.
fn link_tile(chunk: &mut EntityWorldMut, built: Built) {
    let Some(info) = chunk.get::<KdChunk>() else {
        return;
    };
    let (key, volume) = (ChunkKey::new(info.level, info.coord), info.volume);
    chunk.world_scope(|world| {
        let here = std::thread::current().id();
        let Some(mut nav) = world.get_mut::<VolumeNavMesh>(volume) else {
            return;
        };
        if nav.generation != built.generation {
            return; // built for settings since changed: a new one is coming
        }
        let (mut built_n, mut removed, mut failed) = (0, 0, None);
        let ran = built.tile.is_some();
        // A newer tile (or none) replaces one still waiting.
        nav.unqueue(&key);
        match built.tile {
            Some(Ok(tile)) if !tile.is_empty() => {
                nav.waiting.push_back((key, Arc::new(tile)));
                built_n = 1;
            }
            Some(Err(e)) => {
                removed = nav.remove(&key) as u64;
                failed = Some(format!("chunk {:?} (level {}): {e}", key.coord, key.level));
            }
            _ => removed = nav.remove(&key) as u64,
        }
        let mut stats = world.resource_mut::<NavStats>();
        stats.tiles_built += built_n;
        stats.tiles_removed += removed;
        if ran {
            stats.build_ms += built.ms;
            stats.build_ms_max = stats.build_ms_max.max(built.ms);
            stats.built_on_main_thread += (built.thread == here) as u64;
        }
        if let Some(e) = failed {
            warn!("navmesh tile: {e}");
            stats.failures += 1;
            stats.last_error = Some(e);
        }
    });
}

/// What a volume's tiles are built for: the agent, whether tiles are on, and
/// the threshold their chunks are cut at.
type BuiltFor = (NavSettings, bool, f32);

/// Where tiles are wanted from: the LOD camera and every anchor.
type Anchors<'w, 's> =
    Query<'w, 's, &'static GlobalTransform, Or<(With<LodCamera>, With<NavAnchor>)>>;

/// The volumes, their navmesh if they have one yet.
type Volumes<'w, 's> = Query<
    'w,
    's,
    (
        Entity,
        &'static GlobalTransform,
        &'static mut VolumeState,
        Option<&'static VolumeNavMesh>,
    ),
>;

/// Gives new volumes (and every volume when the settings change) a fresh
/// navmesh and the tile builder, then marks the chunks that want a tile; a
/// chunk whose want changed is extracted again (with or without one). Runs
/// before the LOD, which keeps those chunks at or below the tile threshold.
// A Bevy system takes one parameter per resource it reads.
#[allow(clippy::too_many_arguments)]
fn want_tiles(
    mut commands: Commands,
    settings: Res<NavmeshSettings>,
    clock: Res<MainThreadClock>,
    nav_clock: Res<NavClock>,
    mut stats: ResMut<NavStats>,
    mut generation: Local<(u64, Option<BuiltFor>)>,
    anchors: Anchors,
    mut volumes: Volumes,
) {
    let (_time, _nav_time) = (clock.measure(), nav_clock.0.measure());
    let agent = settings.agent();
    let valid = agent.check();
    // What the tiles are built for: a change rebuilds them all (the distance
    // and the linking budget do not). Looked at only when the settings changed
    // (a NaN would differ from itself every frame).
    let built_for = Some((agent.clone(), settings.enabled, settings.threshold));
    if settings.is_changed() && generation.1 != built_for {
        generation.1 = built_for;
        generation.0 += 1;
        if let Err(e) = &valid {
            warn!("{e}: no navmesh tiles until the settings are fixed");
            stats.last_error = Some(e.to_string());
        }
    }
    let enabled = settings.enabled && valid.is_ok();
    for (entity, vol_tf, mut state, nav) in &mut volumes {
        let state = &mut *state;
        if nav.is_none_or(|n| n.generation != generation.0) {
            // A new volume or new settings: an empty navmesh, every tile again.
            let navmesh = NavMesh::new(if valid.is_ok() {
                agent.clone()
            } else {
                NavSettings::default()
            })
            .expect("checked settings");
            commands.entity(entity).insert(VolumeNavMesh {
                navmesh,
                generation: generation.0,
                waiting: VecDeque::new(),
                version: 0,
            });
            state.set_extra(
                ExtraKind::NavTile,
                Some(ChunkExtra {
                    builder: Arc::new(TileExtra {
                        agent: agent.clone(),
                        generation: generation.0,
                    }),
                    on: enabled.then_some(settings.threshold),
                }),
            );
            state.refresh_extra(ExtraKind::NavTile);
        }
        let to_local = to_volume(vol_tf);
        let points: Vec<Vec3> = anchors.iter().map(|a| to_local(a.translation())).collect();
        state.want_near(ExtraKind::NavTile, enabled, settings.distance, &points);
    }
}

/// Links waiting tiles in, oldest first, until the frame's
/// [`NavmeshSettings::link_budget_ms`] is spent (at least one a frame), and
/// totals the tiles for [`NavStats`].
fn link_waiting(
    settings: Res<NavmeshSettings>,
    clock: Res<MainThreadClock>,
    nav_clock: Res<NavClock>,
    mut stats: ResMut<NavStats>,
    mut volumes: Query<&mut VolumeNavMesh>,
) {
    let (_time, _nav_time) = (clock.measure(), nav_clock.0.measure());
    let start = Instant::now();
    // NaN or below 0: none (one tile a frame); past what a Duration holds
    // (infinity): no limit.
    let budget = std::time::Duration::try_from_secs_f32(settings.link_budget_ms.max(0.0) / 1e3)
        .unwrap_or(std::time::Duration::MAX);
    let mut linked = 0;
    for mut nav in &mut volumes {
        while !nav.waiting.is_empty() && (linked == 0 || start.elapsed() < budget) {
            let one = Stopwatch::start();
            let nav = &mut *nav;
            let (key, tile) = nav.waiting.pop_front().expect("not empty");
            nav.navmesh.insert(key, tile);
            nav.version += 1;
            linked += 1;
            let ms = one.ms();
            stats.link_ms += ms;
            stats.link_ms_max = stats.link_ms_max.max(ms);
        }
    }
    let (mut tiles, mut polygons, mut links, mut waiting) = (0, 0, 0, 0);
    for nav in &volumes {
        tiles += nav.navmesh.len();
        polygons += nav.navmesh.polygon_count();
        links += nav.navmesh.link_count();
        waiting += nav.waiting.len();
    }
    let totals = (tiles, polygons, links, waiting);
    if (stats.tiles, stats.polygons, stats.links, stats.waiting) != totals {
        (stats.tiles, stats.polygons, stats.links, stats.waiting) = totals;
    }
}

/// Takes the tiles of chunks no longer loaded (streamed out, replaced by a
/// level change) out of their navmesh, and out of its queue.
fn drop_stale_tiles(
    clock: Res<MainThreadClock>,
    nav_clock: Res<NavClock>,
    mut stats: ResMut<NavStats>,
    mut volumes: Query<(&VolumeState, &mut VolumeNavMesh)>,
) {
    let (_time, _nav_time) = (clock.measure(), nav_clock.0.measure());
    for (state, mut nav) in &mut volumes {
        if nav
            .waiting
            .iter()
            .any(|(k, _)| !state.slots.contains_key(k))
        {
            nav.waiting.retain(|(k, _)| state.slots.contains_key(k));
        }
        let gone: Vec<ChunkKey> = nav
            .navmesh
            .keys()
            .filter(|k| !state.slots.contains_key(k))
            .copied()
            .collect();
        if !gone.is_empty() {
            for k in &gone {
                nav.remove(k);
            }
            stats.tiles_removed += gone.len() as u64;
        }
    }
}
