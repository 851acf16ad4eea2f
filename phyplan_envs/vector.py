"""Gymnasium vector envs of the phyplan tasks on the batched path (:func:`phyplan_envs.batch.simulate_batch`).

``gym.make_vec("PhyPlan/Bridge-v1", num_envs=N)`` returns a :class:`PhyPlanVectorEnv` (the registered
``vector_entry_point``); ``vectorization_mode="sync"`` and ``"async"`` give Gymnasium's own vector envs over single
envs, with the same rewards for the same seeds and actions.

One-step episodes and autoreset. Every phyplan episode is one attempt: ``reset`` fixes a context, one ``step``
simulates the attempt and returns ``terminated=True``. With the default ``autoreset_mode=NEXT_STEP`` (Gymnasium's
default, and what the sync and async modes do) the step *after* a terminated step resets those sub-envs instead
of simulating: it ignores their actions and returns the new context's observation with reward 0 and
``terminated=False``. So steps alternate: a real attempt, then a reset step; contexts are drawn from each
sub-env's own generator (seeded ``seed + i`` by ``reset(seed=seed)``), exactly as in a sync vector env.
With ``autoreset_mode=SAME_STEP`` every step is an attempt: the terminated sub-envs are reset at once, the
returned observation is the new context's, and ``info["final_obs"]`` / ``info["final_info"]`` hold the attempt's
outcome. With ``DISABLED`` the caller resets (``reset(options={"reset_mask": mask})``) before stepping again.
To try many actions on one fixed context, call ``simulate_batch`` directly (or pass
``reset(options={"context": c})``).

All attempts of a step run as one batch over ``workers`` worker processes (default: the machine's cores), so a
step costs about ``N / workers`` single-env steps. Resets run in this process on one env. ``render_mode`` is not
supported here (the scenes live in the workers): use ``vectorization_mode="sync"`` for frames.
"""
from __future__ import annotations

import functools
from copy import deepcopy
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space, concatenate, create_empty_array, iterate

from .batch import default_workers, simulate_batch


