//! Built-in scenes in `[-1, 1]^3`, named after the paper's figures where they come
//! from one.

use crate::error::{Error, SceneError};
use crate::field::csg::CsgNode;
use crate::field::Field;
use glam::Vec3;

/// A named test field.
pub struct Scene {
    /// Its name.
    pub name: &'static str,
    /// One line on what it is.
    pub description: &'static str,
    /// The field.
    pub field: Box<dyn Field>,
    /// Whether its surface is closed inside `[-1, 1]^3` (so meshes must be
    /// watertight).
    pub closed: bool,
}

/// Names of the built-in scenes.
pub const SCENES: &[&str] = &[
    "sphere",
    "box",
    "torus",
    "disk_pole",
    "thin_plates",
    "anisotropic",
    "gyroid",
    "terrain",
    "caves",
    "csg_mix",
];

fn csg(json: &str) -> Box<dyn Field> {
    Box::new(
        CsgNode::from_json(json)
            .and_then(|n| {
                n.compile().map_err(|e| match e {
                    Error::Scene(s) => s,
                    other => SceneError::Semantic {
                        path: "root".into(),
                        message: other.to_string(),
                    },
                })
            })
            .expect("built-in scenes are valid"),
    )
}

/// The JSON of a built-in CSG scene (for scene-file users to start from).
pub fn scene_json(name: &str) -> Option<String> {
    Some(match name {
        "sphere" => r#"{"type":"sphere","radius":0.7,"center":[0.013,0.021,-0.017]}"#.into(),
        "box" => r#"{"type":"transform","rotate_axis":[0.3,1,0.2],"rotate_degrees":17,
            "child":{"type":"box","half_extents":[0.61,0.47,0.39]}}"#
            .into(),
        "torus" => r#"{"type":"transform","rotate_axis":[1,0,0],"rotate_degrees":30,
            "child":{"type":"torus","major_radius":0.6,"minor_radius":0.22}}"#
            .into(),
        "disk_pole" => {
            let mut parts = vec![
                r#"{"type":"transform","rotate_axis":[0,0,1],"rotate_degrees":90,
                   "child":{"type":"cylinder","radius":0.06,"half_height":0.9}}"#
                    .to_string(),
            ];
            for i in 0..7 {
                let x = -0.75 + 0.25 * i as f32;
                parts.push(format!(
                    r#"{{"type":"transform","translate":[{x},0,0],"rotate_axis":[0,0,1],
                       "rotate_degrees":90,
                       "child":{{"type":"cylinder","radius":0.55,"half_height":0.02}}}}"#
                ));
            }
            format!(r#"{{"type":"union","children":[{}]}}"#, parts.join(","))
        }
        // One material, as in the paper: a bare height field would give its
        // rough surface the noise terrain's grass, rock, dirt and snow, whose
        // crisp borders (`Settings::material_borders`) kept the trees from
        // merging across them (k-d 36,438 triangles at res 128 and 0.1, not
        // 24,218).
        "thin_plates" => r#"{"type":"material","id":0,"child":{"type":"union","children":[
            {"type":"box","half_extents":[0.7,0.015,0.7],"center":[0,0.25,0]},
            {"type":"intersection","children":[
                {"type":"box","half_extents":[0.8,0.6,0.8],"center":[0,-0.2,0]},
                {"type":"heightfield","seed":7,"base":0.1,"amplitude":0.05,"frequency":6,"octaves":4}]}]}}"#
            .into(),
        // The fins go 0.02 into the base: the solid is the one of fins standing
        // on it, and the field is negative all through it (fins resting on the
        // base's top made it zero inside the solid where they met, and the
        // gradient there pointed down into the base: 114 and 152 flipped faces
        // at res 32 and 64 under every mesher).
        "anisotropic" => {
            let mut parts =
                vec![r#"{"type":"box","half_extents":[0.62,0.05,0.62],"center":[0,-0.6,0]}"#.to_string()];
            for i in 0..9 {
                let x = -0.6 + 0.15 * i as f32;
                parts.push(format!(
                    r#"{{"type":"box","half_extents":[0.012,0.61,0.6],"center":[{x},0.04,0]}}"#
                ));
            }
            format!(r#"{{"type":"union","children":[{}]}}"#, parts.join(","))
        }
        "terrain" => r#"{"type":"intersection","children":[
            {"type":"box","half_extents":[0.85,0.85,0.85]},
            {"type":"heightfield","seed":3,"base":0.0,"amplitude":0.35,"frequency":1.5,"octaves":5}]}"#
            .into(),
        "caves" => r#"{"type":"intersection","children":[
            {"type":"box","half_extents":[0.85,0.85,0.85]},
            {"type":"density","seed":11,"base":0.1,"amplitude":0.3,"frequency":1.8,"octaves":4,
             "caves":{"frequency":2.0,"radius":0.12}}]}"#
            .into(),
        "csg_mix" => r#"{"type":"union","children":[
            {"type":"difference",
             "a":{"type":"material","id":4,"child":{"type":"intersection","children":[
                 {"type":"box","half_extents":[0.42,0.42,0.42],"center":[0.02,0.31,0.01]},
                 {"type":"sphere","radius":0.56,"center":[0.02,0.31,0.01]}]}},
             "b":{"type":"material","id":5,"child":{"type":"union","children":[
                 {"type":"cylinder","radius":0.2,"half_height":1,"center":[0.02,0.31,0.01]},
                 {"type":"transform","rotate_axis":[0,0,1],"rotate_degrees":90,"translate":[0.02,0.31,0.01],
                  "child":{"type":"cylinder","radius":0.2,"half_height":1}}]}}},
            {"type":"smooth_union","radius":0.12,"children":[
                {"type":"material","id":6,"child":
                    {"type":"torus","major_radius":0.45,"minor_radius":0.12,"center":[0,-0.45,0]}},
                {"type":"material","id":1,"child":
                    {"type":"capsule","radius":0.1,"half_height":0.25,"center":[0.45,-0.45,0]}},
                {"type":"material","id":7,"child":
                    {"type":"rounded_box","half_extents":[0.2,0.1,0.2],"radius":0.04,"center":[-0.5,-0.45,0.1]}}]}]}"#
            .into(),
        _ => return None,
    })
}

