"""Robot mode's controller: the articulated Panda (:mod:`.model`) executes an attempt's plan.

A plan is a list of :class:`Carry` steps (built by the task's ``robot_plan``, see :mod:`.plans`). :class:`RobotArm`
mixes in its servo motion (:mod:`.motion`), its measurements (:mod:`.sensing`) and its scene switches
(:mod:`.switches`) and plans with :class:`.paths.PathPlanner`. For each step, :meth:`RobotArm.execute`:

1. plans first, so that nothing moves if the step cannot be done: the hand's world path (grasp pose first, release
   pose last, plus a stand-off before the grasp and a point above the stand-off) becomes joint waypoints by mink
   IK, each waypoint warm-started from the previous one (so the arm stays on one branch; a plan's first grasp from
   the arm's ready pose, so that it takes the grasp nearest it); a waypoint whose residual exceeds
   :data:`~phyplan_envs.panda.ik.REACH_POS` / :data:`~phyplan_envs.panda.ik.REACH_ORI` makes the step unreachable
   (the step's alternative paths, e.g. the other finger order, are tried next);
2. tracks the waypoints with the position actuators (minimum-jerk timing by hand path length and joint travel, the
   set-point led by each servo's lag damping/kp), to the point above the stand-off keeping the hand
   :data:`.motion.VIA_CLEARANCE` from the grasp point (up, across and down where the joint-space move would dip
   closer) and until the arm has caught up to :data:`VIA_LAG`, coming down to the stand-off and slowly in (an arm
   that waits at the stand-off, :meth:`RobotArm.ready_above` for a step that starts alike for every action, goes
   straight in);
3. closes the fingers until both touch the body (else: grasp failed), then switches the grasp on: a point
   constraint (MuJoCo ``connect``) between the grasp site and the body, so the body may turn between the pads
   (the pendulum bob about its hinge, the plank about its pivot) but not leave them; while the constraint carries
   the body the pads' contacts are off and the fingers hold their width (the pads touch the body at the grasp
   and the release; carrying, their contact checks were a large part of the set-up's cost: docs/robot.md);
4. carries the body along the path, then corrects the release pose in closed loop until the planned grasp point
   of the body is within :data:`HOLD_TOL` of the release position and still (each correction moves the grasp site
   from where it is by the held point's error: :meth:`RobotArm._site_target`);
5. opens the fingers (pads on again); when they are wide open and the hand is still, the grasp constraint switches off:
   the release comes from the gripper opening, nothing is teleported. A latched tool (the Bridge plank's pivot)
   is locked where the arm left it and the hand backs off before the next step; after the last step the hand
   stays where it let go while the attempt goes on.

The set-up is stepped at :data:`SETUP_DT`; the flight that follows at the scene's own time step, without the arm
(:mod:`.flight`). The object at rest (``attach_robot``'s ``hold``: the object when the arm does not carry it) is frozen
during the set-up (it touches nothing and its weight is compensated) and free from the last release on: MuJoCo's resting
contact would creep a puck by ~0.03 mm over the set-up, which the kinematic mode (released at once) never sees. Failures
never raise: :class:`RobotReport` says what failed, the arm opens and stops, and the attempt goes on with the scene as
it is (an unreleased tool simply stays put).
"""
from __future__ import annotations

from ... import _gl  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

from dataclasses import dataclass, field
from typing import Sequence

import mujoco
import numpy as np
from dm_control import mjcf

from .. import model as PM
from ..ik import HOME_Q, REACH_ORI, REACH_POS, ArmIK
from .model import ROBOT_BIT, add_robot
from .motion import HAND_SPEED, ArmMotion
from .paths import APPROACH, VIA_HEIGHT, Carry, PathPlanner, RobotFailure
from .sensing import ArmSensing
from .switches import LATCHED_ARMATURE, SceneSwitches

SETUP_DT = 0.012            # s: physics step of the set-up (the flight keeps the scene's own step; the servos get a
                            # set-point every CTRL_STEPS of it: .motion)
