"""The Franka Panda in every phyplan scene: a visual-only arm, posed by inverse kinematics to hold the tool.

The arm is built from the MJCF fragments and meshes that ``gymnasium-robotics`` ships
(``gymnasium_robotics/envs/assets/kitchen_franka/franka_assets/``: ``assets.xml``, ``chain.xml``, ``meshes/``;
Apache-2.0, originally vikashplus/franka). Two models are made from them:

* the **scene copy**, attached to a task's MJCF root by :func:`attach_panda`: the visual meshes only (collision
  meshes and the finger collision capsules are dropped), every geom ``contype=conaffinity=0`` in geom group
  :data:`PANDA_GEOM_GROUP` (4; the env's observation camera hides that group), and **no joints, no actuators and no
  link bodies**: the geoms sit flat on the one attachment frame at the base. It therefore adds no degree of
  freedom, no contact and no actuator to the task's physics, and one static body. The arm is posed kinematically:
  each geom's ``model.geom_pos``/``geom_quat`` is set to its link's frame (forward kinematics of the IK model below
  at joint angles q) composed with the geom's rest pose in that link. (Keeping the 11 link bodies and writing their
  ``body_quat`` works too, but static bodies cost MuJoCo more per step than static geoms.) Moving geoms inside a
  body leaves MuJoCo's per-body bounding-volume tree (built at compile time) stale, so these geoms must stay
  collision-free and invisible to ``mj_ray``; they are, and nothing in phyplan casts rays.
* the **IK model** (:func:`ik_model`, one per process): the same kinematic chain *with* its 7 arm joints and limits,
  no geoms and no fingers, on which `mink <https://github.com/kevinzakka/mink>`_ solves for the joint angles that put
  the grasp site (between the finger pads) at a world point with a given hand orientation.

The env base calls ``attach_panda(root, base_pos, base_yaw)`` while building the scene, ``handle.bind(physics)`` after
compiling it and ``handle.pose_for(env, action)`` before drawing a frame. ``pose_for`` holds the point
``env.hand_target(action)``; the hand orientation is chosen by :func:`grasp_candidates` (perpendicular to a pendulum
rod, so the fingers close on the bob's side faces; otherwise top-down), and the fingers close to
``env.grip_half_width`` (m, default :data:`DEFAULT_GRIP_HALF_WIDTH`, the pendulum bob) when an action is given and
are wide open before any attempt. A task may override the orientation with a method ``hand_axes(action)`` returning
world ``(approach, closing)`` vectors. IK results are cached per process, keyed by the target (rounded to 0.1 mm)
and orientation in the Panda's base frame, so repeated renders of the same pose cost one dictionary look-up.

Run ``python -m phyplan_envs.panda`` to measure the stepping rate of every task with and without the Panda.
"""
from __future__ import annotations

from . import _gl  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

import functools
import importlib.util
import math
import pathlib
import xml.etree.ElementTree as ET
from collections import OrderedDict
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np
from dm_control import mjcf

from . import assets

# --- where the model comes from ------------------------------------------------------------------------------------------
FRANKA_SUBDIR = ("envs", "assets", "kitchen_franka", "franka_assets")
ARM_LINKS = tuple(f"panda0_link{i}" for i in range(1, 8))
ARM_JOINTS = tuple(f"robot:panda0_joint{i}" for i in range(1, 8))
FINGER_BODIES = ("panda0_leftfinger", "panda0_rightfinger")
HAND_LINK = "panda0_link7"
GRASP_SITE = "grasp"

# --- geometry and looks --------------------------------------------------------------------------------------------------
PANDA_GEOM_GROUP = 4       # hidden by the env's observation camera, shown by render()
PANDA_SITE_GROUP = 5       # the mount and grasp sites: hidden in every default view
# The grasp point: on the hand's axis, 0.07 m into the fingers (finger bodies sit 0.1654 m from the link7 origin and
# their pads span 0.035-0.095 m of the finger frame in chain.xml), so a 3 cm cube held there lies on the pads.
GRASP_DEPTH = 0.1654 + 0.07
# The grasp frame in link7: z = approach (out of the fingers), y = the fingers' closing axis (the hand and fingers are
# yawed by -45 deg in chain.xml, like its ``end_effector`` site).
GRASP_QUAT = (math.cos(-math.pi / 8), 0.0, 0.0, math.sin(-math.pi / 8))
SHOULDER_HEIGHT = 0.333    # link1 above the base (chain.xml)
FINGER_OPEN = 0.04         # finger joint range upper bound (chain.xml): each finger 4 cm from the centre
FINGER_CLEARANCE = 0.001   # the finger mesh's inner face sits 1 mm past the centre line at joint value 0
DEFAULT_GRIP_HALF_WIDTH = assets.BOB_HALF
ARM_RGBA = (0.93, 0.93, 0.91, 1.0)
HAND_RGBA = (0.22, 0.22, 0.24, 1.0)

