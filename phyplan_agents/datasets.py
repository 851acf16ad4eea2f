"""Logged attempts as Minari datasets: one episode per attempt, written and read through Minari's local API.

Needs the optional extra ``pip install 'phyplan[datasets]'`` (Minari with its HDF5 storage); this module imports
without it and :func:`require_minari` names the extra when it is missing. Only Minari's local functions are used
(``create_dataset_from_buffers``, ``MinariDataset``, ``list_local_namespaces``/``create_namespace``): nothing here
touches the network. ``python -m benchmarks.datasets`` builds datasets with the agents; the DQN simulation cache
(:mod:`phyplan_agents.dqn.dataset_io`) writes and reads the same format. ``docs/datasets.md`` is the user's guide.

One episode is one attempt, so it has one step (Minari's convention: ``observations`` and every ``infos`` entry hold
one row more than the steps, row 0 from ``reset`` and row 1 from ``step``):

* ``observations``: ``(2, S)`` float32 state vectors (the env's ``state_names``): the context's observation and the
  one after the attempt; with images a dict ``{"state": (2, S), "image": (2, H, W, 3) uint8}`` (the ``obs`` camera,
  which Minari's HDF5 storage keeps as JPEG);
* ``actions``: ``(1, D)`` float64, exactly what was passed to ``env.step`` (the dataset's action space is the
  task's box in float64: the env's float32 ``Box`` would round the actions and change their outcomes);
* ``rewards`` ``(1,)``, ``terminations`` ``[True]``, ``truncations`` ``[False]``;
* ``infos`` (row 0 after ``reset``, row 1 after ``step``): ``goal`` (2, 2); ``object_pos`` (2, 3): the object's
  start, then the env's ``info["final_pos"]``; ``distance`` (2,): the initial, then the final distance to the goal;
  ``initial_distance``; ``is_success`` (bool); ``end_reason`` (str, ``""`` in row 0); ``sim_time``; ``n_steps``;
  ``context`` (str): ``info["context"]`` as JSON (:func:`encode_context`), replayed by
  ``env.reset(options={"context": decode_context(...)})``; ``context_seed``: the ``env.reset(seed=...)`` that drew
  the context (also the episode's Minari ``seed``); ``attempt``: 1, 2, ... within its context;
* varied tasks only, privileged: ``infos["privileged_hidden_physics"]``, a dict of the hidden values (one (2,) array
  per parameter, ``env.unwrapped.hidden_physics``). A learner that must not see the physics ignores that key.

The dataset's metadata holds a ``"phyplan"`` block (task, policy, split, seeds, versions; :func:`phyplan_metadata`).

Modules: :mod:`phyplan_agents.dataset_store` (the format's names, Minari's local store, the context encoding) and
:mod:`phyplan_agents.dataset_writer` (episodes, metadata, :class:`DatasetWriter`, :func:`compact_hdf5`); their public
names are re-exported here, the stable import. This module reads datasets back: :func:`info_row`,
:func:`episode_context`, :func:`episode_seed`, :func:`replay` and :func:`check_dataset`.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from .dataset_store import (CONTEXT_ENCODING, EXTRA, FORMAT, HIDDEN_KEY, NAMESPACE, dataset_dir,  # noqa: F401
                            dataset_id, datasets_root, decode_context, default_root, encode_context, exists, load,
                            minari_available, require_minari)
from .dataset_writer import (DatasetWriter, action_space64, attempt_episode, compact_hdf5,  # noqa: F401
                             phyplan_metadata, requirements)


# ======================================================================================================= reading
def info_row(value: Any, i: int = 1) -> Any:
    """Row ``i`` of an ``infos`` entry (1: after the step), a Python scalar or bytes for scalars."""
    v = np.asarray(value)[i]
    return v.item() if isinstance(v, np.generic) else v


def episode_context(episode) -> dict[str, Any]:
    """The context of an episode (``reset(options={"context": ...})`` replays it)."""
    return decode_context(info_row(episode.infos["context"]))


def episode_seed(episode) -> int | None:
    s = int(info_row(episode.infos["context_seed"]))
    return None if s < 0 else s


def replay(env, episode, how: str = "context"):
    """Run an episode's attempt again on ``env``: ``(obs, reward, terminated, truncated, info)`` of the step.

    ``how``: ``"context"`` (``reset(options={"context": ...})``, the stored ``info["context"]``; a varied task's
    sealed ``physics_token`` opens only in a process with the secret it was sealed under, see docs/datasets.md),
    ``"seed"`` (``reset(seed=context_seed)``: the same context in any process) or ``"physics"`` (varied tasks,
    privileged: ``reset(options={"goal": ..., "physics": privileged_hidden_physics})``, in any process).
    """
    if how == "context":
        env.reset(options={"context": episode_context(episode)})
    elif how == "seed":
        seed = episode_seed(episode)
        if seed is None:
            raise ValueError(f"episode {episode.id} has no context seed: replay it with how='context'")
        env.reset(seed=seed)
    elif how == "physics":
        if HIDDEN_KEY not in episode.infos:
            raise ValueError(f"episode {episode.id} has no {HIDDEN_KEY} (not a varied task): use how='context'")
        physics = {k: float(np.asarray(v)[0]) for k, v in episode.infos[HIDDEN_KEY].items()}
        env.reset(options={"goal": np.asarray(episode.infos["goal"][0], np.float64), "physics": physics})
    else:
        raise ValueError(f"how must be 'context', 'seed' or 'physics', got {how!r}")
    return env.step(np.asarray(episode.actions[0], dtype=np.float64))


def check_dataset(dataset, episodes: int | None = None) -> None:
    """Minari's integrity checks on a phyplan dataset, raising ``AssertionError`` with what failed: the episode
    and step counts of the metadata against the episodes stored, each episode's id, step count and seed, one step
    per episode, every observation in the observation space and every action in the action space, the infos'
    rows, and the ``"phyplan"`` block."""
    meta = dataset.storage.metadata
    n = dataset.total_episodes
    assert meta["total_episodes"] == n and dataset.total_steps == n, \
        f"metadata says {meta['total_episodes']} episodes / {dataset.total_steps} steps, {n} stored"
    if episodes is not None:
        assert n == episodes, f"{n} episodes, expected {episodes}"
    assert "phyplan" in meta and meta["phyplan"]["format"] == FORMAT, "the 'phyplan' metadata block is missing"
    obs_space, act_space = dataset.observation_space, dataset.action_space
    seen = 0
    for ep, ep_meta in zip(dataset.iterate_episodes(), dataset.storage.get_episode_metadata(dataset.episode_indices)):
        seen += 1
        assert ep_meta["id"] == ep.id and ep_meta["total_steps"] == 1, f"episode {ep.id}: metadata {ep_meta}"
        assert ep_meta.get("seed", -1) == int(info_row(ep.infos["context_seed"])), f"episode {ep.id}: seed differs"
        assert len(ep) == 1 and ep.terminations.tolist() == [True] and ep.truncations.tolist() == [False], \
            f"episode {ep.id} is not one terminated step"
        obs = ep.observations
        rows = [{k: v[i] for k, v in obs.items()} for i in range(2)] if isinstance(obs, dict) else list(obs)
        assert len(rows) == 2 and all(obs_space.contains(r) for r in rows), \
            f"episode {ep.id}: observations not 2 rows inside {obs_space}"
        assert ep.actions.shape == (1,) + act_space.shape and act_space.contains(ep.actions[0]), \
            f"episode {ep.id}: action {ep.actions} outside {act_space}"
        for key, value in ep.infos.items():
            values = value.values() if isinstance(value, dict) else [value]
            assert all(len(v) == 2 for v in values), f"episode {ep.id}: infos[{key!r}] does not have 2 rows"
    assert seen == n, f"iterated {seen} episodes, the dataset says {n}"
