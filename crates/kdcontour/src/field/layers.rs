//! A layered CSG model for interactive editing: an ordered list of [`Layer`]s, each
//! a primitive (or an imported subtree) with its own translation and uniform scale,
//! combined with everything before it by an [`Operation`].
//!
//! [`to_json`] and [`from_json`] save and load a list as the JSON scene format (a
//! left fold of the layers, see [`CsgNode`] and `assets/scenes/README.md`). [`Layers`]
//! holds the list being edited, each layer's compiled field and bounds (compiled
//! once per change), and an undo / redo history; each change says which region of
//! space it can reach ([`Change::regions`]), so only the chunks there need
//! re-meshing. Selection is the caller's.

use super::csg::CsgNode;
use crate::error::SceneError;
use glam::Vec3;

mod history;
pub use history::{Change, Layers, UNDO_DEPTH};

/// A primitive a layer can be, at its unit size (the layer's transform places and
/// scales it).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Solid {
    /// A ball of radius 0.5.
    Sphere,
    /// A cube of half side 0.4.
    Box,
    /// A cube of half side 0.4 with edges rounded by 0.12.
    RoundedBox,
    /// A torus around Y, ring 0.4, tube 0.14.
    Torus,
    /// A cylinder along Y, radius 0.3, half height 0.45.
    Cylinder,
    /// A capsule along Y, radius 0.25, half height 0.35.
    Capsule,
    /// A cone along Y, radius 0.4, half height 0.5.
    Cone,
}

impl Solid {
    /// Every solid, in the order an editor lists them.
    pub const ALL: [Solid; 7] = [
        Solid::Sphere,
        Solid::Box,
        Solid::RoundedBox,
        Solid::Torus,
        Solid::Cylinder,
        Solid::Capsule,
        Solid::Cone,
    ];

    /// The solid as a scene node, centerd at the origin.
    pub fn node(self) -> CsgNode {
        let center = Vec3::ZERO;
        let cube = Vec3::splat(0.4);
        match self {
            Solid::Sphere => CsgNode::Sphere {
                radius: 0.5,
                center,
            },
            Solid::Box => CsgNode::Box {
                half_extents: cube,
                center,
            },
            Solid::RoundedBox => CsgNode::RoundedBox {
                half_extents: cube,
                radius: 0.12,
                center,
            },
            Solid::Torus => CsgNode::Torus {
                major_radius: 0.4,
                minor_radius: 0.14,
                center,
            },
            Solid::Cylinder => CsgNode::Cylinder {
                radius: 0.3,
                half_height: 0.45,
                center,
            },
            Solid::Capsule => CsgNode::Capsule {
                radius: 0.25,
                half_height: 0.35,
                center,
            },
            Solid::Cone => CsgNode::Cone {
                radius: 0.4,
                half_height: 0.5,
                center,
            },
        }
    }
}

/// How a layer combines with everything before it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Operation {
    /// Adds the layer.
    Union,
    /// Cuts the layer away.
    Difference,
    /// Keeps only what is inside the layer too.
    Intersection,
    /// [`Operation::Union`] blended over the layer's blend radius.
    SmoothUnion,
    /// [`Operation::Difference`] blended over the layer's blend radius.
    SmoothDifference,
    /// [`Operation::Intersection`] blended over the layer's blend radius.
    SmoothIntersection,
}

impl Operation {
    /// Every operation, in the order an editor lists them.
    pub const ALL: [Operation; 6] = [
        Operation::Union,
        Operation::Difference,
        Operation::Intersection,
        Operation::SmoothUnion,
        Operation::SmoothDifference,
        Operation::SmoothIntersection,
    ];

