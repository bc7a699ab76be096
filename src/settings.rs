//! The plugin's settings: the [`KdContourSettings`] resource (task and upload
//! caps, the default threshold, the LOD curve) and [`SettingsPlugin`], which
//! inserts it.

use bevy::prelude::*;
use kdcontour::Lod;

/// How chunk thresholds follow the camera.
#[derive(Clone, Debug, PartialEq, Reflect)]
pub struct LodSettings {
    /// Whether the camera drives thresholds at all.
    pub enabled: bool,
    /// Threshold of chunks within `near` of the camera (squared cells).
    pub base: f32,
    /// Distance (world units) up to which chunks stay at `base`.
    pub near: f32,
    /// Growth of the threshold with distance (2: with its square).
    pub growth: f32,
    /// Largest threshold.
    pub max: f32,
    /// A chunk changes threshold only when the new one differs by more than this
    /// fraction, so chunks near a boundary do not flicker.
    pub hysteresis: f32,
}

impl Default for LodSettings {
    fn default() -> Self {
        LodSettings {
            enabled: true,
            base: 0.001,
            near: 16.0,
            growth: 2.0,
            max: 10.0,
            hysteresis: 0.25,
        }
    }
}

impl LodSettings {
    /// The core's threshold-over-distance curve for these settings.
    pub fn curve(&self) -> Lod {
        Lod {
            base: self.base,
            near: self.near,
            growth: self.growth,
            max: self.max,
        }
    }
}

/// The plugin's settings, mirrored into a reflected resource so they can change
/// at run time.
#[derive(Resource, Clone, Debug, PartialEq, Reflect)]
#[reflect(Resource)]
pub struct KdContourSettings {
    /// Most chunk builds and extractions running or queued for a worker at once.
    pub max_tasks_in_flight: usize,
    /// Threads that build and extract chunks (0: one per core). They are the
    /// plugin's own, at a lower priority than the frame's, not Bevy's task pools.
    pub chunk_threads: usize,
    /// Most chunk meshes uploaded per frame.
    pub max_uploads_per_frame: usize,
    /// Threshold of chunks before the camera sets one (or with LOD off).
    pub default_threshold: f32,
    /// Camera-driven level of detail.
    pub lod: LodSettings,
    /// Colour each chunk by its threshold (blue: finest, red: coarsest) instead of
    /// its volume's material, to see the LOD rings and seams. Drawn by the debug
    /// subsystem (crate feature `debug`, which `egui` turns on); without it this
    /// setting does nothing.
    pub color_by_lod: bool,
    /// How many edits (a stroke counts as one) [`crate::UndoEdit`] can take
    /// back per volume; older ones are compacted when saved. 0: no undo.
    pub undo_steps: usize,
}

impl KdContourSettings {
    /// The lowest threshold these settings cut a chunk at: the default
    /// threshold, or the LOD curve's lowest when the camera drives thresholds
    /// and that is finer (extras, a collider's, may cap chunks finer still).
    pub fn lowest_threshold(&self) -> f32 {
        let curve = if self.lod.enabled {
            self.lod.base.min(self.lod.max)
        } else {
            f32::INFINITY
        };
        self.default_threshold.min(curve)
    }
}

impl Default for KdContourSettings {
    fn default() -> Self {
        KdContourSettings {
            max_tasks_in_flight: 8,
            chunk_threads: 0,
            max_uploads_per_frame: 16,
            default_threshold: 0.01,
            lod: LodSettings::default(),
            color_by_lod: false,
            undo_steps: 256,
        }
    }
}

/// Inserts [`KdContourSettings`] (replacing any already there) and registers its
/// types for reflection.
#[derive(Default)]
pub struct SettingsPlugin {
    /// The initial settings.
    pub settings: KdContourSettings,
}

impl Plugin for SettingsPlugin {
    fn build(&self, app: &mut App) {
        app.insert_resource(self.settings.clone())
            .register_type::<KdContourSettings>()
            .register_type::<LodSettings>();
    }
}
