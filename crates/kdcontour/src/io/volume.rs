//! Raw voxel files, and a synthetic CT phantom; NIfTI-1 (`.nii`, `.nii.gz`) is
//! read in [`super::nifti`] and re-exported here.

use super::{bad, read_limited};
use crate::budget::Budget;
use crate::error::Result;
use crate::field::volume::{Inside, SampledVolume};
use glam::{UVec3, Vec3};
use std::path::Path;

pub use super::nifti::{
    is_nifti, load_nifti, load_nifti_within, parse_nifti, read_nifti, write_nifti,
};

/// Voxel storage types of raw files.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VoxelType {
    /// Unsigned 8-bit.
    U8,
    /// Unsigned 16-bit, little endian.
    U16,
    /// Signed 16-bit, little endian (CT in Hounsfield units).
    I16,
    /// 32-bit float, little endian.
    F32,
}

impl VoxelType {
    /// Bytes per voxel.
    pub fn size(self) -> usize {
        match self {
            VoxelType::U8 => 1,
            VoxelType::U16 | VoxelType::I16 => 2,
            VoxelType::F32 => 4,
        }
    }

    /// Parses `u8`, `u16`, `i16` or `f32`.
    pub fn parse(s: &str) -> Option<Self> {
        Some(match s {
            "u8" => VoxelType::U8,
            "u16" => VoxelType::U16,
            "i16" => VoxelType::I16,
            "f32" => VoxelType::F32,
            _ => return None,
        })
    }
}

fn check_dims(dims: UVec3) -> std::result::Result<(), String> {
    if dims.min_element() < 2 {
        return Err(format!(
            "dims {}x{}x{}: every axis needs at least 2 voxels",
            dims.x, dims.y, dims.z
        ));
    }
    Ok(())
}

fn check_spacing(spacing: Vec3) -> std::result::Result<(), String> {
    if !(spacing.is_finite() && spacing.min_element() > 0.0) {
        return Err(format!(
            "voxel spacing {spacing} must be positive and finite along every axis"
        ));
    }
    Ok(())
}

/// The voxel count of `dims` and the bytes they take stored `size` bytes each,
/// checked before anything is allocated: the product must not overflow, and the
/// stored bytes plus `extra` plus the decoded `f32` voxels must fit in `budget`.
pub(crate) fn voxel_sizes(
    dims: UVec3,
    size: u64,
    extra: u64,
    budget: Budget,
) -> std::result::Result<(usize, usize), String> {
    let count = (dims.x as u64)
        .checked_mul(dims.y as u64)
        .and_then(|c| c.checked_mul(dims.z as u64));
    // An overflowing size compares as u64::MAX bytes: over any budget.
    let needed = count
        .and_then(|c| c.checked_mul(size + 4))
        .and_then(|b| b.checked_add(extra))
        .unwrap_or(u64::MAX);
    let what = format!("a volume of {}x{}x{} voxels", dims.x, dims.y, dims.z);
    budget.check(what, needed).map_err(|e| e.to_string())?;
    let count = count.expect("a count within the budget does not overflow");
    Ok((count as usize, (count * size) as usize))
}

/// Loads a headerless voxel file of `dims` voxels of type `ty` (x fastest), within
/// the default budget ([`Budget::DEFAULT`]; see [`load_raw_within`]).
pub fn load_raw(
    path: &Path,
    dims: UVec3,
    ty: VoxelType,
    spacing: Vec3,
    iso: f32,
    inside: Inside,
) -> Result<SampledVolume> {
    let layout = RawLayout { dims, ty, spacing };
    load_raw_within(path, layout, iso, inside, Budget::DEFAULT)
}

