"""What the objects rest on, bounce off or slide over, and the goal: pedestal, tables, wedge, plank, goal box."""
from __future__ import annotations

import math

import numpy as np

from .. import assets
from ..block import add_square_top
from ..contact import restitution_of_solref
from ..description import Obstacle, Support, prism_faces
from ..spaces import ActionDim
from .tool import Tool


def polar(distance: float, angle: float) -> np.ndarray:
    """The xy point at ``distance`` along direction ``angle`` (radians from +x)."""
    return np.array([distance * math.cos(angle), distance * math.sin(angle)])


def polar_goal(rng: np.random.Generator, origin, distance: tuple[float, float],
               angle: tuple[float, float] = (0.0, math.pi / 2)) -> np.ndarray:
    """A goal at distance U(``distance``) from ``origin`` (xy) in direction U(``angle``), drawn in that order."""
    d = rng.uniform(*distance)
    a = rng.uniform(*angle)
    return np.asarray(origin[:2]) + polar(d, a)


PEDESTAL_SIDE_RESTITUTION = 0.13
"""The restitution of a ball meeting the pedestal's side (MuJoCo's default soft contact, critically damped: a ball
thrown square at a side at 1-3 m/s keeps 12-13% of its normal speed, timestep 1 ms)."""


class Pedestal(Tool):
    """The frictionless pedestal the Launch ball rests on: a top the ball rests on, over a column it can run into."""

    def __init__(self, xy):
        self.xy = xy

    def build(self, root) -> None:
        assets.add_pedestal(root, self.xy)

    def describe(self, values):
        centre, half = np.asarray(self.xy, dtype=np.float64), np.full(2, assets.PEDESTAL_HALF)
        return [Support("pedestal", "rect", centre, assets.PEDESTAL_HEIGHT, 0.0, half=half),
                Obstacle("pedestal_column", "pedestal", centre, half, 0.0, assets.PEDESTAL_HEIGHT,
                         PEDESTAL_SIDE_RESTITUTION)]


class Table(Tool):
    """A rectangular table top (``bounds``: xmin, xmax, ymin, ymax) of the given height and friction."""

    def __init__(self, bounds, height: float = assets.TABLE_HEIGHT, friction: float = assets.TABLE_FRICTION,
                 name: str = "table"):
        self.bounds, self.height, self.friction, self.name = bounds, height, friction, name

    def build(self, root) -> None:
        assets.add_table(root, *self.bounds, height=self.height, name=self.name, friction=self.friction)

    def describe(self, values):
        x0, x1, y0, y1 = self.bounds
        return Support(self.name, "rect", np.array([(x0 + x1) / 2, (y0 + y1) / 2]), self.height, self.friction,
                       half=np.array([(x1 - x0) / 2, (y1 - y0) / 2]))


class RoundTable(Tool):
    """The round table of Bridge; ``square_top``: its top collides as a square of the radius's half edge, turned
    with the block puck (:func:`phyplan_envs.block.add_square_top`), and is drawn round."""

    def __init__(self, radius: float, height: float, friction: float, square_top: bool = False, name: str = "table"):
        self.radius, self.height, self.friction, self.square_top, self.name = radius, height, friction, square_top, name

    def build(self, root) -> None:
        assets.add_round_table(root, self.radius, self.height, name=self.name, friction=self.friction)
        if self.square_top:
            add_square_top(root, f"{self.name}_top", self.radius, **assets.WORLD)

    def describe(self, values):
        return Support(self.name, "disc", np.zeros(2), self.height, self.friction, radius=self.radius)


