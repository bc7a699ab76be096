//! The output mesh, and OBJ / binary PLY writers.

use crate::error::{Error, Result};
use crate::material::MaterialBlend;
use glam::{DVec3, Vec3};
use std::io::Write;

/// An indexed triangle mesh with per-vertex normals, counter-clockwise front faces
/// (normals point out of the solid). Reuse one across extractions: [`reset`]
/// keeps the buffers' capacity.
///
/// [`reset`]: IndexedMesh::reset
#[derive(Clone, Debug, Default, PartialEq)]
pub struct IndexedMesh {
    /// Vertex positions (world units).
    pub positions: Vec<Vec3>,
    /// Unit vertex normals.
    pub normals: Vec<Vec3>,
    /// Three indices per triangle.
    pub indices: Vec<u32>,
    /// One material blend per vertex when the field has materials
    /// ([`crate::material`]), empty otherwise.
    pub materials: Vec<MaterialBlend>,
}

impl IndexedMesh {
    /// Empties the mesh and keeps its capacity.
    pub fn reset(&mut self) {
        self.positions.clear();
        self.normals.clear();
        self.indices.clear();
        self.materials.clear();
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    /// Number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// Whether there is no triangle.
    pub fn is_empty(&self) -> bool {
        self.indices.is_empty()
    }

    /// Appends `other`, offsetting its indices. When either has materials the
    /// result has one per vertex (material 0 for the vertices of the one
    /// without).
    pub fn append(&mut self, other: &IndexedMesh) {
        let base = self.positions.len() as u32;
        if !(self.materials.is_empty() && other.materials.is_empty()) {
            self.materials
                .resize(self.positions.len(), MaterialBlend::default());
            self.materials.extend_from_slice(&other.materials);
            self.materials.resize(
                self.positions.len() + other.positions.len(),
                MaterialBlend::default(),
            );
        }
        self.positions.extend_from_slice(&other.positions);
        self.normals.extend_from_slice(&other.normals);
        self.indices.extend(other.indices.iter().map(|i| i + base));
    }

    /// Appends the polygon `ids` (a quad, or a triangle when neighbouring ids
    /// repeat), splitting a quad along the diagonal whose two triangles bend least
    /// (the shorter diagonal on a tie).
    pub fn push_polygon(&mut self, ids: [u32; 4]) {
        self.push_polygon_facing(ids, Vec3::ZERO);
    }

    /// [`IndexedMesh::push_polygon`] for the dual polygon of a grid edge whose
    /// surface faces `facing` (the edge's direction from its inside corner to its
    /// outside corner; zero when unknown). A quad is split along a diagonal whose
    /// two triangles both face that way ([`triangle_faces`]) when only one does, so
    /// no triangle is folded back over its neighbour: the four vertices lie in the
    /// four quadrants around the edge, so seen along the edge the quad is a simple
    /// polygon winding once around it, and one of its diagonals is inside it.
    /// Otherwise the diagonal whose triangles bend least wins.
    pub fn push_polygon_facing(&mut self, ids: [u32; 4], facing: Vec3) {
        let mut poly = [0u32; 4];
        let mut k = 0;
        for i in 0..4 {
            if ids[i] != ids[(i + 3) % 4] {
                poly[k] = ids[i];
                k += 1;
            }
        }
        match k {
            3 => self.indices.extend_from_slice(&poly[..3]),
            4 => {
                let [a, b] = quad_split(
                    poly.map(|i| self.positions[i as usize]),
                    poly.map(|i| self.normals[i as usize]),
                    facing,
                );
                for t in [a, b] {
                    self.indices.extend(t.map(|k| poly[k]));
                }
            }
            _ => {}
        }
    }

    /// Writes Wavefront OBJ text with normals. A mesh with materials gives each
    /// vertex the colour of its dominant material (`v x y z r g b`, the common
    /// vertex-colour extension, colours from [`crate::material::PALETTE`]).
    pub fn write_obj(&self, w: &mut impl Write) -> std::io::Result<()> {
        let mut w = std::io::BufWriter::new(w);
        writeln!(
            w,
            "# kdcontour: {} vertices, {} triangles",
            self.vertex_count(),
            self.triangle_count()
        )?;
        let coloured = self.materials.len() == self.positions.len() && !self.materials.is_empty();
        if coloured {
            writeln!(
                w,
                "# vertex colours: the dominant material (kdcontour::material::PALETTE)"
            )?;
        }
        for (i, p) in self.positions.iter().enumerate() {
            if coloured {
                let [r, g, b] = crate::material::colour(self.materials[i].dominant());
                writeln!(w, "v {} {} {} {r} {g} {b}", p.x, p.y, p.z)?;
            } else {
                writeln!(w, "v {} {} {}", p.x, p.y, p.z)?;
            }
        }
        for n in &self.normals {
            writeln!(w, "vn {} {} {}", n.x, n.y, n.z)?;
        }
        for t in self.indices.chunks_exact(3) {
            let (a, b, c) = (t[0] + 1, t[1] + 1, t[2] + 1);
            writeln!(w, "f {a}//{a} {b}//{b} {c}//{c}")?;
        }
        w.flush()
    }

    /// Writes binary little-endian PLY with normals. A mesh with materials adds
    /// the vertex properties `material0` to `material3` (uchar ids, heaviest
    /// first) and `weight0` to `weight3` (float, summing to 1).
    pub fn write_ply(&self, w: &mut impl Write) -> std::io::Result<()> {
        let mut w = std::io::BufWriter::new(w);
        let blended = self.materials.len() == self.positions.len() && !self.materials.is_empty();
        write!(
            w,
            "ply\nformat binary_little_endian 1.0\ncomment kdcontour\nelement vertex {}\n\
             property float x\nproperty float y\nproperty float z\n\
             property float nx\nproperty float ny\nproperty float nz\n",
            self.vertex_count(),
        )?;
        if blended {
            for k in 0..4 {
                writeln!(w, "property uchar material{k}")?;
            }
            for k in 0..4 {
                writeln!(w, "property float weight{k}")?;
            }
        }
        write!(
            w,
            "element face {}\nproperty list uchar uint vertex_indices\nend_header\n",
            self.triangle_count()
        )?;
        for (i, (p, n)) in self.positions.iter().zip(&self.normals).enumerate() {
            for f in [p.x, p.y, p.z, n.x, n.y, n.z] {
                w.write_all(&f.to_le_bytes())?;
            }
            if blended {
                let m = &self.materials[i];
                w.write_all(&m.ids)?;
                for f in m.weights {
                    w.write_all(&f.to_le_bytes())?;
                }
            }
        }
        for t in self.indices.chunks_exact(3) {
            w.write_all(&[3u8])?;
            for i in t {
                w.write_all(&i.to_le_bytes())?;
            }
        }
        w.flush()
    }

    /// Checks, before any work, that [`IndexedMesh::save`] can write `path`: a
    /// `.obj` or `.ply` name (any case) in a directory that takes new files. The
    /// file itself is not touched.
    pub fn check_path(path: &std::path::Path) -> Result<()> {
        Self::writer(path)?;
        crate::io::check_writable(path)
    }

    /// The writer for the extension of `path`.
    fn writer(path: &std::path::Path) -> Result<MeshWriter> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase());
        match ext.as_deref() {
            Some("obj") => Ok(|m, f| m.write_obj(f)),
            Some("ply") => Ok(|m, f| m.write_ply(f)),
            _ => Err(Error::Io {
                path: path.display().to_string(),
                message: "unknown mesh format; use a .obj or .ply extension".into(),
            }),
        }
    }

    /// Writes OBJ or PLY, chosen by the extension of `path` (any case). An unknown
    /// extension is refused before anything is created, and the mesh goes to a
    /// temporary file renamed over `path` once complete, so a failed write leaves
    /// an existing file as it was.
    pub fn save(&self, path: &std::path::Path) -> Result<()> {
        let write = Self::writer(path)?;
        crate::io::write_atomic(path, |w| write(self, w))
    }
}

