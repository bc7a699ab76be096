//! A small CSG modeller: build a solid from primitives combined in order with
//! union, difference, intersection or their smooth variants; select a shape (click
//! it, or pick it in the list), move and scale it, delete it, undo and redo, save
//! and load the JSON scene file (the format of `scenes/README.md`). Only the chunks
//! a change can reach are re-meshed: the old and new bounds of the changed shape,
//! grown by its blend radius (the panel counts them).
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
use bevy_kdcontour::kdcontour::field::raycast;
use bevy_kdcontour::kdcontour::{Csg, CsgNode, Field};
use bevy_kdcontour::panel::bevy_egui::{egui, EguiContexts, EguiPrimaryContextPass};
use bevy_kdcontour::panel::{KdContourPanel, KdContourPanelPlugin};
use bevy_kdcontour::prelude::*;
use clap::Parser;
use common::{FlyCam, ShotArgs, ShotPlugin};
use serde_json::{json, Value};
use std::path::PathBuf;
use std::sync::Arc;

/// Edit a CSG scene; only touched chunks re-mesh.
#[derive(Parser, Debug)]
struct Args {
    /// Scene file to load (if it exists) and save to.
    #[arg(long, default_value = "csg_scene.json")]
    scene: PathBuf,
    #[command(flatten)]
    shot: ShotArgs,
}

/// Half the side of the edited cube (world units).
const HALF: f32 = 1.5;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Sphere,
    Box,
    RoundedBox,
    Torus,
    Cylinder,
    Capsule,
    Cone,
}

const KINDS: [Kind; 7] = [
    Kind::Sphere,
    Kind::Box,
    Kind::RoundedBox,
    Kind::Torus,
    Kind::Cylinder,
    Kind::Capsule,
    Kind::Cone,
];

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Op {
    Union,
    Difference,
    Intersection,
    SmoothUnion,
    SmoothDifference,
    SmoothIntersection,
}

const OPS: [Op; 6] = [
    Op::Union,
    Op::Difference,
    Op::Intersection,
    Op::SmoothUnion,
    Op::SmoothDifference,
    Op::SmoothIntersection,
];

impl Op {
    fn name(self) -> &'static str {
        match self {
            Op::Union => "union",
            Op::Difference => "difference",
            Op::Intersection => "intersection",
            Op::SmoothUnion => "smooth_union",
            Op::SmoothDifference => "smooth_difference",
            Op::SmoothIntersection => "smooth_intersection",
        }
    }
    fn smooth(self) -> bool {
        matches!(
            self,
            Op::SmoothUnion | Op::SmoothDifference | Op::SmoothIntersection
        )
    }
}

/// What a shape is: a primitive, or a subtree loaded from a file that is not a
/// chain of transformed primitives (kept whole, still movable and scalable).
#[derive(Clone, Debug, PartialEq)]
enum Body {
    Primitive(Kind),
    Imported(Value),
}

#[derive(Clone, Debug, PartialEq)]
struct Shape {
    body: Body,
    /// How it combines with everything before it (ignored for the first).
    op: Op,
    /// Blend radius of smooth ops.
    blend: f32,
    pos: Vec3,
    scale: f32,
}

impl Shape {
    fn label(&self) -> String {
        match &self.body {
            Body::Primitive(k) => format!("{k:?}"),
            Body::Imported(_) => "imported".into(),
        }
    }

    /// The shape alone, as a scene node.
    fn node(&self) -> Value {
        let child = match &self.body {
            Body::Primitive(k) => match k {
                Kind::Sphere => json!({"type": "sphere", "radius": 0.5}),
                Kind::Box => json!({"type": "box", "half_extents": [0.4, 0.4, 0.4]}),
                Kind::RoundedBox => {
                    json!({"type": "rounded_box", "half_extents": [0.4, 0.4, 0.4], "radius": 0.12})
                }
                Kind::Torus => json!({"type": "torus", "major_radius": 0.4, "minor_radius": 0.14}),
                Kind::Cylinder => json!({"type": "cylinder", "radius": 0.3, "half_height": 0.45}),
                Kind::Capsule => json!({"type": "capsule", "radius": 0.25, "half_height": 0.35}),
                Kind::Cone => json!({"type": "cone", "radius": 0.4, "half_height": 0.5}),
            },
            Body::Imported(v) => v.clone(),
        };
        json!({
            "type": "transform",
            "translate": self.pos.to_array(),
            "scale": self.scale,
            "child": child,
        })
    }

