//! The scene-file schema: [`CsgNode`], the serde tree a JSON scene file holds, and
//! its parsing and printing.

use crate::error::SceneError;
use crate::field::terrain::{DensityParams, HeightfieldParams};
use glam::Vec3;
use serde::{Deserialize, Serialize};

/// One node of a scene file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum CsgNode {
    /// A ball.
    Sphere {
        /// Radius (> 0).
        radius: f32,
        /// Center.
        #[serde(default)]
        center: Vec3,
    },
    /// An axis-aligned box with sharp edges.
    Box {
        /// Half side lengths (each > 0).
        half_extents: Vec3,
        /// Center.
        #[serde(default)]
        center: Vec3,
    },
    /// A box with rounded edges.
    RoundedBox {
        /// Half side lengths (each > radius).
        half_extents: Vec3,
        /// Rounding radius (> 0).
        radius: f32,
        /// Center.
        #[serde(default)]
        center: Vec3,
    },
    /// A torus around Y.
    Torus {
        /// Ring radius (> minor radius).
        major_radius: f32,
        /// Tube radius (> 0).
        minor_radius: f32,
        /// Center.
        #[serde(default)]
        center: Vec3,
    },
    /// A capped cylinder along Y.
    Cylinder {
        /// Radius (> 0).
        radius: f32,
        /// Half length (> 0).
        half_height: f32,
        /// Center.
        #[serde(default)]
        center: Vec3,
    },
    /// A capsule along Y.
    Capsule {
        /// Radius (> 0).
        radius: f32,
        /// Half length of the inner segment (>= 0).
        half_height: f32,
        /// Center.
        #[serde(default)]
        center: Vec3,
    },
    /// A capped cone along Y, apex up.
    Cone {
        /// Base radius (> 0).
        radius: f32,
        /// Half height (> 0).
        half_height: f32,
        /// Center.
        #[serde(default)]
        center: Vec3,
    },
    /// The half-space below a plane.
    Plane {
        /// Outward normal (non-zero; normalised on load).
        normal: Vec3,
        /// Plane offset along the normal.
        #[serde(default)]
        offset: f32,
    },
    /// Union (min) of the children.
    Union {
        /// At least one child.
        children: Vec<CsgNode>,
    },
    /// Intersection (max) of the children.
    Intersection {
        /// At least one child.
        children: Vec<CsgNode>,
    },
    /// `a` with `b` removed.
    Difference {
        /// The base shape.
        a: Box<CsgNode>,
        /// The shape cut away.
        b: Box<CsgNode>,
    },
    /// Union blended over `radius`.
    SmoothUnion {
        /// Blend radius (> 0).
        radius: f32,
        /// At least one child.
        children: Vec<CsgNode>,
    },
    /// Intersection blended over `radius`.
    SmoothIntersection {
        /// Blend radius (> 0).
        radius: f32,
        /// At least one child.
        children: Vec<CsgNode>,
    },
    /// Difference blended over `radius`.
    SmoothDifference {
        /// Blend radius (> 0).
        radius: f32,
        /// The base shape.
        a: Box<CsgNode>,
        /// The shape cut away.
        b: Box<CsgNode>,
    },
    /// Moves, rotates and uniformly scales its child (scale, then rotate, then
    /// translate).
    Transform {
        /// Translation.
        #[serde(default)]
        translate: Vec3,
        /// Rotation axis (non-zero when `rotate_degrees` is not 0).
        #[serde(default = "default_axis")]
        rotate_axis: Vec3,
        /// Rotation angle in degrees.
        #[serde(default)]
        rotate_degrees: f32,
        /// Uniform scale (> 0).
        #[serde(default = "one")]
        scale: f32,
        /// The transformed node.
        child: Box<CsgNode>,
    },
    /// Gives its child a material: every surface in `child` has material `id`
    /// (0 to 255), overriding materials given further down. Outside any
    /// `material` node a primitive has material 0 and noise terrain its own
    /// ([`crate::material::terrain_ids`]).
    Material {
        /// The material id (0 to 255).
        id: u8,
        /// The node it gives the material to.
        child: Box<CsgNode>,
    },
    /// An fBm height-field terrain.
    Heightfield(HeightfieldParams),
    /// A 3-D density terrain with overhangs and optional caves.
    Density(DensityParams),
}

fn default_axis() -> Vec3 {
    Vec3::Y
}
fn one() -> f32 {
    1.0
}

impl CsgNode {
    /// Parses a scene file's text. Syntax errors carry line and column; schema
    /// errors (unknown type or field, missing or mistyped value, nesting deeper than
    /// [`MAX_DEPTH`](super::MAX_DEPTH) nodes) and impossible values (negative
    /// radius, empty union) name the node's path. Long names from the text are cut.
    pub fn from_json(text: &str) -> Result<CsgNode, SceneError> {
        let node = super::parse::parse(text)?;
        node.check("root")?;
        Ok(node)
    }

    /// Pretty JSON of this node.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("CsgNode always serialises")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::Field;

    #[test]
    fn documented_example_parses() {
        let text = r#"{ "type": "smooth_union", "radius": 0.1, "children": [
            { "type": "box", "half_extents": [0.5, 0.3, 0.3] },
            { "type": "sphere", "radius": 0.35, "center": [0.5, 0.0, 0.0] },
            { "type": "transform", "translate": [0, 0.4, 0], "rotate_axis": [1, 0, 0],
              "rotate_degrees": 90, "scale": 1.0,
              "child": { "type": "torus", "major_radius": 0.3, "minor_radius": 0.08 } }
        ] }"#;
        let node = CsgNode::from_json(text).unwrap();
        let again = CsgNode::from_json(&node.to_json()).unwrap();
        assert_eq!(node, again);
        let f = node.compile().unwrap();
        assert!(f.value(Vec3::ZERO) < 0.0);
        assert!(f.value(Vec3::splat(0.95)) > 0.0);
    }

    #[test]
    fn syntax_errors_have_line_and_column() {
        let err = CsgNode::from_json("{\n  \"type\": \"sphere\", \"radius\": 1 ]").unwrap_err();
        match &err {
            SceneError::Syntax { line, .. } => assert_eq!(*line, 2),
            other => panic!("{other:?}"),
        }
        assert!(err.to_string().contains("line 2"), "{err}");
    }
}
