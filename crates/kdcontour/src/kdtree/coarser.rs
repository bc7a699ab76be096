//! What a chunk's fold guard and its cells' vertices stand across its faces
//! toward coarser chunks: the coarse chunk's cells there ([`Coarser`]).
//!
//! A seam polygon across a face between levels joins the finer chunk's leaves to
//! the coarser chunk's cells (the coarser chunk keeps cells along faces toward
//! finer chunks, `build::finer_cells`), each fine edge on the face taking the
//! coarse cell and component the seam walk maps it to
//! ([`super::contour::levels::seam_edge`]). The fine chunk's halo holds fine
//! cells there, whose vertices are not the coarse ones, so a guard reading them
//! passed merged fine leaves whose seam polygons fold against the coarse cells.
//! The coarse cells are a function of the field alone (a coarser chunk's samples
//! on its faces toward finer chunks are the field's), so the fine chunk samples
//! them itself: a slab of coarse cells three thick across each such face (the two
//! layers of the coarser chunk that touch the face and one on the fine side, so
//! that the cells' vertices see their neighbours as the coarser chunk's own
//! build does; the fine side's far plane is the coarser chunk's halo, forced
//! inside as it forces it), with the Hermite data of the coarser chunk's cells.
//! In level worlds of the sphere, gyroid and csg_mix, 1,105 of 1,114 coarse
//! vertices the guard reads are the coarser tree's to within a thousandth of a
//! cell (the test below). The chunk's Hermite stage reads the same corners
//! ([`crate::hermite::Hermite::for_chunk`]): the quads of the fine edges on such a
//! face take them, fixed, where they take halo cells, so the fine cells' vertices
//! are placed against the coarse ones the seam joins them to.
//!
//! A coarse cell's vertex is placed by the same rules in both builds, but that
//! placement looks at the cells around it ([`crate::hermite`]), and the slab
//! ends where the coarser chunk does not: near the slab's sides the vertices can
//! differ, and so can the samples where the coarser chunk is itself conformed to
//! a still coarser one. The guard is then as good as the slab, which is what the
//! measurements in `docs/chunks-and-levels.md` count.

use super::contour::levels::seam_edge;
use super::{Comp, NONE};
use crate::cell::{CellTables, NO_COMP};
use crate::field::Field;
use crate::grid::Grid;
use crate::hermite::{sample, Hermite};
use crate::settings::{Boundary, Settings};
use glam::{IVec3, UVec3, Vec3};
use std::collections::HashMap;

/// The coarse cells across a chunk's faces toward coarser chunks, for its fold
/// guard and its cells' vertices.
pub(crate) struct Coarser {
    /// The chunk's grid: its level's cells, one of halo all round.
    grid: Grid,
    /// Cells per side of the chunk (the grid less its halo).
    res: u32,
    /// One slab per face toward a coarser chunk.
    faces: Vec<Slab>,
}

/// The coarse cells along one face.
struct Slab {
    /// The face (`2 * axis + side`).
    face: usize,
    /// The coarse cells' Hermite data (a grid of the coarser level).
    h: Hermite,
    /// Active cell index by cell coordinates.
    index: HashMap<[u16; 3], u32>,
    /// The first corner id of this slab's patches ([`CoarseCorner::id`]).
    base: u32,
}

/// What a coarse cell gives a fine polygon's corner.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CoarseCorner {
    /// An identity of the coarse patch, distinct from every tree node and from
    /// the fine halo's corners (two fine quadrants in one coarse patch are one
    /// corner of the polygon).
    pub(crate) id: u32,
    /// Its vertex, in the chunk's grid units.
    pub(crate) pos: Vec3,
    /// Its unit normal.
    pub(crate) normal: Vec3,
}

/// Corner ids count down from here, below [`NONE`] less the four quadrants'
/// fine halo ids.
const FIRST_ID: u32 = NONE - 4;

