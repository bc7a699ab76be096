//! Saving: [`PersistPlugin`] keeps each [`KdSave`] volume's edit log in a file. The
//! log, with its undo and redo steps, is loaded when the volume starts, saved a
//! moment after the last edit, undo or redo (debounced, on the I/O task pool,
//! compacted by [`kdcontour::edit::EditHistory::saved`]), and saved once more, on
//! the main thread, when the app exits ([`AppExit`]).
//!
//! A save records what its edits were made on (the volume's fingerprint, for
//! example the terrain's seed and parameters: [`KdSave::fingerprint_of`]) and is
//! refused for any other. A save that cannot be read, or was made for another
//! field, is never overwritten: the volume runs without it, autosave stays off
//! for it, and [`PersistFailed`] says why and what to do. Writes are atomic (see
//! [`mod@file`]), so a crash or a full disk leaves the previous save whole.
//!
//! Nothing here needs a renderer or a window: saving works in a headless server
//! ([`crate::headless`]).

pub mod file;

use crate::state::VolumeState;
use crate::stats::MainThreadClock;
use crate::{KdContourStep, KdContourSystems};
use bevy::prelude::*;
use bevy::tasks::{block_on, futures::check_ready, IoTaskPool, Task};
use file::{PersistError, SaveData};
use kdcontour::edit::{EditHistory, EditedField};
use serde::Serialize;
use std::path::PathBuf;
use std::time::Duration;

/// Loads, autosaves and saves on exit the edit logs of [`KdSave`] volumes.
pub struct PersistPlugin;

impl Plugin for PersistPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<MainThreadClock>()
            .add_message::<EditsLoaded>()
            .add_message::<EditsSaved>()
            .add_message::<PersistFailed>()
            .add_systems(
                PostUpdate,
                (
                    load_saves.in_set(KdContourStep::LoadEdits),
                    autosave.in_set(KdContourSystems::Stats),
                ),
            )
            .add_systems(Last, save_on_exit);
    }
}

/// Saves a volume's edits to `path` and loads them when it starts (add it with
/// the [`crate::KdVolume`]).
#[derive(Component, Clone, Debug, Reflect)]
#[reflect(Component)]
pub struct KdSave {
    /// The save file.
    pub path: PathBuf,
    /// What the edits are made on, compared with the save's on loading: two
    /// volumes with the same fingerprint must have the same base field. Use
    /// [`KdSave::fingerprint_of`] on the field's parameters (seed included).
    pub fingerprint: String,
    /// Save this long after the last edit (several edits in a stroke make one
    /// save); `None`: only on [`AppExit`].
    pub autosave_after: Option<Duration>,
}

impl KdSave {
    /// A save at `path` for a field described by `fingerprint`, autosaving two
    /// seconds after the last edit.
    pub fn new(path: impl Into<PathBuf>, fingerprint: impl Into<String>) -> Self {
        KdSave {
            path: path.into(),
            fingerprint: fingerprint.into(),
            autosave_after: Some(Duration::from_secs(2)),
        }
    }

    /// A fingerprint from the field's parameters (their JSON), e.g.
    /// `KdSave::fingerprint_of(&DensityParams::demo(7))`.
    pub fn fingerprint_of(params: &impl Serialize) -> String {
        serde_json::to_string(params).unwrap_or_else(|e| format!("unserialisable: {e}"))
    }

    /// The same save with autosave `after` the last edit (`None`: only on exit).
    pub fn with_autosave(mut self, after: Option<Duration>) -> Self {
        self.autosave_after = after;
        self
    }
}

/// A volume's edits were loaded from its save.
#[derive(Message, Clone, Debug)]
pub struct EditsLoaded {
    /// The volume.
    pub volume: Entity,
    /// The save file.
    pub path: PathBuf,
    /// Edits loaded (applied and undone).
    pub edits: usize,
}

