//! OBJ and PLY triangle meshes (input side; see [`mod@crate::mesh`] for writing).

use super::{bad, cut, read_limited};
use crate::budget::{Budget, DEFAULT_MEMORY_BUDGET};
use crate::error::Result;
use crate::field::mesh_sdf::MeshSdf;
use glam::Vec3;
use std::path::Path;

// The mesh type lives with the field that reads it (field must not depend on io).
pub use crate::field::mesh_sdf::TriMesh;

/// The largest mesh file read within the default budget: an eighth of
/// [`DEFAULT_MEMORY_BUDGET`] (512 MiB), as the parsed mesh and the distance
/// field's tree over it take several times the file's bytes (see
/// [`max_mesh_file`]).
pub const MAX_MESH_FILE: u64 = DEFAULT_MEMORY_BUDGET / 8;

/// The largest mesh file read within `budget`: an eighth of it.
pub fn max_mesh_file(budget: Budget) -> u64 {
    budget.get() / 8
}

/// Bytes a mesh of `vertices` vertices and at least `faces` triangles takes once
/// parsed and made a distance field ([`MeshSdf::estimate_bytes`]), checked against
/// `budget` before any element is read.
fn check_elements(vertices: u64, faces: u64, budget: Budget) -> std::result::Result<(), String> {
    let needed = vertices
        .saturating_mul(12)
        .saturating_add(faces.saturating_mul(12))
        .saturating_add(MeshSdf::estimate_bytes(vertices, faces));
    budget
        .check(
            format!("a mesh of {vertices} vertices and {faces} faces"),
            needed,
        )
        .map_err(|e| e.to_string())
}

/// A triangle mesh file format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshFormat {
    /// Wavefront OBJ.
    Obj,
    /// PLY, ascii or binary.
    Ply,
}

impl MeshFormat {
    /// The format of `path` by its extension (any case), or a message naming the
    /// valid ones.
    pub fn of(path: &Path) -> std::result::Result<MeshFormat, String> {
        match path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase())
            .as_deref()
        {
            Some("obj") => Ok(MeshFormat::Obj),
            Some("ply") => Ok(MeshFormat::Ply),
            _ => Err("unknown mesh format; use a .obj or .ply file".to_string()),
        }
    }
}

/// Loads an `.obj` or `.ply` file (chosen by extension, any case) within the
/// default budget ([`Budget::DEFAULT`]; see [`load_mesh_within`]).
pub fn load_mesh(path: &Path) -> Result<TriMesh> {
    load_mesh_within(path, Budget::DEFAULT)
}

/// Loads an `.obj` or `.ply` file (chosen by extension, any case); files over
/// [`max_mesh_file`]`(budget)` are refused without reading them whole, and
/// element counts whose mesh would not fit `budget` before any element is read.
pub fn load_mesh_within(path: &Path, budget: Budget) -> Result<TriMesh> {
    let format = MeshFormat::of(path).map_err(|m| bad(path, m))?;
    let bytes = read_limited(
        path,
        max_mesh_file(budget),
        "a mesh file may have (an eighth of the memory budget)",
    )?;
    mesh_from_bytes_within(&bytes, format, budget).map_err(|m| bad(path, m))
}

/// Parses a mesh file's bytes and checks the mesh: at least one face, every vertex
/// finite (within the default budget; see [`mesh_from_bytes_within`]).
pub fn mesh_from_bytes(bytes: &[u8], format: MeshFormat) -> std::result::Result<TriMesh, String> {
    mesh_from_bytes_within(bytes, format, Budget::DEFAULT)
}

