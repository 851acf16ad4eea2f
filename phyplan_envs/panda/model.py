"""What the posed arm and robot mode share of the Panda: gymnasium-robotics' Franka files, the IK chain, the facts.

:func:`franka_assets_dir` locates ``gymnasium_robotics/envs/assets/kitchen_franka/franka_assets/`` (``assets.xml``,
``chain.xml``, ``meshes/``) without importing gymnasium-robotics; ``_fragments()`` parses them once and
``_chain_copy()`` copies the chain's root body, from which the posed arm's scene copy
(:mod:`phyplan_envs.panda.posed.scene_copy`) and robot mode's articulated model (:mod:`phyplan_envs.panda.robot.model`)
are built. :func:`ik_model` is the jointed chain (7 arm joints with limits, no geoms, no fingers) that the IK
(:mod:`phyplan_envs.panda.ik`) solves on. The geometric facts of the arm read from chain.xml (grasp depth, finger
travel, shoulder height), its geom groups and colours live here too.
"""
from __future__ import annotations

from .. import _gl  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

import functools
import importlib.util
import math
import pathlib
import xml.etree.ElementTree as ET

import mujoco

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


# ================================================================================================ files and chain
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
