"""Trained DQN models on disk: one ``<task>.pt`` per task plus a ``manifest.json`` with checksums and settings.

The shipped models live in ``phyplan_agents/dqn_models/`` (package data; nothing is downloaded) and are rebuilt by
``make baselines`` (``python -m phyplan_agents.dqn.train --all``, and ``--task paddles --paddles 1 2 3 4`` for the
depth track's Paddles-N models, one per N: ``paddles-paddles<N>.pt``). A model file holds the Q-network's ``state_dict``
(:class:`~phyplan_agents.dqn.policy.ActionConditionedQNetwork`, including the image mean it subtracts); the manifest
entry of the task holds everything needed to rebuild the network (grid, image size, hyperparameters), the SHA-256 of
the file, and how the model was made (simulations, contexts, wall times).

Loading verifies the checksum first: a missing, truncated or modified file raises an error that names the file and
the command that rebuilds it.
"""
from __future__ import annotations

import io
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch as th
from gymnasium import spaces

from ..files import atomic_write_bytes, atomic_write_json, require_sha256, sha256_file
from .grid import ActionGrid
from .policy import ActionConditionedDQNPolicy, ActionConditionedQNetwork

MANIFEST = "manifest.json"
FORMAT_VERSION = 1


class ModelFileError(RuntimeError):
    """A model file or manifest is missing, corrupt or does not match its checksum."""


def shipped_model_dir() -> Path:
    """The folder of the models shipped inside the package."""
    return Path(__file__).resolve().parent.parent / "dqn_models"


def _rebuild_hint(task: str, model_dir: Path) -> str:
    from .cache import train_arguments

    where = "" if model_dir == shipped_model_dir() else f" --out {model_dir}"
    return f"rebuild it with `python -m phyplan_agents.dqn.train {train_arguments(task)}{where}`"


def read_manifest(model_dir: str | Path | None = None) -> dict[str, Any]:
    """The manifest of ``model_dir`` (default: the shipped models); ``{"format": 1, "models": {}}`` if absent."""
    model_dir = Path(model_dir) if model_dir is not None else shipped_model_dir()
    path = model_dir / MANIFEST
    if not path.exists():
        return {"format": FORMAT_VERSION, "models": {}}
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise ModelFileError(f"DQN model manifest {path} is unreadable ({exc})") from exc
    if not isinstance(data, dict) or not isinstance(data.get("models"), dict):
        raise ModelFileError(f"DQN model manifest {path} has no 'models' table")
    return data


def save_model(task: str, q_net: ActionConditionedQNetwork, entry: dict[str, Any],
               model_dir: str | Path | None = None) -> Path:
    """Write ``<task>.pt`` and its manifest entry (``entry`` + file name and checksum) into ``model_dir``."""
    model_dir = Path(model_dir) if model_dir is not None else shipped_model_dir()
    model_dir.mkdir(parents=True, exist_ok=True)
    buf = io.BytesIO()
    th.save({k: v.detach().cpu().clone() for k, v in q_net.state_dict().items()}, buf)
    path = model_dir / f"{task}.pt"
    atomic_write_bytes(path, buf.getvalue())
    manifest = read_manifest(model_dir)
    manifest["format"] = FORMAT_VERSION
    manifest["models"][task] = {**entry, "file": path.name, "sha256": sha256_file(path),
                                "bytes": path.stat().st_size}
    atomic_write_json(model_dir / MANIFEST, manifest, indent=2)
    return path


@dataclass
class LoadedModel:
    """A Q-network ready for inference, with its action grid and settings (the manifest entry)."""

    task: str
    q_net: ActionConditionedQNetwork
    grid: ActionGrid
    image_size: int
    entry: dict[str, Any]
    path: Path


def build_policy(grid: ActionGrid, image_size: int, train_config: dict[str, Any],
                 mean_image: np.ndarray | None = None) -> ActionConditionedDQNPolicy:
    """An untrained :class:`ActionConditionedDQNPolicy` with the architecture of ``train_config``."""
    from .training import TrainConfig

    cfg = TrainConfig(**train_config)
    obs_space = spaces.Box(0, 255, shape=(3, image_size, image_size), dtype=np.uint8)
    policy = ActionConditionedDQNPolicy(obs_space, spaces.Discrete(grid.n), lambda _: cfg.learning_rate,
                                        **cfg.policy_kwargs(grid.encode(grid.points()), mean_image))
    policy.set_training_mode(False)
    return policy


def load_model(task: str, model_dir: str | Path | None = None) -> LoadedModel:
    """Load and verify the model of ``task`` from ``model_dir`` (default: the shipped models).

    Raises :class:`ModelFileError` naming the file if the manifest has no entry for the task, the file is
    missing, its SHA-256 differs from the manifest's, or it cannot be read as this network's weights.
    """
    model_dir = Path(model_dir) if model_dir is not None else shipped_model_dir()
    manifest = read_manifest(model_dir)
    entry = manifest["models"].get(task)
    if entry is None:
        known = ", ".join(sorted(manifest["models"])) or "none"
        raise ModelFileError(f"no DQN model for task {task!r} in {model_dir / MANIFEST} (models: {known}); "
                             f"{_rebuild_hint(task, model_dir)}")
    path = model_dir / entry["file"]
    if not path.exists():
        raise ModelFileError(f"DQN model file {path} is missing; {_rebuild_hint(task, model_dir)}")
    require_sha256(path, entry.get("sha256"), lambda digest: ModelFileError(
        f"DQN model file {path} is corrupt or modified: SHA-256 {digest[:12]}... differs from the manifest's "
        f"{str(entry.get('sha256'))[:12]}...; {_rebuild_hint(task, model_dir)}"))
    try:
        grid = ActionGrid.from_dict(entry["grid"])
        image_size = int(entry["image_size"])
        policy = build_policy(grid, image_size, entry["train_config"])
        state = th.load(path, map_location="cpu", weights_only=True)
        policy.q_net.load_state_dict(state)
        policy.q_net_target.load_state_dict(state)
    except Exception as exc:
        raise ModelFileError(f"DQN model file {path} cannot be loaded ({type(exc).__name__}: {exc}); "
                             f"{_rebuild_hint(task, model_dir)}") from exc
    policy.set_training_mode(False)
    return LoadedModel(task=task, q_net=policy.q_net, grid=grid, image_size=image_size, entry=entry, path=path)