impl Coarser {
    /// The coarse cells across the faces `faces` (bits `2 * axis + side`) of the
    /// chunk of grid `grid` (`res`^3 cells and one of halo), sampled from
    /// `field`. `None` when there are no such faces, when the chunk's cells do
    /// not sit on the coarser lattice (an odd `res`), or when the slab cannot be
    /// sampled (the coarser chunk's own build reports why).
    pub(crate) fn new(
        grid: &Grid,
        field: &dyn Field,
        settings: &Settings,
        res: u32,
        faces: u8,
    ) -> Option<Coarser> {
        let grid = *grid;
        // The core's low corner on the fine lattice must be a coarse corner.
        let lo = grid.offset + IVec3::ONE;
        if faces == 0 || res % 2 == 1 || lo.to_array().iter().any(|c| c % 2 != 0) {
            return None;
        }
        let slab_settings = Settings {
            materials: false,
            material_borders: false,
            boundary: Boundary::Open,
            ..settings.clone()
        };
        let mut out = Coarser {
            grid,
            res,
            faces: Vec::new(),
        };
        let mut base = 0u32;
        for face in (0..6).filter(|f| faces & (1 << f) != 0) {
            let (a, side) = (face / 2, face % 2);
            // Coarse lattice: the core's cells are half as many, two fine wide.
            let mut offset = lo / 2 - IVec3::ONE;
            let mut cells = UVec3::splat(res / 2 + 2);
            let plane = lo[a] / 2 + if side == 1 { res as i32 / 2 } else { 0 };
            offset[a] = if side == 1 { plane - 1 } else { plane - 2 };
            cells[a] = 3;
            let slab = Grid {
                origin: grid.origin,
                cell_size: grid.cell_size * 2.0,
                cells,
                offset,
            };
            let mut values = sample(field, &slab, &slab_settings).ok()?;
            // The coarser chunk's halo across the face is forced inside (rule 2
            // in `crate::world`): the slab's plane on the fine side is that halo.
            let far = if side == 1 { 0 } else { 3 };
            let corners = slab.corners();
            let (u, v) = ((a + 1) % 3, (a + 2) % 3);
            for i in 0..corners[u] {
                for j in 0..corners[v] {
                    let mut c = [0u32; 3];
                    c[a] = far;
                    c[u] = i;
                    c[v] = j;
                    let k = slab.corner_index(c[0], c[1], c[2]);
                    values[k] = -values[k].abs().max(f32::MIN_POSITIVE);
                }
            }
            let sh = Hermite::new(field, &slab, &values, &slab_settings).ok()?;
            let index = sh
                .cells
                .iter()
                .enumerate()
                .map(|(i, c)| (c.coord, i as u32))
                .collect();
            let patches = sh.patch_vertex.len() as u32;
            out.faces.push(Slab {
                face,
                h: sh,
                index,
                base,
            });
            base += patches;
        }
        Some(out)
    }

