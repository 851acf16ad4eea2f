"""The Paddles tools: the shelf the ball is pushed off and the tilted paddles it falls through."""
from __future__ import annotations

import math

import numpy as np

from .. import assets
from ..contact import restitution_of_solref, solref_for_restitution
from ..description import Face, Support
from ..spaces import ActionDim
from .tool import Tool

SHELF_THICK = 0.04       # m: the floating shelf board
SHELF_BACK = 0.3         # m: the shelf's depth behind its front edge (the pendulum's bob swings over it)
SHELF_HALF_Y = 0.1       # m


class Shelf(Tool):
    """A frictionless floating shelf whose top is at height ``top`` and whose front edge is at ``edge_x`` (the ball
    rests at the edge; the shelf reaches ``SHELF_BACK`` behind it, under the pendulum). It is held by a visual
    bracket only: nothing below it collides, so a ball falling under it meets only the paddles."""

    def __init__(self, top: float, edge_x: float, name: str = "shelf"):
        self.top, self.edge_x, self.name = float(top), float(edge_x), name

    @property
    def centre(self) -> np.ndarray:
        return np.array([self.edge_x - SHELF_BACK / 2, 0.0])

    def build(self, root) -> None:
        c = self.centre
        root.worldbody.add("geom", name=self.name, type="box", pos=(c[0], c[1], self.top - SHELF_THICK / 2),
                           size=(SHELF_BACK / 2, SHELF_HALF_Y, SHELF_THICK / 2), rgba=assets.WOOD_RGBA,
                           priority=1, condim=1, friction=(0, 0, 0), **assets.WORLD)
        # the bracket on the wall behind: visual only
        root.worldbody.add("geom", name=f"{self.name}_bracket", type="box",
                           pos=(self.edge_x - SHELF_BACK - 0.01, 0.0, self.top / 2),
                           size=(0.01, SHELF_HALF_Y, self.top / 2), rgba=(0.5, 0.5, 0.55, 1), **assets.GHOST)

    def describe(self, values):
        return Support(self.name, "rect", self.centre, self.top, 0.0,
                       half=np.array([SHELF_BACK / 2, SHELF_HALF_Y]))


def paddle_dim(index: int, span: tuple[float, float]) -> ActionDim:
    """The action dimension of paddle ``index``'s horizontal position."""
    return ActionDim(f"paddle{index}_x", float(span[0]), float(span[1]), "m",
                     f"x of paddle {index}'s centre (its height and tilt are fixed)")


class Paddle(Tool):
    """A square paddle board (:func:`phyplan_envs.assets.add_paddle`; half edge ``half``, default 0.25 m: 0.5 m
    square), its top face's centre at height ``z``, tilted by ``tilt`` rad (default ``assets.PADDLE_TILT``, 45
    degrees) about the y axis so that its face falls towards ``+x`` (``falls=+1``) or ``-x`` (``falls=-1``);
    frictionless, with the overdamped contact ``assets.PADDLE_SOLREF`` (restitution 0), or a soft contact of
    restitution ``restitution`` > 0 (``solref_for_restitution``). Its x is the action dimension ``paddle<index>_x`` in
    ``span``, or fixed at ``x`` (``span=None``). Between attempts it rests at ``rest_x``. Robot mode: the scene places
    it (a tool the arm need not carry)."""

    def __init__(self, index: int, z: float, falls: int, x: float | None = None,
                 span: tuple[float, float] | None = None, rest_x: float | None = None,
                 restitution: float = assets.PADDLE_RESTITUTION, half: float = assets.PADDLE_HALF,
                 tilt: float = assets.PADDLE_TILT):
        if (x is None) == (span is None):
            raise ValueError("a paddle has either a fixed x or an action span")
        if not 0 < half < math.inf:
            raise ValueError(f"half must be a positive half edge (m), got {half}")
        if not 0 < tilt < math.pi / 2:
            raise ValueError(f"tilt must be in (0, pi/2) rad, got {tilt}")
        self.half, self.tilt_from_horizontal = float(half), float(tilt)
        self.index, self.z, self.falls = int(index), float(z), 1 if falls > 0 else -1
        self.x, self.span = x, span
        self.rest_x = float(x if x is not None else rest_x if rest_x is not None else np.mean(span))
        self.name = f"paddle{index}"
        if restitution == 0:
            self.solref, self.restitution = assets.PADDLE_SOLREF, 0.0
        else:
            self.solref = solref_for_restitution(restitution, assets.PADDLE_STIFFNESS)
            self.restitution = restitution_of_solref(self.solref)
        self.dims = () if span is None else (paddle_dim(index, span),)

    @property
    def tilt(self) -> float:
        """The paddle's rotation about +y (rad): its face's normal is ``(sin tilt, 0, cos tilt)``."""
        return self.falls * self.tilt_from_horizontal

    def build(self, root) -> None:
        assets.add_paddle(root, self.name, self.solref, self.half)

    def bind(self, scene) -> None:
        super().bind(scene)
        self.body = scene.body_id(self.name)

    def place(self, x: float) -> None:
        """Put the paddle's face centre at ``x`` (its height and tilt are fixed)."""
        m = self.scene.model
        m.body_pos[self.body] = (x, 0.0, self.z)
        m.body_quat[self.body] = (math.cos(self.tilt / 2), 0.0, math.sin(self.tilt / 2), 0.0)

    def reset(self) -> None:
        self.place(self.rest_x)

    def apply(self, values) -> None:
        self.place(self.x if self.span is None else float(values[0]))

    def robot_steps(self, values) -> list:
        self.apply(values)
        return []

    def describe(self, values):
        n = len(values)
        return self.describe_at(np.full(n, self.x, dtype=np.float64) if self.span is None else values[:, 0])

    def describe_at(self, x) -> Face:
        """The paddle's face with its centre at each of the x ``x`` (N,)."""
        x = np.asarray(x, dtype=np.float64)
        c = np.column_stack([x, np.zeros(len(x)), np.full(len(x), self.z)])
        s, co = math.sin(self.tilt), math.cos(self.tilt)
        h = self.half
        down, across = np.array([co, 0.0, -s]), np.array([0.0, 1.0, 0.0])   # the board's own x and y in the world
        corners = [(-h, -h), (h, -h), (h, h), (-h, h)]
        v = np.stack([c + a * down + b * across for a, b in corners], axis=1)
        normal = np.tile([s, 0.0, co], (len(c), 1))
        return Face(f"{self.name}_face", self.name, v, normal, self.restitution)


