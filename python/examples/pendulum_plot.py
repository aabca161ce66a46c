"""A damped pendulum from Python, stepped the way an embedding simulator would: advance in
communication steps of 0.05, read the state and the energies, then plot the bob's path (equal
aspect) and the energy balance H − H₀ + dissipated with matplotlib. Prints one JSON line.

    python python/examples/pendulum_plot.py [out.png]
"""

import json
import pathlib
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import lieflow  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[2]
out = sys.argv[1] if len(sys.argv) > 1 else "pendulum.png"

sim = lieflow.load(ROOT / "scenes" / "damped_pendulum.toml")
h0 = sim.energy
times, path, change, balance = [], [], [], []
for k in range(1, 201):
    sim.advance_to(0.05 * k)
    times.append(sim.t)
    path.append(sim.state[:2])
    change.append(sim.energy - h0)
    balance.append(sim.energy - h0 + sim.dissipated)
path = np.array(path)

fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4))
left.plot(path[:, 0], path[:, 1])
left.set_aspect("equal")
left.set_title("the bob's path")
right.plot(times, change, label="H − H₀")
right.plot(times, balance, label="H − H₀ + dissipated")
right.set_xlabel("t")
right.legend()
fig.suptitle(sim.name)
fig.tight_layout()
fig.savefig(out)
print(json.dumps({"scene": sim.name, "t": sim.t, "dissipated": sim.dissipated,
                  "largest_balance_error": float(np.max(np.abs(balance))), "plot": out}))