/// Parses a mesh file's bytes and checks the mesh: at least one face, every vertex
/// finite. Its element counts are checked against `budget` before any element is
/// read (the header's for PLY, the `v` and `f` lines for OBJ).
pub fn mesh_from_bytes_within(
    bytes: &[u8],
    format: MeshFormat,
    budget: Budget,
) -> std::result::Result<TriMesh, String> {
    let mesh = match format {
        MeshFormat::Obj => {
            let text = String::from_utf8_lossy(bytes);
            let count = |tag: &str| {
                text.lines()
                    .filter(|l| l.split_whitespace().next() == Some(tag))
                    .count() as u64
            };
            check_elements(count("v"), count("f"), budget)?;
            parse_obj(&text)
        }
        MeshFormat::Ply => parse_ply_within(bytes, budget),
    }?;
    if mesh.triangles.is_empty() {
        return Err("the mesh has no faces".into());
    }
    if let Some(p) = mesh.positions.iter().find(|p| !p.is_finite()) {
        return Err(format!("vertex {p} is not finite"));
    }
    Ok(mesh)
}

/// Parses Wavefront OBJ text: `v` and `f` lines (`i`, `i/t`, `i//n`, `i/t/n`,
/// negative indices), polygons fanned into triangles; other lines are ignored.
pub fn parse_obj(text: &str) -> std::result::Result<TriMesh, String> {
    let mut m = TriMesh::default();
    for (n, line) in text.lines().enumerate() {
        let line_no = n + 1;
        let mut it = line.split_whitespace();
        match it.next() {
            Some("v") => {
                let mut c = [0f32; 3];
                for v in c.iter_mut() {
                    let tok = it
                        .next()
                        .ok_or(format!("line {line_no}: a vertex needs x, y and z"))?;
                    *v = tok
                        .parse()
                        .map_err(|_| format!("line {line_no}: `{}` is not a number", cut(tok)))?;
                }
                m.positions.push(Vec3::from(c));
            }
            Some("f") => {
                let mut idx = Vec::new();
                for tok in it {
                    let first = tok.split('/').next().unwrap_or("");
                    let i: i64 = first.parse().map_err(|_| {
                        format!("line {line_no}: `{}` is not a vertex index", cut(tok))
                    })?;
                    let count = m.positions.len() as i64;
                    let resolved = if i < 0 { count + i } else { i - 1 };
                    if i == 0 || resolved < 0 || resolved >= count {
                        return Err(format!(
                            "line {line_no}: vertex index {i} is out of range (the file has {count} vertices so far)"
                        ));
                    }
                    idx.push(resolved as u32);
                }
                if idx.len() < 3 {
                    return Err(format!("line {line_no}: a face needs at least 3 vertices"));
                }
                for k in 1..idx.len() - 1 {
                    m.triangles.push([idx[0], idx[k], idx[k + 1]]);
                }
            }
            _ => {}
        }
    }
    Ok(m)
}

#[derive(Clone, Copy)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(s: &str) -> Option<Scalar> {
        Some(match s {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }
    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }
    fn read(self, b: &[u8], big: bool) -> f64 {
        macro_rules! rd {
            ($t:ty, $n:expr) => {{
                let a: [u8; $n] = b[..$n].try_into().unwrap();
                (if big {
                    <$t>::from_be_bytes(a)
                } else {
                    <$t>::from_le_bytes(a)
                }) as f64
            }};
        }
        match self {
            Scalar::I8 => b[0] as i8 as f64,
            Scalar::U8 => b[0] as f64,
            Scalar::I16 => rd!(i16, 2),
            Scalar::U16 => rd!(u16, 2),
            Scalar::I32 => rd!(i32, 4),
            Scalar::U32 => rd!(u32, 4),
            Scalar::F32 => rd!(f32, 4),
            Scalar::F64 => rd!(f64, 8),
        }
    }
}

enum Prop {
    One(String, Scalar),
    List(String, Scalar, Scalar),
}

/// Parses PLY (ascii, binary little or big endian): the `vertex` element's x, y, z
/// and the `face` element's index list; other elements and properties are skipped
/// (within the default budget).
pub fn parse_ply(bytes: &[u8]) -> std::result::Result<TriMesh, String> {
    parse_ply_within(bytes, Budget::DEFAULT)
}

