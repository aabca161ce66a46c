//! Errors of scene files: what is wrong, the field's path, and where it is in the file.

use std::fmt;
use toml::de::{DeTable, DeValue};

/// One step of a path into a scene document: a key or an array index.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum PathSegment {
    /// A table key.
    Key(String),
    /// An array index.
    Index(usize),
}

/// A path into a scene document, e.g. `effects[2].stiffness`.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct FieldPath(pub Vec<PathSegment>);

impl FieldPath {
    /// The empty path (the whole document).
    pub fn root() -> Self {
        Self(Vec::new())
    }
    /// This path followed by `key`.
    pub fn key(&self, key: &str) -> Self {
        let mut p = self.clone();
        p.0.push(PathSegment::Key(key.to_owned()));
        p
    }
    /// This path followed by `[index]`.
    pub fn index(&self, index: usize) -> Self {
        let mut p = self.clone();
        p.0.push(PathSegment::Index(index));
        p
    }
}

impl fmt::Display for FieldPath {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, s) in self.0.iter().enumerate() {
            match s {
                PathSegment::Key(k) if i == 0 => write!(f, "{k}")?,
                PathSegment::Key(k) => write!(f, ".{k}")?,
                PathSegment::Index(j) => write!(f, "[{j}]")?,
            }
        }
        Ok(())
    }
}

/// A position in a scene file (1-based line and column).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Location {
    /// The file name as given (`<default scene>` for the embedded one).
    pub file: String,
    /// Line, from 1.
    pub line: usize,
    /// Column in characters, from 1.
    pub column: usize,
}

/// What kind of problem a scene has.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum SceneErrorKind {
    /// The file could not be read.
    Io,
    /// Not valid TOML, or not the schema: a missing or unknown key, a wrong type.
    Syntax,
    /// A version this library does not read.
    Version,
    /// A value out of its range (non-positive mass or length, non-finite numbers, …).
    Value,
    /// A vector with the wrong number of entries.
    Dimension,
    /// A body name that names no body, or a name used twice.
    Reference,
    /// The initial state does not satisfy the constraints.
    OffConstraints,
    /// Constraints that depend on each other.
    Redundant,
    /// A combination the library refuses (an order above 2 with damping, …).
    Unsupported,
    /// Building the scheme failed (see the message).
    Setup,
}

/// An error in a scene: its kind, the field's path, the message and, when the scene came from
/// text, the file, line and column of the field.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub struct SceneError {
    /// What kind of problem.
    pub kind: SceneErrorKind,
    /// The field the problem is in (empty for the whole file).
    pub path: FieldPath,
    /// What is wrong and, where it helps, what to do instead.
    pub message: String,
    /// Where the field is in the file, when known.
    pub location: Option<Location>,
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(l) = &self.location {
            write!(f, "{}:{}:{}: ", l.file, l.line, l.column)?;
        }
        if !self.path.0.is_empty() {
            write!(f, "`{}`: ", self.path)?;
        }
        write!(f, "{}", self.message)
    }
}

impl SceneError {
    /// An error of `kind` at `path`, not yet located in a file.
    pub fn new(kind: SceneErrorKind, path: FieldPath, message: impl Into<String>) -> Self {
        Self {
            kind,
            path,
            message: message.into(),
            location: None,
        }
    }

    /// Fills in the location of the error's path in `text` (the file `file`): the deepest
    /// element of the path that the document has.
    pub fn locate(mut self, file: &str, text: &str) -> Self {
        if self.location.is_none()
            && let Some(offset) = span_of(text, &self.path)
        {
            self.location = Some(location_of(file, text, offset));
        }
        self
    }

    /// A TOML parse error of `text` (the file `file`) as a located [`SceneErrorKind::Syntax`]
    /// error; for an unknown key, at the key's line.
    pub fn from_toml_error(e: &toml::de::Error, file: &str, text: &str) -> Self {
        let mut se = Self::new(
            SceneErrorKind::Syntax,
            FieldPath::root(),
            e.message().trim_end().to_owned(),
        );
        if let Some(span) = e.span() {
            let at = unknown_key_offset(e.message(), text, span.clone()).unwrap_or(span.start);
            se.location = Some(location_of(file, text, at));
            if let Some(path) = path_at(text, at) {
                se.path = path;
            }
        }
        se
    }
}

