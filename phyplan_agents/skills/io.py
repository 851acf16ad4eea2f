"""Saving and loading skill models: a ``.pt`` state dict plus a ``.json`` metadata file with its SHA-256.

Files ``<dir>/<skill>_<kind>.pt`` and ``<dir>/<skill>_<kind>.json``. The JSON holds the skill, kind, input and output
names, the normalisation, data size, seed, learnt parameters, validation errors and the SHA-256 of the ``.pt`` file;
loading checks the checksum before ``torch.load(weights_only=True)`` and raises :class:`SkillFileError` (naming the
file) for a missing, corrupt or mismatching file.
"""
from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import torch

from ..files import atomic_path, atomic_write_json, require_sha256, sha256_file
from .contract import skill_spec
from .models import DEFAULT_KIND, SkillModel, check_kind

WEIGHTS_DIR = Path(__file__).resolve().parent / "weights"
FORMAT_VERSION = 1


class SkillFileError(RuntimeError):
    """A skill model file is missing, corrupt or does not match its metadata."""


sha256 = sha256_file
"""The SHA-256 of a file (:func:`phyplan_agents.files.sha256_file`; kept under this name for callers)."""


def paths(skill: str, kind: str, directory: str | os.PathLike | None = None) -> tuple[Path, Path]:
    """(weights .pt, metadata .json) paths of a model."""
    d = Path(directory) if directory is not None else WEIGHTS_DIR
    return d / f"{skill}_{kind}.pt", d / f"{skill}_{kind}.json"


def _jsonable(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, torch.Tensor):
        return obj.tolist()
    if hasattr(obj, "item") and callable(obj.item):
        return obj.item()
    return obj


def save(model: SkillModel, directory: str | os.PathLike | None = None) -> tuple[Path, Path]:
    """Write ``model`` to ``<directory>/<skill>_<kind>.pt`` and ``.json`` (default: the shipped weights folder)."""
    pt, js = paths(model.skill, model.kind, directory)
    pt.parent.mkdir(parents=True, exist_ok=True)
    state = {k: v.detach().clone().contiguous() for k, v in model.state_dict().items()}
    with atomic_path(pt) as tmp:
        torch.save(state, tmp)
    meta = dict(model.meta)
    meta.update({
        "format": FORMAT_VERSION, "skill": model.skill, "kind": model.kind,
        "inputs": list(model.inputs), "outputs": list(model.outputs),
        "hidden_layers": model.hidden, "width": model.width,
        "normalisation": {"in_center": model.in_center.tolist(), "in_scale": model.in_scale.tolist(),
                          "out_mean": model.out_mean.tolist(), "out_scale": model.out_scale.tolist()},
        "params": model.params,
        "weights_file": pt.name, "sha256": sha256_file(pt), "torch_version": torch.__version__,
    })
    atomic_write_json(js, _jsonable(meta), indent=1)
    return pt, js


