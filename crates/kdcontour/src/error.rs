//! The one error type of the core: every failure a user can cause, with a message
//! that says what to change.

use glam::Vec3;
use std::fmt;

/// Everything that can go wrong when sampling, building or loading.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum Error {
    /// The grid has no cells, a non-positive or non-finite cell size, or a
    /// non-finite origin.
    #[error("invalid grid: {0}")]
    InvalidGrid(String),
    /// The field returned NaN or infinity at a sample point.
    #[error("{}", non_finite(position, *value, cause.as_deref()))]
    NonFiniteSample {
        /// Where the field was evaluated (world units).
        position: Vec3,
        /// What it returned.
        value: f32,
        /// Why, when the field can tell ([`crate::Field::explain_non_finite`]):
        /// e.g. the scene node whose noise was evaluated out of its reach.
        cause: Option<String>,
    },
    /// The grid needs more memory than the configured budget allows.
    #[error(
        "a grid of {cells} cells needs about {needed_size} ({needed} bytes), over the \
         memory budget of {budget_size}; lower the resolution, mesh in chunks, or raise \
         the budget (`--memory-budget` on the command line, `Settings::memory_budget` \
         in code)",
        needed_size = Size(*needed), budget_size = Size(*budget)
    )]
    MemoryBudget {
        /// Cells in the grid.
        cells: u64,
        /// Estimated bytes the build needs.
        needed: u64,
        /// The configured budget.
        budget: u64,
    },
    /// Something other than one grid (a volume after inflation, a mesh file, a
    /// whole world of chunks) needs more memory than the budget allows.
    #[error(
        "{what} needs about {needed_size} ({needed} bytes), over the memory budget of \
         {budget_size}; use a smaller input or raise the budget (`--memory-budget` on \
         the command line, `Settings::memory_budget` in code)",
        needed_size = Size(*needed), budget_size = Size(*budget)
    )]
    TooLarge {
        /// What would be too large, e.g. `a volume of 2048x2048x2048 voxels`.
        what: String,
        /// Estimated bytes it needs.
        needed: u64,
        /// The configured budget.
        budget: u64,
    },
    /// Within the memory budget, but more than this machine can give the
    /// process now (its free memory and swap, its address-space limit or its
    /// control group's limit): the allocation would abort the process.
    #[error(
        "{what} needs about {needed_size} ({needed} bytes), more than this machine can \
         give now ({available_size}: {limit}); use a smaller input, or free memory",
        needed_size = Size(*needed), available_size = Size(*available)
    )]
    MachineMemory {
        /// What would be too large.
        what: String,
        /// Estimated bytes it needs.
        needed: u64,
        /// Bytes the machine can give.
        available: u64,
        /// What sets that limit, in a user's words.
        limit: &'static str,
    },
    /// The system refused the memory for a buffer whose size comes from the
    /// input (what the budget and machine checks let through, but the
    /// allocator could not give): an error instead of an aborted process.
    #[error(
        "{what} needs {needed_size} ({needed} bytes) and the system would not \
         allocate it; use a smaller input, or free memory",
        needed_size = Size(*needed)
    )]
    Allocation {
        /// What the buffer holds.
        what: String,
        /// Bytes asked for (`u64::MAX` when more than the address space).
        needed: u64,
    },
    /// A setting is outside its allowed range.
    #[error("invalid setting `{name}`: {reason}")]
    InvalidSetting {
        /// The setting's name.
        name: &'static str,
        /// What is wrong and what is allowed.
        reason: String,
    },
    /// A scene file could not be parsed or describes an impossible scene.
    #[error("{0}")]
    Scene(#[from] SceneError),
    /// An input file (volume or mesh) is malformed or does not match what was said
    /// about it.
    #[error("{path}: {message}")]
    Input {
        /// The file.
        path: String,
        /// What is wrong, and where in the file.
        message: String,
    },
    /// Reading or writing a file failed.
    #[error("{path}: {message}")]
    Io {
        /// The file.
        path: String,
        /// The operating system's message.
        message: String,
    },
}

/// A scene-file problem, located by line and column where the text says where.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum SceneError {
    /// The JSON is malformed or does not match the schema (unknown primitive, missing
    /// field, wrong type).
    #[error("scene file line {line}, column {column}: {message}")]
    Syntax {
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What serde found.
        message: String,
    },
    /// The JSON parses but a value is impossible (a negative radius, an empty union).
    #[error("scene node `{path}`: {message}")]
    Semantic {
        /// Where in the tree, e.g. `root.children[2].radius`.
        path: String,
        /// What is wrong.
        message: String,
    },
    /// A built-in scene name that does not exist.
    #[error("unknown scene `{name}`; built-in scenes are: {known}")]
    UnknownScene {
        /// The name asked for.
        name: String,
        /// The names that exist.
        known: String,
    },
}

/// Result alias for the core.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// The message of [`Error::NonFiniteSample`]: the field's own explanation when it
/// has one, else the usual causes.
fn non_finite(position: &Vec3, value: f32, cause: Option<&str>) -> String {
    let at = format!(
        "the field returned {value} at ({}, {}, {})",
        position.x, position.y, position.z
    );
    match cause {
        Some(cause) => format!("{at}: {cause}"),
        None => format!(
            "{at}; fields must be finite everywhere in the volume (check divisions by \
             zero, sqrt of negatives, an unbounded noise amplitude, or noise evaluated \
             too far from its origin)"
        ),
    }
}

/// Bytes as people read them: `4 GiB`, `1.5 MiB`, `300 bytes` (binary units,
/// three significant figures; whole numbers print without a fraction).
pub struct Size(pub u64);

impl fmt::Display for Size {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        const UNITS: [&str; 6] = ["KiB", "MiB", "GiB", "TiB", "PiB", "EiB"];
        if self.0 < 1024 {
            return write!(f, "{} bytes", self.0);
        }
        let mut v = self.0 as f64;
        let mut unit = "bytes";
        for u in UNITS {
            if v < 1024.0 {
                break;
            }
            v /= 1024.0;
            unit = u;
        }
        if v.fract() == 0.0 {
            write!(f, "{v} {unit}")
        } else if v < 10.0 {
            write!(f, "{v:.2} {unit}")
        } else if v < 100.0 {
            write!(f, "{v:.1} {unit}")
        } else {
            write!(f, "{v:.0} {unit}")
        }
    }
}
