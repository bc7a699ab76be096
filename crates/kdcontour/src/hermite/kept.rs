//! Crossings kept from one build of a grid for the next ([`KeptCrossings`]): a
//! world's chunk rebuilt because a neighbour changed level has the same field
//! and grid, and its samples change only where the level rules conform them
//! (along the faces toward its neighbours), so most of its edges have the same
//! two samples as before, and the same crossing. When every corner keeps its
//! sign and every crossing edge its two samples, the whole build is the one
//! before ([`KeptCrossings::unchanged`]).

use super::crossing::Crossing;
use crate::error::Result;
use crate::grid::Grid;
use crate::settings::{Budget, Settings};
use glam::Vec3;

/// The crossings one build of a grid found, by edge, with the two samples
/// each was found from. A later build of the same grid, field and settings
/// takes an edge's crossing from here when both its samples are bitwise the
/// same, instead of searching the field again: the crossing is a function of
/// exactly those (the field, the edge and its two samples, the root search's
/// iterations and whether materials are read), so the build is the one a
/// search would give.
///
/// Build them with [`super::Hermite::reusing`]; they must come from the
/// field the next build is given (an edit drops them with the samples).
#[derive(Clone, Debug, Default)]
pub struct KeptCrossings {
    /// The grid they were found on.
    grid: Option<Grid>,
    /// The settings that shape a build ([`shaping`]), and whether materials
    /// were read.
    settings: Settings,
    borders: bool,
    /// The corners' signs they were found with (the Hermite data's bits).
    outside: Vec<u64>,
    /// Edge keys (`3 * corner index + axis`), sorted.
    keys: Vec<u32>,
    /// Per key: the crossing and its edge's two samples.
    found: Vec<KeptCrossing>,
}

/// One kept crossing (see [`KeptCrossings`]).
#[derive(Clone, Copy, Debug)]
struct KeptCrossing {
    /// The samples at the edge's low and high ends, bits as sampled.
    ends: [u32; 2],
    /// Where on the edge, from its low end (grid units).
    t: f32,
    normal: Vec3,
    material: u16,
    forced: bool,
}

impl KeptCrossings {
    /// Keeps the crossings of `found` (each with its edge's key and samples),
    /// found on `grid` with `settings`, materials read when `borders`, and the
    /// corners' signs `outside`.
    pub(super) fn keep(
        grid: &Grid,
        settings: &Settings,
        borders: bool,
        outside: Vec<u64>,
        found: &[Result<Vec<Crossing>>],
    ) -> Self {
        let mut all: Vec<(u32, KeptCrossing)> = found
            .iter()
            .flat_map(|run| run.as_deref().unwrap_or(&[]))
            .filter_map(|c| {
                let (key, ends, t) = c.kept?;
                Some((
                    key,
                    KeptCrossing {
                        ends,
                        t,
                        normal: c.normal,
                        material: c.material,
                        forced: c.forced,
                    },
                ))
            })
            .collect();
        all.sort_unstable_by_key(|e| e.0);
        KeptCrossings {
            grid: Some(*grid),
            settings: shaping(settings),
            borders,
            outside,
            keys: all.iter().map(|e| e.0).collect(),
            found: all.into_iter().map(|e| e.1).collect(),
        }
    }

    /// Whether these were found on `grid` with settings that shape a build as
    /// `settings` do, materials read when `borders`.
    pub(super) fn fits(&self, grid: &Grid, settings: &Settings, borders: bool) -> bool {
        self.shaped_alike(grid, settings) && self.borders == borders
    }

    /// Whether they were found on `grid` with settings that shape a build as
    /// `settings` do. (Whether materials were read follows from the settings
    /// and the field, which is the same field by contract.)
    fn shaped_alike(&self, grid: &Grid, settings: &Settings) -> bool {
        self.grid.as_ref() == Some(grid) && self.settings == shaping(settings)
    }

    /// Whether a build of `grid` from `values` with `settings` is the build
    /// these were kept from: they fit, every corner has the sign it had, and
    /// every edge that crosses has the two samples it had. The Hermite data
    /// reads the samples only through the corners' signs and the crossings,
    /// and a crossing is a function of its edge's two samples, so the data,
    /// and the tree built on it, are the same. (Equal signs at every corner
    /// make the crossing edges the same ones.)
    pub fn unchanged(&self, grid: &Grid, values: &[f32], settings: &Settings) -> bool {
        // Grids too large for 32-bit edge keys keep no crossings (see
        // `crossings`), so their ends cannot be compared.
        let keyed = 3 * grid.corner_count() <= u32::MAX as u64;
        if !keyed
            || !self.shaped_alike(grid, settings)
            || values.len() as u64 != grid.corner_count()
        {
            return false;
        }
        let c = grid.corners();
        let stride = [1usize, c.x as usize, c.x as usize * c.y as usize];
        let same_ends = self.keys.iter().zip(&self.found).all(|(&key, k)| {
            let (i, a) = ((key / 3) as usize, (key % 3) as usize);
            let j = i + stride[a];
            j < values.len() && [values[i].to_bits(), values[j].to_bits()] == k.ends
        });
        same_ends && super::sign_bits(values, c) == self.outside
    }

    /// The crossing kept for edge `key` when its samples were `ends` (bits):
    /// its place along the edge, normal, material and whether it was forced.
    pub(super) fn get(&self, key: u32, ends: [u32; 2]) -> Option<(f32, Vec3, u16, bool)> {
        let i = self.keys.binary_search(&key).ok()?;
        let k = &self.found[i];
        (k.ends == ends).then_some((k.t, k.normal, k.material, k.forced))
    }

    /// How many crossings are kept.
    pub fn len(&self) -> usize {
        self.keys.len()
    }

    /// Whether none are.
    pub fn is_empty(&self) -> bool {
        self.keys.is_empty()
    }

    /// Bytes they hold.
    pub fn retained_bytes(&self) -> usize {
        self.keys.capacity() * std::mem::size_of::<u32>()
            + self.found.capacity() * std::mem::size_of::<KeptCrossing>()
            + self.outside.capacity() * std::mem::size_of::<u64>()
    }
}

/// `settings` with what does not change a build's result (its threads and
/// memory budget) set to the defaults.
fn shaping(settings: &Settings) -> Settings {
    Settings {
        threads: 0,
        memory_budget: Budget::DEFAULT,
        ..settings.clone()
    }
}
