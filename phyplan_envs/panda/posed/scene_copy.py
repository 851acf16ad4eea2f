"""The posed arm's scene copy of the Panda: flat visual mesh geoms, no bodies, joints or contacts.

:func:`panda_mjcf` is the visual-only copy that :func:`phyplan_envs.panda.posed.posing.attach_panda` puts into a task
scene, read once per process from gymnasium-robotics' Franka files (:func:`phyplan_envs.panda.model.franka_assets_dir`):
every visual mesh geom of the chain (collision meshes and the finger collision capsules dropped) sits flat in the
copy's root at its pose in its own link's frame, ``contype=conaffinity=0``, in geom group
:data:`~phyplan_envs.panda.model.PANDA_GEOM_GROUP`, plus the grasp site.
"""
from __future__ import annotations

from ... import _gl  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

import functools
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np
from dm_control import mjcf

from ..model import (ARM_RGBA, FINGER_BODIES, GRASP_DEPTH, GRASP_QUAT, GRASP_SITE, HAND_RGBA, PANDA_GEOM_GROUP,
                     PANDA_SITE_GROUP, _chain_copy, _fragments, franka_assets_dir)


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
