"""What goes in and out of a phyplan env: its action and observation spaces, and the checks on everything passed in.

:class:`ActionDim` is how a task declares an action dimension (named bounds in physical units);
:func:`action_space` and :func:`observation_space` make the Gymnasium spaces; the ``check_*`` functions turn bad
constructor arguments, reset options, contexts and actions into a ``ValueError`` that names the argument.
:func:`seal` and :func:`unseal` make and check a context's sealed entries (the varied tasks' ``physics_token``)
under a secret that no public function returns (:data:`SECRET_ENV`).
"""
from __future__ import annotations

import hashlib
import hmac
import os
import secrets
from dataclasses import dataclass
from typing import Any, Callable, Mapping, Sequence

import numpy as np
from gymnasium import spaces

OBS_MODES = ("state", "image", "state_image", "rgbd")
RENDER_MODES = (None, "rgb_array", "rgb_array_list")
STATE_BOUND = 10.0   # m: bound of every state entry (positions and heights)
ACTION_TOL = 1e-6    # float32 rounding of the Box bounds: values within this of a bound are inside
GOAL_BOUND = 6.0     # m: default goal region |x|, |y| <= this: the 12 x 12 m floor of assets.arena (< STATE_BOUND)
MIN_GOAL_DISTANCE = 0.1  # m: default least xy distance of a goal from the object's start (the goal box's width)


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
def short_repr(value: Any, limit: int = 120) -> str:
    """``repr(value)`` cut to ``limit`` characters (error messages quote what was passed, not megabytes of it)."""
    r = repr(value)
    return r if len(r) <= limit else r[:limit - 5] + " ...>"


def check_flag(value: Any, name: str) -> bool:
    """``value`` as a bool; anything but ``True``/``False`` (or a NumPy bool) raises ``TypeError`` naming ``name``
    (``bool("no")`` is true, so a string must not be read as a flag)."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be True or False, got {type(value).__name__} {short_repr(value)}")
    return bool(value)


def check_choice(value: Any, name: str, choices: Sequence[Any]) -> Any:
    """``value`` if it is one of ``choices`` (strings, maybe ``None``): ``TypeError`` for a non-string, else
    ``ValueError``, both naming ``name`` and the choices."""
    if value is not None and not isinstance(value, str):
        raise TypeError(f"{name} must be one of {tuple(choices)}, got {type(value).__name__} {short_repr(value)}")
    if value not in choices:
        raise ValueError(f"{name} must be one of {tuple(choices)}, got {value!r}")
    return value


def check_int(value: Any, name: str, low: int, high: int) -> int:
    """``value`` as an int in [low, high]: ``TypeError`` for a non-integer (bools and floats included), else
    ``ValueError``, both naming ``name``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an integer in [{low}, {high}], got {type(value).__name__} "
                        f"{short_repr(value)}")
    if not low <= int(value) <= high:
        raise ValueError(f"{name} must be an integer in [{low}, {high}], got {value!r}")
    return int(value)


def check_env_args(obs_mode: Any, render_mode: Any, image_size: Any, **flags: Any) -> int:
    """Raise on a bad ``obs_mode``, ``render_mode``, ``image_size`` or boolean flag (``clip_actions=...``, each
    keyword must be a bool); returns ``image_size`` as an int. ``TypeError`` for a wrong type, ``ValueError`` for a
    bad value; the message names the argument."""
    check_choice(obs_mode, "obs_mode", OBS_MODES)
    check_choice(render_mode, "render_mode", RENDER_MODES)
    for name, value in flags.items():
        check_flag(value, name)
    return check_int(image_size, "image_size", 16, 1024)


def check_seed(seed: Any) -> int | None:
    """A ``reset`` seed: ``None`` or a non-negative integer (NumPy integers too), as a Python int."""
    if seed is None:
        return None
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)):
        raise TypeError(f"seed must be a non-negative integer or None, got {type(seed).__name__} {short_repr(seed)}")
    if seed < 0:
        raise ValueError(f"seed must be a non-negative integer or None, got {seed}")
    return int(seed)


# ============================================================================================ contexts and options
def copy_context(context: Mapping[str, Any]) -> dict[str, Any]:
    """A copy of a context in which sequences become fresh float64 arrays (no memory shared with ``context``)."""
    return {k: (np.array(v, dtype=np.float64) if isinstance(v, (list, tuple, np.ndarray)) else v)
            for k, v in context.items()}


_NOT_REAL = (str, bytes, bool, np.bool_, complex, np.complexfloating, type(None))


