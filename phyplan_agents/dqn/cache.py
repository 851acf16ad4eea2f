"""The simulation cache: random training contexts x random grid actions, simulated once and kept on disk.

Like PHYRE's simulation cache, the training data of the DQN baselines is a table of simulated outcomes, computed once
and reused by every training run (retraining with other network or optimiser settings never re-simulates). One
cache file holds, for one task:

* ``images``  (C, H, W, 3) uint8: the image observation of each training context (what the DQN sees),
* ``seeds``   (C,) int64: the ``env.reset(seed=...)`` seed that made each context (from the *train* split),
* ``goals``   (C, 2) float64: each context's goal (for inspection only; the network does not read it),
* ``context_index`` (N,) int64, ``action_index`` (N,) int64, ``actions`` (N, D) float64, ``rewards`` (N,) float64:
  one row per simulation,
* ``meta``: a JSON string (task, grid, image size, budget, seeds, simulation wall time, versions).

The default budget is the paper's: 2,000 simulations per task (100 contexts x 20 actions, as PHYRE's DQN baseline
that the paper evaluated; ``docs/reference-values.md``). Contexts are random seeds of the *train* split of
:mod:`phyplan_envs.splits` (0..99 999), disjoint from the dev and test seeds that tuning and evaluation use.

With Minari installed (``phyplan[datasets]``) :func:`get_cache` keeps the simulations as a Minari dataset instead of
the ``.npz`` file and reads it back (:mod:`.dataset_io`; the images are rendered again from the contexts, the same
arrays); an ``.npz`` cache is still read.
"""
from __future__ import annotations

import json
import os
import re
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from ..files import atomic_path
from .grid import ActionGrid

CACHE_VERSION = 1
DEFAULT_SIMULATIONS = 2000          # the paper's DQN budget per task (docs/reference-values.md, "Baselines")
DEFAULT_ACTIONS_PER_CONTEXT = 20    # PHYRE/PhyPlan: 100 contexts x 20 actions
DEFAULT_IMAGE_SIZE = 64

def default_cache_dir() -> Path:
    """``$PHYPLAN_CACHE_DIR/dqn`` if that variable is set, else ``~/.cache/phyplan/dqn``."""
    root = os.environ.get("PHYPLAN_CACHE_DIR")
    return Path(root) / "dqn" if root else Path.home() / ".cache" / "phyplan" / "dqn"


def train_seeds(task: str, n: int, seed: int = 0, split: str = "train") -> np.ndarray:
    """``n`` distinct context seeds drawn (with generator ``seed``) from ``split`` of :mod:`phyplan_envs.splits`
    (default the train split; the ``"dev"`` split makes validation caches). The same for every task."""
    from phyplan_envs import splits

    if split == "test":
        raise ValueError("training and validation data must not come from the test split")
    seeds = splits.sample_seeds(split, int(n), np.random.default_rng([seed, 7211]))
    if split == "train":
        splits.assert_train_seeds(seeds)
    return np.sort(np.asarray(seeds, dtype=np.int64))


def test_seeds(task: str, n: int, split: str = "test") -> np.ndarray:
    """The first ``n`` seeds of ``split`` (default the test split, the held-out contexts the benchmark uses)."""
    from phyplan_envs import splits

    return np.asarray(splits.context_seeds(split, int(n)), dtype=np.int64)


