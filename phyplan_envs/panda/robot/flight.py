"""Robot mode's flight without the arm: after the last release the arm stands still and can touch nothing but the
tools it grasps, so the flight is simulated in the kinematic-mode scene of the same task (no arm in the model).

:class:`ArmFreeFlight` gets what it needs passed in: a kinematic twin of the robot-mode env (the env builds it: same
class and arguments, ``robot=None``, without the visual Panda, which changes no outcome; see
:meth:`phyplan_envs.base.PhyPlanEnv.kinematic_twin`), the arm (its scene, finger bodies and openings) and the bodies
it may grasp. At every reset the twin is put at the start of the same context (``twin.start_state``: a varied task's
hidden values passed to the reset included); after the set-up the released state is copied over: every joint of the
twin (the object, the pendulum, the ball) from the robot scene's joint of the same name, the pose of every static
body (the pendulum rig, the wedge, the goal) from the robot scene's model, and the pose of a body that is jointed
only in robot mode (the Bridge plank on its pivot, latched where the arm left it) from its world pose there. The
twin's end rule (:func:`phyplan_envs.end_rule.simulate_until_end`: the kinematic mode's step and chunking, with the
guard below as its ``watch``) then runs the flight, so it costs what a kinematic flight costs, and the final state is
copied back into the robot scene.

The guard. In the robot scene the arm's links collide with nothing and its finger pads only with the bodies a plan
grasps (:mod:`.model`); the grasp lets go only when the fingers are wide open (so the arm does not move
after the release). The flight without the arm is therefore the flight with it unless a graspable body comes near
the pads, which the guard checks during the twin's flight: at a check, each moving graspable geom's distance from
the pads is bounded (bounding spheres; ``mj_geomDistance`` in a scratch copy of the robot scene for pads nearer
than :data:`GUARD_FAR`) and the next check is scheduled while the geom, moving at :data:`GUARD_SPEEDUP` times its
surface speed since the last check and accelerating at :data:`GUARD_ACCEL`, cannot have crossed that distance less
:data:`GUARD_MARGIN` (at least every :data:`GUARD_SKIP` chunks of 5 ms). A latched tool that stays put (the plank)
is checked once, at the release. If the guard trips, the twin's flight is dropped and the flight is simulated
again in the robot scene, arm and all, from the untouched released state. ``info["robot_arm_free"]`` says which
flight the attempt used.

Videos: :meth:`ArmFreeFlight.replay` draws the twin's flight in the robot scene with the arm at its last pose.
"""
from __future__ import annotations

from ... import _gl  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

import math

import mujoco
import numpy as np

from ...end_rule import simulate_until_end
from ...video import step_and_draw
from .. import model as PM

GUARD_MARGIN = 0.002        # m: a graspable body must stay this far from the finger pads ...
GUARD_SPEEDUP = 2.0         # ... when moving at up to this times its speed since the last check ...
GUARD_ACCEL = 3 * 9.81      # ... accelerating at this (m/s^2) ...
GUARD_SKIP = 20             # ... until the next check, at most this many chunks (100 ms) later
GUARD_FAR = 0.02            # m: exact distances are taken up to this far
_STATE = mujoco.mjtState.mjSTATE_INTEGRATION
_NQ = {int(mujoco.mjtJoint.mjJNT_FREE): (7, 6), int(mujoco.mjtJoint.mjJNT_BALL): (4, 3),
       int(mujoco.mjtJoint.mjJNT_SLIDE): (1, 1), int(mujoco.mjtJoint.mjJNT_HINGE): (1, 1)}


def _name(m, kind, i) -> str:
    return mujoco.mj_id2name(m, kind, i) or ""


