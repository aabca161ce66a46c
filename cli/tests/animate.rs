//! The animation page (`lieflow run --animate`) in a real browser: headless Chromium opens the
//! page of a small scene, the page loads without console errors, its time slider reaches the
//! last frame, and screenshots at `t = 0` and at the last frame show the bodies where the run
//! put them (the run's CSV positions, projected by the page's own camera, land on pixels that
//! are not background) and differ from each other. Without Chromium the test says so and
//! passes, unless `LIEFLOW_REQUIRE_BROWSER` is set (CI installs Chromium and sets it).

#[path = "common/browser.rs"]
mod browser;
mod common;

use browser::{Image, chromium, dom, screenshot};
use common::{lieflow, repo, scratch, stderr, summary};
use serde_json::Value;
use std::path::Path;

const SIZE: (u32, u32) = (1000, 700);

/// The page's status (`#lieflow-status`) in a DOM dump.
fn status(dom: &str) -> Value {
    let start = dom
        .find("<pre id=\"lieflow-status\"")
        .expect("the status element");
    let open = start + dom[start..].find('>').unwrap() + 1;
    let close = open + dom[open..].find("</pre>").unwrap();
    let text = dom[open..close]
        .replace("&quot;", "\"")
        .replace("&amp;", "&");
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{e}: {text}"))
}

/// The screen pixel of world point `p` under the page's camera (`status.camera`).
fn project(camera: &Value, p: [f64; 3]) -> (f64, f64) {
    let m: Vec<f64> = camera["matrix"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    // Column-major 4 × 4, as three.js stores it.
    let clip: Vec<f64> = (0..4)
        .map(|i| m[i] * p[0] + m[4 + i] * p[1] + m[8 + i] * p[2] + m[12 + i])
        .collect();
    let (x, y) = (clip[0] / clip[3], clip[1] / clip[3]);
    let f = |k: &str| camera[k].as_f64().unwrap();
    (
        f("left") + (x + 1.0) / 2.0 * f("width"),
        f("top") + (1.0 - y) / 2.0 * f("height"),
    )
}

/// The rows of the run's CSV (header, then values), comment lines skipped.
fn csv(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let header: Vec<String> = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_owned)
        .collect();
    let rows = lines
        .map(|l| {
            l.split(',')
                .map(|v| v.parse().unwrap_or(f64::NAN))
                .collect()
        })
        .collect();
    (header, rows)
}

/// Each body's position in `row` (columns `q.<body>.x`, `.y`, `.z`), not a rigid body's
/// directors.
fn bodies(header: &[String], row: &[f64]) -> Vec<(String, [f64; 3])> {
    header
        .iter()
        .enumerate()
        .filter_map(|(i, h)| {
            let name = h.strip_prefix("q.")?.strip_suffix(".x")?;
            (!name.contains('#')).then(|| {
                let z = header.iter().position(|c| c == &format!("q.{name}.z"));
                (
                    name.to_owned(),
                    [row[i], row[i + 1], z.map_or(0.0, |z| row[z])],
                )
            })
        })
        .collect()
}

/// Asserts every body is drawn over its projected position: the pixels around it are not the
/// background.
fn drawn_at(
    image: &Image,
    camera: &Value,
    background: [u8; 3],
    bodies: &[(String, [f64; 3])],
    what: &str,
) {
    for (name, p) in bodies {
        let (x, y) = project(camera, *p);
        assert!(
            x >= 2.0 && y >= 2.0 && x < image.width as f64 - 2.0 && y < image.height as f64 - 2.0,
            "{what}: '{name}' at {p:?} projects off the page to ({x:.1}, {y:.1})"
        );
        let differs = |c: [u8; 3]| c.iter().zip(background).any(|(&a, b)| a.abs_diff(b) > 40);
        // A body's solid covers the 5 × 5 pixels around its projected centre (a line through
        // them, a rod's or a path's, covers at most half).
        let covered = (-2..=2)
            .flat_map(|dy: i32| (-2..=2).map(move |dx: i32| (dx, dy)))
            .filter(|(dx, dy)| {
                differs(image.at((x as i32 + dx) as usize, (y as i32 + dy) as usize))
            })
            .count();
        assert!(
            covered >= 20,
            "{what}: no body is drawn where '{name}' is ({p:?} → pixel ({x:.0}, {y:.0}): {covered} of 25 pixels drawn)"
        );
    }
}

