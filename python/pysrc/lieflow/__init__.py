"""lieflow: constrained generalized Hamiltonian systems with dissipation, from Python.

Scenes (TOML files or text, the format of ``lieflow run``) compile into a model and a scheme
(Zhang & Deng 2004 projection integrators) and run in Rust; states and trajectories come back as
numpy arrays.

>>> import lieflow
>>> sim = lieflow.loads(lieflow.default_scene())
>>> summary = sim.run(every=100)        # the scene's own steps to its t_end
>>> summary["states"].shape[1] == len(sim.state_names)
True
"""

from os import PathLike
from typing import Union

from ._lieflow import (
    Checkpoint,
    SceneError,
    Simulation,
    StepError,
    __version__,
    default_scene,
    precision,
    run,
    sweep,
)

__all__ = [
    "Checkpoint",
    "SceneError",
    "Simulation",
    "StepError",
    "__version__",
    "default_scene",
    "load",
    "loads",
    "precision",
    "run",
    "sweep",
]


def load(path: Union[str, "PathLike[str]"]) -> Simulation:
    """Loads and compiles the scene file at ``path``; raises ``SceneError`` with the file, line
    and field of what is wrong."""
    return Simulation.load(path)


def loads(text: str, name: str = "scene.toml") -> Simulation:
    """Compiles a scene given as TOML text; ``name`` is the file name its errors cite."""
    return Simulation.loads(text, name)
