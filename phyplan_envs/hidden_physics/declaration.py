"""The declaration of the hidden physics: each base task's hidden parameters (:data:`PARAMETERS`: names, nominal
values, train and test spaces), the spaces and physics keys, the sealed context token, and the task names of the
hidden-physics track (:func:`base_task`: ``"slide-varied"`` -> ``"slide"``, the one place the suffix is read).
Agents read it from here (the chains' physics columns, the identification's search box and prior)."""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from ..spaces import seal, unseal
from ..splits import split_of

SPACES = ("train", "test")
KEY_BOUND = 2 ** 63            # physics keys are integers in [0, KEY_BOUND)
VARIED_SUFFIX = "-varied"      # a hidden-physics task's name: its base task's with this suffix


@dataclass(frozen=True)
class HiddenParameter:
    """One hidden physical parameter: its nominal value, train space and (two-part) test space.

    Attributes:
        name, unit, doc: what it is.
        nominal: the value an agent that ignores the hidden physics should assume (inside ``train``).
        train: (low, high) of the training space.
        test: ((low, high), (low, high)): the test space, below and above ``train`` (disjoint from it).
        log: sample log-uniformly (masses) instead of uniformly.
    """

    name: str
    unit: str
    doc: str
    nominal: float
    train: tuple[float, float]
    test: tuple[tuple[float, float], tuple[float, float]]
    log: bool = False

    def intervals(self, space: str) -> tuple[tuple[float, float], ...]:
        check_space(space)
        return (self.train,) if space == "train" else self.test

    def hull(self) -> tuple[float, float]:
        return (self.test[0][0], self.test[1][1])

    def sample(self, rng: np.random.Generator, space: str) -> float:
        """A value from ``space``: uniform (or log-uniform) over the union of its intervals."""
        f = np.log if self.log else (lambda x: x)
        parts = [(float(f(lo)), float(f(hi))) for lo, hi in self.intervals(space)]
        lengths = np.array([hi - lo for lo, hi in parts])
        u = rng.random() * lengths.sum()
        for (lo, hi), n in zip(parts, lengths):
            if u <= n:
                x = lo + u
                return float(math.exp(x) if self.log else x)
            u -= n
        lo, hi = parts[-1]
        return float(math.exp(hi) if self.log else hi)

    def in_space(self, value: float, space: str) -> bool:
        return any(lo <= value <= hi for lo, hi in self.intervals(space))


BOB_MASS = HiddenParameter("bob_mass", "kg", "mass of the pendulum bob", 0.5, (0.3, 1.0),
                           ((0.1, 0.3), (1.0, 6.0)), log=True)
# Launch's test masses reach down to the original code's 0.05 kg: with the ball (0.1 kg) the mass effect saturates
# above ~1 kg, and heavy bobs with low restitution cancel (the nominal-physics planner's regret stayed < 0.10).
LAUNCH_BOB_MASS = dataclasses.replace(BOB_MASS, test=((0.05, 0.3), (1.0, 3.0)))
BOB_RESTITUTION = HiddenParameter("restitution", "", "restitution of the bob-object contact", 0.5, (0.35, 0.65),
                                  ((0.05, 0.35), (0.65, 0.95)))
FRICTION = HiddenParameter("friction", "", "sliding friction of the puck on the table and the plank", 0.35,
                           (0.25, 0.45), ((0.15, 0.25), (0.45, 0.6)))
INCLINE_RESTITUTION = HiddenParameter("restitution", "", "restitution of the ball-incline contact", 0.8, (0.7, 0.9),
                                      ((0.4, 0.7), (0.9, 0.99)))

# LaunchBounce: the ball-wedge contact's restitution under its own name (the bob-ball one is "restitution").
WEDGE_RESTITUTION = dataclasses.replace(INCLINE_RESTITUTION, name="wedge_restitution",
                                        doc="restitution of the ball-wedge contact")

# Paddles: the ball-paddle restitution, around the original's 0.1 (low: the ball glides down each paddle; high: it
# hops off it).
PADDLE_RESTITUTION = HiddenParameter("paddle_restitution", "", "restitution of the ball-paddle contacts", 0.1,
                                     (0.05, 0.25), ((0.02, 0.05), (0.25, 0.4)))

PARAMETERS: dict[str, tuple[HiddenParameter, ...]] = {
    "launch": (LAUNCH_BOB_MASS, BOB_RESTITUTION),
    "slide": (BOB_MASS, BOB_RESTITUTION, FRICTION),
    "bounce": (INCLINE_RESTITUTION,),
    "bridge": (BOB_MASS, BOB_RESTITUTION, FRICTION),
    "launch-bounce": (BOB_MASS, BOB_RESTITUTION, WEDGE_RESTITUTION),
    "paddles": (PADDLE_RESTITUTION,),
}
"""Base task name -> its hidden parameters (in the order they are drawn)."""


