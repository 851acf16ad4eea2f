"""The skill contract: what each skill model maps from and to, and the names it answers to.

A skill model (:class:`phyplan_agents.skills.SkillModel`, or any object with the same ``predict``) maps the input
columns of its skill's data to the output columns, in physical units, over the domain the data cover. The columns
and the domain are facts about the simulation that recorded the data, declared next to it
(:data:`phyplan_envs.skill_scenes.DATA_SPECS`); a :class:`SkillSpec` adds what the agents need on top:

* ``time_input``: which input is the query time ``t`` (the event queries of :mod:`phyplan_agents.phyplan.queries`
  search it inside its trained range), or ``None`` for the collision skills;
* the skills' names and the paper's aliases (``"sliding"`` for ``"slide"``, ...), looked up by :func:`skill_spec`.

The contract references the data specs rather than repeating them, so a changed domain in a scene is the
models' domain too; the data generators in :mod:`phyplan_envs.skill_scenes` never import this module.
"""
from __future__ import annotations

from dataclasses import dataclass

from phyplan_envs.skill_scenes import DATA_SPECS, DataSpec


@dataclass(frozen=True)
class SkillSpec:
    """What a skill maps from and to, in physical units, and the domain its data cover.

    Attributes:
        name: ``swing``, ``slide``, ``throw``, ``hit`` or ``bounce``.
        data: what the skill's scene records (:class:`phyplan_envs.skill_scenes.DataSpec`).
        time_input: index of the time input ``t``, or ``None`` for the collision skills.

    ``inputs``, ``outputs``, ``input_units``, ``output_units``, ``ranges`` (one (low, high) per input: the sampling
    domain of the data and the models' normalisation) and ``doc`` are the data spec's.
    """

    name: str
    data: DataSpec
    time_input: int | None

    def __post_init__(self):
        if self.data.skill != self.name:
            raise ValueError(f"skill spec {self.name!r} built on the data spec of {self.data.skill!r}")
        if self.time_input is not None and self.data.inputs[self.time_input] != "t":
            raise ValueError(f"skill {self.name!r}: input {self.time_input} is {self.data.inputs[self.time_input]!r}, "
                             f"not the query time 't'")

    @property
    def inputs(self) -> tuple[str, ...]:
        return self.data.inputs

    @property
    def outputs(self) -> tuple[str, ...]:
        return self.data.outputs

    @property
    def input_units(self) -> tuple[str, ...]:
        return self.data.input_units

    @property
    def output_units(self) -> tuple[str, ...]:
        return self.data.output_units

    @property
    def ranges(self) -> tuple[tuple[float, float], ...]:
        return self.data.ranges

    @property
    def doc(self) -> str:
        return self.data.doc


SKILLS: dict[str, SkillSpec] = {
    "swing": SkillSpec("swing", DATA_SPECS["swing"], time_input=1),
    "slide": SkillSpec("slide", DATA_SPECS["slide"], time_input=1),
    "throw": SkillSpec("throw", DATA_SPECS["throw"], time_input=2),
    "hit": SkillSpec("hit", DATA_SPECS["hit"], time_input=None),
    "bounce": SkillSpec("bounce", DATA_SPECS["bounce"], time_input=None),
    # the hidden-physics track's parameter-conditioned skills (phyplan_envs.skill_scenes.{slide,hit,bounce}_cond)
    "slide_cond": SkillSpec("slide_cond", DATA_SPECS["slide_cond"], time_input=2),
    "hit_cond": SkillSpec("hit_cond", DATA_SPECS["hit_cond"], time_input=None),
    "bounce_cond": SkillSpec("bounce_cond", DATA_SPECS["bounce_cond"], time_input=None),
    # the general-incidence bounce (any arrival into an incline; its reflection law: .bounce_law)
    "bounce_general": SkillSpec("bounce_general", DATA_SPECS["bounce_general"], time_input=None),
    "bounce_general_cond": SkillSpec("bounce_general_cond", DATA_SPECS["bounce_general_cond"], time_input=None),
    # the Paddles task's skills (phyplan_envs.skill_scenes.{wide,glide,bounce_general_low})
    "swing_wide": SkillSpec("swing_wide", DATA_SPECS["swing_wide"], time_input=1),
    "hit_wide": SkillSpec("hit_wide", DATA_SPECS["hit_wide"], time_input=None),
    "throw_wide": SkillSpec("throw_wide", DATA_SPECS["throw_wide"], time_input=2),
    "glide": SkillSpec("glide", DATA_SPECS["glide"], time_input=3),
    "bounce_general_low": SkillSpec("bounce_general_low", DATA_SPECS["bounce_general_low"], time_input=None),
    "bounce_general_low_cond": SkillSpec("bounce_general_low_cond", DATA_SPECS["bounce_general_low_cond"],
                                         time_input=None),
    # the hit's physical hand-over: the ball's free flight after the hit (phyplan_envs.skill_scenes.hit_free)
    "hit_free": SkillSpec("hit_free", DATA_SPECS["hit_free"], time_input=None),
    "hit_free_cond": SkillSpec("hit_free_cond", DATA_SPECS["hit_free_cond"], time_input=None),
    "hit_free_slow": SkillSpec("hit_free_slow", DATA_SPECS["hit_free_slow"], time_input=None),
    # the general bounce off steep faces and walls (80-90 degrees; phyplan_envs.skill_scenes.bounce_general)
    "bounce_wall": SkillSpec("bounce_wall", DATA_SPECS["bounce_wall"], time_input=None),
    "bounce_wall_cond": SkillSpec("bounce_wall_cond", DATA_SPECS["bounce_wall_cond"], time_input=None),
    # the general bounce at up to 10 m/s (balls falling through bouncing paddles; the same scene)
    "bounce_general_fast": SkillSpec("bounce_general_fast", DATA_SPECS["bounce_general_fast"], time_input=None),
    "throw_fast": SkillSpec("throw_fast", DATA_SPECS["throw_fast"], time_input=2),
    # the general bounce off faces with exact impacts (PaddlesVaried-v3; phyplan_envs.skill_scenes.bounce_exact)
    "bounce_general_exact_cond": SkillSpec("bounce_general_exact_cond", DATA_SPECS["bounce_general_exact_cond"],
                                           time_input=None),
}

ALIASES = {"swinging": "swing", "sliding": "slide", "throwing": "throw", "hitting": "hit", "bouncing": "bounce"}


def skill_spec(name: str) -> SkillSpec:
    """The :class:`SkillSpec` of a skill name (``"slide"`` or ``"sliding"``, ...); a clear error for others."""
    key = ALIASES.get(str(name).lower(), str(name).lower())
    if key not in SKILLS:
        raise ValueError(f"unknown skill {name!r}; skills: {', '.join(SKILLS)} "
                         f"(or {', '.join(ALIASES)})")
    return SKILLS[key]
