//! Bad input gets a clear error a user can act on, never a panic or a garbage mesh.

use glam::Vec3;
use kdcontour::field::FnField;
use kdcontour::{CsgNode, Error, Grid, KdTree, SceneError, Settings};

fn build(f: impl Fn(Vec3) -> f32 + Send + Sync, grid: Grid, s: &Settings) -> Result<KdTree, Error> {
    KdTree::build(&FnField(f), &grid, s)
}

#[test]
fn nan_field_is_an_error_naming_the_point() {
    let err = build(
        |p| {
            if p.x > 0.3 {
                f32::NAN
            } else {
                p.length() - 0.5
            }
        },
        Grid::cube(1.0, 16),
        &Settings::default(),
    )
    .expect_err("NaN must be an error");
    match &err {
        Error::NonFiniteSample {
            value,
            position,
            cause,
        } => {
            // A closure cannot say why; the message lists the usual causes.
            assert_eq!(cause, &None);
            assert!(value.is_nan());
            assert!(position.x > 0.3);
        }
        other => panic!("{other:?}"),
    }
    let msg = err.to_string();
    assert!(msg.contains("NaN") && msg.contains("finite"), "{msg}");
}

#[test]
fn infinite_field_is_an_error() {
    let err = build(
        |p| 1.0 / (p.y - 0.1).max(0.0) - 3.0,
        Grid::cube(1.0, 16),
        &Settings::default(),
    )
    .err();
    assert!(
        matches!(err, Some(Error::NonFiniteSample { value, .. }) if value.is_infinite()),
        "{err:?}"
    );
}

#[test]
fn nan_only_between_samples_is_still_caught() {
    // Finite at every corner, NaN where the crossing search evaluates the field:
    // the crossings of a sphere lie between corners.
    let err = build(
        |p| {
            let d = p.length() - 0.5;
            if d.abs() < 0.02 && d != 0.0 && (p.x * 16.0).fract().abs() > 0.05 {
                f32::NAN
            } else {
                d
            }
        },
        Grid::cube(1.0, 16),
        &Settings::default(),
    )
    .err();
    assert!(
        matches!(err, Some(Error::NonFiniteSample { .. })),
        "{err:?}"
    );
}

#[test]
fn zero_resolution_and_degenerate_grids() {
    let err = build(
        |p| p.length() - 0.5,
        Grid::cube(1.0, 0),
        &Settings::default(),
    )
    .err()
    .unwrap();
    assert!(err.to_string().contains("res must be >= 1"), "{err}");
    let mut g = Grid::cube(1.0, 8);
    g.cell_size = -1.0;
    let err = build(|p| p.length() - 0.5, g, &Settings::default())
        .err()
        .unwrap();
    assert!(err.to_string().contains("cell size"), "{err}");
    g.cell_size = f32::NAN;
    assert!(matches!(
        build(|p| p.length(), g, &Settings::default()),
        Err(Error::InvalidGrid(_))
    ));
    let mut g = Grid::cube(1.0, 8);
    g.origin.y = f32::INFINITY;
    assert!(matches!(
        build(|p| p.length(), g, &Settings::default()),
        Err(Error::InvalidGrid(_))
    ));
}

#[test]
fn grid_over_the_memory_budget_is_refused_before_allocating() {
    let s = Settings {
        memory_budget: kdcontour::Budget::bytes(64 << 20),
        ..Default::default()
    };
    // 4096^3 cells would need hundreds of GB; the check must come first.
    let err = build(|p| p.length() - 0.5, Grid::cube(1.0, 4096), &s)
        .err()
        .unwrap();
    match &err {
        Error::MemoryBudget { budget, needed, .. } => assert!(needed > budget),
        other => panic!("{other:?}"),
    }
    assert!(err.to_string().contains("memory budget"), "{err}");
    // A small grid fits the same budget.
    assert!(build(|p| p.length() - 0.5, Grid::cube(1.0, 32), &s).is_ok());
}

