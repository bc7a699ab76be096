//! The save file of one volume's edits, and writing it so that a crash or a full
//! disk never damages the save already there.
//!
//! ## Format (version 1)
//! | bytes | what |
//! |---|---|
//! | 8 | magic `KDEDITS\0` |
//! | 4 | format version, little-endian `u32` |
//! | 8 | payload length, little-endian `u64` |
//! | 4 | CRC-32 of the payload, little-endian `u32` |
//! | n | the payload: [`SaveData`] as CBOR (the edits and their undo steps) |
//!
//! CBOR through `ciborium`: compact and binary (a brush is about 40 bytes, a
//! third of its JSON), self-describing (a later version can still read this
//! header and say what it found), serde-driven (the edit log already derives
//! serde), and already in the build through criterion. The checksum catches a
//! file damaged after it was written (a torn copy, a bad disk): such a file is
//! refused, never half-read.
//!
//! ## Writing
//! [`write_atomic`] writes a temporary file beside the save, flushes it to disk
//! (`fsync`), renames it over the save and flushes the directory. A process
//! killed at any point leaves either the old save or the new one, whole.

use kdcontour::edit::{Brush, UndoSteps};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The first bytes of every save file.
pub const MAGIC: [u8; 8] = *b"KDEDITS\0";
/// The format version this build writes and reads.
pub const VERSION: u32 = 1;
/// Bytes before the payload.
pub const HEADER_BYTES: usize = 8 + 4 + 8 + 4;
/// The largest save file read (1 GiB, about 25 million edits): a larger or
/// lying header is refused before anything is allocated.
pub const MAX_FILE_BYTES: u64 = 1 << 30;

/// What a save holds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SaveData {
    /// What the edits were made on: the base field's description (see
    /// [`super::KdSave::fingerprint`]); a save for another field is refused.
    pub fingerprint: String,
    /// The edit log, oldest first: the applied edits, then the undone ones
    /// (compacted: see [`kdcontour::edit::EditHistory::saved`]).
    pub edits: Vec<Brush>,
    /// How the log divides into undo steps, and how many are applied (saves
    /// written before undo existed have none: all their edits are applied and
    /// none can be undone).
    #[serde(default)]
    pub undo: UndoSteps,
}

/// Why a save could not be read or written; each says what to do.
#[derive(Debug)]
pub enum PersistError {
    /// The file system refused (`action` says what was being done).
    Io {
        /// The file.
        path: PathBuf,
        /// What was being done.
        action: &'static str,
        /// The system's error.
        source: std::io::Error,
    },
    /// The file does not start with [`MAGIC`].
    NotASave {
        /// The file.
        path: PathBuf,
    },
    /// Written by a newer (or unknown) format version.
    Version {
        /// The file.
        path: PathBuf,
        /// The version found.
        found: u32,
    },
    /// The header promises more or fewer bytes than the file has, or more than
    /// [`MAX_FILE_BYTES`].
    Length {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// The payload does not match its checksum or does not decode.
    Corrupt {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// The save was made for another base field.
    OtherField {
        /// The file.
        path: PathBuf,
        /// The field it was made for.
        saved: String,
        /// The volume's field.
        current: String,
    },
    /// The saved edits do not apply to the field (a brush the core refuses).
    Replay {
        /// The file.
        path: PathBuf,
        /// The core's error.
        reason: String,
    },
}

impl fmt::Display for PersistError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let keep = "the file was left as it is and autosave is off for this volume";
        match self {
            PersistError::Io {
                path,
                action,
                source,
            } => write!(
                f,
                "{}: {action} failed: {source} (check the path, its permissions and \
                 the free space; an existing save is never damaged by a failed write)",
                path.display()
            ),
            PersistError::NotASave { path } => write!(
                f,
                "{} is not a bevy_kdcontour save (it does not start with `KDEDITS`); \
                 {keep}: point KdSave at another file, or move this one away",
                path.display()
            ),
            PersistError::Version { path, found } => write!(
                f,
                "{} was written in save format {found}, and this build reads format \
                 {VERSION}; {keep}: open it with the version that wrote it",
                path.display()
            ),
            PersistError::Length { path, reason } | PersistError::Corrupt { path, reason } => {
                write!(
                    f,
                    "{} is damaged: {reason}; {keep}: restore it from a backup or \
                     move it away to start over",
                    path.display()
                )
            }
            PersistError::OtherField {
                path,
                saved,
                current,
            } => write!(
                f,
                "{} holds edits made for another field (saved for `{saved}`, this \
                 volume's field is `{current}`); its edits were not loaded and {keep}: \
                 load it with the field it was made for, or move it away to start over",
                path.display()
            ),
            PersistError::Replay { path, reason } => write!(
                f,
                "{}: a saved edit does not apply: {reason}; {keep}",
                path.display()
            ),
        }
    }
}

