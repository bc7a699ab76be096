//! Navmesh tiles from kdcontour chunk meshes, stitched into one walkable
//! graph, with path queries. Bevy-free: the plugin's `navmesh` feature builds
//! a tile in each chunk's meshing task and keeps a [`NavMesh`] per volume.
//!
//! - **A tile per chunk** ([`NavTile::build`]): Recast's steps (through
//!   [rerecast]: rasterize, filter, erode by the agent's radius, regions,
//!   contours, convex polygons) over the chunk's own mesh, the same triangles
//!   it shows. A chunk's mesh ends at its faces; so that Recast does not take
//!   those ends for walls, every open edge of the mesh is continued outward
//!   (an *apron* in the plane of its triangle), and the tile keeps only the
//!   floor of the chunk's own triangles: each floor belongs to the one chunk
//!   whose mesh shows it.
//! - **Stitched** ([`NavMesh::insert`]): an open polygon edge of one tile is
//!   linked to the open edges of the tiles it touches (same level or not)
//!   that run along it within [`NavSettings::link_tolerance`] across and
//!   [`NavSettings::max_climb`] in height; the overlap is the portal.
//! - **Paths** ([`NavMesh::find_path`]): A* over polygons, then the funnel
//!   (string pulling) through the portals, then the corners pulled straight
//!   where a walk over the floor from one to a later one meets no wall. A
//!   start or goal that is not on a walkable floor (inside rock, in the air,
//!   on a too steep slope) and a goal that cannot be reached are errors that
//!   say so ([`PathError`]).
//! - **Straight lines** ([`NavMesh::is_open_between`]): whether the floor is
//!   open along a line seen from above, walked polygon to polygon.
//!
//! What it does not do: headroom is checked against the surface within a
//! chunk and its aprons only (a ceiling in the chunk above, lower than the
//! agent over a floor near the chunk's top, is not seen); path heights follow
//! Recast's detail mesh, which sits up to a few cell heights above the surface
//! it rasterized (0.1 to 0.3 units at the default cell on rolling ground); a
//! floor outline Recast cannot cut into polygons is left out of its tile and
//! counted ([`NavTile::dropped_outlines`]); agents are not steered (a path is
//! a polyline to follow).

#![warn(missing_docs)]

mod links;
mod path;
mod settings;
mod tile;

pub mod navmesh;

pub use navmesh::{NavMesh, Path, PathError};
/// The Recast port the tiles are built with.
pub use rerecast;
pub use settings::{NavError, NavSettings};
pub use tile::{NavPoly, NavTile};
