"""The two Panda models built from gymnasium-robotics' Franka assets: the visual scene copy and the IK chain.

:func:`franka_assets_dir` locates ``gymnasium_robotics/envs/assets/kitchen_franka/franka_assets/`` (``assets.xml``,
``chain.xml``, ``meshes/``) without importing gymnasium-robotics. :func:`panda_mjcf` is the visual-only copy that
:func:`phyplan_envs.panda.attach_panda` puts into a task scene (flat mesh geoms, no bodies, joints or contacts);
:func:`ik_model` is the jointed chain (7 arm joints with limits, no geoms, no fingers) that the IK solves on.
The geometric facts of the arm read from chain.xml (grasp depth, finger travel, shoulder height) live here too.
"""
from __future__ import annotations

from .. import _gl  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

import functools
import importlib.util
import math
import pathlib
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import mujoco
import numpy as np
from dm_control import mjcf

from .. import assets

# --- where the model comes from ---------------------------------------------------------------------------------------
FRANKA_SUBDIR = ("envs", "assets", "kitchen_franka", "franka_assets")
ARM_LINKS = tuple(f"panda0_link{i}" for i in range(1, 8))
ARM_JOINTS = tuple(f"robot:panda0_joint{i}" for i in range(1, 8))
FINGER_BODIES = ("panda0_leftfinger", "panda0_rightfinger")
HAND_LINK = "panda0_link7"
GRASP_SITE = "grasp"

# --- geometry and looks -----------------------------------------------------------------------------------------------
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
    copy (bodies cost MuJoCo more per step than static geoms; ``python -m benchmarks.panda_speed`` measures it).
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