    /// The scene file's name of the operation (`"smooth_union"`).
    pub fn name(self) -> &'static str {
        match self {
            Operation::Union => "union",
            Operation::Difference => "difference",
            Operation::Intersection => "intersection",
            Operation::SmoothUnion => "smooth_union",
            Operation::SmoothDifference => "smooth_difference",
            Operation::SmoothIntersection => "smooth_intersection",
        }
    }

    /// Whether it blends over a radius.
    pub fn is_smooth(self) -> bool {
        matches!(
            self,
            Operation::SmoothUnion | Operation::SmoothDifference | Operation::SmoothIntersection
        )
    }

    /// `acc` combined with `layer` (blended over `blend` when smooth).
    fn combine(self, acc: CsgNode, layer: CsgNode, blend: f32) -> CsgNode {
        let radius = blend;
        match self {
            Operation::Union => CsgNode::Union {
                children: vec![acc, layer],
            },
            Operation::Intersection => CsgNode::Intersection {
                children: vec![acc, layer],
            },
            Operation::SmoothUnion => CsgNode::SmoothUnion {
                radius,
                children: vec![acc, layer],
            },
            Operation::SmoothIntersection => CsgNode::SmoothIntersection {
                radius,
                children: vec![acc, layer],
            },
            Operation::Difference => CsgNode::Difference {
                a: Box::new(acc),
                b: Box::new(layer),
            },
            Operation::SmoothDifference => CsgNode::SmoothDifference {
                radius,
                a: Box::new(acc),
                b: Box::new(layer),
            },
        }
    }

    /// The operation at the top of `node`, its blend radius, and its two operands,
    /// when `node` is a binary combination.
    fn split(node: &CsgNode) -> Option<(Operation, Option<f32>, &CsgNode, &CsgNode)> {
        fn pair(c: &[CsgNode]) -> Option<(&CsgNode, &CsgNode)> {
            match c {
                [a, b] => Some((a, b)),
                _ => None,
            }
        }
        Some(match node {
            CsgNode::Union { children } => {
                let (a, b) = pair(children)?;
                (Operation::Union, None, a, b)
            }
            CsgNode::Intersection { children } => {
                let (a, b) = pair(children)?;
                (Operation::Intersection, None, a, b)
            }
            CsgNode::Difference { a, b } => (Operation::Difference, None, &**a, &**b),
            CsgNode::SmoothUnion { radius, children } => {
                let (a, b) = pair(children)?;
                (Operation::SmoothUnion, Some(*radius), a, b)
            }
            CsgNode::SmoothIntersection { radius, children } => {
                let (a, b) = pair(children)?;
                (Operation::SmoothIntersection, Some(*radius), a, b)
            }
            CsgNode::SmoothDifference { radius, a, b } => {
                (Operation::SmoothDifference, Some(*radius), &**a, &**b)
            }
            _ => return None,
        })
    }
}

/// What a layer is: a primitive, or a subtree loaded from a file that is not a
/// chain of transformed primitives (kept whole, still movable and scalable).
#[derive(Clone, Debug, PartialEq)]
pub enum Body {
    /// One of the editor's primitives.
    Primitive(Solid),
    /// Any scene node.
    Imported(CsgNode),
}

/// One layer: a body, placed and scaled, combined with the layers before it.
#[derive(Clone, Debug, PartialEq)]
pub struct Layer {
    /// What the layer is.
    pub body: Body,
    /// How it combines with everything before it (ignored for the first layer).
    pub operation: Operation,
    /// Blend radius of smooth operations (> 0).
    pub blend: f32,
    /// Where the body's origin goes.
    pub translate: Vec3,
    /// Uniform scale (> 0).
    pub scale: f32,
    /// The layer's material id ([`crate::material`]; an editor's colour). 0, the
    /// default, adds no material node, so an imported body keeps its own.
    pub material: u8,
}

/// Blend radius of a layer read from a file whose operation has none.
const DEFAULT_BLEND: f32 = 0.1;

impl Layer {
    /// A primitive layer.
    pub fn new(
        solid: Solid,
        operation: Operation,
        blend: f32,
        translate: Vec3,
        scale: f32,
    ) -> Self {
        Layer {
            body: Body::Primitive(solid),
            operation,
            blend,
            translate,
            scale,
            material: 0,
        }
    }

    /// The layer with material `id`.
    pub fn with_material(mut self, id: u8) -> Self {
        self.material = id;
        self
    }

    /// A short name for lists: the solid, or `imported`.
    pub fn label(&self) -> String {
        match &self.body {
            Body::Primitive(s) => format!("{s:?}"),
            Body::Imported(_) => "imported".into(),
        }
    }

    /// The layer alone, as a scene node: a transform of its body, inside a
    /// material node unless its material is 0.
    pub fn node(&self) -> CsgNode {
        let child = match &self.body {
            Body::Primitive(s) => s.node(),
            Body::Imported(n) => n.clone(),
        };
        let placed = CsgNode::Transform {
            translate: self.translate,
            rotate_axis: Vec3::Y,
            rotate_degrees: 0.0,
            scale: self.scale,
            child: Box::new(child),
        };
        match self.material {
            0 => placed,
            id => CsgNode::Material {
                id,
                child: Box::new(placed),
            },
        }
    }

