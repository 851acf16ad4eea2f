"""The moving objects: the ball (hit off a pedestal, or dropped onto the wedge) and the puck (a disc, or the block
that faces the swing plane: :mod:`phyplan_envs.block`)."""
from __future__ import annotations

import numpy as np

from .. import assets
from ..description import MovingObject, Release
from ..block import BLOCK_HALF, add_friction_pair, make_block, turn_body, turn_free_body
from ..spaces import ActionDim
from .tool import Tool


class Ball(Tool):
    """The ball (the task's moving object), at rest at ``start`` before an attempt."""

    def __init__(self, start, mass: float = assets.BALL_MASS, name: str = "ball"):
        self.start = np.asarray(start, dtype=np.float64)
        self.half = assets.BALL_RADIUS          # its half-size along a hit
        self.mass, self.name = mass, name
        self.geom = f"{name}_geom"

    def build(self, root) -> None:
        assets.add_ball(root, name=self.name, mass=self.mass)

    def rest(self, phi: float = 0.0) -> None:
        """At rest at its start (a ball faces every way: ``phi`` is not used)."""
        self.scene.set_object_pose(self.start)

    def describe(self, values):
        return MovingObject(self.name, "ball", self.start.copy(), assets.BALL_RADIUS, assets.BALL_RADIUS, self.mass)


class DropBall(Ball):
    """The Bounce ball: on its side table (``start``) between attempts; an attempt releases it at rest at
    ``drop_height`` straight above ``drop_xy``. Robot mode: the arm picks it off the table and lets go of it there;
    the visual Panda holds it from the side (:meth:`hand_axes`) of the arm standing at ``base_xy``."""

    dims = (ActionDim("drop_height", 0.5, 1.5, "m", "height of the ball's centre above the ground at release"),)

    def __init__(self, start, drop_xy, base_xy, mass: float = assets.BALL_MASS, name: str = "ball"):
        super().__init__(start, mass, name)
        self.drop_xy = np.asarray(drop_xy, dtype=np.float64)
        self.base_xy = np.asarray(base_xy, dtype=np.float64)
        self.robot_bodies = (name,)      # robot mode: the arm carries the ball
        self.grip_half_width = assets.BALL_RADIUS     # the Panda's fingers close on the ball

    def reset(self) -> None:
        self.scene.set_object_pose(self.start)

    def apply(self, values) -> None:
        self.scene.set_object_pose((self.drop_xy[0], self.drop_xy[1], values[0]))

    def robot_steps(self, values) -> list:
        from ..panda.robot.plans import drop_carry

        drop = (self.drop_xy[0], self.drop_xy[1], float(values[0]))
        return [drop_carry(self.scene.object_pos(), drop, tuple(self.base_xy), assets.BALL_RADIUS)]

    def describe(self, values):
        drop = np.column_stack([np.tile(self.drop_xy, (len(values), 1)), values[:, 0]])
        return [super().describe(values), Release(self.name, drop)]

    def hand_target(self, values) -> np.ndarray:
        """Before an attempt the hand holds the ball on the side table; for ``values`` its drop point."""
        if values is None:
            return self.start.copy()
        return np.array([self.drop_xy[0], self.drop_xy[1], float(values[0])])

    def hand_axes(self, values):
        """The Panda's grasp (approach, closing) for ``hand_target(values)``: horizontal, from the robot's side.

        A top-down grasp cannot reach drop heights above ~1.3 m; approaching horizontally along the line from the
        base to the ball reaches all of them.
        """
        t = self.hand_target(values)
        h = t[:2] - self.base_xy
        h = h / np.linalg.norm(h)
        return np.array([h[0], h[1], 0.0]), np.array([-h[1], h[0], 0.0])


class Puck(Tool):
    """The puck at rest at ``start``: a disc (``shape="disc"``) or the block (``"block"``, :func:`make_block`).

    The block slides along a face normal: before an attempt it faces the swing plane and its ``supports`` (static
    bodies whose edges it crosses, colliding as boxes) turn with it (:meth:`face_swing_plane`). With ``faces`` it
    does so wherever it is put at rest (:meth:`rest`); a varied task's hidden physics turns it at the first touch
    instead. ``friction_pairs``: ``(geom, pair name)`` of the surfaces it slides on, each a frictional contact pair
    of ``friction`` (:func:`phyplan_envs.block.add_friction_pair`, the block's with the slow friction reference).
    """

    def __init__(self, start, shape: str = "disc", mass: float = assets.PUCK_MASS, faces: bool = False,
                 supports: tuple[str, ...] = (), friction_pairs: tuple[tuple[str, str], ...] = (),
                 friction: float = assets.TABLE_FRICTION, name: str = "puck"):
        if shape not in ("disc", "block"):
            raise ValueError(f"puck shape must be 'disc' or 'block', got {shape!r}")
        self.start = np.asarray(start, dtype=np.float64)
        self.shape, self.mass, self.faces, self.name = shape, mass, faces, name
        self.block = shape == "block"
        self.half = BLOCK_HALF if self.block else assets.PUCK_RADIUS    # its half-size along a hit
        self.supports, self.friction_pairs, self.friction = tuple(supports), tuple(friction_pairs), friction
        self.geom = f"{name}_geom"

    def build(self, root) -> None:
        assets.add_puck(root, name=self.name, mass=self.mass)
        if self.block:
            make_block(root, self.geom)
        for geom, pair in self.friction_pairs:
            add_friction_pair(root, self.geom, geom, pair, self.friction, soft_reference=self.block)

    def bind(self, scene) -> None:
        super().bind(scene)
        self.support_ids = [scene.body_id(name) for name in self.supports]

    def describe(self, values):
        return MovingObject(self.name, "puck", self.start.copy(), self.half, assets.PUCK_HALF_HEIGHT, self.mass)

    def rest(self, phi: float = 0.0) -> None:
        """At rest at its start; a block that ``faces`` turned to the swing plane ``phi``."""
        if self.faces:
            self.face_swing_plane(phi)
        else:
            self.scene.set_object_pose(self.start)

    def turn_supports(self, phi: float) -> None:
        """Turn the block's supports to the swing plane ``phi``."""
        for body in self.support_ids:
            turn_body(self.scene.model, body, phi)

    def face_swing_plane(self, phi: float, from_start: bool = True) -> None:
        """Turn the block and its supports to the swing plane ``phi``: the block set at its start, at rest
        (``from_start``), or turned by ``phi`` where it is (a varied task's block, settled at yaw 0)."""
        s = self.scene
        if from_start:
            s.set_object_pose(self.start, quat=assets.yaw_quat(phi))
        self.turn_supports(phi)
        if not from_start:
            turn_free_body(s.data.qpos, s.object_qpos, phi)
