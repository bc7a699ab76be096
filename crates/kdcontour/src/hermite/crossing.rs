//! The build's second step: the surface crossing on every edge with a sign
//! change, found on the field by false position, with the unit normal there and
//! (when borders are kept) the dominant material.

use super::{ActiveCell, KeptCrossings, FAR};
use crate::boundary::Cap;
use crate::cell::{CellTables, NO_COMP};
use crate::error::{Error, Result};
use crate::field::Field;
use crate::grid::Grid;
use crate::material;
use crate::root::Bracket;
use glam::{UVec3, Vec3};
use rayon::prelude::*;

/// One edge's crossing, as found.
pub(super) struct Crossing {
    /// The cell that owns the edge and the edge's index in it.
    pub(super) cell: u32,
    pub(super) edge: u8,
    pub(super) point: Vec3,
    pub(super) normal: Vec3,
    /// The dominant material there ([`material::UNSET`] when not tracked).
    pub(super) material: u16,
    /// The field has no root on the edge: a sample was forced to the other sign
    /// (see [`FORCED_CROSSING_T`]).
    pub(super) forced: bool,
    /// For a crossing found on the field (not a cap's): the edge's key
    /// (`3 * corner index + axis`), its two samples' bits and where on the
    /// edge the crossing is, for [`KeptCrossings`].
    pub(super) kept: Option<(u32, [u32; 2], f32)>,
}