/// A thin-shelled gyroid clipped by a sphere.
struct Gyroid;

impl Field for Gyroid {
    fn value(&self, p: Vec3) -> f32 {
        let k = 8.0;
        let q = p * k;
        let g = q.x.sin() * q.y.cos() + q.y.sin() * q.z.cos() + q.z.sin() * q.x.cos();
        let shell = g.abs() / (k * 1.5) - 0.03;
        shell.max(p.length() - 0.85)
    }

    /// Each component of the gyroid's gradient in `q` is `cos a cos b - sin c sin a`,
    /// at most `sqrt 2`, so `|grad g| <= sqrt 6 k` in `p`, and the shell's value
    /// `|g| / (1.5 k)` changes by at most `sqrt 6 / 1.5` (1.633) per unit; the
    /// sphere's by 1.
    fn lipschitz(&self) -> Option<f32> {
        Some(1.64)
    }
}

/// A built-in scene by name.
pub fn scene(name: &str) -> Result<Scene, Error> {
    let description = match name {
        "sphere" => "a sphere of radius 0.7",
        "box" => "a rotated box with sharp edges",
        "torus" => "a tilted torus",
        "disk_pole" => "seven thin disks threaded on a pole (paper Fig. 2)",
        "thin_plates" => "a thin flat plate above a rough noisy surface (paper Fig. 3)",
        "anisotropic" => "a comb of thin fins: detail dense along x only (paper Fig. 4)",
        "gyroid" => "a thin-shelled gyroid inside a sphere",
        "terrain" => "an fBm height field, closed by a box",
        "caves" => "3-D density terrain with overhangs and caves, closed by a box",
        "csg_mix" => "box ∩ sphere minus cylinders, plus a smooth torus/capsule/rounded box, each part its own material",
        _ => {
            return Err(SceneError::UnknownScene {
                name: crate::io::cut(name),
                known: SCENES.join(", "),
            }
            .into())
        }
    };
    let field: Box<dyn Field> = match name {
        "gyroid" => Box::new(Gyroid),
        _ => csg(&scene_json(name).expect("listed")),
    };
    Ok(Scene {
        name: SCENES.iter().find(|s| **s == name).unwrap(),
        description,
        field,
        closed: true,
    })
}

/// The streaming-terrain chunk that benchmarks and tests measure: `res`³ cells of
/// 1 m over a 5-octave fBm height field (seed 3, amplitude 10 m, frequency 0.015),
/// the grid starting at x = z = 0 and centerd on y = 0, as the Bevy terrain example
/// meshes one chunk (without its halo).
pub fn terrain_chunk(res: u32) -> (crate::field::terrain::Heightfield, crate::Grid) {
    use crate::field::terrain::{Heightfield, HeightfieldParams};
    let field = Heightfield::new(HeightfieldParams {
        seed: 3,
        base: 0.0,
        amplitude: 10.0,
        frequency: 0.015,
        octaves: 5,
    });
    let grid = crate::Grid {
        origin: Vec3::new(0.0, -(res as f32) / 2.0, 0.0),
        cell_size: 1.0,
        cells: glam::UVec3::splat(res),
        offset: glam::IVec3::ZERO,
    };
    (field, grid)
}

/// A chunk of the terrain demo's field (`DensityParams::demo(7)`, the field the
/// Bevy plugin's horizon benchmark flies over): `res`³ cells of 1 world unit from
/// `(0, -res / 2, 0)`, through hills, an overhang and a cave mouth.
pub fn demo_chunk(res: u32) -> (crate::field::terrain::Density, crate::Grid) {
    use crate::field::terrain::{Density, DensityParams};
    let field = Density::new(DensityParams::demo(7));
    let grid = crate::Grid {
        origin: Vec3::new(0.0, -(res as f32) / 2.0, 0.0),
        cell_size: 1.0,
        cells: glam::UVec3::splat(res),
        offset: glam::IVec3::ZERO,
    };
    (field, grid)
}
