"""phyplan environments: physical-reasoning tasks as contextual-bandit Gymnasium envs on MuJoCo.

Importing this package registers ``PhyPlan/<Task>-vN`` for every task in :data:`TASKS` and
``PhyPlan/<Task>Varied-vN`` for every task in :data:`VARIED_TASKS` (the hidden-physics track; the version of each
task name is in :data:`VERSIONS`), and the superseded ids of :data:`LEGACY_IDS`, kept reproducible::

    import gymnasium as gym
    import phyplan_envs
    env = gym.make("PhyPlan/Launch-v0", obs_mode="state")

``gym.make_vec(id, num_envs=N)`` gives the batched vector env of :mod:`phyplan_envs.vector`, and
:func:`simulate_batch` runs many (context, action) episodes at once (:mod:`phyplan_envs.batch`).

It also sets ``MUJOCO_GL=egl`` (headless rendering) unless the variable is already set; that must happen before
``mujoco`` is first imported, so import ``phyplan_envs`` first.
"""
from . import _gl  # noqa: F401  (must stay first)

import gymnasium as gym

from .base import ActionDim, PhyPlanEnv
from .batch import BatchResult, simulate_batch
from .vector import entry_point_name as _vector_entry_point

# task name -> "module:Class". One registry call per id below; bump -vN when behaviour changes (see CHANGELOG).
TASKS: dict[str, str] = {
    "launch": "phyplan_envs.tasks.launch:LaunchEnv",
    "slide": "phyplan_envs.tasks.slide:SlideEnv",
    "bounce": "phyplan_envs.tasks.bounce:BounceEnv",
    "bridge": "phyplan_envs.tasks.bridge:BridgeEnv",
}
# The hidden-physics track (phyplan_envs.hidden_physics): each nominal assembly plus a hidden-physics component.
VARIED_TASKS: dict[str, str] = {
    "launch-varied": "phyplan_envs.tasks.varied:LaunchVariedEnv",
    "slide-varied": "phyplan_envs.tasks.varied:SlideVariedEnv",
    "bounce-varied": "phyplan_envs.tasks.varied:BounceVariedEnv",
    "bridge-varied": "phyplan_envs.tasks.varied:BridgeVariedEnv",
}
ALL_TASKS: dict[str, str] = {**TASKS, **VARIED_TASKS}
# The current version of a task name (default 0); a task name always makes its current version (see CHANGELOG).
VERSIONS: dict[str, int] = {"bridge": 1, "slide-varied": 1, "bridge-varied": 1}
# Superseded ids, still registered and reproducible (gym.make them by id; the harness runs task names).
LEGACY_IDS: dict[str, str] = {
    "PhyPlan/Bridge-v0": "phyplan_envs.tasks.bridge_v0:BridgeEnvV0",
    "PhyPlan/SlideVaried-v0": "phyplan_envs.tasks.varied_v0:SlideVariedEnvV0",
    "PhyPlan/BridgeVaried-v0": "phyplan_envs.tasks.varied_v0:BridgeVariedEnvV0",
}
TRACKS: dict[str, tuple[str, ...]] = {"nominal": tuple(TASKS), "varied": tuple(VARIED_TASKS)}


def env_id(task: str) -> str:
    """The Gymnasium id of a task name's current version, e.g. ``env_id("launch") == "PhyPlan/Launch-v0"``,
    ``env_id("slide-varied") == "PhyPlan/SlideVaried-v1"``."""
    if task not in ALL_TASKS:
        raise ValueError(f"unknown task {task!r}; available tasks: {', '.join(ALL_TASKS)}")
    return ("PhyPlan/" + "".join(part.capitalize() for part in task.split("-"))
            + f"-v{VERSIONS.get(task, 0)}")


def task_class(task: str) -> type[PhyPlanEnv]:
    """The env class of a task name (without making an env)."""
    import importlib

    env_id(task)  # a clear error for unknown names
    module, _, attr = ALL_TASKS[task].partition(":")
    return getattr(importlib.import_module(module), attr)


for _id, _entry in [*((env_id(t), e) for t, e in ALL_TASKS.items()), *LEGACY_IDS.items()]:
    if _id not in gym.registry:
        gym.register(id=_id, entry_point=_entry, vector_entry_point=_vector_entry_point(_id), max_episode_steps=None,
                     disable_env_checker=False)

__all__ = ["ALL_TASKS", "ActionDim", "BatchResult", "LEGACY_IDS", "PhyPlanEnv", "TASKS", "TRACKS", "VARIED_TASKS",
           "VERSIONS", "env_id", "simulate_batch", "task_class"]
