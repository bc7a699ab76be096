//! Volumes and their chunks: the [`KdVolume`] and [`KdChunk`] components, the
//! [`LodCamera`] marker, and [`VolumePlugin`], which gives every new volume its
//! [`VolumeState`] and rebuilds a volume whose field or iso level changed. It
//! also orders [`KdContourSystems`], the sets every other subsystem runs in.

use crate::material::TerrainMaterial;
use crate::settings::KdContourSettings;
use bevy::prelude::*;
use kdcontour::{Field, World};
use std::sync::Arc;

/// A field shared with meshing tasks.
#[derive(Clone)]
pub struct SharedField(pub Arc<dyn Field>);

impl Default for SharedField {
    /// Empty space (no surface).
    fn default() -> Self {
        SharedField(Arc::new(kdcontour::field::FnField(|_| 1.0)))
    }
}

/// Which chunks a volume has.
#[derive(Clone, Debug, PartialEq, Reflect)]
pub enum VolumeExtent {
    /// A fixed block of X x Y x Z chunks, from chunk (0, 0, 0).
    Bounded {
        /// Chunks along x, y, z.
        chunks: UVec3,
    },
    /// Unbounded: the chunks whose box comes within `view_distance` of the
    /// [`LodCamera`] are loaded, nearest first; a chunk is dropped once its box is
    /// more than `view_distance` plus one chunk side away (so chunks at the edge do
    /// not load and unload every frame). Chunk rows are limited to
    /// `min_y..=max_y` (terrain has nothing far above or below).
    Streaming {
        /// Load radius around the camera (local units).
        view_distance: f32,
        /// Lowest chunk row.
        min_y: i32,
        /// Highest chunk row.
        max_y: i32,
    },
    /// Unbounded terrain seen to the horizon: chunks whose cells double with
    /// distance from the [`LodCamera`] (an octree of chunk levels, see
    /// [`kdcontour::world`]), so the cost of a view grows with the log of its
    /// distance. Finest (level-0) chunks reach about `level0_cells` cells from
    /// the camera, each coarser level about twice as far, and the terrain reaches
    /// at least `view_cells` cells out along x and z. Chunks that lie wholly
    /// outside level-0 chunk rows `min_y..=max_y` are not built.
    Horizon {
        /// Cells the terrain reaches from the camera along x and z (at least
        /// one chunk).
        view_cells: u32,
        /// Cells the finest chunks reach from the camera.
        level0_cells: u32,
        /// Lowest level-0 chunk row.
        min_y: i32,
        /// Highest level-0 chunk row.
        max_y: i32,
    },
}

/// A volume of chunks of `chunk_res`³ cells of side `cell_size`, sampled from
/// `field` in the entity's local space (lattice corner (0, 0, 0) at the entity's
/// origin): a bounded block ([`KdVolume::new`]) or unbounded terrain streamed
/// around the camera ([`KdVolume::streaming`]). Its chunks are spawned as children.
#[derive(Component, Clone, Reflect)]
#[reflect(Component)]
#[require(Transform, Visibility)]
pub struct KdVolume {
    /// The field (negative inside).
    #[reflect(ignore)]
    pub field: SharedField,
    /// Which chunks exist.
    pub extent: VolumeExtent,
    /// Cells per chunk along each axis.
    pub chunk_res: u32,
    /// Side of one cell (local units).
    pub cell_size: f32,
    /// The level of the field that is the surface (0 for signed distances; a
    /// density or intensity threshold for scans). Changing it rebuilds every chunk.
    pub iso: f32,
    /// What the chunk meshes are drawn with. Whether it is the terrain
    /// material (chunks carry the field's materials) is read when the volume
    /// first meshes.
    pub material: VolumeMaterial,
    /// With the terrain material: keep hard borders between materials crisp
    /// (the tree does not merge across them; see `kdcontour::Settings::
    /// material_borders`). On by default; it costs triangles where borders are
    /// many (the demo terrain: +50% at threshold 0.01, about 5x at 1).
    pub material_borders: bool,
}

/// What a volume's chunks are drawn with.
#[derive(Clone, Debug, Reflect)]
pub enum VolumeMaterial {
    /// One `StandardMaterial` for every chunk (the field's materials are not
    /// shown).
    Standard(Handle<StandardMaterial>),
    /// The [`TerrainMaterial`]: each vertex shows the field's materials there,
    /// textured by triplanar projection (chunk meshes then carry per-layer
    /// weights; see [`crate::material`]).
    Terrain(Handle<TerrainMaterial>),
}

impl Default for VolumeMaterial {
    /// The default `StandardMaterial`.
    fn default() -> Self {
        VolumeMaterial::Standard(Handle::default())
    }
}

impl VolumeMaterial {
    /// Whether chunk meshes carry the per-layer weights the terrain material reads.
    pub fn wants_layers(&self) -> bool {
        matches!(self, VolumeMaterial::Terrain(_))
    }
}

impl KdVolume {
    /// A bounded volume of `chunks` chunks, with the default material.
    pub fn new(field: Arc<dyn Field>, chunks: UVec3, chunk_res: u32, cell_size: f32) -> Self {
        Self::with_extent(
            field,
            VolumeExtent::Bounded { chunks },
            chunk_res,
            cell_size,
        )
    }

    /// A volume of `extent` at iso 0 with the default material.
    fn with_extent(
        field: Arc<dyn Field>,
        extent: VolumeExtent,
        chunk_res: u32,
        cell_size: f32,
    ) -> Self {
        KdVolume {
            field: SharedField(field),
            extent,
            chunk_res,
            cell_size,
            iso: 0.0,
            material: VolumeMaterial::default(),
            material_borders: true,
        }
    }