/// [`parse_ply`], with the header's vertex and face counts checked against
/// `budget` before any row is read.
fn parse_ply_within(bytes: &[u8], budget: Budget) -> std::result::Result<TriMesh, String> {
    let end = bytes
        .windows(10)
        .position(|w| w == b"end_header")
        .ok_or("not a PLY file: no end_header")?;
    let body_start = bytes[end..]
        .iter()
        .position(|&c| c == b'\n')
        .map(|i| end + i + 1)
        .ok_or("not a PLY file: nothing after end_header")?;
    let header = String::from_utf8_lossy(&bytes[..end]);
    let mut lines = header.lines();
    if lines.next().map(str::trim) != Some("ply") {
        return Err("not a PLY file: it must start with `ply`".into());
    }
    let mut format = None;
    let mut elements: Vec<(String, usize, Vec<Prop>)> = Vec::new();
    for line in lines {
        let t: Vec<&str> = line.split_whitespace().collect();
        match t.as_slice() {
            ["format", f, _] => format = Some(f.to_string()),
            ["element", name, n] => elements.push((
                cut(name),
                n.parse().map_err(|_| {
                    format!("bad element count `{}`; it must be a whole number", cut(n))
                })?,
                Vec::new(),
            )),
            ["property", "list", c, i, name] => {
                let (c, i) = (scalar(c)?, scalar(i)?);
                elements
                    .last_mut()
                    .ok_or("property before any element")?
                    .2
                    .push(Prop::List(name.to_string(), c, i));
            }
            ["property", ty, name] => {
                let s = scalar(ty)?;
                elements
                    .last_mut()
                    .ok_or("property before any element")?
                    .2
                    .push(Prop::One(name.to_string(), s));
            }
            _ => {}
        }
    }
    let format = format.ok_or("PLY header has no format line")?;
    for (name, _, props) in &elements {
        let has = |axis: &str| {
            props
                .iter()
                .any(|p| matches!(p, Prop::One(n, _) if n.as_str() == axis))
        };
        if name == "vertex" && !(has("x") && has("y") && has("z")) {
            return Err("the vertex element needs x, y and z properties".into());
        }
    }
    // Rows of an element without properties hold nothing: skip them, whatever
    // their count says.
    elements.retain(|(_, _, props)| !props.is_empty());
    let count = |want: &str| {
        elements
            .iter()
            .filter(|(name, _, _)| name == want)
            .fold(0u64, |sum, (_, n, _)| sum.saturating_add(*n as u64))
    };
    // After the file is known to hold the rows, whose counts must fit the budget.
    let fits = || check_elements(count("vertex"), count("face"), budget);
    let body = &bytes[body_start..];
    let mut m = TriMesh::default();
    let mut vertex_count = 0usize;
    match format.as_str() {
        "ascii" => {
            let text = String::from_utf8_lossy(body);
            let mut rows = text.lines().filter(|l| !l.trim().is_empty());
            // Every row is a line: refuse counts the file cannot hold before reading.
            let lines = rows.clone().count();
            let claimed = elements
                .iter()
                .try_fold(0usize, |sum, (_, n, _)| sum.checked_add(*n));
            if claimed.is_none_or(|c| c > lines) {
                return Err(format!(
                    "the header claims {} rows but the file has {lines} lines after end_header; fix the element counts",
                    claimed.map_or("more than 2^64".to_string(), |c| c.to_string())
                ));
            }
            fits()?;
            for (name, n, props) in &elements {
                for r in 0..*n {
                    let row = rows
                        .next()
                        .ok_or(format!("truncated: {name} {r} of {n} is missing"))?;
                    let mut tok = row.split_whitespace();
                    let mut num = |_: Scalar| -> std::result::Result<f64, String> {
                        let t = tok
                            .next()
                            .ok_or(format!("{name} {r}: a value is missing"))?;
                        t.parse()
                            .map_err(|_| format!("{name} {r}: `{}` is not a number", cut(t)))
                    };
                    read_row(name, props, &mut m, &mut vertex_count, &mut num)?;
                }
            }
        }
        "binary_little_endian" | "binary_big_endian" => {
            let big = format == "binary_big_endian";
            // The fewest bytes each element's rows take (lists empty): refuse
            // counts the file cannot hold before reading a row.
            let mut least_before = 0usize;
            for (name, n, props) in &elements {
                let least: usize = props
                    .iter()
                    .map(|p| match p {
                        Prop::One(_, s) | Prop::List(_, s, _) => s.size(),
                    })
                    .sum();
                let left = body.len().saturating_sub(least_before);
                match n.checked_mul(least).filter(|b| *b <= left) {
                    Some(b) => least_before += b,
                    None => {
                        return Err(format!(
                            "element {name} claims {n} rows of at least {least} bytes, but only {left} bytes follow; fix the element count"
                        ))
                    }
                }
            }
            fits()?;
            let mut at = 0usize;
            for (name, n, props) in &elements {
                for r in 0..*n {
                    let mut num_at = |s: Scalar| -> std::result::Result<f64, String> {
                        let b = body.get(at..at + s.size()).ok_or(format!(
                            "truncated: {name} {r} of {n} runs past the end of the file"
                        ))?;
                        at += s.size();
                        Ok(s.read(b, big))
                    };
                    read_row(name, props, &mut m, &mut vertex_count, &mut num_at)?;
                }
            }
        }
        other => return Err(format!("unknown PLY format `{}`", cut(other))),
    }
    Ok(m)
}

