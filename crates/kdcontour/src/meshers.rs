//! Every mesher in the crate behind one call, for side-by-side comparison on the
//! same Hermite data.

use crate::error::Result;
use crate::field::Field;
use crate::grid::Grid;
use crate::hermite::Hermite;
use crate::mesh::IndexedMesh;
use crate::pipeline::{self, Cells};
use crate::settings::{Partition, Settings};
use std::time::Instant;

/// A meshing method.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Mesher {
    /// Classic Marching Cubes (primal, one vertex per edge crossing).
    MarchingCubes,
    /// Uniform Dual Marching Cubes (one vertex per cell component).
    UniformDmc,
    /// The octree baseline: same machinery, midpoint splits.
    Octree,
    /// The discrete k-d tree.
    KdTree,
    /// Adaptive Skeleton Climbing: size-maximal simple boxes
    /// ([`crate::skeleton_climbing`]).
    SkeletonClimbing,
    /// Boada and Navazo's octree of coplanar Discretized Marching Cubes polygons
    /// ([`crate::discrete_planes`]).
    DiscretePlanes,
}

impl Mesher {
    /// All meshers, coarsest idea first.
    pub const ALL: [Mesher; 6] = [
        Mesher::MarchingCubes,
        Mesher::UniformDmc,
        Mesher::Octree,
        Mesher::KdTree,
        Mesher::SkeletonClimbing,
        Mesher::DiscretePlanes,
    ];

    /// The name used in reports and JSON (`marching-cubes`, `dmc`, `octree`,
    /// `kdtree`, `skeleton-climbing`, `discrete-planes`).
    pub fn name(self) -> &'static str {
        match self {
            Mesher::MarchingCubes => "marching-cubes",
            Mesher::UniformDmc => "dmc",
            Mesher::Octree => "octree",
            Mesher::KdTree => "kdtree",
            Mesher::SkeletonClimbing => "skeleton-climbing",
            Mesher::DiscretePlanes => "discrete-planes",
        }
    }

    /// The mesher called `name` (see [`Mesher::name`]).
    pub fn parse(name: &str) -> Option<Mesher> {
        Mesher::ALL.into_iter().find(|m| m.name() == name)
    }

    /// Whether the threshold matters (skeleton climbing reads it as a box size
    /// limit: [`crate::skeleton_climbing::block_for_threshold`]).
    pub fn adaptive(self) -> bool {
        matches!(
            self,
            Mesher::Octree | Mesher::KdTree | Mesher::SkeletonClimbing
        )
    }
}

/// Times of one run, in milliseconds.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Timings {
    /// Sampling and Hermite data.
    pub sample_ms: f64,
    /// Building the tree (0 for uniform meshers).
    pub build_ms: f64,
    /// Making polygons.
    pub contour_ms: f64,
}

impl Timings {
    /// Sum of the stages.
    pub fn total_ms(&self) -> f64 {
        self.sample_ms + self.build_ms + self.contour_ms
    }
}

/// Samples once and keeps the Hermite data for several meshers.
pub struct Sampled<'a> {
    /// The Hermite data.
    pub hermite: Hermite,
    /// The field it was sampled from.
    pub field: &'a dyn Field,
    /// How long sampling took (ms).
    pub sample_ms: f64,
}

/// Samples `field` on `grid` (see [`Hermite::from_field`]).
pub fn sample<'a>(field: &'a dyn Field, grid: &Grid, settings: &Settings) -> Result<Sampled<'a>> {
    settings.run(|| {
        let t0 = Instant::now();
        let hermite = pipeline::hermite(field, grid, settings)?;
        Ok(Sampled {
            hermite,
            field,
            sample_ms: t0.elapsed().as_secs_f64() * 1e3,
        })
    })?
}

/// Meshes sampled data with `mesher` at `threshold` (ignored by uniform meshers;
/// skeleton climbing maps it to a block size with
/// [`crate::skeleton_climbing::block_for_threshold`]).
pub fn run(
    mesher: Mesher,
    s: &Sampled,
    threshold: f32,
    settings: &Settings,
) -> Result<(IndexedMesh, Timings)> {
    settings.run(|| {
        let mut t = Timings {
            sample_ms: s.sample_ms,
            ..Default::default()
        };
        let t0 = Instant::now();
        let mesh = match mesher {
            Mesher::MarchingCubes => crate::mc::marching_cubes(&s.hermite),
            Mesher::UniformDmc => crate::dmc::uniform_dmc(&s.hermite),
            Mesher::SkeletonClimbing => {
                crate::skeleton_climbing::at_threshold(&s.hermite, threshold)
            }
            Mesher::DiscretePlanes => crate::discrete_planes::discrete_planes(&s.hermite),
            Mesher::Octree | Mesher::KdTree => {
                let partition = if mesher == Mesher::Octree {
                    Partition::Octree
                } else {
                    Partition::KdTree
                };
                // One mesh: the tree is built for this cut alone.
                let settings = Settings {
                    partition,
                    ..settings.for_one_cut(threshold)
                };
                let tree = pipeline::tree(&s.hermite, s.field, &settings, Cells::All);
                t.build_ms = t0.elapsed().as_secs_f64() * 1e3;
                let t1 = Instant::now();
                let m = tree.mesh(threshold);
                t.contour_ms = t1.elapsed().as_secs_f64() * 1e3;
                return (m, t);
            }
        };
        t.contour_ms = t0.elapsed().as_secs_f64() * 1e3;
        (mesh, t)
    })
}
