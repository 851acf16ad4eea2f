"""Writing phyplan datasets: one attempt as a Minari episode buffer, the metadata, the writer, the HDF5 compaction.

:func:`attempt_episode` makes the episode of one attempt in the format of :mod:`phyplan_agents.datasets`;
:func:`phyplan_metadata` the dataset's ``"phyplan"`` metadata block; :class:`DatasetWriter` writes a dataset in
chunks into a hidden folder and moves it into place when it is complete; :func:`compact_hdf5` rewrites Minari's HDF5
file with contiguous datasets; :func:`action_space64` and :func:`requirements` are the dataset's action space and
pip requirements. Re-exported by :mod:`phyplan_agents.datasets`.
"""
from __future__ import annotations

import os
import shutil
import tempfile
import warnings
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from .dataset_store import (CONTEXT_ENCODING, FORMAT, HIDDEN_KEY, dataset_dir, datasets_root, default_root,
                            encode_context, exists, load, require_minari)


def attempt_episode(ep_id: int, seed: int | None, attempt: int, obs0: Any, reset_info: Mapping[str, Any],
                    action: np.ndarray, reward: float, obs1: Any, step_info: Mapping[str, Any],
                    hidden: Mapping[str, float] | None = None):
    """A Minari ``EpisodeBuffer`` of one attempt: ``reset`` gave ``(obs0, reset_info)``, ``step(action)`` gave
    ``(obs1, reward, True, False, step_info)``; ``hidden`` the varied task's privileged values (or None)."""
    EpisodeBuffer = require_minari("minari.data_collector").EpisodeBuffer

    if isinstance(obs0, Mapping):
        observations = {k: [np.asarray(obs0[k]), np.asarray(obs1[k])] for k in obs0}
    else:
        observations = [np.asarray(obs0), np.asarray(obs1)]
    ctx = encode_context(step_info["context"])
    d0 = float(reset_info["initial_distance"])
    seed_row = -1 if seed is None else int(seed)
    infos: dict[str, Any] = {
        "goal": [np.asarray(reset_info["goal"], np.float64), np.asarray(step_info["goal"], np.float64)],
        "object_pos": [np.asarray(reset_info["object_pos"], np.float64),
                       np.asarray(step_info["final_pos"], np.float64)],
        "distance": [d0, float(step_info["distance"])],
        "initial_distance": [d0, float(step_info["initial_distance"])],
        "is_success": [False, bool(step_info["is_success"])],
        "end_reason": ["", str(step_info["end_reason"])],
        "sim_time": [0.0, float(step_info["sim_time"])],
        "n_steps": [0, int(step_info["n_steps"])],
        "context": [ctx, ctx],
        "context_seed": [seed_row, seed_row],
        "attempt": [int(attempt), int(attempt)],
    }
    if hidden is not None:
        infos[HIDDEN_KEY] = {k: [float(v), float(v)] for k, v in hidden.items()}
    return EpisodeBuffer(id=int(ep_id), seed=None if seed is None else int(seed),
                         observations=observations, actions=[np.asarray(action, np.float64)],
                         rewards=[float(reward)], terminations=[True], truncations=[False], infos=infos)


def action_space64(env):
    """The task's action box in float64 (exact bounds), the action space of every phyplan dataset."""
    import gymnasium as gym

    base = env.unwrapped
    low = np.array([d.low for d in base.action_dims], dtype=np.float64)
    high = np.array([d.high for d in base.action_dims], dtype=np.float64)
    return gym.spaces.Box(low, high, dtype=np.float64)


def requirements() -> list[str]:
    """pip requirements recorded with a dataset (Minari's ``recover_environment`` warns when they do not hold)."""
    from importlib import metadata

    import mujoco

    out = [f"mujoco=={mujoco.__version__}"]
    try:
        out.insert(0, f"phyplan=={metadata.version('phyplan')}")
    except metadata.PackageNotFoundError:  # pragma: no cover - running from a source tree without install
        pass
    return out


def phyplan_metadata(env, **fields: Any) -> dict[str, Any]:
    """The ``"phyplan"`` block of a dataset's metadata: the format, the env and what the caller adds."""
    import mujoco

    base = env.unwrapped
    hidden = [p.name for p in base.hidden_parameters] if hasattr(base, "hidden_parameters") else []
    return {"format": FORMAT, "task": base.task_name, "env_id": env.spec.id, "env_kwargs": dict(env.spec.kwargs),
            "state_names": list(base.state_names), "action_names": list(base.action_names),
            "context_encoding": CONTEXT_ENCODING, "hidden_physics": hidden,
            "privileged_key": HIDDEN_KEY if hidden else None,
            "context_replay": ("sealed under the building process's PHYPLAN_PHYSICS_SECRET: replay by context_seed or "
                               "the privileged physics elsewhere (docs/datasets.md)") if hidden else "any process",
            "infos_rows": "row 0 after reset, row 1 after step", "mujoco": mujoco.__version__, **fields}


