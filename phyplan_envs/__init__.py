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
from .registry import ALL_TASKS, LEGACY_IDS, TASKS, TRACKS, VARIED_TASKS, VERSIONS, env_id, task_class
from .vector import entry_point_name as _vector_entry_point

# One registry call per id (the names: phyplan_envs.registry); bump -vN when behaviour changes (see CHANGELOG).
for _id, _entry in [*((env_id(t), e) for t, e in ALL_TASKS.items()), *LEGACY_IDS.items()]:
    if _id not in gym.registry:
        gym.register(id=_id, entry_point=_entry, vector_entry_point=_vector_entry_point(_id), max_episode_steps=None,
                     disable_env_checker=False)

__all__ = ["ALL_TASKS", "ActionDim", "BatchResult", "LEGACY_IDS", "PhyPlanEnv", "TASKS", "TRACKS", "VARIED_TASKS",
           "VERSIONS", "env_id", "simulate_batch", "task_class"]
