"""A faster inference path for the skill networks (same weights, same outputs to float32 rounding).

Measured on the project's 2-core AMD EPYC machines (torch 2.13 CPU, one thread): ``torch.tanh`` costs ~8 ns per
element, 20x more than ``torch.sigmoid`` (~0.4 ns) or NumPy's ``tanh``, and it dominates the skill MLPs' cost
(8 tanh layers of 40 units per row). Since ``tanh(x) = 2 * sigmoid(2x) - 1`` exactly, :class:`FastSkill` evaluates a
:class:`phyplan_agents.skills.SkillModel`'s network with that identity, the constants folded into copies of its
weights: ~3x faster per row (``python -m benchmarks.phyplan_eval --section speed`` prints the chain's cost).

:func:`fast_twin` builds the twin only for a model of the known structure (input/output normalisation buffers and
an ``nn.Sequential`` of ``Linear``/``Tanh`` layers ending in a ``Linear``) and only if it reproduces the model's
``predict`` on a probe batch (relative difference below 1e-4); otherwise it returns the model unchanged. Any object
with a ``predict`` method (e.g. a test stand-in) is used as it is.
"""
from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import torch
from torch import nn

SKILL_NAMES = ("swing", "slide", "throw", "hit", "bounce", "slide_cond", "hit_cond", "bounce_cond", "swing_wide",
               "hit_wide", "throw_wide", "glide", "hit_free",
               "hit_free_cond", "throw_fast", "hit_free_slow")
PROBE_ROWS = 256
PROBE_TOLERANCE = 1e-4   # relative to the output scale


class FastSkill:
    """Inference-only twin of a skill model (see the module docstring). ``predict`` has the model's semantics.

    With ``s_k = sigmoid(2 z_k)`` for the pre-activations ``z_k`` of the hidden layers, ``tanh(z_k) = 2 s_k - 1``;
    the factors and offsets are folded into the weights once, so that every layer is one ``addmm`` and one in-place
    ``sigmoid``; the input normalisation is folded into the first layer and the output scaling into the last:

        s_1 = sigmoid(x A_1 + c_1),  s_k = sigmoid(s_{k-1} A_k + c_k),  y = s_L A_out + c_out
    """

    def __init__(self, model: nn.Module, linears: list[nn.Linear]):
        self.model = model
        self.spec = getattr(model, "spec", None)
        self.name = getattr(model, "name", type(model).__name__)
        with torch.no_grad():
            in_c = model.in_center.detach().double()
            in_s = model.in_scale.detach().double()
            out_m = model.out_mean.detach().double()
            out_s = model.out_scale.detach().double()
            ws = [lin.weight.detach().double() for lin in linears]     # (out, in)
            bs = [lin.bias.detach().double() for lin in linears]
            layers = []
            # first hidden layer: z = ((x - c) / s) W^T + b; s_1 = sigmoid(2 z)
            w0 = ws[0] / in_s[None, :]
            b0 = bs[0] - w0 @ in_c
            layers.append((2 * w0.t(), 2 * b0))
            for w, b in zip(ws[1:-1], bs[1:-1]):
                # z = (2 s - 1) W^T + b = s (2 W^T) + (b - W 1); s' = sigmoid(2 z)
                layers.append((4 * w.t(), 2 * (b - w.sum(dim=1))))
            w, b = ws[-1], bs[-1]
            # y = m + s_out * ((2 s - 1) W^T + b)
            a_out = 2 * w.t() * out_s[None, :]
            c_out = out_m + out_s * (b - w.sum(dim=1))
            layers.append((a_out, c_out))
        self._layers = [(a.float().contiguous(), c.float().contiguous()) for a, c in layers]

    def predict(self, x) -> torch.Tensor:
        x = torch.as_tensor(x, dtype=torch.float32)
        if x.ndim == 1:
            x = x[None, :]
        with torch.inference_mode():
            h = x
            for a, c in self._layers[:-1]:
                h = torch.mm(h, a).add_(c).sigmoid_()
            a, c = self._layers[-1]
            return torch.mm(h, a).add_(c)


def _linears(model: Any) -> list[nn.Linear] | None:
    net = getattr(getattr(model, "net", None), "layers", None)
    if not isinstance(net, nn.Sequential):
        return None
    mods = list(net)
    if not mods or not isinstance(mods[-1], nn.Linear):
        return None
    linears = []
    for i, mod in enumerate(mods):
        want_linear = i % 2 == 0
        if want_linear and not isinstance(mod, nn.Linear):
            return None
        if not want_linear and not isinstance(mod, nn.Tanh):
            return None
        if want_linear:
            linears.append(mod)
    return linears


def fast_twin(model: Any) -> Any:
    """A :class:`FastSkill` twin of ``model`` if it has the known structure and agrees on a probe; else ``model``."""
    if not all(isinstance(getattr(model, k, None), torch.Tensor)
               for k in ("in_center", "in_scale", "out_mean", "out_scale")):
        return model
    linears = _linears(model)
    if linears is None:
        return model
    twin = FastSkill(model, linears)
    gen = torch.Generator().manual_seed(0)
    in_c, in_s = model.in_center.detach(), model.in_scale.detach()
    probe = in_c + in_s * (2 * torch.rand(PROBE_ROWS, in_c.shape[0], generator=gen) - 1)
    ref = torch.as_tensor(model.predict(probe), dtype=torch.float32)
    got = twin.predict(probe)
    tol = PROBE_TOLERANCE * model.out_scale.detach().abs() + 1e-6
    if got.shape != ref.shape or not torch.all((got - ref).abs() <= tol):
        return model
    return twin


PASSED_ON = ("bounce_general", "bounce_general_cond", "bounce_general_low",
             "bounce_general_low_cond", "bounce_wall",
             "bounce_wall_cond",
             "bounce_general_fast", "bounce_general_exact_cond")   # skills whose model adds a law: kept as they are


def fast_skills(skills: Any) -> Any:
    """A namespace with :func:`fast_twin` of each skill model that ``skills`` has (missing ones stay missing), and
    the :data:`PASSED_ON` ones unchanged."""
    fast = {name: fast_twin(getattr(skills, name)) for name in SKILL_NAMES if hasattr(skills, name)}
    fast.update({name: getattr(skills, name) for name in PASSED_ON if hasattr(skills, name)})
    return SimpleNamespace(**fast)