/// A PLY scalar type by name, or a message naming the valid ones.
fn scalar(name: &str) -> std::result::Result<Scalar, String> {
    Scalar::parse(name).ok_or(format!(
        "unknown PLY type `{}`; use char, uchar, short, ushort, int, uint, float or double (or int8 ... float64)",
        cut(name)
    ))
}

fn push_face(
    m: &mut TriMesh,
    idx: &[f64],
    vertex_count: usize,
    face: usize,
) -> std::result::Result<(), String> {
    if idx.len() < 3 {
        return Err(format!(
            "face {face} has {} vertices; at least 3 are needed",
            idx.len()
        ));
    }
    for &i in idx {
        if i < 0.0 || i as usize >= vertex_count || i.fract() != 0.0 {
            return Err(format!("face {face}: vertex index {i} is out of range (the file has {vertex_count} vertices)"));
        }
    }
    for k in 1..idx.len() - 1 {
        m.triangles
            .push([idx[0] as u32, idx[k] as u32, idx[k + 1] as u32]);
    }
    Ok(())
}

/// Reads the next number of the type given (ascii ignores the type).
type NextFn<'a> = dyn FnMut(Scalar) -> std::result::Result<f64, String> + 'a;

fn read_row(
    name: &str,
    props: &[Prop],
    m: &mut TriMesh,
    vertex_count: &mut usize,
    next: &mut NextFn,
) -> std::result::Result<(), String> {
    let mut xyz = [0f32; 3];
    for p in props {
        match p {
            Prop::One(pn, s) => {
                let v = next(*s)?;
                if name == "vertex" {
                    match pn.as_str() {
                        "x" => xyz[0] = v as f32,
                        "y" => xyz[1] = v as f32,
                        "z" => xyz[2] = v as f32,
                        _ => {}
                    }
                }
            }
            Prop::List(pn, c, i) => {
                let count = next(*c)? as usize;
                let idx: Vec<f64> = (0..count)
                    .map(|_| next(*i))
                    .collect::<std::result::Result<_, _>>()?;
                if name == "face" && (pn == "vertex_indices" || pn == "vertex_index") {
                    push_face(m, &idx, *vertex_count, m.triangles.len())?;
                }
            }
        }
    }
    if name == "vertex" {
        m.positions.push(Vec3::from(xyz));
        *vertex_count += 1;
    }
    Ok(())
}
