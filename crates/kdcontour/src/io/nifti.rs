//! NIfTI-1 volumes (`.nii`, gzip-compressed `.nii.gz`): reading only what the
//! header says is needed, and writing.

use super::volume::{code_size, decode, finish, voxel_sizes};
use super::{bad, io_error, write_atomic};
use crate::budget::Budget;
use crate::error::{Error, Result};
use crate::field::volume::{Inside, SampledVolume};
use glam::{UVec3, Vec3};
use std::io::{BufRead, Read};
use std::path::Path;

/// The size of a NIfTI-1 header.
const HEADER: usize = 348;

/// Whether `path` names a NIfTI-1 file: it ends in `.nii` or `.nii.gz`, in any case
/// (`.NII.GZ` too). Other volume files are read as raw voxels.
pub fn is_nifti(path: &Path) -> bool {
    let name = path.to_string_lossy().to_ascii_lowercase();
    name.ends_with(".nii") || name.ends_with(".nii.gz")
}

/// Loads a NIfTI-1 file (`.nii`, or gzip-compressed `.nii.gz`) within the default
/// budget ([`Budget::DEFAULT`]; see [`load_nifti_within`]).
pub fn load_nifti(path: &Path, iso: f32, inside: Inside) -> Result<SampledVolume> {
    load_nifti_within(path, iso, inside, Budget::DEFAULT)
}

/// Loads a NIfTI-1 file (`.nii`, or gzip-compressed `.nii.gz`). Dims, voxel type,
/// spacing (`pixdim`) and intensity scaling (`scl_slope`, `scl_inter`) come from
/// the header; the orientation matrices are not applied (voxel (0,0,0) is at the
/// origin). Only the bytes the header describes are read (or inflated), after
/// their size, with the decoded voxels, is checked against `budget`.
pub fn load_nifti_within(
    path: &Path,
    iso: f32,
    inside: Inside,
    budget: Budget,
) -> Result<SampledVolume> {
    let file = std::fs::File::open(path).map_err(|e| io_error(path, e))?;
    let (dims, spacing, data) =
        read_nifti(std::io::BufReader::new(file), budget).map_err(|m| bad(path, m))?;
    finish(dims, spacing, data, iso, inside).map_err(|m| bad(path, m))
}

/// Parses NIfTI-1 bytes, gzip-compressed or not, into dims, spacing and scaled
/// voxel values (see [`read_nifti`]; budget [`Budget::DEFAULT`]).
pub fn parse_nifti(b: &[u8]) -> std::result::Result<(UVec3, Vec3, Vec<f32>), String> {
    read_nifti(b, Budget::DEFAULT)
}

/// Reads NIfTI-1 from `r` (gzip-compressed when it starts with the gzip magic):
/// the header first, then exactly the voxel bytes it describes, once their size,
/// with the decoded voxels, is checked against `budget`. Trailing bytes are never
/// read, so a gzip bomb inflates no further than the header's volume.
pub fn read_nifti(
    mut r: impl BufRead,
    budget: Budget,
) -> std::result::Result<(UVec3, Vec3, Vec<f32>), String> {
    let head = r.fill_buf().map_err(|e| format!("cannot read: {e}"))?;
    if head.starts_with(&[0x1f, 0x8b]) {
        read_plain(
            flate2::bufread::MultiGzDecoder::new(r),
            budget,
            "corrupt gzip data: ",
        )
    } else {
        read_plain(r, budget, "cannot read: ")
    }
}

/// The header fields the loader uses.
struct Header {
    dims: UVec3,
    spacing: Vec3,
    code: i16,
    offset: u64,
    big: bool,
    slope: f32,
    inter: f32,
}