# --- inverse kinematics ---------------------------------------------------------------------------------------------------
# A ready pose of this chain: the hand points straight down in front of the base (link6/link7 in chain.xml carry
# the +pi/2 and +pi/4 offsets that the usual Panda "home" puts in joints 6 and 7, so those are 0 here).
HOME_Q = (0.0, -0.785, 0.0, -2.356, 0.0, 0.0, 0.0)
IK_SOLVER = "daqp"         # the QP backend mink uses (installed with it)
IK_MAX_ITERS = 150
IK_POS_TOL = 1e-4          # m: a solve stops when the grasp site is this close to the target ...
IK_ORI_TOL = 2e-3          # rad: ... and this close to the target orientation
IK_ACCEPT_POS = 2e-3       # m: the first candidate grasp within these residuals is taken; otherwise the best
IK_ACCEPT_ORI = 0.05       # rad
IK_CACHE_SIZE = 4096


# ================================================================================================== the two models
def franka_assets_dir() -> pathlib.Path:
    """The ``franka_assets`` folder of the installed ``gymnasium-robotics`` (found without importing it)."""
    spec = importlib.util.find_spec("gymnasium_robotics")
    if spec is None or not spec.submodule_search_locations:
        raise ModuleNotFoundError("the Panda needs gymnasium-robotics (pip install 'gymnasium-robotics>=1.4'), "
                                  "which ships the Franka meshes; or make the env with with_panda=False")
    folder = pathlib.Path(list(spec.submodule_search_locations)[0]).joinpath(*FRANKA_SUBDIR)
    missing = [n for n in ("assets.xml", "chain.xml", "meshes") if not (folder / n).exists()]
    if missing:
        raise FileNotFoundError(f"{folder} lacks {missing}: this gymnasium-robotics version does not ship the "
                                "kitchen_franka Panda; install gymnasium-robotics 1.4")
    return folder


@functools.lru_cache(maxsize=1)
def _fragments() -> tuple[ET.Element, ET.Element]:
    """The parsed ``<mujocoinclude>`` roots of assets.xml and chain.xml (comments dropped by the parser)."""
    folder = franka_assets_dir()
    return ET.parse(folder / "assets.xml").getroot(), ET.parse(folder / "chain.xml").getroot()


def _chain_copy() -> ET.Element:
    """A fresh copy of the chain's root body (``panda0_link0``)."""
    body = _fragments()[1].find("body")
    return ET.fromstring(ET.tostring(body))


@functools.lru_cache(maxsize=1)
def ik_model() -> mujoco.MjModel:
    """The Panda alone, base at the origin, with its 7 arm joints and their limits, no geoms and no fingers.

    Each link gets a unit point mass (mass does not enter kinematics, but MuJoCo requires it on jointed bodies);
    link7 carries the ``grasp`` site. Built once per process.
    """
    chain = _chain_copy()
    for body in chain.iter("body"):
        for child in list(body):
            if child.tag in ("geom", "site", "inertial"):
                body.remove(child)
            elif child.tag == "body" and child.get("name") in FINGER_BODIES:
                body.remove(child)
        body.attrib.pop("childclass", None)
        if body.find("joint") is not None:
            ET.SubElement(body, "inertial", pos="0 0 0", mass="1", diaginertia="0.001 0.001 0.001")
        for joint in body.findall("joint"):
            joint.attrib.pop("class", None)
            joint.set("limited", "true")
            joint.set("axis", joint.get("axis", "0 0 1"))
            joint.set("pos", joint.get("pos", "0 0 0"))
        if body.get("name") == HAND_LINK:
            ET.SubElement(body, "site", name=GRASP_SITE, pos=f"0 0 {GRASP_DEPTH}",
                          quat=" ".join(map(str, GRASP_QUAT)), size="0.01")
    root = ET.Element("mujoco", model="panda_ik")
    ET.SubElement(root, "compiler", angle="radian")   # the fragment's own setting (assets.xml)
    ET.SubElement(root, "worldbody").append(chain)
    model = mujoco.MjModel.from_xml_string(ET.tostring(root, encoding="unicode"))
    names = [model.joint(i).name for i in range(model.njnt)]
    if tuple(names) != ARM_JOINTS:
        raise RuntimeError(f"unexpected joints in the gymnasium-robotics Panda chain: {names}")
    return model


