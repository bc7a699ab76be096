//! A chunk's meshing work, as the task subsystem tracks it: what is wanted,
//! what runs, and the finished mesh waiting for upload. Only the task
//! subsystem changes it directly; the others ask through its methods.

use crate::mesh::ReadyMesh;
use bevy::tasks::Task;
use kdcontour::world::{BuiltChunk, ChunkBuild};

/// A finished build.
pub(crate) struct BuildOut {
    pub(crate) generation: u64,
    pub(crate) job: ChunkBuild,
    pub(crate) result: Result<BuiltChunk, String>,
    pub(crate) ms: f64,
}

/// A finished extraction.
pub(crate) struct ExtractOut {
    pub(crate) stamp: u64,
    /// The mesh, or why the extraction failed.
    pub(crate) mesh: Result<ReadyMesh, String>,
    pub(crate) ms: f64,
}

/// One chunk's builds and extractions.
#[derive(Default)]
pub(crate) struct ChunkWork {
    /// Bumped by every build request; a build result from an older generation
    /// is dropped.
    pub(super) build_gen: u64,
    /// Bumped by every extraction request; an older extraction is dropped.
    pub(super) extract_stamp: u64,
    /// A build is wanted.
    pub(super) need_build: bool,
    /// An extraction (interior and owned seams) is wanted.
    pub(super) need_extract: bool,
    /// The running build (dropping it cancels it).
    pub(super) building: Option<Task<BuildOut>>,
    /// The running extraction (dropping it cancels it).
    pub(super) extracting: Option<Task<ExtractOut>>,
    /// A finished extraction waiting for upload.
    pub(super) ready: Option<ReadyMesh>,
}

impl ChunkWork {
    /// Asks for a new build (a running one's result will be dropped).
    pub(crate) fn request_build(&mut self) {
        self.build_gen += 1;
        self.need_build = true;
    }

    /// Asks for a new extraction (a running one's result will be dropped).
    pub(crate) fn request_extract(&mut self) {
        self.extract_stamp += 1;
        self.need_extract = true;
    }

    /// A build is wanted or running: the chunk's tree is about to change.
    pub(crate) fn build_pending(&self) -> bool {
        self.need_build || self.building.is_some()
    }

    /// No build or extraction wanted or running (a finished mesh may wait).
    pub(crate) fn idle(&self) -> bool {
        !self.need_build
            && !self.need_extract
            && self.building.is_none()
            && self.extracting.is_none()
    }

    /// No work wanted, running or waiting for upload.
    pub(crate) fn is_settled(&self) -> bool {
        self.idle() && self.ready.is_none()
    }

    /// Builds and extractions running (0 to 2).
    pub(crate) fn running(&self) -> usize {
        self.building.is_some() as usize + self.extracting.is_some() as usize
    }

    /// Builds and extractions wanted but not started (0 to 2).
    pub(crate) fn queued(&self) -> usize {
        self.need_build as usize + self.need_extract as usize
    }

    /// Whether a finished mesh waits for upload.
    pub(crate) fn has_ready(&self) -> bool {
        self.ready.is_some()
    }

    /// The finished mesh waiting for upload, taken.
    pub(crate) fn take_ready(&mut self) -> Option<ReadyMesh> {
        self.ready.take()
    }

    /// Drops a finished mesh that must not be shown (a level change re-extracts).
    pub(crate) fn discard_ready(&mut self) {
        self.ready = None;
    }
}
