//! Loading real inputs: raw and NIfTI-1 volumes, OBJ and PLY triangle meshes.

pub mod input;
pub mod mesh;
pub mod volume;

use crate::error::Error;

/// Reads a whole file, naming it in the error.
pub(crate) fn read(path: &std::path::Path) -> Result<Vec<u8>, Error> {
    std::fs::read(path).map_err(|e| Error::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    })
}

pub(crate) fn bad(path: &std::path::Path, message: impl Into<String>) -> Error {
    Error::Input {
        path: path.display().to_string(),
        message: message.into(),
    }
}
