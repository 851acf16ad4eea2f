"""Reading a task's scene from one RGB-D observation: the state vector the planner needs, rebuilt from pixels.

:func:`perceive` turns ``{"rgb", "depth"}`` from the ``obs`` camera (``obs_mode="rgbd"``) and the camera's
calibration into a :class:`Percept`: the state vector in the env's ``state_names`` order and what each entry was
measured from. Per task:

==========  =================================================================================================
task        measured (all tasks: the goal box centre and the object's start)
==========  =================================================================================================
launch      ball: sphere fit (known radius) to its surface points; ``pivot_height`` = measured ball height +
            the pendulum length (a declared fact: the rig hangs the bob at the ball's height)
slide       puck: circle fit to its top face's outline; ``table_height``: plane fit to the table top
bounce      ball on the side table: sphere fit; ``wedge_x, wedge_y``: rectangle fit to the wedge's outline;
            ``impact_z``: plane fit to the incline, evaluated above the wedge's centre, plus the ball's radius
            over the cosine of the measured incline angle
bridge      puck: circle fit; ``table_radius, table_height``: plane fit and circle fit to the round table top;
            ``bridge_length, bridge_width``: the plank's outline in its own frame (far end from the rim; width)
==========  =================================================================================================

Sizes that identify an object (the ball's and puck's radius, the goal box's 0.1 m side) come from the task's
declared facts and :mod:`phyplan_envs.assets`: public constants, not state. The goal box's centre comes from a
rectangle fit to its outline points (:func:`~phyplan_agents.perception.vision.edge_points`), so a box partly hidden
(e.g. under the Bridge plank) is still placed by its visible sides.

Failures are never silent: an object that is not seen, too small, or touching the picture's border (partly out of
view), fits that fail, and a goal box that leaves red pixels out, are listed in :attr:`Percept.problems`;
:meth:`Percept.require` raises :class:`PerceptionError` naming them.

Imperfect cameras (the env's ``camera_noise``): :class:`~.reads.RGBDView` fills invalid depth pixels, median-filters a
noisy depth picture (:func:`~phyplan_agents.perception.vision.denoise_depth`; its noise estimate widens the
height tolerances) and levels the calibration against the floor (:mod:`phyplan_agents.perception.floor`). An ideal
picture is read as before, bit for bit.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from . import vision as V
from .reads import PerceptionError, RGBDView, read_ball, read_goal, read_horizontal_plane, read_puck


@dataclass
class Percept:
    """What was read from one observation.

    Attributes:
        task: the task name.
        names: the state entries (the env's ``state_names``).
        state: the state vector (float64, NaN where an entry could not be measured).
        objects: per object, what was measured (centres, sizes, pixel counts).
        problems: why entries are missing or unreliable (empty: everything was measured).
    """

    task: str
    names: tuple[str, ...]
    state: np.ndarray
    objects: dict[str, dict[str, Any]] = field(default_factory=dict)
    problems: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.problems and bool(np.all(np.isfinite(self.state)))

    def require(self) -> np.ndarray:
        """The state vector, or :class:`PerceptionError` listing the problems."""
        if not self.ok:
            missing = [n for n, v in zip(self.names, self.state) if not np.isfinite(v)]
            detail = "; ".join(self.problems) or "no problem reported"
            raise PerceptionError(f"{self.task}: cannot read the scene from the picture: {detail}"
                                  + (f" (unmeasured: {', '.join(missing)})" if missing else ""))
        return self.state.copy()

    def as_dict(self) -> dict[str, float]:
        return {n: float(v) for n, v in zip(self.names, self.state)}




# ===================================================================================================== per task
def _launch(view: RGBDView, facts) -> dict[str, float]:
    out = {}
    ball, info = read_ball(view, facts.ball_radius)
    view.objects["ball"] = info
    if ball is not None:
        out.update(object_x=ball[0], object_y=ball[1], object_z=ball[2],
                   pivot_height=ball[2] + facts.bob_dz + facts.pendulum_length)
    return out


def _slide(view: RGBDView, facts) -> dict[str, float]:
    out = {}
    puck, info = read_puck(view, facts.puck_radius, facts.puck_half_height)
    view.objects["puck"] = info
    if puck is not None:
        out.update(object_x=puck[0], object_y=puck[1], object_z=puck[2])
    height, _ = read_horizontal_plane(view, "table", (0.1, 1.5))
    if height is not None:
        out["table_height"] = height
        view.objects["table"] = {"height": height}
    return out


def _bounce(view: RGBDView, facts) -> dict[str, float]:
    out = {}
    ball, info = read_ball(view, facts.ball_radius)
    view.objects["ball"] = info
    if ball is not None:
        out.update(object_x=ball[0], object_y=ball[1], object_z=ball[2])
    b = view.blob("blue", "wedge")
    if b is None:
        return out
    edges = V.edge_points(view.cam, view.depth, b.mask)
    fit = view.fit("wedge", V.fit_rectangle, edges[:, :2])
    if fit is None:
        return out
    centre, half = fit
    out.update(wedge_x=centre[0], wedge_y=centre[1])
    pts = V.world_points(view.cam, view.depth, b.mask)
    # the incline: the blue points off the vertical side faces (|local y| well inside the half width)
    rel = pts[:, :2] - centre
    incline = pts[(np.abs(rel[:, 1]) < half[1] - 0.01) & (np.abs(rel[:, 0]) < half[0] - 0.01)]
    plane = view.fit("wedge incline", V.fit_plane, incline)
    view.objects["wedge"] = {"pixels": b.pixels, "half": half.tolist()}
    if plane is None:
        return out
    n, c = plane
    angle = float(np.arccos(np.clip(n[2], -1, 1)))
    if not 0.1 < angle < 1.4:
        view.problems.append(f"wedge incline: not an incline (measured angle {angle:.3f} rad)")
        return out
    z_axis = (c - n[0] * centre[0] - n[1] * centre[1]) / n[2]
    out["impact_z"] = z_axis + facts.ball_radius / np.cos(angle)
    view.objects["wedge"]["angle"] = angle
    return out


def _bridge(view: RGBDView, facts) -> dict[str, float]:
    out = {}
    puck, info = read_puck(view, facts.puck_radius, facts.puck_half_height)
    view.objects["puck"] = info
    if puck is not None:
        out.update(object_x=puck[0], object_y=puck[1], object_z=puck[2])
    height, top = read_horizontal_plane(view, "table", (0.1, 1.5))
    if height is None:
        return out
    edges = V.edge_points(view.cam, view.depth, top)
    edges = edges[np.abs(edges[:, 2] - height) < 0.03]
    if puck is not None:   # the puck's footprint is a hole in the top's outline, not its rim (Bridge-v1's block
        # edge meets the top in points at the table's height, which pulled the circle fit ~3 mm off-centre)
        edges = edges[np.hypot(edges[:, 0] - puck[0], edges[:, 1] - puck[1]) > 2.5 * facts.puck_radius]
    circle = view.fit("table", V.fit_circle, edges[:, :2])
    if circle is None:
        return out
    centre, radius = circle
    out.update(table_height=height, table_radius=radius)
    view.objects["table"] = {"height": height, "radius": radius, "centre": centre.tolist()}
    plank = view.blob("blue", "bridge plank")
    if plank is None:
        return out
    pts = V.world_points(view.cam, view.depth, plank.mask)
    rel = pts[:, :2] - centre
    _, _, vt = np.linalg.svd(rel - rel.mean(axis=0), full_matrices=False)
    axis = vt[0] if vt[0] @ rel.mean(axis=0) > 0 else -vt[0]     # pointing away from the table centre
    across = np.array([-axis[1], axis[0]])
    e = V.edge_points(view.cam, view.depth, plank.mask)
    s, t = (e[:, :2] - centre) @ axis, (e[:, :2] - centre) @ across
    # the far end: the farthest outline points within 2 cm of the farthest; a lone point beyond the others (noise
    # in the depth picture) is not the end, and is left out (up to 3 such points)
    keep = np.ones(len(s), dtype=bool)
    for _ in range(4):
        far = keep & (s > s[keep].max() - 0.02)
        if far.sum() >= 2 or keep.sum() <= far.sum():
            break
        keep &= ~far
    mid = keep & (s > radius + 0.05) & (s < s[keep].max() - 0.05)
    pos, neg = mid & (t > 0), mid & (t < 0)
    if far.sum() < 2 or pos.sum() < 2 or neg.sum() < 2:
        view.problems.append("bridge plank: its outline (far end and both sides) is not seen")
        return out
    end = float(np.median(s[far]))
    width = float(np.median(t[pos]) - np.median(t[neg]))
    out.update(bridge_length=end - radius, bridge_width=width)
    view.objects["bridge"] = {"pixels": plank.pixels, "yaw": float(np.arctan2(axis[1], axis[0]))}
    return out


# The readers by what the state vector holds after goal and object (a task's ``state_extra``): a task whose state
# has a known layout is read without code of its own (LaunchBounce's is Launch's: the ball on its pedestal).
_READERS = {
    ("pivot_height",): _launch,
    ("table_height",): _slide,
    ("wedge_x", "wedge_y", "impact_z"): _bounce,
    ("table_radius", "table_height", "bridge_length", "bridge_width"): _bridge,
}


def has_reader(state_names: tuple[str, ...]) -> bool:
    """Whether a task whose state vector holds ``state_names`` has a scene reader (its layout after goal and object
    is a known one; Paddles' high shelf is out of the camera's view and has none)."""
    return tuple(state_names[5:]) in _READERS


def perceive(task: str, obs: Mapping[str, Any], camera, facts, state_names: tuple[str, ...]) -> Percept:
    """Read the state vector of ``task`` from an RGB-D observation (module docstring).

    Args:
        task: the task name (for messages); the reader is chosen by ``state_names``.
        obs: ``{"rgb": H x W x 3 uint8, "depth": H x W float32}`` (``obs_mode="rgbd"``).
        camera: the ``obs`` camera's :class:`phyplan_envs.camera.CameraModel` (resized to the picture if needed).
        facts: the task's declared facts (``phyplan_envs.task_class(task).facts``).
        state_names: the env's ``state_names`` (the order of the returned vector).
    """
    layout = tuple(state_names[5:])
    if layout not in _READERS:
        raise ValueError(f"task {task!r} has no scene reader for its state {layout}; readers exist for "
                         f"{', '.join(str(k) for k in _READERS)}")
    view = RGBDView(obs, camera)
    values: dict[str, float] = {}
    goal, info = read_goal(view)
    view.objects["goal"] = info
    if goal is not None:
        values.update(goal_x=goal[0], goal_y=goal[1])
    values.update(_READERS[layout](view, facts))
    state = np.array([values.get(n, np.nan) for n in state_names], dtype=np.float64)
    missing = [n for n, v in zip(state_names, state) if not np.isfinite(v)]
    problems = list(view.problems)
    if missing and not problems:
        problems.append(f"unmeasured: {', '.join(missing)}")
    return Percept(task, tuple(state_names), state, view.objects, problems)