VIA_LAG = 0.02              # rad: the move to a via point ends when every arm joint is this close to its set-point
                            # (the way down then starts on course; other moves: TRACK_TOL) or after TRACK_TIMEOUT
APPROACH_SPEED = 0.15       # m/s: average hand speed over the stand-off
SQUEEZE = 0.004             # m: the fingers are commanded this far inside the body's half width
CLEAR = 0.003               # m: the grasp lets go once both fingers are this far outside the half width (and
                            # wide open, OPEN_SLACK) ...
RELEASE_SPEED = 1e-5        # m/s: ... and the held point is this slow ...
RELEASE_WAIT = 0.5          # s: ... or this long after the fingers cleared it
HOLD_TOL = 3e-6             # m: closed-loop release accuracy of the held point, measured when it is slower than
                            # HOLD_SPEED or than its error over CREEP_TIME (.sensing) ...
SETTLE_WAIT = 0.3           # s: ... or after this long
CORRECTION_TIME = 0.05      # s: shortest corrective move
CORRECTION_IK_TOL = 3e-7    # m: a corrective move's IK solves this close (the plan's waypoints: IK_POS_TOL, 0.1 mm)
MAX_CORRECTIONS = 6
CORRECTION_IK_ITERS = 20   # a corrective solve (a few um from the last) stops after this many iterations ...
CORRECTION_REACH = 1e-5     # m: ... and one that ends farther than this (and than half the error it corrects) from
                            # its target is at the edge of the reach
GRIP_TIMEOUT = 0.4          # s
OPEN_TIMEOUT = 0.4          # s
OPEN_SLACK = 1e-3           # m: the grasp lets go only when the fingers are this close to wide open (so that they
                            # do not move after the release, and the flight can run without the arm: see .flight)
RELEASE_MISS = 1e-3         # m: a release farther than this from its target is reported (robot_ok False)
FINGER_OPEN = PM.FINGER_OPEN


@dataclass
class RobotReport:
    ok: bool = True
    reason: str = ""
    setup_time: float = 0.0          # simulated seconds from the start of the attempt to the last release
    hold_error: float = 0.0          # m: distance of the held point from its target at the release
    release_speed: float = 0.0       # m/s: speed of the held point at the release
    ik_solves: int = 0
    log: list = field(default_factory=list)

    def info(self) -> dict:
        """The ``info`` entries of a robot-mode step."""
        return {"robot_ok": self.ok, "robot_reason": self.reason, "robot_setup_time": self.setup_time,
                "robot_hold_error": self.hold_error, "robot_release_speed": self.release_speed,
                "robot_ik_solves": self.ik_solves}


