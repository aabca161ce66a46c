"""Time per step from Python against the command's, on the default scene (measured, not
asserted): `Simulation.run` (the Rust loop, one call) and `Simulation.step` called from a Python
loop (one call per step). Prints one JSON line.

    python python/examples/bench_step.py [path/to/lieflow]
"""

import json
import pathlib
import subprocess
import sys
import time

import lieflow

ROOT = pathlib.Path(__file__).resolve().parents[2]
binary = sys.argv[1] if len(sys.argv) > 1 else str(ROOT / "target" / "release" / "lieflow")


def best(f, repeats=5):
    return min(f() for _ in range(repeats))


def cli_ns():
    out = subprocess.run([binary, "run"], capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])["ns_per_step"]


def run_ns():
    return lieflow.loads(lieflow.default_scene()).run(every=1000)["ns_per_step"]


def step_ns(steps=20000):
    sim = lieflow.loads(lieflow.default_scene())
    start = time.perf_counter()
    for _ in range(steps):
        sim.step()
    return (time.perf_counter() - start) * 1e9 / steps


cli, run, step = best(cli_ns), best(run_ns), best(step_ns)
print(json.dumps({"cli_ns_per_step": cli, "python_run_ns_per_step": run,
                  "python_step_loop_ns_per_step": step,
                  "run_over_cli": run / cli, "step_loop_over_cli": step / cli}))
