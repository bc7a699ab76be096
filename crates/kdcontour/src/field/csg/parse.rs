//! Reading a scene file's JSON into a [`CsgNode`] one node at a time, so every
//! schema error names the node's path (`root.children[2]`), long names from the
//! file are cut, and nesting is limited to [`MAX_DEPTH`] nodes.

use super::CsgNode;
use crate::error::SceneError;
use crate::io::{cut, cut_quoted, MAX_QUOTED};
use serde::Deserialize;
use serde_json::{Map, Value};

/// The deepest a scene may nest: a node path has at most this many nodes
/// (`root` is depth 1). Deeper trees gain nothing a wider union does not give,
/// and every level costs stack when the scene is checked, compiled and evaluated.
pub const MAX_DEPTH: usize = 32;

/// The longest string a scene file may hold (bytes): its strings are node types
/// and field names, all far shorter.
pub const MAX_NAME: usize = 64;

/// The first string of `text` longer than [`MAX_NAME`] bytes: its line and
/// column (1-based), its length in bytes and its first characters. JSON has
/// quotes only around strings, so a scan that skips escaped characters finds
/// every string of a valid text.
fn long_string(text: &str) -> Option<(usize, usize, usize, String)> {
    let b = text.as_bytes();
    let mut i = 0;
    while i < b.len() {
        if b[i] != b'"' {
            i += 1;
            continue;
        }
        let start = i + 1;
        let mut j = start;
        while j < b.len() && b[j] != b'"' {
            j += if b[j] == b'\\' { 2 } else { 1 };
        }
        let end = j.min(b.len());
        if end - start > MAX_NAME {
            let before = &text[..i];
            let line = before.matches('\n').count() + 1;
            let column = before.len() - before.rfind('\n').map_or(0, |n| n + 1) + 1;
            // `start` follows an ASCII quote, so it is a char boundary.
            let head = text[start..].chars().take(MAX_QUOTED).collect();
            return Some((line, column, end - start, head));
        }
        i = j + 1;
    }
    None
}

/// Parses a scene file's text: syntax errors carry line and column; schema errors
/// (unknown type or field, a missing or mistyped value, too deep) the node path.
/// A string longer than any name is refused first, before the text is copied
/// into a tree.
pub(super) fn parse(text: &str) -> Result<CsgNode, SceneError> {
    if let Some((line, column, len, head)) = long_string(text) {
        return Err(SceneError::Syntax {
            line,
            column,
            message: format!(
                "a string of {len} bytes (`{head}...`); a scene file's strings are node \
                 types and field names, none longer than {MAX_NAME} bytes (see \
                 assets/scenes/README.md)"
            ),
        });
    }
    let value: Value = serde_json::from_str(text).map_err(|e| {
        let message = e.to_string();
        let message = message.split(" at line ").next().unwrap_or("");
        let message = if message.contains("recursion limit") {
            format!(
                "nested too deeply for JSON (128 levels); a scene nests at most {MAX_DEPTH} nodes deep"
            )
        } else {
            cut_quoted(message)
        };
        SceneError::Syntax {
            line: e.line(),
            column: e.column(),
            message,
        }
    })?;
    node(&value, "root", 1)
}

/// The child slots of each node type that has children: a list (`children`) or
/// single nodes (`a`, `b`, `child`).
fn child_keys(ty: &str) -> (&'static [&'static str], bool) {
    match ty {
        "union" | "intersection" | "smooth_union" | "smooth_intersection" => (&["children"], true),
        "difference" | "smooth_difference" => (&["a", "b"], false),
        "transform" | "material" => (&["child"], false),
        _ => (&[], false),
    }
}

fn semantic(path: &str, message: impl Into<String>) -> SceneError {
    SceneError::Semantic {
        path: path.to_string(),
        message: message.into(),
    }
}

/// A stand-in for a child while the node's own fields are read.
fn placeholder() -> Value {
    serde_json::json!({"type": "sphere", "radius": 1.0})
}