    /// Reads a scene node as one layer: a material node gives the layer its
    /// material; an unrotated transform keeps its translation and scale (its child
    /// is a primitive if it equals one), anything else is imported whole.
    fn of(node: &CsgNode, operation: Operation, blend: f32) -> Layer {
        if let CsgNode::Material { id, child } = node {
            return Layer::of(child, operation, blend).with_material(*id);
        }
        if let CsgNode::Transform {
            translate,
            rotate_degrees,
            scale,
            child,
            ..
        } = node
        {
            if *rotate_degrees == 0.0 {
                let body = Solid::ALL
                    .into_iter()
                    .find(|s| s.node() == **child)
                    .map(Body::Primitive)
                    .unwrap_or_else(|| Body::Imported((**child).clone()));
                return Layer {
                    body,
                    operation,
                    blend,
                    translate: *translate,
                    scale: *scale,
                    material: 0,
                };
            }
        }
        Layer {
            body: Body::Imported(node.clone()),
            operation,
            blend,
            translate: Vec3::ZERO,
            scale: 1.0,
            material: 0,
        }
    }
}

/// The editor's opening scene: a rounded block with a dome, a bore, a ring and a
/// carved groove, each its own material (0 to 4).
pub fn starter() -> Vec<Layer> {
    let s = |solid, op, translate, scale| Layer::new(solid, op, 0.12, translate, scale);
    let shapes = vec![
        s(
            Solid::RoundedBox,
            Operation::Union,
            Vec3::new(0.0, -0.1, 0.0),
            1.6,
        ),
        s(
            Solid::Sphere,
            Operation::SmoothUnion,
            Vec3::new(0.0, 0.6, 0.0),
            1.3,
        ),
        s(
            Solid::Cylinder,
            Operation::Difference,
            Vec3::new(0.0, 1.15, 0.0),
            1.1,
        ),
        s(
            Solid::Torus,
            Operation::SmoothUnion,
            Vec3::new(0.0, -0.55, 0.0),
            2.2,
        ),
        s(
            Solid::Capsule,
            Operation::SmoothDifference,
            Vec3::new(0.55, 0.1, 0.75),
            0.9,
        ),
    ];
    shapes
        .into_iter()
        .zip(0u8..)
        .map(|(layer, id)| layer.with_material(id))
        .collect()
}

/// The whole list as one scene node: a left fold of the layers in order. An empty
/// list is a tiny sphere far away, so its field stays finite.
pub fn scene_node(layers: &[Layer]) -> CsgNode {
    let Some(first) = layers.first() else {
        return CsgNode::Sphere {
            radius: 0.01,
            center: Vec3::splat(100.0),
        };
    };
    layers[1..].iter().fold(first.node(), |acc, l| {
        l.operation.combine(acc, l.node(), l.blend)
    })
}

/// Reads a scene node back into layers: a left fold of transformed bodies comes
/// back as the list it was saved from; anything else becomes one imported layer.
pub fn layers_of(node: &CsgNode) -> Vec<Layer> {
    let mut tail = Vec::new();
    let mut node = node;
    while let Some((operation, blend, a, b)) = Operation::split(node) {
        tail.push(Layer::of(b, operation, blend.unwrap_or(DEFAULT_BLEND)));
        node = a;
    }
    tail.push(Layer::of(node, Operation::Union, DEFAULT_BLEND));
    tail.reverse();
    tail
}

/// Parses a scene file's text into layers; errors name the line and column, or the
/// bad node's path (see [`CsgNode::from_json`]).
pub fn from_json(text: &str) -> Result<Vec<Layer>, SceneError> {
    Ok(layers_of(&CsgNode::from_json(text)?))
}

