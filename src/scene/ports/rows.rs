//! How an output names a constraint: by its `name`, or by its row in the scene **as declared**
//! (every constraint on, none dropped), never by a row of the assembled model, whose numbering
//! moves when `--off NAME` switches a constraint off or a redundant one is dropped.

use crate::scene::error::{FieldPath, SceneErrorKind};
use crate::scene::validate::{Result, err};
use serde::Deserialize;

/// A constraint as an output names it: `constraint = "rail"` or `constraint = 2`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(untagged)]
pub enum ConstraintRef {
    /// A row of the scene as declared (the rows of the constraints in file order, generators'
    /// first; a pin has `dim` rows, every other constraint one).
    Row(usize),
    /// The `name` of a declared constraint (with `component` choosing among its rows when it
    /// has several).
    Name(String),
}

/// One row of the scene as declared: the label of its term, the row within the term, and the
/// declaration's path.
#[derive(Debug, Clone)]
struct DeclaredRow {
    label: String,
    within: usize,
    path: FieldPath,
}

/// A term of the assembled model: its label, declaration, first row and row count.
#[derive(Debug, Clone)]
struct AssembledTerm {
    label: String,
    path: FieldPath,
    row: usize,
    rows: usize,
}

/// The constraint rows as declared and as assembled, and why a declared row may be absent.
#[derive(Debug, Clone, Default)]
pub(crate) struct ConstraintRows {
    declared: Vec<DeclaredRow>,
    assembled: Vec<AssembledTerm>,
    /// The declarations' names, with their paths.
    names: Vec<(String, FieldPath)>,
    /// The names switched off (`off`, `--off`).
    off: Vec<String>,
    /// The labels of the terms dropped as redundant.
    dropped: Vec<String>,
    /// `[flags] constraints = false`.
    all_off: bool,
    /// The named hinges' and sliders' coordinates (`joint-position`, `joint-velocity`).
    pub(crate) joints: std::sync::Arc<super::JointTable>,
}

impl ConstraintRows {
    /// From the declared terms `(label, path, rows)` (every constraint on), the assembled ones
    /// `(label, path, first row, rows)`, the declarations' names and what left terms out.
    pub(crate) fn new(
        declared: impl IntoIterator<Item = (String, FieldPath, usize)>,
        assembled: impl IntoIterator<Item = (String, FieldPath, usize, usize)>,
        names: impl IntoIterator<Item = (String, FieldPath)>,
        off: Vec<String>,
        dropped: Vec<String>,
        all_off: bool,
    ) -> Self {
        let declared = declared
            .into_iter()
            .flat_map(|(label, path, rows)| {
                (0..rows).map(move |within| DeclaredRow {
                    label: label.clone(),
                    within,
                    path: path.clone(),
                })
            })
            .collect();
        let assembled = assembled
            .into_iter()
            .map(|(label, path, row, rows)| AssembledTerm {
                label,
                path,
                row,
                rows,
            })
            .collect();
        Self {
            declared,
            assembled,
            names: names.into_iter().collect(),
            off,
            dropped,
            all_off,
            joints: std::sync::Arc::default(),
        }
    }

    /// No rows; the joints' coordinates `joints` (what an event may read).
    pub(crate) fn joints_only(joints: std::sync::Arc<super::JointTable>) -> Self {
        Self {
            joints,
            ..Self::default()
        }
    }