impl std::error::Error for PersistError {}

/// The bytes of a save file holding `data`.
pub fn encode(data: &SaveData) -> Vec<u8> {
    let mut payload = Vec::new();
    ciborium::into_writer(data, &mut payload).expect("writing CBOR into memory cannot fail");
    let mut out = Vec::with_capacity(HEADER_BYTES + payload.len());
    out.extend_from_slice(&MAGIC);
    out.extend_from_slice(&VERSION.to_le_bytes());
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    out.extend_from_slice(&crc32fast::hash(&payload).to_le_bytes());
    out.extend_from_slice(&payload);
    out
}

/// Reads a save file's bytes (`path` names it in errors).
pub fn decode(path: &Path, bytes: &[u8]) -> Result<SaveData, PersistError> {
    let path = path.to_path_buf();
    if bytes.len() < MAGIC.len() || bytes[..MAGIC.len()] != MAGIC {
        return Err(PersistError::NotASave { path });
    }
    if bytes.len() < HEADER_BYTES {
        return Err(PersistError::Length {
            path,
            reason: format!(
                "{} bytes, shorter than the {HEADER_BYTES}-byte header",
                bytes.len()
            ),
        });
    }
    let word = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes"));
    let version = word(8);
    if version != VERSION {
        return Err(PersistError::Version {
            path,
            found: version,
        });
    }
    let length = u64::from_le_bytes(bytes[12..20].try_into().expect("8 bytes"));
    let have = (bytes.len() - HEADER_BYTES) as u64;
    if length != have {
        return Err(PersistError::Length {
            path,
            reason: format!("the header promises {length} bytes of edits, the file has {have}"),
        });
    }
    let payload = &bytes[HEADER_BYTES..];
    let (want, got) = (word(20), crc32fast::hash(payload));
    if want != got {
        return Err(PersistError::Corrupt {
            path,
            reason: format!("checksum {got:08x} where the header says {want:08x}"),
        });
    }
    ciborium::from_reader(payload).map_err(|e| PersistError::Corrupt {
        path,
        reason: format!("the edits do not decode: {e}"),
    })
}

/// The save at `path`, or `None` when there is no file. A file larger than
/// `limit` bytes is refused before it is read.
pub fn read(path: &Path, limit: u64) -> Result<Option<SaveData>, PersistError> {
    let io = |action, source| PersistError::Io {
        path: path.to_path_buf(),
        action,
        source,
    };
    let size = match std::fs::metadata(path) {
        Ok(m) => m.len(),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(io("reading the save's size", e)),
    };
    if size > limit {
        return Err(PersistError::Length {
            path: path.to_path_buf(),
            reason: format!("{size} bytes, more than the {limit} bytes a save may hold"),
        });
    }
    let bytes = std::fs::read(path).map_err(|e| io("reading the save", e))?;
    decode(path, &bytes).map(Some)
}

