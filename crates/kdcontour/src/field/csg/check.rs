//! Validation: every value of a [`CsgNode`] tree lies in its range, and the first
//! one that does not is reported with its node path (`root.children[1].radius`).

use super::param::{check_all, param, Range::*};
use super::CsgNode;
use crate::error::SceneError;
use crate::field::terrain;

impl CsgNode {
    /// Checks every value in the tree; the error names the first bad node's path.
    pub fn check(&self, path: &str) -> Result<(), SceneError> {
        self.check_scaled(path, 1.0)
    }

    /// [`CsgNode::check`] of a node under transforms whose scales multiply to
    /// `scaled`.
    fn check_scaled(&self, path: &str, scaled: f64) -> Result<(), SceneError> {
        if let Some(primitive) = self.primitive() {
            check_all(&primitive.params, path)?;
            // A primitive's coordinates are the point's divided by the scales
            // above it: past this range their squares under- or overflow f32,
            // and a tiny sphere reads as inside everywhere (a huge one as
            // outside). Noise nodes report a point beyond their reach instead.
            if !(MIN_SCALE..=MAX_SCALE).contains(&scaled) {
                return Err(SceneError::Semantic {
                    path: path.to_string(),
                    message: format!(
                        "the transforms above it scale it by {scaled:e} in all; keep that \
                         product of scales between {MIN_SCALE:e} and {MAX_SCALE:e} (beyond, \
                         its coordinates under- or overflow f32)"
                    ),
                });
            }
            return Ok(());
        }
        let noise = |amplitude, frequency, octaves| {
            terrain::check_noise(amplitude, frequency, octaves).map_err(|(field, message)| {
                SceneError::Semantic {
                    path: format!("{path}.{field}"),
                    message,
                }
            })
        };
        match self {
            CsgNode::Union { children } | CsgNode::Intersection { children } => {
                check_children(children, path, scaled)
            }
            CsgNode::SmoothUnion { radius, children }
            | CsgNode::SmoothIntersection { radius, children } => {
                check_all(&[param("radius", *radius, Positive)], path)?;
                check_children(children, path, scaled)
            }
            CsgNode::Difference { a, b } => check_pair(a, b, path, scaled),
            CsgNode::SmoothDifference { radius, a, b } => {
                check_all(&[param("radius", *radius, Positive)], path)?;
                check_pair(a, b, path, scaled)
            }
            CsgNode::Transform {
                translate,
                rotate_axis,
                rotate_degrees,
                scale,
                child,
            } => {
                let mut params = vec![
                    param("translate", *translate, Finite),
                    param("rotate_axis", *rotate_axis, Finite),
                    param("rotate_degrees", *rotate_degrees, FiniteUnquoted),
                ];
                if *rotate_degrees != 0.0 {
                    params.push(param("rotate_axis", *rotate_axis, NonZero));
                }
                params.push(param("scale", *scale, Positive));
                check_all(&params, path)?;
                let scaled = scaled * *scale as f64;
                child.check_scaled(&format!("{path}.child"), scaled)
            }
            CsgNode::Material { child, .. } => child.check_scaled(&format!("{path}.child"), scaled),
            CsgNode::Heightfield(p) => noise(p.amplitude, p.frequency, p.octaves),
            CsgNode::Density(p) => {
                noise(p.amplitude, p.frequency, p.octaves)?;
                match &p.caves {
                    Some(c) => {
                        let mut params = vec![
                            param("caves.frequency", c.frequency, UpTo(terrain::MAX_FREQUENCY)),
                            param("caves.radius", c.radius, Positive),
                        ];
                        if let Some(d) = c.depth {
                            params.push(param("caves.depth", d, NonNegative));
                        }
                        check_all(&params, path)
                    }
                    None => Ok(()),
                }
            }
            _ => unreachable!("every other node is a primitive, checked above"),
        }
    }
}

/// The smallest product of nested transforms' scales a primitive may be under.
const MIN_SCALE: f64 = 1e-15;
/// The largest product of nested transforms' scales a primitive may be under.
const MAX_SCALE: f64 = 1e15;

/// Checks the children of the node at `path` (at least one), under scales
/// multiplying to `scaled`.
fn check_children(children: &[CsgNode], path: &str, scaled: f64) -> Result<(), SceneError> {
    if children.is_empty() {
        return Err(SceneError::Semantic {
            path: format!("{path}.children"),
            message: "needs at least one child".into(),
        });
    }
    for (i, c) in children.iter().enumerate() {
        c.check_scaled(&format!("{path}.children[{i}]"), scaled)?;
    }
    Ok(())
}