/// The crossings of the edges each active cell owns, in runs of 1,024 cells (in
/// cell order; a run stops at its first non-finite value). An edge belongs to the
/// cell that has it on its low side in both other axes, or to the last cell along
/// an axis at the grid's high boundary. A capped grid's cap edges take the cap's
/// crossing; `iterations` bounds each root search; with `borders`, each crossing
/// records the field's dominant material when it is pure. An edge whose two
/// samples are those `reuse` kept for it takes the crossing kept (see
/// [`KeptCrossings`]).
#[allow(clippy::too_many_arguments)]
pub(super) fn crossings(
    field: &dyn Field,
    grid: &Grid,
    values: &[f32],
    cells: &[ActiveCell],
    cap: Option<Cap>,
    iterations: u32,
    borders: bool,
    reuse: Option<&KeptCrossings>,
) -> Vec<Result<Vec<Crossing>>> {
    let tables = CellTables::get();
    // Edge keys fit in 32 bits on every grid a world's chunk has; on larger
    // grids nothing is kept.
    let keyed = 3 * grid.corner_count() <= u32::MAX as u64;
    let n = grid.cells;
    let cidx = |x: u32, y: u32, z: u32| grid.corner_index(x, y, z);
    cells
        .par_chunks(1024)
        .enumerate()
        .map(|(chunk, list)| {
            let mut out = Vec::new();
            for (j, c) in list.iter().enumerate() {
                let cc = tables.cell(c.config, c.mask);
                let coord = [c.coord[0] as u32, c.coord[1] as u32, c.coord[2] as u32];
                for e in 0..12usize {
                    if cc.edge_comp[e] == NO_COMP {
                        continue;
                    }
                    let a = e / 4;
                    let (u, v) = ((a + 1) % 3, (a + 2) % 3);
                    let bu = (e % 4) as u32 & 1;
                    let bv = (e % 4) as u32 >> 1;
                    if (bu == 1 && coord[u] + 1 != n[u]) || (bv == 1 && coord[v] + 1 != n[v]) {
                        continue;
                    }
                    let mut g = coord;
                    g[u] += bu;
                    g[v] += bv;
                    if let Some((point, normal)) = cap.and_then(|c| c.crossing(g, a)) {
                        out.push(Crossing {
                            cell: (chunk * 1024 + j) as u32,
                            edge: e as u8,
                            point,
                            normal,
                            material: material::UNSET,
                            forced: false,
                            kept: None,
                        });
                        continue;
                    }
                    let mut h = g;
                    h[a] += 1;
                    let mut v0 = values[cidx(g[0], g[1], g[2])];
                    let mut v1 = values[cidx(h[0], h[1], h[2])];
                    let p0 = UVec3::from(g).as_vec3();
                    let dir = Vec3::AXES[a];
                    let key = keyed.then(|| 3 * cidx(g[0], g[1], g[2]) as u32 + a as u32);
                    let ends = [v0.to_bits(), v1.to_bits()];
                    let cell = (chunk * 1024 + j) as u32;
                    if let Some((t, normal, material, forced)) =
                        reuse.zip(key).and_then(|(r, key)| r.get(key, ends))
                    {
                        out.push(Crossing {
                            cell,
                            edge: e as u8,
                            point: p0 + dir * t,
                            normal,
                            material,
                            forced,
                            kept: key.map(|key| (key, ends, t)),
                        });
                        continue;
                    }
                    // Corners skipped by sampling hold only a sign: evaluate them.
                    if v0.abs() == FAR {
                        v0 = field.value(grid.to_world(p0)).copysign(v0);
                    }
                    if v1.abs() == FAR {
                        v1 = field
                            .value(grid.to_world(UVec3::from(h).as_vec3()))
                            .copysign(v1);
                    }
                    for (v, c) in [(v0, p0), (v1, UVec3::from(h).as_vec3())] {
                        if !v.is_finite() {
                            let position = grid.to_world(c);
                            return Err(Error::NonFiniteSample {
                                position,
                                value: v,
                                cause: field.explain_non_finite(position),
                            });
                        }
                    }
                    let Root {
                        t,
                        forced,
                        gradient,
                    } = find_root(field, grid, p0, dir, v0, v1, iterations)?;
                    let point = p0 + dir * t;
                    let wp = grid.to_world(point);
                    let (grad, blend) = match (gradient, borders) {
                        (Some(g), true) => (g, Some(field.material_with_gradient(wp, g))),
                        (Some(g), false) => (g, None),
                        (None, true) => {
                            let (g, m) = field.gradient_and_material(wp);
                            (g, Some(m))
                        }
                        (None, false) => (field.gradient(wp), None),
                    };
                    let outward = if v1 >= 0.0 { dir } else { -dir };
                    let normal = if grad.is_finite() && grad.length_squared() > 1e-20 {
                        grad.normalize()
                    } else {
                        outward
                    };
                    // Only a pure material counts toward a border (see
                    // [`material::PURE`]).
                    let material = match blend {
                        Some(m) if m.weights[0] >= material::PURE => m.dominant() as u16,
                        _ => material::UNSET,
                    };
                    out.push(Crossing {
                        cell,
                        edge: e as u8,
                        point,
                        normal,
                        material,
                        forced,
                        kept: key.map(|key| (key, ends, t)),
                    });
                }
            }
            Ok(out)
        })
        .collect()
}

/// Where on an edge a crossing goes when the field has no root there: a
/// fraction of the edge away from the end whose sample was forced to the other
/// sign. A chunk conformed to a coarser neighbour has such samples (the level
/// rules in [`crate::world`]); a root search from one closes on it, and
/// every cell around would put its vertex there (zero-area faces). Nearer the
/// end the level worlds' error and flipped faces drop but slivers grow (camera
/// levels, five scenes: 0.02 gives 5-690 slivers, 0.5 gives 0-364 and 10-25%
/// more error); 0.1 is between.
pub(crate) const FORCED_CROSSING_T: f32 = 0.1;

/// How near a sample on the surface (a field zero at a grid corner to the root
/// search's tolerance, as a terrain's height field is at its origin) a crossing
/// from it may be, as a fraction of the edge: at the sample, the crossings of
/// every edge from that corner would be on it, and the cells around it would put
/// their vertices on top of each other (zero-area faces). A hundredth of an edge
/// keeps them apart and moves the crossing by that much. Crossings near other
/// samples stay where the field puts them (nudging them all would tilt the planes
/// of flat faces: the box's adaptive meshes grew 12%).
pub(crate) const END_T: f32 = 0.01;

