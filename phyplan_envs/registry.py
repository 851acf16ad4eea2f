"""The registered ids' names: the task names, their versions and entry points, the superseded ids, and
:func:`env_id` / :func:`task_class` (re-exported by :mod:`phyplan_envs`, which registers them with Gymnasium)."""
from __future__ import annotations

import importlib

# task name -> "module:Class" (phyplan_envs registers one id each; bump -vN when behaviour changes: CHANGELOG).
TASKS: dict[str, str] = {
    "launch": "phyplan_envs.tasks.launch:LaunchEnv",
    "slide": "phyplan_envs.tasks.slide:SlideEnv",
    "bounce": "phyplan_envs.tasks.bounce:BounceEnv",
    "bridge": "phyplan_envs.tasks.bridge:BridgeEnv",
    "launch-bounce": "phyplan_envs.tasks.launch_bounce:LaunchBounceEnv",
    "paddles": "phyplan_envs.tasks.paddles:PaddlesEnv",
}
# The hidden-physics track (phyplan_envs.hidden_physics): each nominal assembly plus a hidden-physics component.
VARIED_TASKS: dict[str, str] = {
    "launch-varied": "phyplan_envs.tasks.varied:LaunchVariedEnv",
    "slide-varied": "phyplan_envs.tasks.varied:SlideVariedEnv",
    "bounce-varied": "phyplan_envs.tasks.varied:BounceVariedEnv",
    "bridge-varied": "phyplan_envs.tasks.varied:BridgeVariedEnv",
    "launch-bounce-varied": "phyplan_envs.tasks.varied:LaunchBounceVariedEnv",
    "paddles-varied": "phyplan_envs.tasks.varied:PaddlesVariedEnv",
}
ALL_TASKS: dict[str, str] = {**TASKS, **VARIED_TASKS}
# The current version of a task name (default 0); a task name always makes its current version (see CHANGELOG).
VERSIONS: dict[str, int] = {"bridge": 1, "slide-varied": 1, "bridge-varied": 1, "launch-bounce": 1,
                            "launch-bounce-varied": 1, "paddles": 2, "paddles-varied": 3}
# Superseded ids, still registered and reproducible (gym.make them by id; the harness runs task names).
LEGACY_IDS: dict[str, str] = {
    "PhyPlan/Bridge-v0": "phyplan_envs.tasks.bridge_v0:BridgeEnvV0",
    "PhyPlan/SlideVaried-v0": "phyplan_envs.tasks.varied_v0:SlideVariedEnvV0",
    "PhyPlan/BridgeVaried-v0": "phyplan_envs.tasks.varied_v0:BridgeVariedEnvV0",
    "PhyPlan/LaunchBounce-v0": "phyplan_envs.tasks.launch_bounce_v0:LaunchBounceEnvV0",
    "PhyPlan/LaunchBounceVaried-v0": "phyplan_envs.tasks.varied_v0:LaunchBounceVariedEnvV0",
    "PhyPlan/Paddles-v0": "phyplan_envs.tasks.paddles_v0:PaddlesEnvV0",
    "PhyPlan/PaddlesVaried-v0": "phyplan_envs.tasks.varied_v0:PaddlesVariedEnvV0",
    "PhyPlan/Paddles-v1": "phyplan_envs.tasks.paddles_v1:PaddlesEnvV1",
    "PhyPlan/PaddlesVaried-v1": "phyplan_envs.tasks.varied_v0:PaddlesVariedEnvV1",
    "PhyPlan/PaddlesVaried-v2": "phyplan_envs.tasks.varied_v0:PaddlesVariedEnvV2",
}
# The tracks (task sets benchmarked together; ``python -m benchmarks.run --track``). Paddles-N is the depth dial,
# benchmarked over N by ``python -m benchmarks.depth``: its own track.
DEPTH_TASKS: tuple[str, ...] = ("paddles", "paddles-varied")
TRACKS: dict[str, tuple[str, ...]] = {"nominal": tuple(t for t in TASKS if t not in DEPTH_TASKS),
                                      "varied": tuple(t for t in VARIED_TASKS if t not in DEPTH_TASKS),
                                      "depth": DEPTH_TASKS}


def env_id(task: str) -> str:
    """The Gymnasium id of a task name's current version, e.g. ``env_id("launch") == "PhyPlan/Launch-v0"``,
    ``env_id("slide-varied") == "PhyPlan/SlideVaried-v1"``."""
    if task not in ALL_TASKS:
        raise ValueError(f"unknown task {task!r}; available tasks: {', '.join(ALL_TASKS)}")
    return ("PhyPlan/" + "".join(part.capitalize() for part in task.split("-"))
            + f"-v{VERSIONS.get(task, 0)}")


def task_class(task: str) -> type:
    """The env class of a task name (without making an env)."""
    env_id(task)  # a clear error for unknown names
    module, _, attr = ALL_TASKS[task].partition(":")
    return getattr(importlib.import_module(module), attr)