/// Loads a headerless voxel file laid out as `layout` says. The stored and
/// decoded sizes are checked against `budget` before reading, and no more than
/// the voxels the layout describes (plus one byte, to tell a longer file) is
/// read.
pub fn load_raw_within(
    path: &Path,
    layout: RawLayout,
    iso: f32,
    inside: Inside,
    budget: Budget,
) -> Result<SampledVolume> {
    let RawLayout { dims, ty, spacing } = layout;
    check_dims(dims)
        .and_then(|()| check_spacing(spacing))
        .map_err(|m| bad(path, m))?;
    let (_, need) = voxel_sizes(dims, ty.size() as u64, 0, budget).map_err(|m| bad(path, m))?;
    let bytes = read_limited(
        path,
        need as u64,
        &format!(
            "{}x{}x{} voxels of {ty:?} take; check --dims and --type",
            dims.x, dims.y, dims.z
        ),
    )?;
    decode_raw(&bytes, layout, iso, inside, budget).map_err(|m| bad(path, m))
}

/// Decodes a headerless voxel file's bytes: `dims` voxels of type `ty`, x fastest,
/// exactly as many bytes as they take, within the default budget. Every failure
/// is a message saying what to change.
pub fn raw_from_bytes(
    bytes: &[u8],
    dims: UVec3,
    ty: VoxelType,
    spacing: Vec3,
    iso: f32,
    inside: Inside,
) -> std::result::Result<SampledVolume, String> {
    let layout = RawLayout { dims, ty, spacing };
    decode_raw(bytes, layout, iso, inside, Budget::DEFAULT)
}

/// How a raw file's voxels are laid out.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RawLayout {
    /// Voxels along x, y, z (x fastest in the file).
    pub dims: UVec3,
    /// The stored type of each voxel.
    pub ty: VoxelType,
    /// Voxel spacing along x, y, z (world units).
    pub spacing: Vec3,
}

/// [`raw_from_bytes`] with the decoded voxels checked against `budget`.
fn decode_raw(
    bytes: &[u8],
    RawLayout { dims, ty, spacing }: RawLayout,
    iso: f32,
    inside: Inside,
    budget: Budget,
) -> std::result::Result<SampledVolume, String> {
    check_dims(dims)?;
    check_spacing(spacing)?;
    let (count, need) = voxel_sizes(dims, ty.size() as u64, 0, budget)?;
    if bytes.len() != need {
        return Err(format!(
            "the file has {} bytes but {}x{}x{} voxels of {ty:?} need {need}; check --dims and --type{}",
            bytes.len(),
            dims.x,
            dims.y,
            dims.z,
            if bytes.len() < need { " (or the file is truncated)" } else { "" }
        ));
    }
    let data = decode(bytes, ty_code(ty), count, false).ok_or("unsupported voxel type")?;
    finish(dims, spacing, data, iso, inside)
}

/// The volume of `data`, once every voxel and the iso value are checked finite.
pub(super) fn finish(
    dims: UVec3,
    spacing: Vec3,
    data: Vec<f32>,
    iso: f32,
    inside: Inside,
) -> std::result::Result<SampledVolume, String> {
    if let Some(i) = data.iter().position(|v| !v.is_finite()) {
        return Err(format!("voxel {i} is {} (not finite)", data[i]));
    }
    if !iso.is_finite() {
        return Err(format!("iso value {iso} must be finite"));
    }
    Ok(SampledVolume {
        dims,
        spacing,
        origin: Vec3::ZERO,
        data,
        iso,
        inside,
    })
}

fn ty_code(ty: VoxelType) -> i16 {
    match ty {
        VoxelType::U8 => 2,
        VoxelType::I16 => 4,
        VoxelType::F32 => 16,
        VoxelType::U16 => 512,
    }
}

/// Bytes per voxel of NIfTI datatype `code`, `None` for unsupported types.
pub(super) fn code_size(code: i16) -> Option<usize> {
    match code {
        2 | 256 => Some(1),
        4 | 512 => Some(2),
        8 | 768 | 16 => Some(4),
        64 => Some(8),
        _ => None,
    }
}