    /// Where the shape can change the scene: its bounding sphere grown by its blend
    /// radius, or `None` when it is unbounded.
    fn reach(&self) -> Option<(Vec3, f32)> {
        let csg = compile(&self.node()).ok()?;
        let (c, r) = csg.bounding_sphere()?;
        Some((c, r + if self.op.smooth() { self.blend } else { 0.0 }))
    }
}

/// A scene node, checked and compiled.
fn compile(v: &Value) -> Result<Csg, String> {
    CsgNode::from_json(&v.to_string())
        .map_err(|e| e.to_string())?
        .compile()
        .map_err(|e| e.to_string())
}

/// The whole scene as one node: a left fold of the shapes in order.
fn scene_node(shapes: &[Shape]) -> Value {
    let Some(first) = shapes.first() else {
        // Nothing: a sphere far outside the cube, so the field stays finite.
        return json!({"type": "sphere", "radius": 0.01, "center": [100.0, 100.0, 100.0]});
    };
    let mut acc = first.node();
    for s in &shapes[1..] {
        let b = s.node();
        acc = match s.op {
            Op::Union | Op::Intersection => json!({"type": s.op.name(), "children": [acc, b]}),
            Op::SmoothUnion | Op::SmoothIntersection => {
                json!({"type": s.op.name(), "radius": s.blend, "children": [acc, b]})
            }
            Op::Difference => json!({"type": "difference", "a": acc, "b": b}),
            Op::SmoothDifference => {
                json!({"type": "smooth_difference", "radius": s.blend, "a": acc, "b": b})
            }
        };
    }
    acc
}

/// Reads a scene node back into shapes: a left fold of transformed shapes comes
/// back as the list it was saved from; anything else becomes one imported shape.
fn shapes_of(v: &Value) -> Vec<Shape> {
    fn leaf(v: &Value, op: Op, blend: f32) -> Shape {
        if v["type"] == "transform" && v.get("rotate_axis").is_none() {
            let pos = v["translate"]
                .as_array()
                .and_then(|a| {
                    let f: Vec<f32> = a
                        .iter()
                        .filter_map(|x| x.as_f64())
                        .map(|x| x as f32)
                        .collect();
                    (f.len() == 3).then(|| Vec3::new(f[0], f[1], f[2]))
                })
                .unwrap_or(Vec3::ZERO);
            let scale = v["scale"].as_f64().unwrap_or(1.0) as f32;
            let child = &v["child"];
            let body = KINDS
                .into_iter()
                .find(|k| {
                    Shape {
                        body: Body::Primitive(*k),
                        op,
                        blend,
                        pos: Vec3::ZERO,
                        scale: 1.0,
                    }
                    .node()["child"]
                        == *child
                })
                .map(Body::Primitive)
                .unwrap_or_else(|| Body::Imported(child.clone()));
            return Shape {
                body,
                op,
                blend,
                pos,
                scale,
            };
        }
        Shape {
            body: Body::Imported(v.clone()),
            op,
            blend,
            pos: Vec3::ZERO,
            scale: 1.0,
        }
    }
    let op = OPS.into_iter().find(|o| v["type"] == o.name());
    let blend = v["radius"].as_f64().unwrap_or(0.1) as f32;
    let pair = match op {
        Some(Op::Difference | Op::SmoothDifference) => Some((&v["a"], &v["b"])),
        Some(_) => v["children"]
            .as_array()
            .filter(|c| c.len() == 2)
            .map(|c| (&c[0], &c[1])),
        None => None,
    };
    match (op, pair) {
        (Some(op), Some((a, b))) => {
            let mut out = shapes_of(a);
            out.push(leaf(b, op, blend));
            out
        }
        _ => vec![leaf(v, Op::Union, 0.1)],
    }
}

