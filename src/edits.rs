//! Edits: [`EditsPlugin`] applies [`ApplyEdit`] brushes, [`UndoEdit`] and
//! [`RedoEdit`] steps and [`ReplaceField`] swaps to each volume's edited field
//! (its [`kdcontour::edit::EditHistory`]) and queues a rebuild of exactly the
//! chunks they reach (in [`KdContourSystems::Edits`](crate::KdContourSystems::Edits)).

use crate::messages::{ApplyEdit, EditApplied, RedoEdit, ReplaceField, UndoEdit};
use crate::settings::KdContourSettings;
use crate::state::VolumeState;
use crate::stats::MainThreadClock;
use crate::volume::KdVolume;
use crate::KdContourStep;
use bevy::prelude::*;
use kdcontour::world::ChunkKey;

/// Applies [`ApplyEdit`], [`UndoEdit`], [`RedoEdit`] and [`ReplaceField`]
/// messages.
pub struct EditsPlugin;

impl Plugin for EditsPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<MainThreadClock>()
            .add_systems(PostUpdate, apply_edits.in_set(KdContourStep::ApplyEdits));
    }
}

/// Field swaps first (they put the edit log on the new field), then brushes in
/// order, then undos, then redos.
#[allow(clippy::too_many_arguments)]
pub(crate) fn apply_edits(
    mut edits: MessageReader<ApplyEdit>,
    mut undos: MessageReader<UndoEdit>,
    mut redos: MessageReader<RedoEdit>,
    mut replaced: MessageReader<ReplaceField>,
    mut applied: MessageWriter<EditApplied>,
    settings: Res<KdContourSettings>,
    clock: Res<MainThreadClock>,
    mut volumes: Query<(&mut VolumeState, &mut KdVolume)>,
) {
    let _time = clock.measure();
    for msg in replaced.read() {
        let Ok((mut state, mut vol)) = volumes.get_mut(msg.volume) else {
            warn!("ReplaceField: {} is not a meshed volume", msg.volume);
            continue;
        };
        let iso = state.base_iso();
        state.swap_base(msg.field.0.clone(), iso);
        // Keep the component in step (the volume subsystem then sees nothing to do).
        vol.field = msg.field.clone();
        let rebuilt = match &msg.regions {
            Some(regions) => {
                let mut all: Vec<ChunkKey> = Vec::new();
                for &(center, radius) in regions {
                    all.extend(state.rebuild_near(center, radius));
                }
                all.sort_by_key(|c| c.order());
                all.dedup();
                all
            }
            None => state.rebuild_all(),
        };
        applied.write(EditApplied {
            volume: msg.volume,
            rebuilt,
        });
    }
    for edit in edits.read() {
        let Ok((mut state, _)) = volumes.get_mut(edit.volume) else {
            warn!("ApplyEdit: {} is not a meshed volume", edit.volume);
            continue;
        };
        let brush = edit.brush.clone();
        let steps = settings.undo_steps;
        let (center, reach) = match state
            .history_mut()
            .apply(brush, edit.continues_stroke, steps)
        {
            Ok(r) => r,
            Err(e) => {
                warn!("ApplyEdit on {}: {e}", edit.volume);
                continue;
            }
        };
        let rebuilt = state.rebuild_near(center, reach);
        applied.write(EditApplied {
            volume: edit.volume,
            rebuilt,
        });
    }
    let steps = undos
        .read()
        .map(|m| (m.volume, true))
        .chain(redos.read().map(|m| (m.volume, false)));
    for (volume, undo) in steps {
        let Ok((mut state, _)) = volumes.get_mut(volume) else {
            warn!("UndoEdit / RedoEdit: {volume} is not a meshed volume");
            continue;
        };
        let history = state.history_mut();
        let reaches = if undo { history.undo() } else { history.redo() };
        let Some(reaches) = reaches else {
            let what = if undo { "undo" } else { "redo" };
            info!("KdVolume {volume}: nothing to {what}");
            continue;
        };
        let mut rebuilt = Vec::new();
        for (center, reach) in reaches {
            rebuilt.extend(state.rebuild_near(center, reach));
        }
        rebuilt.sort_by_key(|c| c.order());
        rebuilt.dedup();
        applied.write(EditApplied { volume, rebuilt });
    }
}
