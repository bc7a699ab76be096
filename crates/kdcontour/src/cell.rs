//! Dual Marching Cubes cell components (the paper's section 3, Nielson's DMC with a
//! consistent face rule).
//!
//! Corner `i` of a cell sits at offset `(i & 1, (i >> 1) & 1, (i >> 2) & 1)`. Bit `i`
//! of a cell's *config* is set when corner `i` is outside (value >= 0). Edge
//! `4 * a + k` runs along axis `a`; with `u = (a + 1) % 3`, `v = (a + 2) % 3`, its
//! low corner has offset `k & 1` along `u` and `k >> 1` along `v`. Face `2 * a + s`
//! is the face perpendicular to axis `a` at side `s`.
//!
//! A cell's surface components are the loops its contour makes on the cube's
//! surface; each loop is spanned by one patch, which gets one dual vertex. On a face
//! whose corners alternate in sign the contour has two segments, joined one of two
//! ways. The *resolution mask* of a cell has bit `f` set when face `f` joins its two
//! outside corners (the segments cut off the inside corners), clear when they are
//! separated. The mesher sets bit `f` exactly when both cells sharing the face
//! already join those two outside corners through their other cube edges
//! ([`CellTables::skeleton_joined`]). Both cells compute the same answer, and no
//! patch of one cell can then share two segments of a face with one patch of the
//! other, the configuration that makes plain DMC non-manifold. (If both cells joined
//! the outside corners and the face separated them, each cell would have one patch
//! through both segments. With the face joining them, the inside corners of the face
//! cannot also be joined behind it in either cell, because two paths across the cube
//! surface between alternating corners of a face would have to cross.)

use std::sync::OnceLock;

/// Components of one cell configuration under one resolution mask.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CellComps {
    /// Component of each edge, or [`NO_COMP`] when the edge has no sign change.
    pub edge_comp: [u8; 12],
    /// Number of components (0 to 4).
    pub count: u8,
}

/// The contour loops of one cell configuration under one resolution mask, each an
/// ordered cycle of crossing edges (consecutive edges share a face).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CellLoops {
    /// The edges of all loops, loop after loop.
    pub edges: [u8; 12],
    /// Number of edges of each loop.
    pub len: [u8; 4],
    /// Number of loops (equals [`CellComps::count`], loops in component order).
    pub count: u8,
}

impl CellLoops {
    /// The ordered edges of loop `k`.
    pub fn edges_of(&self, k: usize) -> &[u8] {
        let start: usize = self.len[..k].iter().map(|&l| l as usize).sum();
        &self.edges[start..start + self.len[k] as usize]
    }
}

/// Marks an edge without a sign change in [`CellComps::edge_comp`].
pub const NO_COMP: u8 = u8::MAX;

/// All Dual Marching Cubes tables, built once.
pub struct CellTables {
    /// Bit `f`: face `f` has alternating corner signs.
    pub ambiguous: [u8; 256],
    /// Bit `f`: face `f` is ambiguous and its two outside corners are joined by a
    /// path of outside cube edges (which never runs through face `f` itself).
    pub skeleton_joined: [u8; 256],
    /// Indexed by `config * 64 + mask`.
    pub comps: Vec<CellComps>,
    /// Indexed by `config * 64 + mask`.
    pub loops: Vec<CellLoops>,
}

/// The corner offset of corner `i`.
#[inline]
pub fn corner_offset(i: usize) -> [u32; 3] {
    [(i & 1) as u32, ((i >> 1) & 1) as u32, ((i >> 2) & 1) as u32]
}

/// The edge of a cell along `axis` whose low corner has offsets `bu`, `bv` along the
/// two other axes (`(axis + 1) % 3`, `(axis + 2) % 3`).
#[inline]
pub fn edge_index(axis: usize, bu: u32, bv: u32) -> usize {
    axis * 4 + (bu + 2 * bv) as usize
}

/// The two corners of edge `e` (low, high).
pub fn edge_corners(e: usize) -> (usize, usize) {
    let a = e / 4;
    let k = e % 4;
    let u = (a + 1) % 3;
    let v = (a + 2) % 3;
    let lo = ((k & 1) << u) | ((k >> 1) << v);
    (lo, lo | (1 << a))
}

/// The four corners of face `f` in cyclic order.
pub fn face_corners(f: usize) -> [usize; 4] {
    let a = f / 2;
    let s = f % 2;
    let u = (a + 1) % 3;
    let v = (a + 2) % 3;
    let c = |bu: usize, bv: usize| (s << a) | (bu << u) | (bv << v);
    [c(0, 0), c(1, 0), c(1, 1), c(0, 1)]
}

