//! A small CSG modeller: build a solid from primitives combined in order with
//! union, difference, intersection or their smooth variants; select a shape (click
//! it, or pick it in the list), move and scale it, delete it, undo and redo, save
//! and load the JSON scene file (the format of `assets/scenes/README.md`). Only the chunks
//! a change can reach are re-meshed: the old and new bounds of the changed shape,
//! grown by its blend radius (the panel counts them).
//!
//! Each shape has a colour (a material id, saved in the scene file): the volume
//! uses the terrain material with flat tints, and borders between colours stay
//! crisp at every threshold.
//!
//! The model (layers, undo, save / load, the regions a change reaches) is
//! `kdcontour::field::layers`; this file is the window, the panel and the input.
//!
//! Keys: left click selects, Delete removes the selection, Ctrl+Z undo,
//! Ctrl+Y or Ctrl+Shift+Z redo, Ctrl+S save; WASD / E / Q and arrows or middle
//! mouse to fly. F1 hides the stats panel.
//!
//! ```text
//! cargo run --release --example csg_editor -- --scene my_scene.json
//! ```

mod common;

use bevy::prelude::*;
use bevy_kdcontour::kdcontour::field::layers::{self, Change, Layer, Layers, Operation, Solid};
use bevy_kdcontour::kdcontour::{self, Field};
use bevy_kdcontour::material::LAYERS;
use bevy_kdcontour::panel::bevy_egui::{egui, EguiContexts, EguiPrimaryContextPass};
use bevy_kdcontour::panel::KdContourPanel;
use bevy_kdcontour::prelude::*;
use clap::Parser;
use common::{FlyCam, ShotArgs};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Edit a CSG scene; only touched chunks re-mesh.
#[derive(Parser, Debug)]
struct Args {
    /// Scene file to load (if it exists) and save to. The default is in the OS
    /// temp directory, so a run never writes into the directory it was started
    /// from (usually the repository).
    #[arg(long, default_value_os_t = default_scene())]
    scene: PathBuf,
    #[command(flatten)]
    shot: ShotArgs,
}

/// Where the scene is saved unless `--scene` names a file.
fn default_scene() -> PathBuf {
    std::env::temp_dir().join("bevy_kdcontour_csg_scene.json")
}

/// Half the side of the edited cube (world units).
const HALF: f32 = 1.5;

#[derive(Resource)]
struct Editor {
    layers: Layers,
    selected: Option<usize>,
    path: PathBuf,
    message: Option<(String, bool)>,
    volume: Option<Entity>,
    /// Chunks the last change re-meshed, and how many there are.
    last_rebuilt: Option<(usize, usize)>,
    was_dragging: bool,
}

fn load(path: &Path) -> Result<Vec<Layer>, String> {
    // Read with a size limit (a FIFO or /dev/zero is refused, not read forever).
    let text = bevy_kdcontour::kdcontour::io::input::read_scene_text(path)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    // Errors name the line and column, or the node's path.
    layers::from_json(&text).map_err(|e| format!("{}: {e}", path.display()))
}

fn main() {
    let args = Args::parse();
    let list = if args.scene.exists() {
        load(&args.scene).unwrap_or_else(|e| common::fail(e))
    } else {
        layers::starter()
    };
    let layers = Layers::new(list).unwrap_or_else(|e| common::fail(e));
    let mut app = App::new();
    app.insert_resource(ClearColor(Color::srgb(0.14, 0.15, 0.18)));
    common::add_plugins(
        &mut app,
        "bevy_kdcontour: csg_editor",
        &args.shot,
        common::fixed(0.005),
        KdContourPanel {
            show_iso: false,
            ..default()
        },
    )
    .add_plugins(TerrainMaterialPlugin)
    .insert_resource(Editor {
        layers,
        selected: Some(1),
        path: args.scene.clone(),
        message: None,
        volume: None,
        last_rebuilt: None,
        was_dragging: false,
    })
    .add_systems(Startup, setup)
    .add_systems(Update, (common::fly_camera, pick, keys, highlight))
    .add_systems(EguiPrimaryContextPass, editor_panel)
    .add_systems(PostUpdate, count_rebuilt)
    .run();
}