#[test]
fn out_of_range_settings() {
    let s = Settings {
        threads: 100_000,
        ..Default::default()
    };
    let err = build(|p| p.length() - 0.5, Grid::cube(1.0, 8), &s)
        .err()
        .unwrap();
    assert!(
        matches!(
            err,
            Error::InvalidSetting {
                name: "threads",
                ..
            }
        ),
        "{err}"
    );
    let s = Settings {
        root_iterations: 1000,
        ..Default::default()
    };
    let err = build(|p| p.length() - 0.5, Grid::cube(1.0, 8), &s)
        .err()
        .unwrap();
    assert!(err.to_string().contains("root_iterations"), "{err}");
}

#[test]
fn empty_volumes_give_empty_meshes() {
    for f in [
        (|_p: Vec3| 1.0) as fn(Vec3) -> f32,
        |_p| -1.0,
        |p| p.length() - 5.0,                      // all inside
        |p| (p - Vec3::splat(3.0)).length() - 0.5, // sphere outside the grid
    ] {
        let tree = build(f, Grid::cube(1.0, 16), &Settings::default()).unwrap();
        let m = tree.mesh(0.01);
        assert!(m.is_empty() && m.positions.is_empty());
        assert!(tree.mesh(-1.0).is_empty());
    }
}

#[test]
fn one_cell_grid_works() {
    let tree = build(
        |p| p.length() - 0.5,
        Grid::cube(1.0, 1),
        &Settings::default(),
    )
    .unwrap();
    // One cell with every corner outside: nothing. A corner inside: an open patch.
    assert!(tree.mesh(-1.0).is_empty());
    let tree = build(
        |p| (p - Vec3::splat(-1.0)).length() - 0.5,
        Grid::cube(1.0, 1),
        &Settings::default(),
    )
    .unwrap();
    // The patch's only crossing edges lie on the grid boundary: no quad can form.
    assert!(tree.mesh(-1.0).is_empty());
}

#[test]
fn malformed_scene_files_report_line_and_column() {
    let cases = [
        ("{\n  \"type\": \"sphere\",\n  \"radius\": 0.5,\n", "EOF"),
        (
            "{\"type\": \"sphere\", \"radius\": 0.5 ]",
            "expected `,` or `}`",
        ),
        ("", "EOF"),
    ];
    for (text, needle) in cases {
        let err = CsgNode::from_json(text).unwrap_err();
        let msg = err.to_string();
        assert!(matches!(err, SceneError::Syntax { .. }), "{text}: {err:?}");
        assert!(msg.contains("line") && msg.contains("column"), "{msg}");
        assert!(msg.contains(needle), "{text}: {msg}");
    }
}

#[test]
fn schema_errors_in_scene_files_name_the_node() {
    // Well-formed JSON that does not match the schema: the message names the
    // node's path (serde cannot give a line inside a tagged node).
    let cases = [
        (
            "{\"type\": \"sphere\", \"radius\": \"big\"}",
            "root.radius",
            "invalid type: string \"big\", expected a number",
        ),
        ("{\"type\": \"sphere\"}", "root", "missing field `radius`"),
        (
            "{\"type\": \"sphere\", \"radius\": 0.5, \"colour\": 1}",
            "root",
            "unknown field `colour`",
        ),
        (
            "{\"type\":\"union\",\"children\":[{\"type\":\"sphere\",\"radius\":1},{\"type\": \"blob\"}]}",
            "root.children[1]",
            "unknown variant `blob`",
        ),
        ("[1, 2]", "root", "expected a node"),
    ];
    for (text, path, needle) in cases {
        let err = CsgNode::from_json(text).unwrap_err();
        let msg = err.to_string();
        assert!(
            msg.starts_with(&format!("scene node `{path}`: ")),
            "{text}: {msg}"
        );
        assert!(msg.contains(needle), "{text}: {msg}");
    }
}