/// The scene file's text for `layers` (pretty JSON, newline-terminated).
pub fn to_json(layers: &[Layer]) -> String {
    scene_node(layers).to_json() + "\n"
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Field;

    #[test]
    fn a_saved_scene_loads_back_as_the_same_shapes() {
        let layers = starter();
        let text = to_json(&layers);
        // Sharp operations have no blend radius to save.
        let norm = |v: Vec<Layer>| -> Vec<Layer> {
            v.into_iter()
                .map(|mut s| {
                    if !s.operation.is_smooth() {
                        s.blend = 0.0;
                    }
                    s
                })
                .collect()
        };
        assert_eq!(norm(from_json(&text).unwrap()), norm(layers));
        // And it is a valid scene file for every other tool.
        CsgNode::from_json(&text).unwrap().compile().unwrap();
    }

    #[test]
    fn each_layer_gives_its_material_where_it_wins_and_keeps_it_through_a_file() {
        let layers = starter();
        let ids: Vec<u8> = layers.iter().map(|l| l.material).collect();
        assert_eq!(ids, vec![0, 1, 2, 3, 4]);
        let field = scene_node(&layers).compile().unwrap();
        assert!(field.has_materials());
        // The block's side, the dome's flank (outside the bore) and the ring's
        // outer rim: each where its own layer decides the surface.
        for (p, id) in [
            (Vec3::new(-0.62, -0.1, -0.2), 0),
            (Vec3::new(0.5, 1.015, 0.0), 1),
            (Vec3::new(0.0, -0.55, 1.18), 3),
        ] {
            assert!(field.value(p).abs() < 0.05, "{p} is near the surface");
            assert_eq!(field.material(p).dominant(), id, "at {p}");
        }
        // The bore's wall is the cutter's material; the file keeps every id.
        let wall = Vec3::new(0.3 * 1.1 - 0.01, 1.0, 0.0);
        assert_eq!(field.material(wall).dominant(), 2);
        let back = from_json(&to_json(&layers)).unwrap();
        assert_eq!(back.iter().map(|l| l.material).collect::<Vec<_>>(), ids);
        // A layer of material 0 adds no node: an imported body keeps its own.
        let inner = CsgNode::Material {
            id: 5,
            child: Box::new(Solid::Sphere.node()),
        };
        let imported = Layer {
            body: Body::Imported(inner),
            ..Layer::new(Solid::Sphere, Operation::Union, 0.1, Vec3::ZERO, 1.0)
        };
        let f = imported.node().compile().unwrap();
        assert_eq!(f.material(Vec3::new(0.5, 0.0, 0.0)).dominant(), 5);
    }

    #[test]
    fn files_the_untyped_editor_wrote_still_load() {
        // Sorted keys, f32 values printed as f64, no rotation fields.
        let text = r#"{
  "a": {
    "child": { "radius": 0.5, "type": "sphere" },
    "scale": 1.2999999523162842,
    "translate": [0.0, 0.6000000238418579, 0.0],
    "type": "transform"
  },
  "b": {
    "child": { "half_height": 0.3499999940395355, "radius": 0.25, "type": "capsule" },
    "scale": 0.8999999761581421,
    "translate": [0.550000011920929, 0.10000000149011612, 0.75],
    "type": "transform"
  },
  "radius": 0.11999999731779099,
  "type": "smooth_difference"
}"#;
        let layers = from_json(text).unwrap();
        assert_eq!(
            layers,
            vec![
                Layer::new(
                    Solid::Sphere,
                    Operation::Union,
                    DEFAULT_BLEND,
                    Vec3::new(0.0, 0.6, 0.0),
                    1.3
                ),
                Layer::new(
                    Solid::Capsule,
                    Operation::SmoothDifference,
                    0.12,
                    Vec3::new(0.55, 0.1, 0.75),
                    0.9
                ),
            ]
        );
    }

    #[test]
    fn foreign_scenes_load_as_one_movable_shape() {
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../assets/scenes/example.json"
        ))
        .unwrap();
        let node = CsgNode::from_json(&text).unwrap();
        let layers = from_json(&text).unwrap();
        assert_eq!(layers.len(), 1);
        assert!(matches!(layers[0].body, Body::Imported(_)));
        // Wrapped in a transform, it is the same field.
        let a = node.compile().unwrap();
        let b = scene_node(&layers).compile().unwrap();
        for i in 0..50 {
            let p = Vec3::new(
                (i as f32 * 0.37).sin(),
                (i as f32 * 0.71).cos(),
                0.1 * i as f32 - 2.5,
            );
            assert!((a.value(p) - b.value(p)).abs() < 1e-5);
        }
    }
}
