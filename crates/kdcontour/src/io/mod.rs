//! Loading real inputs: raw and NIfTI-1 volumes, OBJ and PLY triangle meshes.
//!
//! Every loader reads at most what the memory budget allows (see
//! [`crate::settings::DEFAULT_MEMORY_BUDGET`]) and refuses a header whose sizes
//! cannot fit in the file before it allocates; every error names the file.

pub mod input;
pub mod mesh;
pub mod nifti;
pub mod probe;
pub mod volume;

use crate::error::Error;
use std::io::Read;
use std::path::Path;

/// The longest a quoted value from an input is echoed in a message (characters).
pub const MAX_QUOTED: usize = 60;

/// Reads at most `limit` bytes of `path`, naming it in the error; a longer file
/// (or an endless one such as `/dev/zero`) is refused after `limit + 1` bytes, with
/// `what` saying what the limit is for.
pub(crate) fn read_limited(path: &Path, limit: u64, what: &str) -> Result<Vec<u8>, Error> {
    let file = std::fs::File::open(path).map_err(|e| io_error(path, e))?;
    let mut bytes = Vec::new();
    file.take(limit.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(|e| io_error(path, e))?;
    if bytes.len() as u64 > limit {
        return Err(bad(
            path,
            format!("the file is longer than {limit} bytes, the most {what}"),
        ));
    }
    Ok(bytes)
}

/// An I/O error on `path`.
pub(crate) fn io_error(path: &Path, e: std::io::Error) -> Error {
    Error::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

pub(crate) fn bad(path: &Path, message: impl Into<String>) -> Error {
    Error::Input {
        path: path.display().to_string(),
        message: message.into(),
    }
}

/// `s` cut to [`MAX_QUOTED`] characters (with the full length said), for echoing
/// a value from an input in a message.
pub fn cut(s: &str) -> String {
    if s.chars().count() <= MAX_QUOTED {
        return s.to_string();
    }
    let head: String = s.chars().take(MAX_QUOTED).collect();
    format!("{head}... ({} bytes in all)", s.len())
}

/// `message` with every backtick- or double-quoted value longer than
/// [`MAX_QUOTED`] cut (see [`cut`]): serde echoes unknown names and mistyped
/// strings whole.
pub fn cut_quoted(message: &str) -> String {
    ['`', '"'].iter().fold(message.to_string(), |m, &q| {
        m.split(q)
            .enumerate()
            .map(|(i, part)| {
                if i % 2 == 1 {
                    cut(part)
                } else {
                    part.to_string()
                }
            })
            .collect::<Vec<_>>()
            .join(&q.to_string())
    })
}

/// The longest file name (bytes) the common file systems take (ext4, XFS,
/// APFS, NTFS in UTF-16 units).
pub const NAME_MAX: usize = 255;

/// A hidden temporary name for a file named `name`: `.{name}.{tag}`, with
/// `name` cut (on a character boundary) so the whole is at most [`NAME_MAX`]
/// bytes: a legal 255-byte name has a legal temporary name too.
pub fn temporary_name(name: &str, tag: &str) -> String {
    let room = NAME_MAX.saturating_sub(2 + tag.len());
    let mut end = name.len().min(room);
    while !name.is_char_boundary(end) {
        end -= 1;
    }
    format!(".{}.{tag}", &name[..end])
}

/// Writes `path` through `write` into a temporary file in the same directory,
/// then renames it over `path`: a failed write never truncates an existing file.
pub fn write_atomic(
    path: &Path,
    write: impl FnOnce(&mut std::io::BufWriter<std::fs::File>) -> std::io::Result<()>,
) -> Result<(), Error> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let name = path.file_name().ok_or_else(|| Error::Io {
        path: path.display().to_string(),
        message: "not a file name".into(),
    })?;
    // Unique per process and per call, so concurrent writers never share one.
    static CALLS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let call = CALLS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let tmp = dir.join(temporary_name(
        &name.to_string_lossy(),
        &format!("{}-{call}.tmp", std::process::id()),
    ));
    let result = std::fs::File::create(&tmp).and_then(|f| {
        let mut w = std::io::BufWriter::new(f);
        write(&mut w)?;
        let f = w.into_inner().map_err(|e| e.into_error())?;
        f.sync_all()
    });
    match result.and_then(|()| std::fs::rename(&tmp, path)) {
        Ok(()) => Ok(()),
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(io_error(path, e))
        }
    }
}

/// Checks, before any work, that `path` can be written: its directory exists and
/// takes a new file (probed with a temporary file, removed at once). The file
/// itself is not touched.
pub fn check_writable(path: &Path) -> Result<(), Error> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if path.is_dir() {
        return Err(Error::Io {
            path: path.display().to_string(),
            message: "is a directory; give a file name".into(),
        });
    }
    if !dir.is_dir() {
        return Err(Error::Io {
            path: path.display().to_string(),
            message: format!("the directory {} does not exist", dir.display()),
        });
    }
    let probe = dir.join(format!(".kdcontour-probe.{}.tmp", std::process::id()));
    std::fs::File::create(&probe).map_err(|e| Error::Io {
        path: path.display().to_string(),
        message: format!("cannot write in {}: {e}", dir.display()),
    })?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}