/// Checks the operands `a` and `b` of the difference at `path`, under scales
/// multiplying to `scaled`.
fn check_pair(a: &CsgNode, b: &CsgNode, path: &str, scaled: f64) -> Result<(), SceneError> {
    a.check_scaled(&format!("{path}.a"), scaled)?;
    b.check_scaled(&format!("{path}.b"), scaled)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn negative_radius_names_the_path() {
        let err = CsgNode::from_json(
            r#"{"type":"union","children":[{"type":"sphere","radius":0.2},{"type":"sphere","radius":-1}]}"#,
        )
        .unwrap_err();
        assert_eq!(
            err.to_string(),
            "scene node `root.children[1].radius`: must be a finite number > 0, got -1"
        );
    }

    #[test]
    fn every_range_keeps_its_message() {
        // 1e40 overflows f32 to infinity on load.
        let cases = [
            (
                r#"{"type":"sphere","radius":0}"#,
                "root.radius",
                "must be a finite number > 0, got 0",
            ),
            (
                r#"{"type":"sphere","radius":1,"center":[1e40,0,0]}"#,
                "root.center",
                "must be finite, got [inf, 0, 0]",
            ),
            (
                r#"{"type":"box","half_extents":[1,-2,1]}"#,
                "root.half_extents.y",
                "must be a finite number > 0, got -2",
            ),
            (
                r#"{"type":"rounded_box","half_extents":[0.5,0.5,0.1],"radius":0.2}"#,
                "root.half_extents.z",
                "must be finite and larger than radius 0.2, got 0.1",
            ),
            (
                r#"{"type":"torus","major_radius":0.2,"minor_radius":0.3}"#,
                "root.minor_radius",
                "must be smaller than major_radius 0.2, got 0.3",
            ),
            (
                r#"{"type":"torus","major_radius":-1,"minor_radius":0.3}"#,
                "root.major_radius",
                "must be a finite number > 0, got -1",
            ),
            (
                r#"{"type":"cone","radius":1,"half_height":0}"#,
                "root.half_height",
                "must be a finite number > 0, got 0",
            ),
            (
                r#"{"type":"capsule","radius":1,"half_height":-1}"#,
                "root.half_height",
                "must be finite and >= 0, got -1",
            ),
            (
                r#"{"type":"plane","normal":[0,0,0]}"#,
                "root.normal",
                "must not be zero (length at least 0.000001), got [0, 0, 0]",
            ),
            (
                r#"{"type":"plane","normal":[0,1,0],"offset":1e40}"#,
                "root.offset",
                "must be finite, got inf",
            ),
            (
                r#"{"type":"intersection","children":[]}"#,
                "root.children",
                "needs at least one child",
            ),
            (
                r#"{"type":"smooth_union","radius":-0.5,"children":[]}"#,
                "root.radius",
                "must be a finite number > 0, got -0.5",
            ),
            (
                r#"{"type":"smooth_difference","radius":0.1,"a":{"type":"sphere","radius":1},
                    "b":{"type":"union","children":[{"type":"sphere","radius":1},{"type":"sphere","radius":-3}]}}"#,
                "root.b.children[1].radius",
                "must be a finite number > 0, got -3",
            ),
            (
                r#"{"type":"transform","rotate_degrees":1e40,"child":{"type":"sphere","radius":1}}"#,
                "root.rotate_degrees",
                "must be finite",
            ),
            (
                r#"{"type":"transform","rotate_axis":[0,0,0],"rotate_degrees":90,"child":{"type":"sphere","radius":1}}"#,
                "root.rotate_axis",
                "must not be zero (length at least 0.000001), got [0, 0, 0]",
            ),
            (
                r#"{"type":"transform","scale":0,"child":{"type":"sphere","radius":-1}}"#,
                "root.scale",
                "must be a finite number > 0, got 0",
            ),
            (
                r#"{"type":"transform","child":{"type":"sphere","radius":-1}}"#,
                "root.child.radius",
                "must be a finite number > 0, got -1",
            ),
            (
                r#"{"type":"density","amplitude":1,"frequency":1,"caves":{"frequency":1,"radius":0}}"#,
                "root.caves.radius",
                "must be a finite number > 0, got 0",
            ),
            (
                r#"{"type":"density","amplitude":1,"frequency":1,"caves":{"frequency":1e30,"radius":1}}"#,
                "root.caves.frequency",
                "must be > 0 and at most 1000000, got 1000000000000000000000000000000",
            ),
        ];
        for (text, path, message) in cases {
            let err = CsgNode::from_json(text).unwrap_err();
            assert_eq!(
                err.to_string(),
                format!("scene node `{path}`: {message}"),
                "{text}"
            );
        }
        // A zero axis is fine when nothing rotates.
        CsgNode::from_json(
            r#"{"type":"transform","rotate_axis":[0,0,0],"child":{"type":"sphere","radius":1}}"#,
        )
        .unwrap();
    }
}