def _frame_attrs(el: ET.Element, what: str) -> tuple[np.ndarray, np.ndarray]:
    """``pos`` and ``quat`` of a chain.xml element (defaults 0 and identity); other frame forms are refused."""
    for bad in ("euler", "axisangle", "xyaxes", "zaxis"):
        if el.get(bad) is not None:
            raise RuntimeError(f"unexpected {bad!r} frame on {what} in the Panda chain")
    pos = np.array(el.get("pos", "0 0 0").split(), dtype=np.float64)
    quat = np.array(el.get("quat", "1 0 0 0").split(), dtype=np.float64)
    return pos, quat / np.linalg.norm(quat)


@dataclass(frozen=True)
class _VisualParts:
    xml: str                                  # the scene copy: one flat set of mesh geoms and the grasp site
    files: dict                               # mesh file name -> bytes
    geoms: tuple                              # (geom name, name of the link or finger it belongs to)
    fingers: tuple                            # (finger name, rest pos, rest quat, slide axis) in link7's frame


@functools.lru_cache(maxsize=1)
def _visual_parts() -> _VisualParts:
    """The scene copy of the Panda, read once per process.

    All visual mesh geoms sit flat in the copy's root (no bodies, no joints), each at its pose in its own link's
    frame; :meth:`PandaHandle.set_pose` moves them by composing that pose with the link's frame from forward
    kinematics of :func:`ik_model`. One flat set of geoms instead of 11 link bodies halves the per-step cost of the
    copy (bodies cost MuJoCo more per step than static geoms; ``python -m phyplan_envs.panda`` measures it).
    """
    folder = franka_assets_dir()
    asset_root, _ = _fragments()
    files: dict[str, bytes] = {}
    asset = ET.Element("asset")
    viz_meshes = set()
    for mesh in asset_root.find("asset").findall("mesh"):
        name = mesh.get("name")
        if not name.endswith("_viz"):
            continue                          # collision meshes are not needed
        viz_meshes.add(name)
        fname = mesh.get("file")
        flat = "panda_" + fname.replace("/", "_")
        files[flat] = (folder / "meshes" / fname).read_bytes()
        attrs = {"name": name, "file": flat}
        if mesh.get("scale"):
            attrs["scale"] = mesh.get("scale")
        ET.SubElement(asset, "mesh", **attrs)

    world = ET.Element("worldbody")
    geoms, fingers = [], []
    for body in _chain_copy().iter("body"):
        name = body.get("name")
        if name in FINGER_BODIES:
            pos, quat = _frame_attrs(body, name)
            axis = np.array(body.find("joint").get("axis").split(), dtype=np.float64)
            fingers.append((name, pos, quat, axis))
        k = 0
        for child in body.findall("geom"):
            if child.get("class") != "panda_viz" or child.get("mesh") not in viz_meshes:
                continue                      # collision meshes and the finger collision capsules
            pos, quat = _frame_attrs(child, f"a geom of {name}")
            gname = f"{name}_viz{k}"
            k += 1
            rgba = HAND_RGBA if child.get("mesh") in ("hand_viz", "finger_viz") else ARM_RGBA
            ET.SubElement(world, "geom", name=gname, type="mesh", mesh=child.get("mesh"),
                          pos=" ".join(f"{v:.17g}" for v in pos), quat=" ".join(f"{v:.17g}" for v in quat),
                          contype="0", conaffinity="0", group=str(PANDA_GEOM_GROUP), mass="0",
                          rgba=" ".join(map(str, rgba)))
            geoms.append((gname, name))
    ET.SubElement(world, "site", name=GRASP_SITE, pos=f"0 0 {GRASP_DEPTH}", quat=" ".join(map(str, GRASP_QUAT)),
                  size="0.008", group=str(PANDA_SITE_GROUP), rgba="1 0 0 1")
    root = ET.Element("mujoco", model="panda")
    root.append(asset)
    root.append(world)
    return _VisualParts(ET.tostring(root, encoding="unicode"), files, tuple(geoms), tuple(fingers))


def panda_mjcf() -> mjcf.RootElement:
    """A fresh dm_control MJCF model of the visual-only Panda (base at its origin), ready to attach."""
    parts = _visual_parts()
    return mjcf.from_xml_string(parts.xml, assets=parts.files)


