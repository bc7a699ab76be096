//! What the hostile-input tests share: running the command with its address
//! space capped (Linux: `ulimit -v`, see [`kdcontour`]) under a hang guard.

// Each test file uses its own part of this module.
#![allow(dead_code)]

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

pub const BIN: &str = env!("CARGO_BIN_EXE_kdcontour");

/// A small world with camera thresholds.
pub const WORLD: [&str; 5] = ["world", "--scene", "sphere", "--camera", "0,0,0"];

/// The address space a command may map, in KiB (128 MiB). Measured with
/// `ulimit -v` on the debug binary under [`kdcontour`]'s environment: `mesh
/// --scene sphere --res 16` runs in 30,000 KiB, so this leaves about 100 MB
/// (issue 14's bound) for what an input makes the command allocate. An
/// allocation past it fails and the command aborts (status 134), which every
/// test here reports as a failure.
pub const MAX_VM_KIB: u64 = 128 << 10;

/// A command still running after this long is killed and the test fails (a
/// hang guard, not a timing: the refusals take milliseconds).
pub const HANG: Duration = Duration::from_secs(20);

/// Runs the command with `args`: exit status (-1 for a signal), stdout,
/// stderr. On Linux it runs under `ulimit -v` [`MAX_VM_KIB`], with two worker
/// threads and two malloc arenas (each thread's arena reserves 64 MiB of address
/// space, which would count against the cap without being used). Fails if it
/// runs past [`HANG`].
pub fn kdcontour(args: &[&str]) -> (i32, String, String) {
    kdcontour_under(&format!("-v {MAX_VM_KIB}"), args)
}

/// [`kdcontour`] under the shell limit `ulimit {limit}` (`-v KIB`: address
/// space; `-f BLOCKS`: file size, in 512-byte blocks) instead of the default
/// cap, on Linux; elsewhere without a limit.
pub fn kdcontour_under(limit: &str, args: &[&str]) -> (i32, String, String) {
    let mut cmd = if cfg!(target_os = "linux") {
        let mut c = Command::new("sh");
        c.arg("-c")
            .arg(format!("ulimit {limit} && exec \"$0\" \"$@\""))
            .arg(BIN)
            .env("RAYON_NUM_THREADS", "2")
            .env("MALLOC_ARENA_MAX", "2");
        c
    } else {
        Command::new(BIN)
    };
    let mut child = cmd
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("runs");
    let drain = |mut r: Box<dyn Read + Send>| {
        std::thread::spawn(move || {
            let mut b = Vec::new();
            r.read_to_end(&mut b).ok();
            String::from_utf8_lossy(&b).into_owned()
        })
    };
    let out = drain(Box::new(child.stdout.take().unwrap()));
    let err = drain(Box::new(child.stderr.take().unwrap()));
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().expect("waits") {
            break status;
        }
        if start.elapsed() > HANG {
            child.kill().ok();
            child.wait().ok();
            panic!("{args:?} was still running after {HANG:?}");
        }
        std::thread::sleep(Duration::from_millis(2));
    };
    (
        status.code().unwrap_or(-1),
        out.join().unwrap(),
        err.join().unwrap(),
    )
}

/// A fresh temporary directory for one test.
pub fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("kdcontour-hostile-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Runs `args`, expects status 2 and a one-line error containing every needle.
pub fn refused(args: &[&str], needles: &[&str]) {
    let (code, out, err) = kdcontour(args);
    assert_eq!(code, 2, "{args:?}\nstdout: {out}\nstderr: {err}");
    let first = err.lines().next().unwrap_or("");
    assert!(first.starts_with("error: "), "{args:?}: {err}");
    // clap adds a usage hint after a blank line; our own errors are one line.
    assert!(
        err.lines().count() == 1 || err.contains("For more information"),
        "{args:?}: {err}"
    );
    for n in needles {
        assert!(first.contains(n), "{args:?}: missing `{n}` in\n{first}");
    }
}

/// `a` then `b`.
pub fn cat<'a>(a: &[&'a str], b: &[&'a str]) -> Vec<&'a str> {
    [a, b].concat()
}

/// `p` as an argument.
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A NIfTI-1 header (little endian, u8 voxels after byte 352) of `dims` voxels
/// spaced `pixdim`.
pub fn nifti_header(dims: [i16; 3], pixdim: [f32; 3]) -> Vec<u8> {
    let mut h = vec![0u8; 352];
    h[0..4].copy_from_slice(&348i32.to_le_bytes());
    for (i, v) in [3i16, dims[0], dims[1], dims[2], 1, 1, 1, 1]
        .iter()
        .enumerate()
    {
        h[40 + 2 * i..42 + 2 * i].copy_from_slice(&v.to_le_bytes());
    }
    h[70..72].copy_from_slice(&2i16.to_le_bytes());
    for (i, p) in pixdim.iter().enumerate() {
        h[80 + 4 * i..84 + 4 * i].copy_from_slice(&p.to_le_bytes());
    }
    h[108..112].copy_from_slice(&352f32.to_le_bytes());
    h[344..348].copy_from_slice(b"n+1\0");
    h
}