/// Decodes `count` voxels of NIfTI datatype `code`.
pub(super) fn decode(bytes: &[u8], code: i16, count: usize, big_endian: bool) -> Option<Vec<f32>> {
    let n = code_size(code)?;
    if bytes.len() / n < count {
        return None;
    }
    macro_rules! conv {
        ($t:ty, $n:expr) => {{
            bytes[..count * $n]
                .chunks_exact($n)
                .map(|c| {
                    let a: [u8; $n] = c.try_into().expect("chunks_exact");
                    (if big_endian {
                        <$t>::from_be_bytes(a)
                    } else {
                        <$t>::from_le_bytes(a)
                    }) as f32
                })
                .collect()
        }};
    }
    Some(match code {
        2 => conv!(u8, 1),
        256 => conv!(i8, 1),
        4 => conv!(i16, 2),
        512 => conv!(u16, 2),
        8 => conv!(i32, 4),
        768 => conv!(u32, 4),
        16 => conv!(f32, 4),
        _ => conv!(f64, 8),
    })
}

/// The share of a voxel `step` wide centerd at `r` (in the ellipsoid's frame)
/// inside the ellipsoid of semi-axes `axes`: a ramp across one voxel over the
/// first-order signed distance to its surface.
fn coverage(r: Vec3, axes: Vec3, step: f32) -> f32 {
    let u = r / axes;
    let k = u.length();
    // |∇k| = |u / axes| / k; the signed distance is about (k - 1) / |∇k|.
    let g = (u / axes).length();
    if k <= 0.0 || g <= 0.0 {
        return 1.0;
    }
    let sd = (k - 1.0) * k / g;
    (0.5 - sd / step).clamp(0.0, 1.0)
}

/// A synthetic CT scan of `n`³ voxels in `[-1, 1]^3`: the 3-D Shepp-Logan head
/// phantom (Kak and Slaney): a skull shell, brain, ventricles and small tumours,
/// plus deterministic scanner noise of 1% of the skull's density. At iso 1.5 the
/// surface is the thin skull (inside above).
///
/// Each voxel holds the density at its center, so a voxel is inside an ellipsoid
/// or out and the surface between voxels is a staircase (as in a segmented
/// scan); [`phantom_scanned`] holds each voxel's partial volume instead.
///
/// `n` is at least 2 (smaller values are raised to 2, the fewest voxels a volume
/// has per axis). Errors ([`crate::Error::Allocation`]) when the system cannot
/// give the voxels' memory.
pub fn phantom(n: u32) -> crate::Result<SampledVolume> {
    let vol = shepp_logan(n, false)?;
    Ok(SampledVolume {
        iso: skull_iso(&vol.data, 1.5),
        ..vol
    })
}

/// [`phantom`] as a scanner measures it: each voxel holds the density averaged
/// over the voxel (partial volume), not the density at its center. A voxel an
/// ellipsoid's surface crosses holds the share of it inside, so the surface
/// between voxels is where the scanner saw it rather than a staircase of whole
/// voxels. The share is that of the voxel on the inside of the surface's
/// tangent plane (exact for a plane along an axis, close wherever the surface is
/// flat over a voxel).
///
/// The skull is about 0.03 thick and voxels are `2 / (n - 1)` wide, so where it
/// is thinnest no voxel is all bone: its iso value is 1.3, not 1.5, where the
/// skull is whole (two closed surfaces, Euler characteristic 4) at 96 and 128
/// voxels; at 64 it needs 1.2, and below that a coarse scan's holes remain.
/// Scans too coarse for any voxel to reach 1.3 come with a lower iso their
/// voxels hold (see `skull_iso`). Errors as [`phantom`] does.
pub fn phantom_scanned(n: u32) -> crate::Result<SampledVolume> {
    let vol = shepp_logan(n, true)?;
    Ok(SampledVolume {
        iso: skull_iso(&vol.data, PHANTOM_SCANNED_ISO),
        ..vol
    })
}

/// The iso value of [`phantom_scanned`]'s skull where its voxels reach it.
pub const PHANTOM_SCANNED_ISO: f32 = 1.3;

/// The brain's density in the phantom (the skull's 2 less 0.98).
const PHANTOM_BRAIN: f32 = 1.02;

