//! Scene fields addressed by path (`effects[1].coefficient`): parsing, and setting a value in
//! the scene's TOML table with the type the field had. Used by sweeps (a member's values) and by
//! [`set_parameter`](super::set_parameter) (a parameter changed between steps).

use super::{FieldPath, SceneError, SceneErrorKind};

fn bad(what: impl Into<String>) -> SceneError {
    SceneError::new(SceneErrorKind::Value, FieldPath::root(), what.into())
}

/// A path segment: a key or an index.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Seg<'a> {
    /// A table's key.
    Key(&'a str),
    /// An array's index.
    Index(usize),
}

/// Parses `a.b[2].c` into its segments.
///
/// # Errors
/// An empty key, a bad or unclosed index.
pub fn parse_path(path: &str) -> Result<Vec<Seg<'_>>, SceneError> {
    let mut segs = Vec::new();
    for part in path.split('.') {
        let (key, mut rest) = match part.find('[') {
            Some(i) => (&part[..i], &part[i..]),
            None => (part, ""),
        };
        if key.is_empty() {
            return Err(bad(format!("parameter path '{path}': empty key")));
        }
        segs.push(Seg::Key(key));
        while let Some(r) = rest.strip_prefix('[') {
            let end = r
                .find(']')
                .ok_or_else(|| bad(format!("parameter path '{path}': missing ']'")))?;
            let i = r[..end].parse().map_err(|_| {
                bad(format!(
                    "parameter path '{path}': bad index '{}'",
                    &r[..end]
                ))
            })?;
            segs.push(Seg::Index(i));
            rest = &r[end + 1..];
        }
        if !rest.is_empty() {
            return Err(bad(format!("parameter path '{path}': unexpected '{rest}'")));
        }
    }
    Ok(segs)
}

/// The TOML value for `value` in a field that holds `old`: an integer where the base scene has
/// an integer and the value is integral (`links`, `order`), else a float.
pub fn value_like(old: Option<&toml::Value>, value: f64) -> toml::Value {
    match old {
        Some(toml::Value::Integer(_)) if value.fract() == 0.0 && value.abs() < 9.0e15 => {
            toml::Value::Integer(value as i64)
        }
        _ => toml::Value::Float(value),
    }
}

/// Sets `path` in `table` to `value`: every key and index but the last must exist; the last
/// key may be new (a field the scene leaves at its default).
///
/// # Errors
/// A path that does not parse or names no field of the table.
pub fn set_path(table: &mut toml::Table, path: &str, value: f64) -> Result<(), SceneError> {
    let segs = parse_path(path)?;
    let missing = |what: &str| {
        bad(format!(
            "parameter path '{path}': the base scene has no {what}"
        ))
    };
    let mut cur: &mut toml::Value = match segs.first() {
        Some(Seg::Key(k)) if segs.len() == 1 => {
            let v = value_like(table.get(*k), value);
            table.insert((*k).to_owned(), v);
            return Ok(());
        }
        Some(Seg::Key(k)) => table
            .get_mut(*k)
            .ok_or_else(|| missing(&format!("'{k}'")))?,
        _ => {
            return Err(bad(format!(
                "parameter path '{path}' must start with a key"
            )));
        }
    };
    for (i, seg) in segs.iter().enumerate().skip(1) {
        let last = i + 1 == segs.len();
        match seg {
            Seg::Key(k) => {
                let t = cur
                    .as_table_mut()
                    .ok_or_else(|| missing(&format!("table before '{k}'")))?;
                if last {
                    let v = value_like(t.get(*k), value);
                    t.insert((*k).to_owned(), v);
                    return Ok(());
                }
                cur = t.get_mut(*k).ok_or_else(|| missing(&format!("'{k}'")))?;
            }
            Seg::Index(j) => {
                let a = cur
                    .as_array_mut()
                    .ok_or_else(|| missing(&format!("array for [{j}]")))?;
                let len = a.len();
                let slot = a
                    .get_mut(*j)
                    .ok_or_else(|| missing(&format!("element [{j}] (it has {len})")))?;
                if last {
                    *slot = value_like(Some(slot), value);
                    return Ok(());
                }
                cur = slot;
            }
        }
    }
    Ok(())
}

/// The number at `path` in `table` (an integer or a float field).
///
/// # Errors
/// A path that does not parse, names no field, or names one that is not a number.
pub fn value_at(table: &toml::Table, path: &str) -> Result<f64, SceneError> {
    let missing = |what: String| bad(format!("parameter path '{path}': the scene has no {what}"));
    let mut cur: Option<&toml::Value> = None;
    for seg in parse_path(path)? {
        cur = Some(match (seg, cur) {
            (Seg::Key(k), None) => table.get(k).ok_or_else(|| missing(format!("'{k}'")))?,
            (Seg::Key(k), Some(v)) => v
                .as_table()
                .and_then(|t| t.get(k))
                .ok_or_else(|| missing(format!("'{k}'")))?,
            (Seg::Index(i), Some(v)) => v
                .as_array()
                .and_then(|a| a.get(i))
                .ok_or_else(|| missing(format!("element [{i}]")))?,
            (Seg::Index(_), None) => {
                return Err(bad(format!(
                    "parameter path '{path}' must start with a key"
                )));
            }
        });
    }
    match cur {
        Some(toml::Value::Float(x)) => Ok(*x),
        Some(toml::Value::Integer(i)) => Ok(*i as f64),
        _ => Err(bad(format!("parameter path '{path}' names no number"))),
    }
}