#[derive(Resource)]
struct Editor {
    shapes: Vec<Shape>,
    selected: Option<usize>,
    undo: Vec<Vec<Shape>>,
    redo: Vec<Vec<Shape>>,
    path: PathBuf,
    message: Option<(String, bool)>,
    volume: Option<Entity>,
    /// Chunks the last change re-meshed, and how many there are.
    last_rebuilt: Option<(usize, usize)>,
    was_dragging: bool,
}

fn load(path: &PathBuf) -> Result<Vec<Shape>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    // Parse and check it as a scene first: errors name the line and column, or
    // the node's path.
    let node = CsgNode::from_json(&text).map_err(|e| format!("{}: {e}", path.display()))?;
    node.compile()
        .map_err(|e| format!("{}: {e}", path.display()))?;
    let v: Value = serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(shapes_of(&v))
}

fn starter() -> Vec<Shape> {
    let s = |body, op, pos: Vec3, scale| Shape {
        body: Body::Primitive(body),
        op,
        blend: 0.12,
        pos,
        scale,
    };
    vec![
        s(Kind::RoundedBox, Op::Union, Vec3::new(0.0, -0.1, 0.0), 1.6),
        s(Kind::Sphere, Op::SmoothUnion, Vec3::new(0.0, 0.6, 0.0), 1.3),
        s(
            Kind::Cylinder,
            Op::Difference,
            Vec3::new(0.0, 1.15, 0.0),
            1.1,
        ),
        s(
            Kind::Torus,
            Op::SmoothUnion,
            Vec3::new(0.0, -0.55, 0.0),
            2.2,
        ),
        s(
            Kind::Capsule,
            Op::SmoothDifference,
            Vec3::new(0.55, 0.1, 0.75),
            0.9,
        ),
    ]
}

