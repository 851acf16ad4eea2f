"""What the skill scenes share: the data layout of a skill (:class:`DataSpec`), the data set (:class:`SkillData`)
and the compiled-scene wrapper (:class:`Scene`) with the named access that :class:`phyplan_envs.tools.Pendulum` uses.
"""
from __future__ import annotations

from .. import _gl  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

from dataclasses import dataclass, field

import mujoco
import numpy as np

from .. import assets


@dataclass(frozen=True)
class DataSpec:
    """What one skill scene records: its data's columns (names and units, in order) and the domain it samples.

    These are facts about the simulation (what the scene measures and over which initial conditions), so they live
    here with the scene; the model-facing contract built on them (which input is the query time, the skill's
    names) is :class:`phyplan_agents.skills.contract.SkillSpec`.

    Attributes:
        skill: ``swing``, ``slide``, ``throw``, ``hit`` or ``bounce``.
        inputs, outputs: column names, in order (the query time ``t`` is the last input of the time-parameterised
            skills).
        input_units, output_units: one unit string per name.
        ranges: (low, high) per input: the domain the inputs are drawn from uniformly.
        doc: what the scene is.
    """

    skill: str
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    input_units: tuple[str, ...]
    output_units: tuple[str, ...]
    ranges: tuple[tuple[float, float], ...]
    doc: str


DATA_SPECS: dict[str, DataSpec] = {}
"""Skill name -> its :class:`DataSpec`; :mod:`phyplan_envs.skill_scenes` fills it as it imports the skill modules
(it is that package's ``DATA_SPECS``)."""


@dataclass
class SkillData:
    """A data set of one skill: ``inputs`` (N, n_in) and ``outputs`` (N, n_out), float64, physical units.

    ``extras`` holds further per-sample measurements (e.g. the hit's physical separation speed) that the skill
    models do not use. Row ``i`` is sample ``i`` of the seeded stream, so ``head(n)`` of a larger set is the set
    that ``generate(skill, n, seed)`` makes.
    """

    skill: str
    inputs: np.ndarray
    outputs: np.ndarray
    seed: int
    extras: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def spec(self) -> DataSpec:
        """The :class:`DataSpec` of the skill (column names, units, sampled domain)."""
        return DATA_SPECS[self.skill]

    def __len__(self) -> int:
        return int(self.inputs.shape[0])

    def head(self, n: int) -> "SkillData":
        """The first ``n`` samples."""
        if not 0 < n <= len(self):
            raise ValueError(f"head({n}): the {self.skill} set has {len(self)} samples")
        return SkillData(self.skill, self.inputs[:n].copy(), self.outputs[:n].copy(), self.seed,
                         {k: v[:n].copy() for k, v in self.extras.items()})


class Scene:
    """A compiled skill scene with the named access that :class:`phyplan_envs.tools.Pendulum` uses."""

    def __init__(self, model: mujoco.MjModel):
        self.model = model
        self.data = mujoco.MjData(model)

    @classmethod
    def from_root(cls, root) -> "Scene":
        return cls(mujoco.MjModel.from_xml_string(root.to_xml_string(), root.get_assets()))

    def _id(self, kind, name: str) -> int:
        i = mujoco.mj_name2id(self.model, kind, name)
        if i < 0:
            raise KeyError(f"no {kind.name} named {name!r} in the skill scene")
        return i

    def body_id(self, name: str) -> int:
        return self._id(mujoco.mjtObj.mjOBJ_BODY, name)

    def geom_id(self, name: str) -> int:
        return self._id(mujoco.mjtObj.mjOBJ_GEOM, name)

    def joint_qpos_adr(self, name: str) -> int:
        return int(self.model.jnt_qposadr[self._id(mujoco.mjtObj.mjOBJ_JOINT, name)])

    def joint_dof_adr(self, name: str) -> int:
        return int(self.model.jnt_dofadr[self._id(mujoco.mjtObj.mjOBJ_JOINT, name)])

    def set_body_pose(self, body: int, pos, yaw: float | None = None) -> None:
        self.model.body_pos[body] = pos
        if yaw is not None:
            self.model.body_quat[body] = assets.yaw_quat(yaw)

    def touching(self, g1: int, g2: int) -> bool:
        d = self.data
        for i in range(d.ncon):
            c = d.contact[i]
            if (c.geom1 == g1 and c.geom2 == g2) or (c.geom1 == g2 and c.geom2 == g1):
                return True
        return False


def progress(n: int, desc: str, enabled: bool):
    """``range(n)``, with a tqdm progress bar if ``enabled``."""
    if not enabled:
        return range(n)
    from tqdm.auto import tqdm
    return tqdm(range(n), desc=desc, unit="sample", leave=False)


def steps(t: float) -> int:
    """The number of physics steps in ``t`` seconds."""
    return int(round(t / assets.TIMESTEP))
