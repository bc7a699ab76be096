//! Raw voxel files and NIfTI-1 (`.nii`, `.nii.gz`), and a synthetic CT phantom.

use super::{bad, read};
use crate::error::{Error, Result};
use crate::field::volume::{Inside, SampledVolume};
use glam::{UVec3, Vec3};
use std::io::Read;
use std::path::Path;

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

fn check_dims(path: &Path, dims: UVec3) -> Result<()> {
    if dims.min_element() < 2 {
        return Err(bad(
            path,
            format!(
                "dims {}x{}x{}: every axis needs at least 2 voxels",
                dims.x, dims.y, dims.z
            ),
        ));
    }
    Ok(())
}

fn check_spacing(path: &Path, spacing: Vec3) -> Result<()> {
    if !(spacing.is_finite() && spacing.min_element() > 0.0) {
        return Err(bad(
            path,
            format!("voxel spacing {spacing} must be positive and finite"),
        ));
    }
    Ok(())
}

/// Loads a headerless voxel file of `dims` voxels of type `ty` (x fastest).
pub fn load_raw(
    path: &Path,
    dims: UVec3,
    ty: VoxelType,
    spacing: Vec3,
    iso: f32,
    inside: Inside,
) -> Result<SampledVolume> {
    check_dims(path, dims)?;
    check_spacing(path, spacing)?;
    let bytes = read(path)?;
    let count = dims.x as usize * dims.y as usize * dims.z as usize;
    let need = count * ty.size();
    if bytes.len() != need {
        return Err(bad(
            path,
            format!(
                "the file has {} bytes but {}x{}x{} voxels of {ty:?} need {need}; check --dims and --type{}",
                bytes.len(),
                dims.x,
                dims.y,
                dims.z,
                if bytes.len() < need { " (or the file is truncated)" } else { "" }
            ),
        ));
    }
    let data = decode(&bytes, ty_code(ty), count, false).expect("size checked");
    finish(path, dims, spacing, data, iso, inside)
}

