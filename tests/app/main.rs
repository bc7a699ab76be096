//! The plugin's headless tests, one binary: a module per subject, so a new
//! subsystem adds tests, not another link of Bevy.

mod colliders;
mod common;
mod horizon;
mod materials;
mod navmesh;
mod net;
mod persist;
mod rolling;
mod undo;
mod volumes;