#[test]
fn semantically_wrong_scene_files_name_the_node() {
    let cases = [
        (r#"{"type":"sphere","radius":-1}"#, "root.radius"),
        (
            r#"{"type":"torus","major_radius":0.2,"minor_radius":0.3}"#,
            "root.minor_radius",
        ),
        (r#"{"type":"union","children":[]}"#, "root.children"),
        (
            r#"{"type":"difference","a":{"type":"sphere","radius":1},"b":{"type":"box","half_extents":[1,0,1]}}"#,
            "root.b.half_extents.y",
        ),
        (
            r#"{"type":"transform","scale":0,"child":{"type":"sphere","radius":1}}"#,
            "root.scale",
        ),
        (r#"{"type":"plane","normal":[0,0,0]}"#, "root.normal"),
        (
            r#"{"type":"heightfield","amplitude":1,"frequency":1,"octaves":40}"#,
            "root.octaves",
        ),
        (
            r#"{"type":"density","amplitude":-1,"frequency":1}"#,
            "root.amplitude",
        ),
        (
            r#"{"type":"rounded_box","half_extents":[0.1,0.5,0.5],"radius":0.2}"#,
            "root.half_extents.x",
        ),
    ];
    for (text, path) in cases {
        let err = CsgNode::from_json(text).unwrap_err();
        assert!(
            matches!(err, SceneError::Semantic { .. }),
            "{text}: {err:?}"
        );
        assert!(err.to_string().contains(path), "{text}: {err}");
    }
}

#[test]
fn every_scene_error_names_its_place_and_cuts_long_values() {
    let long = "x".repeat(1 << 20);
    let cases = [
        // Syntax: a line and a column (never line 0).
        "{\"type\": \"sphere\",\n \"radius\": }".to_string(),
        format!("{{\"type\": \"sphere\", \"radius\": 1}} {long}"),
        // Schema: the node path, long names and strings cut.
        format!(r#"{{"type":"{long}"}}"#),
        format!(r#"{{"type":"sphere","radius":1,"{long}":2}}"#),
        format!(r#"{{"type":"sphere","radius":"{long}"}}"#),
        format!(r#"{{"type":"union","children":[{{"type":"sphere","radius":1}},"{long}"]}}"#),
        format!(r#"{{"type":"transform","child":{{"type":7,"radius":1}},"translate":"{long}"}}"#),
        // Values: the field's path.
        r#"{"type":"heightfield","amplitude":1,"frequency":1e19}"#.to_string(),
        r#"{"type":"density","amplitude":1,"frequency":1,"caves":{"frequency":0,"radius":1}}"#
            .to_string(),
    ];
    for text in &cases {
        let msg = CsgNode::from_json(text).unwrap_err().to_string();
        let head: String = text.chars().take(80).collect();
        assert!(msg.len() < 600, "{head}: {} bytes", msg.len());
        assert!(!msg.contains('\n'), "{head}: {msg}");
        let placed = msg.starts_with("scene node `root")
            || (msg.starts_with("scene file line ") && !msg.starts_with("scene file line 0"));
        assert!(placed, "{head}: {msg}");
        if text.len() > 1 << 20 {
            let said = msg.contains("a string of 1048576 bytes") || msg.contains("trailing");
            assert!(said, "{head}: {msg}");
        }
    }
}

/// A vector parameter whose squared length overflows (or underflows) f32 is
/// normalised as the vector it points along, not turned into zero or NaN: a
/// plane's normal and a rotation's axis give the field the small vector gives.
#[test]
fn huge_and_tiny_direction_vectors_mean_their_direction() {
    use kdcontour::Field;
    let plane = |n: &str| {
        format!(
            r#"{{"type":"intersection","children":[{{"type":"sphere","radius":0.9}},{{"type":"plane","normal":{n},"offset":0.1}}]}}"#
        )
    };
    let rotated = |axis: &str| {
        format!(
            r#"{{"type":"transform","rotate_axis":{axis},"rotate_degrees":30,"child":{{"type":"box","half_extents":[0.5,0.3,0.2]}}}}"#
        )
    };
    let cases = [
        (plane("[1,1,0]"), plane("[1e20,1e20,0]")),
        (plane("[1,1,0]"), plane("[3e38,3e38,0]")),
        (plane("[1,0,0]"), plane("[2e19,0,0]")),
        (plane("[0,1,1]"), plane("[0,1e-4,1e-4]")),
        (rotated("[1,1,0]"), rotated("[1e20,1e20,0]")),
        (rotated("[0,0,1]"), rotated("[0,0,3e38]")),
        (rotated("[1,2,3]"), rotated("[1e-3,2e-3,3e-3]")),
    ];
    for (small, scaled) in &cases {
        let a = CsgNode::from_json(small).unwrap().compile().unwrap();
        let b = CsgNode::from_json(scaled).unwrap().compile().unwrap();
        let mut inside = 0;
        for i in 0..1000 {
            let t = i as f32;
            let p = (Vec3::new(t * 0.618, t * 0.414, t * 0.732).fract() - 0.5) * 1.6;
            let (va, vb) = (a.value(p), b.value(p));
            assert!(vb.is_finite(), "{scaled} at {p}: {vb}");
            assert!(
                (va - vb).abs() <= 1e-6,
                "{scaled} at {p}: {vb}, {small} gives {va}"
            );
            inside += (va < 0.0) as usize;
        }
        assert!(
            inside > 50 && inside < 950,
            "{small}: {inside} of 1000 inside"
        );
    }
}

/// A direction too short to have one is refused by name, with its value and
/// the shortest length taken.
#[test]
fn vanishing_directions_are_refused_by_name() {
    let cases = [
        (r#"{"type":"plane","normal":[1e-7,0,0]}"#, "root.normal"),
        (
            r#"{"type":"plane","normal":[1e-30,1e-30,1e-30]}"#,
            "root.normal",
        ),
        (
            r#"{"type":"transform","rotate_axis":[0,-1e-9,0],"rotate_degrees":10,"child":{"type":"sphere","radius":1}}"#,
            "root.rotate_axis",
        ),
    ];
    for (text, path) in cases {
        let msg = CsgNode::from_json(text).unwrap_err().to_string();
        assert!(msg.contains(path), "{text}: {msg}");
        assert!(
            msg.contains("must not be zero (length at least 0.000001)"),
            "{text}: {msg}"
        );
    }
}

/// Any name the file system takes (up to 255 bytes, multi-byte characters
/// too) writes atomically: the temporary name beside it is cut to fit, and no
/// temporary file is left behind.
#[test]
fn the_longest_legal_names_write_and_leave_nothing_behind() {
    use kdcontour::io::{temporary_name, write_atomic, NAME_MAX};
    use std::io::Write;
    let dir = std::env::temp_dir().join(format!("kdcontour-names-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let names = [
        "x".repeat(NAME_MAX - 4) + ".obj",
        "é".repeat((NAME_MAX - 4) / 2) + ".ply",
        "m".repeat(200) + ".stl",
    ];
    for name in &names {
        assert!(name.len() <= NAME_MAX);
        let tmp = temporary_name(name, "123-4.tmp");
        assert!(tmp.len() <= NAME_MAX, "{} bytes", tmp.len());
        let path = dir.join(name);
        write_atomic(&path, |w| w.write_all(b"first")).unwrap();
        write_atomic(&path, |w| w.write_all(b"second")).unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"second");
    }
    let left: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .filter(|n| n.to_string_lossy().starts_with('.'))
        .collect();
    assert!(left.is_empty(), "{left:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A primitive under transforms whose scales multiply past what f32
/// coordinates survive is refused by its path, nested or not; scales that
/// cancel out are fine. (Noise under such a scale reports the point beyond its
/// reach when sampled: `hostile_files`.)
#[test]
fn scales_that_underflow_or_overflow_a_primitive_are_refused() {
    let t = |scale: &str, child: &str| {
        format!(r#"{{"type":"transform","scale":{scale},"child":{child}}}"#)
    };
    let tiny = r#"{"type":"sphere","radius":1e-30}"#;
    let big = r#"{"type":"sphere","radius":1e30}"#;
    for (text, path) in [
        (t("1e25", tiny), "root.child"),
        (t("1e-25", big), "root.child"),
        (t("1e10", &t("1e10", tiny)), "root.child.child"),
        (
            format!(
                r#"{{"type":"union","children":[{{"type":"sphere","radius":1}},{}]}}"#,
                t("1e-16", big)
            ),
            "root.children[1].child",
        ),
    ] {
        let msg = CsgNode::from_json(&text).unwrap_err().to_string();
        assert!(msg.contains(&format!("`{path}`")), "{text}: {msg}");
        assert!(msg.contains("scale it by"), "{text}: {msg}");
    }
    // 1e10 and 1e-10 cancel: the sphere of radius 0.5 is meshed as it is.
    let ok = CsgNode::from_json(&t("1e10", &t("1e-10", r#"{"type":"sphere","radius":0.5}"#)))
        .unwrap()
        .compile()
        .unwrap();
    use kdcontour::Field;
    assert!(ok.value(Vec3::ZERO) < 0.0 && ok.value(Vec3::splat(0.6)) > 0.0);
}
