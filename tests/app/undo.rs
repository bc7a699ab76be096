//! Undo and redo, headless, on a horizon volume (chunk levels around a still
//! camera): after an undo every shown mesh equals a from-scratch build of the
//! edits before it, bit for bit, and only the chunks the undone stroke reached
//! are rebuilt; a redo gives back the meshes it took; a new edit after an undo
//! drops the redo tail; and the history survives a restart through the save.

use crate::common::{app_with, applied_edits, assert_shown_match_fresh, meshes, settle};
use bevy::prelude::*;
use bevy_kdcontour::persist::SaveState;
use bevy_kdcontour::prelude::*;
use kdcontour::edit::EditedField;
use kdcontour::field::FnField;
use kdcontour::Field;
use std::collections::HashSet;
use std::path::Path;
use std::sync::Arc;

/// Cells per chunk side.
const RES: u32 = 8;
/// The view reaches 64 cells: four levels.
const VIEW: u32 = 64;

/// Gentle hills.
fn hills() -> Arc<dyn Field> {
    Arc::new(FnField(|p: Vec3| {
        p.y - 3.0 * (p.x * 0.09).sin() * (p.z * 0.07).cos()
    }))
}

/// A headless app with a still camera over a horizon volume of [`hills`];
/// saved at `save` when given.
fn hills_app(save: Option<&Path>) -> (App, Entity) {
    let mut app = app_with(LodSettings {
        base: 0.01,
        near: 8.0,
        ..Default::default()
    });
    app.world_mut()
        .spawn((LodCamera, Transform::from_xyz(4.0, 8.0, 4.0)));
    let volume = KdVolume::horizon(hills(), RES, 1.0, VIEW).with_level0(2 * RES);
    let mut v = app.world_mut().spawn(volume);
    if let Some(path) = save {
        v.insert(KdSave::new(path, "hills").with_autosave(None));
    }
    let v = v.id();
    settle(&mut app, v);
    (app, v)
}

/// Stroke `s`: dab `d` of it. Strokes alternate digging and raising, each a
/// line of dabs 6 cells apart; the later ones cross from level 0 into level 1.
fn dab(s: usize, d: usize) -> Brush {
    let at = Vec3::new(
        -6.0 + 7.0 * s as f32 + 6.0 * d as f32,
        1.0,
        3.0 + 0.5 * d as f32,
    );
    let op = if s.is_multiple_of(2) {
        BrushOp::SmoothSubtract { radius: 1.0 }
    } else {
        BrushOp::SmoothAdd { radius: 1.0 }
    };
    Brush::sphere(at, 2.5, op)
}

/// Dabs per stroke.
const DABS: usize = 3;

/// Sends stroke `s` (its dabs one frame apart, the first a new step).
fn stroke(app: &mut App, volume: Entity, s: usize) {
    for d in 0..DABS {
        let b = dab(s, d);
        app.world_mut().write_message(if d == 0 {
            ApplyEdit::new(volume, b)
        } else {
            ApplyEdit::continuing(volume, b)
        });
        app.update();
    }
}

/// The first `n` strokes, as a log.
fn strokes(n: usize) -> Vec<Brush> {
    (0..n)
        .flat_map(|s| (0..DABS).map(move |d| dab(s, d)))
        .collect()
}

/// The base field with the first `n` strokes replayed from scratch.
fn replayed(n: usize) -> EditedField {
    EditedField::replay(hills(), &strokes(n)).unwrap()
}

fn history(app: &App, volume: Entity) -> (usize, usize, Vec<Brush>) {
    let state = app.world().get::<VolumeState>(volume).unwrap();
    let h = state.history();
    (h.undo_steps(), h.redo_steps(), state.edit_log())
}

/// Sends one undo (or redo) and settles; returns the chunks it rebuilt.
fn step(app: &mut App, volume: Entity, undo: bool) -> HashSet<(u32, [i32; 3])> {
    applied_edits(app);
    if undo {
        app.world_mut().write_message(UndoEdit { volume });
    } else {
        app.world_mut().write_message(RedoEdit { volume });
    }
    app.update();
    let applied = applied_edits(app);
    settle(app, volume);
    assert!(applied.len() <= 1, "{applied:?}");
    applied
        .iter()
        .flat_map(|a| a.rebuilt.iter().map(|k| (k.level, k.coord.to_array())))
        .collect()
}

