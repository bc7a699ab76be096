//! An egui panel for the plugin (crate feature `egui`): counts, meshing times,
//! the threshold and the LOD curve, the iso value, wireframe and LOD colouring,
//! each edited volume's undo and redo, (feature `avian`) the collider
//! distance, threshold and layers, and (feature `navmesh`) the navmesh agent's
//! radius, height, slope and climb with the tiles' counts.
//!
//! Add [`KdContourPanelPlugin`] after [`crate::KdContourPlugins`] (it adds
//! `bevy_egui`'s `EguiPlugin` and Bevy's `WireframePlugin` when they are missing).
//! It edits [`KdContourSettings`], every [`KdVolume`]'s `iso`, and Bevy's
//! `WireframeConfig`; it reads [`KdContourStats`] and each [`VolumeState`]'s
//! history, and writes [`UndoEdit`] and [`RedoEdit`]. Examples add their own rows
//! through [`KdContourPanel::extra`] or draw their own windows.

use crate::{KdContourSettings, KdContourStats, KdVolume, RedoEdit, UndoEdit, VolumeState};
use bevy::diagnostic::{DiagnosticsStore, FrameTimeDiagnosticsPlugin};
use bevy::pbr::wireframe::{WireframeConfig, WireframePlugin};
use bevy::prelude::*;
use bevy_egui::{egui, EguiContexts, EguiPlugin, EguiPrimaryContextPass};
use std::ops::RangeInclusive;

pub use bevy_egui;

/// Adds the panel.
#[derive(Default)]
pub struct KdContourPanelPlugin {
    /// Initial panel state.
    pub panel: KdContourPanel,
}

/// The panel's state.
#[derive(Resource, Clone, Debug)]
pub struct KdContourPanel {
    /// Whether the panel is shown (F1 toggles it).
    pub open: bool,
    /// Range of the iso-value slider (it edits every [`KdVolume`]'s `iso`).
    pub iso_range: RangeInclusive<f32>,
    /// Whether to show the iso slider at all.
    pub show_iso: bool,
    /// Lines the app adds under the counts (cleared by the app, not the panel).
    pub extra: Vec<String>,
    /// Whether the pointer is over the panel this frame (apps skip their own
    /// mouse handling then).
    pub pointer_over: bool,
}

impl Default for KdContourPanel {
    fn default() -> Self {
        KdContourPanel {
            open: true,
            iso_range: -1.0..=1.0,
            show_iso: true,
            extra: Vec::new(),
            pointer_over: false,
        }
    }
}

impl Plugin for KdContourPanelPlugin {
    fn build(&self, app: &mut App) {
        if !app.is_plugin_added::<EguiPlugin>() {
            app.add_plugins(EguiPlugin::default());
        }
        if !app.is_plugin_added::<WireframePlugin>() {
            app.add_plugins(WireframePlugin::default());
        }
        if !app.is_plugin_added::<FrameTimeDiagnosticsPlugin>() {
            app.add_plugins(FrameTimeDiagnosticsPlugin::default());
        }
        app.insert_resource(self.panel.clone())
            .add_systems(Update, toggle_panel)
            .add_systems(EguiPrimaryContextPass, draw_panel);
    }
}

fn toggle_panel(keys: Res<ButtonInput<KeyCode>>, mut panel: ResMut<KdContourPanel>) {
    if keys.just_pressed(KeyCode::F1) {
        panel.open = !panel.open;
    }
}

/// A logarithmic slider over `range` for a positive value.
fn log_slider(ui: &mut egui::Ui, value: &mut f32, range: RangeInclusive<f32>, label: &str) {
    ui.add(
        egui::Slider::new(value, range)
            .logarithmic(true)
            .text(label),
    );
}

/// The collider settings: on or off, distance, threshold; the layers' bits.
#[cfg(feature = "avian")]
fn collider_rows(ui: &mut egui::Ui, c: &mut crate::ColliderSettings) {
    ui.separator();
    ui.checkbox(&mut c.enabled, "colliders");
    if c.enabled {
        ui.add(
            egui::Slider::new(&mut c.distance, 1.0..=512.0)
                .logarithmic(true)
                .text("collider distance"),
        );
        log_slider(ui, &mut c.threshold, 1e-5..=1.0, "collider threshold");
        layer_bits(ui, "member of layers", &mut c.layers.memberships.0);
        layer_bits(ui, "collides with", &mut c.layers.filters.0);
    }
}

