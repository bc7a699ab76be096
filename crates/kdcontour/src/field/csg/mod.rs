//! A CSG tree of primitives, booleans and transforms, and its JSON scene format.
//!
//! [`CsgNode`] is the serialisable description (what a scene file holds); it is
//! checked and compiled into a [`Csg`] field that evaluates fast. A scene file is one
//! node, tagged by `"type"`:
//!
//! ```json
//! { "type": "smooth_union", "radius": 0.1, "children": [
//!     { "type": "box", "half_extents": [0.5, 0.3, 0.3] },
//!     { "type": "sphere", "radius": 0.35, "center": [0.5, 0.0, 0.0] },
//!     { "type": "transform", "translate": [0, 0.4, 0], "rotate_axis": [1, 0, 0],
//!       "rotate_degrees": 90, "scale": 1.0,
//!       "child": { "type": "torus", "major_radius": 0.3, "minor_radius": 0.08 } }
//! ] }
//! ```
//!
//! Node types: primitives `sphere`, `box`, `rounded_box`, `torus`, `cylinder`,
//! `capsule`, `cone`, `plane` (each with an optional `center`); booleans `union`,
//! `intersection` (over `children`), `difference` (`a` minus `b`); smooth variants
//! `smooth_union`, `smooth_intersection` (with `radius`) and `smooth_difference`;
//! `transform` (`translate`, `rotate_axis` + `rotate_degrees`, uniform `scale`); and
//! noise terrain `heightfield` and `density` (see [`super::terrain`]); and
//! `material` (`id`, `child`), which gives its child a material id.
//!
//! A scene nests at most [`MAX_DEPTH`] nodes deep, and holds no string longer than
//! [`MAX_NAME`] bytes.
//!
//! The module is split by job: [`CsgNode`] and its JSON in `schema`, read node by
//! node in `parse`; the fields
//! each primitive has, their ranges and the shape they build in `primitive` (one
//! table, read by both validation and compilation) over the range checks of
//! `param`; validation in `check`; compilation to the evaluable tree in `compile`;
//! bounding spheres in `bound`, and the hierarchy over a union's many children in
//! `bvh`; evaluation in `eval`; and batched grid sampling in `sample`.

mod bound;
mod bvh;
mod check;
mod compile;
mod eval;
mod material;
mod param;
mod parse;
mod primitive;
mod sample;
mod schema;

pub use compile::Csg;
pub use parse::{MAX_DEPTH, MAX_NAME};
pub use schema::CsgNode;
