"""The FMU `lieflow fmu` exports, checked by a real importer: FMPy validates it and simulates it
with its own co-simulation master, driving the held input from a table, and its outputs equal
the same scene stepped through the package at the same communication points to 1e-12."""

import os
import pathlib
import subprocess

import numpy as np
import pytest

import lieflow

fmpy = pytest.importorskip("fmpy")
from fmpy.validation import validate_fmu  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCENE = ROOT / "tests" / "data" / "fmu_pendulum.toml"
BIN = pathlib.Path(os.environ.get("LIEFLOW_BIN", ROOT / "target" / "release" / "lieflow"))

# A force of 0 until t = 0.5, then 1 until t = 1, then -0.5 (steps as repeated times).
TABLE = np.array(
    [(0.0, 0.0), (0.5, 0.0), (0.5, 1.0), (1.0, 1.0), (1.0, -0.5), (2.0, -0.5)],
    dtype=[("time", np.float64), ("push", np.float64)],
)


def push(t):
    return 0.0 if t < 0.5 else (1.0 if t < 1.0 else -0.5)


@pytest.fixture(scope="module")
def fmu(tmp_path_factory):
    if not BIN.exists():
        pytest.skip(f"the command is not built at {BIN}")
    path = tmp_path_factory.mktemp("fmu") / "pendulum.fmu"
    out = subprocess.run([str(BIN), "fmu", str(SCENE), "-o", str(path)],
                         capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    return path


def test_fmpy_validates_the_fmu_without_a_problem(fmu):
    assert validate_fmu(str(fmu)) == []
    md = fmpy.read_model_description(str(fmu))
    assert md.fmiVersion == "3.0"
    assert float(md.coSimulation.fixedInternalStepSize) == 0.01
    names = {v.name: v.causality for v in md.modelVariables}
    assert names == {"time": "independent", "damping": "parameter", "push": "input",
                     "bob.x": "output", "bob.vy": "output"}
    damping = next(v for v in md.modelVariables if v.name == "damping")
    assert float(damping.start) == 0.2 and damping.variability == "fixed"


@pytest.mark.parametrize("step", [0.03, 0.05])
def test_fmpy_s_master_reproduces_the_scene_stepped_through_the_package(fmu, step):
    # 0.03 is not a multiple of the internal step 0.01: the FMU lands on each communication
    # point with a shorter last step. 0.05 is.
    result = fmpy.simulate_fmu(str(fmu), input=TABLE, output=["bob.x", "bob.vy"], stop_time=2.0,
                               step_size=step, output_interval=step, validate=True)
    times = result["time"]
    assert times[-1] == pytest.approx(2.0)
    sim = lieflow.load(SCENE)
    for k in range(len(times) - 1):
        out = sim.outputs()
        assert out["bob.x"] == pytest.approx(result["bob.x"][k], abs=1e-12)
        assert out["bob.vy"] == pytest.approx(result["bob.vy"][k], abs=1e-12)
        sim.set_input("push", push(times[k]))
        sim.advance_to(times[k + 1])
    out = sim.outputs()
    assert out["bob.x"] == pytest.approx(result["bob.x"][-1], abs=1e-12)
    # The push moved the bob: the input reached the FMU.
    assert abs(result["bob.x"]).max() > 1e-3


def test_the_fmu_of_a_scene_without_held_inputs_runs_like_the_command(tmp_path):
    if not BIN.exists():
        pytest.skip("the command is not built")
    path = tmp_path / "damped.fmu"
    subprocess.run([str(BIN), "fmu", str(ROOT / "scenes" / "forced_pendulum.toml"), "-o", str(path)],
                   check=True, capture_output=True)
    assert validate_fmu(str(path)) == []


def test_an_fmu_carries_its_table_files_and_shows_positions_and_velocities(tmp_path):
    # A scene whose input reads `file = "push.csv"` and that declares no outputs: the FMU packs
    # the table beside its scene (FMPy failed at instantiation), and exposes every position and
    # velocity (it showed only the time).
    if not BIN.exists():
        pytest.skip("the command is not built")
    scenes = tmp_path / "scenes"
    scenes.mkdir()
    (scenes / "push.csv").write_text("t,u\n0,0\n0.5,0\n0.6,1\n2,1\n")
    (scenes / "slider.toml").write_text("""version = 1
name = "slider"
dim = 2
[[bodies]]
name = "cart"
mass = 2.0
position = [0.0, 0.0]
[[effects]]
type = "damping"
coefficient = 0.5
[[inputs]]
type = "force"
name = "push"
bodies = ["cart"]
direction = [1.0, 0.0]
signal = { type = "table", file = "push.csv" }
[integrator]
dt = 0.01
t_end = 2.0
""")
    path = tmp_path / "slider.fmu"
    # From another working directory: the table is found beside its scene.
    out = subprocess.run([str(BIN), "fmu", str(scenes / "slider.toml"), "-o", str(path)],
                         capture_output=True, text=True, cwd=str(tmp_path))
    assert out.returncode == 0, out.stderr
    assert validate_fmu(str(path)) == []
    md = fmpy.read_model_description(str(path))
    outputs = [v.name for v in md.modelVariables if v.causality == "output"]
    assert outputs == ["cart.x", "cart.y", "cart.vx", "cart.vy"]
    result = fmpy.simulate_fmu(str(path), output=["cart.x", "cart.vx"], stop_time=2.0,
                               step_size=0.01, output_interval=0.01)
    # At rest until t = 0.5, then pushed (ramped to 1 N by t = 0.6) against c = 0.5: from
    # t = 0.6 on, v → 2 with rate 1/4 (within the ramp's 0.05 N s of it at the end).
    v = result["cart.vx"]
    assert v[result["time"] <= 0.5].max() == 0.0
    assert v[-1] == pytest.approx(2.0 * (1.0 - np.exp(-1.45 / 4.0)), rel=1e-2)


def test_without_input_the_fmu_ends_where_lieflow_run_ends(fmu):
    import json

    result = fmpy.simulate_fmu(str(fmu), output=["bob.x"], stop_time=2.0, step_size=0.01,
                               output_interval=0.01)
    out = subprocess.run([str(BIN), "run", str(SCENE)], capture_output=True, text=True, check=True)
    summary = json.loads(out.stdout.strip().splitlines()[-1])
    assert result["time"][-1] == pytest.approx(summary["t"])
    assert result["bob.x"][-1] == pytest.approx(summary["x"][0], abs=1e-12)


def test_fmu_states_restore_the_continuation_bit_for_bit(fmu, tmp_path):
    from fmpy import extract, read_model_description
    from fmpy.fmi3 import FMU3Slave

    md = read_model_description(str(fmu))
    vrs = {v.name: v.valueReference for v in md.modelVariables}
    slave = FMU3Slave(guid=md.guid, unzipDirectory=extract(str(fmu), str(tmp_path / "unzipped")),
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName="state")
    slave.instantiate()
    slave.enterInitializationMode(startTime=0.0)
    slave.exitInitializationMode()
    t, h = 0.0, 0.03
    for _ in range(10):
        slave.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        t += h
    state = slave.getFMUState()
    slave.setFloat64([vrs["push"]], [0.7])
    runs = []
    for _ in range(2):
        u = t
        for _ in range(10):
            slave.doStep(currentCommunicationPoint=u, communicationStepSize=h)
            u += h
        runs.append(slave.getFloat64([vrs["bob.x"], vrs["bob.vy"]]))
        slave.setFMUState(state)
        slave.setFloat64([vrs["push"]], [0.7])
    assert runs[0] == runs[1]
    assert slave.getFloat64([vrs["time"]])[0] == pytest.approx(t)
    slave.freeFMUState(state)
    slave.terminate()
    slave.freeInstance()


def test_do_step_refuses_steps_that_are_not_finite_positive_or_beyond_the_run(fmu, tmp_path):
    # A NaN step stepped forever (100% CPU); 0 and a negative step returned OK; a step of 1e9
    # took 1e11 internal steps. Each is now fmi3Error, logged, and the FMU stays where it was.
    from fmpy import extract, read_model_description
    from fmpy.fmi3 import FMU3Slave

    md = read_model_description(str(fmu))
    slave = FMU3Slave(guid=md.guid, unzipDirectory=extract(str(fmu), str(tmp_path / "unzipped")),
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName="hostile")
    slave.instantiate()
    slave.enterInitializationMode(startTime=0.0)
    slave.exitInitializationMode()
    for h in [float("nan"), float("inf"), 0.0, -0.1, 1e9]:
        with pytest.raises(Exception):
            slave.doStep(currentCommunicationPoint=0.0, communicationStepSize=h)
    # Still at t = 0, and a good step goes on.
    time_vr = next(v.valueReference for v in md.modelVariables if v.name == "time")
    assert slave.getFloat64([time_vr])[0] == 0.0
    slave.doStep(currentCommunicationPoint=0.0, communicationStepSize=0.05)
    assert slave.getFloat64([time_vr])[0] == pytest.approx(0.05)
    slave.terminate()
    slave.freeInstance()


def replay(sim, times):
    """The outputs of `sim` at `times`, its held force set from TABLE at each of them."""
    rows = []
    for k, t in enumerate(times):
        rows.append(sim.outputs()["bob.x"])
        if k + 1 < len(times):
            sim.set_input("push", push(t))
            sim.advance_to(times[k + 1])
    return np.array(rows)


def test_a_parameter_set_by_the_importer_is_the_scene_with_that_value(fmu):
    result = fmpy.simulate_fmu(str(fmu), input=TABLE, start_values={"damping": 1.5},
                               output=["bob.x"], stop_time=2.0, step_size=0.05,
                               output_interval=0.05)
    stiffer = lieflow.loads(SCENE.read_text().replace("coefficient = 0.2", "coefficient = 1.5"))
    expected = replay(stiffer, result["time"])
    assert np.max(np.abs(result["bob.x"] - expected)) <= 1e-12
    # … and not the scene's own damping.
    plain = replay(lieflow.load(SCENE), result["time"])
    assert np.max(np.abs(result["bob.x"] - plain)) > 1e-3


def test_the_fmu_of_a_rigid_body_scene_validates_and_ends_where_lieflow_run_ends(tmp_path):
    # The spinning top (a rigid body on a ball joint): its outputs are the top's centre height
    # and the FMU's co-simulation lands on the command's final state.
    import json

    if not BIN.exists():
        pytest.skip("the command is not built")
    scene = ROOT / "scenes" / "spinning_top.toml"
    path = tmp_path / "top.fmu"
    subprocess.run([str(BIN), "fmu", str(scene), "-o", str(path)], check=True, capture_output=True)
    assert validate_fmu(str(path)) == []
    result = fmpy.simulate_fmu(str(path), output=["height"], stop_time=2.0, step_size=0.01,
                               output_interval=0.01)
    out = subprocess.run([str(BIN), "run", str(scene)], capture_output=True, text=True, check=True)
    summary = json.loads(out.stdout.strip().splitlines()[-1])
    assert result["time"][-1] == pytest.approx(summary["t"])
    assert result["height"][-1] == pytest.approx(summary["x"][2], abs=1e-12)


def test_a_rigid_body_scene_without_outputs_shows_its_bodies_centres(tmp_path):
    # With no [[outputs]], an FMU shows every body's position and velocity: a rigid body's
    # centre, not its directors (slots of its state, not bodies).
    if not BIN.exists():
        pytest.skip("the command is not built")
    text = (ROOT / "scenes" / "spinning_top.toml").read_text()
    text = text.split("[[outputs]]")[0] + "[integrator]" + text.split("[integrator]")[1]
    scene = tmp_path / "top.toml"
    scene.write_text(text)
    path = tmp_path / "top.fmu"
    out = subprocess.run([str(BIN), "fmu", str(scene), "-o", str(path)], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert validate_fmu(str(path)) == []
    names = [v.name for v in fmpy.read_model_description(str(path)).modelVariables]
    assert "top.x" in names and "top.vz" in names
    assert not any("#" in n for n in names), names


def test_the_fmu_of_a_scene_with_a_tolerance_steps_adaptively_like_the_package(tmp_path):
    # scenes/kepler.toml asks for tol = 1e-8: inside each communication step the controller
    # chooses the steps (the model description declares no fixed internal step), and FMPy's
    # master at a step that is not the scene's dt lands where the package lands.
    if not BIN.exists():
        pytest.skip("the command is not built")
    scene = ROOT / "scenes" / "kepler.toml"
    path = tmp_path / "kepler.fmu"
    subprocess.run([str(BIN), "fmu", str(scene), "-o", str(path)], check=True,
                   capture_output=True)
    assert validate_fmu(str(path)) == []
    md = fmpy.read_model_description(str(path))
    assert md.coSimulation.fixedInternalStepSize is None
    result = fmpy.simulate_fmu(str(path), output=["r_x"], stop_time=6.0, step_size=0.25,
                               output_interval=0.25)
    sim = lieflow.load(scene)
    times = result["time"]
    for k in range(len(times)):
        assert sim.outputs()["r_x"] == pytest.approx(result["r_x"][k], abs=1e-12)
        if k + 1 < len(times):
            sim.advance_to(times[k + 1])
    assert abs(result["r_x"]).max() > 0.05