/// The node `v` at `path`, `depth` nodes deep.
fn node(v: &Value, path: &str, depth: usize) -> Result<CsgNode, SceneError> {
    if depth > MAX_DEPTH {
        return Err(semantic(
            path,
            format!(
                "the scene nests deeper than {MAX_DEPTH} nodes, the most allowed; flatten it (a union takes any number of children)"
            ),
        ));
    }
    let Some(obj) = v.as_object() else {
        return Err(semantic(
            path,
            format!(
                "expected a node (an object with a \"type\"), got {}",
                kind(v)
            ),
        ));
    };
    let ty = match obj.get("type") {
        Some(Value::String(t)) => t.as_str(),
        Some(other) => {
            return Err(semantic(
                path,
                format!("\"type\" must be a string, got {}", kind(other)),
            ))
        }
        None => return Err(semantic(path, "missing field `type`")),
    };
    // Read the node's own fields with its children stood in for, then parse the
    // children at their own paths.
    let (keys, list) = child_keys(ty);
    let mut own = Map::new();
    let mut kids: Vec<(&str, &Value)> = Vec::new();
    for (k, val) in obj {
        if keys.contains(&k.as_str()) && (!list || val.is_array()) {
            kids.push((k, val));
            own.insert(
                k.clone(),
                if list {
                    Value::Array(vec![])
                } else {
                    placeholder()
                },
            );
        } else {
            own.insert(k.clone(), val.clone());
        }
    }
    let mut n = CsgNode::deserialize(Value::Object(own.clone()))
        .map_err(|e| field_error(&own, path, &e.to_string()))?;
    for (k, val) in kids {
        match (&mut n, val) {
            (
                CsgNode::Union { children }
                | CsgNode::Intersection { children }
                | CsgNode::SmoothUnion { children, .. }
                | CsgNode::SmoothIntersection { children, .. },
                Value::Array(items),
            ) => {
                *children = items
                    .iter()
                    .enumerate()
                    .map(|(i, c)| node(c, &format!("{path}.children[{i}]"), depth + 1))
                    .collect::<Result<_, _>>()?;
            }
            (CsgNode::Difference { a, b } | CsgNode::SmoothDifference { a, b, .. }, _) => {
                let slot = if k == "a" { a } else { b };
                **slot = node(val, &format!("{path}.{k}"), depth + 1)?;
            }
            (CsgNode::Transform { child, .. } | CsgNode::Material { child, .. }, _) => {
                **child = node(val, &format!("{path}.child"), depth + 1)?;
            }
            _ => unreachable!("child keys are listed per node type"),
        }
    }
    Ok(n)
}

/// The error of a node whose fields `own` do not deserialize: at the field
/// that is wrong (`root.id`) when one is, found by leaving each field out in
/// turn (the node then reads, or misses exactly that field), with serde's
/// Rust type names said as ranges (`expected u8`: an integer from 0 to 255).
fn field_error(own: &Map<String, Value>, path: &str, message: &str) -> SceneError {
    // Unknown and missing fields are named by the message itself.
    let wrong_value = message.starts_with("invalid ");
    let culprit = own
        .keys()
        .filter(|k| wrong_value && k.as_str() != "type")
        .find(|k| {
            let mut rest = own.clone();
            rest.remove(k.as_str());
            match CsgNode::deserialize(Value::Object(rest)) {
                Ok(_) => true,
                Err(e) => e.to_string() == format!("missing field `{k}`"),
            }
        });
    let message = cut_quoted(&in_user_terms(message));
    match culprit {
        Some(k) => semantic(&format!("{path}.{k}"), message),
        None => semantic(path, message),
    }
}

/// serde's message with its Rust type names (`u8`, `f32`) said as what a
/// scene file may hold there.
fn in_user_terms(message: &str) -> String {
    [
        (
            "expected a sequence of 3 f32 values",
            "expected a list of three numbers",
        ),
        ("expected u8", "expected an integer from 0 to 255"),
        ("expected u32", "expected an integer from 0 to 4294967295"),
        ("expected f32", "expected a number"),
        ("expected a sequence", "expected a list"),
        (
            "expected an array of length 3",
            "expected a list of three numbers",
        ),
    ]
    .iter()
    .fold(message.to_string(), |m, (rust, user)| m.replace(rust, user))
}