/// A volume's edits were saved.
#[derive(Message, Clone, Debug)]
pub struct EditsSaved {
    /// The volume.
    pub volume: Entity,
    /// The save file.
    pub path: PathBuf,
    /// Edits in the log when it was saved (applied and undone).
    pub edits: usize,
    /// Edits written (after compaction).
    pub written: usize,
    /// Bytes written.
    pub bytes: usize,
}

/// Loading or saving a volume's edits failed; the message says what to do.
#[derive(Message, Clone, Debug)]
pub struct PersistFailed {
    /// The volume.
    pub volume: Entity,
    /// What went wrong and what to do.
    pub error: String,
}

/// The history revision and edits a save write covered, and its outcome.
type SaveResult = (u64, usize, Result<(usize, usize), PersistError>);

/// Where a volume's save stands.
#[derive(Component, Default)]
pub struct SaveState {
    /// The save could not be used (unreadable, or another field's): it is never
    /// overwritten.
    refused: bool,
    /// The history's revision when it was last saved (or loaded).
    saved: u64,
    /// Edits in the log when it was last saved (or loaded).
    saved_edits: usize,
    /// The history's revision when it last changed, and when (real time).
    changed: (u64, Duration),
    /// The save being written.
    task: Option<Task<SaveResult>>,
}

impl SaveState {
    /// Whether the save was refused (see the module docs).
    pub fn refused(&self) -> bool {
        self.refused
    }

    /// Edits in the log (applied and undone) when it was last saved or loaded.
    pub fn saved(&self) -> usize {
        self.saved_edits
    }

    /// Whether a save is being written.
    pub fn saving(&self) -> bool {
        self.task.is_some()
    }
}

/// Loads the save of each new [`KdSave`] volume before anything is built.
fn load_saves(
    mut commands: Commands,
    clock: Res<MainThreadClock>,
    mut volumes: Query<(Entity, &KdSave, &mut VolumeState), Without<SaveState>>,
    mut loaded: MessageWriter<EditsLoaded>,
    mut failed: MessageWriter<PersistFailed>,
) {
    let _time = clock.measure();
    for (volume, save, mut state) in &mut volumes {
        let mut status = SaveState::default();
        match load(save, state.field()) {
            Ok(None) => {}
            Ok(Some(history)) => {
                let edits = history.brush_count() - state.field().edit_count();
                *state.history_mut() = history;
                state.rebuild_all();
                info!(
                    "KdVolume {volume}: loaded {edits} edits from {}",
                    save.path.display()
                );
                loaded.write(EditsLoaded {
                    volume,
                    path: save.path.clone(),
                    edits,
                });
            }
            Err(e) => {
                status.refused = true;
                error!("KdVolume {volume}: {e}");
                failed.write(PersistFailed {
                    volume,
                    error: e.to_string(),
                });
            }
        }
        let history = state.history();
        status.saved = history.revision();
        status.saved_edits = history.brush_count();
        status.changed = (history.revision(), Duration::ZERO);
        commands.entity(volume).insert(status);
    }
}

/// The volume's field with the saved edits and their undo steps on top, or
/// `None` with no save.
fn load(save: &KdSave, field: &EditedField) -> Result<Option<EditHistory>, PersistError> {
    let Some(data) = file::read(&save.path, file::MAX_FILE_BYTES)? else {
        return Ok(None);
    };
    if data.fingerprint != save.fingerprint {
        return Err(PersistError::OtherField {
            path: save.path.clone(),
            saved: data.fingerprint,
            current: save.fingerprint.clone(),
        });
    }
    data.undo
        .check(data.edits.len())
        .map_err(|e| PersistError::Corrupt {
            path: save.path.clone(),
            reason: format!("its undo steps do not fit its edits: {e}"),
        })?;
    EditHistory::restore(field.clone(), data.edits, &data.undo)
        .map(Some)
        .map_err(|e| PersistError::Replay {
            path: save.path.clone(),
            reason: e.to_string(),
        })
}