# ============================================================================================= the task names
def base_task(task: str) -> str:
    """The base task of a task name: ``"slide-varied"`` -> ``"slide"``; a name without the suffix is its own."""
    return task[:-len(VARIED_SUFFIX)] if task.endswith(VARIED_SUFFIX) else task


def varied_name(task: str) -> str:
    """The hidden-physics task name of a base task: ``"slide"`` -> ``"slide-varied"``."""
    return base_task(task) + VARIED_SUFFIX


def varied_tasks() -> tuple[str, ...]:
    """The hidden-physics task names, in the declaration's order (``"launch-varied"``, ...)."""
    return tuple(varied_name(t) for t in PARAMETERS)


def is_varied(task: str) -> bool:
    """Whether ``task`` names a hidden-physics task (``"<base>-varied"`` with hidden parameters declared)."""
    return task.endswith(VARIED_SUFFIX) and base_task(task) in PARAMETERS


def parameters(task: str) -> tuple[HiddenParameter, ...]:
    """The hidden parameters of a base task name (``"launch"``, ...; a ``"-varied"`` suffix is accepted)."""
    base = base_task(task)
    if base not in PARAMETERS:
        raise ValueError(f"no hidden physics for task {task!r}; tasks: {', '.join(PARAMETERS)}")
    return PARAMETERS[base]


def parameter_names(task: str) -> tuple[str, ...]:
    """The names of a task's hidden parameters, in their declared order (the order they are drawn, and the columns a
    parameter-conditioned model takes after the action)."""
    return tuple(p.name for p in parameters(task))


# ================================================================================================ spaces and keys
def check_space(space: str) -> str:
    if space not in SPACES:
        raise ValueError(f"physics space must be one of {SPACES}, got {space!r}")
    return space


def nominal(task: str) -> dict[str, float]:
    """The nominal values of a task's hidden parameters (what an agent ignoring them should assume)."""
    return {p.name: p.nominal for p in parameters(task)}


def space_of_seed(seed: int) -> str:
    """The physics space that a context seed draws from: ``"test"`` for the test split, else ``"train"``."""
    return "test" if split_of(int(seed)) == "test" else "train"


def draw(task: str, space: str, rng: np.random.Generator) -> dict[str, float]:
    """One context's hidden values for ``task`` drawn from ``space`` with ``rng`` (each parameter independently)."""
    check_space(space)
    return {p.name: p.sample(rng, space) for p in parameters(task)}


def values_of_key(task: str, key: int, space: str) -> dict[str, float]:
    """The hidden values that ``physics_key`` ``key`` stands for in ``space`` (deterministic)."""
    check_key(key)
    return draw(task, space, np.random.default_rng(np.random.SeedSequence(int(key))))


def check_key(key: Any) -> int:
    if isinstance(key, bool) or not isinstance(key, (int, np.integer)) or not 0 <= int(key) < KEY_BOUND:
        raise ValueError(f"a physics key must be an integer in [0, 2**63), got {key!r}")
    return int(key)


TOKEN_ENTRY = "options['context']['physics_token']"


def _label(task: str) -> str:
    """The base task name a token is sealed for (``SlideVaried-v0`` and ``-v1`` share their contexts)."""
    parameters(task)
    return "physics:" + base_task(task)


def seal_token(task: str, key: int, space: str, secret: bytes) -> str:
    """A context's ``physics_token``: ``(key, space)`` sealed under ``secret`` for ``task`` (deterministic)."""
    return seal(check_key(key).to_bytes(8, "big") + bytes([SPACES.index(check_space(space))]), _label(task), secret)


def open_token(task: str, token: Any, secret: bytes) -> tuple[int, str]:
    """``(key, space)`` of a :func:`seal_token` token; raises naming ``options['context']['physics_token']`` for a
    token that is not one or that another secret or task sealed."""
    payload = unseal(token, _label(task), secret, 9, TOKEN_ENTRY)   # authenticated: only seal_token made it
    return int.from_bytes(payload[:8], "big"), SPACES[payload[8]]


def check_values(task: str, values: Mapping[str, Any]) -> dict[str, float]:
    """``values`` validated: exactly the task's parameter names, finite, inside the hull of the two spaces."""
    if not isinstance(values, Mapping):
        raise ValueError(f"options['physics'] must be a dict of {[p.name for p in parameters(task)]}, "
                         f"got {values!r}")
    names = [p.name for p in parameters(task)]
    if sorted(values) != sorted(names):
        raise ValueError(f"options['physics'] must have exactly the keys {names}, got {sorted(values)}")
    out = {}
    for p in parameters(task):
        v = values[p.name]
        lo, hi = p.hull()
        if isinstance(v, bool) or not isinstance(v, (int, float, np.floating, np.integer)) or not lo <= v <= hi:
            raise ValueError(f"options['physics'][{p.name!r}] must be a number in [{lo}, {hi}], got {v!r}")
        out[p.name] = float(v)
    return out
