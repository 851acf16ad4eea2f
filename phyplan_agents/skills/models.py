"""Skill networks: the paper's MLP (Table 1) with stored input/output normalisation and learnt physical parameters.

A :class:`SkillModel` maps physical inputs to physical outputs::

    y = out_mean + out_scale * MLP((x - in_center) / in_scale)

The MLP is 8 hidden layers of 40 tanh units with Xavier-normal weights and zero biases (Table 1 of the paper; its
"10 layers" count the input and output layers). The normalisation is part of the model (buffers of its
``state_dict``), so a loaded model needs nothing else. Physics-informed models also carry their unknown physical
parameters (the slide's friction coefficient ``mu``) as trainable scalars.
"""
from __future__ import annotations

from typing import Any, Mapping, Sequence

import numpy as np
import torch
from torch import nn

from . import bounce_law
from .contract import SKILLS, SkillSpec

HIDDEN_LAYERS = 8     # Table 1: 8 hidden layers
WIDTH = 40            # Table 1: 40 neurons per hidden layer
KINDS = ("pinn", "nn")
PINN_SKILLS = ("swing", "slide", "throw", "slide_cond")   # Table 2: the skills with a governing equation
PINN_SKILLS += ("swing_wide", "throw_wide", "glide")      # the Paddles task's (.physics)
PINN_SKILLS += ("throw_fast",)                            # bouncing paddles' (.physics)
PINN_SKILLS += bounce_law.LAW_SKILLS                      # and the general bounce's reflection law (.bounce_law)
DEFAULT_KIND = {"swing": "pinn", "slide": "pinn", "throw": "pinn", "hit": "nn", "bounce": "nn",
                "slide_cond": "pinn", "hit_cond": "nn", "bounce_cond": "nn",
                "swing_wide": "pinn", "hit_wide": "nn", "throw_wide": "pinn", "glide": "pinn", "hit_free": "nn",
                "throw_fast": "pinn",
                "hit_free_cond": "nn", "hit_free_slow": "nn"}
DEFAULT_KIND.update({name: "pinn" for name in bounce_law.LAW_SKILLS})
# Unknown physical parameters per PINN skill and their initial values (reference code: mu starts at 0.25).
LEARNT_PARAMS: dict[str, dict[str, float]] = {"slide": {"mu": 0.25}}
LEARNT_PARAMS.update({name: dict(bounce_law.LEARNT) for name in bounce_law.LAW_SKILLS})


def check_kind(skill: str, kind: str | None) -> str:
    """The model kind for ``skill``: ``kind`` if valid, else the skill's default; a clear error otherwise."""
    if kind is None:
        return DEFAULT_KIND[skill]
    kind = str(kind).lower()
    if kind not in KINDS:
        raise ValueError(f"model kind must be one of {KINDS}, got {kind!r}")
    if kind == "pinn" and skill not in PINN_SKILLS:
        raise ValueError(f"skill {skill!r} has no physics-informed model: collisions have no governing equation in "
                         f"the paper's Table 2, so hit and bounce are data-only (use kind='nn')")
    return kind


class MLP(nn.Module):
    """Fully connected tanh network: ``n_in -> [width] * hidden -> n_out`` (linear output), Xavier-normal init."""

    def __init__(self, n_in: int, n_out: int, hidden: int = HIDDEN_LAYERS, width: int = WIDTH):
        super().__init__()
        layers: list[nn.Module] = []
        d = n_in
        for _ in range(hidden):
            layers += [nn.Linear(d, width), nn.Tanh()]
            d = width
        layers.append(nn.Linear(d, n_out))
        self.layers = nn.Sequential(*layers)
        for mod in self.layers:
            if isinstance(mod, nn.Linear):
                nn.init.xavier_normal_(mod.weight)
                nn.init.zeros_(mod.bias)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.layers(x)