/// The navmesh settings: on or off, the agent (radius, height, steepest
/// slope, climb) and the distance; returns new settings when they changed. A
/// new agent rebuilds every tile, so a slider edits a draft and the settings
/// take it when the drag ends.
#[cfg(feature = "navmesh")]
fn navmesh_rows(
    ui: &mut egui::Ui,
    settings: &crate::NavmeshSettings,
    draft: &mut Option<crate::NavmeshSettings>,
    stats: &crate::NavStats,
) -> Option<crate::NavmeshSettings> {
    ui.separator();
    let mut enabled = settings.enabled;
    let mut out = None;
    if ui.checkbox(&mut enabled, "navmesh").changed() {
        out = Some(crate::NavmeshSettings {
            enabled,
            ..settings.clone()
        });
    }
    if !enabled {
        return out;
    }
    let d = draft.get_or_insert_with(|| settings.clone());
    let mut commit = false;
    let mut row = |ui: &mut egui::Ui, v: &mut f32, range: RangeInclusive<f32>, label: &str| {
        let r = ui.add(egui::Slider::new(v, range).text(label));
        commit |= r.drag_stopped() || (r.changed() && !r.dragged());
    };
    row(ui, &mut d.agent_radius, 0.1..=2.0, "agent radius");
    row(ui, &mut d.agent_height, 0.5..=4.0, "agent height");
    row(
        ui,
        &mut d.max_slope_degrees,
        5.0..=85.0,
        "max slope (degrees)",
    );
    row(ui, &mut d.max_climb, 0.0..=2.0, "max climb");
    row(ui, &mut d.distance, 8.0..=256.0, "navmesh distance");
    if commit {
        out = Some(crate::NavmeshSettings {
            enabled,
            ..d.clone()
        });
    }
    ui.small(format!(
        "{} tiles, {} polygons, {} links; slowest tile {:.1} ms",
        stats.tiles, stats.polygons, stats.links, stats.build_ms_max
    ));
    if let Some(e) = &stats.last_error {
        ui.small(e.as_str());
    }
    out
}

/// Checkboxes for bits 0-7 of a collision layer mask (higher bits are kept
/// as they are, and shown).
#[cfg(feature = "avian")]
fn layer_bits(ui: &mut egui::Ui, label: &str, mask: &mut u32) {
    ui.horizontal(|ui| {
        ui.label(label);
        for bit in 0..8 {
            let mut on = *mask & (1 << bit) != 0;
            if ui.checkbox(&mut on, bit.to_string()).changed() {
                *mask ^= 1 << bit;
            }
        }
        if *mask >> 8 != 0 {
            ui.small(format!("+ {:#x}", *mask & !0xff));
        }
    });
}

/// A row per edited volume (at most four): its edits and undo / redo buttons.
fn history_rows(
    ui: &mut egui::Ui,
    states: &Query<(Entity, &VolumeState)>,
    undo: &mut MessageWriter<UndoEdit>,
    redo: &mut MessageWriter<RedoEdit>,
) {
    let edited = states.iter().filter(|(_, s)| s.history().brush_count() > 0);
    for (volume, state) in edited.take(4) {
        let h = state.history();
        ui.horizontal(|ui| {
            ui.label(format!("{} edits", state.field().edit_count()));
            let can_undo = h.undo_steps() > 0;
            if ui
                .add_enabled(
                    can_undo,
                    egui::Button::new(format!("undo ({})", h.undo_steps())),
                )
                .clicked()
            {
                undo.write(UndoEdit { volume });
            }
            let can_redo = h.redo_steps() > 0;
            if ui
                .add_enabled(
                    can_redo,
                    egui::Button::new(format!("redo ({})", h.redo_steps())),
                )
                .clicked()
            {
                redo.write(RedoEdit { volume });
            }
        });
    }
}

