"""The articulated Franka Panda of robot mode: the MJCF model and how it is attached to a task scene.

Built from the same gymnasium-robotics files as the visual copy (``chain.xml``, ``assets.xml`` and ``actuator.xml``
under ``kitchen_franka/franka_assets``): the 11 link bodies with the 7 arm hinges and 2 finger slides, their limits
and damping, the links' masses (from their collision meshes) and the 9 position actuators (kp, force and control
ranges of actuator.xml). The visual meshes are drawn in geom group 4 like the visual copy's. Changes to the shipped
model, each for a reason:

* contact: only the finger pads (the capsules and box of chain.xml) collide, and only with the bodies a plan may
  grasp (their geoms' ``conaffinity`` gets :data:`ROBOT_BIT`); the pads are frictionless (``condim=1``). The link
  meshes carry mass but touch nothing, so the arm never touches the tables, the object at rest or the flying
  object; the fingers press on the grasped tool with real contacts (while they close on it and open off it;
  :mod:`.arm` switches the pads' contacts off while the grasp constraint carries the tool).
* gravity compensation (``gravcomp=1`` on the moving links), as the Panda's own controller does: without it the
  servos sag by centimetres under the links' weight.
* a quicker finger servo (armature 0.1, damping 20 instead of 5 and 100): the fingers close in ~0.1 s, not ~1 s.

:func:`attach_robot` also adds, per graspable body, the grasp constraint (a MuJoCo ``connect`` equality between
the grasp site and the body, off until the fingers touch it) and, per latched tool joint, a joint equality that
holds the joint still except while the arm turns it.
"""
from __future__ import annotations

from ... import _gl  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

import functools
import xml.etree.ElementTree as ET
from typing import Sequence

from dm_control import mjcf

from ... import assets
from .. import model as PM

ROBOT_BIT = 4               # contact bit of the finger pads, set in the conaffinity of the bodies they may grasp
ARM_DAMPING = (100.0, 100.0, 100.0, 100.0, 10.0, 10.0, 10.0)   # chain.xml: classes panda_arm / panda_forearm
FINGER_DAMPING = 20.0
FINGER_ARMATURE = 0.1
FINGER_KP = 500.0
CONSTRAINT_SOLREF = (0.005, 1.0)
   # grasp and latch equalities: stiff (time constant 5 ms at the 1-2 ms steps)


def _fmt(v) -> str:
    return " ".join(f"{x:.17g}" for x in v)