/// Writes a mesh in one format.
type MeshWriter = fn(&IndexedMesh, &mut std::io::BufWriter<std::fs::File>) -> std::io::Result<()>;

/// The two triangles (corners of the quad, in its order) that
/// [`IndexedMesh::push_polygon_facing`] splits the quad `p` with vertex normals
/// `n` into: along the diagonal whose two triangles both face `facing`
/// ([`triangle_faces`]) when only one does, else along the one whose triangles
/// bend least (the shorter on a tie).
pub fn quad_split(p: [Vec3; 4], n: [Vec3; 4], facing: Vec3) -> [[usize; 3]; 2] {
    let s = QuadSplit::new(p, n, facing);
    let t = QuadSplit::TRIS;
    if s.takes_02(&p) {
        [t[0], t[1]]
    } else {
        [t[2], t[3]]
    }
}

/// The four triangles a quad can be split into ([`QuadSplit::TRIS`]: two along
/// the diagonal 0-2, two along 1-3), their (unnormalised, f64) normals, and
/// whether each faces its way ([`triangle_faces`]).
pub(crate) struct QuadSplit {
    pub cross: [DVec3; 4],
    pub faces: [bool; 4],
}

impl QuadSplit {
    /// Corners of the four triangles.
    pub const TRIS: [[usize; 3]; 4] = [[0, 1, 2], [0, 2, 3], [0, 1, 3], [1, 2, 3]];