class SkillModel(nn.Module):
    """A learnt skill: physical inputs (N, n_in) -> physical outputs (N, n_out).

    Attributes:
        skill: ``swing``, ``slide``, ``throw``, ``hit`` or ``bounce``.
        kind: ``pinn`` (data + physics loss) or ``nn`` (data loss only).
        inputs, outputs: names in order (see :data:`phyplan_agents.skills.contract.SKILLS`).
        meta: a dict with the training record (data size, seed, validation errors, ...), filled by training/loading.

    Use :meth:`predict` to evaluate (batched, float32, no autograd graph); :meth:`forward` is the differentiable map
    used in training.
    """

    def __init__(self, skill: str, kind: str, in_center: Sequence[float], in_scale: Sequence[float],
                 out_mean: Sequence[float], out_scale: Sequence[float], hidden: int = HIDDEN_LAYERS,
                 width: int = WIDTH, params: Mapping[str, float] | None = None):
        super().__init__()
        if skill not in SKILLS:
            raise ValueError(f"unknown skill {skill!r}; skills: {', '.join(SKILLS)}")
        self.skill = skill
        self.kind = check_kind(skill, kind)
        spec = self.spec
        n_in, n_out = len(spec.inputs), len(spec.outputs)
        for name, v, n in (("in_center", in_center, n_in), ("in_scale", in_scale, n_in),
                           ("out_mean", out_mean, n_out), ("out_scale", out_scale, n_out)):
            arr = np.asarray(v, dtype=np.float64)
            if arr.shape != (n,) or not np.all(np.isfinite(arr)):
                raise ValueError(f"{name} must be {n} finite numbers, got {v!r}")
            if "scale" in name and np.any(arr <= 0):
                raise ValueError(f"{name} must be positive, got {v!r}")
            self.register_buffer(name, torch.tensor(arr, dtype=torch.float32))
        self.net = MLP(n_in, n_out, hidden, width)
        self.hidden, self.width = int(hidden), int(width)
        self.phys = nn.ParameterDict({k: nn.Parameter(torch.tensor(float(v), dtype=torch.float32))
                                      for k, v in (params or {}).items()})
        self.meta: dict[str, Any] = {}

    # --- description -------------------------------------------------------------------------------------------------
    @property
    def spec(self) -> SkillSpec:
        return SKILLS[self.skill]

    @property
    def inputs(self) -> tuple[str, ...]:
        return self.spec.inputs

    @property
    def outputs(self) -> tuple[str, ...]:
        return self.spec.outputs

    @property
    def name(self) -> str:
        return f"{self.skill}-{self.kind}"

    @property
    def params(self) -> dict[str, float]:
        """The learnt physical parameters, e.g. ``{"mu": 0.1999}`` for the slide PINN (empty otherwise)."""
        return {k: float(p.detach()) for k, p in self.phys.items()}

    def __repr__(self) -> str:
        extra = "".join(f", {k}={v:.5g}" for k, v in self.params.items())
        return (f"SkillModel({self.skill!r}, kind={self.kind!r}, inputs={self.inputs}, outputs={self.outputs}"
                f"{extra})")

    # --- evaluation ---------------------------------------------------------------------------------------------------
    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """Differentiable physical map (x in physical units, float32)."""
        return self.out_mean + self.out_scale * self.net((x - self.in_center) / self.in_scale)

    def predict(self, x) -> torch.Tensor:
        """Outputs (N, n_out) in physical units for inputs ``x`` (N, n_in) in physical units.

        ``x`` may be a torch tensor or anything ``torch.as_tensor`` accepts; it is evaluated in float32 without
        building an autograd graph. A single row of shape (n_in,) is accepted and returns shape (1, n_out).
        Inputs outside the training ranges (``meta["input_ranges"]``) are extrapolated, not rejected.
        """
        x = torch.as_tensor(x, dtype=torch.float32)
        n_in = len(self.inputs)
        if x.ndim == 1 and x.shape[0] == n_in:
            x = x[None, :]
        if x.ndim != 2 or x.shape[1] != n_in:
            raise ValueError(f"{self.name}.predict expects shape (N, {n_in}) for inputs {self.inputs}, "
                             f"got {tuple(x.shape)}")
        if not torch.isfinite(x).all():
            raise ValueError(f"{self.name}.predict got non-finite inputs")
        with torch.no_grad():
            return self.forward(x)

    def in_range(self, x) -> torch.Tensor:
        """Boolean mask (N,): rows of ``x`` inside the training ranges of every input."""
        x = torch.as_tensor(x, dtype=torch.float32)
        lo = self.in_center - self.in_scale
        hi = self.in_center + self.in_scale
        tol = 1e-6 * self.in_scale
        return ((x >= lo - tol) & (x <= hi + tol)).all(dim=1)
