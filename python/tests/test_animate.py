"""`Simulation.animate`: the run's animation page, the same page `lieflow run --animate` writes."""

import base64
import json
import pathlib
import re

import numpy as np
import pytest

import lieflow

ROOT = pathlib.Path(__file__).resolve().parents[2]


def page_data(path):
    text = pathlib.Path(path).read_text()
    block = re.search(r'<script id="lieflow-data" type="application/json">(.*?)</script>', text, re.S)
    return text, json.loads(block.group(1))


def test_animate_writes_one_self_contained_page_of_the_run(tmp_path):
    sim = lieflow.load(ROOT / "scenes" / "spinning_top.toml")
    out = tmp_path / "top.html"
    s = sim.animate(out, every=10, frames=50, trace=["top"])
    assert s["animation"]["path"] == str(out)
    assert s["animation"]["frames"] == 50
    assert s["animation"]["bytes"] == out.stat().st_size
    text, data = page_data(out)
    # three.js is inlined: nothing is fetched (no script or link with a source).
    assert "three.js 0.187.0" in text
    assert "Copyright © 2010-2026 three.js authors" in text  # its MIT licence travels with it
    assert not re.search(r"<script[^>]*\ssrc=", text)
    assert not re.search(r"<link[^>]*\shref=", text)
    assert data["frames"] == 50 and data["dim"] == 3
    assert data["bodies"][0]["rigid"]["shape"] == {"kind": "cylinder", "radius": 0.1, "height": 0.2}
    # The first frame is the initial state, the last the run's end (as float32).
    pos = np.frombuffer(base64.b64decode(data["positions"]), dtype="<f4").reshape(50, -1, 3)
    n = s["states"].shape[1] // 2
    q0 = s["states"][0][:n].reshape(-1, 3)
    q1 = s["states"][-1][:n].reshape(-1, 3)
    np.testing.assert_array_equal(pos[0], q0.astype(np.float32))
    np.testing.assert_array_equal(pos[-1], q1.astype(np.float32))
    assert data["times"][0] == 0.0 and data["times"][-1] == s["t"]
    assert data["outputs"]["names"] == ["height"]


def test_animate_refuses_what_it_cannot_draw():
    sim = lieflow.load(ROOT / "scenes" / "paper.toml")
    with pytest.raises(ValueError, match="built-in model"):
        sim.animate("never.html")
    sim = lieflow.load(ROOT / "scenes" / "damped_pendulum.toml")
    with pytest.raises(ValueError, match="'nobody'"):
        sim.animate("never.html", trace=["nobody"])
    with pytest.raises(ValueError, match="at least 2"):
        sim.animate("never.html", frames=1)