def as_real(value: Any) -> np.ndarray | None:
    """``value`` as a float64 array (no copy if it is one) if it holds only real numbers, else ``None``.

    Ints and floats of any NumPy width count; so do objects that convert with ``float()`` (e.g. 0-d tensors).
    Strings, bools, complex numbers and None do not: ``np.asarray(v, dtype=float)`` would parse ``"0.5"``, read
    ``True`` as 1, None as NaN and drop an imaginary part without a word.
    """
    try:
        a = np.asarray(value)
    except (TypeError, ValueError):       # ragged nesting and the like
        return None
    if a.dtype.kind in "iuf":
        return a.astype(np.float64, copy=False)
    if a.dtype.kind != "O" or any(isinstance(x, _NOT_REAL) for x in a.flat):
        return None
    try:
        return a.astype(np.float64)
    except (TypeError, ValueError):
        return None


def real_array(value: Any, what: str) -> np.ndarray:
    """``value`` as a new float64 array of real numbers (:func:`as_real`), else ``TypeError`` naming ``what``."""
    a = as_real(value)
    if a is None:
        raise TypeError(f"{what} must be real numbers, got {short_repr(value)}")
    return a.copy() if a is value else a


def check_goal(goal: Any, what: str) -> np.ndarray:
    """``goal`` as a new float64 (x, y) array of finite numbers; ``what`` names the argument in the error.
    (Whether the goal lies in the task's goal region is the env's check: :meth:`PhyPlanEnv.check_goal_region`.)"""
    if isinstance(goal, (str, bytes, Mapping)):
        raise TypeError(f"{what} must be two finite numbers (x, y), got {type(goal).__name__} {short_repr(goal)}")
    g = real_array(goal, what)
    if g.shape != (2,) or not np.all(np.isfinite(g)):
        raise ValueError(f"{what} must be two finite numbers (x, y), got {short_repr(goal)}")
    return g


def check_context(context: Any, known: Sequence[str] = ("goal",),
                  check_entry: Callable[[str, Any], Any] | None = None) -> dict[str, Any]:
    """A validated copy of a context passed back as ``reset(options={"context": ...})``.

    ``known`` are the entries a context of the task may hold (``"goal"`` is required); each entry but the goal
    goes through ``check_entry(name, value)``, which returns the value to keep or raises (without it, only the goal
    is allowed). Sequences are copied to float64 arrays as by :func:`copy_context`.
    """
    if not isinstance(context, Mapping):
        raise TypeError("options['context'] must be a dict with at least a 'goal' entry (as returned by "
                        f"env.context or info['context']), got {type(context).__name__} {short_repr(context)}")
    if "goal" not in context:
        raise ValueError("options['context'] must be a dict with at least a 'goal' entry (as returned by "
                         f"env.context or info['context']), got the keys {sorted(map(str, context))}")
    unknown = [k for k in context if k not in known]
    if unknown:
        raise ValueError(f"options['context'] has unknown entries {sorted(map(str, unknown))}; a context of this "
                         f"task holds: {', '.join(known)}")
    out = {}
    for name, value in context.items():
        if name == "goal":
            out[name] = check_goal(value, "options['context']['goal']")
        elif check_entry is None:
            raise ValueError(f"options['context'][{name!r}]: no check is declared for this entry")
        else:
            out[name] = check_entry(name, value)
    return copy_context(out)


# ========================================================================================= sealed context entries
SECRET_ENV = "PHYPLAN_PHYSICS_SECRET"
"""The environment variable holding the process's secret for sealed context entries. The first import of
:mod:`phyplan_envs` sets it to a fresh random value (``secrets.token_hex(32)``) unless it is set, and reads it once;
child processes (:func:`phyplan_envs.simulate_batch`'s workers, spawned harness and vector workers) inherit it and
so replay the parent's contexts. Set it yourself (at least :data:`MIN_SECRET_CHARS` characters) to replay contexts
between unrelated processes; leave it out of the environment of a process that should not replay them."""
MIN_SECRET_CHARS = 32
TOKEN_PREFIX = "pt1-"          # format of a sealed entry: prefix, then hex of tag (TAG_BYTES) + encrypted payload
TAG_BYTES = 16
os.environ.setdefault(SECRET_ENV, secrets.token_hex(32))
_SECRET_TEXT = os.environ[SECRET_ENV]


def secret_bytes(text: Any, what: str = SECRET_ENV) -> bytes:
    """A secret given as text (at least :data:`MIN_SECRET_CHARS` characters) as the bytes :func:`seal` takes."""
    if not isinstance(text, str) or len(text) < MIN_SECRET_CHARS:
        got = f"{len(text)} characters" if isinstance(text, str) else type(text).__name__
        raise ValueError(f"{what} must be a string of at least {MIN_SECRET_CHARS} characters (e.g. "
                         f"python -c 'import secrets; print(secrets.token_hex(32))'), got {got}")
    return text.encode("utf-8")


def _process_secret() -> bytes:
    """This process's secret (env-internal: the varied envs seal and open their contexts' physics with it)."""
    return secret_bytes(_SECRET_TEXT)