// A Bevy system takes one parameter per resource it reads.
#[allow(clippy::too_many_arguments)]
fn draw_panel(
    mut contexts: EguiContexts,
    mut panel: ResMut<KdContourPanel>,
    mut settings: ResMut<KdContourSettings>,
    stats: Res<KdContourStats>,
    diagnostics: Option<Res<DiagnosticsStore>>,
    wireframe: Option<ResMut<WireframeConfig>>,
    mut volumes: Query<&mut KdVolume>,
    states: Query<(Entity, &VolumeState)>,
    mut undo: MessageWriter<UndoEdit>,
    mut redo: MessageWriter<RedoEdit>,
    #[cfg(feature = "avian")] colliders: Option<ResMut<crate::ColliderSettings>>,
    #[cfg(feature = "navmesh")] navmesh: Option<(
        ResMut<crate::NavmeshSettings>,
        Res<crate::NavStats>,
    )>,
    #[cfg(feature = "navmesh")] mut nav_draft: Local<Option<crate::NavmeshSettings>>,
) -> Result {
    let ctx = contexts.ctx_mut()?;
    if !panel.open {
        panel.pointer_over = false;
        return Ok(());
    }
    let frame_ms = diagnostics
        .as_ref()
        .and_then(|d| d.get(&FrameTimeDiagnosticsPlugin::FRAME_TIME))
        .and_then(|d| d.smoothed());
    let mut wireframe = wireframe;
    egui::Window::new("kdcontour")
        .default_pos([10.0, 10.0])
        .default_width(280.0)
        .resizable(false)
        .show(ctx, |ui| {
            egui::Grid::new("counts").num_columns(2).show(ui, |ui| {
                if let Some(ms) = frame_ms {
                    ui.label("frame");
                    ui.label(format!("{ms:.1} ms ({:.0} fps)", 1000.0 / ms.max(1e-3)));
                    ui.end_row();
                }
                ui.label("plugin, main thread");
                ui.label(format!(
                    "{:.2} ms ({:.2} ms processor)",
                    stats.main_thread_ms, stats.main_thread_cpu_ms
                ));
                ui.end_row();
                ui.label("chunks");
                ui.label(format!("{} meshed / {}", stats.meshed_chunks, stats.chunks));
                ui.end_row();
                ui.label("triangles");
                ui.label(format!("{}", stats.triangles));
                ui.end_row();
                ui.label("tasks");
                ui.label(format!(
                    "{} running, {} queued",
                    stats.tasks_in_flight, stats.queued
                ));
                ui.end_row();
                ui.label("chunk build");
                ui.label(format!("{:.2} ms ({} done)", stats.build_ms, stats.builds));
                ui.end_row();
                ui.label("extraction");
                ui.label(format!(
                    "{:.2} ms ({} done)",
                    stats.extract_ms, stats.extractions
                ));
                ui.end_row();
                ui.label("thresholds");
                ui.label(format!(
                    "{:.3} to {:.3}",
                    stats.threshold_range.0, stats.threshold_range.1
                ));
                ui.end_row();
            });
            for line in &panel.extra {
                ui.label(line);
            }
            history_rows(ui, &states, &mut undo, &mut redo);
            ui.separator();
            let s = &mut *settings;
            ui.checkbox(&mut s.lod.enabled, "camera LOD");
            if s.lod.enabled {
                log_slider(ui, &mut s.lod.base, 1e-5..=1.0, "base threshold");
                ui.add(
                    egui::Slider::new(&mut s.lod.near, 0.01..=500.0)
                        .logarithmic(true)
                        .text("near"),
                );
                ui.add(egui::Slider::new(&mut s.lod.growth, 0.0..=4.0).text("growth"));
                log_slider(ui, &mut s.lod.max, 1e-4..=100.0, "max threshold");
                ui.add(egui::Slider::new(&mut s.lod.hysteresis, 0.0..=2.0).text("hysteresis"));
                s.lod.max = s.lod.max.max(s.lod.base);
            } else {
                log_slider(ui, &mut s.default_threshold, 1e-5..=10.0, "threshold");
            }
            if panel.show_iso {
                if let Some(mut vol) = volumes.iter_mut().next() {
                    let mut iso = vol.iso;
                    let range = panel.iso_range.clone();
                    ui.add(egui::Slider::new(&mut iso, range).text("iso value"));
                    if iso != vol.iso {
                        // Every volume follows the slider.
                        vol.iso = iso;
                        for mut other in volumes.iter_mut().skip(1) {
                            other.iso = iso;
                        }
                    }
                }
            }
            #[cfg(feature = "avian")]
            if let Some(mut c) = colliders {
                collider_rows(ui, &mut c);
            }
            #[cfg(feature = "navmesh")]
            if let Some((mut n, stats)) = navmesh {
                if n.is_changed() {
                    *nav_draft = Some(n.clone());
                }
                // Written only on a change: a new agent rebuilds every tile.
                if let Some(new) = navmesh_rows(ui, &n, &mut nav_draft, &stats) {
                    *n = new;
                }
            }
            ui.horizontal(|ui| {
                if let Some(w) = wireframe.as_mut() {
                    ui.checkbox(&mut w.global, "wireframe");
                }
                ui.checkbox(&mut s.color_by_lod, "colour by LOD");
            });
            ui.small("F1 hides this panel");
        });
    panel.pointer_over = ctx.is_pointer_over_egui() || ctx.egui_wants_pointer_input();
    Ok(())
}
