//! Hermite data (section 3): corner samples, active cells with their Dual Marching
//! Cubes components, and for every edge with a sign change its crossing (found on
//! the field by false position, not just interpolated) and the unit normal there.
//!
//! Positions are in grid units. A NaN or infinite sample is an error, never a mesh.

use crate::boundary::{self, Boundary, Cap};
use crate::cell::{edge_index, opposite_face, CellTables, NO_COMP};
use crate::error::{Error, Result};
use crate::facing::Facing;
use crate::field::Field;
use crate::grid::Grid;
use crate::material;
use crate::qef::Qef;
use crate::settings::Settings;
use glam::{UVec3, Vec3};
use rayon::prelude::*;

mod sample;
mod vertex;

pub(crate) use crate::grid::FAR;
pub use sample::{one_sign, sample};

/// A cell with at least one sign change.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ActiveCell {
    /// Cell coordinates.
    pub coord: [u16; 3],
    /// Outside bits of its corners (see [`crate::cell`]).
    pub config: u8,
    /// Face resolution mask (see [`crate::cell`]).
    pub mask: u8,
    /// Index of its first patch in [`Hermite::patch_qef`].
    pub patch_base: u32,
}

/// Hermite data of a sampled grid.
pub struct Hermite {
    /// The grid.
    pub(crate) grid: Grid,
    /// One bit per corner: set when the corner is outside (value >= 0).
    pub(crate) outside: Vec<u64>,
    /// Active cells, ordered by linear index (x fastest).
    pub(crate) cells: Vec<ActiveCell>,
    /// QEF of each cell patch (grid units).
    pub(crate) patch_qef: Vec<Qef>,
    /// Sum of the unit normals of each patch's crossings.
    pub(crate) patch_normal: Vec<Vec3>,
    /// Each patch's vertex in its cell (grid units, before
    /// [`crate::comp::Comp::pack`] rounds it): the QEF's minimiser, moved toward
    /// the mass point where that would fold a quad (module `vertex`).
    pub(crate) patch_vertex: Vec<Vec3>,
    /// Number of edges with a sign change.
    pub(crate) crossings: usize,
    /// Every edge crossing, in a fixed order.
    pub(crate) edges: Vec<EdgeCrossing>,
    /// Per active cell, when the field has materials and
    /// [`Settings::material_borders`] is on: the dominant material of every
    /// crossing on the edges of the active cells within one cell of it (the
    /// 3x3x3 block around it), or [`material::MIXED`] where they differ (a
    /// border is near). Empty otherwise.
    pub(crate) cell_material: Vec<u16>,
    /// With [`Boundary::Capped`] and a solid that reaches the grid's faces, the
    /// grid the caps close (this data's grid less its layer of caps); `None`
    /// otherwise.
    pub(crate) capped: Option<Grid>,
}

/// What [`Hermite::surface`] gives: a field, or a field cut by caps.
pub enum Surface<'a> {
    /// The field itself.
    Field(&'a dyn Field),
    /// The field cut by the box the caps close.
    Capped(boundary::CappedField<'a>),
}

impl<'a> Surface<'a> {
    /// `field`, cut by the box of `capped` when there is one.
    fn of(field: &'a dyn Field, capped: Option<&Grid>) -> Self {
        match capped {
            Some(g) => Surface::Capped(boundary::CappedField::new(field, g)),
            None => Surface::Field(field),
        }
    }

    /// The surface as a field.
    pub fn field(&self) -> &dyn Field {
        match self {
            Surface::Field(f) => *f,
            Surface::Capped(c) => c,
        }
    }
}

/// The surface crossing on one grid edge.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EdgeCrossing {
    /// The edge: `3 * (linear index of its low corner) + axis`.
    pub key: u64,
    /// Where the surface crosses it (grid units).
    pub point: Vec3,
    /// The unit normal there.
    pub normal: Vec3,
}

/// Estimated bytes the build needs for `grid` (samples, sign bits, the cell lookup
/// and a surface-proportional allowance for patches and tree nodes).
pub fn estimate_bytes(grid: &Grid) -> u64 {
    let corners = grid.corner_count();
    let cells = grid.cell_count();
    corners * 4 + corners / 8 + cells * 4 + surface_bytes(grid.cells.as_u64vec3())
}

