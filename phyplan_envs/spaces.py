"""What goes in and out of a phyplan env: its action and observation spaces, and the checks on everything passed in.

:class:`ActionDim` is how a task declares an action dimension (named bounds in physical units);
:func:`action_space` and :func:`observation_space` make the Gymnasium spaces; the ``check_*`` functions turn bad
constructor arguments, reset options, contexts and actions into a ``ValueError`` that names the argument.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np
from gymnasium import spaces

OBS_MODES = ("state", "image", "state_image", "rgbd")
RENDER_MODES = (None, "rgb_array", "rgb_array_list")
STATE_BOUND = 10.0   # m: bound of every state entry (positions and heights)
ACTION_TOL = 1e-6    # float32 rounding of the Box bounds: values within this of a bound are inside


@dataclass(frozen=True)
class ActionDim:
    """One named action dimension in physical units."""

    name: str
    low: float
    high: float
    unit: str
    doc: str


# ================================================================================================== the spaces
def action_space(dims: Sequence[ActionDim]) -> spaces.Box:
    """The float32 Box of the action dimensions ``dims``, in their order."""
    low = np.array([d.low for d in dims], dtype=np.float32)
    high = np.array([d.high for d in dims], dtype=np.float32)
    return spaces.Box(low=low, high=high, dtype=np.float32)


def observation_space(obs_mode: str, n_state: int, image_size: int) -> spaces.Space:
    """The observation space of ``obs_mode``: a float32 state vector of ``n_state`` entries (every entry is a
    position or height in metres inside the 12 x 12 m arena), a uint8 square image, a Dict of both, or (``"rgbd"``)
    a Dict of the image (``"rgb"``) and its float32 depth picture (``"depth"``, metres)."""
    state_space = spaces.Box(-STATE_BOUND, STATE_BOUND, shape=(n_state,), dtype=np.float32)
    image_space = spaces.Box(0, 255, shape=(image_size, image_size, 3), dtype=np.uint8)
    if obs_mode == "state":
        return state_space
    if obs_mode == "image":
        return image_space
    if obs_mode == "rgbd":   # z-depth in metres (phyplan_envs.camera)
        depth_space = spaces.Box(0.0, np.inf, shape=(image_size, image_size), dtype=np.float32)
        return spaces.Dict({"rgb": image_space, "depth": depth_space})
    return spaces.Dict({"state": state_space, "image": image_space})


# ============================================================================================ constructor checks
def check_env_args(obs_mode: Any, render_mode: Any, image_size: Any) -> int:
    """Raise on a bad ``obs_mode``, ``render_mode`` or ``image_size``; returns ``image_size`` as an int."""
    if obs_mode not in OBS_MODES:
        raise ValueError(f"obs_mode must be one of {OBS_MODES}, got {obs_mode!r}")
    if render_mode not in RENDER_MODES:
        raise ValueError(f"render_mode must be one of {RENDER_MODES}, got {render_mode!r}")
    if not (isinstance(image_size, (int, np.integer)) and 16 <= int(image_size) <= 1024):
        raise ValueError(f"image_size must be an integer in [16, 1024], got {image_size!r}")
    return int(image_size)


# ============================================================================================ contexts and options
def copy_context(context: Mapping[str, Any]) -> dict[str, Any]:
    """A copy of a context in which sequences become fresh float64 arrays (no memory shared with ``context``)."""
    return {k: (np.array(v, dtype=np.float64) if isinstance(v, (list, tuple, np.ndarray)) else v)
            for k, v in context.items()}


def check_goal(goal: Any, what: str) -> np.ndarray:
    """``goal`` as a new float64 (x, y) array; ``what`` names the argument in the error."""
    g = np.array(goal, dtype=np.float64)
    if g.shape != (2,) or not np.all(np.isfinite(g)):
        raise ValueError(f"{what} must be two finite numbers (x, y), got {goal!r}")
    return g


def check_context(context: Any) -> dict[str, Any]:
    """A validated copy of a context passed back as ``reset(options={"context": ...})``."""
    if not isinstance(context, Mapping) or "goal" not in context:
        raise ValueError("options['context'] must be a dict with at least a 'goal' entry "
                         "(as returned by env.context or info['context'])")
    out = copy_context(context)
    out["goal"] = check_goal(out["goal"], "context['goal']")
    return out


def check_reset_options(options: Mapping[str, Any] | None, known: Sequence[str]) -> dict[str, Any]:
    """``options`` as a dict; raises on a name not in ``known``."""
    options = dict(options or {})
    unknown = set(options) - set(known)
    if unknown:
        raise ValueError(f"unknown reset options {sorted(unknown)}; known: {', '.join(known)}")
    return options


# ======================================================================================================= actions
def check_action(action: Any, dims: Sequence[ActionDim], low: np.ndarray, high: np.ndarray, clip: bool,
                 who: str) -> tuple[np.ndarray, bool]:
    """``action`` as a float64 vector inside the bounds ``low``/``high`` (float64) of ``dims``, and whether it was
    clipped. Shape ``(1, n)`` is accepted. Wrong shapes, non-numeric and non-finite values always raise; values out
    of bounds (by more than :data:`ACTION_TOL`) raise unless ``clip``. ``who`` (the task name) starts each message."""
    names = tuple(d.name for d in dims)
    try:
        a = np.asarray(action, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{who}: action must be numeric, got {action!r}") from None
    n = len(dims)
    if a.shape == (1, n):
        a = a[0]
    if a.shape != (n,):
        raise ValueError(f"{who}: action must have shape ({n},) for {names}, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        bad = [names[i] for i in np.flatnonzero(~np.isfinite(a))]
        raise ValueError(f"{who}: action has non-finite values in {bad}: {a.tolist()}")
    out = (a < low - ACTION_TOL) | (a > high + ACTION_TOL)
    clipped = False
    if np.any(out):
        if not clip:
            parts = [f"{dims[i].name}={a[i]:.6g} not in [{dims[i].low:.6g}, {dims[i].high:.6g}] {dims[i].unit}"
                     for i in np.flatnonzero(out)]
            raise ValueError(f"{who}: action out of bounds: " + "; ".join(parts) +
                             " (make the env with clip_actions=True to clip instead)")
        clipped = True
    return np.clip(a, low, high), clipped
