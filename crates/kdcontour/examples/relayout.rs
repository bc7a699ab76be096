//! What one camera step costs a horizon world (issue 12, keeping up with the
//! camera): the terrain demo's field, 32-cell chunks, a 4,096-cell view over
//! level-0 rows -3..=1 as the plugin's horizon volume lays it out, the camera
//! 40 cells up. After building the whole view, the camera steps one level-0
//! chunk along x at a time; each step prints the chunks rebuilt (new ones, and
//! kept ones whose neighbourhood changed, by level) and how long rebuilding
//! them took on 2 threads.
//!
//! `cargo run --release -p kdcontour --example relayout [-- STEPS [RING]]`
//! (default 6 steps, ring 1: level-0 chunks within 64 cells, as the demo).

use glam::{IVec3, Vec2, Vec3};
use kdcontour::field::terrain::{Density, DensityParams};
use kdcontour::world::{ChunkKey, Layout, World};
use kdcontour::Settings;
use std::collections::HashSet;
use std::time::Instant;

/// Cells per chunk side.
const RES: u32 = 32;
/// The top level: 32 * 2^7 = 4,096 cells.
const TOP: u32 = 7;
/// Level-0 chunk rows kept (as the demo's `with_rows(-3, 1)`).
const ROWS: (i32, i32) = (-3, 1);

/// Whether the view keeps chunk `k` with the camera at `cam` (level-0 chunks):
/// it reaches into the rows and comes within the view distance along x and z.
fn kept(k: &ChunkKey, cam: Vec3) -> bool {
    let c = Vec2::new(cam.x, cam.z);
    let near = c.clamp(
        Vec2::new(k.lo().x as f32, k.lo().z as f32),
        Vec2::new(k.hi().x as f32, k.hi().z as f32),
    );
    k.lo().y <= ROWS.1 && k.hi().y > ROWS.0 && near.distance(c) <= (1 << TOP) as f32
}

fn main() {
    let mut args = std::env::args().skip(1);
    let steps: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(6);
    let ring: f32 = args.next().and_then(|s| s.parse().ok()).unwrap_or(1.0);
    let field = Density::new(DensityParams::demo(7));
    let side = 1i32 << TOP;
    let (lo, hi) = (
        IVec3::new(-side, -side, -side),
        IVec3::new(2 * side, side, 2 * side),
    );
    let settings = Settings {
        threads: 2,
        ..Default::default()
    };
    let mut cam = Vec3::new(0.5, 40.0 / RES as f32, 0.5);
    let uniform = Layout::uniform(lo, hi, TOP).expect("a valid region");
    let mut world =
        World::new(Vec3::ZERO, 1.0, RES, uniform, 0.02, settings).expect("a valid world");
    world
        .set_layout(Layout::around(lo, hi, TOP, cam, ring).expect("a valid layout"))
        .expect("within budget");
    let all: Vec<ChunkKey> = world
        .chunks()
        .into_iter()
        .filter(|k| kept(k, cam))
        .collect();
    let t = Instant::now();
    world.build(&all, &field).expect("the demo field builds");
    println!(
        "whole view: {} chunks in {:.2} s",
        all.len(),
        t.elapsed().as_secs_f64()
    );
    for _ in 0..steps {
        cam.x += 1.0;
        let before: HashSet<ChunkKey> = world.chunks().into_iter().collect();
        let layout = Layout::around(lo, hi, TOP, cam, ring).expect("a valid layout");
        let stale: Vec<ChunkKey> = world
            .set_layout(layout)
            .expect("within budget")
            .into_iter()
            .filter(|k| kept(k, cam))
            .collect();
        let mut by_level = vec![[0usize; 2]; TOP as usize + 1];
        for k in &stale {
            by_level[k.level as usize][before.contains(k) as usize] += 1;
        }
        let t = Instant::now();
        world.build(&stale, &field).expect("the demo field builds");
        let new: usize = by_level.iter().map(|l| l[0]).sum();
        println!(
            "camera at x = {:.1} chunks: {} rebuilt ({} new, {} kept) in {:.2} s; \
             [new, kept] by level: {:?}",
            cam.x,
            stale.len(),
            new,
            stale.len() - new,
            t.elapsed().as_secs_f64(),
            by_level
        );
    }
}
