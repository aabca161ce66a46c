//! The names a run's CSV gives the state and the multipliers: `q.<body>.<axis>`,
//! `p.<body>.<axis>` and `v.<body>.<axis>` per body, and one `lambda.<constraint>` column per
//! constraint row — the constraint's `name` when the file gives one, otherwise its kind and
//! bodies (`rod:a-b`, `rod:a` to a fixed point, `pin:a.x`, `sphere:a`, `plane:a`).

use super::bodies::Bodies;
use crate::scene::error::FieldPath;
use crate::scene::model::SceneModel;
use crate::scene::schema::SceneFile;

const AXES: [&str; 3] = ["x", "y", "z"];

/// `q.<body>.<axis>` for every position coordinate, then `p.<body>.<axis>` for every momentum.
pub(super) fn state_names(bodies: &Bodies) -> Vec<String> {
    let dim = bodies.dim;
    ["q", "p"]
        .iter()
        .flat_map(|part| {
            bodies.list.iter().flat_map(move |b| {
                AXES[..dim]
                    .iter()
                    .map(move |axis| format!("{part}.{}.{axis}", b.name))
            })
        })
        .collect()
}

/// One name per constraint row of `model`, in row order.
pub(super) fn multiplier_names(
    model: &SceneModel,
    bodies: &Bodies,
    file: &SceneFile,
) -> Vec<String> {
    let name = |b: usize| bodies.list[b].name.as_str();
    let root = FieldPath::root().key("constraints");
    // The named declarations and how many terms each produced (one pass over the terms): a
    // name alone when it made one term, the name and the body when it made several.
    let mut named: Vec<(FieldPath, &String, usize)> = file
        .constraints
        .iter()
        .enumerate()
        .filter_map(|(i, c)| Some((root.index(i), c.name()?, 0)))
        .collect();
    if !named.is_empty() {
        for term in &model.constraints {
            if let Some(entry) = named.iter_mut().find(|e| e.0 == term.path) {
                entry.2 += 1;
            }
        }
    }
    let declared_name = |path: &FieldPath| {
        named
            .iter()
            .find(|e| e.0 == *path)
            .map(|e| (e.1.clone(), e.2 > 1))
    };
    let mut out = Vec::with_capacity(model.m);
    for term in &model.constraints {
        let named = declared_name(&term.path);
        let info = term.kind.info();
        let (kind, body) = (info.kind(), info.bodies(&|b| name(b).to_owned()));
        let base = match named {
            Some((n, false)) => n,
            Some((n, true)) => format!("{n}:{body}"),
            None => format!("{kind}:{body}"),
        };
        if term.rows(model.dim) > 1 {
            out.extend((0..term.rows(model.dim)).map(|r| format!("{base}.{}", info.row_name(r))));
        } else {
            out.push(base);
        }
    }
    out
}