fn finish(
    path: &Path,
    dims: UVec3,
    spacing: Vec3,
    data: Vec<f32>,
    iso: f32,
    inside: Inside,
) -> Result<SampledVolume> {
    if let Some(i) = data.iter().position(|v| !v.is_finite()) {
        return Err(bad(path, format!("voxel {i} is {} (not finite)", data[i])));
    }
    if !iso.is_finite() {
        return Err(bad(path, format!("iso value {iso} must be finite")));
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

/// Decodes `count` voxels of NIfTI datatype `code`.
fn decode(bytes: &[u8], code: i16, count: usize, big_endian: bool) -> Option<Vec<f32>> {
    macro_rules! conv {
        ($t:ty, $n:expr) => {{
            if bytes.len() < count * $n {
                return None;
            }
            bytes[..count * $n]
                .chunks_exact($n)
                .map(|c| {
                    let a: [u8; $n] = c.try_into().unwrap();
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
        64 => conv!(f64, 8),
        _ => return None,
    })
}

/// Whether `path` names a NIfTI-1 file: it ends in `.nii` or `.nii.gz`, in any case
/// (`.NII.GZ` too). Other volume files are read as raw voxels.
pub fn is_nifti(path: &Path) -> bool {
    let name = path.to_string_lossy().to_ascii_lowercase();
    name.ends_with(".nii") || name.ends_with(".nii.gz")
}

/// Loads a NIfTI-1 file (`.nii`, or gzip-compressed `.nii.gz`). Dims, voxel type,
/// spacing (`pixdim`) and intensity scaling (`scl_slope`, `scl_inter`) come from
/// the header; the orientation matrices are not applied (voxel (0,0,0) is at the
/// origin).
pub fn load_nifti(path: &Path, iso: f32, inside: Inside) -> Result<SampledVolume> {
    let raw = read(path)?;
    let bytes = if raw.starts_with(&[0x1f, 0x8b]) {
        let mut out = Vec::new();
        flate2::read::MultiGzDecoder::new(&raw[..])
            .read_to_end(&mut out)
            .map_err(|e| bad(path, format!("corrupt gzip data: {e}")))?;
        out
    } else {
        raw
    };
    let (dims, spacing, data) = parse_nifti(&bytes).map_err(|m| bad(path, m))?;
    finish(path, dims, spacing, data, iso, inside)
}

/// Parses NIfTI-1 bytes into dims, spacing and scaled voxel values.
pub fn parse_nifti(b: &[u8]) -> std::result::Result<(UVec3, Vec3, Vec<f32>), String> {
    if b.len() < 348 {
        return Err(format!(
            "{} bytes is too short for a NIfTI-1 header (348)",
            b.len()
        ));
    }
    let le = i32::from_le_bytes(b[0..4].try_into().unwrap()) == 348;
    let be = i32::from_be_bytes(b[0..4].try_into().unwrap()) == 348;
    if !le && !be {
        return Err("not a NIfTI-1 file: sizeof_hdr is not 348".into());
    }
    let big = !le;
    let i16_at = |o: usize| {
        let a = [b[o], b[o + 1]];
        if big {
            i16::from_be_bytes(a)
        } else {
            i16::from_le_bytes(a)
        }
    };
    let f32_at = |o: usize| {
        let a: [u8; 4] = b[o..o + 4].try_into().unwrap();
        if big {
            f32::from_be_bytes(a)
        } else {
            f32::from_le_bytes(a)
        }
    };
    let magic = &b[344..348];
    if magic == b"ni1\0" {
        return Err("a two-file NIfTI (.hdr + .img) header; convert it to a single .nii".into());
    }
    if magic != b"n+1\0" {
        return Err(format!(
            "wrong NIfTI magic {:?} (expected \"n+1\")",
            String::from_utf8_lossy(magic)
        ));
    }
    let ndim = i16_at(40);
    let dim: Vec<i16> = (0..8).map(|i| i16_at(40 + 2 * i)).collect();
    let extra: i64 = (4..=ndim.clamp(0, 7) as usize)
        .map(|i| dim[i].max(1) as i64)
        .product();
    if !(3..=7).contains(&ndim) || extra != 1 {
        return Err(format!(
            "dim[0] = {ndim} with dims {:?}: only one 3-D volume is supported",
            &dim[1..=ndim.clamp(1, 7) as usize]
        ));
    }
    if dim[1] < 2 || dim[2] < 2 || dim[3] < 2 {
        return Err(format!(
            "dims {}x{}x{}: every axis needs at least 2 voxels",
            dim[1], dim[2], dim[3]
        ));
    }
    let dims = UVec3::new(dim[1] as u32, dim[2] as u32, dim[3] as u32);
    let code = i16_at(70);
    let spacing = Vec3::new(f32_at(80).abs(), f32_at(84).abs(), f32_at(88).abs());
    let spacing = if spacing.is_finite() && spacing.min_element() > 0.0 {
        spacing
    } else {
        Vec3::ONE
    };
    let offset = f32_at(108);
    if !(offset.is_finite() && offset >= 348.0) {
        return Err(format!("vox_offset {offset} is not a valid data offset"));
    }
    let offset = offset as usize;
    let count = dims.x as usize * dims.y as usize * dims.z as usize;
    let data = b.get(offset..).unwrap_or(&[]);
    let mut values = match decode(data, code, count, big) {
        Some(v) => v,
        None if [2, 4, 8, 16, 64, 256, 512, 768].contains(&code) => {
            return Err(format!(
                "truncated: {} bytes of voxel data after the header, {count} voxels of datatype {code} need more",
                data.len()
            ))
        }
        None => {
            return Err(format!(
                "unsupported NIfTI datatype {code}; supported: 2 (u8), 4 (i16), 8 (i32), 16 (f32), 64 (f64), 256 (i8), 512 (u16), 768 (u32)"
            ))
        }
    };
    let (slope, inter) = (f32_at(112), f32_at(116));
    if slope != 0.0 && slope.is_finite() && inter.is_finite() && (slope, inter) != (1.0, 0.0) {
        for v in &mut values {
            *v = *v * slope + inter;
        }
    }
    Ok((dims, spacing, values))
}

/// Writes a single-file NIfTI-1 (f32 voxels, little endian), gzip-compressed when
/// `path` ends in `.gz`.
pub fn write_nifti(path: &Path, vol: &SampledVolume) -> Result<()> {
    let mut h = vec![0u8; 352];
    h[0..4].copy_from_slice(&348i32.to_le_bytes());
    let dims = [
        3i16,
        vol.dims.x as i16,
        vol.dims.y as i16,
        vol.dims.z as i16,
        1,
        1,
        1,
        1,
    ];
    for (i, d) in dims.iter().enumerate() {
        h[40 + 2 * i..42 + 2 * i].copy_from_slice(&d.to_le_bytes());
    }
    h[70..72].copy_from_slice(&16i16.to_le_bytes());
    h[72..74].copy_from_slice(&32i16.to_le_bytes());
    let pix = [
        1.0f32,
        vol.spacing.x,
        vol.spacing.y,
        vol.spacing.z,
        1.0,
        1.0,
        1.0,
        1.0,
    ];
    for (i, p) in pix.iter().enumerate() {
        h[76 + 4 * i..80 + 4 * i].copy_from_slice(&p.to_le_bytes());
    }
    h[108..112].copy_from_slice(&352f32.to_le_bytes());
    h[112..116].copy_from_slice(&1f32.to_le_bytes());
    h[344..348].copy_from_slice(b"n+1\0");
    for v in &vol.data {
        h.extend_from_slice(&v.to_le_bytes());
    }
    let io = |e: std::io::Error| Error::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    };
    if path.extension().is_some_and(|e| e == "gz") {
        use std::io::Write;
        let f = std::fs::File::create(path).map_err(io)?;
        let mut z = flate2::write::GzEncoder::new(f, flate2::Compression::fast());
        z.write_all(&h).map_err(io)?;
        z.finish().map_err(io)?;
        Ok(())
    } else {
        std::fs::write(path, h).map_err(io)
    }
}

/// A synthetic CT scan of `n`³ voxels in `[-1, 1]^3`: the 3-D Shepp-Logan head
/// phantom (Kak and Slaney): a skull shell, brain, ventricles and small tumours,
/// plus deterministic scanner noise of 1% of the skull's density. At iso 1.5 the
/// surface is the thin skull (inside above).
pub fn phantom(n: u32) -> SampledVolume {
    // (semi-axes a, b, c; centre x, y, z; rotation about z in degrees; density)
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
    let mut data = Vec::with_capacity((n * n * n) as usize);
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                let p = Vec3::new(x as f32, y as f32, z as f32) * step - Vec3::ONE;
                let mut d = 0.0;
                for e in &E {
                    let (s, c) = e[6].to_radians().sin_cos();
                    let q = p - Vec3::new(e[3], e[4], e[5]);
                    let r = Vec3::new(c * q.x + s * q.y, -s * q.x + c * q.y, q.z);
                    if (r / Vec3::new(e[0], e[1], e[2])).length_squared() <= 1.0 {
                        d += e[7];
                    }
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
    SampledVolume {
        dims: UVec3::splat(n),
        spacing: Vec3::splat(step),
        origin: Vec3::splat(-1.0),
        data,
        iso: 1.5,
        inside: Inside::Above,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nifti_is_told_by_its_extension_in_any_case() {
        for name in ["head.nii", "head.nii.gz", "HEAD.NII.GZ", "dir.x/Head.Nii"] {
            assert!(is_nifti(Path::new(name)), "{name}");
        }
        for name in ["ct.raw", "head.nii.bak", "head.gz", "nii"] {
            assert!(!is_nifti(Path::new(name)), "{name}");
        }
    }
}
