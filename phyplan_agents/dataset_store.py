"""Where phyplan datasets live and how a context is stored: Minari's local store and the context encoding.

The format's names (:data:`FORMAT`, :data:`NAMESPACE`, :data:`HIDDEN_KEY`, :data:`CONTEXT_ENCODING`, the extra
:data:`EXTRA`); Minari reached only through :func:`require_minari` (an optional dependency: this module imports
without it, :func:`minari_available` tells), and only its local functions: :func:`default_root` /
:func:`datasets_root` (``MINARI_DATASETS_PATH``), :func:`dataset_id`, :func:`dataset_dir`, :func:`exists` and
:func:`load` (never downloads); :func:`encode_context` / :func:`decode_context`, ``info["context"]`` as JSON and back
(every float64 bit kept). Re-exported by :mod:`phyplan_agents.datasets`, the format's module.
"""
from __future__ import annotations

import contextlib
import importlib
import json
import os
import re
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