class ArmFreeFlight:
    """The arm-free flight of a robot-mode env: ``twin`` its kinematic twin, ``arm`` its bound
    :class:`~phyplan_envs.panda.robot.RobotArm` (whose ``model``/``data`` are the robot scene), ``graspable`` the
    bodies the arm may grasp (the env's ``robot_bodies``)."""

    def __init__(self, twin, arm, graspable):
        self.twin, self.arm, self.graspable = twin, arm, tuple(graspable)
        self.model, self.data = arm.model, arm.data
        self.flew = False
        self._map()

    # ------------------------------------------------------------------------------------------------ mapping
    def _map(self) -> None:
        mr, mt = self.model, self.twin.model
        J, B, G = mujoco.mjtObj.mjOBJ_JOINT, mujoco.mjtObj.mjOBJ_BODY, mujoco.mjtObj.mjOBJ_GEOM
        qr, qt, vr, vt = [], [], [], []
        for j in range(mt.njnt):
            jr = mujoco.mj_name2id(mr, J, _name(mt, J, j))
            if jr < 0:
                raise RuntimeError(f"arm-free flight: the robot scene lacks the joint {_name(mt, J, j)!r}")
            nq, nv = _NQ[int(mt.jnt_type[j])]
            qt += range(mt.jnt_qposadr[j], mt.jnt_qposadr[j] + nq)
            qr += range(mr.jnt_qposadr[jr], mr.jnt_qposadr[jr] + nq)
            vt += range(mt.jnt_dofadr[j], mt.jnt_dofadr[j] + nv)
            vr += range(mr.jnt_dofadr[jr], mr.jnt_dofadr[jr] + nv)
        self._qr, self._qt, self._vr, self._vt = (np.array(x, dtype=np.int64) for x in (qr, qt, vr, vt))
        model_t, model_r, data_t, data_r = [], [], [], []
        for b in range(1, mt.nbody):
            br = mujoco.mj_name2id(mr, B, _name(mt, B, b))
            if br < 0:
                raise RuntimeError(f"arm-free flight: the robot scene lacks the body {_name(mt, B, b)!r}")
            if mt.body_jntnum[b] == 0 and mr.body_jntnum[br] > 0:    # jointed in robot mode only (a latched tool)
                if mt.body_parentid[b] != 0:
                    raise RuntimeError(f"arm-free flight: {_name(mt, B, b)!r} must hang from the world body")
                data_t.append(b)
                data_r.append(br)
            else:
                model_t.append(b)
                model_r.append(br)
        self._bt_model, self._br_model = np.array(model_t), np.array(model_r)
        self._bt_data, self._br_data = np.array(data_t, dtype=np.int64), np.array(data_r, dtype=np.int64)
        # the guard: the finger pads (robot scene) against the graspable bodies' collision geoms
        arm = self.arm
        fingers = set(arm.finger_bodies)
        self._pads = np.array([g for g in range(mr.ngeom) if mr.geom_bodyid[g] in fingers
                               and (mr.geom_contype[g] or mr.geom_conaffinity[g])], dtype=np.int64)
        moving_r, moving_t, static_r = [], [], []
        for name in self.graspable:
            root = mujoco.mj_name2id(mr, B, name)
            for g in range(mr.ngeom):
                if not (mr.geom_contype[g] or mr.geom_conaffinity[g]) or not arm.descends(mr.geom_bodyid[g], root):
                    continue
                gt = mujoco.mj_name2id(mt, G, _name(mr, G, g))
                if gt >= 0 and mt.body_weldid[mt.geom_bodyid[gt]] != 0 and _name(mr, G, g):
                    moving_r.append(g)
                    moving_t.append(gt)
                else:
                    static_r.append(g)
        self._moving_r, self._moving_t = np.array(moving_r, dtype=np.int64), np.array(moving_t, dtype=np.int64)
        self._static_r = np.array(static_r, dtype=np.int64)
        self._body_t = mt.geom_bodyid[self._moving_t]
        self._rb = mr.geom_rbound[self._moving_r] + mr.geom_margin[self._moving_r]
        self._hinge = [self._only_hinge(mr, int(mr.geom_bodyid[g])) for g in self._moving_r]
        self._scratch = mujoco.MjData(mr)

    @staticmethod
    def _only_hinge(m, body: int) -> int:
        """The hinge joint of ``body`` if that is the one joint between it and the world, else -1."""
        if m.body_jntnum[body] != 1 or m.jnt_type[m.body_jntadr[body]] != mujoco.mjtJoint.mjJNT_HINGE:
            return -1
        b = int(m.body_parentid[body])
        while b > 0:
            if m.body_jntnum[b]:
                return -1
            b = int(m.body_parentid[b])
        return int(m.body_jntadr[body])

    @staticmethod
    def _slab(d, m, geoms, axis) -> tuple[np.ndarray, np.ndarray]:
        """The extent of each geom's bounding box (``geom_aabb``) along the world ``axis``: (low, high)."""
        R = d.geom_xmat[geoms].reshape(-1, 3, 3)
        mid = (d.geom_xpos[geoms] + np.einsum("gij,gj->gi", R, m.geom_aabb[geoms, :3])) @ axis
        half = np.sum(np.abs(np.einsum("gij,i->gj", R, axis)) * m.geom_aabb[geoms, 3:], axis=1)
        return mid - half, mid + half

    # ------------------------------------------------------------------------------------------------ attempt
    def reset(self, context, physics=None) -> None:
        """The twin at the start of ``context`` (a varied task's hidden values ``physics`` passed to the reset, if
        any); called at every reset of the robot-mode env."""
        self.twin.start_state(context, physics)
        self.flew = False

    def run(self, record: bool = False, keep_release: bool = False) -> dict | None:
        """The flight from the robot scene's released state, in the twin (``record``: its trajectory;
        ``keep_release``: the released state is kept for :meth:`replay`); None if the guard tripped (the robot
        scene is then untouched and simulates the flight itself)."""
        t = self.twin
        mr, dr, mt, dt = self.model, self.data, t.model, t.data
        self.flew = False
        mt.body_pos[self._bt_model] = mr.body_pos[self._br_model]
        mt.body_quat[self._bt_model] = mr.body_quat[self._br_model]
        if len(self._bt_data):
            mt.body_pos[self._bt_data] = dr.xpos[self._br_data]
            mt.body_quat[self._bt_data] = dr.xquat[self._br_data]
        dt.qpos[self._qt] = dr.qpos[self._qr]
        dt.qvel[self._vt] = dr.qvel[self._vr]
        mujoco.mj_forward(mt, dt)
        if not self._guard_start():
            return None
        if keep_release:
            self._release = np.empty(mujoco.mj_stateSize(mt, _STATE))
            mujoco.mj_getState(mt, dt, self._release, _STATE)
        out = simulate_until_end(t, record=record, watch=self._guard if self._active else None)
        if out is None:
            return None
        dr.qpos[self._qr] = dt.qpos[self._qt]
        dr.qvel[self._vr] = dt.qvel[self._vt]
        mujoco.mj_forward(mr, dr)
        self.flew = True
        return out

    # ------------------------------------------------------------------------------------------------ the guard
    def _guard_start(self) -> bool:
        """Set up the guard at the released state; False if a graspable geom is already too close to a pad."""
        mr, dr, s = self.model, self.data, self._scratch
        s.qpos[:] = dr.qpos
        mujoco.mj_kinematics(mr, s)
        arm = self.arm
        self._travel = float(max(0.0, PM.FINGER_OPEN - float(np.min(arm.fingers()))))
        self._pad_x = s.geom_xpos[self._pads].copy()
        self._pad_r = mr.geom_rbound[self._pads] + mr.geom_margin[self._pads] + self._travel
        self._pad_margin = float(np.max(mr.geom_margin[self._pads]))
        self._fingers = []          # per finger: its pads' bounding sphere, and each pad's
        for fb in arm.finger_bodies:
            sel = mr.geom_bodyid[self._pads] == fb
            px, pr = self._pad_x[sel], self._pad_r[sel]
            fc = px.mean(axis=0)
            fr = float(np.max(np.linalg.norm(px - fc, axis=1) + pr))
            self._fingers.append(((*fc.tolist(), fr), [(int(p), *xx, r) for p, xx, r in
                                                        zip(self._pads[sel], px.tolist(), pr.tolist())]))
        c = self._pad_x.mean(axis=0)
        self._c = c.tolist()
        self._R = float(np.max(np.linalg.norm(self._pad_x - c, axis=1) + self._pad_r))
        # a graspable body that does not move in the flight (the latched plank) is checked once, here
        for g in self._static_r:
            if self._distance(g, mr.geom_rbound[g] + mr.geom_margin[g], s.geom_xpos[g]) < GUARD_MARGIN:
                return False
        self._prev = [(s.geom_xpos[g].tolist(), s.xquat[mr.geom_bodyid[g]].tolist()) for g in self._moving_r]
        self._active = []
        for k, g in enumerate(self._moving_r):
            if self._distance(g, self._rb[k], s.geom_xpos[g]) < GUARD_MARGIN:
                return False
            if self._hinge[k] >= 0:
                # a body turning about a fixed hinge keeps its extent along the hinge axis: if the pads lie outside
                # that slab, it can never reach them (the pendulum bob between the open fingers)
                axis = s.xaxis[self._hinge[k]].copy()
                lo, hi = self._slab(s, mr, np.array([g]), axis)
                plo, phi = self._slab(s, mr, self._pads, axis)
                gap = GUARD_MARGIN + self._travel + self._pad_margin + float(mr.geom_margin[g])
                if np.all((plo > hi[0] + gap) | (phi < lo[0] - gap)):
                    continue
            self._active.append(k)
        self._h = self.twin.chunk * self.twin.model.opt.timestep
        self._wait = self._since = 1
        return True

    def _guard(self) -> bool:
        """Per chunk of the twin's flight: True (stop) if a graspable body may touch a pad before the next check.

        A check bounds each graspable geom's distance D from the pads (bounding spheres, else exact) and its surface
        speed v (chunks since the last check: centre travel plus bounding radius times the rotation angle); the next
        check is the last chunk n (at most GUARD_SKIP) for which GUARD_SPEEDUP v n h + GUARD_ACCEL (n h)^2 / 2 stays
        below D - GUARD_MARGIN (h the chunk's duration); if not even n = 1 passes, the guard trips."""
        self._wait -= 1
        if self._wait > 0:
            return False
        dt = self.twin.data
        since = self._since
        cx, cy, cz = self._c
        n_next = GUARD_SKIP
        for k in self._active:
            g = self._moving_t[k]
            x, y, z = dt.geom_xpos[g].tolist()
            q = dt.xquat[self._body_t[k]].tolist()
            (px, py, pz), pq = self._prev[k]
            self._prev[k] = ((x, y, z), q)
            dot = abs(q[0] * pq[0] + q[1] * pq[1] + q[2] * pq[2] + q[3] * pq[3])
            moved = (math.sqrt((x - px) ** 2 + (y - py) ** 2 + (z - pz) ** 2)
                     + self._rb[k] * 2.0 * math.acos(min(1.0, dot)))
            v = GUARD_SPEEDUP * moved / since
            room = math.sqrt((x - cx) ** 2 + (y - cy) ** 2 + (z - cz) ** 2) - self._R - self._rb[k] - GUARD_MARGIN
            n = self._horizon(v, room)
            if n < GUARD_SKIP:          # near the fingers: the exact distance
                gr = int(self._moving_r[k])
                sc = self._scratch          # the geom where the twin has it, in the scratch robot scene
                sc.geom_xpos[gr] = dt.geom_xpos[g]
                sc.geom_xmat[gr] = dt.geom_xmat[g]
                n = self._horizon(v, self._distance(gr, self._rb[k], (x, y, z)) - GUARD_MARGIN)
                if n < 1:
                    return True
            n_next = min(n_next, n)
        self._wait = self._since = n_next
        return False

    def _horizon(self, v: float, room: float) -> int:
        """The most chunks (up to GUARD_SKIP) a surface moving at v per chunk, accelerating at GUARD_ACCEL, needs
        to cross ``room`` (m)."""
        if room <= 0.0:
            return 0
        a = 0.5 * GUARD_ACCEL * self._h * self._h
        n = int((-v + math.sqrt(v * v + 4.0 * a * room)) / (2.0 * a))     # v n + a n^2 <= room
        return min(n, GUARD_SKIP)

    def _distance(self, g: int, rb: float, x) -> float:
        """A lower bound of geom ``g``'s distance from the pads (bounding spheres of each finger's pads, of each pad,
        then ``mj_geomDistance`` in the scratch robot scene for pads nearer than GUARD_FAR), less the finger travel
        left."""
        m, s = self.model, self._scratch
        x0, x1, x2 = x
        best = math.inf
        for (f0, f1, f2, fr), pads in self._fingers:
            lb = math.sqrt((x0 - f0) ** 2 + (x1 - f1) ** 2 + (x2 - f2) ** 2) - fr - rb
            if lb >= GUARD_FAR:
                best = min(best, lb)
                continue
            for p, p0, p1, p2, r in pads:
                lb = math.sqrt((x0 - p0) ** 2 + (x1 - p1) ** 2 + (x2 - p2) ** 2) - r - rb
                if lb < GUARD_FAR:
                    lb = mujoco.mj_geomDistance(m, s, p, g, GUARD_FAR + self._travel, None) - self._travel
                best = min(best, lb)
        return best - self._pad_margin - float(m.geom_margin[g])

    # ------------------------------------------------------------------------------------------------ video
    def replay(self, frames, n_steps: int) -> None:
        """Append the frames of the twin's last flight to ``frames`` (a :class:`phyplan_envs.video.AttemptFrames`),
        drawn in the robot scene with the arm where it let go; the same frame times as ``AttemptFrames.flight``."""
        mt, mr = self.twin.model, self.model
        d = mujoco.MjData(mt)
        mujoco.mj_setState(mt, d, self._release, _STATE)
        mujoco.mj_forward(mt, d)
        vis = self._scratch
        vis.qpos[:] = self.data.qpos
        vis.qpos[self._qr] = d.qpos[self._qt]

        def draw():
            vis.qpos[self._qr] = d.qpos[self._qt]
            mujoco.mj_kinematics(mr, vis)
            mujoco.mj_camlight(mr, vis)
            frames.frames.append(frames.view.draw(vis))

        step_and_draw(mt, d, n_steps, frames.fps, draw)

    def close(self) -> None:
        self.twin.close()