/// Starts writing `history`'s log on the I/O task pool.
fn spawn_save(save: &KdSave, history: EditHistory) -> Task<SaveResult> {
    let (path, fingerprint) = (save.path.clone(), save.fingerprint.clone());
    IoTaskPool::get().spawn(async move {
        let count = history.brush_count();
        (
            history.revision(),
            count,
            write(&path, fingerprint, &history),
        )
    })
}

/// Writes `history`'s compacted log and steps; returns the edits and bytes
/// written.
fn write(
    path: &std::path::Path,
    fingerprint: String,
    history: &EditHistory,
) -> Result<(usize, usize), PersistError> {
    let (edits, undo) = history.saved();
    let written = edits.len();
    let bytes = file::encode(&SaveData {
        fingerprint,
        edits,
        undo,
    });
    file::write_atomic(path, &bytes)?;
    Ok((written, bytes.len()))
}

/// Collects finished saves and starts a new one once a volume's log has been
/// still for its `autosave_after`.
fn autosave(
    time: Res<Time<Real>>,
    clock: Res<MainThreadClock>,
    mut volumes: Query<(Entity, &KdSave, &VolumeState, &mut SaveState)>,
    mut saved: MessageWriter<EditsSaved>,
    mut failed: MessageWriter<PersistFailed>,
) {
    let _time = clock.measure();
    let now = time.elapsed();
    for (volume, save, state, mut status) in &mut volumes {
        if let Some(task) = status.task.as_mut() {
            let Some((revision, count, result)) = check_ready(task) else {
                continue;
            };
            status.task = None;
            report(
                volume,
                save,
                &mut status,
                (revision, count),
                result,
                &mut saved,
                &mut failed,
            );
        }
        let revision = state.history().revision();
        if revision != status.changed.0 {
            status.changed = (revision, now);
        }
        let Some(after) = save.autosave_after else {
            continue;
        };
        if status.refused || revision == status.saved || now < status.changed.1 + after {
            continue;
        }
        status.task = Some(spawn_save(save, state.history().clone()));
    }
}

/// Records a finished save.
fn report(
    volume: Entity,
    save: &KdSave,
    status: &mut SaveState,
    (revision, count): (u64, usize),
    result: Result<(usize, usize), PersistError>,
    saved: &mut MessageWriter<EditsSaved>,
    failed: &mut MessageWriter<PersistFailed>,
) {
    match result {
        Ok((written, bytes)) => {
            status.saved = revision;
            status.saved_edits = count;
            saved.write(EditsSaved {
                volume,
                path: save.path.clone(),
                edits: count,
                written,
                bytes,
            });
        }
        Err(e) => {
            // Tried again after the next edit (or on exit).
            warn!("KdVolume {volume}: {e}");
            failed.write(PersistFailed {
                volume,
                error: e.to_string(),
            });
        }
    }
}

/// On [`AppExit`], waits for saves in flight and saves every log with unsaved
/// edits, on this thread (the app is about to stop).
fn save_on_exit(
    mut exit: MessageReader<AppExit>,
    mut volumes: Query<(Entity, &KdSave, &VolumeState, &mut SaveState)>,
    mut saved: MessageWriter<EditsSaved>,
    mut failed: MessageWriter<PersistFailed>,
) {
    if exit.read().last().is_none() {
        return;
    }
    for (volume, save, state, mut status) in &mut volumes {
        if let Some(task) = status.task.take() {
            let (revision, count, result) = block_on(task);
            report(
                volume,
                save,
                &mut status,
                (revision, count),
                result,
                &mut saved,
                &mut failed,
            );
        }
        let history = state.history();
        if status.refused || history.revision() == status.saved {
            continue;
        }
        let result = write(&save.path, save.fingerprint.clone(), history);
        report(
            volume,
            save,
            &mut status,
            (history.revision(), history.brush_count()),
            result,
            &mut saved,
            &mut failed,
        );
    }
}
