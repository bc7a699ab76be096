//! A scanned volume as a surface: a raw voxel file or a NIfTI-1 scan (`.nii`,
//! `.nii.gz`), or, with no file, a generated CT of the 3-D Shepp-Logan head phantom
//! (each voxel its partial volume, as a scanner measures it; `--segmented` for
//! the density at each voxel's center, a staircase between voxels).
//! The iso-value slider moves the surface through the scan's values (skull,
//! brain, ventricles); every change re-meshes the chunks in the background from
//! the voxels already in memory (the file is read once) while the old mesh stays
//! on screen. Meshed at one cell per voxel, as the CLI, unless `--res` says
//! otherwise; normals come from the cubic B-spline gradient over the voxels, so
//! they do not terrace.
//!
//! Keys: WASD / E / Q and arrows or middle mouse to fly. F1 hides the panel.
//!
//! ```text
//! cargo run --release --example volume
//! cargo run --release --example volume -- --file head.nii.gz --iso 300
//! cargo run --release --example volume -- --file ct.raw --dims 256,256,128 --type u16 --spacing 0.5,0.5,1
//! ```

mod common;

use bevy::prelude::*;
use bevy_kdcontour::kdcontour::field::volume::{Inside, SampledVolume};
use bevy_kdcontour::kdcontour::io::input::{parse_uvec3, parse_vec3};
use bevy_kdcontour::kdcontour::io::volume::{
    is_nifti, load_nifti, load_raw, phantom, phantom_scanned, VoxelType,
};
use bevy_kdcontour::panel::bevy_egui::{egui, EguiContexts, EguiPrimaryContextPass};
use bevy_kdcontour::panel::KdContourPanel;
use bevy_kdcontour::prelude::*;
use clap::Parser;
use common::ShotArgs;
use std::path::PathBuf;
use std::sync::Arc;

/// Iso-surfaces of a voxel volume.
#[derive(Parser, Debug)]
struct Args {
    /// A `.nii` / `.nii.gz` scan, or a headerless raw file (then give --dims and
    /// --type). Without it, a generated phantom CT is shown.
    #[arg(long)]
    file: Option<PathBuf>,
    /// Raw files: voxels along x, y, z.
    #[arg(long, value_parser = parse_uvec3)]
    dims: Option<UVec3>,
    /// Raw files: u8, u16, i16 or f32 (little endian).
    #[arg(long, default_value = "u8")]
    r#type: String,
    /// Raw files: voxel spacing along x, y, z.
    #[arg(long, value_parser = parse_vec3, default_value = "1,1,1")]
    spacing: Vec3,
    /// Starting iso value (default: the phantom's skull, or the middle of the
    /// file's value range).
    #[arg(long)]
    iso: Option<f32>,
    /// Values below the iso value are inside (default: above, as in CT).
    #[arg(long)]
    below: bool,
    /// Phantom voxels per side.
    #[arg(long, default_value_t = 96)]
    phantom: u32,
    /// Phantom voxels hold the density at their centers (inside or out, a
    /// staircase between voxels), not the partial volumes a scanner measures.
    #[arg(long)]
    segmented: bool,
    /// Cells along the longest side (default: one per voxel, as the CLI).
    #[arg(long)]
    res: Option<u32>,
    #[command(flatten)]
    shot: ShotArgs,
}

#[derive(Resource)]
struct Scan {
    volume: SampledVolume,
    name: String,
    range: (f32, f32),
    iso: f32,
    /// Cells along the longest side.
    cells: u32,
    entity: Option<Entity>,
}

