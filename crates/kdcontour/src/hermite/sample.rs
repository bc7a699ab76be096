//! Sampling the field on the grid's corners for Hermite data: every corner, or
//! (fields with a Lipschitz bound) blocks proved far from the surface skipped,
//! their corners `FAR` with the proved sign; a whole grid proved one-signed is
//! built from signs alone ([`one_sign`]).

use super::check_grid;
use crate::error::{Error, Result};
use crate::field::Field;
use crate::grid::{Grid, FAR};
use crate::settings::Settings;
use glam::UVec3;
use rayon::prelude::*;

/// Cells per side of the blocks that sampling may skip (fields with a Lipschitz
/// bound only). Measured at res 128 (block centers included): 4 evaluates 12.6% of
/// the corners of `disk_pole` and 9.3% of `csg_mix`; 8 evaluates 28.7% / 16.1% (its
/// blocks are rarely far enough), 2 evaluates 21.3% / 15.3% (too many centers).
const SKIP_BLOCK: u32 = 4;

/// The samples of `grid` when [`Field::bound`] over its box grown by `margin`
/// cells (plus one more, for the rounding of corner positions) proves one strict
/// sign: every corner `FAR` with that sign, as [`sample`]'s skipped blocks, and
/// no evaluation. `None` when the bound cannot tell; the grid is checked as
/// [`sample`] checks it either way.
pub fn one_sign(
    field: &dyn Field,
    grid: &Grid,
    margin: u32,
    settings: &Settings,
) -> Result<Option<Vec<f32>>> {
    check_grid(grid, settings)?;
    let m = (margin + 1) as f32 * grid.cell_size;
    let lo = grid.corner_pos(UVec3::ZERO) - m;
    let hi = grid.corner_pos(grid.cells) + m;
    let sign = match field.bound(lo, hi) {
        Some((a, _)) if a > 0.0 => FAR,
        Some((_, b)) if b < 0.0 => -FAR,
        _ => return Ok(None),
    };
    let n = grid.corner_count();
    crate::budget::filled(|| format!("the samples of {n} grid corners"), n, sign).map(Some)
}

/// Samples `field` at every corner of `grid`, in parallel over z slabs.
///
/// Without a Lipschitz bound, planes of corners (one y, all x and z) outside the
/// span that [`Field::bound`] cannot prove one-signed get `FAR` with their
/// sign instead of an evaluation.
///
/// With a Lipschitz bound `L`, the field is first evaluated at the center of every
/// block of `SKIP_BLOCK`³ cells; a block whose center value exceeds `L` times its
/// half-diagonal holds no surface, and its corners get `FAR` with the center's
/// sign instead of an evaluation. Only their sign is meaningful: a crossing next to
/// such a corner evaluates it on the field.
pub fn sample(field: &dyn Field, grid: &Grid, settings: &Settings) -> Result<Vec<f32>> {
    check_grid(grid, settings)?;
    let c = grid.corners();
    let slab = (c.x * c.y) as usize;
    let n = grid.corner_count();
    let mut values = crate::budget::filled(|| format!("the samples of {n} grid corners"), n, 0f32)?;
    let lipschitz = field.lipschitz().filter(|l| l.is_finite() && *l > 0.0);
    match lipschitz {
        None => sample_planes(field, grid, &mut values),
        Some(l) => sample_skipping(field, grid, l, &mut values),
    }
    // Blocks scanned without an early exit vectorise; `position_first` per value
    // did not, and cost a quarter of sampling a CSG terrain.
    const SCAN: usize = 4096;
    let bad = values
        .par_chunks(SCAN)
        .position_first(|c| c.iter().fold(false, |bad, v| bad | !v.is_finite()));
    if let Some(i) = bad.and_then(|k| {
        let start = k * SCAN;
        values[start..]
            .iter()
            .position(|v| !v.is_finite())
            .map(|j| start + j)
    }) {
        let z = i / slab;
        let y = (i % slab) / c.x as usize;
        let x = i % c.x as usize;
        let position = grid.corner_pos(UVec3::new(x as u32, y as u32, z as u32));
        return Err(Error::NonFiniteSample {
            position,
            value: values[i],
            cause: field.explain_non_finite(position),
        });
    }
    Ok(values)
}

/// How far from zero, in cells times the cell size, a sample may be proved
/// before the field may give it as [`FAR`] ([`Field::sample_grid_far`]): twice
/// what a field of slope 1 changes along an edge, so the ends of crossing edges
/// (which the build evaluates again when skipped) rarely are.
const FAR_CELLS: f32 = 2.0;