    /// The triangles of quad `p` (vertex normals `n`) facing `facing`.
    pub fn new(p: [Vec3; 4], n: [Vec3; 4], facing: Vec3) -> Self {
        let q = p.map(|x| x.as_dvec3());
        let mut cross = [DVec3::ZERO; 4];
        let mut faces = [false; 4];
        for (k, [a, b, c]) in Self::TRIS.into_iter().enumerate() {
            cross[k] = (q[b] - q[a]).cross(q[c] - q[a]);
            faces[k] = normal_faces(cross[k], [n[a], n[b], n[c]], facing)
                && !degenerate([q[a], q[b], q[c]], cross[k]);
        }
        QuadSplit { cross, faces }
    }

    /// Whether the mesh splits quad `p` along 0-2 (see [`quad_split`]).
    pub fn takes_02(&self, p: &[Vec3; 4]) -> bool {
        let (ok02, ok13) = (
            self.faces[0] && self.faces[1],
            self.faces[2] && self.faces[3],
        );
        if ok02 != ok13 {
            return ok02;
        }
        let unit = self.cross.map(|c| c.normalize_or_zero());
        let bend02 = unit[0].dot(unit[1]);
        let bend13 = unit[2].dot(unit[3]);
        if (bend02 - bend13).abs() > 1e-6 {
            bend02 > bend13
        } else {
            let q = p.map(|x| x.as_dvec3());
            q[0].distance_squared(q[2]) <= q[1].distance_squared(q[3])
        }
    }
}

/// Whether the triangle `p` (counter-clockwise seen from outside) faces the way
/// the dual polygon it comes from must: its normal has a positive component along
/// `facing` (its grid edge, from the inside corner to the outside one) and does not
/// point against the sum of its vertices' normals (the field's gradients at their
/// crossings), when that sum is not zero. A triangle whose vertices are in a row
/// (to the rounding of their coordinates) faces no way.
pub fn triangle_faces(p: [Vec3; 3], n: [Vec3; 3], facing: Vec3) -> bool {
    let p = p.map(|x| x.as_dvec3());
    let cross = (p[1] - p[0]).cross(p[2] - p[0]);
    normal_faces(cross, n, facing) && !degenerate(p, cross)
}

/// The sine of a triangle's angles below which it is a line: three vertices
/// in a row (as leaves' vertices on an axis-aligned plane can be, at their
/// boxes' centers) give a triangle of no area, up to the rounding of their
/// coordinates, which faces no way.
const DEGENERATE_SIN: f64 = 1e-5;

/// Whether the triangle `p` (normal `cross`, unnormalised) is a line or a
/// point: its area is below [`DEGENERATE_SIN`] of its longest edge squared.
fn degenerate(p: [DVec3; 3], cross: DVec3) -> bool {
    let longest = (0..3)
        .map(|i| p[i].distance_squared(p[(i + 1) % 3]))
        .fold(0.0, f64::max);
    cross.length_squared() <= (DEGENERATE_SIN * longest).powi(2)
}

