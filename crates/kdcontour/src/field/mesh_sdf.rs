//! A triangle mesh as a signed distance field: the distance to the nearest
//! triangle (a BVH query), signed by the generalised winding number, so the sign
//! stays right on meshes with holes, gaps or flipped patches (Jacobson et al. 2013),
//! evaluated with the dipole approximation of Barill et al. 2018 for far BVH nodes.

use super::Field;
use glam::Vec3;

/// A triangle soup with shared vertices.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriMesh {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Vertex indices, counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
}

impl TriMesh {
    /// The box around the vertices.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.positions
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(*p), hi.max(*p))
            })
    }
}

/// Triangles per BVH leaf.
const LEAF: usize = 4;
/// A BVH node is approximated by its dipole when the query is farther than this
/// many node radii from its center. At 2 the winding number is within 1e-2 of the
/// exact sum on the test meshes, far below the 0.5 that decides the sign.
const BETA: f32 = 2.0;

struct Node {
    lo: Vec3,
    hi: Vec3,
    /// Children (internal) or a triangle range start (leaf).
    a: u32,
    b: u32,
    leaf: bool,
    /// Area-weighted normal sum (half the cross products).
    normal: Vec3,
    /// Area-weighted centroid.
    center: Vec3,
    radius: f32,
}

impl TriMesh {
    /// The volume enclosed, by the divergence theorem: positive when the faces
    /// turn counter-clockwise seen from outside, negative when every face is
    /// reversed (then the winding number is -1 inside). With holes it is the
    /// volume of the mesh closed by fans to the origin, whose sign still follows
    /// the orientation of most of the faces.
    pub fn signed_volume(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.positions[i as usize].as_dvec3());
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }
}

/// A signed distance field of a triangle mesh (negative inside).
pub struct MeshSdf {
    v: Vec<Vec3>,
    tris: Vec<[u32; 3]>,
    nodes: Vec<Node>,
    bounds: (Vec3, Vec3),
    inside_out: bool,
}

impl MeshSdf {
    /// Builds the BVH. The mesh should be oriented counter-clockwise seen from
    /// outside; holes are tolerated. A mesh turned inside out (every face
    /// reversed: a negative [`TriMesh::signed_volume`]) would have winding number
    /// -1 inside, read as outside everywhere, and mesh to nothing: its faces are
    /// turned back, and [`MeshSdf::inside_out`] says so (callers should warn).
    pub fn new(mesh: &TriMesh) -> Self {
        let inside_out = mesh.signed_volume() < 0.0;
        let mut tris = mesh.triangles.clone();
        if inside_out {
            for t in &mut tris {
                t.swap(1, 2);
            }
        }
        let v = mesh.positions.clone();
        let mut nodes = Vec::new();
        let n = tris.len();
        build(&v, &mut tris, 0, n, &mut nodes);
        MeshSdf {
            bounds: mesh.bounds(),
            v,
            tris,
            nodes,
            inside_out,
        }
    }

    /// Whether the input mesh was inside out and its faces were turned back.
    pub fn inside_out(&self) -> bool {
        self.inside_out
    }

    /// Bytes a field over a mesh of `vertices` vertices and `triangles` triangles
    /// holds (its copy of the mesh and, at most, two tree nodes per triangle), for
    /// checking a mesh against a memory budget before it is built.
    pub fn estimate_bytes(vertices: u64, triangles: u64) -> u64 {
        let node = std::mem::size_of::<Node>() as u64;
        vertices
            .saturating_mul(12)
            .saturating_add(triangles.saturating_mul(12 + 2 * node))
    }

    /// Bytes this field holds (see [`MeshSdf::estimate_bytes`]).
    pub fn held_bytes(&self) -> u64 {
        let node = std::mem::size_of::<Node>() as u64;
        (self.v.capacity() * 12 + self.tris.capacity() * 12) as u64
            + self.nodes.capacity() as u64 * node
    }

