//! A chunk's build ([`ChunkBuild`]): its samples (the field, except where the
//! chunk meets a chunk of another level: the rules are in [`super`]'s docs), then
//! the chunk pipeline ([`crate::pipeline`]).

use super::layout::{ChunkKey, Layout};
use crate::error::{Error, Result};
use crate::field::Field;
use crate::grid::Grid;
use crate::hermite::{self, Hermite, KeptCrossings};
use crate::kdtree::{Coarser, KdTree};
use crate::pipeline::{self, Cells};
use crate::Settings;
use glam::{IVec3, UVec3, Vec3};
use std::cell::Cell;
use std::sync::Arc;

/// What a chunk's samples depend on besides the field: the layout around it.
/// A chunk whose neighbourhood changes is rebuilt.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Neighbourhood {
    /// Per face (`2 * axis + side`): the chunks across are at another level.
    pub level_faces: [bool; 6],
    /// Per face: the chunks across are finer (a subset of `level_faces`).
    pub finer_faces: [bool; 6],
    /// The chunks one level coarser that touch it (face, edge or corner).
    pub coarser: Vec<ChunkKey>,
}

impl Neighbourhood {
    /// The neighbourhood of `key` in `layout`.
    pub fn of(layout: &Layout, key: &ChunkKey) -> Self {
        Neighbourhood {
            level_faces: layout.level_faces(key),
            finer_faces: layout.finer_faces(key),
            coarser: layout.coarser_touching(key),
        }
    }

    /// [`Neighbourhood::finer_faces`] as bits (`1 << face`), as
    /// [`Cells::Core`] takes them.
    pub fn finer_face_bits(&self) -> u8 {
        (0..6).fold(0, |acc, f| acc | (self.finer_faces[f] as u8) << f)
    }

    /// The faces toward coarser chunks (level faces that are not finer), as
    /// bits like [`Neighbourhood::finer_face_bits`].
    pub fn coarser_face_bits(&self) -> u8 {
        (0..6).fold(0, |acc, f| {
            acc | ((self.level_faces[f] && !self.finer_faces[f]) as u8) << f
        })
    }
}

/// A chunk build detached from its world (see [`super::World::chunk_build`]), to
/// run on any thread.
#[derive(Clone, Debug)]
pub struct ChunkBuild {
    /// The chunk.
    pub key: ChunkKey,
    /// Its grid (cells of its level, one cell of halo).
    pub grid: Grid,
    /// Cells per chunk.
    pub res: u32,
    /// The layout around it.
    pub neighbourhood: Neighbourhood,
    /// Build settings.
    pub settings: Settings,
    /// The field's samples of `grid` from an earlier build of this chunk, kept
    /// by its world ([`super::World::keep_samples`]): a chunk
    /// rebuilt because a neighbour changed level conforms these again instead
    /// of sampling. They must come from the field the build is given.
    pub kept: Option<Arc<[f32]>>,
    /// The crossings an earlier build of this chunk found, kept with its
    /// samples: an edge whose two samples the level rules left as they were
    /// takes its crossing from here instead of searching the field
    /// ([`KeptCrossings`]).
    pub kept_crossings: Option<Arc<KeptCrossings>>,
    /// The tree that earlier build made, for the same faces toward finer
    /// chunks (they shape the tree: [`Cells::Core`]): when the level rules leave every
    /// corner's sign and every crossing edge's samples as they were
    /// ([`KeptCrossings::unchanged`]), the build is this tree again.
    pub kept_tree: Option<Arc<KdTree>>,
    /// Whether to return the samples and crossings for the next build
    /// ([`super::World::keep_samples`]).
    pub keep: bool,
}

/// A chunk's tree and the field samples it was built from (none when the
/// field's bound proved one sign and nothing was sampled).
pub struct BuiltChunk {
    /// The chunk's tree.
    pub tree: Arc<KdTree>,
    /// The field's samples of the chunk's grid, before the level rules.
    pub samples: Option<Arc<[f32]>>,
    /// The crossings found on them (when [`ChunkBuild::keep`] asked for them).
    pub crossings: Option<Arc<KeptCrossings>>,
}

/// A chunk's samples after the level rules, and the field's samples before
/// them (none when nothing was sampled).
type Sampled = (Vec<f32>, Option<Arc<[f32]>>);

/// Fine cells past its grid that conforming reads ([`ChunkBuild::conformed`]).
const CONFORM_MARGIN: u32 = 3;