/// [`triangle_faces`] of a triangle whose (unnormalised) normal is `cross`.
fn normal_faces(cross: DVec3, n: [Vec3; 3], facing: Vec3) -> bool {
    cross.dot(facing.as_dvec3()) > 0.0 && cross.dot((n[0] + n[1] + n[2]).as_dvec3()) >= 0.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_quad_with_three_vertices_in_a_row_is_split_the_other_way() {
        // Leaves' vertices on the plane x = 118.4 of a 128-cell grid over
        // [-1, 1]^3, three of them in a row up to f32 rounding: the shorter
        // diagonal would give a triangle of no area.
        let p = [
            [118.4, 23.500008, 54.500023],
            [118.4, 24.500008, 55.500008],
            [118.4, 26.00003, 57.000015],
            [118.4, 20.000061, 60.00006],
        ]
        .map(|c| Vec3::from_array(c) / 64.0 - Vec3::ONE);
        let [a, b] = quad_split(p, [Vec3::X; 4], Vec3::X);
        assert_eq!([a, b], [[0, 1, 3], [1, 2, 3]]);
        for t in [a, b] {
            let q = t.map(|i| p[i]);
            assert!((q[1] - q[0]).cross(q[2] - q[0]).length() > 1e-4);
        }
    }

    #[test]
    fn ply_header_and_size() {
        let m = IndexedMesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            normals: vec![Vec3::Z; 3],
            indices: vec![0, 1, 2],
            materials: Vec::new(),
        };
        let mut buf = Vec::new();
        m.write_ply(&mut buf).unwrap();
        let header_end = buf.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
        assert_eq!(buf.len() - header_end, 3 * 24 + 13);
        let mut obj = Vec::new();
        m.write_obj(&mut obj).unwrap();
        let text = String::from_utf8(obj).unwrap();
        assert!(text.contains("f 1//1 2//2 3//3"));
        // With materials: four ids and four weights more per vertex, and colours.
        let mut m = m;
        m.materials = vec![
            crate::material::MaterialBlend::single(3),
            crate::material::MaterialBlend::mix(
                crate::material::MaterialBlend::single(1),
                crate::material::MaterialBlend::single(2),
                0.25,
            ),
            crate::material::MaterialBlend::single(0),
        ];
        let mut buf = Vec::new();
        m.write_ply(&mut buf).unwrap();
        let header_end = buf.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
        let header = String::from_utf8_lossy(&buf[..header_end]).to_string();
        assert!(header.contains("property uchar material3\nproperty float weight0"));
        assert_eq!(buf.len() - header_end, 3 * (24 + 4 + 16) + 13);
        // The second vertex: ids 1, 2 and weights 0.75, 0.25 after its 24 bytes.
        let v1 = header_end + 44 + 24;
        assert_eq!(&buf[v1..v1 + 2], &[1, 2]);
        assert_eq!(
            f32::from_le_bytes(buf[v1 + 4..v1 + 8].try_into().unwrap()),
            0.75
        );
        let mut obj = Vec::new();
        m.write_obj(&mut obj).unwrap();
        let text = String::from_utf8(obj).unwrap();
        assert!(text.contains("v 0 0 0 0.95 0.95 0.97"), "{text}");
    }

    #[test]
    fn a_refused_save_leaves_an_existing_file_untouched() {
        let dir = std::env::temp_dir().join(format!("kdcontour-mesh-save-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let keep = dir.join("keep.stl");
        std::fs::write(&keep, b"solid keep").unwrap();
        let err = IndexedMesh::default().save(&keep).unwrap_err();
        assert!(err.to_string().contains(".obj or .ply"), "{err}");
        assert_eq!(std::fs::read(&keep).unwrap(), b"solid keep");
        // Nor is a missing file created.
        let absent = dir.join("absent.stl");
        assert!(IndexedMesh::default().save(&absent).is_err());
        assert!(!absent.exists());
        // Upper-case extensions are accepted.
        let obj = dir.join("upper.OBJ");
        IndexedMesh::default().save(&obj).unwrap();
        assert!(std::fs::read(&obj).unwrap().starts_with(b"# kdcontour"));
        std::fs::remove_dir_all(&dir).ok();
    }
}