# ======================================================================================================== geometry
def _yaw_matrix(yaw: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def grasp_rotation(approach, closing) -> np.ndarray:
    """The grasp frame as a rotation matrix (columns x, y, z): z = ``approach``, y = ``closing`` made orthogonal."""
    z = np.asarray(approach, dtype=np.float64)
    z = z / np.linalg.norm(z)
    y = np.asarray(closing, dtype=np.float64)
    y = y - (y @ z) * z
    ny = np.linalg.norm(y)
    if ny < 1e-9:
        raise ValueError(f"closing axis {closing!r} is parallel to the approach {approach!r}")
    y = y / ny
    return np.column_stack([np.cross(y, z), y, z])


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v)


def grasp_candidates(target, shoulder, rod_top=None) -> list[np.ndarray]:
    """Hand orientations (rotation matrices in the world frame) to try for holding ``target``, best guess first.

    With ``rod_top`` (the pivot of a pendulum whose bob is at ``target``) the fingers close across the swing plane
    and the hand approaches perpendicular to the rod from above (a top-down grasp when the rod is horizontal), or
    it comes from the side along the hinge axis, closing in the swing plane; candidates whose approach points
    away from the arm's ``shoulder`` (towards the target) come first. Without a rod: a top-down grasp with the
    fingers closing across the line from the shoulder to the target. Both finger orderings are listed (the hand is
    symmetric, the joint limits are not).
    """
    target = np.asarray(target, dtype=np.float64)
    reach = target - np.asarray(shoulder, dtype=np.float64)
    reach_h = np.array([reach[0], reach[1], 0.0])
    if np.linalg.norm(reach_h) < 1e-6:
        reach_h = np.array([1.0, 0.0, 0.0])
    reach_dir = _unit(reach)
    across = _unit(np.cross([0.0, 0.0, 1.0], reach_h))
    down = np.array([0.0, 0.0, -1.0])
    pairs: list[tuple[np.ndarray, np.ndarray]] = []
    rod = None if rod_top is None else np.asarray(rod_top, dtype=np.float64) - target
    if rod is not None and np.linalg.norm(rod) > 1e-6:
        r = _unit(rod)
        hinge = np.cross(r, [0.0, 0.0, 1.0])
        if np.linalg.norm(hinge) < 1e-6:        # vertical rod: any horizontal hinge; take the one across the reach
            hinge = across
        hinge = _unit(hinge)
        over = _unit(np.cross(r, hinge))       # perpendicular to the rod, in the swing plane
        if over[2] > 0:
            over = -over
        if hinge @ reach_dir < 0:
            hinge = -hinge
        pairs = [(over, hinge), (hinge, over)]
        pairs.sort(key=lambda p: -float(p[0] @ reach_dir))
    else:
        pairs = [(down, across)]
    out = []
    for approach, closing in pairs:
        out.append(grasp_rotation(approach, closing))
        out.append(grasp_rotation(approach, -closing))
    return out


# ================================================================================================ inverse kinematics
@dataclass(frozen=True)
class IKSolution:
    """Joint angles (rad, joints 1-7) and how far the grasp site ends from the requested pose."""

    q: np.ndarray
    position_residual: float      # m
    orientation_residual: float   # rad
    iterations: int