/// The phantom's iso value, derived from its own voxels: `preferred` where some
/// voxel is denser (a whole or partial skull voxel); in a scan so coarse that
/// no voxel is, halfway from the brain's density to the densest voxel (the
/// skull as far as the scan saw it) or, where not even that stands above the
/// brain, halfway from the least dense voxel to the densest (the head). So
/// meshing a written phantom at its printed iso always finds a surface.
fn skull_iso(data: &[f32], preferred: f32) -> f32 {
    let (lo, hi) = data
        .iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    if hi > preferred {
        preferred
    } else if hi > PHANTOM_BRAIN + 0.05 {
        (PHANTOM_BRAIN + hi) / 2.0
    } else {
        (lo + hi) / 2.0
    }
}

/// [`phantom`] or, with `partial`, [`phantom_scanned`].
fn shepp_logan(n: u32, partial: bool) -> crate::Result<SampledVolume> {
    let n = n.max(2);
    // (semi-axes a, b, c; center x, y, z; rotation about z in degrees; density)
    const E: [[f32; 8]; 10] = [
        [0.69, 0.92, 0.81, 0.0, 0.0, 0.0, 0.0, 2.0],
        [0.6624, 0.874, 0.78, 0.0, -0.0184, 0.0, 0.0, -0.98],
        [0.11, 0.31, 0.22, 0.22, 0.0, 0.0, -18.0, -0.02],
        [0.16, 0.41, 0.28, -0.22, 0.0, 0.0, 18.0, -0.02],
        [0.21, 0.25, 0.41, 0.0, 0.35, -0.15, 0.0, 0.01],
        [0.046, 0.046, 0.05, 0.0, 0.1, 0.25, 0.0, 0.01],
        [0.046, 0.046, 0.05, 0.0, -0.1, 0.25, 0.0, 0.01],
        [0.046, 0.023, 0.05, -0.08, -0.605, 0.0, 0.0, 0.01],
        [0.023, 0.023, 0.02, 0.0, -0.606, 0.0, 0.0, 0.01],
        [0.023, 0.046, 0.02, 0.06, -0.605, 0.0, 0.0, 0.01],
    ];
    let step = 2.0 / (n - 1) as f32;
    let voxels = (n as u64).checked_pow(3);
    let mut data = Vec::new();
    let reserved = voxels
        .and_then(|v| usize::try_from(v).ok())
        .is_some_and(|v| data.try_reserve_exact(v).is_ok());
    if !reserved {
        return Err(crate::Error::Allocation {
            what: format!("the phantom's {n}^3 voxels"),
            needed: voxels.unwrap_or(u64::MAX).saturating_mul(4),
        });
    }
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                let p = Vec3::new(x as f32, y as f32, z as f32) * step - Vec3::ONE;
                let mut d = 0.0;
                for e in &E {
                    let (s, c) = e[6].to_radians().sin_cos();
                    let q = p - Vec3::new(e[3], e[4], e[5]);
                    let r = Vec3::new(c * q.x + s * q.y, -s * q.x + c * q.y, q.z);
                    let axes = Vec3::new(e[0], e[1], e[2]);
                    d += e[7]
                        * if partial {
                            coverage(r, axes, step)
                        } else {
                            ((r / axes).length_squared() <= 1.0) as u8 as f32
                        };
                }
                // Hash noise, deterministic.
                let h = (x.wrapping_mul(73_856_093)
                    ^ y.wrapping_mul(19_349_663)
                    ^ z.wrapping_mul(83_492_791))
                .wrapping_mul(2_654_435_761);
                d += ((h >> 8) as f32 / (1u32 << 24) as f32 - 0.5) * 0.04;
                data.push(d);
            }
        }
    }
    Ok(SampledVolume {
        dims: UVec3::splat(n),
        spacing: Vec3::splat(step),
        origin: Vec3::splat(-1.0),
        data,
        iso: 1.5,
        inside: Inside::Above,
    })
}