fn edge_between(c0: usize, c1: usize) -> usize {
    let diff = c0 ^ c1;
    let a = diff.trailing_zeros() as usize;
    let lo = c0 & c1;
    let u = (a + 1) % 3;
    let v = (a + 2) % 3;
    edge_index(a, ((lo >> u) & 1) as u32, ((lo >> v) & 1) as u32)
}

fn find(p: &mut [usize], mut x: usize) -> usize {
    while p[x] != x {
        p[x] = p[p[x]];
        x = p[x];
    }
    x
}

impl CellTables {
    fn build() -> Self {
        let mut ambiguous = [0u8; 256];
        let mut skeleton_joined = [0u8; 256];
        for config in 0..256usize {
            let outside = |c: usize| (config >> c) & 1 == 1;
            for f in 0..6 {
                let fc = face_corners(f);
                let s: [bool; 4] = fc.map(outside);
                if s[0] == s[2] && s[1] == s[3] && s[0] != s[1] {
                    ambiguous[config] |= 1 << f;
                    let (a, c) = if s[0] { (fc[0], fc[2]) } else { (fc[1], fc[3]) };
                    // Flood outside corners along cube edges from a.
                    let mut seen = 1u32 << a;
                    let mut stack = vec![a];
                    while let Some(x) = stack.pop() {
                        for axis in 0..3 {
                            let y = x ^ (1 << axis);
                            if outside(y) && seen & (1 << y) == 0 {
                                seen |= 1 << y;
                                stack.push(y);
                            }
                        }
                    }
                    if seen & (1 << c) != 0 {
                        skeleton_joined[config] |= 1 << f;
                    }
                }
            }
        }
        // Mask bits only matter on ambiguous faces: compute each distinct entry once.
        let mut comps = vec![CellComps::default(); 256 * 64];
        for config in 0..256usize {
            let amb = ambiguous[config] as usize;
            for mask in 0..64usize {
                comps[config * 64 + mask] = if mask & !amb == 0 {
                    Self::components(config, mask)
                } else {
                    comps[config * 64 + (mask & amb)]
                };
            }
        }
        let loops = (0..256 * 64)
            .map(|i| Self::loops_of(i / 64, i % 64, &comps[i]))
            .collect();
        CellTables {
            ambiguous,
            skeleton_joined,
            comps,
            loops,
        }
    }

    /// The face segments of a cell: pairs of crossing edges joined on a face.
    fn segments(config: usize, mask: usize) -> Vec<(usize, usize)> {
        let outside = |c: usize| (config >> c) & 1 == 1;
        let crossing = |e: usize| {
            let (a, b) = edge_corners(e);
            outside(a) != outside(b)
        };
        let mut out = Vec::new();
        for f in 0..6 {
            let fc = face_corners(f);
            let fe: [usize; 4] = std::array::from_fn(|i| edge_between(fc[i], fc[(i + 1) % 4]));
            let active: Vec<usize> = fe.iter().cloned().filter(|&e| crossing(e)).collect();
            match active.len() {
                2 => out.push((active[0], active[1])),
                4 => {
                    let join_outside = mask & (1 << f) != 0;
                    for i in 0..4 {
                        if outside(fc[i]) != join_outside {
                            out.push((fe[(i + 3) % 4], fe[i]));
                        }
                    }
                }
                _ => {}
            }
        }
        out
    }

    fn loops_of(config: usize, mask: usize, comps: &CellComps) -> CellLoops {
        let segs = Self::segments(config, mask);
        let mut out = CellLoops {
            count: comps.count,
            ..Default::default()
        };
        let mut n = 0;
        for k in 0..comps.count {
            let start = (0..12).find(|&e| comps.edge_comp[e] == k).unwrap();
            let (mut prev, mut cur) = (usize::MAX, start);
            loop {
                out.edges[n] = cur as u8;
                n += 1;
                out.len[k as usize] += 1;
                let next = segs
                    .iter()
                    .find_map(|&(a, b)| {
                        if a == cur && b != prev {
                            Some(b)
                        } else if b == cur && a != prev {
                            Some(a)
                        } else {
                            None
                        }
                    })
                    .unwrap();
                prev = cur;
                cur = next;
                if cur == start {
                    break;
                }
            }
        }
        out
    }