class PandaIK:
    """Differential IK with mink on :func:`ik_model`; deterministic (always starts from :data:`HOME_Q` turned
    towards the target) and cached per process on the rounded request.

    Targets are in the Panda's base frame. Out-of-reach targets are not an error: the solver returns the closest
    pose it finds (position weighted above orientation) and its residuals.
    """

    def __init__(self):
        import mink

        self._mink = mink
        self.model = ik_model()
        self._home = np.array(HOME_Q, dtype=np.float64)
        self._low = self.model.jnt_range[:, 0].copy()
        self._high = self.model.jnt_range[:, 1].copy()
        self._site = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_SITE, GRASP_SITE)
        self._cache: OrderedDict[tuple, IKSolution] = OrderedDict()
        self.solves = 0      # IK problems actually solved (not served from the cache)

    def _start(self, pos: np.ndarray) -> np.ndarray:
        q = self._home.copy()
        q[0] = float(np.clip(math.atan2(pos[1], pos[0]), self._low[0], self._high[0]))
        return q

    def solve(self, pos, rot, orientation_cost: float = 0.5) -> IKSolution:
        """Joint angles that put the grasp site at ``pos`` (m) with orientation ``rot`` (3x3), base frame."""
        mink = self._mink
        pos = np.asarray(pos, dtype=np.float64)
        rot = np.asarray(rot, dtype=np.float64)
        if pos.shape != (3,) or rot.shape != (3, 3) or not (np.all(np.isfinite(pos)) and np.all(np.isfinite(rot))):
            raise ValueError(f"IK target must be a finite position (3,) and rotation (3, 3), got {pos!r}, {rot!r}")
        key = (tuple(np.round(pos, 4)), tuple(np.round(rot, 4).ravel()), round(orientation_cost, 4))
        hit = self._cache.get(key)
        if hit is not None:
            self._cache.move_to_end(key)
            return hit
        pos = np.array(key[0])
        rot = grasp_rotation(np.array(key[1]).reshape(3, 3)[:, 2], np.array(key[1]).reshape(3, 3)[:, 1])
        config = mink.Configuration(self.model, self._start(pos))
        frame = mink.FrameTask(GRASP_SITE, "site", position_cost=1.0, orientation_cost=orientation_cost,
                               lm_damping=1e-3)
        frame.set_target(mink.SE3.from_rotation_and_translation(mink.SO3.from_matrix(rot), pos))
        posture = mink.PostureTask(self.model, cost=1e-3)
        posture.set_target(self._home)
        limits = [mink.ConfigurationLimit(self.model)]
        best = None
        it = 0
        for it in range(1, IK_MAX_ITERS + 1):
            try:
                v = mink.solve_ik(config, [frame, posture], 1.0, IK_SOLVER, damping=1e-4, limits=limits)
            except mink.NoSolutionFound:    # an infeasible QP step: keep the best pose found so far
                break
            config.integrate_inplace(v, 1.0)
            pe, oe = self._residuals(config.data, pos, rot)
            score = pe + 0.05 * oe
            if best is None or score < best[0] - 1e-9:
                best = (score, config.q.copy(), pe, oe)
            if pe < IK_POS_TOL and oe < IK_ORI_TOL:
                break
            if np.max(np.abs(v)) < 1e-7:    # converged to the closest reachable pose
                break
        if best is None:                    # not even one step: the start pose
            pe, oe = self._residuals(config.data, pos, rot)
            best = (0.0, config.q.copy(), pe, oe)
        _, q, pe, oe = best
        sol = IKSolution(np.clip(q, self._low, self._high), float(pe), float(oe), it)
        self.solves += 1
        self._cache[key] = sol
        if len(self._cache) > IK_CACHE_SIZE:
            self._cache.popitem(last=False)
        return sol

    def _residuals(self, data: mujoco.MjData, pos: np.ndarray, rot: np.ndarray) -> tuple[float, float]:
        p = data.site_xpos[self._site]
        r = data.site_xmat[self._site].reshape(3, 3)
        pe = float(np.linalg.norm(p - pos))
        c = (np.trace(rot.T @ r) - 1.0) / 2.0
        oe = float(math.acos(min(1.0, max(-1.0, c))))
        return pe, oe

    def forward(self, q) -> tuple[np.ndarray, np.ndarray]:
        """Grasp-site position and rotation matrix (base frame) for joint angles ``q``."""
        data = mujoco.MjData(self.model)
        data.qpos[:] = q
        mujoco.mj_kinematics(self.model, data)
        return data.site_xpos[self._site].copy(), data.site_xmat[self._site].reshape(3, 3).copy()

    def solve_grasp(self, pos, candidates) -> tuple[IKSolution, int]:
        """The first candidate orientation (base frame) reached within the acceptance residuals, else the best."""
        best = None
        for i, rot in enumerate(candidates):
            sol = self.solve(pos, rot)
            if sol.position_residual < IK_ACCEPT_POS and sol.orientation_residual < IK_ACCEPT_ORI:
                return sol, i
            score = sol.position_residual + 0.05 * sol.orientation_residual
            if best is None or score < best[0]:
                best = (score, sol, i)
        # none is good: the closest reachable point, position first (orientation barely weighted)
        _, sol, i = best
        if sol.position_residual >= IK_ACCEPT_POS:
            loose = self.solve(pos, candidates[i], orientation_cost=0.02)
            if loose.position_residual < sol.position_residual:
                sol = loose
        return sol, i


@functools.lru_cache(maxsize=1)
def shared_ik() -> PandaIK:
    """The per-process IK solver (and its cache) that every Panda handle uses."""
    return PandaIK()