# ================================================================================================= the arm
class RobotArm(ArmMotion, ArmSensing, SceneSwitches):
    """The articulated Panda attached to one task scene (see :func:`attach_robot`)."""

    def __init__(self, model: mjcf.RootElement, base_pos, base_yaw: float, bodies: Sequence[str]):
        self.mjcf_model = model
        self.hold_name: str | None = None    # the object frozen during the set-up (attach_robot's ``hold``)
        self.base_pos = np.asarray(base_pos, dtype=np.float64)
        self.base_yaw = float(base_yaw)
        self.ik = ArmIK(base_pos, base_yaw)
        self.paths = PathPlanner(self.ik)
        self.bodies = tuple(bodies)
        self.ready_q = np.array(HOME_Q, dtype=np.float64)
        self.mj_step = mujoco.mj_step     # the controller's physics step (the stage timer times it)

    # ------------------------------------------------------------------------------------------------ binding
    def bind(self, physics: mjcf.Physics) -> None:
        m = self.model = physics.model.ptr
        self.data = physics.data.ptr
        name = self.mjcf_model.model

        def jid(j):
            return mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, f"{name}/{j}")
        arm = [jid(j) for j in PM.ARM_JOINTS]
        fingers = [jid(f"robot:panda0_finger_joint{i}") for i in (1, 2)]
        self._arm_qpos = np.array([m.jnt_qposadr[j] for j in arm])
        self._arm_qvel = np.array([m.jnt_dofadr[j] for j in arm])
        self._fing_qpos = np.array([m.jnt_qposadr[j] for j in fingers])
        self._fing_qvel = np.array([m.jnt_dofadr[j] for j in fingers])
        acts = [int(np.flatnonzero(m.actuator_trnid[:, 0] == j)[0]) for j in arm + fingers]
        self._arm_act = np.array(acts[:7])
        self._fing_act = np.array(acts[7:])
        # consecutive indices as slices (views, not copies: read at every control step)
        for attr in ("_arm_qpos", "_arm_qvel", "_fing_qpos", "_fing_qvel", "_arm_act", "_fing_act"):
            idx = getattr(self, attr)
            if np.array_equal(idx, np.arange(idx[0], idx[0] + len(idx))):
                setattr(self, attr, slice(int(idx[0]), int(idx[0]) + len(idx)))
        self._site = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, f"{name}/{PM.GRASP_SITE}")
        self._hand = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, f"{name}/{PM.HAND_LINK}")
        self.finger_bodies = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, f"{name}/{b}")
                               for b in PM.FINGER_BODIES]
        self._grasps = {}
        for b in self.bodies:
            bid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, b)
            eq = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_EQUALITY, f"grasp_{b}")
            self._grasps[b] = (bid, eq)
        # a grasped body with its descendants (a tool's parts may sit in child bodies)
        self._subtree = {bid: {i for i in range(m.nbody) if self.descends(i, bid)} for bid, _ in self._grasps.values()}
        self._hold = -1 if self.hold_name is None else mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, self.hold_name)
        self._held_frozen = False
        self._free_bodies = [int(m.jnt_bodyid[j]) for j in range(m.njnt) if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE]
        self._contype0 = m.geom_contype.copy()
        fingers = set(self.finger_bodies)
        self._pad_geoms = np.array([g for g in range(m.ngeom) if m.geom_bodyid[g] in fingers and m.geom_contype[g]])
        self._gravcomp0 = m.body_gravcomp.copy()
        self._armature0 = m.dof_armature.copy()
        self._conaffinity0 = m.geom_conaffinity.copy()
        kp = m.actuator_gainprm[self._arm_act, 0]
        self._lag = m.dof_damping[self._arm_qvel] / kp        # s: the servo's first-order time constant
        self.arm_joint_names = tuple(f"{name}/{j}" for j in PM.ARM_JOINTS)

    # ------------------------------------------------------------------------------------------------ state
    def ready_towards(self, point) -> None:
        """The pose between attempts: the home pose with the base joint turned towards world ``point``."""
        self.ready_q = self.ik.home_towards(point)

    def ready_above(self, step: Carry) -> bool:
        """The pose between attempts: above the stand-off of ``step`` (a typical first step), so that an attempt
        starts close to its work, or at the stand-off itself if ``step.fixed_start`` (every attempt's first step
        starts there: :meth:`_carry` then goes straight in); False (and the pose unchanged) if the arm cannot
        reach it."""
        try:
            _, q_app, _, _ = self.paths.plan(step)
        except RobotFailure:
            return False
        self.ready_q = np.asarray(q_app[1 if step.fixed_start else 0], dtype=np.float64).copy()
        return True

    def reset(self) -> None:
        """Arm at its ready pose, fingers open, servos holding there, grasps off, latches holding their joints at 0."""
        d = self.data
        d.qpos[self._arm_qpos] = self.ready_q
        d.qpos[self._fing_qpos] = FINGER_OPEN
        d.ctrl[self._arm_act] = self.ready_q
        d.ctrl[self._fing_act] = FINGER_OPEN
        self._hold_off()
        self._restore_contacts()
        self.model.dof_armature[:] = self._armature0
        for i in range(self.model.neq):          # latched tools: locked and stiff from the reset on
            if self.model.eq_type[i] == mujoco.mjtEq.mjEQ_JOINT:
                self.model.dof_armature[self.model.jnt_dofadr[self.model.eq_obj1id[i]]] = LATCHED_ARMATURE
        d.eq_active[:] = self.model.eq_active0     # grasps off, latches on at the tools' reset pose (joint 0)
        for i in range(self.model.neq):
            if self.model.eq_type[i] == mujoco.mjtEq.mjEQ_JOINT:
                self.model.eq_data[i, :] = 0.0
        self.q_cmd = self.ready_q.copy()

    # ------------------------------------------------------------------------------------------------ the plan
    def execute(self, plan: Sequence[Carry], on_frame=None) -> RobotReport:
        """Carry out ``plan``; never raises for an infeasible plan: the report says what failed (the arm then stops
        where it is, opens, and the attempt goes on with the scene as it is)."""
        self.report = RobotReport()
        solves0 = self.ik.solves
        self.clock = 0.0
        self.on_frame = on_frame
        m = self.model
        flight_dt = m.opt.timestep
        self._hold_on()
        m.opt.timestep = SETUP_DT          # the set-up is stepped coarser; the flight at the scene's own step
        try:
            for k, step in enumerate(plan):
                self._carry(step, first=k == 0, last=k == len(plan) - 1)
        except RobotFailure as e:
            self.report.ok = False
            self.report.reason = str(e)
            for b, (bid, eq) in self._grasps.items():
                self._grasp_off(eq, bid)
            self._restore_contacts()
            self.data.ctrl[self._fing_act] = FINGER_OPEN
            mujoco.mj_forward(self.model, self.data)
        finally:
            m.opt.timestep = flight_dt
            self._hold_off()               # the object is free from the (last) release on
        self.report.ik_solves = self.ik.solves - solves0
        self.report.setup_time = self.clock
        return self.report

    def _carry(self, step: Carry, first: bool = True, last: bool = True) -> None:
        m, d = self.model, self.data
        if step.body not in self._grasps:
            raise ValueError(f"robot plan grasps {step.body!r}, not among the env's robot_bodies {self.bodies}")
        body, eq = self._grasps[step.body]
        path, q_app, q_grasp, q_carry = self.paths.plan(step, self.q_cmd if first else None)
        grasp_pos, grasp_rot = path[0]
        rel_pos, rel_rot = path[-1]
        back = (rel_pos - step.retreat * rel_rot[:, 2], rel_rot)
        pre = (grasp_pos - APPROACH * grasp_rot[:, 2], grasp_rot)
        # the held point: the planned grasp point in the body's frame, taken before anything moves (the plan puts
        # it at the release position)
        mujoco.mj_kinematics(m, d)
        local = d.xmat[body].reshape(3, 3).T @ (grasp_pos - d.xpos[body])
        if step.fingers_only:
            parts = np.isin(m.geom_bodyid, list(self._subtree[body]))
            geoms = np.flatnonzero(parts & (self._conaffinity0 & ROBOT_BIT > 0))
            m.geom_contype[geoms] = 0
            m.geom_conaffinity[geoms] = ROBOT_BIT
        # reach the body
        # to the stand-off through a point above it (unless the arm waits at this very stand-off: ready_above),
        # then slowly in (the fingers pass close to the body)
        if not np.array_equal(self.q_cmd, q_app[1]):
            # the arm catches up with the set-point above the stand-off, to VIA_LAG (a long move's joints lag by up to
            # ~1.7 rad at their force limits, and a lagging arm's way down could sweep the body)
            self.move(self._clear_way(q_app[0], grasp_pos), float(np.linalg.norm(pre[0] - self.site_pose()[0]))
                      + VIA_HEIGHT, settle=VIA_LAG)
            self.move([q_app[1]], VIA_HEIGHT)
        self.move(q_app[2:] + [q_grasp], APPROACH * HAND_SPEED / APPROACH_SPEED)
        # close on it
        d.ctrl[self._fing_act] = max(0.0, step.half_width - SQUEEZE)
        self._run(GRIP_TIMEOUT, None, until=lambda: self._touching(body))
        if not self._touching(body):
            raise RobotFailure(f"grasp failed: the fingers closed to {self.fingers().mean() * 1e3:.1f} mm "
                               f"without both touching {step.body!r}")
        self._run(0.03, None)
        self._grasp_on(eq, body)
        self._pads(False)
        if step.latch is not None:          # the tool's pivot turns while the arm holds it
            self.data.eq_active[self._latch_id(step.latch)] = 0
            j = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, step.latch)
            m.dof_armature[m.jnt_dofadr[j]] = self._armature0[m.jnt_dofadr[j]]
        # carry along the path
        length = sum(float(np.linalg.norm(path[i + 1][0] - path[i][0])) for i in range(len(path) - 1))
        self.move(q_carry, length)
        # closed-loop correction of the release pose
        target = rel_pos
        q = q_carry[-1] if q_carry else q_grasp
        for it in range(MAX_CORRECTIONS + 1):
            self._run(SETTLE_WAIT, None, until=lambda: self._settled(body, local, target))
            p, v = self._body_point(body, local)
            err = target - p
            if np.linalg.norm(err) < (HOLD_TOL if step.hold_tol is None else step.hold_tol):
                break
            if it == MAX_CORRECTIONS:
                break
            cmd = self._site_target(eq, body, err)
            q_new, pe, oe = self.ik.solve(q, cmd, rel_rot, pos_tol=CORRECTION_IK_TOL, iters=CORRECTION_IK_ITERS)
            if pe > max(CORRECTION_REACH, 0.5 * float(np.linalg.norm(err))) or oe > REACH_ORI:
                break     # the hand cannot get even halfway there: at the edge of the reach, release from here
            q = q_new
            self.move([q], float(np.linalg.norm(err)), min_time=CORRECTION_TIME)
        # open; the grasp lets go when both fingers have cleared the body
        self._pads(True)
        d.ctrl[self._fing_act] = FINGER_OPEN
        opened = max(step.half_width + CLEAR, FINGER_OPEN - OPEN_SLACK)
        self._run(OPEN_TIMEOUT, None, until=lambda: bool(np.all(self.fingers() > opened)))
        # the fingers are off the body; the grasp constraint lets go once the hand is still again
        self._run(RELEASE_WAIT, None, until=lambda: self._held_still(body, local, RELEASE_SPEED))
        p, v = self._body_point(body, local)
        self.report.hold_error = float(np.linalg.norm(target - p))
        self.report.release_speed = float(np.linalg.norm(v))
        if self.report.hold_error > RELEASE_MISS and self.report.ok:
            self.report.ok = False
            self.report.reason = (f"inaccurate release: {step.body!r} let go {self.report.hold_error * 1e3:.1f} mm "
                                  "from its release point (at the edge of the reach)")
        self._grasp_off(eq, body)
        self._restore_contacts()
        if step.latch is not None:
            self._latch(step.latch)
        self.report.log.append((step.body, self.clock, self.report.hold_error, self.report.release_speed))
        if not last:   # back off along -approach before the next step (after the last one the hand stays still)
            q_back, pe, oe = self.ik.solve(q, *back)
            if pe < REACH_POS and oe < REACH_ORI:
                self.move([q_back], step.retreat, settle=False)     # the next step's move follows at once


def attach_robot(root: mjcf.RootElement, base_pos, base_yaw: float, bodies: Sequence[str] = (),
                 latches: Sequence[str] = (), hold: str | None = None, name: str = "panda") -> RobotArm:
    """Attach the articulated Panda to ``root`` (see :func:`.model.add_robot`); bind the returned arm to the
    compiled physics with :meth:`RobotArm.bind`."""
    model = add_robot(root, base_pos, base_yaw, bodies, latches, name)
    arm = RobotArm(model, base_pos, base_yaw, bodies)
    arm.hold_name = hold
    return arm
