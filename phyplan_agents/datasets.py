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
"""
from __future__ import annotations

import contextlib
import importlib
import json
import os
import re
import shutil
import tempfile
import warnings
from pathlib import Path
from typing import Any, Iterator, Mapping

import numpy as np

EXTRA = "datasets"
NAMESPACE = "phyplan"
FORMAT = "phyplan-attempts-v1"
CONTEXT_ENCODING = "json, numpy arrays as {'__ndarray__': list, 'dtype': str} (phyplan_agents.datasets)"
HIDDEN_KEY = "privileged_hidden_physics"
_NAME_RE = re.compile(r"^[A-Za-z0-9_]+(-[A-Za-z0-9_]+)*$")


# ======================================================================================================= minari
def require_minari(module: str = "minari"):
    """The ``minari`` module (or ``module``, one of Minari's or ``h5py``, its HDF5 storage), or ``ImportError``
    naming the extra that installs them. Every use of Minari here goes through this function: an optional
    dependency, declared in setup.cfg's ``datasets`` extra (``tests/test_datasets.py`` checks the declaration)."""
    try:
        importlib.import_module("h5py")
        minari = importlib.import_module("minari")
        if module != "minari":
            minari = importlib.import_module(module)
    except ImportError as exc:
        raise ImportError(f"phyplan datasets need Minari: pip install 'phyplan[{EXTRA}]' (Minari 0.5.x with h5py); "
                          f"{exc}") from exc
    return minari


def minari_available() -> bool:
    """Whether :func:`require_minari` would succeed (without importing Minari)."""
    import importlib.util

    return all(importlib.util.find_spec(m) is not None for m in ("minari", "h5py"))


def default_root() -> Path:
    """Where Minari keeps datasets: ``$MINARI_DATASETS_PATH``, else ``~/.minari/datasets`` (Minari's default)."""
    root = os.environ.get("MINARI_DATASETS_PATH")
    return Path(root) if root else Path.home() / ".minari" / "datasets"


@contextlib.contextmanager
def datasets_root(root: str | Path | None) -> Iterator[Path]:
    """Point Minari's local functions at ``root`` (``MINARI_DATASETS_PATH``) for the ``with`` block."""
    root = Path(root) if root is not None else default_root()
    old = os.environ.get("MINARI_DATASETS_PATH")
    os.environ["MINARI_DATASETS_PATH"] = str(root)
    try:
        yield root
    finally:
        if old is None:
            os.environ.pop("MINARI_DATASETS_PATH", None)
        else:
            os.environ["MINARI_DATASETS_PATH"] = old


def dataset_id(task: str, name: str, version: int = 0) -> str:
    """``phyplan/<task>/<name>-v<version>``, e.g. ``dataset_id("launch", "random") == "phyplan/launch/random-v0"``."""
    if not isinstance(name, str) or not _NAME_RE.match(name) or re.search(r"-v\d+$", name):
        raise ValueError(f"dataset name must be letters, digits, '_' and single '-' (no -vN suffix), got {name!r}")
    return f"{NAMESPACE}/{task}/{name}-v{int(version)}"


def dataset_dir(root: str | Path, ds_id: str) -> Path:
    """The folder of dataset ``ds_id`` under ``root`` (it holds ``data/``)."""
    return Path(root) / ds_id


def exists(root: str | Path, ds_id: str) -> bool:
    return (dataset_dir(root, ds_id) / "data").exists()


def load(root: str | Path | None, ds_id: str):
    """The local dataset ``ds_id`` under ``root`` (default :func:`default_root`); never downloads."""
    minari = require_minari()
    with datasets_root(root) as r:
        if not exists(r, ds_id):
            raise FileNotFoundError(f"no dataset {ds_id!r} under {r} (nothing is downloaded: build it with "
                                    f"python -m benchmarks.datasets, or copy it there)")
        return minari.load_dataset(ds_id, download=False)


# ====================================================================================================== contexts
def _to_json(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return {"__ndarray__": value.tolist(), "dtype": value.dtype.str}
    if isinstance(value, Mapping):
        if not all(isinstance(k, str) for k in value):
            raise TypeError(f"context keys must be strings, got {sorted(map(repr, value))}")
        return {k: _to_json(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_to_json(v) for v in value]
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.floating):
        return float(value)
    if isinstance(value, bytes):
        return {"__bytes__": value.hex()}
    if value is None or isinstance(value, (int, float, str)):
        return value
    raise TypeError(f"cannot store a context entry of type {type(value).__name__}: {value!r}")


def _from_json(value: Any) -> Any:
    if isinstance(value, dict):
        if "__ndarray__" in value:
            return np.asarray(value["__ndarray__"], dtype=np.dtype(value["dtype"]))
        if "__bytes__" in value:
            return bytes.fromhex(value["__bytes__"])
        return {k: _from_json(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_from_json(v) for v in value]
    return value


def encode_context(context: Mapping[str, Any]) -> str:
    """``info["context"]`` as a JSON string that :func:`decode_context` turns back into an equal context (arrays keep
    their dtype and every float64 bit: JSON floats are written with ``repr``)."""
    return json.dumps(_to_json(context), sort_keys=True, allow_nan=False)


def decode_context(text: str | bytes) -> dict[str, Any]:
    """The context stored by :func:`encode_context` (HDF5 gives strings back as ``bytes``; both are accepted)."""
    if isinstance(text, (bytes, np.bytes_)):
        text = bytes(text).decode("utf-8")
    return _from_json(json.loads(str(text)))


# ====================================================================================================== episodes
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