# ================================================================================================ the scene's Panda
class PandaHandle:
    """The Panda attached to one task scene: binds to its compiled physics and poses the arm kinematically.

    Attributes (after :meth:`pose_for` / :meth:`set_pose`):
        q: the 7 arm joint angles (rad) in use.
        finger_opening: each finger's distance from the hand's centre plane (m).
        residual: distance (m) between the grasp point and the requested target (0 when reached; larger when the
            target is out of reach: the arm then gets as close as it can and nothing is raised).
        orientation_residual: angle (rad) between the hand's orientation and the chosen grasp orientation.
        target: the last requested world point.
    """

    def __init__(self, model: mjcf.RootElement, frame: mjcf.Element, base_pos, base_yaw: float):
        self.mjcf_model = model
        self.frame = frame
        self.base_pos = np.asarray(base_pos, dtype=np.float64)
        self.base_yaw = float(base_yaw)
        self._R = _yaw_matrix(self.base_yaw)
        self.shoulder = self.base_pos + np.array([0.0, 0.0, SHOULDER_HEIGHT])
        self._bound = False
        self.q = np.array(HOME_Q, dtype=np.float64)
        self.finger_opening = FINGER_OPEN
        self.residual = float("nan")
        self.orientation_residual = float("nan")
        self.target: np.ndarray | None = None

    # ---------------------------------------------------------------------------------------------------- binding
    def bind(self, physics: mjcf.Physics) -> None:
        """Find the Panda's geoms and grasp site in the compiled ``physics``; remember their poses in their links."""
        self.model: mujoco.MjModel = physics.model.ptr
        self.data: mujoco.MjData = physics.data.ptr
        parts = _visual_parts()
        ik = ik_model()
        self._ik_data = mujoco.MjData(ik)
        self._ik_body = {n: mujoco.mj_name2id(ik, mujoco.mjtObj.mjOBJ_BODY, n) for n in ("panda0_link0",) + ARM_LINKS}
        self._geoms = np.array([physics.bind(self.mjcf_model.find("geom", g)).element_id for g, _ in parts.geoms])
        self._geom_frame = [frame for _, frame in parts.geoms]
        m = self.model
        # compiled poses in the link frames (MuJoCo moves mesh geoms to the mesh's centre of volume)
        self._geom_pos0 = m.geom_pos[self._geoms].copy()
        self._geom_quat0 = m.geom_quat[self._geoms].copy()
        # kinematics must read geom_pos/geom_quat: no "same frame as the body" shortcut for these geoms
        m.geom_sameframe[self._geoms] = 0
        self._site = int(physics.bind(self.mjcf_model.find("site", GRASP_SITE)).element_id)
        self._site_pos0 = m.site_pos[self._site].copy()
        self._site_quat0 = m.site_quat[self._site].copy()
        m.site_sameframe[self._site] = 0
        self._fingers = [(name, pos, quat, self._rotate(quat, axis)) for name, pos, quat, axis in parts.fingers]
        self._bound = True
        self.set_pose(self.q, self.finger_opening)

    @staticmethod
    def _rotate(quat, vec) -> np.ndarray:
        out = np.zeros(3)
        mujoco.mju_rotVecQuat(out, np.asarray(vec, dtype=np.float64), np.asarray(quat, dtype=np.float64))
        return out

    # ---------------------------------------------------------------------------------------------------- posing
    def link_frames(self, q, finger_opening: float) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """Each link's and finger's (pos, quat) in the Panda's base frame for joint angles ``q`` (rad) and
        ``finger_opening`` (m): forward kinematics of :func:`ik_model`, fingers slid along their joint axes."""
        ik, d = ik_model(), self._ik_data
        d.qpos[:] = q
        mujoco.mj_kinematics(ik, d)
        frames = {n: (d.xpos[b].copy(), d.xquat[b].copy()) for n, b in self._ik_body.items()}
        hand_pos, hand_quat = frames[HAND_LINK]
        for name, pos, quat, axis in self._fingers:
            p, qt = np.zeros(3), np.zeros(4)
            mujoco.mju_mulPose(p, qt, hand_pos, hand_quat, pos + finger_opening * axis, quat)
            frames[name] = (p, qt)
        return frames

    def set_pose(self, q, finger_opening: float) -> None:
        """Write joint angles ``q`` (7, rad) and ``finger_opening`` (m per finger, clipped to [0, 0.04]) into the
        model: every Panda geom's ``geom_pos``/``geom_quat`` becomes its link's frame composed with its rest pose
        in that link. Takes effect at the next ``mj_forward``/``mj_kinematics``; the physics state is untouched."""
        if not self._bound:
            raise RuntimeError("PandaHandle.bind(physics) must be called after compiling the scene")
        q = np.asarray(q, dtype=np.float64)
        if q.shape != (7,) or not np.all(np.isfinite(q)):
            raise ValueError(f"Panda joint angles must be 7 finite numbers, got {q!r}")
        opening = float(np.clip(finger_opening, 0.0, FINGER_OPEN))
        frames = self.link_frames(q, opening)
        m = self.model
        p, qt = np.zeros(3), np.zeros(4)
        for k, g in enumerate(self._geoms):
            fp, fq = frames[self._geom_frame[k]]
            mujoco.mju_mulPose(p, qt, fp, fq, self._geom_pos0[k], self._geom_quat0[k])
            m.geom_pos[g] = p
            m.geom_quat[g] = qt
        fp, fq = frames[HAND_LINK]
        mujoco.mju_mulPose(p, qt, fp, fq, self._site_pos0, self._site_quat0)
        m.site_pos[self._site] = p
        m.site_quat[self._site] = qt
        self.q = q.copy()
        self.finger_opening = opening

    def to_base(self, point) -> np.ndarray:
        """A world point in the Panda's base frame."""
        return self._R.T @ (np.asarray(point, dtype=np.float64) - self.base_pos)

    def hold(self, target, candidates_world, finger_opening: float) -> IKSolution:
        """Pose the arm so that the grasp point is at the world point ``target``, trying the world-frame hand
        orientations ``candidates_world`` in order (see :func:`grasp_candidates`)."""
        target = np.asarray(target, dtype=np.float64)
        if target.shape != (3,) or not np.all(np.isfinite(target)):
            raise ValueError(f"hand target must be 3 finite numbers (world x, y, z in m), got {target!r}")
        cands = [self._R.T @ r for r in candidates_world]
        ik = shared_ik()
        target_b = self.to_base(target)
        sol, i = ik.solve_grasp(target_b, cands)
        self.set_pose(sol.q, finger_opening)
        self.target = target.copy()
        # residuals against the exact request (the solver works on the target rounded to 0.1 mm)
        p, r = ik.forward(sol.q)
        self.residual = float(np.linalg.norm(p - target_b))
        c = (np.trace(cands[i].T @ r) - 1.0) / 2.0
        self.orientation_residual = float(math.acos(min(1.0, max(-1.0, c))))
        return sol

    def pose_for(self, env: Any, action) -> IKSolution:
        """Hold ``env.hand_target(action)``: the bob at its release angle, the object at its drop point, ...

        The hand orientation: the env's ``hand_axes(action)`` (``(approach, closing)`` world vectors) if it defines
        one; else perpendicular to the pendulum rod if the env has a pendulum tool (``env._pendulum``); else top-down.
        Fingers: closed on ``env.grip_half_width`` (default the bob's half edge) once an action is given, open before.
        """
        target = np.asarray(env.hand_target(action), dtype=np.float64)
        if hasattr(env, "hand_axes"):
            approach, closing = env.hand_axes(action)
            cands = [grasp_rotation(approach, closing)]
        else:
            pend = getattr(env, "_pendulum", None)
            rod_top = pend.pivot() if pend is not None and hasattr(pend, "pivot") else None
            cands = grasp_candidates(target, self.shoulder, rod_top)
        if action is None:
            opening = FINGER_OPEN
        else:
            opening = float(getattr(env, "grip_half_width", DEFAULT_GRIP_HALF_WIDTH)) + FINGER_CLEARANCE
        return self.hold(target, cands, opening)

    def grasp_site_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """World position and rotation matrix of the grasp point (after ``mj_forward``/``mj_kinematics``)."""
        return self.data.site_xpos[self._site].copy(), self.data.site_xmat[self._site].reshape(3, 3).copy()