/// The editor's colours, by material id (sRGB): sand, terracotta, teal, slate
/// blue, ochre, plum. Ids past the last wrap, as the terrain material's layers do.
const TINTS: [[f32; 3]; LAYERS] = [
    [0.80, 0.72, 0.62],
    [0.80, 0.42, 0.30],
    [0.22, 0.58, 0.60],
    [0.35, 0.45, 0.75],
    [0.85, 0.66, 0.25],
    [0.58, 0.36, 0.62],
];

/// The scene's field in the volume's local space (lattice origin at the cube's
/// corner).
fn field_of(layers: &Layers) -> Arc<dyn Field> {
    Arc::new(layers.field_at(Vec3::splat(HALF)))
}

fn setup(
    mut commands: Commands,
    mut editor: ResMut<Editor>,
    mut images: ResMut<Assets<Image>>,
    mut materials: ResMut<Assets<TerrainMaterial>>,
) {
    let field = field_of(&editor.layers);
    let res = 16;
    let chunks = 6;
    let tints = TINTS.map(|[r, g, b]| Color::srgb(r, g, b));
    let material = materials.add(TerrainTextures::generate(&mut images, 128).tinted(tints));
    let volume = commands
        .spawn((
            KdVolume::new(
                field,
                UVec3::splat(chunks),
                res,
                2.0 * HALF / (chunks * res) as f32,
            )
            .with_terrain_material(material),
            Transform::from_translation(Vec3::splat(-HALF)),
        ))
        .id();
    editor.volume = Some(volume);
    let (fly, t) = FlyCam::looking(Vec3::new(2.2, 1.9, 3.0), Vec3::new(0.0, -0.1, 0.0), 1.5);
    commands.spawn((Camera3d::default(), fly, t));
    common::spawn_lights(&mut commands);
}

fn count_rebuilt(
    mut editor: ResMut<Editor>,
    mut applied: MessageReader<EditApplied>,
    volumes: Query<&VolumeState>,
) {
    for a in applied.read() {
        let total = volumes.get(a.volume).map(|s| s.world().len()).unwrap_or(0);
        editor.last_rebuilt = Some((a.rebuilt.len(), total));
    }
}

/// Sends the changed scene to the volume, which re-meshes only the chunks the
/// change reaches; an impossible change is refused and shown.
fn apply(
    editor: &mut Editor,
    change: Result<Change, kdcontour::Error>,
    replace: &mut MessageWriter<ReplaceField>,
) {
    let change = match change {
        Ok(c) => c,
        Err(e) => {
            editor.message = Some((e.to_string(), true));
            return;
        }
    };
    let n = editor.layers.list().len();
    editor.selected = editor.selected.filter(|&i| i < n);
    if let Some(volume) = editor.volume {
        let to_local = |(c, r): (Vec3, f32)| (c + Vec3::splat(HALF), r);
        replace.write(ReplaceField {
            volume,
            field: SharedField(field_of(&editor.layers)),
            regions: change
                .regions
                .map(|r| r.into_iter().map(to_local).collect()),
        });
    }
}

fn undo(editor: &mut Editor, replace: &mut MessageWriter<ReplaceField>) {
    if let Some(change) = editor.layers.undo() {
        apply(editor, Ok(change), replace);
    }
}

fn redo(editor: &mut Editor, replace: &mut MessageWriter<ReplaceField>) {
    if let Some(change) = editor.layers.redo() {
        apply(editor, Ok(change), replace);
    }
}

fn save(editor: &mut Editor) {
    let text = layers::to_json(editor.layers.list());
    // Through a temporary file and a rename: a failed write leaves the old
    // scene whole.
    let written = bevy_kdcontour::kdcontour::io::write_atomic(&editor.path, |w| {
        std::io::Write::write_all(w, text.as_bytes())
    });
    editor.message = Some(match written {
        Ok(()) => (format!("saved {}", editor.path.display()), false),
        Err(e) => (format!("{}: {e}", editor.path.display()), true),
    });
}

