//! One field, five meshers, side by side, from the same samples, left to right:
//! Marching Cubes, Boada and Navazo's discrete planes, Poston, Wong and Heng's
//! adaptive skeleton climbing, the octree baseline and the discrete k-d tree,
//! drawn as wireframes over the shaded surface so the triangles can be counted by
//! eye as well as in the panel. The threshold slider re-cuts both retained trees
//! (and re-runs skeleton climbing, whose box size follows it) without sampling the
//! field again; the scene box picks any built-in scene.
//!
//! Keys: WASD / E / Q and arrows or middle mouse to fly. F1 hides the panel.
//!
//! ```text
//! cargo run --release --example compare -- --scene disk_pole --res 64
//! ```

mod common;

use bevy::asset::RenderAssetUsages;
use bevy::mesh::PrimitiveTopology;
use bevy::pbr::wireframe::WireframeConfig;
use bevy::prelude::*;
use bevy_kdcontour::kdcontour::hermite::Hermite;
use bevy_kdcontour::kdcontour::meshers::{Mesher, Sampled};
use bevy_kdcontour::kdcontour::pipeline::{self, Cells};
use bevy_kdcontour::kdcontour::Partition;
use bevy_kdcontour::kdcontour::{meshers, scenes, Grid, IndexedMesh, KdTree, Settings};
use bevy_kdcontour::panel::bevy_egui::{egui, EguiContexts, EguiPrimaryContextPass};
use bevy_kdcontour::panel::KdContourPanel;
use bevy_kdcontour::prelude::*;
use clap::Parser;
use common::ShotArgs;

/// Five meshers on the same grid.
#[derive(Parser, Debug)]
struct Args {
    /// Built-in scene (see `kdcontour scenes`).
    #[arg(long, default_value = "disk_pole")]
    scene: String,
    /// Cells per side of the cube [-1, 1]^3.
    #[arg(long, default_value_t = 64)]
    res: u32,
    /// Error threshold (squared cells) of the adaptive meshers.
    #[arg(long, default_value_t = 0.01)]
    threshold: f32,
    #[command(flatten)]
    shot: ShotArgs,
}

/// The meshers shown, left to right, with their labels.
const SHOWN: [(&str, Mesher); 5] = [
    ("Marching Cubes", Mesher::MarchingCubes),
    ("discrete planes", Mesher::DiscretePlanes),
    ("skeleton climbing", Mesher::SkeletonClimbing),
    ("octree", Mesher::Octree),
    ("k-d tree", Mesher::KdTree),
];

/// One mesher's view.
struct Row {
    name: &'static str,
    /// Its view's colour, which its name in the panel takes.
    colour: Color,
    mesher: Mesher,
    /// The retained tree (octree and k-d tree).
    tree: Option<KdTree>,
    triangles: usize,
    mesh: Handle<Mesh>,
}

/// The meshes of the current scene.
#[derive(Resource)]
struct Compare {
    scene: String,
    res: u32,
    threshold: f32,
    rows: Vec<Row>,
    /// The samples every mesher reads (of the scene's field, made again from its
    /// name when a mesher needs it).
    hermite: Option<Hermite>,
    sample_ms: f64,
    error: Option<String>,
}

fn main() {
    let args = Args::parse();
    if scenes::scene(&args.scene).is_err() {
        common::fail(format!(
            "unknown scene {:?}; the built-in scenes are: {}",
            args.scene,
            scenes::SCENES.join(", ")
        ));
    }
    if !(4..=256).contains(&args.res) {
        common::fail(format!("--res must be 4 to 256, got {}", args.res));
    }
    if !args.threshold.is_finite() {
        common::fail("--threshold must be a number");
    }
    let mut app = App::new();
    app.insert_resource(ClearColor(Color::srgb(0.16, 0.17, 0.2)));
    common::add_plugins(
        &mut app,
        "bevy_kdcontour: compare",
        &args.shot,
        KdContourSettings::default(),
        KdContourPanel {
            open: false,
            ..default()
        },
    )
    .insert_resource(Compare {
        scene: args.scene.clone(),
        res: args.res,
        threshold: args.threshold,
        rows: Vec::new(),
        hermite: None,
        sample_ms: 0.0,
        error: None,
    })
    .add_systems(Startup, setup)
    .add_systems(Update, common::fly_camera)
    .add_systems(EguiPrimaryContextPass, panel)
    .run();
}

fn setup(
    mut commands: Commands,
    mut cmp: ResMut<Compare>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
    mut wireframe: ResMut<WireframeConfig>,
) {
    wireframe.global = true;
    wireframe.default_color = Color::srgb(0.05, 0.05, 0.08);
    let colours = [
        Color::srgb(0.85, 0.55, 0.4),
        Color::srgb(0.8, 0.7, 0.35),
        Color::srgb(0.7, 0.5, 0.8),
        Color::srgb(0.55, 0.75, 0.45),
        Color::srgb(0.45, 0.65, 0.9),
    ];
    for (i, ((name, mesher), colour)) in SHOWN.into_iter().zip(colours).enumerate() {
        let handle = meshes.add(Mesh::new(
            PrimitiveTopology::TriangleList,
            RenderAssetUsages::default(),
        ));
        commands.spawn((
            Mesh3d(handle.clone()),
            MeshMaterial3d(materials.add(StandardMaterial {
                base_color: colour,
                perceptual_roughness: 0.7,
                double_sided: true,
                cull_mode: None,
                ..default()
            })),
            Transform::from_xyz((i as f32 - 2.0) * 2.3, 0.0, 0.0),
        ));
        cmp.rows.push(Row {
            name,
            colour,
            mesher,
            tree: None,
            triangles: 0,
            mesh: handle,
        });
    }
    let (fly, t) =
        common::FlyCam::looking(Vec3::new(0.0, 2.6, 8.6), Vec3::new(0.0, -0.2, 0.0), 2.0);
    commands.spawn((Camera3d::default(), fly, t));
    common::spawn_lights(&mut commands);
    rebuild(&mut cmp, &mut meshes, true);
}