@functools.lru_cache(maxsize=1)
def _robot_parts() -> tuple[str, dict]:
    folder = PM.franka_assets_dir()
    asset_root, _ = PM._fragments()
    files, asset = {}, ET.Element("asset")
    for mesh in asset_root.find("asset").findall("mesh"):
        fname = mesh.get("file")
        flat = "panda_" + fname.replace("/", "_")
        files[flat] = (folder / "meshes" / fname).read_bytes()
        attrs = {"name": mesh.get("name"), "file": flat}
        if mesh.get("scale"):
            attrs["scale"] = mesh.get("scale")
        ET.SubElement(asset, "mesh", **attrs)
    chain = PM._chain_copy()
    arm_i = 0
    for body in chain.iter("body"):
        body.attrib.pop("childclass", None)
        name = body.get("name")
        finger = name in PM.FINGER_BODIES
        if name != "panda0_link0":
            body.set("gravcomp", "1")
        for j in body.findall("joint"):
            j.attrib.pop("class", None)
            j.set("limited", "true")
            j.set("axis", j.get("axis", "0 0 1"))
            if finger:
                j.set("damping", str(FINGER_DAMPING))
                j.set("armature", str(FINGER_ARMATURE))
            else:
                j.set("damping", str(ARM_DAMPING[arm_i]))
                arm_i += 1
        k = 0
        for g in body.findall("geom"):
            cls = g.attrib.pop("class", None)
            if cls == "panda_viz":
                rgba = PM.HAND_RGBA if g.get("mesh") in ("hand_viz", "finger_viz") else PM.ARM_RGBA
                g.attrib.update(type="mesh", contype="0", conaffinity="0", mass="0",
                                group=str(PM.PANDA_GEOM_GROUP), rgba=_fmt(rgba), name=f"{name}_viz{k}")
            elif cls == "panda_col":    # mass carriers only
                g.attrib.update(type="mesh", group="3", contype="0", conaffinity="0", name=f"{name}_col{k}")
            else:                        # finger pads: they touch only bodies whose conaffinity has ROBOT_BIT
                g.attrib.update(contype=str(ROBOT_BIT), conaffinity="0", group="3", condim="1", mass="0",
                                name=f"{name}_pad{k}")
            k += 1
        if name == PM.HAND_LINK:
            ET.SubElement(body, "site", name=PM.GRASP_SITE, pos=f"0 0 {PM.GRASP_DEPTH}", quat=_fmt(PM.GRASP_QUAT),
                          size="0.008", group=str(PM.PANDA_SITE_GROUP), rgba="1 0 0 1")
    act = ET.Element("actuator")
    for a in ET.parse(folder / "actuator.xml").getroot().find("actuator").findall("position"):
        attrs = {k: a.get(k) for k in ("name", "joint", "kp", "forcerange", "ctrlrange")}
        if "finger" in attrs["joint"]:
            attrs["kp"] = str(FINGER_KP)
        ET.SubElement(act, "position", forcelimited="true", ctrllimited="true", **attrs)
    root = ET.Element("mujoco", model="panda")
    ET.SubElement(root, "compiler", angle="radian")
    root.append(asset)
    ET.SubElement(root, "worldbody").append(chain)
    contact = ET.SubElement(root, "contact")
    ET.SubElement(contact, "exclude", body1=PM.FINGER_BODIES[0], body2=PM.FINGER_BODIES[1])
    root.append(act)
    return ET.tostring(root, encoding="unicode"), files


def robot_mjcf() -> mjcf.RootElement:
    """A fresh MJCF model of the articulated Panda (base at its origin), ready to attach."""
    xml, files = _robot_parts()
    return mjcf.from_xml_string(xml, assets=files)


def add_robot(root: mjcf.RootElement, base_pos, base_yaw: float, bodies: Sequence[str] = (),
              latches: Sequence[str] = (), name: str = "panda") -> mjcf.RootElement:
    """Attach the articulated Panda to ``root`` at world ``base_pos`` turned by ``base_yaw``; ``bodies`` are the
    bodies a plan may grasp (each gets a grasp constraint, off at the start, and the fingers' contact bit); ``latches``
    the tool joints a plan may turn (each gets a latch, a joint equality holding it at 0 from the reset until a
    grasp releases it, and again where the arm leaves it)."""
    model = robot_mjcf()
    model.model = name
    mount = root.worldbody.add("site", name=f"{name}_mount", pos=base_pos, quat=assets.yaw_quat(base_yaw),
                               size=(0.01,), group=PM.PANDA_SITE_GROUP)
    mount.attach(model)
    hand = model.find("body", PM.HAND_LINK)
    for b in bodies:
        el = root.find("body", b)
        if el is None:
            raise KeyError(f"robot_bodies names {b!r}, which the scene lacks")
        for g in el.find_all("geom"):
            ct = 1 if g.contype is None else int(g.contype)
            ca = 1 if g.conaffinity is None else int(g.conaffinity)
            if ct == 0 and ca == 0:
                continue              # visual-only parts (rods, stands) stay out of reach of the fingers too
            g.conaffinity = ca | ROBOT_BIT      # the fingers touch it; nothing else changes
        root.equality.add("connect", name=f"grasp_{b}", body1=hand, body2=el, anchor=(0, 0, PM.GRASP_DEPTH),
                          active=False, solref=CONSTRAINT_SOLREF)
    for j in latches:
        root.equality.add("joint", name=f"latch_{j}", joint1=j, active=True, polycoef=(0, 0, 0, 0, 0),
                          solref=CONSTRAINT_SOLREF)
    return model
