//! `kdcontour phantom`: a synthetic CT scan (the 3-D Shepp-Logan head phantom)
//! written as NIfTI.

use crate::args::Memory;
use kdcontour::io::volume;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Phantom {
    /// Voxels per axis.
    #[arg(long, default_value_t = 128)]
    res: u32,
    /// The .nii or .nii.gz file to write (any case; other names are refused).
    #[arg(long)]
    out: PathBuf,
    /// Each voxel holds its partial volume (the density averaged over it, as a
    /// scanner measures it) instead of the density at its center: the skull is
    /// smooth between voxels, at iso 1.3 (whole from about 96 voxels). The iso
    /// printed is always one the file's voxels hold (lower on scans too coarse
    /// to reach 1.3).
    #[arg(long)]
    scanned: bool,
    #[command(flatten)]
    memory: Memory,
}

pub fn run(args: Phantom) -> Result<(), String> {
    let Phantom {
        res,
        out,
        scanned,
        memory,
    } = args;
    if !(8..=1024).contains(&res) {
        return Err(format!("--res must be 8 to 1024, got {res}"));
    }
    if !volume::is_nifti(&out) {
        return Err(format!(
            "--out {}: the phantom is written as NIfTI; name it .nii or .nii.gz",
            out.display()
        ));
    }
    kdcontour::io::check_writable(&out).map_err(|e| format!("--out {e}"))?;
    // The voxels, and the file's bytes while they are written.
    let voxels = (res as u64).pow(3);
    memory
        .budget
        .check(format!("a phantom of {res}^3 voxels"), voxels * 8 + 352)
        .map_err(|e| e.to_string())?;
    let progress = crate::progress::Progress::new(false);
    progress.stage(format!("making a phantom of {res}^3 voxels"));
    let vol = if scanned {
        volume::phantom_scanned(res)
    } else {
        volume::phantom(res)
    }
    .map_err(|e| e.to_string())?;
    progress.stage(format!("writing {}", out.display()));
    volume::write_nifti(&out, &vol).map_err(|e| e.to_string())?;
    progress.finish();
    say!(
        "wrote {} ({res}^3 voxels; the skull is at --iso {})",
        out.display(),
        vol.iso
    );
    Ok(())
}