/// The smallest negative sample: inside, and the root search on an edge from it
/// starts at it and moves along the field.
const TINY: f32 = -f32::MIN_POSITIVE;

impl ChunkBuild {
    /// Samples the field (with the level rules) and builds the chunk's tree.
    pub fn run(&self, field: &dyn Field) -> Result<KdTree> {
        Ok(Arc::unwrap_or_clone(self.build(field)?.tree))
    }

    /// [`ChunkBuild::run`], also returning the field's samples to keep for the
    /// next build of the chunk.
    pub fn build(&self, field: &dyn Field) -> Result<BuiltChunk> {
        self.settings.run(|| {
            let (values, samples) = self.sampled(field)?;
            // Crossings kept with samples that were dropped are stale.
            let reuse = self
                .kept_crossings
                .as_ref()
                .filter(|_| self.kept.is_some() && samples.is_some());
            if let (true, Some(kept), Some(tree)) = (self.keep, reuse, &self.kept_tree) {
                if kept.unchanged(&self.grid, &values, &self.settings) {
                    return Ok(BuiltChunk {
                        tree: tree.clone(),
                        samples,
                        crossings: Some(kept.clone()),
                    });
                }
            }
            let coarser_faces = self.neighbourhood.coarser_face_bits();
            // The coarse cells the seams take across faces toward coarser
            // chunks: the cells' vertices and the fold guard are held to them.
            let coarser = Coarser::new(&self.grid, field, &self.settings, self.res, coarser_faces);
            let keep = (self.keep && samples.is_some()).then(|| reuse.map(|k| &**k));
            let (h, kept) = Hermite::for_chunk(
                field,
                &self.grid,
                &values,
                &self.settings,
                keep,
                coarser.as_ref(),
            )?;
            let crossings = kept.map(Arc::new);
            let cells = Cells::Core {
                res: self.res,
                finer_faces: self.neighbourhood.finer_face_bits(),
                coarser_faces,
            };
            let tree = pipeline::tree_beside(&h, field, &self.settings, cells, coarser.as_ref());
            Ok(BuiltChunk {
                tree: Arc::new(tree),
                samples: samples.filter(|_| self.keep),
                crossings,
            })
        })?
    }

    /// The chunk's samples: the field, conformed on the boundaries of coarser
    /// neighbours, with the halo across level faces forced inside.
    ///
    /// When the field's bound over every point the chunk reads (its grid and the
    /// three cells conforming reads past it) proves one strict sign, nothing is
    /// sampled ([`hermite::one_sign`]): conforming keeps a one-signed field's
    /// signs, so the samples have the signs sampling would give, and the tree is
    /// the one sampling would build (no surface).
    pub fn samples(&self, field: &dyn Field) -> Result<Vec<f32>> {
        Ok(self.sampled(field)?.0)
    }

    /// [`ChunkBuild::samples`] and the field's samples they came from (taken
    /// from [`ChunkBuild::kept`] when it has them).
    fn sampled(&self, field: &dyn Field) -> Result<Sampled> {
        let inner = match &self.kept {
            Some(kept) => kept.clone(),
            None => {
                // Only a chunk that conforms reads the field past its grid.
                let margin = if self.neighbourhood.coarser.is_empty() {
                    0
                } else {
                    CONFORM_MARGIN
                };
                if let Some(mut v) = hermite::one_sign(field, &self.grid, margin, &self.settings)? {
                    self.force_halo(&mut v);
                    return Ok((v, None));
                }
                Arc::from(hermite::sample(field, &self.grid, &self.settings)?)
            }
        };
        if inner.len() != self.grid.corner_count() as usize {
            return Err(Error::InvalidSetting {
                name: "kept samples",
                reason: format!(
                    "{} samples kept for a grid of {} corners",
                    inner.len(),
                    self.grid.corner_count()
                ),
            });
        }
        let mut values = if self.neighbourhood.coarser.is_empty() {
            inner.to_vec()
        } else {
            self.conformed(field, &inner)?
        };
        self.force_halo(&mut values);
        Ok((values, Some(inner)))
    }