class PhyPlanVectorEnv(VectorEnv):
    """``num_envs`` phyplan envs of ``env_id`` whose attempts are simulated as one batch (see the module docstring).

    Args:
        env_id: the registered single-env id, e.g. ``"PhyPlan/Bridge-v1"``.
        num_envs: the number of sub-envs.
        workers: worker processes for the attempts (default: the machine's cores; 1 simulates in this process).
        autoreset_mode: a :class:`gymnasium.vector.AutoresetMode` (or its value), default ``NEXT_STEP``.
        **env_kwargs: ``gym.make`` keywords of every sub-env (``obs_mode``, ``image_size``, ``clip_actions``, ...).
    """

    def __init__(self, env_id: str, num_envs: int = 1, workers: int | None = None,
                 autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP, **env_kwargs: Any):
        if not (isinstance(num_envs, (int, np.integer)) and num_envs >= 1):
            raise ValueError(f"num_envs must be an integer >= 1, got {num_envs!r}")
        if env_kwargs.get("render_mode") is not None:
            raise ValueError("render_mode is not supported by the batched vector env (the attempts run in worker "
                             "processes); use gym.make_vec(..., vectorization_mode='sync') to render")
        env_kwargs.pop("render_mode", None)
        env_kwargs.pop("max_episode_steps", None)          # one step per episode; the spec sets none
        self.autoreset_mode = _autoreset_mode(autoreset_mode)
        self.env_id = env_id
        self.num_envs = int(num_envs)
        self.workers = default_workers() if workers is None else workers
        self.env_kwargs = dict(env_kwargs)
        self._env = gym.make(env_id, **env_kwargs)
        self.metadata = dict(self._env.metadata, autoreset_mode=self.autoreset_mode)
        self.render_mode = None
        self.single_observation_space = self._env.observation_space
        self.single_action_space = self._env.action_space
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self._rngs: list[np.random.Generator | None] = [None] * self.num_envs
        self._contexts: list[dict | None] = [None] * self.num_envs
        self._obs: list[Any] = [None] * self.num_envs
        self._autoreset = np.zeros(self.num_envs, dtype=np.bool_)
        self._done = np.ones(self.num_envs, dtype=np.bool_)      # no context yet: reset() first

    # -------------------------------------------------------------------------------------------------- resets
    def _reset_one(self, i: int, seed: int | None, options: dict | None) -> dict:
        env = self._env.unwrapped
        if seed is None:
            env._np_random = self._rngs[i]          # continue sub-env i's own generator (None: a fresh random one)
        self._obs[i], info = self._env.reset(seed=seed, options=options)
        self._rngs[i] = env.np_random
        self._contexts[i] = info["context"]
        self._done[i] = False
        return info

    def reset(self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None):
        """Reset every sub-env (or those in ``options["reset_mask"]``); seeds as in Gymnasium's sync vector env."""
        if seed is None:
            seeds = [None] * self.num_envs
        elif isinstance(seed, (int, np.integer)):
            seeds = [int(seed) + i for i in range(self.num_envs)]
        else:
            seeds = list(seed)
        if len(seeds) != self.num_envs:
            raise ValueError(f"seed must be None, an int or a list of num_envs={self.num_envs} seeds, "
                             f"got {len(seeds)}")
        options = dict(options) if options is not None else None
        mask = np.ones(self.num_envs, dtype=np.bool_)
        if options is not None and "reset_mask" in options:
            mask = options.pop("reset_mask")
            if not (isinstance(mask, np.ndarray) and mask.shape == (self.num_envs,) and mask.dtype == np.bool_
                    and mask.any()):
                raise ValueError(f"options['reset_mask'] must be a bool array of shape ({self.num_envs},) with at "
                                 f"least one True, got {mask!r}")
        infos: dict[str, Any] = {}
        for i in np.flatnonzero(mask):
            infos = self._add_info(infos, self._reset_one(int(i), seeds[i], options), int(i))
            self._autoreset[i] = False
        return self._batched_obs(), infos

    # ---------------------------------------------------------------------------------------------------- steps
    def step(self, actions):
        """One attempt per sub-env (or a reset for those that terminated last step, in ``NEXT_STEP`` mode)."""
        actions = list(iterate(self.action_space, actions))
        if len(actions) != self.num_envs:
            raise ValueError(f"actions must hold num_envs={self.num_envs} actions, got {len(actions)}")
        rewards = np.zeros(self.num_envs, dtype=np.float64)
        terminated = np.zeros(self.num_envs, dtype=np.bool_)
        truncated = np.zeros(self.num_envs, dtype=np.bool_)
        infos: dict[str, Any] = {}
        step_idx = [i for i in range(self.num_envs)
                    if not (self.autoreset_mode == AutoresetMode.NEXT_STEP and self._autoreset[i])]
        resets = [i for i in range(self.num_envs) if i not in step_idx]
        if self.autoreset_mode == AutoresetMode.DISABLED and self._done[step_idx].any():
            raise RuntimeError("autoreset_mode=DISABLED: reset the terminated sub-envs (reset(options={'reset_mask': "
                               "...})) before stepping them again")
        if self._done[step_idx].any():
            raise RuntimeError("call reset() before step()")
        per_env_info: dict[int, dict] = {}
        for i in resets:
            per_env_info[i] = self._reset_one(i, None, None)
        if step_idx:
            res = simulate_batch(self.env_id, [self._contexts[i] for i in step_idx],
                                 np.stack([np.asarray(actions[i], dtype=np.float64) for i in step_idx]),
                                 workers=min(self.workers, len(step_idx)), **self.env_kwargs)
            for k, i in enumerate(step_idx):
                rewards[i] = res.reward[k]
                terminated[i] = True
                self._done[i] = True
                if self.autoreset_mode == AutoresetMode.SAME_STEP:
                    infos = self._add_info(infos, {"final_obs": res.obs[k], "final_info": res.info[k]}, i)
                    per_env_info[i] = self._reset_one(i, None, None)
                else:
                    self._obs[i] = res.obs[k]
                    per_env_info[i] = res.info[k]
        for i in range(self.num_envs):
            infos = self._add_info(infos, per_env_info[i], i)
        self._autoreset = terminated | truncated
        return self._batched_obs(), rewards, terminated, truncated, infos

    def _batched_obs(self):
        out = create_empty_array(self.single_observation_space, self.num_envs)
        return deepcopy(concatenate(self.single_observation_space, self._obs, out))

    def close_extras(self, **kwargs: Any) -> None:
        self._env.close()


def _autoreset_mode(mode) -> AutoresetMode:
    """An ``AutoresetMode`` from itself, its value (``"SameStep"``) or its name (``"SAME_STEP"``, any case)."""
    if isinstance(mode, AutoresetMode):
        return mode
    key = str(mode).replace("_", "").lower()
    for m in AutoresetMode:
        if key in (m.value.lower(), m.name.replace("_", "").lower()):
            return m
    raise ValueError(f"autoreset_mode must be one of {[m.value for m in AutoresetMode]} (or their names), "
                     f"got {mode!r}")


def entry_point_name(env_id: str) -> str:
    """The ``vector_entry_point`` string of ``env_id``, e.g. ``"phyplan_envs.vector:PhyPlan__Bridge_v0"``."""
    return f"{__name__}:{env_id.replace('/', '__').replace('-', '_')}"


def __getattr__(name: str):
    """``PhyPlan__Bridge_v1`` -> a constructor of vector envs of ``PhyPlan/Bridge-v1`` (what make_vec loads)."""
    for env_id in gym.registry:
        if entry_point_name(env_id).partition(":")[2] == name:
            return functools.partial(PhyPlanVectorEnv, env_id)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
