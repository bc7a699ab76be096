//! 1-D: dikes. Every line of samples along each axis of a block is organised as a
//! binary tree of *dikes* (aligned runs of `2^k` unit edges). A dike's occupancy
//! says how the isosurface crosses it; its *simple dike array* entry says how long
//! the length-maximal simple dike starting at each sample is.

/// Occupancy: the dike is not crossed (both ends have one sign, nothing between).
pub(super) const NONE: u8 = 0b00;
/// Occupancy: crossed once, from inside (`δ`, value < 0) to outside (`ε`, >= 0).
pub(super) const UP: u8 = 0b01;
/// Occupancy: crossed once, from outside to inside.
pub(super) const DOWN: u8 = 0b10;
/// Occupancy: crossed more than once (not simple). `UP | DOWN`, so a parent's
/// occupancy is the bitwise or of its children's, as in the paper.
pub(super) const NON_SIMPLE: u8 = UP | DOWN;

/// The signs of a block's samples, `(ext + 1)^3` of them, x fastest (local coords).
pub(super) struct Signs {
    /// Cells per axis of the block (at most the block size).
    pub ext: [u32; 3],
    /// `true` where the sample is outside (value >= 0).
    pub outside: Vec<bool>,
}

impl Signs {
    /// Whether local sample `p` is outside.
    #[inline]
    pub fn at(&self, p: [u32; 3]) -> bool {
        let [ex, ey, _] = self.ext;
        self.outside[(p[0] + (ex + 1) * (p[1] + (ey + 1) * p[2])) as usize]
    }
}

/// The occupancy of the unit edge from a sample of sign `a` to one of sign `b`.
#[inline]
pub(super) fn leaf_occ(a: bool, b: bool) -> u8 {
    match (a, b) {
        (false, true) => UP,
        (true, false) => DOWN,
        _ => NONE,
    }
}

/// The simple dike arrays of one block, one per axis.
pub(super) struct Dikes {
    ext: [u32; 3],
    /// Per axis, per line, per start sample: the level `k` of the length-maximal
    /// simple dike (`2^k` unit edges) that starts there.
    level: [Vec<u8>; 3],
}

impl Dikes {
    /// Builds every line's binary tree over the block's samples (`2^block_log`
    /// cells per side; a partial block at the grid's end pads its lines with
    /// non-simple leaves, so no dike crosses the grid's end).
    pub fn new(signs: &Signs, block_log: u32) -> Self {
        let ext = signs.ext;
        let level = [0, 1, 2].map(|a| {
            let (u, v) = ((a + 1) % 3, (a + 2) % 3);
            let n = ext[a] as usize;
            let lines = ((ext[u] + 1) * (ext[v] + 1)) as usize;
            let mut out = vec![0u8; n * lines];
            let mut occ = vec![NON_SIMPLE; 1 << block_log];
            for lv in 0..=ext[v] {
                for lu in 0..=ext[u] {
                    let line = (lu + (ext[u] + 1) * lv) as usize;
                    let at = |i: u32| {
                        let mut p = [0; 3];
                        p[a] = i;
                        p[u] = lu;
                        p[v] = lv;
                        signs.at(p)
                    };
                    occ.fill(NON_SIMPLE);
                    for i in 0..n {
                        occ[i] = leaf_occ(at(i as u32), at(i as u32 + 1));
                    }
                    simple_dike_array(&mut occ, &mut out[line * n..(line + 1) * n]);
                }
            }
            out
        });
        Dikes { ext, level }
    }

    /// The level of the length-maximal simple dike along `axis` starting at local
    /// sample `p`.
    #[inline]
    pub fn level(&self, axis: usize, p: [u32; 3]) -> u8 {
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        let n = self.ext[axis];
        let line = p[u] + (self.ext[u] + 1) * p[v];
        self.level[axis][(line * n + p[axis]) as usize]
    }
}

/// Fills `simple[i]` with the level of the length-maximal simple dike that starts
/// at sample `i`, from the leaf occupancies in `occ` (overwritten, level by level,
/// with the occupancies of the tree's upper nodes).
///
/// The paper labels dikes breadth first and keeps the label of the length-maximal
/// simple dike, so that the max of two labels is the shorter dike; a level is the
/// same information, with min in place of max.
fn simple_dike_array(occ: &mut [u8], simple: &mut [u8]) {
    simple.fill(0);
    let mut nodes = occ.len();
    let mut k = 0u8;
    while nodes > 1 {
        nodes /= 2;
        k += 1;
        for j in 0..nodes {
            occ[j] = occ[2 * j] | occ[2 * j + 1];
            let start = j << k;
            if occ[j] != NON_SIMPLE && start < simple.len() {
                simple[start] = k;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn levels(signs: &[bool], block: usize) -> Vec<u8> {
        let mut occ = vec![NON_SIMPLE; block];
        for i in 0..signs.len() - 1 {
            occ[i] = leaf_occ(signs[i], signs[i + 1]);
        }
        let mut simple = vec![0; signs.len() - 1];
        simple_dike_array(&mut occ, &mut simple);
        simple
    }

    #[test]
    fn a_dike_is_simple_while_it_is_crossed_at_most_once() {
        // - - - + + + + - - : crossings on edges 2 and 6.
        let s = [false, false, false, true, true, true, true, false, false];
        // Start 0: [0, 4] holds edge 2 only; [0, 8] holds both.
        // Start 4: [4, 8] holds edge 6 only. Odd starts: unit dikes.
        assert_eq!(levels(&s, 8), vec![2, 0, 1, 0, 2, 0, 1, 0]);
    }

    #[test]
    fn a_partial_line_never_has_a_dike_past_its_end() {
        let s = [true; 6]; // 5 edges in a block of 8
        assert_eq!(levels(&s, 8), vec![2, 0, 1, 0, 0]);
    }
}