fn load(args: &Args) -> Result<(SampledVolume, String), String> {
    let inside = if args.below {
        Inside::Below
    } else {
        Inside::Above
    };
    let Some(path) = &args.file else {
        if !(8..=256).contains(&args.phantom) {
            return Err(format!("--phantom must be 8 to 256, got {}", args.phantom));
        }
        let (mut v, kind) = if args.segmented {
            (
                phantom(args.phantom).map_err(|e| e.to_string())?,
                "center samples",
            )
        } else {
            (
                phantom_scanned(args.phantom).map_err(|e| e.to_string())?,
                "partial volumes",
            )
        };
        v.inside = inside;
        return Ok((
            v,
            format!("Shepp-Logan phantom, {}^3, {kind}", args.phantom),
        ));
    };
    let name = path.display().to_string();
    let v = if is_nifti(path) {
        load_nifti(path, 0.0, inside).map_err(|e| e.to_string())?
    } else {
        let dims = args.dims.ok_or_else(|| {
            format!("{name}: a raw file needs --dims X,Y,Z (and --type, --spacing)")
        })?;
        let ty = VoxelType::parse(&args.r#type)
            .ok_or_else(|| format!("--type {:?}: use u8, u16, i16 or f32", args.r#type))?;
        load_raw(path, dims, ty, args.spacing, 0.0, inside).map_err(|e| e.to_string())?
    };
    Ok((v, name))
}

fn main() {
    let args = Args::parse();
    let (volume, name) = load(&args).unwrap_or_else(|e| common::fail(e));
    let range = volume.range();
    if !(range.0.is_finite() && range.1.is_finite()) || range.0 == range.1 {
        common::fail(format!(
            "{name}: the voxel values span {range:?}; there is no surface to show"
        ));
    }
    let iso = args.iso.unwrap_or(if args.file.is_none() {
        // The phantom's skull (1.3 with partial volumes, 1.5 without).
        volume.iso
    } else {
        0.5 * (range.0 + range.1)
    });
    // An iso level outside the data has no surface (it would show nothing, or
    // the volume's box).
    if let Err(e) = volume.check_iso(iso) {
        common::fail(format!("{name}: --iso {iso}: {e}"));
    }
    // One cell per voxel unless --res says otherwise; every axis needs two
    // cells of the grid the volume is meshed on.
    let grid_cells = args.res.unwrap_or_else(|| volume.native_res());
    if !(2..=1024).contains(&grid_cells) {
        common::fail(format!(
            "{name}: --res must be 2 to 1024 cells along the longest side, got {grid_cells}"
        ));
    }
    let (lo, hi) = volume.bounds();
    let cells = bevy_kdcontour::kdcontour::Grid::covering(lo, hi, grid_cells).cells;
    if cells.min_element() < 2 {
        common::fail(format!(
            "{name}: the voxels span {:?} units; at {grid_cells} cells along the longest \
             side that is {cells} cells, and every axis needs at least 2 (check --dims, \
             --spacing and --res)",
            (hi - lo).to_array()
        ));
    }
    let mut app = App::new();
    app.insert_resource(ClearColor(Color::srgb(0.1, 0.11, 0.13)));
    common::add_plugins(
        &mut app,
        "bevy_kdcontour: volume",
        &args.shot,
        common::fixed(0.02),
        KdContourPanel {
            show_iso: false,
            ..default()
        },
    )
    .insert_resource(Scan {
        volume,
        name,
        range,
        iso,
        cells: grid_cells,
        entity: None,
    })
    .add_systems(Startup, setup)
    .add_systems(Update, common::fly_camera)
    .add_systems(EguiPrimaryContextPass, iso_panel)
    .run();
}

/// The scan's field at `iso`, with voxel (0, 0, 0) at the local origin.
fn field_at(scan: &Scan, iso: f32) -> Arc<dyn bevy_kdcontour::kdcontour::Field> {
    let mut v = scan.volume.clone();
    v.iso = iso;
    v.origin = Vec3::ZERO;
    Arc::new(v)
}

fn setup(
    mut commands: Commands,
    mut scan: ResMut<Scan>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    let (lo, hi) = scan.volume.bounds();
    let extent = hi - lo;
    // The grid covering the voxels (one cell per voxel by default), in chunks
    // of 16 cells.
    let grid = bevy_kdcontour::kdcontour::Grid::covering(lo, hi, scan.cells);
    let cell = grid.cell_size;
    let res = 16;
    let chunks = (grid.cells + UVec3::splat(res - 1)) / res;
    let material = materials.add(StandardMaterial {
        base_color: Color::srgb(0.93, 0.88, 0.8),
        perceptual_roughness: 0.6,
        double_sided: true,
        cull_mode: None,
        ..default()
    });
    let scale = 2.0 / extent.max_element();
    let entity = commands
        .spawn((
            KdVolume::new(field_at(&scan, scan.iso), chunks, res, cell).with_material(material),
            // Centerd at the origin, two units across.
            Transform::from_scale(Vec3::splat(scale)).with_translation(-extent * 0.5 * scale),
        ))
        .id();
    scan.entity = Some(entity);
    let (fly, t) = common::FlyCam::looking(Vec3::new(1.7, 0.9, 2.2), Vec3::ZERO, 1.0);
    commands.spawn((Camera3d::default(), fly, t, LodCamera));
    common::spawn_lights(&mut commands);
}

fn iso_panel(
    mut contexts: EguiContexts,
    mut scan: ResMut<Scan>,
    mut replace: MessageWriter<ReplaceField>,
) -> Result {
    let ctx = contexts.ctx_mut()?;
    let mut iso = scan.iso;
    // Top right: the plugin's panel (top left) grows with the features on.
    let right = ctx.content_rect().right();
    egui::Window::new("volume")
        .pivot(egui::Align2::RIGHT_TOP)
        .default_pos([right - 10.0, 10.0])
        .resizable(false)
        .show(ctx, |ui| {
            ui.label(&scan.name);
            let v = &scan.volume;
            ui.label(format!(
                "{} x {} x {} voxels, spacing {:.3} x {:.3} x {:.3}",
                v.dims.x, v.dims.y, v.dims.z, v.spacing.x, v.spacing.y, v.spacing.z
            ));
            ui.add(egui::Slider::new(&mut iso, scan.range.0..=scan.range.1).text("iso value"));
        });
    if iso != scan.iso {
        scan.iso = iso;
        if let Some(volume) = scan.entity {
            replace.write(ReplaceField {
                volume,
                field: SharedField(field_at(&scan, iso)),
                regions: None,
            });
        }
    }
    Ok(())
}
