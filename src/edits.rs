//! Edits: [`EditsPlugin`] applies [`ApplyEdit`] brushes and [`ReplaceField`]
//! swaps to each volume's edited field and queues a rebuild of exactly the
//! chunks they reach (in [`KdContourSystems::Edits`](crate::KdContourSystems::Edits)).

use crate::messages::{ApplyEdit, EditApplied, ReplaceField};
use crate::state::VolumeState;
use crate::stats::MainThreadClock;
use crate::volume::KdVolume;
use crate::KdContourStep;
use bevy::prelude::*;
use kdcontour::world::ChunkKey;

/// Applies [`ApplyEdit`] and [`ReplaceField`] messages.
pub struct EditsPlugin;

impl Plugin for EditsPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<MainThreadClock>()
            .add_systems(PostUpdate, apply_edits.in_set(KdContourStep::ApplyEdits));
    }
}

/// Field swaps first (they replay the edit log), then brushes in order.
pub(crate) fn apply_edits(
    mut edits: MessageReader<ApplyEdit>,
    mut replaced: MessageReader<ReplaceField>,
    mut applied: MessageWriter<EditApplied>,
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
        if let Err(e) = state.swap_base(msg.field.0.clone(), iso) {
            warn!(
                "ReplaceField on {}: replaying the edits failed: {e}",
                msg.volume
            );
            continue;
        }
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
        let field = match state.field().with_edit(edit.brush.clone()) {
            Ok(f) => f,
            Err(e) => {
                warn!("ApplyEdit on {}: {e}", edit.volume);
                continue;
            }
        };
        let (center, reach) = field.last_reach().expect("an edit was just added");
        state.set_field(field);
        let rebuilt = state.rebuild_near(center, reach);
        applied.write(EditApplied {
            volume: edit.volume,
            rebuilt,
        });
    }
}