def _prf(secret: bytes, *parts: bytes) -> bytes:
    return hmac.new(secret, b"".join(len(p).to_bytes(4, "big") + p for p in parts), hashlib.sha256).digest()


def seal(payload: bytes, label: str, secret: bytes) -> str:
    """``payload`` (at most 32 bytes) encrypted and authenticated under ``secret`` for ``label``, as text.

    Deterministic (the same payload, label and secret give the same token; SIV-style: the tag is an HMAC-SHA256 of
    label and payload, the payload is XORed with an HMAC of the tag), so a context that is sealed twice is equal to
    itself. Without the secret, the token tells nothing about the payload but its length.
    """
    if not isinstance(payload, bytes) or not 0 < len(payload) <= 32:
        raise ValueError(f"payload must be 1 to 32 bytes, got {short_repr(payload)}")
    tag = _prf(secret, b"tag", label.encode(), payload)[:TAG_BYTES]
    pad = _prf(secret, b"pad", label.encode(), tag)
    return TOKEN_PREFIX + (tag + bytes(a ^ b for a, b in zip(payload, pad))).hex()


def unseal(token: Any, label: str, secret: bytes, size: int, what: str) -> bytes:
    """The ``size``-byte payload of a :func:`seal` token; ``TypeError``/``ValueError`` naming ``what`` for a token
    that is not one, or that another secret or label sealed (or that was edited)."""
    if not isinstance(token, str):
        raise TypeError(f"{what} must be the sealed token string of info['context'], got {type(token).__name__} "
                        f"{short_repr(token)}")
    body = token[len(TOKEN_PREFIX):]
    try:
        raw = bytes.fromhex(body) if token.startswith(TOKEN_PREFIX) else b""
    except ValueError:
        raw = b""
    if len(raw) != TAG_BYTES + size:
        raise ValueError(f"{what} must be a sealed token {TOKEN_PREFIX!r} + {2 * (TAG_BYTES + size)} hex digits (pass "
                         f"back info['context'] unchanged), got {short_repr(token)}")
    tag = raw[:TAG_BYTES]
    pad = _prf(secret, b"pad", label.encode(), tag)
    payload = bytes(a ^ b for a, b in zip(raw[TAG_BYTES:], pad))
    if not hmac.compare_digest(tag, _prf(secret, b"tag", label.encode(), payload)[:TAG_BYTES]):
        raise ValueError(f"{what} was not sealed for {label!r} under this process's secret ({SECRET_ENV}): a "
                         f"context from a process with another secret, from another task, or edited. Replay a "
                         f"context in the process that made it or in a child that inherited {SECRET_ENV} (set the "
                         f"variable to the same value to share contexts between processes)")
    return payload


def check_reset_options(options: Any, known: Sequence[str]) -> dict[str, Any]:
    """``options`` (a dict or ``None``) as a new dict; ``TypeError`` for another type, ``ValueError`` for a name
    not in ``known``."""
    if options is None:
        return {}
    if not isinstance(options, Mapping):
        raise TypeError(f"reset options must be a dict (or None), got {type(options).__name__} "
                        f"{short_repr(options)}")
    options = dict(options)
    unknown = [k for k in options if k not in known]
    if unknown:
        raise ValueError(f"unknown reset options {sorted(map(str, unknown))}; known: {', '.join(known)}")
    return options


# ======================================================================================================= actions
def check_action(action: Any, dims: Sequence[ActionDim], low: np.ndarray, high: np.ndarray, clip: bool,
                 who: str) -> tuple[np.ndarray, bool]:
    """``action`` as a float64 vector inside the bounds ``low``/``high`` (float64) of ``dims``, and whether it was
    clipped. Shape ``(1, n)`` is accepted. Non-real values (strings, bools, complex) raise ``TypeError``; wrong
    shapes and non-finite values always raise ``ValueError``; values out of bounds (by more than
    :data:`ACTION_TOL`) raise unless ``clip``. ``who`` (the task name) starts each message."""
    names = tuple(d.name for d in dims)
    a = as_real(action)
    if a is None:                   # strings, bools and complex numbers are not silently cast
        raise TypeError(f"{who}: action must be numeric (real numbers), got {short_repr(action)}")
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


def format_xy(v) -> str:
    """An xy point as an error message shows it."""
    return f"({float(v[0]):.6g}, {float(v[1]):.6g})"


def check_goal_region(goal: np.ndarray, region, task: str, what: str) -> None:
    """Raise ``ValueError`` naming ``what`` unless the (finite) ``goal`` lies in ``region`` (x range, y range) of
    the task named ``task``."""
    (x0, x1), (y0, y1) = region
    if not (x0 <= goal[0] <= x1 and y0 <= goal[1] <= y1):
        raise ValueError(f"{what} = {format_xy(goal)} is outside the {task} goal region: "
                         f"x in [{x0}, {x1}] m, y in [{y0}, {y1}] m")