def attach_panda(root: mjcf.RootElement, base_pos=(0.0, 0.0, 0.0), base_yaw: float = 0.0,
                 name: str = "panda") -> PandaHandle:
    """Attach a visual-only Panda to ``root`` with its base at world ``base_pos`` (m) turned by ``base_yaw`` (rad).

    Adds no joints, actuators or contacts (see the module docstring). Names of the attached elements are prefixed
    ``"{name}/"``. Call ``handle.bind(physics)`` after compiling ``root``.
    """
    base_pos = np.asarray(base_pos, dtype=np.float64)
    if base_pos.shape != (3,) or not np.all(np.isfinite(base_pos)) or not math.isfinite(base_yaw):
        raise ValueError(f"Panda base_pos must be 3 finite numbers and base_yaw finite, got {base_pos!r}, {base_yaw!r}")
    model = panda_mjcf()
    model.model = name
    mount = root.worldbody.add("site", name=f"{name}_mount", pos=base_pos, quat=assets.yaw_quat(base_yaw),
                               size=(0.01,), group=PANDA_SITE_GROUP)
    frame = mount.attach(model)
    return PandaHandle(model, frame, base_pos, base_yaw)


# ============================================================================================== stepping benchmark
def benchmark_stepping(tasks=None, steps: int = 4000, repeats: int = 7, episodes: int = 20) -> list[dict]:
    """Physics cost of the Panda: per task, MuJoCo steps/s and env episodes/s with and without it (medians).

    ``steps/s``: ``mj_step(nstep=steps)`` from the released state of one fixed attempt (no Python in the loop).
    ``episodes/s``: ``reset(seed=i)`` + ``step(a_i)`` over ``episodes`` fixed random attempts (state observations).
    Times are CPU time of this process (``time.process_time``), so other processes on the machine disturb them less;
    the two models are timed back to back in every repeat.
    """
    import statistics
    import time

    import gymnasium as gym

    from . import TASKS, env_id

    rows = []
    for task in (tasks or list(TASKS)):
        envs, acts = {}, None
        for with_panda in (False, True):
            env = gym.make(env_id(task), with_panda=with_panda).unwrapped
            if acts is None:
                rng = np.random.default_rng(0)
                lo, hi = env.action_space.low.astype(np.float64), env.action_space.high.astype(np.float64)
                acts = lo + (hi - lo) * rng.random((episodes, len(lo)))
            envs[with_panda] = env
        rates: dict[bool, list[float]] = {False: [], True: []}
        eps: dict[bool, list[float]] = {False: [], True: []}
        for _ in range(repeats):          # interleaved, so that load changes on the machine hit both alike
            for with_panda, env in envs.items():
                m, d = env.model, env.data
                env.reset(seed=0)
                env.apply_action(acts[0])
                mujoco.mj_forward(m, d)
                t0 = time.process_time()
                mujoco.mj_step(m, d, nstep=steps)
                rates[with_panda].append(steps / (time.process_time() - t0))
                t0 = time.process_time()
                for i, a in enumerate(acts):
                    env.reset(seed=i)
                    env.step(a)
                eps[with_panda].append(episodes / (time.process_time() - t0))
        # paired ratios (each repeat times both models back to back) are steadier than ratios of medians on a
        # loaded machine
        step_ratio = statistics.median(b / a for a, b in zip(rates[False], rates[True]))
        ep_ratio = statistics.median(b / a for a, b in zip(eps[False], eps[True]))
        for with_panda, env in envs.items():
            m = env.model
            rows.append({"task": task, "with_panda": with_panda, "nq": m.nq, "nbody": m.nbody, "ngeom": m.ngeom,
                         "steps_per_s": statistics.median(rates[with_panda]),
                         "episodes_per_s": statistics.median(eps[with_panda]),
                         "paired_step_ratio": step_ratio, "paired_episode_ratio": ep_ratio})
            env.close()
    return rows