class Wedge(Tool):
    """The Bounce wedge on its round stand, yawed about its vertical axis at ``pos`` by the action ``wedge_yaw``;
    between attempts at ``rest_yaw``. Robot mode: the scene turns it (a tool the arm need not carry)."""

    dims = (ActionDim("wedge_yaw", -math.pi, math.pi, "rad", "yaw of the wedge (direction the ball bounces off to)"),)

    def __init__(self, pos, rest_yaw: float = 0.0, name: str = "wedge",
                 stand_height: float = assets.WEDGE_STAND_HEIGHT, restitution: float | None = None,
                 contact: str = "solref"):
        self.pos, self.rest_yaw, self.name, self.stand_height = pos, rest_yaw, name, stand_height
        # the contact's model and restitution (default: the incline's own solref and its nominal restitution; a task
        # that adds an impact pair for it says so, for the scene description)
        self.restitution = restitution_of_solref(assets.ELASTIC_SOLREF) if restitution is None else restitution
        self.contact = contact

    def build(self, root) -> None:
        assets.add_wedge(root, name=self.name, stand_height=self.stand_height)

    def bind(self, scene) -> None:
        super().bind(scene)
        self.body = scene.body_id(self.name)

    def reset(self) -> None:
        self.scene.set_body_pose(self.body, self.pos, yaw=self.rest_yaw)

    def apply(self, values) -> None:
        self.scene.set_body_pose(self.body, self.pos, yaw=values[0])

    def robot_steps(self, values) -> list:
        self.apply(values)
        return []

    def pose(self, values) -> tuple[np.ndarray, np.ndarray]:
        """The wedge's axis on its support (N, 3) and its yaw (N,) for the action values (N, 1)."""
        return np.tile(np.asarray(self.pos, dtype=np.float64), (len(values), 1)), values[:, 0].copy()

    def describe(self, values):
        pos, yaw = self.pose(values)
        return prism_faces(self.name, pos, yaw, assets.WEDGE_HALF, assets.WEDGE_ANGLE, self.stand_height,
                           self.restitution, self.contact)


def placed_wedge_dims(distance: tuple[float, float], angle: tuple[float, float]) -> tuple[ActionDim, ...]:
    """The action dimensions of a :class:`PlacedWedge`: its distance and direction from the origin, and its yaw."""
    return (
        ActionDim("wedge_distance", *distance, "m", "distance of the wedge's axis from the pedestal"),
        ActionDim("wedge_angle", *angle, "rad", "direction of the wedge's axis from the pedestal (from +x)"),
        ActionDim("wedge_yaw", -math.pi, math.pi, "rad", "yaw of the wedge (direction its incline falls to)"),
    )


class PlacedWedge(Wedge):
    """A wedge standing on the ground (no stand) that the action places (``dims``: :func:`placed_wedge_dims`):
    ``wedge_distance`` from ``origin`` (xy) along ``wedge_angle``, turned to ``wedge_yaw`` (its incline falls
    towards ``wedge_yaw``); between attempts at ``rest_pos``/``rest_yaw``. Robot mode: the scene places it (a tool
    the arm need not carry)."""

    def __init__(self, origin, dims: tuple[ActionDim, ...], rest_pos, rest_yaw: float = 0.0, name: str = "wedge",
                 restitution: float | None = None, contact: str = "solref"):
        super().__init__(rest_pos, rest_yaw, name, stand_height=0.0, restitution=restitution, contact=contact)
        self.origin = np.asarray(origin[:2], dtype=np.float64)
        self.dims = tuple(dims)

    def pose(self, values) -> tuple[np.ndarray, np.ndarray]:
        """The wedge's axis on the ground (N, 3) and its yaw (N,) for the action values (N, 3)."""
        d, a = values[:, 0], values[:, 1]
        pos = np.column_stack([self.origin[0] + d * np.cos(a), self.origin[1] + d * np.sin(a), np.zeros(len(d))])
        return pos, values[:, 2].copy()

    def apply(self, values) -> None:
        pos, yaw = self.pose(np.asarray(values, dtype=np.float64)[None])
        self.scene.set_body_pose(self.body, pos[0], yaw=float(yaw[0]))


