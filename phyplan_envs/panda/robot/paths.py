"""Robot mode's path planning: a plan step (:class:`Carry`) turned into joint waypoints, checked for reach.

:class:`PathPlanner` plans on the arm's warm-started IK (:class:`phyplan_envs.panda.ik.ArmIK`): each waypoint
warm-started from the previous one (so neighbouring waypoints stay on one branch of solutions); a waypoint whose
residuals exceed :data:`~phyplan_envs.panda.ik.REACH_POS` / :data:`~phyplan_envs.panda.ik.REACH_ORI` from its warm
start and from the home pose turned towards it (unless that jumps more than :data:`MAX_JOINT_JUMP` from the previous
waypoint) is out of reach (:class:`RobotFailure`). :meth:`PathPlanner.plan` plans a whole step before anything
moves: the path, then back out to the stand-off and a point above it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..ik import REACH_ORI, REACH_POS, ArmIK

MAX_JOINT_JUMP = 0.6        # rad: largest joint change between neighbouring waypoints of a path
VIA_POS_TOL = 1e-3          # m: the poses the hand passes (the carry's inner waypoints, the stand-off path) are
VIA_ORI_TOL = 1e-2          # rad: solved this close (its grasp and release poses to IK_POS_TOL / IK_ORI_TOL); the
                            # servos track them to a few mrad anyway
WAYPOINT_STEP = 0.1        # m: plans space the hand's waypoints at most this far apart
APPROACH = 0.08             # m: pre-grasp stand-off along the approach direction
VIA_HEIGHT = 0.1            # m: the hand comes down to the stand-off from this far above it
RETREAT = 0.10              # m: after the release the hand backs off this far along -approach


@dataclass
class Carry:
    """One pick-carry-release of the plan.

    Attributes:
        body: name of the body grasped (it must be listed in the env's ``robot_bodies``).
        half_width: half the body's width between the fingers (m).
        path: the grasp site's world poses ``(position, rotation 3x3, z = approach, y = closing axis)``: grasp
            pose first, release pose last. The body point at the first position (before anything moves) is the
            held point; closed-loop correction puts it at the last position.
        latch: a tool joint the arm turns (free while held, locked where the arm leaves it), or ``None``.
        retreat: how far the hand backs off along -approach after the release (m; not after the last step).
        alternatives: other paths for the same step, tried in order if ``path`` is out of reach.
        fingers_only: until the release the body touches only the fingers (the pendulum bob, which hangs 0.5 mm
            behind the object at rest: a grasp there would nudge the object); its own contacts are back from the
            release on.
        fixed_start: the step picks the body where it rests at reset, the same for every action (the Bounce ball on
            its table, the Bridge plank at its rest yaw): the arm then waits between attempts at this step's
            stand-off (:meth:`~phyplan_envs.panda.robot.RobotArm.ready_above`) instead of above it.
        hold_tol: closed-loop release accuracy of the held point (m); ``None``: the controller's ``HOLD_TOL``.
    """

    body: str
    half_width: float
    path: Sequence[tuple[np.ndarray, np.ndarray]]
    latch: str | None = None
    retreat: float = RETREAT
    alternatives: Sequence[Sequence[tuple[np.ndarray, np.ndarray]]] = ()
    fingers_only: bool = False
    fixed_start: bool = False
    hold_tol: float | None = None


class RobotFailure(Exception):
    """The plan cannot be carried out (out of reach, failed grasp); the attempt goes on without it."""


class PathPlanner:
    """Joint paths of the arm whose warm-started IK is ``ik`` (an :class:`~phyplan_envs.panda.ik.ArmIK`)."""

    def __init__(self, ik: ArmIK):
        self.ik = ik

    def closest_approach(self, qs, point, samples: int = 10) -> float:
        """How near the grasp site comes to world ``point`` along the joint-space polyline ``qs`` (sampled)."""
        best = math.inf
        point = np.asarray(point, dtype=np.float64)
        for a, b in zip(qs[:-1], qs[1:]):
            a, b = np.asarray(a), np.asarray(b)
            for k in range(samples + 1):
                d = self.ik.forward(a + (b - a) * (k / samples))[0] - point
                best = min(best, math.sqrt(d @ d))
        return best

    def joint_path(self, q0, poses, what: str, exact=()) -> list[np.ndarray]:
        """Warm-started IK through ``poses`` (world); :class:`RobotFailure` if one is out of reach. The poses whose
        indices are in ``exact`` are solved to IK_POS_TOL / IK_ORI_TOL, the others (points the hand passes) to
        VIA_POS_TOL / VIA_ORI_TOL."""
        qs, q = [], np.asarray(q0, dtype=np.float64)
        for k, (pos, rot) in enumerate(poses):
            q_prev = q
            tol = {} if k in exact else {"pos_tol": VIA_POS_TOL, "ori_tol": VIA_ORI_TOL}
            q, pe, oe = self.ik.solve(q_prev, pos, rot, **tol)
            if pe > REACH_POS or oe > REACH_ORI:     # a local minimum of the warm start: from the home pose again
                q2, pe2, oe2 = self.ik.solve(self.ik.home_towards(pos), pos, rot, **tol)
                if pe2 <= REACH_POS and oe2 <= REACH_ORI and np.max(np.abs(q2 - q_prev)) < MAX_JOINT_JUMP:
                    q, pe, oe = q2, pe2, oe2
            if pe > REACH_POS or oe > REACH_ORI:
                raise RobotFailure(f"unreachable: {what} waypoint {k + 1}/{len(poses)} at "
                                   f"({pos[0]:.3f}, {pos[1]:.3f}, {pos[2]:.3f}) m misses by {pe * 1e3:.1f} mm, "
                                   f"{math.degrees(oe):.1f} deg")
            qs.append(q)
        return qs

    def plan(self, step: Carry, q_from=None):
        """Joint waypoints for the first of ``step.path`` and ``step.alternatives`` that the arm reaches all along
        (nothing moves before): the grasp warm-started from ``q_from`` (the arm's joints now: the grasp nearest them,
        so the arm does not swing its wrist or elbow around on the way; the controller passes its ready pose for a
        plan's first step) or, without it or for a ``fixed_start`` step (whose stand-off is the ready pose itself),
        from the home pose turned towards it; then warm-started along the path and back out to the pre-grasp
        stand-off. The grasp and release poses are solved to IK_POS_TOL / IK_ORI_TOL, the rest to VIA_POS_TOL /
        VIA_ORI_TOL; if the grasp nearest ``q_from`` does not reach along the path, the home pose's is tried."""
        first = None
        for cand in [step.path, *step.alternatives]:
            path = [(np.asarray(p, dtype=np.float64), np.asarray(r, dtype=np.float64)) for p, r in cand]
            grasp_pos, grasp_rot = path[0]
            home = self.ik.home_towards(grasp_pos)
            starts = [home] if q_from is None or step.fixed_start else [q_from, home]
            try:
                q_path = self._carry_path(path, starts)
                stand_off = [(grasp_pos - f * APPROACH * grasp_rot[:, 2], grasp_rot) for f in (0.25, 0.5, 0.75, 1.0)]
                via = (stand_off[-1][0] + np.array([0.0, 0.0, VIA_HEIGHT]), grasp_rot)
                q_app = self.joint_path(q_path[0], stand_off + [via], "pre-grasp")[::-1]
            except RobotFailure as e:
                first = first or e
                continue
            return path, q_app, q_path[0], q_path[1:]
        raise first

    def _carry_path(self, path, starts) -> list[np.ndarray]:
        """The joint path along ``path`` from the first of ``starts`` that reaches all along it (grasp and release
        solved exactly); the last start's :class:`RobotFailure` if none does."""
        for k, q0 in enumerate(starts):
            try:
                return self.joint_path(q0, path, "carry", exact=(0, len(path) - 1))
            except RobotFailure:
                if k == len(starts) - 1:
                    raise
