"""The Python package against the same numbers as the Rust tests and the command."""

import json
import math
import os
import pathlib
import subprocess

import numpy as np
import pytest

import lieflow

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCENES = ROOT / "scenes"
BIN = pathlib.Path(os.environ.get("LIEFLOW_BIN", ROOT / "target" / "release" / "lieflow"))

FORCED = """version = 1
name = "pushed pendulum"
dim = 2
[[bodies]]
name = "bob"
mass = 1.0
position = [0.0, -1.0]
[[constraints]]
type = "rod"
name = "hinge"
bodies = ["bob"]
point = [0.0, 0.0]
[[effects]]
type = "gravity"
g = [0.0, -9.81]
[[inputs]]
type = "force"
name = "push"
bodies = ["bob"]
direction = [1.0, 0.0]
signal = { type = "held", value = 0.0 }
[[outputs]]
quantity = "position"
body = "bob"
component = 0
[integrator]
dt = 0.01
t_end = 2.0
"""


def command(scene, *flags):
    """The command's JSON summary of ``lieflow run scene flags…``."""
    if not BIN.exists():
        pytest.skip(f"the command is not built at {BIN} (cargo build --release)")
    out = subprocess.run(
        [str(BIN), "run", str(scene), *flags], capture_output=True, text=True, check=True
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize(
    "scene",
    [
        "paper.toml",
        "damped_pendulum.toml",
        "spinning_top.toml",
        "slider_crank.toml",
        "slider_crank_planar.toml",
        "kepler.toml",
    ],
)
def test_a_run_equals_the_command_bit_for_bit(scene):
    mine = lieflow.run(SCENES / scene)
    theirs = command(SCENES / scene)
    # Python's float parsing is correctly rounded and the command prints the shortest
    # round-trip form: equal floats mean equal bits.
    assert mine["x"] == theirs["x"]
    assert mine["steps"] == theirs["steps"]
    assert mine["dissipated"] == theirs["dissipated"]
    assert mine["max_abs_g"] == theirs["max_abs_g"]
    # A scene with a tolerance reports its controller's work, the same in both.
    assert mine["adaptive"] == theirs["adaptive"]
    if scene == "kepler.toml":
        assert mine["adaptive"]["accepted"] > mine["steps"]
        assert mine["adaptive"]["smallest_step"] < mine["adaptive"]["largest_step"] / 10


def test_a_run_at_the_accepted_steps_has_a_row_per_step_as_the_command_does():
    mine = lieflow.run(SCENES / "kepler.toml", accepted_steps=True)
    theirs = command(SCENES / "kepler.toml", "--accepted-steps")
    assert mine["x"] == theirs["x"]
    assert mine["adaptive"] == theirs["adaptive"]
    # A row per accepted step and the initial state, the controller's steps between them.
    assert mine["steps"] == mine["adaptive"]["accepted"]
    assert mine["times"].shape == (mine["steps"] + 1,)
    steps = np.diff(mine["times"])
    assert steps.min() > 0 and steps.max() > 10 * steps.min()
    with pytest.raises(ValueError, match="fixed steps of dt"):
        lieflow.run(SCENES / "damped_pendulum.toml", accepted_steps=True)


def test_the_paper_example_keeps_its_constraint_and_energy():
    s = lieflow.run(SCENES / "paper.toml")
    assert s["error"] is None
    assert s["max_abs_g"] < 1e-14
    assert s["max_abs_phi"] < 1e-14


def test_the_trajectory_is_one_numpy_array_from_the_initial_to_the_last_state():
    sim = lieflow.load(SCENES / "damped_pendulum.toml")
    x0 = sim.state
    s = sim.run(every=10)
    times, states = s["times"], s["states"]
    assert isinstance(states, np.ndarray) and states.dtype == np.float64
    assert states.shape == (101, 4) and times.shape == (101,)
    assert np.all(np.diff(times) > 0)
    assert np.array_equal(states[0], x0)
    assert list(states[-1]) == s["x"]
    assert times[-1] == s["t"] == 10.0
    # A step that does not divide t_end still ends on it, with its last state recorded.
    sim = lieflow.loads((SCENES / "damped_pendulum.toml").read_text().replace("dt = 0.01", "dt = 0.003"))
    s = sim.run(every=1000)
    assert s["times"][-1] == 10.0 and s["last_step"] == pytest.approx(0.001)


def test_stepping_saving_and_restoring_continue_bit_for_bit():
    sim = lieflow.loads(FORCED)
    assert sim.advance_to(0.5) == 50
    saved = sim.save()
    sim.set_input("push", 2.0)
    sim.advance_to(1.0)
    first = sim.state.copy()
    sim.restore(saved)
    assert sim.t == 0.5
    sim.set_input("push", 2.0)
    sim.advance_to(1.0)
    assert np.array_equal(sim.state, first)


def test_inputs_outputs_multipliers_and_energies_are_read_by_name():
    sim = lieflow.loads(FORCED)
    assert sim.input_names == ["push"]
    assert sim.output_names == ["bob.x"]
    assert sim.multiplier_names == ["hinge"]
    assert np.isnan(sim.multipliers()).all()  # no step has solved for them yet
    sim.set_input("push", 1.0)
    assert sim.input("push") == 1.0
    with pytest.raises(ValueError, match="no input 'nosuch'"):
        sim.input("nosuch")
    with pytest.raises(ValueError, match="not a bool"):
        sim.set_input("push", True)
    sim.advance_to(0.2)
    out = sim.outputs()
    assert out["bob.x"] == sim.state[0] > 0.0
    lam = sim.multipliers()
    assert lam.shape == (1,)
    # The rod carries about the bob's weight near the bottom (g = (|q|² − 1)/2: force λ |q|).
    assert lam[0] == pytest.approx(9.81, rel=0.05)
    assert sim.supplied > 0.0
    g, phi = sim.residuals()
    assert g < 1e-14 and phi < 1e-14
    # The energy budget H − H₀ = supplied (no damping) closes to the splitting's error.
    start = lieflow.loads(FORCED).energy
    assert sim.energy - start == pytest.approx(sim.supplied, abs=1e-4)


RIGID = """version = 1
dim = 3
[[bodies]]
name = "disc"
mass = 1.0
inertia = { shape = "cylinder", radius = 0.2, height = 0.05 }
position = [0.0, 0.0, 0.0]
[[constraints]]
type = "hinge"
name = "axle"
bodies = ["disc"]
anchor = [0.0, 0.0, 0.0]
axis = [0.0, 0.0, 1.0]
[[inputs]]
type = "hinge-torque"
name = "motor"
bodies = ["disc"]
axis = [0.0, 0.0, 1.0]
signal = { type = "held", value = 0.0 }
[[outputs]]
quantity = "angular-velocity"
body = "disc"
component = 2
[[outputs]]
quantity = "orientation"
body = "disc"
component = 3
[integrator]
dt = 0.01
t_end = 2.0
"""


def test_a_rigid_body_on_a_hinge_is_driven_and_read_by_name():
    # A disc (J = 0.02) on a hinge, its motor held at 0.1 N m by the embedder: its rate is
    # tau t / J to round-off, and its quaternion turns about z.
    sim = lieflow.loads(RIGID)
    assert sim.output_names == ["disc.wz", "disc.qz"]
    assert sim.input_names == ["motor"]
    sim.set_input("motor", 0.1)
    sim.advance_to(1.0)
    out = sim.outputs()
    assert out["disc.wz"] == pytest.approx(0.1 * 1.0 / 0.02, rel=1e-12)
    theta = 0.5 * 0.1 / 0.02 * 1.0**2
    assert out["disc.qz"] == pytest.approx(abs(math.sin(theta / 2)), abs=1e-3)
    g, phi = sim.residuals()
    assert g < 1e-14 and phi < 1e-13
    assert sim.supplied == pytest.approx(0.5 * 0.02 * (0.1 / 0.02) ** 2, rel=1e-9)


SERVO = """
version = 1
dim = 3
[[bodies]]
name = "disc"
mass = 1.0
inertia = { shape = "cylinder", radius = 0.2, height = 0.02 }
position = [0, 0, 0]
[[constraints]]
type = "hinge"
name = "axle"
bodies = ["disc"]
anchor = [0, 0, 0]
axis = [0, 0, 1]
[[inputs]]
type = "hinge-servo"
name = "servo"
bodies = ["disc"]
axis = [0, 0, 1]
stiffness = 2.0
damping = 0.4
signal = { type = "held", value = 0.0 }
[[outputs]]
name = "angle"
quantity = "joint-position"
constraint = "axle"
[[outputs]]
name = "rate"
quantity = "joint-velocity"
constraint = "axle"
[integrator]
dt = 0.001
t_end = 10.0
"""


def test_a_servo_follows_the_reference_an_embedder_sets():
    # A disc (J = 0.02) under a servo (k_p = 2, k_d = 0.4: critically damped, 10 rad/s): the
    # embedder sets the reference angle by name, and the joint's angle settles on it (the
    # kick runs the damper's flow around the spring's and the motor's kicks, which balance).
    sim = lieflow.loads(SERVO)
    assert sim.input_names == ["servo"]
    assert sim.output_names == ["angle", "rate"]
    sim.set_input("servo", 1.0)
    sim.advance_to(3.0)
    out = sim.outputs()
    assert out["angle"] == pytest.approx(1.0, abs=1e-9)
    assert out["rate"] == pytest.approx(0.0, abs=1e-5)
    sim.set_input("servo", -0.5)
    sim.advance_to(6.0)
    assert sim.outputs()["angle"] == pytest.approx(-0.5, abs=1e-9)
    assert sim.supplied is not None and sim.dissipated > 0.0


def test_a_bad_scene_raises_a_located_scene_error():
    text = (SCENES / "damped_pendulum.toml").read_text().replace("mass = 1.0", "mass = -1.0")
    with pytest.raises(lieflow.SceneError) as e:
        lieflow.loads(text, "bad.toml")
    assert "bad.toml:" in str(e.value) and "`bodies[0].mass`" in str(e.value)
    assert e.value.kind == "Value" and e.value.path == "bodies[0].mass"
    assert isinstance(e.value.line, int) and e.value.line > 0
    assert isinstance(e.value, ValueError)
    with pytest.raises(lieflow.SceneError):
        lieflow.load(ROOT / "no-such-scene.toml")


def test_a_failed_step_raises_and_keeps_the_last_good_state():
    sim = lieflow.loads(lieflow.default_scene().replace("dt = 1e-4", "dt = 0.5"))
    before = sim.state.copy()
    with pytest.raises(lieflow.StepError) as e:
        sim.step()
    assert "Newton" in str(e.value)
    assert np.array_equal(sim.state, before) and sim.t == 0.0


def test_bad_arguments_raise_value_errors():
    sim = lieflow.loads(FORCED)
    with pytest.raises(ValueError, match="push"):
        sim.set_input("pull", 1.0)
    with pytest.raises(ValueError):
        sim.set_state(np.zeros(3))
    with pytest.raises(ValueError):
        sim.advance_to(math.nan)
    sim.advance_to(0.1)
    with pytest.raises(ValueError, match="behind the current time"):
        sim.advance_to(0.05)
    assert sim.t == pytest.approx(0.1)
    # A re-projection reports how far it moved the state.
    x = sim.state.copy()
    x[0] += 1e-3
    report = sim.set_state(x, reproject=True)
    assert report["g_after"] < 1e-14 and 0.0 < report["moved"] < 1e-2
    assert sim.set_state(sim.state.copy()) is None
    with pytest.raises(ValueError):
        sim.run(every=0)


def test_a_work_precision_set_fits_the_orders_the_schemes_have():
    s = lieflow.precision(SCENES / "paper.toml", dts=[0.4, 0.2, 0.1], tolerances=[1e-6, 1e-10],
                          repeats=1)
    assert s["reference"]["source"].startswith("closed form")
    methods = {r["method"] for r in s["rows"]}
    assert "lieflow order 2" in methods and any(m.startswith("DOP853") for m in methods)
    assert all(r["status"] in ("ok", "Skipped") for r in s["rows"])
    assert s["fitted_orders"]["lieflow order 2"] == pytest.approx(2.0, abs=0.3)
    assert s["fitted_orders"]["lieflow order 4"] == pytest.approx(4.0, abs=0.3)
    with pytest.raises(ValueError):
        lieflow.precision(SCENES / "paper.toml", dts=[-0.1])


def test_a_sweep_returns_the_command_s_rows():
    sweep = ROOT / "tests" / "data" / "sweep_damped.toml"
    rows = lieflow.sweep(sweep, threads=2)
    assert [r["id"] for r in rows] == list(range(12))
    assert all(r["error"] is None and r["seconds"] >= 0 for r in rows)
    if not BIN.exists():
        pytest.skip("the command is not built")
    out = pathlib.Path(os.environ.get("TMPDIR", "/tmp")) / f"lieflow-py-sweep-{os.getpid()}"
    subprocess.run([str(BIN), "sweep", str(sweep), "--out", str(out), "--threads", "1"],
                   capture_output=True, check=True)
    theirs = [json.loads(l) for l in (out / "members.jsonl").read_text().splitlines()]
    for mine, their in zip(rows, theirs):
        mine = {k: v for k, v in mine.items() if k != "seconds"}
        assert json.loads(json.dumps(mine)) == their