fn main() {
    let args = Args::parse();
    let shapes = if args.scene.exists() {
        load(&args.scene).unwrap_or_else(|e| common::fail(e))
    } else {
        starter()
    };
    App::new()
        .insert_resource(ClearColor(Color::srgb(0.14, 0.15, 0.18)))
        .add_plugins((
            common::default_plugins("bevy_kdcontour: csg_editor", &args.shot),
            KdContourPlugin {
                settings: KdContourSettings {
                    // Chunk tasks take milliseconds; allow many per frame so
                    // a slow (software-rendered) frame does not throttle meshing.
                    max_tasks_in_flight: 32,
                    lod: LodSettings {
                        enabled: false,
                        ..default()
                    },
                    default_threshold: 0.005,
                    ..default()
                },
            },
            KdContourPanelPlugin {
                panel: KdContourPanel {
                    show_iso: false,
                    ..default()
                },
            },
            ShotPlugin(args.shot.clone()),
        ))
        .insert_resource(Editor {
            shapes,
            selected: Some(1),
            undo: Vec::new(),
            redo: Vec::new(),
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

/// The scene's field in the volume's local space (lattice origin at the cube's
/// corner).
fn field_of(shapes: &[Shape]) -> Result<Arc<dyn Field>, String> {
    let node = json!({
        "type": "transform",
        "translate": [HALF, HALF, HALF],
        "child": scene_node(shapes),
    });
    Ok(Arc::new(compile(&node)?))
}

fn setup(
    mut commands: Commands,
    mut editor: ResMut<Editor>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    let field = field_of(&editor.shapes).unwrap_or_else(|e| common::fail(e));
    let res = 16;
    let chunks = 6;
    let material = materials.add(StandardMaterial {
        base_color: Color::srgb(0.8, 0.72, 0.62),
        perceptual_roughness: 0.5,
        ..default()
    });
    let volume = commands
        .spawn((
            KdVolume::new(
                field,
                UVec3::splat(chunks),
                res,
                2.0 * HALF / (chunks * res) as f32,
            )
            .with_material(material),
            Transform::from_translation(Vec3::splat(-HALF)),
        ))
        .id();
    editor.volume = Some(volume);
    let (fly, t) = FlyCam::looking(Vec3::new(2.2, 1.9, 3.0), Vec3::new(0.0, -0.1, 0.0), 1.5);
    commands.spawn((Camera3d::default(), fly, t));
    common::spawn_lights(&mut commands);
}

/// Applies a new shape list: re-meshes only where the changed shapes were or are.
///
/// Outside a shape's bounding sphere (grown by its blend radius) its distance is
/// positive, so the scene's inside / outside and its surface there do not depend on
/// it; chunks that never meet either sphere keep their trees. (A smooth operation
/// later in the list could in principle carry a change a blend radius further; the
/// regions do not grow for that.)
fn commit(editor: &mut Editor, before: Vec<Shape>, replace: &mut MessageWriter<ReplaceField>) {
    let field = match field_of(&editor.shapes) {
        Ok(f) => f,
        Err(e) => {
            editor.message = Some((e, true));
            editor.shapes = before;
            return;
        }
    };
    let changed: Option<Vec<&Shape>> = {
        let (a, b) = (&before, &editor.shapes);
        if a.len() == b.len() {
            Some(
                a.iter()
                    .zip(b)
                    .filter(|(x, y)| x != y)
                    .flat_map(|(x, y)| [x, y])
                    .collect(),
            )
        } else {
            // One shape inserted or removed: everything else the same, in order.
            let (short, long) = if a.len() < b.len() { (a, b) } else { (b, a) };
            let i = (0..short.len())
                .find(|&i| short[i] != long[i])
                .unwrap_or(short.len());
            (long.len() == short.len() + 1 && short[i..] == long[i + 1..]).then(|| vec![&long[i]])
        }
    };
    // The regions the changed shapes reach, old and new; `None`: everywhere.
    let regions = changed.and_then(|shapes| {
        shapes
            .into_iter()
            .map(|s| s.reach().map(|(c, r)| (c + Vec3::splat(HALF), r)))
            .collect::<Option<Vec<_>>>()
    });
    if let Some(volume) = editor.volume {
        replace.write(ReplaceField {
            volume,
            field: SharedField(field),
            regions,
        });
    }
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

fn push_undo(editor: &mut Editor, before: Vec<Shape>) {
    editor.undo.push(before);
    editor.redo.clear();
    if editor.undo.len() > 200 {
        editor.undo.remove(0);
    }
}

fn undo(editor: &mut Editor, replace: &mut MessageWriter<ReplaceField>) {
    if let Some(prev) = editor.undo.pop() {
        let now = std::mem::replace(&mut editor.shapes, prev);
        editor.redo.push(now.clone());
        editor.selected = editor.selected.filter(|&i| i < editor.shapes.len());
        commit(editor, now, replace);
    }
}

fn redo(editor: &mut Editor, replace: &mut MessageWriter<ReplaceField>) {
    if let Some(next) = editor.redo.pop() {
        let now = std::mem::replace(&mut editor.shapes, next);
        editor.undo.push(now.clone());
        editor.selected = editor.selected.filter(|&i| i < editor.shapes.len());
        commit(editor, now, replace);
    }
}

fn save(editor: &mut Editor) {
    let text = serde_json::to_string_pretty(&scene_node(&editor.shapes)).expect("json");
    editor.message = Some(match std::fs::write(&editor.path, text + "\n") {
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
        if let Some(i) = editor.selected.filter(|&i| i < editor.shapes.len()) {
            let before = editor.shapes.clone();
            editor.shapes.remove(i);
            editor.selected = None;
            push_undo(&mut editor, before.clone());
            commit(&mut editor, before, &mut replace);
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
    let mut best: Option<(f32, usize)> = None;
    for (i, s) in editor.shapes.iter().enumerate() {
        let Ok(csg) = compile(&s.node()) else {
            continue;
        };
        if let Some(t) = raycast(&csg, ray.origin, *ray.direction, 50.0, 0.05) {
            if best.is_none_or(|(bt, _)| t < bt) {
                best = Some((t, i));
            }
        }
    }
    editor.selected = best.map(|(_, i)| i);
}

/// Outlines the selected shape's bounds.
fn highlight(editor: Res<Editor>, mut gizmos: Gizmos) {
    if let Some(s) = editor.selected.and_then(|i| editor.shapes.get(i)) {
        if let Some((c, r)) = s.reach() {
            gizmos.sphere(
                Isometry3d::from_translation(c),
                r,
                Color::srgb(1.0, 0.8, 0.2),
            );
        }
    }
}

fn editor_panel(
    mut contexts: EguiContexts,
    mut editor: ResMut<Editor>,
    mut replace: MessageWriter<ReplaceField>,
) -> Result {
    let ctx = contexts.ctx_mut()?;
    let before = editor.shapes.clone();
    let mut action: Option<&'static str> = None;
    egui::Window::new("scene")
        .default_pos([1280.0 - 330.0, 10.0])
        .default_width(310.0)
        .resizable(false)
        .show(ctx, |ui| {
            let ed = &mut *editor;
            ui.horizontal(|ui| {
                if ui
                    .add_enabled(!ed.undo.is_empty(), egui::Button::new("undo"))
                    .clicked()
                {
                    action = Some("undo");
                }
                if ui
                    .add_enabled(!ed.redo.is_empty(), egui::Button::new("redo"))
                    .clicked()
                {
                    action = Some("redo");
                }
                if ui.button("save").clicked() {
                    action = Some("save");
                }
                if ui.button("load").clicked() {
                    action = Some("load");
                }
            });
            ui.small(ed.path.display().to_string());
            ui.separator();
            for (i, s) in ed.shapes.iter().enumerate() {
                let text = if i == 0 {
                    format!("{i}: {}", s.label())
                } else {
                    format!("{i}: {} {}", s.op.name(), s.label())
                };
                if ui.selectable_label(ed.selected == Some(i), text).clicked() {
                    ed.selected = Some(i);
                }
            }
            ui.horizontal_wrapped(|ui| {
                ui.label("add:");
                for k in KINDS {
                    if ui.small_button(format!("{k:?}")).clicked() {
                        ed.shapes.push(Shape {
                            body: Body::Primitive(k),
                            op: Op::Union,
                            blend: 0.1,
                            pos: Vec3::new(0.0, 1.0, 0.0),
                            scale: 0.8,
                        });
                        ed.selected = Some(ed.shapes.len() - 1);
                    }
                }
            });
            ui.separator();
            if let Some(i) = ed.selected.filter(|&i| i < ed.shapes.len()) {
                let s = &mut ed.shapes[i];
                ui.strong(format!("shape {i}: {}", s.label()));
                if i > 0 {
                    egui::ComboBox::from_label("operation")
                        .selected_text(s.op.name())
                        .show_ui(ui, |ui| {
                            for o in OPS {
                                ui.selectable_value(&mut s.op, o, o.name());
                            }
                        });
                    if s.op.smooth() {
                        ui.add(egui::Slider::new(&mut s.blend, 0.01..=0.5).text("blend"));
                    }
                }
                for (a, name) in [(0, "x"), (1, "y"), (2, "z")] {
                    ui.add(egui::Slider::new(&mut s.pos[a], -HALF..=HALF).text(name));
                }
                ui.add(
                    egui::Slider::new(&mut s.scale, 0.1..=3.0)
                        .logarithmic(true)
                        .text("scale"),
                );
                if ui.button("delete").clicked() {
                    action = Some("delete");
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
        Some("undo") => undo(ed, &mut replace),
        Some("redo") => redo(ed, &mut replace),
        Some("save") => save(ed),
        Some("load") => match load(&ed.path) {
            Ok(shapes) => {
                let old = std::mem::replace(&mut ed.shapes, shapes);
                push_undo(ed, old.clone());
                ed.selected = None;
                ed.message = Some((format!("loaded {}", ed.path.display()), false));
                commit(ed, old, &mut replace);
            }
            Err(e) => ed.message = Some((e, true)),
        },
        Some("delete") => {
            if let Some(i) = ed.selected.take() {
                ed.shapes.remove(i);
            }
        }
        _ => {}
    }
    if matches!(action, None | Some("delete")) && ed.shapes != before {
        // One undo step per drag, not one per frame of it.
        if !(dragging && ed.was_dragging) {
            push_undo(ed, before.clone());
        }
        commit(ed, before, &mut replace);
    }
    ed.was_dragging = dragging;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_saved_scene_loads_back_as_the_same_shapes() {
        let shapes = starter();
        let text = serde_json::to_string_pretty(&scene_node(&shapes)).unwrap();
        let v: Value = serde_json::from_str(&text).unwrap();
        // Sharp operations have no blend radius to save.
        let norm = |v: Vec<Shape>| -> Vec<Shape> {
            v.into_iter()
                .map(|mut s| {
                    if !s.op.smooth() {
                        s.blend = 0.0;
                    }
                    s
                })
                .collect()
        };
        assert_eq!(norm(shapes_of(&v)), norm(shapes));
        // And it is a valid scene file for every other tool.
        CsgNode::from_json(&text).unwrap().compile().unwrap();
    }

    #[test]
    fn foreign_scenes_load_as_one_movable_shape() {
        let text =
            std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/example.json"))
                .unwrap();
        let v: Value = serde_json::from_str(&text).unwrap();
        let shapes = shapes_of(&v);
        assert_eq!(shapes.len(), 1);
        assert!(matches!(shapes[0].body, Body::Imported(_)));
        // Wrapped in a transform, it is the same field.
        let a = compile(&v).unwrap();
        let b = compile(&scene_node(&shapes)).unwrap();
        for i in 0..50 {
            let p = Vec3::new(
                (i as f32 * 0.37).sin(),
                (i as f32 * 0.71).cos(),
                0.1 * i as f32 - 2.5,
            );
            assert!((a.value(p) - b.value(p)).abs() < 1e-5);
        }
    }

    #[test]
    fn a_moved_shape_re_meshes_only_near_its_old_and_new_places() {
        let mut shapes = starter();
        let before = shapes.clone();
        shapes[4].pos.x -= 0.3;
        let (old, new) = (before[4].reach().unwrap(), shapes[4].reach().unwrap());
        // Outside both spheres the scene's inside / outside is unchanged (its
        // values may differ deep inside the solid, where a difference's distance
        // to the moved shape still counts, but no crossing moves there), and the
        // surface itself is unchanged: where one field is on it, so is the other.
        let (a, b) = (field_of(&before).unwrap(), field_of(&shapes).unwrap());
        let mut checked = 0;
        for i in 0..4000 {
            let p = Vec3::new(
                (i as f32 * 0.173).sin(),
                (i as f32 * 0.311).cos(),
                (i as f32 * 0.097).sin(),
            ) * HALF;
            if p.distance(old.0) > old.1 && p.distance(new.0) > new.1 {
                let q = p + Vec3::splat(HALF); // the volume's local space
                let (fa, fb) = (a.value(q), b.value(q));
                assert_eq!(fa < 0.0, fb < 0.0, "{p}: {fa} vs {fb}");
                if fa.abs() < 0.05 {
                    assert!((fa - fb).abs() < 1e-5, "{p}: {fa} vs {fb} near the surface");
                }
                checked += 1;
            }
        }
        assert!(checked > 500, "{checked}");
    }
}
