//! Edits: [`EditsPlugin`] applies [`ApplyEdit`] brushes, [`UndoEdit`] and
//! [`RedoEdit`] steps and [`ReplaceField`] swaps to each volume's edited field
//! (its [`kdcontour::edit::EditHistory`]) and queues a rebuild of exactly the
//! chunks they reach (in [`KdContourSystems::Edits`](crate::KdContourSystems::Edits)).
//! A volume marked [`RemoteEdits`] takes its edits from elsewhere (a server):
//! its brushes, undos and redos are left to that subsystem.

use crate::messages::{ApplyEdit, EditApplied, RedoEdit, ReplaceField, UndoEdit};
use crate::settings::KdContourSettings;
use crate::state::VolumeState;
use crate::stats::MainThreadClock;
use crate::volume::KdVolume;
use crate::KdContourStep;
use bevy::prelude::*;
use kdcontour::edit::EditOp;
use kdcontour::world::ChunkKey;

/// Applies [`ApplyEdit`], [`UndoEdit`], [`RedoEdit`] and [`ReplaceField`]
/// messages.
pub struct EditsPlugin;

impl Plugin for EditsPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<MainThreadClock>()
            .register_type::<RemoteEdits>()
            .add_systems(PostUpdate, apply_edits.in_set(KdContourStep::ApplyEdits));
    }
}

/// On a volume: its edit history follows another (a server's, through the
/// `net` subsystem), so [`ApplyEdit`], [`UndoEdit`] and [`RedoEdit`] for it
/// are not applied here; that subsystem sends them on as requests and applies
/// what comes back.
#[derive(Component, Clone, Copy, Debug, Default, Reflect)]
#[reflect(Component)]
pub struct RemoteEdits;

/// Applies `op` to `state`'s history (keeping at most `steps` undo steps) and
/// queues a rebuild of the chunks it reaches; returns them (none for an undo
/// or redo with nothing to take back, which still ends the open stroke). The
/// one path every edit takes, local or from the network.
pub(crate) fn apply_op(
    state: &mut VolumeState,
    op: &EditOp,
    steps: usize,
) -> kdcontour::Result<Vec<ChunkKey>> {
    let reaches = op.apply_to(state.history_mut(), steps)?;
    let mut rebuilt = Vec::new();
    for (center, reach) in reaches {
        rebuilt.extend(state.rebuild_near(center, reach));
    }
    rebuilt.sort_by_key(|c| c.order());
    rebuilt.dedup();
    Ok(rebuilt)
}

/// The frame's [`ApplyEdit`], [`UndoEdit`] and [`RedoEdit`] messages as ops,
/// per volume: the brushes in order, then the undos, then the redos (Bevy
/// keeps no order across message types).
pub(crate) fn read_ops<'a>(
    edits: &'a mut MessageReader<ApplyEdit>,
    undos: &'a mut MessageReader<UndoEdit>,
    redos: &'a mut MessageReader<RedoEdit>,
) -> impl Iterator<Item = (Entity, EditOp)> + 'a {
    edits
        .read()
        .map(|e| {
            let op = EditOp::Apply {
                brush: e.brush.clone(),
                continues_stroke: e.continues_stroke,
            };
            (e.volume, op)
        })
        .chain(undos.read().map(|m| (m.volume, EditOp::Undo)))
        .chain(redos.read().map(|m| (m.volume, EditOp::Redo)))
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
    mut volumes: Query<(&mut VolumeState, &mut KdVolume, Has<RemoteEdits>)>,
) {
    let _time = clock.measure();
    for msg in replaced.read() {
        let Ok((mut state, mut vol, _)) = volumes.get_mut(msg.volume) else {
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
            op: None,
        });
    }
    for (volume, op) in read_ops(&mut edits, &mut undos, &mut redos) {
        let Ok((mut state, _, remote)) = volumes.get_mut(volume) else {
            warn!("ApplyEdit / UndoEdit / RedoEdit: {volume} is not a meshed volume");
            continue;
        };
        if remote {
            // The net subsystem sends it to the server instead.
            continue;
        }
        match apply_op(&mut state, &op, settings.undo_steps) {
            Ok(rebuilt) => {
                if rebuilt.is_empty() && matches!(op, EditOp::Undo | EditOp::Redo) {
                    let what = if op == EditOp::Undo { "undo" } else { "redo" };
                    info!("KdVolume {volume}: nothing to {what}");
                }
                applied.write(EditApplied {
                    volume,
                    rebuilt,
                    op: Some(op),
                });
            }
            Err(e) => warn!("ApplyEdit on {volume}: {e}"),
        }
    }
}