    /// The coarse corner of the polygon of the chunk grid's edge along `d` through
    /// corner `line` in quadrant `q`, whose cell `cell` (chunk grid coordinates)
    /// is a halo cell across a face toward a coarser chunk (and inside the chunk's
    /// span along the other two axes). `None` when the cell is elsewhere, or when
    /// the coarse side has no component for the edge (the fine halo then stands in).
    pub(crate) fn corner(
        &self,
        cell: [u32; 3],
        line: [u32; 3],
        d: usize,
        q: usize,
    ) -> Option<CoarseCorner> {
        let last = self.res + 1;
        let halo = |a: usize| cell[a] == 0 || cell[a] == last;
        // In the halo across exactly one face (not along a chunk edge).
        let a = (0..3).find(|&a| halo(a))?;
        if (a + 1..3).any(halo) {
            return None;
        }
        let face = 2 * a + (cell[a] == last) as usize;
        let slab = self.faces.iter().find(|s| s.face == face)?;
        let sg = &slab.h.grid;
        // The edge on the fine lattice, relative to the slab's cell (0, 0, 0).
        let o = sg.offset * 2;
        let at = IVec3::from_array(line.map(|c| c as i32)) + self.grid.offset - o;
        let corners = sg.corners();
        let (coord, e) = seam_edge(at.to_array(), at[d], d, q, 1, |c| {
            (0..3).all(|k| c[k] < corners[k]) && slab.h.is_outside(c)
        })?;
        if (0..3).any(|k| coord[k] >= sg.cells[k]) {
            return None;
        }
        let i = *slab.index.get(&coord.map(|c| c as u16))? as usize;
        let c = slab.h.cells[i];
        let local = CellTables::get().cell(c.config, c.mask).edge_comp[e];
        if local == NO_COMP {
            return None;
        }
        let p = c.patch_base as usize + local as usize;
        // Where the coarser chunk's tree stores the vertex, and its normal.
        let lo = Vec3::from_array(coord.map(|v| v as f32));
        let hi = lo + Vec3::ONE;
        let stored = Comp::pack(slab.h.patch_vertex[p], slab.h.patch_normal[p], lo, hi, 0);
        Some(CoarseCorner {
            id: FIRST_ID - slab.base - p as u32,
            pos: self.grid.to_local(sg.to_world(stored.position(lo, hi))),
            normal: stored.normal(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kdtree::CELL;
    use crate::scenes;
    use crate::world::{Layout, Neighbourhood, World};

    /// Every coarse cell of a slab that lies in a coarser chunk along the face
    /// (the layer the seam takes) has the vertices the coarser chunk's tree
    /// stores for that cell, away from the slab's sides.
    #[test]
    fn a_slab_has_the_coarser_chunks_cells_and_vertices() {
        let (region, res) = (8, 8u32);
        let cell = 2.0 / (region as u32 * res) as f32;
        for (name, seed) in [("sphere", 3), ("gyroid", 5), ("csg_mix", 7)] {
            let scene = scenes::scene(name).unwrap();
            let field = &*scene.field;
            let layout = Layout::random(IVec3::ZERO, IVec3::splat(region), 2, 0.3, seed).unwrap();
            let mut w = World::new(
                Vec3::splat(-1.0),
                cell,
                res,
                layout,
                0.01,
                Settings::default(),
            )
            .unwrap();
            w.build_all(field).unwrap();
            let (mut same, mut moved, mut sides) = (0usize, 0usize, 0usize);
            for k in w.chunks() {
                let faces = Neighbourhood::of(w.layout(), &k).coarser_face_bits();
                let Some(coarser) =
                    Coarser::new(&w.chunk_grid(&k), field, &Settings::default(), res, faces)
                else {
                    assert_eq!(faces, 0, "{name} {k:?}");
                    continue;
                };
                for slab in &coarser.faces {
                    let a = slab.face / 2;
                    // The slab's middle layer: the coarser chunk's cells that
                    // touch the face (the slab's other layers are its second
                    // one and the fine side).
                    let layer = 1;
                    let sg = slab.h.grid;
                    for c in &slab.h.cells {
                        if c.coord[a] != layer {
                            continue;
                        }
                        let count = CellTables::get().cell(c.config, c.mask).count;
                        // The slab's sides reach past the face (the guard
                        // reads no cell there: they are the others' context).
                        let on_side = (0..3).any(|b| {
                            b != a && (c.coord[b] == 0 || c.coord[b] + 1 == sg.cells[b] as u16)
                        });
                        if on_side {
                            sides += count as usize;
                            continue;
                        }
                        let lattice = IVec3::from_array(c.coord.map(i32::from)) + sg.offset;
                        // The coarser chunk holding that cell (level of the slab).
                        let level = k.level + 1;
                        let level0 = IVec3::from_array(
                            [0, 1, 2].map(|i| (lattice[i] * (1 << level)).div_euclid(res as i32)),
                        );
                        let Some(owner) = w.layout().chunk_at(level0) else {
                            continue;
                        };
                        assert_eq!(owner.level, level, "{name} {k:?}: {owner:?}");
                        let tree = w.tree(&owner).expect("built");
                        let og = w.chunk_grid(&owner);
                        let at = lattice - og.offset;
                        let leaf = tree
                            .nodes
                            .iter()
                            .position(|n| n.axis == CELL && n.min.map(i32::from) == at.to_array());
                        let leaf = leaf.expect("the coarser chunk keeps cells on the face");
                        if tree.nodes[leaf].config != c.config {
                            moved += count as usize;
                            continue;
                        }
                        for local in 0..count {
                            let p = c.patch_base as usize + local as usize;
                            let lo = Vec3::from_array(c.coord.map(|v| v as f32));
                            let mine = Comp::pack(
                                slab.h.patch_vertex[p],
                                slab.h.patch_normal[p],
                                lo,
                                lo + Vec3::ONE,
                                0,
                            )
                            .position(lo, lo + Vec3::ONE);
                            let theirs = tree.comp_position(leaf as u32, local);
                            let d = sg.to_world(mine).distance(og.to_world(theirs)) / cell;
                            if d < 1e-3 {
                                same += 1;
                            } else {
                                moved += 1;
                            }
                        }
                    }
                }
            }
            println!(
                "{name}: {same} vertices as the coarser chunk's, {moved} moved, \
                 {sides} on the slab's sides (past the face, not read)"
            );
            assert!(same > 0, "{name}: no coarse cell compared");
            assert!(
                moved * 20 <= same,
                "{name}: {moved} of {} coarse vertices differ from the coarser chunk's",
                same + moved
            );
        }
    }
}