def main(argv=None) -> None:
    import argparse

    parser = argparse.ArgumentParser(description="Stepping rate of every task with and without the Panda")
    parser.add_argument("--tasks", nargs="*", default=None, help="task names (default: all registered)")
    parser.add_argument("--steps", type=int, default=4000, help="physics steps per raw-rate repeat")
    parser.add_argument("--repeats", type=int, default=7, help="repeats; medians are printed")
    parser.add_argument("--episodes", type=int, default=20, help="episodes per env-rate repeat")
    args = parser.parse_args(argv)
    rows = benchmark_stepping(args.tasks, args.steps, args.repeats, args.episodes)
    print(f"{'task':8s} {'panda':5s} {'nq':>3s} {'nbody':>5s} {'ngeom':>5s} {'steps/s':>9s} {'episodes/s':>10s}")
    for r in rows:
        print(f"{r['task']:8s} {str(r['with_panda']):5s} {r['nq']:3d} {r['nbody']:5d} {r['ngeom']:5d} "
              f"{r['steps_per_s']:9.0f} {r['episodes_per_s']:10.1f}")
    for r in rows:
        if r["with_panda"]:
            print(f"{r['task']}: with/without Panda (median of paired repeats) = {r['paired_step_ratio']:.2f}x "
                  f"steps/s, {r['paired_episode_ratio']:.2f}x episodes/s")


if __name__ == "__main__":
    main()