fn keys(
    keys: Res<ButtonInput<KeyCode>>,
    mut editor: ResMut<Editor>,
    mut replace: MessageWriter<ReplaceField>,
    panel: Res<KdContourPanel>,
) {
    let ctrl = keys.pressed(KeyCode::ControlLeft) || keys.pressed(KeyCode::ControlRight);
    let shift = keys.pressed(KeyCode::ShiftLeft) || keys.pressed(KeyCode::ShiftRight);
    if ctrl && keys.just_pressed(KeyCode::KeyZ) {
        if shift {
            redo(&mut editor, &mut replace);
        } else {
            undo(&mut editor, &mut replace);
        }
    } else if ctrl && keys.just_pressed(KeyCode::KeyY) {
        redo(&mut editor, &mut replace);
    } else if ctrl && keys.just_pressed(KeyCode::KeyS) {
        save(&mut editor);
    } else if keys.just_pressed(KeyCode::Delete) && !panel.pointer_over {
        if let Some(i) = editor.selected.take() {
            let mut list = editor.layers.list().to_vec();
            if i < list.len() {
                list.remove(i);
                let change = editor.layers.edit(list);
                apply(&mut editor, change, &mut replace);
            }
        }
    }
}

/// Left click selects the shape whose own surface the cursor ray meets first.
fn pick(
    buttons: Res<ButtonInput<MouseButton>>,
    panel: Res<KdContourPanel>,
    windows: Query<&Window>,
    cameras: Query<(&Camera, &GlobalTransform)>,
    mut editor: ResMut<Editor>,
) {
    if !buttons.just_pressed(MouseButton::Left) || panel.pointer_over {
        return;
    }
    let (Ok(window), Ok((camera, tf))) = (windows.single(), cameras.single()) else {
        return;
    };
    let Some(ray) = window
        .cursor_position()
        .and_then(|c| camera.viewport_to_world(tf, c).ok())
    else {
        return;
    };
    editor.selected = editor.layers.pick(ray.origin, *ray.direction, 50.0, 0.05);
}

/// Outlines the selected shape's bounds (compiled once per change, not per frame).
fn highlight(editor: Res<Editor>, mut gizmos: Gizmos) {
    if let Some((c, r)) = editor.selected.and_then(|i| editor.layers.reach(i)) {
        gizmos.sphere(
            Isometry3d::from_translation(c),
            r,
            Color::srgb(1.0, 0.8, 0.2),
        );
    }
}

/// What a panel button asked for.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Action {
    Undo,
    Redo,
    Save,
    Load,
    Delete,
}

