//! Saving and loading a long sculpting session: 10,000 dabs on the terrain
//! demo's field, in strokes of 8 that grow over a point, as a brush held down
//! makes them, each stroke one undo step (the plugin's default 256 kept).
//!
//! Before measuring it prints the save's size with and without compaction
//! ([`kdcontour::edit::EditHistory::saved`]), and what the other way to shorten a
//! long log would hold: a snapshot of the samples of every 32-cell chunk the edits
//! reach (34^3 `f32` each, as [`kdcontour::World`] keeps them). Then:
//! - `save`: compact, encode and write atomically (what autosave does on the I/O
//!   pool);
//! - `load`: read, check and decode the file, and restore the edits and their
//!   undo steps onto the field (what a volume does when it starts).
//!
//! `cargo bench -p bevy_kdcontour --bench persist`

use bevy::math::{IVec3, Vec3};
use bevy_kdcontour::kdcontour::edit::{Brush, BrushOp, EditHistory, EditedField};
use bevy_kdcontour::kdcontour::field::terrain::{Density, DensityParams};
use bevy_kdcontour::persist::file::{self, SaveData};
use bevy_kdcontour::KdSave;
use criterion::{criterion_group, criterion_main, Criterion};
use std::collections::HashSet;
use std::sync::Arc;
use std::time::Duration;

/// Edits in the session.
const EDITS: usize = 10_000;
/// Cells per chunk side (the terrain demo's).
const CHUNK: f32 = 32.0;
/// Dabs per stroke.
const DABS: usize = 8;
/// Undo steps kept (the plugin's default).
const UNDO_STEPS: usize = 256;

/// The session: strokes of 8 dabs, each a little larger than the last, over
/// points scattered across 512 x 512 cells of terrain; digs and adds alternate.
fn session() -> Vec<Brush> {
    let mut s = 0x2545_f491_4f6c_dd1du64;
    let mut unit = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f32 / (1u64 << 53) as f32
    };
    (0..EDITS / DABS)
        .flat_map(|stroke| {
            let at = Vec3::new(
                unit() * 512.0 - 256.0,
                unit() * 30.0 - 15.0,
                unit() * 512.0 - 256.0,
            );
            let op = if stroke % 2 == 0 {
                BrushOp::Subtract
            } else {
                BrushOp::Add
            };
            (0..DABS).map(move |dab| Brush::sphere(at, 2.0 + 0.5 * dab as f32, op))
        })
        .collect()
}

fn persist(c: &mut Criterion) {
    let params = DensityParams::demo(7);
    let fingerprint = KdSave::fingerprint_of(&params);
    let log = session();
    let base: Arc<dyn kdcontour::Field> = Arc::new(Density::new(params));
    let mut history = EditHistory::new(EditedField::new(base.clone()));
    for (i, b) in log.iter().enumerate() {
        history.apply(b.clone(), i % DABS != 0, UNDO_STEPS).unwrap();
    }
    let whole = file::encode(&SaveData {
        fingerprint: fingerprint.clone(),
        edits: log.clone(),
        undo: Default::default(),
    });
    let (kept, undo) = history.saved();
    let saved = file::encode(&SaveData {
        fingerprint: fingerprint.clone(),
        edits: kept.clone(),
        undo,
    });
    // Chunks whose samples a snapshot would hold: every chunk a brush's reach
    // (its bounding sphere) touches.
    let mut chunks = HashSet::new();
    for b in &log {
        let kdcontour::field::csg::CsgNode::Sphere { radius, center } = b.shape else {
            unreachable!("the session uses spheres")
        };
        let lo = ((center - radius) / CHUNK).floor().as_ivec3();
        let hi = ((center + radius) / CHUNK).floor().as_ivec3();
        for z in lo.z..=hi.z {
            for y in lo.y..=hi.y {
                for x in lo.x..=hi.x {
                    chunks.insert(IVec3::new(x, y, z));
                }
            }
        }
    }
    let snapshot = chunks.len() * 34usize.pow(3) * 4;
    println!(
        "persist_10000: log of {} edits is {} bytes; compacted to {} edits, {} bytes; \
         a snapshot of the {} chunks they reach would hold {} bytes of samples",
        log.len(),
        whole.len(),
        kept.len(),
        saved.len(),
        chunks.len(),
        snapshot
    );
    let dir = std::env::temp_dir().join(format!("kdsave-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("terrain.kdsave");
    let mut g = c.benchmark_group("persist_10000");
    g.sample_size(20).measurement_time(Duration::from_secs(5));
    g.bench_function("save", |b| {
        b.iter(|| {
            let (edits, undo) = history.saved();
            let bytes = file::encode(&SaveData {
                fingerprint: fingerprint.clone(),
                edits,
                undo,
            });
            file::write_atomic(&path, &bytes).unwrap();
        })
    });
    g.bench_function("load", |b| {
        b.iter(|| {
            let data = file::read(&path, file::MAX_FILE_BYTES).unwrap().unwrap();
            EditHistory::restore(EditedField::new(base.clone()), data.edits, &data.undo).unwrap()
        })
    });
    g.bench_function("load_uncompacted", |b| {
        let raw = dir.join("raw.kdsave");
        file::write_atomic(&raw, &whole).unwrap();
        b.iter(|| {
            let data = file::read(&raw, file::MAX_FILE_BYTES).unwrap().unwrap();
            EditedField::new(base.clone())
                .with_edits(data.edits)
                .unwrap()
        })
    });
    g.finish();
    std::fs::remove_dir_all(&dir).unwrap();
}

criterion_group!(benches, persist);
criterion_main!(benches);