fn read_plain(
    mut r: impl Read,
    budget: Budget,
    io_prefix: &str,
) -> std::result::Result<(UVec3, Vec3, Vec<f32>), String> {
    let io = |e: std::io::Error| format!("{io_prefix}{e}");
    let mut bytes = Vec::with_capacity(HEADER);
    r.by_ref()
        .take(HEADER as u64)
        .read_to_end(&mut bytes)
        .map_err(io)?;
    let h = header(&bytes)?;
    let size = code_size(h.code).ok_or_else(|| {
        format!(
            "unsupported NIfTI datatype {}; supported: 2 (u8), 4 (i16), 8 (i32), 16 (f32), 64 (f64), 256 (i8), 512 (u16), 768 (u32)",
            h.code
        )
    })?;
    let (count, stored) = voxel_sizes(h.dims, size as u64, h.offset, budget)?;
    // The extensions between the header and the voxels are skipped, not kept.
    let skip = h.offset - HEADER as u64;
    let skipped = std::io::copy(&mut r.by_ref().take(skip), &mut std::io::sink()).map_err(io)?;
    let mut data = Vec::new();
    if skipped == skip {
        r.take(stored as u64).read_to_end(&mut data).map_err(io)?;
    }
    let Some(mut values) = decode(&data, h.code, count, h.big) else {
        return Err(format!(
            "truncated: {} bytes of voxel data after vox_offset {}, but {}x{}x{} voxels of datatype {} need {stored}",
            data.len(),
            h.offset,
            h.dims.x,
            h.dims.y,
            h.dims.z,
            h.code
        ));
    };
    let (slope, inter) = (h.slope, h.inter);
    if slope != 0.0 && slope.is_finite() && inter.is_finite() && (slope, inter) != (1.0, 0.0) {
        for v in &mut values {
            *v = *v * slope + inter;
        }
    }
    Ok((h.dims, h.spacing, values))
}

/// Parses and checks the 348-byte header.
fn header(b: &[u8]) -> std::result::Result<Header, String> {
    if b.len() < HEADER {
        return Err(format!(
            "{} bytes is too short for a NIfTI-1 header ({HEADER})",
            b.len()
        ));
    }
    let word = |o: usize| -> [u8; 4] { [b[o], b[o + 1], b[o + 2], b[o + 3]] };
    let le = i32::from_le_bytes(word(0)) == HEADER as i32;
    let be = i32::from_be_bytes(word(0)) == HEADER as i32;
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
        if big {
            f32::from_be_bytes(word(o))
        } else {
            f32::from_le_bytes(word(o))
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
    let pixdim = Vec3::new(f32_at(80), f32_at(84), f32_at(88));
    let spacing = pixdim.abs();
    if !(spacing.is_finite() && spacing.min_element() > 0.0) {
        return Err(format!(
            "pixdim[1..=3] = {pixdim}: the voxel spacing must be finite and non-zero along every axis; fix the header"
        ));
    }
    let offset = f32_at(108);
    if !(offset.is_finite() && offset >= HEADER as f32 && offset.fract() == 0.0) {
        return Err(format!(
            "vox_offset {offset} is not a valid data offset (a whole number >= {HEADER})"
        ));
    }
    Ok(Header {
        dims,
        spacing,
        code: i16_at(70),
        // A finite f32 >= 348 converts exactly (up to 2^24) or saturates.
        offset: offset as u64,
        big,
        slope: f32_at(112),
        inter: f32_at(116),
    })
}

/// Writes a single-file NIfTI-1 (f32 voxels, little endian), gzip-compressed when
/// `path` ends in `.gz` (any case). Any other name than `.nii` or `.nii.gz` is
/// refused before anything is written, and the file is replaced only once it is
/// complete.
pub fn write_nifti(path: &Path, vol: &SampledVolume) -> Result<()> {
    if !is_nifti(path) {
        return Err(Error::Io {
            path: path.display().to_string(),
            message: "a NIfTI file must be named .nii or .nii.gz".into(),
        });
    }
    if vol.dims.max_element() > i16::MAX as u32 {
        return Err(bad(
            path,
            format!(
                "{} voxels along one axis do not fit in NIfTI-1 (at most 32767)",
                vol.dims.max_element()
            ),
        ));
    }
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
    let gz = path.to_string_lossy().to_ascii_lowercase().ends_with(".gz");
    write_atomic(path, |w| {
        use std::io::Write;
        if gz {
            let mut z = flate2::write::GzEncoder::new(w, flate2::Compression::fast());
            z.write_all(&h)?;
            z.finish().map(|_| ())
        } else {
            w.write_all(&h)
        }
    })
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