/// What a JSON value is, for messages (strings cut).
fn kind(v: &Value) -> String {
    match v {
        Value::Null => "null".into(),
        Value::Bool(b) => format!("the boolean {b}"),
        Value::Number(n) => format!("the number {n}"),
        Value::String(s) => format!("the string \"{}\"", cut(s)),
        Value::Array(_) => "a list".into(),
        Value::Object(_) => "an object".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(text: &str) -> String {
        CsgNode::from_json(text).unwrap_err().to_string()
    }

    #[test]
    fn schema_errors_name_the_node_path() {
        let cases = [
            (
                r#"{"type":"union","children":[{"type":"sphere","radius":1},{"type":"blob"}]}"#,
                "scene node `root.children[1]`: unknown variant `blob`",
            ),
            (
                r#"{"type":"difference","a":{"type":"sphere","radius":1},"b":{"type":"sphere"}}"#,
                "scene node `root.b`: missing field `radius`",
            ),
            (
                r#"{"type":"transform","child":{"type":"box","half_extents":[1,1,1],"colour":2}}"#,
                "scene node `root.child`: unknown field `colour`",
            ),
            (
                r#"{"type":"union","children":[3]}"#,
                "scene node `root.children[0]`: expected a node (an object with a \"type\"), got the number 3",
            ),
            (
                r#"{"type":"union","children":{"type":"sphere","radius":1}}"#,
                "scene node `root.children`: invalid type: map, expected a list",
            ),
            (r#"{"radius":1}"#, "scene node `root`: missing field `type`"),
            // A value of the wrong kind or out of its type's range: the field's
            // path and the range in a scene file's terms.
            (
                r#"{"type":"material","id":256,"child":{"type":"sphere","radius":1}}"#,
                "scene node `root.id`: invalid value: integer `256`, expected an integer from 0 to 255",
            ),
            (
                r#"{"type":"union","children":[{"type":"material","id":-1,"child":{"type":"sphere","radius":1}}]}"#,
                "scene node `root.children[0].id`: invalid value: integer `-1`, expected an integer from 0 to 255",
            ),
            (
                r#"{"type":"material","id":2.5,"child":{"type":"sphere","radius":1}}"#,
                "scene node `root.id`: invalid type: floating point `2.5`, expected an integer from 0 to 255",
            ),
            (
                r#"{"type":"heightfield","amplitude":1,"frequency":1,"octaves":5,"seed":-3}"#,
                "scene node `root.seed`: invalid value: integer `-3`, expected an integer from 0 to 4294967295",
            ),
            (
                r#"{"type":"sphere","radius":"big"}"#,
                "scene node `root.radius`: invalid type: string \"big\", expected a number",
            ),
            (
                r#"{"type":"box","half_extents":[1,1]}"#,
                "scene node `root.half_extents`: invalid length 2, expected a list of three numbers",
            ),
        ];
        for (text, want) in cases {
            let got = err(text);
            assert!(got.starts_with(want), "{text}\n got: {got}\nwant: {want}");
        }
    }

    #[test]
    fn long_names_are_cut() {
        // Longer than any name: refused by its place before it is parsed.
        let ty = "x".repeat(1 << 20);
        let got = err(&format!("{{\n  \"type\": \"{ty}\"}}"));
        assert!(got.len() < 600, "{} bytes", got.len());
        assert!(got.starts_with("scene file line 2, column 11: "), "{got}");
        assert!(got.contains("a string of 1048576 bytes"), "{got}");
        // Escaped quotes do not end a string.
        let got = err(&format!(r#"{{"type":"sphere","radius":"{}\"{ty}"}}"#, "a"));
        assert!(got.contains("a string of 1048579 bytes"), "{got}");
        // Within the limit, unknown names are cut by the schema's message.
        let ty = "y".repeat(MAX_NAME);
        let got = err(&format!(r#"{{"type":"{ty}"}}"#));
        assert!(
            got.contains("bytes in all") && got.contains("expected one of"),
            "{got}"
        );
    }

    #[test]
    fn nesting_is_limited_with_a_message() {
        let nest = |depth: usize| {
            let mut s = r#"{"type":"sphere","radius":1}"#.to_string();
            for _ in 1..depth {
                s = format!(r#"{{"type":"union","children":[{s}]}}"#);
            }
            s
        };
        let node = CsgNode::from_json(&nest(MAX_DEPTH)).unwrap();
        node.compile().unwrap();
        let got = err(&nest(MAX_DEPTH + 1));
        assert!(got.contains("nests deeper than 32 nodes"), "{got}");
        assert!(got.contains("flatten"), "{got}");
        // Past serde's own limit the message still names the scene limit.
        let got = err(&nest(200));
        assert!(got.contains("at most 32 nodes deep"), "{got}");
    }
}