/// The byte offset of the deepest existing element of `path` in `text`.
fn span_of(text: &str, path: &FieldPath) -> Option<usize> {
    let doc = DeTable::parse(text).ok()?;
    let mut start = doc.span().start;
    let mut value: Option<&DeValue<'_>> = None;
    let mut table: &DeTable<'_> = doc.get_ref();
    for seg in &path.0 {
        let next = match (seg, value) {
            (PathSegment::Key(k), None) => table.get(k.as_str()),
            (PathSegment::Key(k), Some(DeValue::Table(t))) => t.get(k.as_str()),
            (PathSegment::Index(i), Some(DeValue::Array(a))) => a.get(*i),
            _ => None,
        };
        let Some(next) = next else { break };
        start = next.span().start;
        value = Some(next.get_ref());
        if let DeValue::Table(t) = next.get_ref() {
            table = t;
        }
    }
    Some(start)
}

/// The field path of the innermost key or array element of `text` whose value spans byte
/// `offset` (the reverse of `span_of`), so that a value the format refuses is named by its
/// path as well as its line.
fn path_at(text: &str, offset: usize) -> Option<FieldPath> {
    let doc = DeTable::parse(text).ok()?;
    let mut path = FieldPath::root();
    find_in_table(doc.get_ref(), offset, &mut path).then_some(path)
}

/// Depth first: a table's header span need not cover its entries, so every entry is searched.
fn find_in_table(table: &DeTable<'_>, offset: usize, path: &mut FieldPath) -> bool {
    table.iter().any(|(k, v)| {
        path.0.push(PathSegment::Key(k.get_ref().to_string()));
        let found = find_in_value(v, offset, path) || k.span().contains(&offset);
        if !found {
            path.0.pop();
        }
        found
    })
}

fn find_in_value(value: &toml::Spanned<DeValue<'_>>, offset: usize, path: &mut FieldPath) -> bool {
    match value.get_ref() {
        DeValue::Table(t) => find_in_table(t, offset, path),
        DeValue::Array(a) => {
            a.iter().enumerate().any(|(i, v)| {
                path.0.push(PathSegment::Index(i));
                let found = find_in_value(v, offset, path);
                if !found {
                    path.0.pop();
                }
                found
            }) || value.span().contains(&offset)
        }
        _ => value.span().contains(&offset),
    }
}

/// Line and column (1-based, columns in characters) of byte `offset` in `text`.
pub(crate) fn location_of(file: &str, text: &str, offset: usize) -> Location {
    let offset = offset.min(text.len());
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    Location {
        file: file.to_owned(),
        line,
        column: before[line_start..].chars().count() + 1,
    }
}

/// For serde's "unknown field `k`, expected one of `a`, `b`, …" reported at `span` (for a
/// buffered, tagged table the parser reports the header of the array's first table): the offset
/// of the line that sets `k` in the first table after `span` whose other keys are all among the
/// expected ones (the table the message is about), else of the first line that sets `k`.
pub(crate) fn unknown_key_offset(
    message: &str,
    text: &str,
    span: std::ops::Range<usize>,
) -> Option<usize> {
    let key = message.strip_prefix("unknown field `")?.split('`').next()?;
    let expected: Vec<&str> = message
        .split_once("expected")
        .map(|(_, rest)| rest.split('`').skip(1).step_by(2).collect())
        .unwrap_or_default();
    let region = text.get(span.start..)?;
    // Lines with their offsets, split into tables at `[` headers.
    let mut tables: Vec<Vec<(usize, &str)>> = vec![Vec::new()];
    let mut offset = span.start;
    for line in region.split_inclusive('\n') {
        let trimmed = line.trim_start();
        if trimmed.starts_with('[') && !tables.last().is_some_and(|t| t.is_empty()) {
            tables.push(Vec::new());
        }
        tables
            .last_mut()
            .expect("one table at least")
            .push((offset + (line.len() - trimmed.len()), trimmed));
        offset += line.len();
    }
    let key_of = |line: &str| -> Option<String> {
        let (k, _) = line.split_once('=')?;
        let k = k.trim();
        (!k.is_empty() && !k.starts_with('#') && !k.starts_with('[')).then(|| k.to_owned())
    };
    let sets_key = |t: &[(usize, &str)]| {
        t.iter()
            .find(|(_, l)| key_of(l).as_deref() == Some(key))
            .map(|p| p.0)
    };
    let fits = |t: &[(usize, &str)]| {
        t.iter().filter_map(|(_, l)| key_of(l)).all(|k| {
            k == key || k == "type" || expected.is_empty() || expected.contains(&k.as_str())
        })
    };
    tables
        .iter()
        .find(|t| sets_key(t).is_some() && fits(t))
        .or_else(|| tables.iter().find(|t| sets_key(t).is_some()))
        .and_then(|t| sets_key(t))
}