    /// The mesh's bounding box.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.bounds
    }

    fn tri(&self, t: usize) -> (Vec3, Vec3, Vec3) {
        let [a, b, c] = self.tris[t];
        (self.v[a as usize], self.v[b as usize], self.v[c as usize])
    }

    /// Distance to the nearest triangle and the nearest point on it.
    pub fn closest(&self, p: Vec3) -> (f32, Vec3, usize) {
        let mut best = (f32::INFINITY, p, 0usize);
        let mut stack = vec![0u32];
        while let Some(i) = stack.pop() {
            let nd = &self.nodes[i as usize];
            let d = (nd.lo - p).max(p - nd.hi).max(Vec3::ZERO).length_squared();
            if d >= best.0 * best.0 {
                continue;
            }
            if nd.leaf {
                for t in nd.a as usize..nd.b as usize {
                    let (a, b, c) = self.tri(t);
                    let q = closest_on_triangle(p, a, b, c);
                    let dd = p.distance(q);
                    if dd < best.0 {
                        best = (dd, q, t);
                    }
                }
            } else {
                // Nearer child last, so it is popped first.
                let (l, r) = (nd.a, nd.b);
                let dl = box_dist(&self.nodes[l as usize], p);
                let dr = box_dist(&self.nodes[r as usize], p);
                if dl < dr {
                    stack.push(r);
                    stack.push(l);
                } else {
                    stack.push(l);
                    stack.push(r);
                }
            }
        }
        best
    }

    /// Generalised winding number at `p` (1 inside a closed outward mesh, 0 out).
    pub fn winding_number(&self, p: Vec3) -> f32 {
        let mut w = 0f64;
        let mut stack = vec![0u32];
        while let Some(i) = stack.pop() {
            let nd = &self.nodes[i as usize];
            let r = nd.center - p;
            let dist = r.length();
            if dist > BETA * nd.radius {
                w +=
                    (nd.normal.dot(r) / (dist * dist * dist)) as f64 / (4.0 * std::f64::consts::PI);
            } else if nd.leaf {
                for t in nd.a as usize..nd.b as usize {
                    let (a, b, c) = self.tri(t);
                    w += solid_angle(p, a, b, c) / (4.0 * std::f64::consts::PI);
                }
            } else {
                stack.push(nd.a);
                stack.push(nd.b);
            }
        }
        w as f32
    }
}

fn box_dist(nd: &Node, p: Vec3) -> f32 {
    (nd.lo - p).max(p - nd.hi).max(Vec3::ZERO).length_squared()
}

