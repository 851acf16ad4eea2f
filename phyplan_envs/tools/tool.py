"""The tool interface (:class:`Tool`) and a task's assembly of tools (:class:`Assembly`)."""
from __future__ import annotations

from typing import Sequence

import numpy as np

from ..description import SceneDescription
from ..spaces import ActionDim


class Tool:
    """A piece of a task scene; the defaults do nothing (a support that only stands there)."""

    dims: tuple[ActionDim, ...] = ()            # the action dimensions the tool applies (names, in its order)
    robot_bodies: tuple[str, ...] = ()          # robot mode: the bodies of the tool the arm grasps
    robot_latches: tuple[str, ...] = ()         # robot mode: the tool joints the arm turns (see robot_scene)
    slots: np.ndarray | None = None             # where the tool's dims sit in the task's action (the Assembly's)

    def build(self, root) -> None:
        raise NotImplementedError(f"{type(self).__name__} must implement build")

    def robot_scene(self, root) -> None:
        """Robot mode: the changes to the scene the arm needs; default none."""

    def bind(self, scene) -> None:
        self.scene = scene

    def reset(self) -> None:
        """The tool's pose between attempts (called at every reset, after the goal is placed)."""

    def apply(self, values: np.ndarray) -> None:
        """Kinematic mode: set the tool for its action values."""

    def robot_steps(self, values: np.ndarray) -> list:
        """Robot mode: set what the arm does not carry and return the arm's steps for the values; default none."""
        return []

    def describe(self, values: np.ndarray):
        """The tool's part of the scene description (:mod:`phyplan_envs.description`) for the tool's action values
        ``values`` (N, len(dims)): a part, a list of parts or ``None`` (default: nothing the object meets)."""
        return None


class Assembly:
    """A task's tools in build order, and the map of its action onto them: every action dimension (``dims``) is
    applied by exactly one tool (an assembly error otherwise); ``hand`` is the tool the Panda's hand holds."""

    def __init__(self, tools: Sequence[Tool], dims: Sequence[ActionDim], hand: Tool | None = None):
        names = [d.name for d in dims]
        claimed = [d.name for t in tools for d in t.dims]
        if sorted(claimed) != sorted(names):
            raise RuntimeError(f"the tools apply the action dimensions {claimed}, the task declares {names}")
        for t in tools:
            t.slots = np.array([names.index(d.name) for d in t.dims], dtype=np.int64)
        self.tools, self.hand = list(tools), hand
        self.robot_bodies = tuple(b for t in tools for b in t.robot_bodies)    # in the tools' order
        self.robot_latches = tuple(j for t in tools for j in t.robot_latches)

    def __iter__(self):
        return iter(self.tools)

    def build(self, root) -> None:
        for t in self.tools:
            t.build(root)

    def robot_scene(self, root) -> None:
        for t in self.tools:
            t.robot_scene(root)

    def bind(self, scene) -> None:
        for t in self.tools:
            t.bind(scene)

    def reset(self) -> None:
        for t in self.tools:
            t.reset()

    def apply(self, action) -> None:
        """Every tool set for its values of ``action`` (float64), in build order."""
        for t in self.tools:
            t.apply(action[t.slots])

    def robot_steps(self, action) -> list:
        return [step for t in self.tools for step in t.robot_steps(action[t.slots])]

    def describe(self, actions, **scene) -> SceneDescription:
        """The scene description for ``actions`` (N, A) float64 (:mod:`phyplan_envs.description`); ``scene``: the
        :class:`~phyplan_envs.description.SceneDescription` fields the task gives (landing height, end rule)."""
        d = SceneDescription(n=len(actions), object=None, **scene)
        for t in self.tools:
            d.add(t.describe(actions[:, t.slots]))
        return d

    def hand_target(self, action) -> np.ndarray:
        return self.hand.hand_target(None if action is None else action[self.hand.slots])

    def hand_axes(self, action):
        axes = getattr(self.hand, "hand_axes", None)
        return None if axes is None else axes(None if action is None else action[self.hand.slots])