/// The surface-proportional part of [`estimate_bytes`] for a box of `cells`:
/// patches and tree nodes for a surface as large as the box's six faces
/// (saturating, so an absurd box compares as too large instead of wrapping).
pub fn surface_bytes(cells: glam::U64Vec3) -> u64 {
    let c = cells;
    let faces =
        c.x.saturating_mul(c.y)
            .saturating_add(c.y.saturating_mul(c.z))
            .saturating_add(c.z.saturating_mul(c.x));
    faces.saturating_mul(2 * 8 * 420)
}

/// Checks the grid and the memory budget before anything is allocated.
pub fn check_grid(grid: &Grid, settings: &Settings) -> Result<()> {
    grid.validate()?;
    let needed = estimate_bytes(grid);
    if needed > settings.memory_budget.get() {
        return Err(Error::MemoryBudget {
            cells: grid.cell_count(),
            needed,
            budget: settings.memory_budget.get(),
        });
    }
    Ok(())
}

struct Crossing {
    /// The cell that owns the edge and the edge's index in it.
    cell: u32,
    edge: u8,
    point: Vec3,
    normal: Vec3,
    /// The dominant material there ([`material::UNSET`] when not tracked).
    material: u16,
    /// The field has no root on the edge: a sample was forced to the other sign
    /// (see [`FORCED_CROSSING_T`]).
    forced: bool,
}

impl Hermite {
    /// The grid the data is on (a capped grid's padded one).
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// Cells with a sign change (active cells).
    pub fn active_cells(&self) -> usize {
        self.cells.len()
    }

    /// Edges with a sign change.
    pub fn crossing_count(&self) -> usize {
        self.crossings
    }
}

impl Hermite {
    /// Samples `field` on `grid` ([`sample`]) and builds its Hermite data
    /// ([`Hermite::new`]); the samples are dropped before returning. Runs on the
    /// calling thread pool (wrap in [`Settings::run`] to honour `settings.threads`).
    ///
    /// With [`Boundary::Capped`] and a solid that reaches the grid's faces, the
    /// data is of the grid grown by one cell of caps ([`crate::boundary`]), and
    /// [`Hermite::grid`] is that grid.
    pub fn from_field(field: &dyn Field, grid: &Grid, settings: &Settings) -> Result<Self> {
        let values = sample(field, grid, settings)?;
        if settings.boundary == Boundary::Capped && boundary::reaches_faces(grid, &values) {
            let big = boundary::padded(grid);
            check_grid(&big, settings)?;
            let values = boundary::pad_values(grid, &values);
            let cap = Cap { cells: big.cells };
            return Hermite::build(field, &big, &values, settings, Some((cap, *grid)));
        }
        Hermite::new(field, grid, &values, settings)
    }

    /// Builds Hermite data from samples of `field` on `grid` (from [`sample`]).
    pub fn new(
        field: &dyn Field,
        grid: &Grid,
        values: &[f32],
        settings: &Settings,
    ) -> Result<Self> {
        Hermite::build(field, grid, values, settings, None)
    }

