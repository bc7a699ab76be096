//! `kdcontour`: mesh built-in scenes, scene files, volumes and triangle meshes from
//! the command line, and compare the meshers side by side.
//!
//! One module per subcommand; [`args`] holds the options they share, [`output`]
//! the JSON line `mesh` and `compare` print, and [`progress`] the progress line
//! long commands draw on a terminal. This file only parses and dispatches.

/// `println!` that exits quietly when stdout is closed ([`output::line`]).
macro_rules! say {
    ($($t:tt)*) => {
        $crate::output::line(format_args!($($t)*))
    };
}

mod args;
mod compare;
mod mesh;
mod output;
mod phantom;
mod progress;
mod scenes;
mod world;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "kdcontour",
    version,
    about = "Adaptive isosurface meshing through a discrete k-d tree"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Mesh a scene in [-1, 1]^3 and report size, times and mesh checks.
    Mesh(mesh::Mesh),
    /// Mesh one input with Marching Cubes, uniform DMC, the octree and the k-d tree
    /// side by side (same samples, same threshold).
    Compare(compare::Compare),
    /// Mesh a scene as a grid of chunks, each at its own threshold, and write the
    /// union of every chunk's mesh and seams as one welded mesh (so the seams can be
    /// checked).
    World(world::World),
    /// List the built-in scenes.
    Scenes,
    /// Write a synthetic CT scan (the 3-D Shepp-Logan head phantom) as NIfTI.
    Phantom(phantom::Phantom),
}

fn main() -> ExitCode {
    ignore_file_size_signal();
    let result = match Cli::parse().command {
        Command::Mesh(args) => mesh::run(args),
        Command::Compare(args) => compare::run(args),
        Command::World(args) => world::run(args),
        Command::Scenes => scenes::run(),
        Command::Phantom(args) => phantom::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}

/// A write past the process's file-size limit (`ulimit -f`) raises SIGXFSZ,
/// which kills the process where it stands, leaving its temporary file behind.
/// Ignored, the write fails with an error instead, and the command's usual
/// error path removes the temporary file and leaves any existing file whole.
fn ignore_file_size_signal() {
    #[cfg(unix)]
    // SAFETY: setting a standard signal's disposition to "ignore" at start-up,
    // before any other thread exists, has no other effect.
    unsafe {
        libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
    }
}