def offset_dim(index: int, span: tuple[float, float]) -> ActionDim:
    """The action dimension of paddle ``index``'s offset from the paddle above."""
    return ActionDim(f"paddle{index}_offset", float(span[0]), float(span[1]), "m",
                     f"x of paddle {index}'s centre less paddle {index - 1}'s, along the way the ball leaves "
                     f"paddle {index - 1}")


def chained_x(first_x: float, falls, offsets) -> np.ndarray:
    """The x (K, N) of N paddles placed each relative to the one above: the first at ``first_x``, paddle i at paddle
    i-1's x plus ``falls[i - 1] * offsets[:, i - 1]`` (``falls``: +1 or -1 per paddle, the way its face falls;
    ``offsets`` (K, N - 1))."""
    v = np.atleast_2d(np.asarray(offsets, dtype=np.float64))
    f = np.asarray(falls, dtype=np.float64)[:v.shape[1]]
    return first_x + np.column_stack([np.zeros(len(v)), np.cumsum(v * f, axis=1)])


class PaddleChain(Tool):
    """Paddles placed each relative to the one above. Paddle 0 stays at its fixed x; paddle i (i >= 1) goes to
    ``x[i - 1] + falls[i - 1] * offset[i]``: its offset from the paddle above, along the way the ball leaves that
    paddle (the way its face falls), is the action dimension ``paddle<i>_offset`` in ``span``. Moving one offset
    moves that paddle and every paddle below it. ``paddles``: :class:`Paddle` tools with a fixed x, from the top
    (paddle 0's x is its place; the others' is where they rest between attempts)."""

    def __init__(self, paddles, span: tuple[float, float]):
        self.paddles = list(paddles)
        if any(p.span is not None for p in self.paddles):
            raise ValueError("a PaddleChain places paddles built with a fixed x (their rest), not an action span")
        self.span = (float(span[0]), float(span[1]))
        self.falls = np.array([p.falls for p in self.paddles[:-1]], dtype=np.float64)
        self.dims = tuple(offset_dim(p.index, self.span) for p in self.paddles[1:])

    def x(self, values) -> np.ndarray:
        """The paddles' x (K, N) for the offsets ``values`` (K, N - 1, or one row (N - 1,))."""
        return chained_x(self.paddles[0].x, self.falls, values)

    def build(self, root) -> None:
        for p in self.paddles:
            p.build(root)

    def bind(self, scene) -> None:
        super().bind(scene)
        for p in self.paddles:
            p.bind(scene)

    def reset(self) -> None:
        for p in self.paddles:
            p.reset()

    def apply(self, values) -> None:
        for p, x in zip(self.paddles, self.x(values)[0]):
            p.place(float(x))

    def robot_steps(self, values) -> list:
        self.apply(values)
        return []

    def describe(self, values):
        xs = self.x(values)
        return [p.describe_at(xs[:, i]) for i, p in enumerate(self.paddles)]