    /// [`Hermite::new`], on a grid whose added corners `cap` marks when capped
    /// (with the grid the caps close).
    fn build(
        field: &dyn Field,
        grid: &Grid,
        values: &[f32],
        settings: &Settings,
        capped: Option<(Cap, Grid)>,
    ) -> Result<Self> {
        let (cap, capped) = (capped.map(|c| c.0), capped.map(|c| c.1));
        let surface = Surface::of(field, capped.as_ref());
        let tables = CellTables::get();
        let n = grid.cells;
        let corners = grid.corners();
        let cidx = |x: u32, y: u32, z: u32| grid.corner_index(x, y, z);
        let config_at = |x: u32, y: u32, z: u32| -> u8 {
            let mut cfg = 0u8;
            for i in 0..8u32 {
                let v = values[cidx(x + (i & 1), y + ((i >> 1) & 1), z + ((i >> 2) & 1))];
                if v >= 0.0 {
                    cfg |= 1 << i;
                }
            }
            cfg
        };

        // Active cells, layer by layer.
        let layers: Vec<Vec<ActiveCell>> = (0..n.z)
            .into_par_iter()
            .map(|z| {
                let mut out = Vec::new();
                let cx = corners.x as usize;
                let mut signs = vec![0u8; cx];
                let mut row_cfg = vec![0u8; cx];
                for y in 0..n.y {
                    // Sign bits of the four corner rows around this row of cells,
                    // combined column by column (vectorises; no index arithmetic).
                    row_cfg.fill(0);
                    for (k, (dy, dz)) in [(0u32, 0u32), (1, 0), (0, 1), (1, 1)]
                        .into_iter()
                        .enumerate()
                    {
                        let start = cidx(0, y + dy, z + dz);
                        let row = &values[start..start + cx];
                        for (s, v) in signs.iter_mut().zip(row) {
                            *s = (*v >= 0.0) as u8;
                        }
                        // Corner bit: x offset 0 -> bit 2k', x offset 1 -> bit 2k'+1,
                        // with k' = dy + 2 dz = k.
                        for x in 0..cx - 1 {
                            row_cfg[x] |= (signs[x] | (signs[x + 1] << 1)) << (2 * k);
                        }
                    }
                    for x in 0..n.x {
                        let cfg = row_cfg[x as usize];
                        if cfg == 0 || cfg == 255 {
                            continue;
                        }
                        let mut mask = 0u8;
                        let joined = tables.skeleton_joined[cfg as usize];
                        for f in 0..6usize {
                            if joined & (1 << f) == 0 {
                                continue;
                            }
                            let a = f / 2;
                            let mut nc = [x as i64, y as i64, z as i64];
                            nc[a] += if f % 2 == 1 { 1 } else { -1 };
                            if nc[a] < 0 || nc[a] >= n[a] as i64 {
                                continue;
                            }
                            let ncfg = config_at(nc[0] as u32, nc[1] as u32, nc[2] as u32);
                            if tables.skeleton_joined[ncfg as usize] & (1 << opposite_face(f)) != 0
                            {
                                mask |= 1 << f;
                            }
                        }
                        out.push(ActiveCell {
                            coord: [x as u16, y as u16, z as u16],
                            config: cfg,
                            mask,
                            patch_base: 0,
                        });
                    }
                }
                out
            })
            .collect();
        let mut cells: Vec<ActiveCell> = Vec::with_capacity(layers.iter().map(Vec::len).sum());
        for l in layers {
            cells.extend(l);
        }
        let mut patches = 0u32;
        for c in cells.iter_mut() {
            c.patch_base = patches;
            patches += tables.cell(c.config, c.mask).count as u32;
        }

        // Dense lookup from cell to active index (dropped after the build).
        let mut lookup: Vec<u32> = Vec::with_capacity(grid.cell_count() as usize);
        lookup.par_extend(rayon::iter::repeat_n(u32::MAX, grid.cell_count() as usize));
        let lin = |c: [u32; 3]| {
            c[0] as usize + n.x as usize * (c[1] as usize + n.y as usize * c[2] as usize)
        };
        for (i, c) in cells.iter().enumerate() {
            lookup[lin([c.coord[0] as u32, c.coord[1] as u32, c.coord[2] as u32])] = i as u32;
        }

        // Crossings of the edges each active cell owns: an edge belongs to the cell
        // that has it on its low side in both other axes, or to the last cell along
        // an axis at the grid's high boundary.
        let iterations = settings.root_iterations;
        let borders = settings.materials && settings.material_borders && field.has_materials();
        let crossing_lists: Vec<Result<Vec<Crossing>>> = cells
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
                            });
                            continue;
                        }
                        let mut h = g;
                        h[a] += 1;
                        let mut v0 = values[cidx(g[0], g[1], g[2])];
                        let mut v1 = values[cidx(h[0], h[1], h[2])];
                        let p0 = UVec3::from(g).as_vec3();
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
                        let dir = Vec3::AXES[a];
                        let (t, forced) = find_root(field, grid, p0, dir, v0, v1, iterations)?;
                        let point = p0 + dir * t;
                        let wp = grid.to_world(point);
                        let grad = field.gradient(wp);
                        let outward = if v1 >= 0.0 { dir } else { -dir };
                        let normal = if grad.is_finite() && grad.length_squared() > 1e-20 {
                            grad.normalize()
                        } else {
                            outward
                        };
                        // Only a pure material counts toward a border (see
                        // [`material::PURE`]).
                        let material = match borders.then(|| field.material(wp)) {
                            Some(m) if m.weights[0] >= material::PURE => m.dominant() as u16,
                            _ => material::UNSET,
                        };
                        out.push(Crossing {
                            cell: (chunk * 1024 + j) as u32,
                            edge: e as u8,
                            point,
                            normal,
                            material,
                            forced,
                        });
                    }
                }
                Ok(out)
            })
            .collect();

        let mut patch_qef = vec![Qef::default(); patches as usize];
        let mut patch_normal = vec![Vec3::ZERO; patches as usize];
        let mut crossings = 0usize;
        let mut edges = Vec::new();
        let mut quads = Vec::new();
        let mut own_material = if borders {
            vec![material::UNSET; cells.len()]
        } else {
            Vec::new()
        };
        for list in crossing_lists {
            for x in list? {
                crossings += 1;
                let owner = cells[x.cell as usize];
                let e = x.edge as usize;
                let a = e / 4;
                let (u, v) = ((a + 1) % 3, (a + 2) % 3);
                let mut g = [
                    owner.coord[0] as u32,
                    owner.coord[1] as u32,
                    owner.coord[2] as u32,
                ];
                g[u] += (e % 4) as u32 & 1;
                g[v] += (e % 4) as u32 >> 1;
                edges.push(EdgeCrossing {
                    key: 3 * cidx(g[0], g[1], g[2]) as u64 + a as u64,
                    point: x.point,
                    normal: x.normal,
                });
                // The (up to) four cells around the edge, and the edge's dual quad
                // when all four are in the grid.
                let mut quad = [u32::MAX; 4];
                for su in 0..2u32 {
                    for sv in 0..2u32 {
                        if (su == 0 && g[u] == 0) || (sv == 0 && g[v] == 0) {
                            continue;
                        }
                        let mut c = g;
                        c[u] = g[u] + su - 1;
                        c[v] = g[v] + sv - 1;
                        if c[u] >= n[u] || c[v] >= n[v] {
                            continue;
                        }
                        let idx = lookup[lin(c)];
                        debug_assert!(idx != u32::MAX, "a cell around a crossing is active");
                        let cell = cells[idx as usize];
                        let comp = tables.cell(cell.config, cell.mask).edge_comp
                            [edge_index(a, 1 - su, 1 - sv)];
                        debug_assert!(comp != NO_COMP);
                        let p = (cell.patch_base + comp as u32) as usize;
                        // Counter-clockwise about the axis, as the contouring walks.
                        quad[[[0, 3], [1, 2]][su as usize][sv as usize]] = p as u32;
                        patch_qef[p].add_plane(x.point, x.normal);
                        patch_normal[p] += x.normal;
                        if let Some(m) = own_material.get_mut(idx as usize) {
                            *m = material::combine(*m, x.material);
                        }
                    }
                }
                // A forced crossing's quad is not the field's surface (a halo
                // forced inside, a conformed face): its cells' vertices are not
                // judged by it.
                if !quad.contains(&u32::MAX) && !x.forced {
                    let mut facing = Vec3::ZERO;
                    facing[a] = 1.0;
                    if values[cidx(g[0], g[1], g[2])] >= 0.0 {
                        quad.reverse();
                        facing = -facing;
                    }
                    quads.push(vertex::DualQuad {
                        patches: quad,
                        facing,
                        normal: x.normal,
                    });
                }
            }
        }
        let patch_vertex = vertex::cell_vertices(
            &cells,
            &patch_qef,
            &patch_normal,
            &quads,
            &Facing::new(surface.field(), grid),
        );
        drop(quads);
        let cell_material = dilate(&cells, &own_material, n, |c| lookup[lin(c)]);
        drop(lookup);

        // Sign bits, 64 corners per word, in parallel (this was a serial 2 M-corner
        // loop at res 128 that kept two threads from doubling the speed).
        let mut outside =
            vec![0u64; (corners.x as usize * corners.y as usize * corners.z as usize).div_ceil(64)];
        outside
            .par_chunks_mut(256)
            .zip(values.par_chunks(256 * 64))
            .for_each(|(words, vals)| {
                for (word, vals) in words.iter_mut().zip(vals.chunks(64)) {
                    let mut w = 0u64;
                    for (k, v) in vals.iter().enumerate() {
                        w |= ((*v >= 0.0) as u64) << k;
                    }
                    *word = w;
                }
            });
        Ok(Hermite {
            grid: *grid,
            outside,
            cells,
            patch_qef,
            patch_normal,
            patch_vertex,
            crossings,
            edges,
            cell_material,
            capped,
        })
    }

    /// The surface this data's polygons are held to: `field`, the field it was
    /// sampled from, cut by the caps' box when capped ([`Hermite::capped`]).
    pub fn surface<'a>(&self, field: &'a dyn Field) -> Surface<'a> {
        Surface::of(field, self.capped.as_ref())
    }

    /// Whether corner `(x, y, z)` is outside.
    #[inline]
    pub fn is_outside(&self, c: [u32; 3]) -> bool {
        let i = self.grid.corner_index(c[0], c[1], c[2]);
        self.outside[i / 64] >> (i % 64) & 1 == 1
    }
}