    /// The assembled row of `r` (`component` picks a row of a named constraint with several),
    /// and the default column name; a located error when it names nothing, a row of a
    /// constraint switched off or dropped, or is ambiguous.
    pub(crate) fn resolve(
        &self,
        r: Option<&ConstraintRef>,
        component: Option<usize>,
        path: &FieldPath,
    ) -> Result<(usize, String)> {
        let at = path.key("constraint");
        match r.unwrap_or(&ConstraintRef::Row(0)) {
            ConstraintRef::Row(row) => {
                let Some(d) = self.declared.get(*row) else {
                    return Err(err(
                        SceneErrorKind::Reference,
                        at,
                        format!(
                            "constraint row {row}, but the scene declares {} rows",
                            self.declared.len()
                        ),
                    ));
                };
                let found = self
                    .assembled
                    .iter()
                    .find(|t| t.label == d.label && self.lost_row(&t.label).is_none());
                match found {
                    Some(t) => Ok((t.row + d.within, format!("lambda{row}"))),
                    None => Err(err(
                        SceneErrorKind::Reference,
                        at,
                        format!(
                            "constraint row {row} is {}'s, which {}",
                            d.label,
                            self.why_absent(&d.label, &d.path)
                        ),
                    )),
                }
            }
            ConstraintRef::Name(name) => {
                let Some((_, decl)) = self.names.iter().find(|(n, _)| n == name) else {
                    let known: Vec<&str> = self.names.iter().map(|(n, _)| n.as_str()).collect();
                    return Err(err(
                        SceneErrorKind::Reference,
                        at,
                        format!(
                            "no constraint is named '{name}' (named ones: {})",
                            if known.is_empty() {
                                "none".to_owned()
                            } else {
                                known.join(", ")
                            }
                        ),
                    ));
                };
                let partial = self
                    .assembled
                    .iter()
                    .filter(|t| t.path == *decl)
                    .find_map(|t| self.lost_row(&t.label));
                if let Some(row) = partial {
                    return Err(err(
                        SceneErrorKind::Reference,
                        at,
                        format!(
                            "constraint '{name}' lost its {row} as redundant: its rows are not those declared"
                        ),
                    ));
                }
                let rows: Vec<usize> = self
                    .assembled
                    .iter()
                    .filter(|t| t.path == *decl)
                    .flat_map(|t| t.row..t.row + t.rows)
                    .collect();
                if rows.is_empty() {
                    return Err(err(
                        SceneErrorKind::Reference,
                        at,
                        format!(
                            "constraint '{name}' {}",
                            self.why_absent(&format!("'{name}'"), decl)
                        ),
                    ));
                }
                match (rows.as_slice(), component) {
                    ([row], None | Some(0)) => Ok((*row, format!("lambda_{name}"))),
                    (_, Some(k)) if k < rows.len() => Ok((rows[k], format!("lambda_{name}_{k}"))),
                    (_, k) => Err(err(
                        SceneErrorKind::Reference,
                        path.key("component"),
                        match k {
                            None => format!(
                                "constraint '{name}' has {} rows: choose one with `component = 0 … {}`",
                                rows.len(),
                                rows.len() - 1
                            ),
                            Some(k) => format!(
                                "component {k}, but constraint '{name}' has {} rows",
                                rows.len()
                            ),
                        },
                    )),
                }
            }
        }
    }

    /// The index of the assembled term that holds `row` (a row [`resolve`](Self::resolve)
    /// returned).
    pub(crate) fn term_of(&self, row: usize) -> usize {
        self.assembled
            .iter()
            .position(|t| t.row <= row && row < t.row + t.rows)
            .expect("a resolved row")
    }

    /// `"row k"` when the term `label` lost that row as dependent (`drop-dependent`).
    fn lost_row(&self, label: &str) -> Option<&str> {
        self.dropped.iter().find_map(|d| {
            d.strip_prefix(label)
                .and_then(|r| r.strip_prefix(' '))
                .filter(|r| r.starts_with("row "))
        })
    }

    /// Why a declared term is not in the model: switched off, dropped, or every constraint off.
    fn why_absent(&self, label: &str, decl: &FieldPath) -> String {
        if self.all_off {
            return "is not simulated: [flags] constraints = false".to_owned();
        }
        if let Some((name, _)) = self
            .names
            .iter()
            .find(|(n, p)| p == decl && self.off.contains(n))
        {
            return format!(
                "is switched off (off = ['{name}'] or --off {name}): it has no multiplier"
            );
        }
        if self.dropped.iter().any(|d| d == label) {
            return "was dropped as redundant: it has no multiplier".to_owned();
        }
        if let Some(row) = self.lost_row(label) {
            return format!("lost its {row} as redundant: its rows are not those declared");
        }
        "is not in the compiled model".to_owned()
    }
}