fn editor_panel(
    mut contexts: EguiContexts,
    mut editor: ResMut<Editor>,
    mut replace: MessageWriter<ReplaceField>,
) -> Result {
    let ctx = contexts.ctx_mut()?;
    // The panel edits a copy; a difference at the end is one change.
    let mut draft = editor.layers.list().to_vec();
    let mut action: Option<Action> = None;
    egui::Window::new("scene")
        .default_pos([1280.0 - 330.0, 10.0])
        .default_width(310.0)
        .resizable(false)
        .show(ctx, |ui| {
            let ed = &mut *editor;
            ui.horizontal(|ui| {
                let history = [
                    (ed.layers.can_undo(), "undo", Action::Undo),
                    (ed.layers.can_redo(), "redo", Action::Redo),
                ];
                for (enabled, text, a) in history {
                    if ui.add_enabled(enabled, egui::Button::new(text)).clicked() {
                        action = Some(a);
                    }
                }
                if ui.button("save").clicked() {
                    action = Some(Action::Save);
                }
                if ui.button("load").clicked() {
                    action = Some(Action::Load);
                }
            });
            ui.small(ed.path.display().to_string());
            ui.separator();
            for (i, s) in draft.iter().enumerate() {
                let text = if i == 0 {
                    format!("{i}: {}", s.label())
                } else {
                    format!("{i}: {} {}", s.operation.name(), s.label())
                };
                if ui.selectable_label(ed.selected == Some(i), text).clicked() {
                    ed.selected = Some(i);
                }
            }
            ui.horizontal_wrapped(|ui| {
                ui.label("add:");
                for k in Solid::ALL {
                    if ui.small_button(format!("{k:?}")).clicked() {
                        let at = Vec3::new(0.0, 1.0, 0.0);
                        let colour = (draft.len() % LAYERS) as u8;
                        draft.push(
                            Layer::new(k, Operation::Union, 0.1, at, 0.8).with_material(colour),
                        );
                        ed.selected = Some(draft.len() - 1);
                    }
                }
            });
            ui.separator();
            if let Some(i) = ed.selected.filter(|&i| i < draft.len()) {
                let s = &mut draft[i];
                ui.strong(format!("shape {i}: {}", s.label()));
                if i > 0 {
                    egui::ComboBox::from_label("operation")
                        .selected_text(s.operation.name())
                        .show_ui(ui, |ui| {
                            for o in Operation::ALL {
                                ui.selectable_value(&mut s.operation, o, o.name());
                            }
                        });
                    if s.operation.is_smooth() {
                        ui.add(egui::Slider::new(&mut s.blend, 0.01..=0.5).text("blend"));
                    }
                }
                for (a, name) in [(0, "x"), (1, "y"), (2, "z")] {
                    ui.add(egui::Slider::new(&mut s.translate[a], -HALF..=HALF).text(name));
                }
                ui.add(
                    egui::Slider::new(&mut s.scale, 0.1..=3.0)
                        .logarithmic(true)
                        .text("scale"),
                );
                ui.horizontal(|ui| {
                    ui.label("colour");
                    for (id, [r, g, b]) in TINTS.iter().enumerate() {
                        let fill = egui::Color32::from_rgb(
                            (r * 255.0) as u8,
                            (g * 255.0) as u8,
                            (b * 255.0) as u8,
                        );
                        let chosen = s.material as usize % LAYERS == id;
                        let stroke = if chosen {
                            egui::Stroke::new(2.0, egui::Color32::WHITE)
                        } else {
                            egui::Stroke::NONE
                        };
                        let swatch = egui::Button::new("")
                            .fill(fill)
                            .stroke(stroke)
                            .min_size(egui::vec2(22.0, 18.0));
                        if ui.add(swatch).clicked() {
                            s.material = id as u8;
                        }
                    }
                });
                if ui.button("delete").clicked() {
                    action = Some(Action::Delete);
                }
            } else {
                ui.label("click a shape to select it");
            }
            ui.separator();
            if let Some((n, total)) = ed.last_rebuilt {
                ui.label(format!("last change re-meshed {n} of {total} chunks"));
            }
            if let Some((m, is_err)) = &ed.message {
                if *is_err {
                    ui.colored_label(egui::Color32::LIGHT_RED, m);
                } else {
                    ui.label(m);
                }
            }
        });
    let dragging = ctx.dragged_id().is_some();
    let ed = &mut *editor;
    match action {
        Some(Action::Undo) => undo(ed, &mut replace),
        Some(Action::Redo) => redo(ed, &mut replace),
        Some(Action::Save) => save(ed),
        Some(Action::Load) => match load(&ed.path) {
            Ok(list) => {
                ed.selected = None;
                let change = ed.layers.edit(list);
                if change.is_ok() {
                    ed.message = Some((format!("loaded {}", ed.path.display()), false));
                }
                apply(ed, change, &mut replace);
            }
            Err(e) => ed.message = Some((e, true)),
        },
        Some(Action::Delete) => {
            if let Some(i) = ed.selected.take() {
                draft.remove(i);
            }
        }
        None => {}
    }
    let edited = matches!(action, None | Some(Action::Delete));
    if edited && draft != ed.layers.list() {
        // One undo step per drag, not one per frame of it.
        let change = if dragging && ed.was_dragging {
            ed.layers.continue_edit(draft)
        } else {
            ed.layers.edit(draft)
        };
        apply(ed, change, &mut replace);
    }
    ed.was_dragging = dragging;
    Ok(())
}
