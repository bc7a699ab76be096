//! Reading a scene file's JSON into a [`CsgNode`] one node at a time, so every
//! schema error names the node's path (`root.children[2]`), long names from the
//! file are cut, and nesting is limited to [`MAX_DEPTH`] nodes.

use super::CsgNode;
use crate::error::SceneError;
use crate::io::{cut, cut_quoted};
use serde::Deserialize;
use serde_json::{Map, Value};

/// The deepest a scene may nest: a node path has at most this many nodes
/// (`root` is depth 1). Deeper trees gain nothing a wider union does not give,
/// and every level costs stack when the scene is checked, compiled and evaluated.
pub const MAX_DEPTH: usize = 32;

/// Parses a scene file's text: syntax errors carry line and column; schema errors
/// (unknown type or field, a missing or mistyped value, too deep) the node path.
pub(super) fn parse(text: &str) -> Result<CsgNode, SceneError> {
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
        "transform" => (&["child"], false),
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
    let mut n = CsgNode::deserialize(Value::Object(own))
        .map_err(|e| semantic(path, cut_quoted(&e.to_string())))?;
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
            (CsgNode::Transform { child, .. }, _) => {
                **child = node(val, &format!("{path}.child"), depth + 1)?;
            }
            _ => unreachable!("child keys are listed per node type"),
        }
    }
    Ok(n)
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
                "scene node `root`: invalid type: map, expected a sequence",
            ),
            (r#"{"radius":1}"#, "scene node `root`: missing field `type`"),
        ];
        for (text, want) in cases {
            let got = err(text);
            assert!(got.starts_with(want), "{text}\n got: {got}\nwant: {want}");
        }
    }

    #[test]
    fn long_names_are_cut() {
        let ty = "x".repeat(1 << 20);
        let got = err(&format!(r#"{{"type":"{ty}"}}"#));
        assert!(got.len() < 600, "{} bytes", got.len());
        assert!(got.contains("1048576 bytes in all"), "{got}");
        assert!(got.contains("expected one of"), "{got}");
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
