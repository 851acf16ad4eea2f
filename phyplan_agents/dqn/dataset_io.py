"""The DQN simulation cache as a Minari dataset (the format of :mod:`phyplan_agents.datasets`), and back.

With Minari installed (``pip install 'phyplan[datasets]'``) :func:`~.cache.get_cache` keeps its simulations as the
dataset ``phyplan/<task>/dqn-cache-<split>-sims<S>-apc<A>-grid<counts>-seed<seed>-env<version>-v1`` under
``<cache dir>/minari`` (a Minari root: ``MINARI_DATASETS_PATH=<cache dir>/minari`` lets ``minari.load_dataset``
find it) and reads it back; without Minari it keeps the ``.npz`` file as before, and an existing ``.npz`` is read in
either case. A dataset holds one one-step episode per simulation, as every phyplan dataset: the state
observations, the float64 grid action, the reward and the infos (final position, distance, end reason, context).

Images are not stored: the context image the Q-network reads is rendered again from each context when the dataset
is read (``reset(options={"context": ...})`` in ``obs_mode="image"``), at any ``image_size``. On one machine this
is the image the simulation run rendered, bit for bit (``tests/test_datasets.py``), so the cache read back equals
the ``.npz`` cache and trains the same weights; a dataset made elsewhere is rendered by the local renderer, which
is also what the DQN agents see at evaluation. (Minari would store images as JPEG, which changes pixels.)

:func:`cache_from_dataset` turns any phyplan dataset of a nominal task (``python -m benchmarks.datasets``) into a
:class:`~.cache.SimulationCache` to train the baselines on: episodes of the same context share a context row, and
each action must be a grid point (``snap=True`` maps it to the nearest one, keeping its reward: an approximation
within half a grid step).
"""
from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping

import numpy as np

from .. import datasets as pds
from .grid import ActionGrid

POLICY = "dqn-cache"


class CacheDataset:
    """Where one cache's dataset lives: ``root`` (a Minari root) and its dataset ``id``."""

    def __init__(self, root: str | Path, ds_id: str) -> None:
        self.root, self.id = Path(root), ds_id

    @property
    def path(self) -> Path:
        return pds.dataset_dir(self.root, self.id)

    def exists(self) -> bool:
        return pds.exists(self.root, self.id)

    def write(self, cache) -> Path:
        """Write ``cache`` (just simulated: it carries ``cache.log``) as this dataset."""
        write_cache(cache, self.root, self.id)
        return self.path

    def read(self, image_size: int, grid_counts: tuple[int, ...] | None = None):
        """The cache stored here, with its images rendered at ``image_size``."""
        return cache_from_dataset(pds.load(self.root, self.id), image_size, grid_counts)


def cache_dataset(cache_dir: str | Path, task: str, simulations: int, actions_per_context: int, grid: ActionGrid,
                  seed: int, split: str = "train", scene: Mapping[str, Any] | None = None) -> CacheDataset | None:
    """The dataset of a cache's settings, or None when Minari is not installed (the cache then keeps ``.npz``).
    A task with scene arguments keeps each scene's datasets under the scene's name (:func:`~.cache.scene_name`)."""
    import phyplan_envs

    from .cache import CACHE_VERSION, scene_name

    if not pds.minari_available():
        return None
    counts = "x".join(map(str, grid.counts))
    name = (f"{POLICY}-{split}-sims{simulations}-apc{actions_per_context}-grid{counts}-seed{seed}"
            f"-env{phyplan_envs.VERSIONS.get(task, 0)}")
    return CacheDataset(Path(cache_dir) / "minari", pds.dataset_id(scene_name(task, scene), name, CACHE_VERSION))


def write_cache(cache, root: str | Path, ds_id: str, overwrite: bool = False) -> None:
    """Write a freshly simulated cache (:func:`~.cache.simulate_cache` sets ``cache.log``) as dataset ``ds_id``."""
    from .cache import make_env

    log = cache.log
    if log is None:
        raise ValueError("only a cache just simulated by simulate_cache can be written (it holds the infos)")
    task = cache.meta["task"]
    env = make_env(task, obs_mode="state", scene=cache.meta.get("scene"))
    try:
        if env.spec.id != cache.meta["env_id"]:
            raise ValueError(f"the cache was simulated on {cache.meta['env_id']}, this version makes {env.spec.id}")
        extra = pds.phyplan_metadata(env, policy=POLICY, split=cache.meta["split"], seed=int(cache.meta["seed"]),
                                     episodes=cache.n_simulations, contexts=cache.n_contexts,
                                     attempts_per_context=int(cache.meta["actions_per_context"]), images=False,
                                     cache=dict(cache.meta), built_by="phyplan_agents.dqn.cache.get_cache")
        writer = pds.DatasetWriter(ds_id, env, root, overwrite=overwrite, algorithm_name=POLICY,
                                   description=f"DQN simulation cache of {env.spec.id}: {cache.n_contexts} "
                                               f"{cache.meta['split']} contexts x distinct random grid actions",
                                   extra=extra)
        try:
            attempt = np.zeros(cache.n_contexts, np.int64)
            for i, (c, action, reward) in enumerate(zip(cache.context_index, cache.actions, cache.rewards)):
                attempt[c] += 1
                writer.add(pds.attempt_episode(i, int(cache.seeds[c]), int(attempt[c]), log["reset_obs"][c],
                                               log["reset_info"][c], action, float(reward), log["final_obs"][i],
                                               log["step_info"][i]))
            writer.finish()
        except BaseException:
            writer.abort()
            raise
    finally:
        env.close()