/// Writes `bytes` to `path` atomically (see the module docs). On failure the
/// temporary file is removed and `path` is untouched.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), PersistError> {
    let io = |action, source| PersistError::Io {
        path: path.to_path_buf(),
        action,
        source,
    };
    let name = path
        .file_name()
        .ok_or_else(|| {
            io(
                "naming the save",
                std::io::Error::new(
                    std::io::ErrorKind::InvalidInput,
                    "the path has no file name",
                ),
            )
        })?
        .to_string_lossy();
    let tmp = path.with_file_name(kdcontour::io::temporary_name(&name, "tmp"));
    let written = (|| {
        let mut f =
            std::fs::File::create(&tmp).map_err(|e| io("creating the temporary file", e))?;
        f.write_all(bytes)
            .map_err(|e| io("writing the temporary file", e))?;
        f.sync_all()
            .map_err(|e| io("flushing the temporary file to disk", e))?;
        std::fs::rename(&tmp, path).map_err(|e| io("replacing the save", e))
    })();
    if written.is_err() {
        let _ = std::fs::remove_file(&tmp);
        return written;
    }
    // The rename itself is durable once the directory is flushed (where the
    // platform can open a directory; elsewhere the rename is still atomic).
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        if let Ok(d) = std::fs::File::open(dir) {
            let _ = d.sync_all();
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::math::Vec3;
    use kdcontour::edit::BrushOp;

    fn data(n: usize) -> SaveData {
        SaveData {
            fingerprint: "terrain seed 7".into(),
            edits: (0..n)
                .map(|i| Brush::sphere(Vec3::new(i as f32, 0.0, 0.0), 2.0, BrushOp::Subtract))
                .collect(),
            undo: UndoSteps::default(),
        }
    }

    #[test]
    fn a_save_round_trips_and_every_damage_is_named() {
        let p = Path::new("x.kdsave");
        let bytes = encode(&data(20));
        assert_eq!(decode(p, &bytes).unwrap(), data(20));
        let msg = |b: &[u8]| decode(p, b).unwrap_err().to_string();
        assert!(msg(b"hello").contains("not a bevy_kdcontour save"));
        assert!(msg(&bytes[..HEADER_BYTES - 1]).contains("shorter than the"));
        let mut v = bytes.clone();
        v[8] = 9;
        assert!(msg(&v).contains("save format 9"), "{}", msg(&v));
        assert!(msg(&bytes[..bytes.len() - 3]).contains("the header promises"));
        let mut lying = bytes.clone();
        lying[12..20].copy_from_slice(&u64::MAX.to_le_bytes());
        assert!(msg(&lying).contains("promises 18446744073709551615 bytes"));
        let mut flipped = bytes.clone();
        let last = flipped.len() - 1;
        flipped[last] ^= 1;
        assert!(msg(&flipped).contains("checksum"));
        // A payload with a good checksum that is not a save.
        let junk = [0xffu8; 16];
        let mut bad = bytes[..HEADER_BYTES].to_vec();
        bad[12..20].copy_from_slice(&16u64.to_le_bytes());
        bad[20..24].copy_from_slice(&crc32fast::hash(&junk).to_le_bytes());
        bad.extend_from_slice(&junk);
        assert!(msg(&bad).contains("do not decode"), "{}", msg(&bad));
    }

    #[test]
    fn a_save_with_the_longest_legal_name_writes() {
        let dir = std::env::temp_dir().join(format!("kdsave-long-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("w".repeat(kdcontour::io::NAME_MAX - 7) + ".kdsave");
        write_atomic(&path, &encode(&data(3))).unwrap();
        write_atomic(&path, &encode(&data(4))).unwrap();
        assert_eq!(read(&path, MAX_FILE_BYTES).unwrap(), Some(data(4)));
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_failed_write_leaves_the_old_save_whole() {
        let dir = std::env::temp_dir().join(format!("kdsave-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("world.kdsave");
        write_atomic(&path, &encode(&data(3))).unwrap();
        assert_eq!(read(&path, MAX_FILE_BYTES).unwrap(), Some(data(3)));
        // The temporary file cannot be created where a directory stands.
        std::fs::create_dir_all(dir.join(".world.kdsave.tmp")).unwrap();
        let e = write_atomic(&path, &encode(&data(5))).unwrap_err();
        assert!(e.to_string().contains("creating the temporary file"), "{e}");
        assert_eq!(read(&path, MAX_FILE_BYTES).unwrap(), Some(data(3)));
        std::fs::remove_dir(dir.join(".world.kdsave.tmp")).unwrap();
        // A file over the limit is refused before it is read; none is no save.
        let e = read(&path, 10).unwrap_err().to_string();
        assert!(e.contains("more than the 10 bytes"), "{e}");
        assert_eq!(
            read(&dir.join("none.kdsave"), MAX_FILE_BYTES).unwrap(),
            None
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