/// Per active cell: the material codes `own` (one per cell, empty when not
/// tracked) of the active cells in the 3x3x3 block around it, combined
/// ([`material::combine`]); `index` gives a cell's active index or `u32::MAX`.
fn dilate(
    cells: &[ActiveCell],
    own: &[u16],
    n: UVec3,
    index: impl Fn([u32; 3]) -> u32 + Sync,
) -> Vec<u16> {
    if own.is_empty() {
        return Vec::new();
    }
    cells
        .par_iter()
        .enumerate()
        .map(|(i, c)| {
            let mut code = own[i];
            for d in 0..27u32 {
                let off = [d % 3, d / 3 % 3, d / 9];
                let mut at = [0u32; 3];
                let mut inside = true;
                for a in 0..3 {
                    let v = c.coord[a] as u32 + off[a];
                    inside &= v >= 1 && v <= n[a];
                    at[a] = v.wrapping_sub(1);
                }
                if !inside {
                    continue;
                }
                let j = index(at);
                if j != u32::MAX {
                    code = material::combine(code, own[j as usize]);
                }
            }
            code
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
fn find_root(
    field: &dyn Field,
    grid: &Grid,
    p0: Vec3,
    dir: Vec3,
    v0: f32,
    v1: f32,
    iterations: u32,
) -> Result<(f32, bool)> {
    let (mut t0, mut f0, mut t1, mut f1) = (0f32, v0, 1f32, v1);
    let mut t = (f0 / (f0 - f1)).clamp(0.0, 1.0);
    let mut side = 0i8;
    // Converged when the field is within 1e-5 cells of zero (distance units for
    // SDFs) or the bracket is 1e-5 cells wide.
    let tol = 1e-5 * grid.cell_size;
    // Whether an evaluation had end 0's sign or end 1's, and whether one was
    // within `tol` of zero (a root for sure).
    let (mut seen0, mut seen1, mut on_root) = (false, false, false);
    for _ in 0..iterations {
        let wp = grid.to_world(p0 + dir * t);
        let ft = field.value(wp);
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
        if (t1 - t0) < 1e-5 {
            break;
        }
        if (ft >= 0.0) == (v0 >= 0.0) {
            seen0 = true;
        } else {
            seen1 = true;
        }
        if (ft >= 0.0) == (f0 >= 0.0) {
            t0 = t;
            f0 = ft;
            if side == -1 {
                f1 *= 0.5;
            }
            side = -1;
        } else {
            t1 = t;
            f1 = ft;
            if side == 1 {
                f0 *= 0.5;
            }
            side = 1;
        }
        if f0 == f1 {
            break;
        }
        t = (t0 - f0 * (t1 - t0) / (f1 - f0)).clamp(t0, t1);
    }
    // Every evaluation had one end's sign: the search closed on the other end,
    // whose sample the field may contradict.
    if !on_root && seen0 != seen1 {
        let (end, sample) = if seen1 { (0.0, v0) } else { (1.0, v1) };
        let field_there = field.value(grid.to_world(p0 + dir * end));
        if field_there.is_finite() && (field_there >= 0.0) != (sample >= 0.0) {
            return Ok(((end - FORCED_CROSSING_T).abs(), true));
        }
    }
    // A root at a sample that is itself on the surface moves into the edge.
    if v0.abs() <= tol {
        t = t.max(END_T);
    }
    if v1.abs() <= tol {
        t = t.min(1.0 - END_T);
    }
    Ok((t, false))
}