/// What [`find_root`] finds on an edge.
struct Root {
    /// Where on the edge the crossing is.
    t: f32,
    /// The field has no root on the edge (see [`FORCED_CROSSING_T`]).
    forced: bool,
    /// [`Field::gradient`] at the crossing, when the search's last evaluation
    /// was there and gave it ([`Field::value_and_gradient`]).
    gradient: Option<Vec3>,
}

/// The crossing along `p0 + t * dir`, `t` in `[0, 1]`, between samples `v0` and `v1`
/// of opposite sign: linear interpolation refined by up to `iterations` steps of the
/// Illinois false-position method on the field itself.
///
/// A chunk conformed to a coarser neighbour has samples forced to the sign the
/// coarse side gives them (`world::conform`), so the field can have one sign along
/// an edge whose samples differ. The search then closes on the forced end, and
/// every cell around that end would put its vertex there, on top of each other
/// (zero-area triangles). When the search ends at an end whose sample the field
/// contradicts, the crossing goes [`FORCED_CROSSING_T`] of the edge away from it,
/// and the second value says so. A crossing from a sample on the surface stays
/// [`END_T`] of the edge from it.
///
/// A field with [`Field::value_and_gradient`] gives the gradient with each
/// value; where the search ends on a point it evaluated (the crossing of a
/// field within tolerance of zero there, as most are), that is the normal's
/// gradient, and no second evaluation is needed.
fn find_root(
    field: &dyn Field,
    grid: &Grid,
    p0: Vec3,
    dir: Vec3,
    v0: f32,
    v1: f32,
    iterations: u32,
) -> Result<Root> {
    let mut b = Bracket::new(v0, v1);
    let mut t = (v0 / (v0 - v1)).clamp(0.0, 1.0);
    // Converged when the field is within 1e-5 cells of zero (distance units for
    // SDFs) or the bracket is 1e-5 cells wide.
    let tol = 1e-5 * grid.cell_size;
    // Whether an evaluation had end 0's sign or end 1's, and whether one was
    // within `tol` of zero (a root for sure).
    let (mut seen0, mut seen1, mut on_root) = (false, false, false);
    // The last point evaluated, and the gradient there when the field gave it.
    let mut last: Option<(f32, Vec3)> = None;
    for _ in 0..iterations {
        let wp = grid.to_world(p0 + dir * t);
        let ft = match field.value_and_gradient(wp) {
            Some((ft, g)) => {
                last = Some((t, g));
                ft
            }
            None => field.value(wp),
        };
        if !ft.is_finite() {
            return Err(Error::NonFiniteSample {
                position: wp,
                value: ft,
                cause: field.explain_non_finite(wp),
            });
        }
        if ft.abs() <= tol {
            on_root = true;
            break;
        }
        if (b.t1 - b.t0) < 1e-5 {
            break;
        }
        if (ft >= 0.0) == (v0 >= 0.0) {
            seen0 = true;
        } else {
            seen1 = true;
        }
        b.narrow(t, ft);
        if b.flat() {
            break;
        }
        t = b.secant();
    }
    // Every evaluation had one end's sign: the search closed on the other end,
    // whose sample the field may contradict.
    if !on_root && seen0 != seen1 {
        let (end, sample) = if seen1 { (0.0, v0) } else { (1.0, v1) };
        let field_there = field.value(grid.to_world(p0 + dir * end));
        if field_there.is_finite() && (field_there >= 0.0) != (sample >= 0.0) {
            return Ok(Root {
                t: (end - FORCED_CROSSING_T).abs(),
                forced: true,
                gradient: None,
            });
        }
    }
    // A root at a sample that is itself on the surface moves into the edge.
    if v0.abs() <= tol {
        t = t.max(END_T);
    }
    if v1.abs() <= tol {
        t = t.min(1.0 - END_T);
    }
    let gradient = last.and_then(|(at, g)| (at.to_bits() == t.to_bits()).then_some(g));
    Ok(Root {
        t,
        forced: false,
        gradient,
    })
}