def load(skill: str, kind: str | None = None, directory: str | os.PathLike | None = None) -> SkillModel:
    """Load a saved model (see :func:`load_skill`)."""
    spec = skill_spec(skill)
    kind = check_kind(spec.name, kind)
    pt, js = paths(spec.name, kind, directory)
    if not js.is_file():
        raise SkillFileError(f"skill metadata file not found: {js} (train it with `python -m "
                             f"phyplan_agents.skills.train --skill {spec.name} --model {kind}` or `make skills`)")
    if not pt.is_file():
        raise SkillFileError(f"skill weights file not found: {pt} (metadata {js.name} exists; retrain with "
                             f"`python -m phyplan_agents.skills.train --skill {spec.name} --model {kind}`)")
    try:
        meta = json.loads(js.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise SkillFileError(f"skill metadata file {js} is not valid JSON: {exc}") from None
    if not isinstance(meta, dict) or meta.get("skill") != spec.name or meta.get("kind") != kind:
        raise SkillFileError(f"skill metadata file {js} does not describe {spec.name}/{kind}")
    require_sha256(pt, meta.get("sha256"), lambda digest: SkillFileError(
        f"skill weights file {pt} is corrupt or was changed: its SHA-256 {digest[:16]}... does not match "
        f"{str(meta.get('sha256'))[:16]}... recorded in {js.name}"))
    try:
        state = torch.load(pt, map_location="cpu", weights_only=True)
    except Exception as exc:  # noqa: BLE001 - any unpickling failure is a corrupt file
        raise SkillFileError(f"skill weights file {pt} cannot be read: {exc}") from None
    if (list(meta.get("inputs", [])) != list(spec.inputs) or list(meta.get("outputs", [])) != list(spec.outputs)):
        raise SkillFileError(f"skill metadata file {js}: inputs/outputs {meta.get('inputs')} -> {meta.get('outputs')} "
                             f"differ from the skill's {spec.inputs} -> {spec.outputs}")
    norm = meta["normalisation"]
    model = SkillModel(spec.name, kind, norm["in_center"], norm["in_scale"], norm["out_mean"], norm["out_scale"],
                       hidden=int(meta.get("hidden_layers", 8)), width=int(meta.get("width", 40)),
                       params=meta.get("params") or {})
    try:
        model.load_state_dict(state, strict=True)
    except (RuntimeError, KeyError) as exc:
        raise SkillFileError(f"skill weights file {pt} does not fit the model described in {js.name}: {exc}") from None
    model.eval()
    model.meta = meta
    return model


def load_skill(skill: str, kind: str | None = None, directory: str | os.PathLike | None = None) -> SkillModel:
    """A trained skill model, by default from the weights shipped with the package.

    Args:
        skill: ``swing``, ``slide``, ``throw``, ``hit`` or ``bounce`` (or ``swinging``, ``sliding``, ...).
        kind: ``"pinn"`` or ``"nn"``; default ``pinn`` for swing/slide/throw and ``nn`` for hit/bounce. ``"pinn"``
            for hit or bounce is a ``ValueError`` (they have no governing equation).
        directory: a folder of ``<skill>_<kind>.pt/.json`` files (default: ``phyplan_agents/skills/weights``).

    Raises:
        SkillFileError: the files are missing, corrupt (checksum mismatch) or inconsistent; the message names the file.
    """
    return load(skill, kind, directory)


class SkillSet:
    """The nominal skill models as attributes ``swing``, ``slide``, ``throw``, ``hit``, ``bounce`` and
    ``bounce_general`` (the general-incidence bounce), and the Paddles task's :data:`PADDLE_NAMES` (``swing_wide``,
    ``hit_wide``, ``throw_wide``, ``glide``, ``bounce_general_low``, ``bounce_general_low_cond``; ``None`` when
    loaded with ``paddles=False``) and the skills the composer adds where a scene needs them, :data:`COMPOSER_NAMES`
    (``hit_free``: the hit's physical hand-over; ``bounce_wall``: the bounce off walls; ``bounce_general_fast``: the
    general bounce at up to 10 m/s; ``throw_fast``: the throw of balls bouncing off paddles;
    ``bounce_general_exact_cond``: the bounce off PaddlesVaried-v3's exact impacts; ``hit_free_slow``: the slow
    hits' and pushes' hand-over; ``None`` when loaded with ``composer=False``).

    Iterating yields the :data:`NAMES` ones only (as before the Paddles skills); :meth:`all_items` yields every
    loaded one."""

    NAMES = ("swing", "slide", "throw", "hit", "bounce", "bounce_general")
    PADDLE_NAMES = ("swing_wide", "hit_wide", "throw_wide", "glide", "bounce_general_low", "bounce_general_low_cond")
    COMPOSER_NAMES = ("hit_free", "bounce_wall", "bounce_general_fast", "throw_fast", "bounce_general_exact_cond",
                      "hit_free_slow")

    def __init__(self, swing: SkillModel, slide: SkillModel, throw: SkillModel, hit: SkillModel,
                 bounce: SkillModel, bounce_general: SkillModel, swing_wide: SkillModel | None = None,
                 hit_wide: SkillModel | None = None, throw_wide: SkillModel | None = None,
                 glide: SkillModel | None = None, bounce_general_low: SkillModel | None = None,
                 bounce_general_low_cond: SkillModel | None = None, hit_free: SkillModel | None = None,
                 bounce_wall: SkillModel | None = None, bounce_general_fast: SkillModel | None = None,
                 throw_fast: SkillModel | None = None, bounce_general_exact_cond: SkillModel | None = None,
                 hit_free_slow: SkillModel | None = None):
        self.swing, self.slide, self.throw, self.hit, self.bounce = swing, slide, throw, hit, bounce
        self.bounce_general = bounce_general
        self.swing_wide, self.hit_wide, self.throw_wide, self.glide = swing_wide, hit_wide, throw_wide, glide
        self.bounce_general_low, self.bounce_general_low_cond = bounce_general_low, bounce_general_low_cond
        self.hit_free, self.bounce_wall, self.bounce_general_fast = hit_free, bounce_wall, bounce_general_fast
        self.throw_fast, self.bounce_general_exact_cond = throw_fast, bounce_general_exact_cond
        self.hit_free_slow = hit_free_slow

    @classmethod
    def load(cls, directory: str | os.PathLike | None = None, kinds: dict[str, str] | None = None,
             paddles: bool = True, composer: bool = True) -> "SkillSet":
        """Load them all (default: the shipped weights, each skill's default kind; ``kinds`` overrides per skill,
        e.g. ``{"swing": "nn"}``; ``paddles=False`` / ``composer=False``: not the Paddles skills / not
        :data:`COMPOSER_NAMES`, e.g. from a folder without them)."""
        kinds = dict(kinds or {})
        names = cls.NAMES + (cls.PADDLE_NAMES if paddles else ()) + (cls.COMPOSER_NAMES if composer else ())
        unknown = set(kinds) - set(names)
        if unknown:
            raise ValueError(f"unknown skills in kinds: {sorted(unknown)}; skills: {names}")
        return cls(**{s: load(s, kinds.get(s, DEFAULT_KIND[s]), directory) for s in names})

    def __iter__(self):
        return iter((s, getattr(self, s)) for s in self.NAMES)

    def all_items(self):
        """(name, model) of every loaded skill: :data:`NAMES`, then the loaded :data:`PADDLE_NAMES` and
        :data:`COMPOSER_NAMES`."""
        return iter((s, getattr(self, s)) for s in self.NAMES + self.PADDLE_NAMES + self.COMPOSER_NAMES
                    if getattr(self, s) is not None)

    def __repr__(self) -> str:
        return "SkillSet(" + ", ".join(f"{s}={getattr(self, s).kind}" for s in self.NAMES) + ")"
