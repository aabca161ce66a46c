//! The page: the template (`assets/page.html`) with its style, the frames as a JSON data block,
//! three.js and the viewer inlined.

use crate::base64::encode_f32;
use crate::recorder::Recorder;
use lieflow::scene::sketch::{End, Link, Shape, Sketch, Surface};
use serde_json::{Value, json};
use std::path::Path;

const TEMPLATE: &str = include_str!("../assets/page.html");
const CSS: &str = include_str!("../assets/viewer.css");
const THREE: &str = include_str!("../assets/three.min.js");
const THREE_LICENSE: &str = include_str!("../assets/THREE_LICENSE");
const VIEWER: &str = include_str!("../assets/viewer.js");

/// What a page says besides its frames.
#[derive(Debug, Clone, Default)]
pub struct PageInfo {
    /// The title (the scene's name).
    pub title: String,
    /// A line under it (the scheme, the steps).
    pub subtitle: String,
    /// The run's events: `(name, t)`.
    pub events: Vec<(String, f64)>,
}

/// Writes the page of `recorder`'s frames to `path`; returns its size in bytes.
///
/// # Errors
/// Writing the file.
pub fn write_page(path: &Path, recorder: &Recorder, info: &PageInfo) -> std::io::Result<usize> {
    let html = page(recorder, info);
    std::fs::write(path, &html)?;
    Ok(html.len())
}

/// The page's text.
pub(crate) fn page(r: &Recorder, info: &PageInfo) -> String {
    let data = data(r, info).to_string();
    // Inside a <script> element: no `</` may end it early.
    let data = data.replace('<', "\\u003c");
    let escape = |s: &str| {
        s.replace('&', "&amp;")
            .replace('<', "&lt;")
            .replace('>', "&gt;")
            .replace('"', "&quot;")
    };
    let mut out = String::with_capacity(TEMPLATE.len() + data.len() + THREE.len() + VIEWER.len());
    let mut rest = TEMPLATE;
    while let Some(open) = rest.find("{{") {
        out.push_str(&rest[..open]);
        let close = open + rest[open..].find("}}").expect("a closed placeholder");
        match &rest[open + 2..close] {
            "TITLE" => out.push_str(&escape(&info.title)),
            "SUBTITLE" => out.push_str(&escape(&info.subtitle)),
            "VERSION" => out.push_str(env!("CARGO_PKG_VERSION")),
            "CSS" => out.push_str(CSS),
            "DATA" => out.push_str(&data),
            "THREE" => out.push_str(THREE),
            "THREE_LICENSE" => out.push_str(THREE_LICENSE),
            "VIEWER" => out.push_str(VIEWER),
            other => panic!("unknown placeholder {other}"),
        }
        rest = &rest[close + 2..];
    }
    out.push_str(rest);
    out
}

/// The data block the viewer reads.
fn data(r: &Recorder, info: &PageInfo) -> Value {
    let s: &Sketch = &r.sketch;
    let frames = r.times.len();
    json!({
        "dim": s.dim,
        "frames": frames,
        "slots": r.slots,
        "times": r.times,
        "steps": r.steps,
        "positions": encode_f32(&r.positions),
        "outputs": {
            "names": r.output_names,
            "values": encode_f32(&r.outputs),
        },
        "energy": (r.energy.len() == frames).then_some(&r.energy),
        "events": info.events.iter().map(|(name, t)| json!({"name": name, "t": t})).collect::<Vec<_>>(),
        "traces": r.traces,
        "bodies": s.bodies.iter().map(|b| json!({
            "name": b.name,
            "slot": b.slot,
            "mass": b.mass,
            "rigid": b.rigid.as_ref().map(|g| json!({
                "directors": g.directors,
                "axes": g.axes,
                "shape": shape(g.shape),
            })),
        })).collect::<Vec<_>>(),
        "links": s.links.iter().map(link).collect::<Vec<_>>(),
        "surfaces": s.surfaces.iter().map(|&f| surface(f)).collect::<Vec<_>>(),
    })
}

fn shape(s: Shape) -> Value {
    match s {
        Shape::Box { size } => json!({"kind": "box", "size": size}),
        Shape::Cylinder { radius, height } => {
            json!({"kind": "cylinder", "radius": radius, "height": height})
        }
        Shape::Sphere { radius } => json!({"kind": "sphere", "radius": radius}),
        Shape::InertiaBox { size } => json!({"kind": "inertia-box", "size": size}),
    }
}

fn end(e: End) -> Value {
    match e {
        End::Body { body, offset } => json!({"body": body, "offset": offset}),
        End::World(p) => json!({"world": p}),
    }
}

fn link(l: &Link) -> Value {
    json!({
        "kind": l.kind,
        "label": l.label,
        "a": end(l.a),
        "b": end(l.b),
        "axis": l.axis,
    })
}

fn surface(s: Surface) -> Value {
    match s {
        Surface::Plane { normal, offset } => {
            json!({"kind": "plane", "normal": normal, "offset": offset})
        }
        Surface::Sphere { centre, radius } => {
            json!({"kind": "sphere", "centre": centre, "radius": radius})
        }
    }
}