    /// Rule 1 (see [`super`]): on the boundary of a coarser neighbour, a
    /// coarse edge's midpoint takes its ends' sign where the edge has no crossing;
    /// where it has one, it is inside if a coarse face around the edge is
    /// ambiguous, else it keeps the field's sign (the fine crossing is then in the
    /// half that holds the field's root). A coarse face's center follows
    /// [`center_inside`]. The rules read up to three fine cells past the grid,
    /// so the coarse corners and midpoints around its own points are read from
    /// samples computed as their owners compute them; the grid is sampled, and
    /// the points past it are evaluated when first read (only around the coarse
    /// boundaries).
    fn conformed(&self, field: &dyn Field, inner: &[f32]) -> Result<Vec<f32>> {
        let res = self.res as i32;
        let g = &self.grid;
        let wide = Grid {
            cells: g.cells + UVec3::splat(2 * CONFORM_MARGIN),
            offset: g.offset - IVec3::splat(CONFORM_MARGIN as i32),
            ..*g
        };
        let corners = g.corners().as_ivec3();
        // Points past the grid: NaN until first read.
        let wide_n = wide.corner_count();
        let past: Vec<Cell<f32>> = crate::budget::filled(
            || format!("the conformed samples of {wide_n} corners"),
            wide_n,
            Cell::new(f32::NAN),
        )?;
        let bad: Cell<Option<(Vec3, f32)>> = Cell::new(None);
        // The sample as taken: sampling may leave a corner it proved far from the
        // surface at [`hermite::FAR`] with its sign.
        let raw = |p: IVec3| {
            let l = p - g.offset;
            if l.cmpge(IVec3::ZERO).all() && l.cmplt(corners).all() {
                let l = l.as_uvec3();
                return inner[g.corner_index(l.x, l.y, l.z)];
            }
            let w = (p - wide.offset).as_uvec3();
            let slot = &past[wide.corner_index(w.x, w.y, w.z)];
            if slot.get().is_nan() {
                let at = wide.corner_pos(w);
                let v = field.value(at);
                if !v.is_finite() {
                    bad.set(Some((at, v)));
                    return 0.0;
                }
                slot.set(v);
            }
            slot.get()
        };
        // The field's value, for the rules that average values: a skipped
        // corner is evaluated as sampling would have, once (the rules read a
        // corner up to a dozen times; its slot past the grid is free).
        let real = |p: IVec3| {
            let v = raw(p);
            if v.abs() == hermite::FAR {
                let l = (p - wide.offset).as_uvec3();
                let slot = &past[wide.corner_index(l.x, l.y, l.z)];
                if slot.get().is_nan() {
                    slot.set(field.value(wide.corner_pos(l)));
                }
                slot.get().copysign(v)
            } else {
                v
            }
        };
        let mean = |vs: &[f32]| {
            let s: f64 = vs.iter().map(|&v| (v as f64).clamp(-1e30, 1e30)).sum();
            (s / vs.len() as f64) as f32
        };
        let inside = |p: IVec3| raw(p) < 0.0;
        // A coarse edge midpoint `p` (odd along `a` only).
        let mid = |p: IVec3, a: usize| {
            let ea = IVec3::AXES[a];
            let (e0, e1) = (real(p - ea), real(p + ea));
            if (e0 < 0.0) == (e1 < 0.0) {
                return mean(&[e0, e1]);
            }
            // A coarse face around the edge with alternating corners.
            let ambiguous = [(a + 1) % 3, (a + 2) % 3].iter().any(|&b| {
                [-2, 2].iter().any(|&s| {
                    let o = IVec3::AXES[b] * s;
                    inside(p - ea) == inside(p + ea + o) && inside(p + ea) == inside(p - ea + o)
                })
            });
            let v = real(p);
            if ambiguous && v >= 0.0 {
                TINY
            } else {
                v
            }
        };
        let boxes: Vec<(IVec3, IVec3)> = self
            .neighbourhood
            .coarser
            .iter()
            .map(|c| (c.coord * res * 2, (c.coord + IVec3::ONE) * res * 2))
            .collect();
        let on_boundary = |p: IVec3| {
            boxes.iter().any(|(lo, hi)| {
                p.cmpge(*lo).all()
                    && p.cmple(*hi).all()
                    && (p.cmpeq(*lo).any() || p.cmpeq(*hi).any())
            })
        };
        let n = g.corners();
        let mut values = crate::budget::filled(
            || format!("the samples of {} grid corners", g.corner_count()),
            g.corner_count(),
            0f32,
        )?;
        // Every corner off the coarse boundaries keeps its sample.
        values.copy_from_slice(inner);
        for z in 0..n.z {
            for y in 0..n.y {
                for x in 0..n.x {
                    let p = g.offset + UVec3::new(x, y, z).as_ivec3();
                    // The axes along which `p` is odd (a coarse edge's midpoint
                    // has one, a coarse face's center two).
                    let (mut odd, mut count) = ([0usize; 3], 0);
                    for a in 0..3 {
                        if p[a] & 1 == 1 {
                            odd[count] = a;
                            count += 1;
                        }
                    }
                    if !(count == 1 || count == 2) || !on_boundary(p) {
                        continue;
                    }
                    let i = g.corner_index(x, y, z);
                    values[i] = if count == 1 {
                        mid(p, odd[0])
                    } else {
                        let (a, b) = (odd[0], odd[1]);
                        let (ea, eb) = (IVec3::AXES[a], IVec3::AXES[b]);
                        // Corners (00, 10, 11, 01 in a, b) and the midpoints
                        // between them in the same cyclic order.
                        let corner = [
                            real(p - ea - eb),
                            real(p + ea - eb),
                            real(p + ea + eb),
                            real(p - ea + eb),
                        ];
                        let mids = [
                            mid(p - eb, a),
                            mid(p + ea, b),
                            mid(p + eb, a),
                            mid(p - ea, b),
                        ];
                        let v = real(p);
                        let inside = center_inside(corner, mids, v < 0.0);
                        let around: [f32; 8] =
                            std::array::from_fn(|k| if k < 4 { corner[k] } else { mids[k - 4] });
                        if (v < 0.0) == inside {
                            v
                        } else if !inside {
                            mean(&around).max(0.0)
                        } else {
                            mean(&around).min(TINY)
                        }
                    };
                }
            }
        }
        if let Some((position, value)) = bad.get() {
            return Err(Error::NonFiniteSample {
                position,
                value,
                cause: field.explain_non_finite(position),
            });
        }
        Ok(values)
    }

