//! Checks of single values in a scene, each failing with a located error: finite, positive,
//! non-negative numbers; vectors of the scene's dimension.

use crate::scene::error::{FieldPath, SceneError, SceneErrorKind};

/// A scene's result: a located [`SceneError`] on failure.
pub(crate) type Result<T> = std::result::Result<T, SceneError>;

/// An error of `kind` at `path`.
pub(crate) fn err(kind: SceneErrorKind, path: FieldPath, msg: impl Into<String>) -> SceneError {
    SceneError::new(kind, path, msg)
}

/// `x` if `ok(x)`, else a `Value` error at `path` saying what `x` must be.
pub(crate) fn check(
    x: f64,
    path: &FieldPath,
    ok: bool,
    must: impl FnOnce() -> String,
) -> Result<f64> {
    if ok {
        Ok(x)
    } else {
        Err(err(
            SceneErrorKind::Value,
            path.clone(),
            format!("{}, not {x}", must()),
        ))
    }
}

pub(crate) fn finite(x: f64, path: &FieldPath) -> Result<f64> {
    check(x, path, x.is_finite(), || "the value must be finite".into())
}

pub(crate) fn positive(x: f64, path: &FieldPath, what: &str) -> Result<f64> {
    check(x, path, x.is_finite() && x > 0.0, || {
        format!("the {what} must be positive and finite")
    })
}

pub(crate) fn non_negative(x: f64, path: &FieldPath, what: &str) -> Result<f64> {
    check(x, path, x.is_finite() && x >= 0.0, || {
        format!("the {what} must be non-negative and finite")
    })
}

/// A `dim`-vector as `[f64; 3]` (zero-padded).
pub(crate) fn vector(v: &[f64], dim: usize, path: &FieldPath) -> Result<[f64; 3]> {
    if v.len() != dim {
        return Err(err(
            SceneErrorKind::Dimension,
            path.clone(),
            format!("{} entries, but the scene is {dim}-dimensional", v.len()),
        ));
    }
    let mut out = [0.0; 3];
    for (i, &x) in v.iter().enumerate() {
        out[i] = finite(x, &path.index(i))?;
    }
    Ok(out)
}

pub(crate) fn vector_or(
    v: &Option<Vec<f64>>,
    dim: usize,
    path: &FieldPath,
    default: [f64; 3],
) -> Result<[f64; 3]> {
    match v {
        Some(v) => vector(v, dim, path),
        None => Ok(default),
    }
}

pub(crate) fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

pub(crate) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
