//! A node's numeric fields with the range each must lie in, and the message that
//! names the first field outside its range.

use crate::error::SceneError;
use crate::geometry::safe_length;
use glam::Vec3;

/// The shortest vector (and the smallest number in size) [`Range::NonZero`]
/// takes.
const MIN_LENGTH: f32 = 1e-6;

/// Whether a length (or NaN) is shorter than [`MIN_LENGTH`].
fn too_short(length: f32) -> bool {
    length.is_nan() || length < MIN_LENGTH
}

/// The range a field must lie in. A vector is checked as a whole against
/// [`Range::Finite`] and [`Range::NonZero`], and component by component (named
/// `field.x`, `field.y`, `field.z`) against the others.
#[derive(Clone, Copy, Debug)]
pub(super) enum Range {
    /// Finite and > 0.
    Positive,
    /// Finite and >= 0.
    NonNegative,
    /// > 0 and at most the value given.
    UpTo(f32),
    /// Finite and larger than another field (its name and value).
    Above(&'static str, f32),
    /// Smaller than another field (its name and value).
    Below(&'static str, f32),
    /// Finite; the message quotes the value.
    Finite,
    /// Finite; the message does not quote the value.
    FiniteUnquoted,
    /// Not (nearly) zero.
    NonZero,
}

/// A field's value: a number or a vector.
#[derive(Clone, Copy, Debug)]
pub(super) enum Value {
    /// A number.
    Scalar(f32),
    /// A vector.
    Vector(Vec3),
}

impl From<f32> for Value {
    fn from(v: f32) -> Value {
        Value::Scalar(v)
    }
}

impl From<Vec3> for Value {
    fn from(v: Vec3) -> Value {
        Value::Vector(v)
    }
}

/// One field of a node: its name in the scene file, its value and its range.
#[derive(Clone, Copy, Debug)]
pub(super) struct Param {
    field: &'static str,
    value: Value,
    range: Range,
}

/// The field `field` holding `value`, which must lie in `range`.
pub(super) fn param(field: &'static str, value: impl Into<Value>, range: Range) -> Param {
    Param {
        field,
        value: value.into(),
        range,
    }
}

/// Checks `params` in order; the error names the first bad field under `path`.
pub(super) fn check_all(params: &[Param], path: &str) -> Result<(), SceneError> {
    params.iter().try_for_each(|p| p.check(path))
}

impl Param {
    /// Checks the value of the node at `path`; the error names `path.field`.
    fn check(&self, path: &str) -> Result<(), SceneError> {
        let fault = |field: String, message: String| {
            Err(SceneError::Semantic {
                path: format!("{path}.{field}"),
                message,
            })
        };
        match (self.value, self.range) {
            (Value::Vector(v), Range::Finite) if !v.is_finite() => {
                fault(self.field.into(), format!("must be finite, got {v}"))
            }
            (Value::Vector(v), Range::NonZero) if too_short(safe_length(v)) => fault(
                self.field.into(),
                format!("must not be zero (length at least {MIN_LENGTH}), got {v}"),
            ),
            (Value::Vector(_), Range::Finite | Range::NonZero) => Ok(()),
            (Value::Vector(v), range) => {
                for (axis, x) in ["x", "y", "z"].iter().zip(v.to_array()) {
                    if let Some(message) = range.fault(x) {
                        return fault(format!("{}.{axis}", self.field), message);
                    }
                }
                Ok(())
            }
            (Value::Scalar(x), range) => match range.fault(x) {
                Some(message) => fault(self.field.into(), message),
                None => Ok(()),
            },
        }
    }
}

impl Range {
    /// What is wrong with the number `v`, or `None` when it lies in the range.
    fn fault(self, v: f32) -> Option<String> {
        match self {
            Range::Positive => (!(v.is_finite() && v > 0.0))
                .then(|| format!("must be a finite number > 0, got {v}")),
            Range::UpTo(max) => {
                (!(v > 0.0 && v <= max)).then(|| format!("must be > 0 and at most {max}, got {v}"))
            }
            Range::NonNegative => {
                (!(v.is_finite() && v >= 0.0)).then(|| format!("must be finite and >= 0, got {v}"))
            }
            Range::Above(name, other) => (!(v.is_finite() && v > other))
                .then(|| format!("must be finite and larger than {name} {other}, got {v}")),
            Range::Below(name, other) => {
                (v >= other).then(|| format!("must be smaller than {name} {other}, got {v}"))
            }
            Range::Finite => (!v.is_finite()).then(|| format!("must be finite, got {v}")),
            Range::FiniteUnquoted => (!v.is_finite()).then(|| "must be finite".to_string()),
            Range::NonZero => too_short(v.abs())
                .then(|| format!("must not be zero (at least {MIN_LENGTH} in size), got {v}")),
        }
    }
}
