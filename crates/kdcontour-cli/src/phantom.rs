//! `kdcontour phantom`: a synthetic CT scan (the 3-D Shepp-Logan head phantom)
//! written as NIfTI.

use kdcontour::io::volume;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Phantom {
    /// Voxels per axis.
    #[arg(long, default_value_t = 128)]
    res: u32,
    /// The .nii or .nii.gz file to write.
    #[arg(long)]
    out: PathBuf,
}

pub fn run(args: Phantom) -> Result<(), String> {
    let Phantom { res, out } = args;
    if !(8..=1024).contains(&res) {
        return Err(format!("--res must be 8 to 1024, got {res}"));
    }
    volume::write_nifti(&out, &volume::phantom(res)).map_err(|e| e.to_string())?;
    println!(
        "wrote {} ({res}^3 voxels; the skull is at --iso 1.5)",
        out.display()
    );
    Ok(())
}
