//! Bevy plugin for [`kdcontour`]: chunked, LOD-driven isosurface meshing.
//!
//! The ECS layer (plugin, chunk entities, async meshing, edits and LOD) is being
//! built on top of the Bevy-free core; until then this crate re-exports the core so
//! downstream code can start against its API.

pub use kdcontour;

/// The README's code, compiled and run as a doctest so it cannot drift.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