class DatasetWriter:
    """Writes one Minari dataset, ``chunk`` episodes at a time, into a hidden folder of ``root`` that is moved to
    its place only when :meth:`finish` succeeds (a failed build leaves no partial dataset).

    Args:
        ds_id: the dataset id (:func:`dataset_id`).
        env: the env the attempts ran on (made by ``gym.make``: its spec is what ``recover_environment`` makes).
        root: the Minari root folder (default :func:`default_root`).
        overwrite: replace an existing dataset of that id (else ``FileExistsError``, raised here, before any work).
        algorithm_name, description: Minari's metadata fields; ``extra``: the ``"phyplan"`` metadata block.
    """

    def __init__(self, ds_id: str, env, root: str | Path | None = None, overwrite: bool = False,
                 algorithm_name: str = "", description: str = "", extra: Mapping[str, Any] | None = None,
                 chunk: int = 500):
        self.minari = require_minari()
        self.root = Path(root) if root is not None else default_root()
        if exists(self.root, ds_id) and not overwrite:
            raise FileExistsError(f"dataset {ds_id} already exists in {self.root}; pass overwrite=True "
                                  f"(--overwrite) to replace it")
        self.ds_id, self.env, self.overwrite = ds_id, env, overwrite
        self.algorithm_name, self.description = algorithm_name, description
        self.extra = dict(extra or {})
        self.chunk = int(chunk)
        self._pending: list = []
        self._dataset = None
        self._tmp: Path | None = None
        self.episodes = 0

    def add(self, episode) -> None:
        self._pending.append(episode)
        self.episodes += 1
        if len(self._pending) >= self.chunk:
            self._flush()

    def _flush(self) -> None:
        if not self._pending:
            return
        if self._dataset is None:
            self.root.mkdir(parents=True, exist_ok=True)
            self._tmp = Path(tempfile.mkdtemp(prefix=".phyplan-build-", dir=self.root))
            with datasets_root(self._tmp), warnings.catch_warnings():
                warnings.filterwarnings("ignore", message=".*author_email.*")
                self._dataset = self.minari.create_dataset_from_buffers(
                    self.ds_id, self._pending, env=self.env, eval_env=self.env.spec,
                    algorithm_name=self.algorithm_name, author="phyplan", code_permalink="phyplan_agents/datasets.py",
                    action_space=action_space64(self.env), observation_space=self.env.observation_space,
                    description=self.description, data_format="hdf5", requirements=requirements())
        else:
            self._dataset.update_dataset_from_buffer(self._pending)
        self._pending = []

    def finish(self):
        """Write what is left, add the ``"phyplan"`` metadata, move the dataset into ``root`` and load it."""
        if self.episodes == 0:
            self.abort()
            raise ValueError("a dataset needs at least one episode")
        self._flush()
        storage = self._dataset.storage
        compact_hdf5(Path(storage.data_path) / "main_data.hdf5")
        storage.update_metadata({"phyplan": self.extra, "dataset_size": storage.get_size()})
        final = dataset_dir(self.root, self.ds_id)
        with datasets_root(self.root):
            ns = require_minari("minari.namespace")
            namespace = self.ds_id.rsplit("/", 1)[0]
            if namespace not in ns.list_local_namespaces():
                ns.create_namespace(namespace)
        if final.exists():
            if not self.overwrite:
                self.abort()
                raise FileExistsError(f"dataset {self.ds_id} appeared in {self.root} during the build")
            shutil.rmtree(final)
        final.parent.mkdir(parents=True, exist_ok=True)
        os.replace(dataset_dir(self._tmp, self.ds_id), final)
        self.abort()
        return load(self.root, self.ds_id)

    def abort(self) -> None:
        """Drop the hidden build folder (called by :meth:`finish`; call it when a build fails)."""
        if self._tmp is not None:
            shutil.rmtree(self._tmp, ignore_errors=True)
            self._tmp = None
        self._dataset = None


def compact_hdf5(path: Path) -> None:
    """Rewrite Minari's HDF5 file with contiguous datasets (same groups, datasets, dtypes and attributes).

    Minari writes every array of an episode as a chunked dataset, whose index costs ~2 KB: with one-step episodes
    that is 44 KB per episode for ~0.4 KB of data; contiguous datasets cost ~7 KB (HDF5's object headers). Minari
    reads both layouts alike (and appends new episodes to either)."""
    h5py = require_minari("h5py")

    def copy(src, dst) -> None:
        for k, v in src.attrs.items():
            dst.attrs[k] = v
        for name, obj in src.items():
            if isinstance(obj, h5py.Group):
                copy(obj, dst.create_group(name))
            else:
                d = dst.create_dataset(name, data=obj[()], dtype=obj.dtype)
                for k, v in obj.attrs.items():
                    d.attrs[k] = v

    tmp = path.with_name(path.name + ".compact")
    with h5py.File(path, "r") as src, h5py.File(tmp, "w", libver="latest") as dst:
        copy(src, dst)
    os.replace(tmp, path)