class Plank(Tool):
    """The Bridge plank on its stands, from the rim of a round table (``table``: a :class:`RoundTable`) outwards
    along the action ``bridge_yaw``; between attempts at ``rest_yaw``.

    Robot mode: the plank turns on a pivot at the table centre (the hinge ``bridge_yaw``, locked but while the arm
    turns it); the arm, standing at ``robot_base_xy``, holds it ``grasp_r`` from the centre
    (:func:`phyplan_envs.panda.robot.plans.plank_carry`); only its inertia about the pivot matters (``robot_mass``).
    """

    dims = (ActionDim("bridge_yaw", 0.0, math.pi / 2, "rad", "direction of the bridge plank from the table centre"),)
    robot_bodies = ("bridge",)
    robot_latches = ("bridge_yaw",)

    def __init__(self, table: RoundTable, length: float, width: float, thick: float, drop: float, rest_yaw: float,
                 robot_base_xy, grasp_r: float, robot_mass: float, name: str = "bridge"):
        self.table, self.length, self.width, self.thick, self.drop = table, length, width, thick, drop
        self.rest_yaw, self.robot_base_xy, self.grasp_r, self.robot_mass = rest_yaw, robot_base_xy, grasp_r, robot_mass
        self.name = name

    def build(self, root) -> None:
        t = self.table
        assets.add_bridge(root, t.radius, t.height, length=self.length, width=self.width, thick=self.thick,
                          drop=self.drop, name=self.name, friction=t.friction)

    def robot_scene(self, root) -> None:
        """The plank turns about the table's axis (the arm turns it); it does not touch the table it sits under."""
        body = root.find("body", self.name)
        body.add("joint", name="bridge_yaw", type="hinge", axis=(0, 0, 1), damping=2.0)
        reach = self.table.radius + self.length / 2
        body.add("inertial", pos=(reach, 0, self.table.height), mass=self.robot_mass, diaginertia=(0.01, 0.05, 0.05))
        root.contact.add("exclude", body1=body, body2=root.find("body", self.table.name))

    def bind(self, scene) -> None:
        super().bind(scene)
        self.body = scene.body_id(self.name)

    def reset(self) -> None:
        self.scene.set_body_pose(self.body, (0.0, 0.0, 0.0), yaw=self.rest_yaw)

    def apply(self, values) -> None:
        self.scene.set_body_pose(self.body, (0.0, 0.0, 0.0), yaw=values[0])

    def describe(self, values):
        t, yaw = self.table, values[:, 0]
        start = t.radius - assets.bridge_overlap(t.radius, self.width)     # it reaches under the rim
        end = t.radius + self.length
        mid = (start + end) / 2
        centre = np.column_stack([mid * np.cos(yaw), mid * np.sin(yaw)])
        return Support(self.name, "rect", centre, t.height - self.drop, t.friction,
                       half=np.array([(end - start) / 2, self.width / 2]), yaw=yaw.copy())

    def yaw(self) -> float:
        """The plank's current yaw (rad) in the model: ``rest_yaw`` after reset, the action's after a set-up."""
        w, _, _, z = self.scene.model.body_quat[self.body]
        return 2.0 * math.atan2(z, w)

    def robot_steps(self, values) -> list:
        from ..panda.robot.plans import plank_carry

        top = self.table.height - self.drop
        return [plank_carry(self.rest_yaw, float(values[0]), self.grasp_r, self.width, self.thick, top,
                            self.robot_base_xy)]


class GoalBox(Tool):
    """The 0.1 x 0.1 goal box (``walls=False``: a flat marker at height ``base_z``); the env places it at each
    reset (:meth:`phyplan_envs.scene.Scene.place_goal`)."""

    def __init__(self, walls: bool = True, base_z: float = 0.0):
        self.walls, self.base_z = walls, base_z

    def build(self, root) -> None:
        assets.add_goal_box(root, walls=self.walls, base_z=self.base_z)


class PandaStand(Tool):
    """The visual Panda's stand (Bounce: from the ground its hand could not reach the drop heights): visual only,
    in the Panda's geom group (hidden from the observation camera)."""

    def __init__(self, base, half: float):
        self.base, self.half = base, half

    def build(self, root) -> None:
        b = self.base
        root.worldbody.add("geom", name="panda_stand", type="box", group=4, rgba=(0.35, 0.35, 0.38, 1),
                           pos=(b[0], b[1], b[2] / 2), size=(self.half, self.half, b[2] / 2), **assets.GHOST)