    /// An unbounded volume streamed within `view_distance` of the camera, chunk
    /// rows -2 to 1 (change them with [`KdVolume::with_rows`]).
    pub fn streaming(
        field: Arc<dyn Field>,
        chunk_res: u32,
        cell_size: f32,
        view_distance: f32,
    ) -> Self {
        let extent = VolumeExtent::Streaming {
            view_distance,
            min_y: -2,
            max_y: 1,
        };
        Self::with_extent(field, extent, chunk_res, cell_size)
    }

    /// Unbounded terrain seen to the horizon: chunk levels around the camera
    /// reaching `view_cells` cells out (see [`VolumeExtent::Horizon`]); finest
    /// chunks within two chunks of the camera, level-0 chunk rows -2 to 1
    /// (change them with [`KdVolume::with_level0`] and [`KdVolume::with_rows`]).
    /// `chunk_res` must be even.
    pub fn horizon(field: Arc<dyn Field>, chunk_res: u32, cell_size: f32, view_cells: u32) -> Self {
        let extent = VolumeExtent::Horizon {
            view_cells,
            level0_cells: 2 * chunk_res,
            min_y: -2,
            max_y: 1,
        };
        Self::with_extent(field, extent, chunk_res, cell_size)
    }

    /// A horizon volume whose finest chunks reach `cells` cells from the camera
    /// (no effect on other extents).
    pub fn with_level0(mut self, cells: u32) -> Self {
        if let VolumeExtent::Horizon { level0_cells, .. } = &mut self.extent {
            *level0_cells = cells;
        }
        self
    }

    /// The same volume with its surface at level `iso` of the field.
    pub fn with_iso(mut self, iso: f32) -> Self {
        self.iso = iso;
        self
    }

    /// A streaming or horizon volume limited to level-0 chunk rows
    /// `min_y..=max_y` (no effect on a bounded one).
    pub fn with_rows(mut self, min_y: i32, max_y: i32) -> Self {
        match &mut self.extent {
            VolumeExtent::Streaming {
                min_y: lo,
                max_y: hi,
                ..
            }
            | VolumeExtent::Horizon {
                min_y: lo,
                max_y: hi,
                ..
            } => (*lo, *hi) = (min_y, max_y),
            VolumeExtent::Bounded { .. } => {}
        }
        self
    }

    /// The same volume drawn with one `StandardMaterial`.
    pub fn with_material(mut self, material: Handle<StandardMaterial>) -> Self {
        self.material = VolumeMaterial::Standard(material);
        self
    }

    /// The same volume drawn with the [`TerrainMaterial`], which shows the
    /// field's materials (a field without materials shows layer 0 everywhere).
    pub fn with_terrain_material(mut self, material: Handle<TerrainMaterial>) -> Self {
        self.material = VolumeMaterial::Terrain(material);
        self
    }

    /// The same volume with crisp material borders on or off
    /// ([`KdVolume::material_borders`]).
    pub fn with_material_borders(mut self, crisp: bool) -> Self {
        self.material_borders = crisp;
        self
    }

    /// The field this volume meshes: its field at its iso level.
    pub(crate) fn shifted(field: &Arc<dyn Field>, iso: f32) -> Arc<dyn Field> {
        if iso == 0.0 {
            field.clone()
        } else {
            Arc::new(kdcontour::field::IsoShift {
                inner: field.clone(),
                iso,
            })
        }
    }
}

/// What a chunk is doing.
#[derive(Clone, Debug, Default, PartialEq, Reflect)]
pub enum ChunkStatus {
    /// Waiting for its first build.
    #[default]
    Pending,
    /// A build or extraction is queued or running.
    Busy,
    /// Shows a mesh.
    Meshed,
    /// Has no surface.
    Empty,
    /// Its last build or extraction failed, or an extra of its mesh could not
    /// be built (the message says why); an edit retries it.
    Failed(String),
}

/// One chunk of a [`KdVolume`] (a child entity).
#[derive(Component, Clone, Debug, Reflect)]
#[reflect(Component)]
pub struct KdChunk {
    /// The volume it belongs to.
    pub volume: Entity,
    /// Its chunk coordinates (in chunks of its level).
    pub coord: IVec3,
    /// Its level: cells of `2^level` volume cells (0 in a one-level volume).
    pub level: u32,
    /// The threshold of the mesh it shows.
    pub threshold: f32,
    /// Triangles in the mesh it shows.
    pub triangles: usize,
    /// What it is doing.
    pub status: ChunkStatus,
}

/// Marks the camera whose distance sets chunk thresholds (the first one found).
#[derive(Component, Clone, Copy, Debug, Default, Reflect)]
#[reflect(Component)]
pub struct LodCamera;

/// The camera position, if there is a [`LodCamera`].
pub(crate) fn lod_camera(camera: &Query<&GlobalTransform, With<LodCamera>>) -> Option<Vec3> {
    camera.iter().next().map(|t| t.translation())
}

/// World points in the local space of the volume at `volume` (where its chunks,
/// brushes and LOD distances are measured).
pub(crate) fn to_volume(volume: &GlobalTransform) -> impl Fn(Vec3) -> Vec3 {
    let inverse = volume.affine().inverse();
    move |p| inverse.transform_point3(p)
}

mod setup;

pub use setup::VolumePlugin;