/// Samples with [`Field::sample_grid_far`] in parallel z slabs, except the planes of
/// corners at one y (whole xz planes) below the lowest or above the highest plane
/// that [`Field::bound`] cannot prove one-signed: those get `FAR` with their
/// sign, as skipped blocks do (a terrain chunk far larger than its hills'
/// height evaluates only the planes that reach them).
fn sample_planes(field: &dyn Field, grid: &Grid, values: &mut [f32]) {
    const SLICES: u32 = 2;
    let c = grid.corners();
    let known: Vec<Option<f32>> = (0..c.y)
        .map(|y| {
            // Half a cell of slack for the rounding of corner positions.
            let m = 0.5 * grid.cell_size;
            let lo = grid.corner_pos(UVec3::new(0, y, 0)) - m;
            let hi = grid.corner_pos(UVec3::new(c.x - 1, y, c.z - 1)) + m;
            match field.bound(lo, hi) {
                Some((a, _)) if a > 0.0 => Some(FAR),
                Some((_, b)) if b < 0.0 => Some(-FAR),
                _ => None,
            }
        })
        .collect();
    let slab = (c.x * c.y) as usize;
    let Some(ya) = known.iter().position(|k| k.is_none()) else {
        for (i, v) in values.iter_mut().enumerate() {
            *v = known[(i % slab) / c.x as usize].unwrap_or(FAR);
        }
        return;
    };
    let yb = known.iter().rposition(|k| k.is_none()).unwrap_or(ya);
    // The planes ya..=yb: the same lattice points, so bitwise the same values.
    let sub = Grid {
        cells: UVec3::new(grid.cells.x, (yb - ya) as u32, grid.cells.z),
        offset: grid.offset + glam::IVec3::new(0, ya as i32, 0),
        ..*grid
    };
    let whole = ya == 0 && yb + 1 == c.y as usize;
    let far = FAR_CELLS * grid.cell_size;
    let sub_slab = (c.x as usize) * (yb - ya + 1);
    values
        .par_chunks_mut(slab * SLICES as usize)
        .enumerate()
        .for_each(|(i, out)| {
            let z0 = i as u32 * SLICES;
            let z1 = (z0 + SLICES).min(c.z);
            if whole {
                field.sample_grid_far(grid, z0..z1, out, far);
                return;
            }
            let mut part = vec![0f32; sub_slab * (z1 - z0) as usize];
            field.sample_grid_far(&sub, z0..z1, &mut part, far);
            let cx = c.x as usize;
            for (out, part) in out.chunks_mut(slab).zip(part.chunks(sub_slab)) {
                for (y, row) in out.chunks_mut(cx).enumerate() {
                    if (ya..=yb).contains(&y) {
                        let start = (y - ya) * cx;
                        row.copy_from_slice(&part[start..start + cx]);
                    } else {
                        row.fill(known[y].unwrap_or(FAR));
                    }
                }
            }
        });
}

fn sample_skipping(field: &dyn Field, grid: &Grid, l: f32, values: &mut [f32]) {
    let n = grid.cells;
    let c = grid.corners();
    let b = SKIP_BLOCK;
    let nb = (n + UVec3::splat(b - 1)) / b;
    let half_diag = (b as f32 * 0.5) * 3f32.sqrt() * grid.cell_size;
    // Block center values, or NaN where the block may hold surface.
    let centers: Vec<f32> = (0..nb.z)
        .into_par_iter()
        .flat_map_iter(|bz| {
            (0..nb.y).flat_map(move |by| {
                (0..nb.x).map(move |bx| {
                    let lo = UVec3::new(bx, by, bz) * b;
                    let hi = (lo + UVec3::splat(b)).min(n);
                    let center = grid.to_world((lo + hi).as_vec3() * 0.5);
                    let half = (hi - lo).as_vec3().length() * 0.5 * grid.cell_size;
                    let v = field.value(center);
                    let far = v.is_finite() && v.abs() > l * half.min(half_diag) * 1.001 + 1e-7;
                    if far {
                        v
                    } else {
                        f32::NAN
                    }
                })
            })
        })
        .collect();
    let slab = (c.x * c.y) as usize;
    values
        .par_chunks_mut(slab)
        .enumerate()
        .for_each(|(z, out)| {
            let z = z as u32;
            // Per row, the sign known from any far block of each x block column.
            let mut row_sign = vec![f32::NAN; nb.x as usize];
            for y in 0..c.y {
                row_sign.fill(f32::NAN);
                for bz in block_range(z, b, nb.z) {
                    for by in block_range(y, b, nb.y) {
                        let base = (nb.x * (by + nb.y * bz)) as usize;
                        for (bx, known) in row_sign.iter_mut().enumerate() {
                            let v = centers[base + bx];
                            if known.is_nan() && !v.is_nan() {
                                *known = FAR.copysign(v);
                            }
                        }
                    }
                }
                for x in 0..c.x {
                    // A corner on block boundaries lies in up to eight blocks; any
                    // one far block decides its sign.
                    let known = block_range(x, b, nb.x)
                        .map(|bx| row_sign[bx as usize])
                        .find(|v| !v.is_nan());
                    out[(x + c.x * y) as usize] = match known {
                        Some(v) => v,
                        None => field.value(grid.corner_pos(UVec3::new(x, y, z))),
                    };
                }
            }
        });
}

/// Blocks (of `b` cells) that contain corner coordinate `i`.
fn block_range(i: u32, b: u32, nb: u32) -> std::ops::Range<u32> {
    let hi = (i / b).min(nb - 1);
    let lo = if i.is_multiple_of(b) && i > 0 {
        i / b - 1
    } else {
        hi
    };
    lo..hi + 1
}