/// Runs `scene` with an animation and a CSV of every step, opens the page and checks it.
fn check_page(scene: &str, extra: &[&str], tag: &str) {
    let Some(chrome) = chromium() else {
        eprintln!(
            "skipped: no Chromium (apt-get install chromium; CI sets LIEFLOW_REQUIRE_BROWSER)"
        );
        return;
    };
    let (page, rows) = (
        scratch(&format!("{tag}.html")),
        scratch(&format!("{tag}.csv")),
    );
    let mut args = vec![
        "run",
        scene,
        "--animate",
        page.to_str().unwrap(),
        "--csv",
        rows.to_str().unwrap(),
        "--every",
        "1",
    ];
    args.extend_from_slice(extra);
    let o = lieflow(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let run = summary(&o);
    let frames = run["animation"]["frames"].as_u64().unwrap();
    assert!(frames >= 2, "{run}");
    let profile = scratch(&format!("{tag}-profile"));
    let url = |hash: &str| format!("file://{}#{hash}", page.display());
    // A DOM dump's viewport is the window less the browser's own frame; a screenshot's is the
    // whole window. Size the dumps' window so that their viewport is the screenshots' (the
    // camera depends on it).
    let (probe, _) = dom(&chrome, &profile, SIZE, &url("frame=0"));
    let viewport = &status(&probe)["viewport"];
    let size = (
        2 * SIZE.0 - viewport[0].as_u64().unwrap() as u32,
        2 * SIZE.1 - viewport[1].as_u64().unwrap() as u32,
    );

    // Loaded without errors, at the first frame; the slider reaches the last.
    let (first_dom, console) = dom(&chrome, &profile, size, &url("frame=0"));
    let first = status(&first_dom);
    assert_eq!(
        first["viewport"],
        serde_json::json!([SIZE.0, SIZE.1]),
        "{first}"
    );
    assert_eq!(first["ready"], true, "{first}");
    assert_eq!(first["errors"], Value::Array(vec![]), "{first}");
    // Nothing on the console but the software renderer's performance notes.
    let said: Vec<&str> = console
        .lines()
        .filter(|l| l.contains(":CONSOLE:") && !l.contains("GL Driver Message"))
        .collect();
    assert!(said.is_empty(), "the page wrote to the console: {said:#?}");
    assert_eq!(first["frame"], 0);
    assert_eq!(first["frames"].as_u64(), Some(frames));
    let (last_dom, _) = dom(&chrome, &profile, size, &url("frame=last"));
    let last = status(&last_dom);
    assert_eq!(last["errors"], Value::Array(vec![]), "{last}");
    assert_eq!(last["frame"].as_u64(), Some(frames - 1));
    assert_eq!(last["slider"]["value"], last["slider"]["max"], "{last}");
    assert_eq!(last["slider"]["max"].as_u64(), Some(frames - 1));
    assert_eq!(
        last["t"].as_f64(),
        run["t"].as_f64(),
        "the last frame is the run's end"
    );
    // Playing moves the frame on (virtual time runs the page's animation loop).
    let (played, _) = dom(&chrome, &profile, size, &url("play"));
    assert!(
        status(&played)["frame"].as_u64().unwrap() > 0,
        "playing did not advance"
    );

    // The bodies stand where the run put them, at t = 0 and at the end.
    let (header, values) = csv(&rows);
    let background: Vec<u8> = first["background"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_u64().unwrap() as u8)
        .collect();
    let background = [background[0], background[1], background[2]];
    let shot0 = screenshot(
        &chrome,
        &profile,
        SIZE,
        &url("frame=0"),
        &scratch(&format!("{tag}-0.png")),
    );
    let shot1 = screenshot(
        &chrome,
        &profile,
        SIZE,
        &url("frame=last"),
        &scratch(&format!("{tag}-1.png")),
    );
    assert_eq!(
        (shot0.width, shot0.height),
        (SIZE.0 as usize, SIZE.1 as usize)
    );
    drawn_at(
        &shot0,
        &first["camera"],
        background,
        &bodies(&header, &values[0]),
        "t = 0",
    );
    drawn_at(
        &shot1,
        &last["camera"],
        background,
        &bodies(&header, values.last().unwrap()),
        "the last frame",
    );
    let changed = shot0
        .rgb
        .iter()
        .zip(&shot1.rgb)
        .filter(|(a, b)| a != b)
        .count();
    assert!(
        changed > 200,
        "the first and last frames differ in {changed} pixels only"
    );
}

#[test]
fn the_page_of_a_planar_pendulum_plays_in_a_browser_with_its_bodies_in_place() {
    check_page(
        &repo("scenes/damped_pendulum.toml"),
        &["--t-end", "2"],
        "pendulum",
    );
}

#[test]
fn the_page_of_a_rigid_top_draws_the_body_where_the_run_put_it() {
    check_page(
        &repo("scenes/spinning_top.toml"),
        &["--t-end", "0.5"],
        "top",
    );
}

/// The page's data block.
fn page_data(path: &Path) -> Value {
    let text = std::fs::read_to_string(path).unwrap();
    let open = text
        .find("<script id=\"lieflow-data\" type=\"application/json\">")
        .unwrap();
    let start = open + text[open..].find('>').unwrap() + 1;
    let end = start + text[start..].find("</script>").unwrap();
    serde_json::from_str(&text[start..end]).unwrap()
}

#[test]
fn the_page_holds_the_runs_first_and_last_states_and_its_events() {
    // The forced pendulum records events; its page marks them.
    let page = scratch("forced.html");
    let o = lieflow(&[
        "run",
        &repo("scenes/forced_pendulum.toml"),
        "--animate",
        page.to_str().unwrap(),
        "--frames",
        "40",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let run = summary(&o);
    let data = page_data(&page);
    // At most 40 frames spread over 20 s; the run stops at its `high` event, and the page
    // ends there.
    let frames = data["frames"].as_u64().unwrap() as usize;
    assert!((2..40).contains(&frames), "{frames} frames");
    assert_eq!(run["animation"]["frames"].as_u64(), Some(frames as u64));
    assert!(run["stopped_by"].is_string(), "{run}");
    assert_eq!(data["times"][frames - 1].as_f64(), run["t"].as_f64());
    let events = run["events"].as_array().unwrap();
    assert!(!events.is_empty(), "the scene records events");
    assert_eq!(data["events"].as_array().unwrap().len(), events.len());
    assert_eq!(data["events"][0]["t"], events[0]["t"]);
    // The last frame's positions are the final state's, as f32.
    let b64 = data["positions"].as_str().unwrap();
    let bytes = decode_base64(b64);
    let slots = data["slots"].as_u64().unwrap() as usize;
    let last: Vec<f32> = bytes[((frames - 1) * slots * 12)..]
        .chunks(4)
        .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
        .collect();
    let x: Vec<f64> = run["x"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    let d = data["dim"].as_u64().unwrap() as usize;
    for s in 0..slots {
        for k in 0..d {
            assert_eq!(last[3 * s + k], x[s * d + k] as f32, "slot {s}, axis {k}");
        }
    }
}

fn decode_base64(text: &str) -> Vec<u8> {
    let value = |c: u8| match c {
        b'A'..=b'Z' => c - b'A',
        b'a'..=b'z' => c - b'a' + 26,
        b'0'..=b'9' => c - b'0' + 52,
        b'+' => 62,
        b'/' => 63,
        _ => panic!("not base64: {c}"),
    };
    let mut out = Vec::new();
    for chunk in text.as_bytes().chunks(4) {
        let n = chunk.iter().take_while(|&&c| c != b'=').count();
        let mut v = 0u32;
        for (i, &c) in chunk.iter().enumerate() {
            v |= u32::from(if i < n { value(c) } else { 0 }) << (18 - 6 * i);
        }
        out.extend_from_slice(&v.to_be_bytes()[1..n]);
    }
    out
}

#[test]
fn a_sweep_animates_the_member_it_is_asked_for() {
    let (page, out) = (scratch("member.html"), scratch("sweep-out"));
    let sweep = repo("tests/data/sweep_damped.toml");
    let o = lieflow(&[
        "sweep",
        &sweep,
        "--out",
        out.to_str().unwrap(),
        "--threads",
        "1",
        "--animate",
        page.to_str().unwrap(),
        "--animate-member",
        "3",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j = summary(&o);
    assert!(j["animation"]["frames"].as_u64().unwrap() >= 2, "{j}");
    assert!(page_data(&page)["frames"].as_u64().unwrap() >= 2);
    let o = lieflow(&[
        "sweep",
        &sweep,
        "--out",
        out.to_str().unwrap(),
        "--animate",
        page.to_str().unwrap(),
        "--animate-member",
        "99",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--animate-member 99"), "{}", stderr(&o));
}

#[test]
fn animation_flags_are_checked_before_the_run() {
    let page = scratch("refused.html");
    for (args, expect) in [
        (vec!["run", "--animate", "out.svg"], "ending in .html"),
        (
            vec![
                "run",
                &repo("scenes/paper.toml"),
                "--animate",
                page.to_str().unwrap(),
            ],
            "built-in model",
        ),
        (
            vec![
                "run",
                "--animate",
                page.to_str().unwrap(),
                "--trace",
                "nobody",
            ],
            "'nobody'",
        ),
        (
            vec!["run", "--animate", page.to_str().unwrap(), "--frames", "1"],
            "at least 2",
        ),
    ] {
        let o = lieflow(&args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(expect), "{args:?}: {}", stderr(&o));
    }
}
