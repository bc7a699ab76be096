//! `kdcontour scenes`: the built-in scenes, one line each.

use kdcontour::scenes;

pub fn run() -> Result<(), String> {
    for name in scenes::SCENES {
        let s = scenes::scene(name).map_err(|e| e.to_string())?;
        say!("{:<12} {}", s.name, s.description);
    }
    Ok(())
}