    fn components(config: usize, mask: usize) -> CellComps {
        let outside = |c: usize| (config >> c) & 1 == 1;
        let crossing = |e: usize| {
            let (a, b) = edge_corners(e);
            outside(a) != outside(b)
        };
        let mut parent: [usize; 12] = std::array::from_fn(|i| i);
        let union = |p: &mut [usize; 12], a: usize, b: usize| {
            let ra = find(p, a);
            let rb = find(p, b);
            if ra != rb {
                p[ra.max(rb)] = ra.min(rb);
            }
        };
        for f in 0..6 {
            let fc = face_corners(f);
            let fe: Vec<usize> = (0..4)
                .map(|i| edge_between(fc[i], fc[(i + 1) % 4]))
                .collect();
            let active: Vec<usize> = fe.iter().cloned().filter(|&e| crossing(e)).collect();
            match active.len() {
                0 => {}
                2 => union(&mut parent, active[0], active[1]),
                4 => {
                    // Corner i of the face lies between face edges i-1 and i.
                    let join_outside = mask & (1 << f) != 0;
                    for i in 0..4 {
                        // Cut off the corners of the sign that is *not* joined.
                        if outside(fc[i]) != join_outside {
                            union(&mut parent, fe[(i + 3) % 4], fe[i]);
                        }
                    }
                }
                n => unreachable!("a face has {n} crossing edges"),
            }
        }
        let mut out = CellComps {
            edge_comp: [NO_COMP; 12],
            count: 0,
        };
        let mut root_comp = [NO_COMP; 12];
        for e in 0..12 {
            if crossing(e) {
                let r = find(&mut parent, e);
                if root_comp[r] == NO_COMP {
                    root_comp[r] = out.count;
                    out.count += 1;
                }
                out.edge_comp[e] = root_comp[r];
            }
        }
        out
    }

    /// The tables, built on first use.
    pub fn get() -> &'static CellTables {
        static TABLES: OnceLock<CellTables> = OnceLock::new();
        TABLES.get_or_init(CellTables::build)
    }

    /// Components of a cell.
    #[inline]
    pub fn cell(&self, config: u8, mask: u8) -> &CellComps {
        &self.comps[config as usize * 64 + mask as usize]
    }
}

/// The face of a cell that its neighbour across face `f` sees (same plane).
#[inline]
pub fn opposite_face(f: usize) -> usize {
    f ^ 1
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn masks_only_matter_on_ambiguous_faces() {
        let t = CellTables::get();
        for config in 0..256usize {
            for mask in 0..64usize {
                assert_eq!(
                    t.comps[config * 64 + mask],
                    CellTables::components(config, mask),
                    "config {config} mask {mask}"
                );
            }
        }
    }

    #[test]
    fn loops_are_the_components_in_face_order() {
        let t = CellTables::get();
        for i in 0..256 * 64 {
            let (c, l) = (t.comps[i], t.loops[i]);
            assert_eq!(c.count, l.count);
            for k in 0..l.count as usize {
                let edges = l.edges_of(k);
                assert!(edges.len() >= 3);
                for (j, &e) in edges.iter().enumerate() {
                    assert_eq!(c.edge_comp[e as usize], k as u8);
                    // Consecutive edges share a face: their corners span 4 corners.
                    let next = edges[(j + 1) % edges.len()] as usize;
                    let (a, b) = edge_corners(e as usize);
                    let (x, y) = edge_corners(next);
                    let common = (a & b & x & y, a | b | x | y);
                    assert_eq!((common.1 & !common.0).count_ones(), 2, "{i}: {e} {next}");
                }
            }
        }
    }

    #[test]
    fn single_corner_has_one_component_of_three_edges() {
        let t = CellTables::get();
        for c in 0..8 {
            let cc = t.cell(1 << c, 0);
            assert_eq!(cc.count, 1);
            assert_eq!(cc.edge_comp.iter().filter(|&&x| x == 0).count(), 3);
        }
    }

    #[test]
    fn complement_swaps_resolution() {
        // Inverting all signs and the mask gives the same partition.
        let t = CellTables::get();
        for config in 0..256usize {
            for mask in 0..64usize {
                let a = t.comps[config * 64 + mask];
                let b = t.comps[(255 - config) * 64 + (63 - mask)];
                assert_eq!(a.count, b.count, "config {config} mask {mask}");
            }
        }
    }

    #[test]
    fn at_most_four_components_and_every_crossing_assigned() {
        let t = CellTables::get();
        for config in 0..256usize {
            for mask in 0..64usize {
                let cc = t.comps[config * 64 + mask];
                assert!(cc.count <= 4);
                for e in 0..12 {
                    let (a, b) = edge_corners(e);
                    let crossing = ((config >> a) ^ (config >> b)) & 1 == 1;
                    assert_eq!(crossing, cc.edge_comp[e] != NO_COMP);
                }
                // Every loop on a cube crosses at least 3 edges.
                for k in 0..cc.count {
                    assert!(cc.edge_comp.iter().filter(|&&x| x == k).count() >= 3);
                }
            }
        }
    }

    #[test]
    fn edge_helpers_agree() {
        for e in 0..12 {
            let (a, b) = edge_corners(e);
            assert_eq!(edge_between(a, b), e);
        }
        for f in 0..6 {
            let fc = face_corners(f);
            for i in 0..4 {
                assert_eq!((fc[i] ^ fc[(i + 1) % 4]).count_ones(), 1);
            }
        }
    }
}