def scene_of(task: str, scene: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The full scene of ``task``: its scene arguments (the task class's ``scene_args``, e.g. Paddles' ``paddles``)
    from ``scene``, the rest at the class's defaults; ``{}`` for a task with a fixed scene. ``ValueError`` names an
    argument the task does not have."""
    import inspect

    import phyplan_envs

    from ..base import check_scene

    cls = phyplan_envs.task_class(task)
    scene = check_scene(cls, scene)
    params = inspect.signature(cls.__init__).parameters
    return {k: scene.get(k, params[k].default) for k in getattr(cls, "scene_args", ())}


def scene_name(task: str, scene: Mapping[str, Any] | None = None) -> str:
    """The name of a task's scene, under which its caches and models are kept: the task name, followed by each
    scene argument and its value (``"paddles-paddles4"`` for ``PhyPlan/Paddles-v1`` with ``paddles=4``)."""
    return "-".join([task, *(f"{k}{v}" for k, v in sorted(scene_of(task, scene).items()))])


def train_arguments(name: str) -> str:
    """The ``python -m phyplan_agents.dqn.train`` arguments that make the model called ``name`` (a
    :func:`scene_name`): ``"--task paddles --paddles 4"`` for ``"paddles-paddles4"``."""
    m = re.fullmatch(r"(.+)-paddles(\d+)", name)
    return f"--task {m.group(1)} --paddles {m.group(2)}" if m else f"--task {name}"


def make_env(task: str, obs_mode: str = "image", image_size: int = DEFAULT_IMAGE_SIZE,
             scene: Mapping[str, Any] | None = None, **kwargs: Any):
    """A fresh env of ``task`` (``phyplan_envs.TASKS``) in ``scene`` (:func:`scene_of`), without the Panda (it is
    hidden from the obs camera)."""
    import gymnasium as gym

    import phyplan_envs

    if task not in phyplan_envs.TASKS:
        raise ValueError(f"unknown task {task!r}; available tasks: {', '.join(phyplan_envs.TASKS)}")
    kwargs.setdefault("with_panda", False)
    return gym.make(phyplan_envs.env_id(task), obs_mode=obs_mode, image_size=image_size, **scene_of(task, scene),
                    **kwargs)


def task_grid(task: str, counts: tuple[int, ...] | None = None,
              scene: Mapping[str, Any] | None = None) -> ActionGrid:
    """The action grid of ``task`` in ``scene`` over its exact (float64) action bounds (a task with scene arguments
    builds the scene, without simulating, to read its action dimensions)."""
    import phyplan_envs

    if task not in phyplan_envs.TASKS:
        raise ValueError(f"unknown task {task!r}; available tasks: {', '.join(phyplan_envs.TASKS)}")
    cls = phyplan_envs.task_class(task)
    full = scene_of(task, scene)
    dims = cls(with_panda=False, **full).action_dims if full else cls.action_dims
    return ActionGrid.for_task(task, [d.low for d in dims], [d.high for d in dims], counts)


@dataclass
class SimulationCache:
    """One task's simulated training data (see the module docstring for the arrays)."""

    images: np.ndarray
    seeds: np.ndarray
    goals: np.ndarray
    context_index: np.ndarray
    action_index: np.ndarray
    actions: np.ndarray
    rewards: np.ndarray
    meta: dict[str, Any] = field(default_factory=dict)
    # simulate_cache's per-simulation observations and infos, for the Minari dataset (dataset_io); not in the .npz
    log: dict[str, Any] | None = field(default=None, repr=False, compare=False)

    def __post_init__(self) -> None:
        c, n = len(self.images), len(self.rewards)
        if self.images.ndim != 4 or self.images.shape[-1] != 3 or self.images.dtype != np.uint8:
            raise ValueError(f"images must be uint8 (C, H, W, 3), got {self.images.dtype} {self.images.shape}")
        if not (len(self.seeds) == len(self.goals) == c):
            raise ValueError("images, seeds and goals must have one row per context")
        if not (len(self.context_index) == len(self.action_index) == len(self.actions) == n):
            raise ValueError("context_index, action_index, actions and rewards must have one row per simulation")
        if n and (self.context_index.min() < 0 or self.context_index.max() >= c):
            raise ValueError("context_index refers to a context that is not in the cache")
        if not np.all(np.isfinite(self.rewards)):
            raise ValueError("the cache holds non-finite rewards")

    @property
    def n_simulations(self) -> int:
        return int(len(self.rewards))

    @property
    def n_contexts(self) -> int:
        return int(len(self.images))

    @property
    def grid(self) -> ActionGrid:
        return ActionGrid.from_dict(self.meta["grid"])

    def save(self, path: str | Path) -> Path:
        """Write the cache as a compressed ``.npz`` (atomically: a temporary file, then a rename)."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(path) as tmp, open(tmp, "wb") as fh:
            np.savez_compressed(fh, images=self.images, seeds=self.seeds, goals=self.goals,
                                context_index=self.context_index, action_index=self.action_index,
                                actions=self.actions, rewards=self.rewards, meta=np.array(json.dumps(self.meta)))
        return path

    @classmethod
    def load(cls, path: str | Path) -> "SimulationCache":
        path = Path(path)
        try:
            with np.load(path, allow_pickle=False) as z:
                arrays = {k: z[k] for k in ("images", "seeds", "goals", "context_index", "action_index",
                                             "actions", "rewards")}
                meta = json.loads(str(z["meta"]))
        except FileNotFoundError:
            raise
        except Exception as exc:  # zipfile/ValueError/KeyError: a damaged or foreign file
            raise ValueError(f"simulation cache {path} is unreadable ({type(exc).__name__}: {exc}); delete it to "
                             f"re-simulate") from exc
        return cls(meta=meta, **arrays)


def cache_path(cache_dir: str | Path, task: str, simulations: int, actions_per_context: int, image_size: int,
               grid: ActionGrid, seed: int, split: str = "train", scene: Mapping[str, Any] | None = None) -> Path:
    import phyplan_envs

    counts = "x".join(map(str, grid.counts))
    prefix = "" if split == "train" else f"{split}-"
    version = phyplan_envs.VERSIONS.get(task, 0)      # a task's later versions simulate caches of their own
    name = scene_name(task, scene) + ("" if version == 0 else f".v{version}")
    return Path(cache_dir) / (f"{prefix}{name}-sims{simulations}-apc{actions_per_context}-img{image_size}-grid{counts}"
                              f"-seed{seed}-v{CACHE_VERSION}.npz")


def simulate_cache(task: str, simulations: int = DEFAULT_SIMULATIONS,
                   actions_per_context: int = DEFAULT_ACTIONS_PER_CONTEXT, image_size: int = DEFAULT_IMAGE_SIZE,
                   grid_counts: tuple[int, ...] | None = None, seed: int = 0, progress: bool = True,
                   split: str = "train", workers: int = 1,
                   scene: Mapping[str, Any] | None = None) -> SimulationCache:
    """Simulate a new cache: ``simulations // actions_per_context`` train contexts x distinct random grid actions.

    Args:
        task: the task name.
        simulations: the total number of real simulations (the budget; default 2,000, the paper's).
        actions_per_context: random actions simulated per context (default 20, the paper's/PHYRE's).
        image_size: side of the image observation in pixels (default 64).
        grid_counts: the action grid resolution (default: :func:`grid.default_counts`).
        seed: picks the train contexts and the actions.
        progress: show a tqdm progress bar.
        split: the context split (``"train"``; ``"dev"`` for validation data).
        workers: processes for each context's simulations (:func:`phyplan_envs.simulate_batch`, on state-observation
            envs: the outcomes do not depend on the observation mode or on ``workers``).
        scene: the task's scene arguments (:func:`scene_of`; e.g. ``{"paddles": 4}``).
    """
    from tqdm import tqdm

    from phyplan_envs import simulate_batch

    if simulations < 1 or actions_per_context < 1:
        raise ValueError(f"simulations and actions_per_context must be >= 1, got {simulations}, {actions_per_context}")
    n_ctx = -(-simulations // actions_per_context)
    scene = scene_of(task, scene)
    env = make_env(task, obs_mode="state_image", image_size=image_size, scene=scene)  # the image; the state for the log
    try:
        grid = task_grid(task, grid_counts, scene)
        if actions_per_context > grid.n:
            raise ValueError(f"actions_per_context={actions_per_context} exceeds the {grid.n} grid actions")
        seeds = train_seeds(task, n_ctx, seed, split)
        rng = np.random.default_rng([seed, 4049])
        images = np.zeros((n_ctx, image_size, image_size, 3), np.uint8)
        goals = np.zeros((n_ctx, 2))
        rows_c, rows_a, rewards = [], [], []
        log: dict[str, list] = {"reset_obs": [], "reset_info": [], "final_obs": [], "step_info": []}
        t0 = time.perf_counter()
        bar = tqdm(total=simulations, desc=f"simulate {task}", unit="sim", disable=not progress)
        env_id = env.spec.id                                   # make_env is gym.make: the spec is there
        sim_kwargs = {**env.spec.kwargs, "obs_mode": "state"}  # the same env without rendering each final frame
        for c, s in enumerate(seeds):
            obs, info = env.reset(seed=int(s))
            images[c] = obs["image"]
            goals[c] = info["goal"]
            log["reset_obs"].append(obs["state"])
            log["reset_info"].append(info)
            k = min(actions_per_context, simulations - len(rewards))
            idx = rng.choice(grid.n, size=k, replace=False)
            res = simulate_batch(env_id, info["context"], grid.action(idx), workers=workers, **sim_kwargs)
            rows_c += [c] * k
            rows_a += [int(a) for a in idx]
            rewards += [float(r) for r in res.reward]
            log["final_obs"] += list(res.obs)
            log["step_info"] += list(res.info)
            bar.update(k)
        bar.close()
        wall = time.perf_counter() - t0
    finally:
        env.close()
    action_index = np.asarray(rows_a, np.int64)
    meta = {"version": CACHE_VERSION, "task": task, "env_id": env_id, "grid": grid.to_dict(), "scene": scene,
            "image_size": image_size, "simulations": len(rewards), "actions_per_context": actions_per_context,
            "contexts": n_ctx, "seed": seed, "split": split,
            "simulation_wall_time_s": round(wall, 3)}
    return SimulationCache(images=images, seeds=seeds, goals=goals, context_index=np.asarray(rows_c, np.int64),
                           action_index=action_index, actions=grid.action(action_index),
                           rewards=np.asarray(rewards), meta=meta, log=log)


def get_cache(task: str, cache_dir: str | Path | None = None, simulations: int = DEFAULT_SIMULATIONS,
              actions_per_context: int = DEFAULT_ACTIONS_PER_CONTEXT, image_size: int = DEFAULT_IMAGE_SIZE,
              grid_counts: tuple[int, ...] | None = None, seed: int = 0,
              progress: bool = True, split: str = "train",
              scene: Mapping[str, Any] | None = None) -> tuple[SimulationCache, Path, bool]:
    """The cache for these settings (``scene``: the task's scene arguments, :func:`scene_of`): loaded from
    ``cache_dir`` if present, else simulated and saved there.

    Returns ``(cache, path, simulated)`` where ``simulated`` says whether this call ran the simulations.
    """
    cache_dir = Path(cache_dir) if cache_dir is not None else default_cache_dir()
    scene = scene_of(task, scene)
    grid = task_grid(task, grid_counts, scene)
    path = cache_path(cache_dir, task, simulations, actions_per_context, image_size, grid, seed, split, scene)
    from .dataset_io import cache_dataset

    # None: Minari is not installed
    dataset = cache_dataset(cache_dir, task, simulations, actions_per_context, grid, seed, split, scene)
    if dataset is not None and dataset.exists():
        cache, path = dataset.read(image_size, grid.counts), dataset.path
    elif path.exists():
        cache = SimulationCache.load(path)           # the .npz format (without Minari, and older caches)
    else:
        cache = simulate_cache(task, simulations, actions_per_context, image_size, grid.counts, seed, progress, split,
                               scene=scene)
        if dataset is None:
            cache.save(path)
            return cache, path, True
        dataset.write(cache)
        return dataset.read(image_size, grid.counts), dataset.path, True
    import phyplan_envs

    if (cache.meta.get("grid") != grid.to_dict() or cache.meta.get("task") != task
            or cache.meta.get("env_id") != phyplan_envs.env_id(task) or cache.meta.get("scene", {}) != scene):
        raise ValueError(f"simulation cache {path} was made for other settings ({cache.meta.get('task')}, "
                         f"{cache.meta.get('env_id')}, {cache.meta.get('scene', {})}, {cache.meta.get('grid')}); "
                         f"delete it to re-simulate")
    return cache, path, False