#[test]
fn undo_gives_the_meshes_before_the_stroke_and_redo_gives_them_back() {
    let (mut app, v) = hills_app(None);
    let untouched = meshes(&app, v);
    const N: usize = 4;
    for s in 0..N {
        stroke(&mut app, v, s);
    }
    settle(&mut app, v);
    assert_eq!(history(&app, v), (N, 0, strokes(N)));
    let after = meshes(&app, v);
    assert_shown_match_fresh(&app, v, &replayed(N));

    // Undo the last stroke: the meshes of the first N - 1, from scratch.
    let rebuilt = step(&mut app, v, true);
    assert_eq!(history(&app, v), (N - 1, 1, strokes(N - 1)));
    assert_shown_match_fresh(&app, v, &replayed(N - 1));
    let undone = meshes(&app, v);
    // Only what the stroke reached was rebuilt, and every mesh it changed was.
    let changed: Vec<_> = after
        .keys()
        .filter(|k| after.get(k) != undone.get(k))
        .collect();
    assert!(!changed.is_empty(), "the undo changed no mesh");
    for k in &changed {
        assert!(
            rebuilt.contains(k),
            "chunk {k:?} changed but was not rebuilt"
        );
    }
    assert!(
        rebuilt.len() * 4 < after.len(),
        "an undo of one stroke rebuilt {} of {} chunks",
        rebuilt.len(),
        after.len()
    );
    let levels: HashSet<u32> = rebuilt.iter().map(|k| k.0).collect();
    assert!(
        levels.len() > 1,
        "the stroke crosses a level boundary: {levels:?}"
    );
    eprintln!(
        "undo rebuilt {} of {} shown chunks (levels {levels:?}); {} meshes changed",
        rebuilt.len(),
        after.len(),
        changed.len()
    );

    // Redo: the meshes with all N, bit for bit.
    step(&mut app, v, false);
    assert_eq!(history(&app, v), (N, 0, strokes(N)));
    assert_eq!(meshes(&app, v), after, "redo did not give the meshes back");

    // Undo everything: the untouched terrain; one more undo does nothing.
    for _ in 0..N {
        step(&mut app, v, true);
    }
    assert_eq!(meshes(&app, v), untouched);
    assert!(step(&mut app, v, true).is_empty());
    assert_eq!(history(&app, v), (0, N, vec![]));

    // Redo two, then a new stroke: the two left to redo are dropped.
    step(&mut app, v, false);
    step(&mut app, v, false);
    stroke(&mut app, v, 7);
    settle(&mut app, v);
    let mut log = strokes(2);
    log.extend((0..DABS).map(|d| dab(7, d)));
    assert_eq!(history(&app, v), (3, 0, log.clone()));
    assert!(step(&mut app, v, false).is_empty(), "redo after a new edit");
    assert_shown_match_fresh(&app, v, &EditedField::replay(hills(), &log).unwrap());
}

#[test]
fn undo_and_redo_survive_a_restart() {
    let dir = std::env::temp_dir().join(format!("kdundo-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("hills.kdsave");
    let (mut app, v) = hills_app(Some(&path));
    for s in 0..3 {
        stroke(&mut app, v, s);
    }
    settle(&mut app, v);
    let all = meshes(&app, v);
    step(&mut app, v, true);
    let before = meshes(&app, v);
    app.world_mut().write_message(AppExit::Success);
    app.update();
    drop(app);

    let (mut again, v) = hills_app(Some(&path));
    let status = again.world().get::<SaveState>(v).unwrap();
    assert!(!status.refused());
    assert_eq!(status.saved(), 3 * DABS, "the undone stroke is saved too");
    assert_eq!(history(&again, v), (2, 1, strokes(2)));
    assert_eq!(meshes(&again, v), before, "the reload differs");
    // The stroke undone before the restart comes back, whole.
    step(&mut again, v, false);
    assert_eq!(history(&again, v), (3, 0, strokes(3)));
    assert_eq!(meshes(&again, v), all);
    std::fs::remove_dir_all(&dir).unwrap();
}