def cache_from_dataset(dataset, image_size: int = 64, grid_counts: tuple[int, ...] | None = None,
                       snap: bool = False):
    """A :class:`~.cache.SimulationCache` of a phyplan dataset (a cache's, or one of ``benchmarks.datasets``).

    Args:
        dataset: a ``minari.MinariDataset`` in the phyplan format (``phyplan_agents.datasets.load``).
        image_size: side of the context images, rendered from each context.
        grid_counts: the action grid (default: the cache's grid, else the task's default resolution).
        snap: map actions that are not grid points to the nearest grid point (else ``ValueError``).
    """
    import phyplan_envs

    from .cache import CACHE_VERSION, SimulationCache, make_env, task_grid

    meta: dict[str, Any] = dict(dataset.storage.metadata.get("phyplan") or {})
    if meta.get("format") != pds.FORMAT:
        raise ValueError(f"dataset {dataset.id} is not in the phyplan format ({pds.FORMAT}): no 'phyplan' metadata")
    task = meta["task"]
    if task not in phyplan_envs.TASKS:
        raise ValueError(f"the DQN baselines train on the nominal tasks ({', '.join(phyplan_envs.TASKS)}); dataset "
                         f"{dataset.id} is of {task!r}")
    if meta["env_id"] != phyplan_envs.env_id(task):
        raise ValueError(f"dataset {dataset.id} was made on {meta['env_id']}; this version's {task} is "
                         f"{phyplan_envs.env_id(task)}")
    cache_meta = dict(meta.get("cache") or {})
    if grid_counts is None and "grid" in cache_meta:
        grid_counts = tuple(cache_meta["grid"]["counts"])
    scene = cache_meta.get("scene")
    grid = task_grid(task, grid_counts, scene)
    keys: dict[str, int] = {}
    contexts, seeds, rows_c, actions, rewards = [], [], [], [], []
    for ep in dataset.iterate_episodes():
        text = pds.info_row(ep.infos["context"])
        if text not in keys:
            keys[text] = len(contexts)
            contexts.append(pds.decode_context(text))
            seeds.append(pds.episode_seed(ep))
        rows_c.append(keys[text])
        actions.append(np.asarray(ep.actions[0], np.float64))
        rewards.append(float(ep.rewards[0]))
    actions = np.asarray(actions, np.float64).reshape(len(rewards), grid.dim)
    index = grid.nearest(actions)
    on_grid = np.all(grid.action(index) == actions, axis=1)
    if not snap and not on_grid.all():
        raise ValueError(f"{int((~on_grid).sum())} of {len(actions)} actions of {dataset.id} are not points of the "
                         f"grid {grid.counts}; pass snap=True to map them to the nearest grid point")
    if any(s is None for s in seeds):
        raise ValueError(f"dataset {dataset.id} has episodes without a context seed")
    env = make_env(task, obs_mode="image", image_size=image_size, scene=scene)
    try:
        images = np.zeros((len(contexts), image_size, image_size, 3), np.uint8)
        for c, ctx in enumerate(contexts):
            images[c] = env.reset(options={"context": ctx})[0]
    finally:
        env.close()
    if not cache_meta:
        counts = np.bincount(rows_c)
        cache_meta = {"version": CACHE_VERSION, "task": task, "env_id": meta["env_id"], "simulations": len(rewards),
                      "actions_per_context": int(counts.max()), "contexts": len(contexts), "seed": meta.get("seed"),
                      "split": meta.get("split"), "source_policy": meta.get("policy"),
                      "snapped": int((~on_grid).sum())}
    cache_meta.update(grid=grid.to_dict(), image_size=int(image_size), dataset=dataset.id)
    return SimulationCache(images=images, seeds=np.asarray(seeds, np.int64),
                           goals=np.asarray([np.asarray(c["goal"], np.float64) for c in contexts]).reshape(-1, 2),
                           context_index=np.asarray(rows_c, np.int64), action_index=np.asarray(index, np.int64),
                           actions=grid.action(index), rewards=np.asarray(rewards, np.float64), meta=cache_meta)