fn build(
    v: &[Vec3],
    tris: &mut [[u32; 3]],
    start: usize,
    end: usize,
    nodes: &mut Vec<Node>,
) -> u32 {
    let idx = nodes.len() as u32;
    let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    let (mut clo, mut chi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    let mut normal = Vec3::ZERO;
    let mut center = Vec3::ZERO;
    let mut area = 0.0;
    for t in &tris[start..end] {
        let (a, b, c) = (v[t[0] as usize], v[t[1] as usize], v[t[2] as usize]);
        lo = lo.min(a).min(b).min(c);
        hi = hi.max(a).max(b).max(c);
        let ct = (a + b + c) / 3.0;
        clo = clo.min(ct);
        chi = chi.max(ct);
        let n = (b - a).cross(c - a) * 0.5;
        let ar = n.length();
        normal += n;
        center += ct * ar;
        area += ar;
    }
    let center = if area > 0.0 {
        center / area
    } else {
        (lo + hi) * 0.5
    };
    let radius = (hi - center).max(center - lo).length();
    nodes.push(Node {
        lo,
        hi,
        a: start as u32,
        b: end as u32,
        leaf: true,
        normal,
        center,
        radius,
    });
    if end - start > LEAF {
        let axis = (chi - clo).max_position();
        let mid = (start + end) / 2;
        let key =
            |t: &[u32; 3]| v[t[0] as usize][axis] + v[t[1] as usize][axis] + v[t[2] as usize][axis];
        tris[start..end].select_nth_unstable_by(mid - start, |x, y| key(x).total_cmp(&key(y)));
        let l = build(v, tris, start, mid, nodes);
        let r = build(v, tris, mid, end, nodes);
        let nd = &mut nodes[idx as usize];
        nd.leaf = false;
        nd.a = l;
        nd.b = r;
    }
    idx
}

/// Solid angle of triangle `abc` seen from `p` (Van Oosterom and Strackee), signed
/// positive when `p` is behind the triangle's counter-clockwise normal.
fn solid_angle(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> f64 {
    let (a, b, c) = ((a - p).as_dvec3(), (b - p).as_dvec3(), (c - p).as_dvec3());
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let det = a.dot(b.cross(c));
    let den = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
    2.0 * det.atan2(den)
}

/// The closest point to `p` on triangle `abc` (Ericson, Real-Time Collision
/// Detection, 5.1.5).
fn closest_on_triangle(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> Vec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

impl Field for MeshSdf {
    fn value(&self, p: Vec3) -> f32 {
        let (d, _, _) = self.closest(p);
        if self.winding_number(p) > 0.5 {
            -d
        } else {
            d
        }
    }

    fn gradient(&self, p: Vec3) -> Vec3 {
        let (d, q, t) = self.closest(p);
        let sign = if self.winding_number(p) > 0.5 {
            -1.0
        } else {
            1.0
        };
        if d > 1e-7 {
            (p - q) / d * sign
        } else {
            let (a, b, c) = self.tri(t);
            (b - a).cross(c - a).normalize_or_zero()
        }
    }

    fn lipschitz(&self) -> Option<f32> {
        // The distance is 1-Lipschitz; the winding-number sign only flips across
        // the surface, or across the cap a hole would need, where a skipped block
        // takes one sign for all its corners (the cap snaps to the block's side).
        Some(1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cube() -> TriMesh {
        let p = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
        let positions = vec![
            p(-0.5, -0.5, -0.5),
            p(0.5, -0.5, -0.5),
            p(0.5, 0.5, -0.5),
            p(-0.5, 0.5, -0.5),
            p(-0.5, -0.5, 0.5),
            p(0.5, -0.5, 0.5),
            p(0.5, 0.5, 0.5),
            p(-0.5, 0.5, 0.5),
        ];
        let triangles = vec![
            [0, 2, 1],
            [0, 3, 2],
            [4, 5, 6],
            [4, 6, 7],
            [0, 1, 5],
            [0, 5, 4],
            [2, 3, 7],
            [2, 7, 6],
            [1, 2, 6],
            [1, 6, 5],
            [0, 4, 7],
            [0, 7, 3],
        ];
        TriMesh {
            positions,
            triangles,
        }
    }

    #[test]
    fn cube_distance_and_sign() {
        let sdf = MeshSdf::new(&cube());
        assert!((sdf.value(Vec3::ZERO) + 0.5).abs() < 1e-6);
        assert!((sdf.value(Vec3::new(1.0, 0.0, 0.0)) - 0.5).abs() < 1e-6);
        assert!((sdf.winding_number(Vec3::new(0.1, 0.2, 0.0)) - 1.0).abs() < 1e-3);
        assert!(sdf.winding_number(Vec3::new(3.0, 0.2, 0.0)).abs() < 1e-3);
    }

    #[test]
    fn an_inside_out_mesh_is_turned_back() {
        let mut m = cube();
        assert!((m.signed_volume() - 1.0).abs() < 1e-9);
        assert!(!MeshSdf::new(&m).inside_out());
        for t in &mut m.triangles {
            t.swap(0, 1);
        }
        assert!((m.signed_volume() + 1.0).abs() < 1e-9);
        let sdf = MeshSdf::new(&m);
        assert!(sdf.inside_out());
        assert!((sdf.winding_number(Vec3::new(0.1, 0.2, 0.0)) - 1.0).abs() < 1e-3);
        assert!((sdf.value(Vec3::ZERO) + 0.5).abs() < 1e-6);
        assert!(sdf.value(Vec3::new(1.0, 0.0, 0.0)) > 0.0);
    }

    #[test]
    fn a_hole_keeps_a_usable_sign() {
        let mut m = cube();
        m.triangles.truncate(10); // drop one face: a square hole
        let sdf = MeshSdf::new(&m);
        assert!(sdf.value(Vec3::ZERO) < 0.0);
        assert!(sdf.value(Vec3::new(0.0, 0.0, 2.0)) > 0.0);
        assert!(sdf.value(Vec3::new(-2.0, 0.0, 0.0)) > 0.0);
    }
}