/// Samples the scene once and runs every mesher (`resample`), or only redoes
/// the ones the threshold changes (re-cutting the retained trees).
fn rebuild(cmp: &mut Compare, meshes: &mut Assets<Mesh>, resample: bool) {
    let scene = match scenes::scene(&cmp.scene) {
        Ok(s) => s,
        Err(e) => {
            cmp.error = Some(e.to_string());
            return;
        }
    };
    if resample {
        let settings = Settings::default();
        let grid = Grid::cube(1.0, cmp.res);
        let sampled = match meshers::sample(&*scene.field, &grid, &settings) {
            Ok(s) => s,
            Err(e) => {
                cmp.error = Some(e.to_string());
                return;
            }
        };
        cmp.sample_ms = sampled.sample_ms;
        for row in &mut cmp.rows {
            let partition = match row.mesher {
                Mesher::Octree => Partition::Octree,
                Mesher::KdTree => Partition::KdTree,
                _ => {
                    row.tree = None;
                    continue;
                }
            };
            let settings = Settings {
                partition,
                ..settings.clone()
            };
            row.tree = Some(pipeline::tree(
                &sampled.hermite,
                sampled.field,
                &settings,
                Cells::All,
            ));
        }
        cmp.hermite = Some(sampled.hermite);
        cmp.error = None;
    }
    let Some(hermite) = cmp.hermite.take() else {
        return;
    };
    let sampled = Sampled {
        hermite,
        field: &*scene.field,
        sample_ms: cmp.sample_ms,
    };
    let threshold = cmp.threshold;
    for row in &mut cmp.rows {
        if !resample && !row.mesher.adaptive() {
            continue;
        }
        let mesh: IndexedMesh = match &row.tree {
            Some(tree) => tree.mesh(threshold),
            None => match meshers::run(row.mesher, &sampled, threshold, &Settings::default()) {
                Ok((m, _)) => m,
                Err(e) => {
                    cmp.error = Some(format!("{}: {e}", row.name));
                    continue;
                }
            },
        };
        row.triangles = mesh.triangle_count();
        if let Some(mut m) = meshes.get_mut(&row.mesh) {
            *m = bevy_kdcontour::to_bevy_mesh(&mesh);
        }
    }
    cmp.hermite = Some(sampled.hermite);
}

fn panel(
    mut contexts: EguiContexts,
    mut cmp: ResMut<Compare>,
    mut meshes: ResMut<Assets<Mesh>>,
) -> Result {
    let ctx = contexts.ctx_mut()?;
    let mut resample = false;
    let mut recut = false;
    egui::Window::new("compare")
        .default_pos([10.0, 10.0])
        .resizable(false)
        .show(ctx, |ui| {
            let mut scene = cmp.scene.clone();
            egui::ComboBox::from_label("scene")
                .selected_text(&scene)
                .show_ui(ui, |ui| {
                    for name in scenes::SCENES {
                        ui.selectable_value(&mut scene, name.to_string(), *name);
                    }
                });
            if scene != cmp.scene {
                cmp.scene = scene;
                resample = true;
            }
            let mut res = cmp.res;
            ui.add(egui::Slider::new(&mut res, 8..=128).text("cells per side"));
            if res != cmp.res {
                cmp.res = res;
                resample = true;
            }
            let mut t = cmp.threshold;
            ui.add(
                egui::Slider::new(&mut t, 1e-4..=1.0)
                    .logarithmic(true)
                    .text("threshold"),
            );
            if t != cmp.threshold {
                cmp.threshold = t;
                recut = true;
            }
            ui.separator();
            egui::Grid::new("rows").num_columns(3).show(ui, |ui| {
                ui.strong("mesher (left to right)");
                ui.strong("triangles");
                ui.strong("vs MC");
                ui.end_row();
                let mc = cmp.rows.first().map(|r| r.triangles).unwrap_or(0).max(1);
                for row in &cmp.rows {
                    let [r, g, b, _] = row.colour.to_srgba().to_u8_array();
                    ui.colored_label(egui::Color32::from_rgb(r, g, b), row.name);
                    ui.label(row.triangles.to_string());
                    ui.label(format!("{:.2}", row.triangles as f64 / mc as f64));
                    ui.end_row();
                }
            });
            ui.small(format!(
                "sampled once in {:.0} ms; the slider re-cuts the trees",
                cmp.sample_ms
            ));
            if let Some(e) = &cmp.error {
                ui.colored_label(egui::Color32::LIGHT_RED, e);
            }
        });
    if resample || recut {
        rebuild(&mut cmp, &mut meshes, resample);
    }
    Ok(())
}