    /// Rule 2: across a face whose neighbours are at another level, the halo
    /// is inside, so the chunk's ambiguous faces there separate their outside
    /// corners (join their inside ones), on both sides of the seam.
    fn force_halo(&self, values: &mut [f32]) {
        let r = self.res + 1;
        for (f, &level) in self.neighbourhood.level_faces.iter().enumerate() {
            if !level {
                continue;
            }
            let (a, side) = (f / 2, f % 2);
            let (u, v) = ((a + 1) % 3, (a + 2) % 3);
            for i in 1..=r {
                for j in 1..=r {
                    let mut c = [0u32; 3];
                    c[a] = if side == 1 { r + 1 } else { 0 };
                    c[u] = i;
                    c[v] = j;
                    let k = self.grid.corner_index(c[0], c[1], c[2]);
                    values[k] = -values[k].abs().max(f32::MIN_POSITIVE);
                }
            }
        }
    }
}

/// Whether a coarse face's center is inside, from its corners and edge midpoints
/// (both in cyclic order, midpoint `i` between corners `i` and `i + 1`) and the
/// field's sign there (`field`): inside on an ambiguous face (its inside
/// corners join through the center, as the coarse side resolves it);
/// otherwise the field's sign when it leaves no fine quarter of the face
/// ambiguous and joins the center to a midpoint (the fine contour then runs
/// between the same coarse edges as the coarse one, with no loop around the
/// center), else the sign that does: the midpoints' sign when a corner's two
/// midpoints both differ from it, else inside when any midpoint is.
fn center_inside(corner: [f32; 4], mids: [f32; 4], field: bool) -> bool {
    let c = corner.map(|v| v < 0.0);
    let m = mids.map(|v| v < 0.0);
    if c[0] == c[2] && c[1] == c[3] && c[0] != c[1] {
        return true;
    }
    // Fine quarter `i` is (corner i, midpoint i, center, midpoint i - 1).
    let fits = |center: bool| {
        m.contains(&center)
            && (0..4).all(|i| {
                let (before, after) = (m[(i + 3) % 4], m[i]);
                !(c[i] == center && before == after && before != center)
            })
    };
    if fits(field) {
        return field;
    }
    for i in 0..4 {
        let (before, after) = (m[(i + 3) % 4], m[i]);
        if before == after && before != c[i] {
            return before;
        }
    }
    m.iter().any(|&x| x)
}

/// The grid of chunk `key` (its level's cells, one cell of halo), on the lattice
/// of `origin` and level-0 `cell_size`.
pub fn level_grid(origin: Vec3, cell_size: f32, res: u32, key: &ChunkKey) -> Grid {
    Grid {
        origin,
        cell_size: cell_size * (1u64 << key.level) as f32,
        cells: UVec3::splat(res + 2),
        offset: key.coord * res as i32 - IVec3::ONE,
    }
}
