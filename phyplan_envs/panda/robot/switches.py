"""Robot mode's scene switches: what :class:`.arm.RobotArm` turns on and off around a grasp (the finger pads'
contacts, the grasp constraint, a tool's latch) and the object frozen at rest during the set-up."""
from __future__ import annotations

import mujoco
import numpy as np

LATCHED_ARMATURE = 1e4      # kg m^2 on a latched tool joint (the arm turns it with the latch off and no armature)


class SceneSwitches:
    """Mixed into :class:`.arm.RobotArm`, whose ``bind`` sets the ids and the model's original contact bits."""

    def _pads(self, on: bool) -> None:
        """The finger pads' contacts on (the grasp, the release) or off while the grasp constraint carries the tool
        (the fingers then hold their width instead of squeezing)."""
        m = self.model
        if on:
            m.geom_contype[self._pad_geoms] = self._contype0[self._pad_geoms]
        else:
            m.geom_contype[self._pad_geoms] = 0
            self.data.ctrl[self._fing_act] = self.data.qpos[self._fing_qpos]

    def _hold_on(self) -> None:
        """Freeze the object at rest for the set-up: it touches nothing and its weight is compensated, so it stays
        exactly where it was placed (MuJoCo's resting contact would creep a puck by ~0.03 mm in 10 s, which the
        kinematic mode, released at once, never sees, and a hard-hit puck's hops amplify it)."""
        if self._hold < 0:
            return
        m, d = self.model, self.data
        geoms = np.flatnonzero(m.geom_bodyid == self._hold)
        m.geom_contype[geoms] = 0
        m.geom_conaffinity[geoms] = 0
        m.body_gravcomp[self._hold] = 1.0
        self._held_frozen = True

    def _hold_off(self) -> None:
        if self._hold < 0 or not self._held_frozen:
            return
        m = self.model
        geoms = np.flatnonzero(m.geom_bodyid == self._hold)
        m.geom_contype[geoms] = self._contype0[geoms]
        m.geom_conaffinity[geoms] = self._conaffinity0[geoms]
        m.body_gravcomp[self._hold] = self._gravcomp0[self._hold]
        self._held_frozen = False

    def _restore_contacts(self) -> None:
        self.model.geom_contype[:] = self._contype0
        self.model.geom_conaffinity[:] = self._conaffinity0
        if self._held_frozen:        # the object stays frozen until the end of the set-up
            geoms = np.flatnonzero(self.model.geom_bodyid == self._hold)
            self.model.geom_contype[geoms] = 0
            self.model.geom_conaffinity[geoms] = 0

    def _held_still(self, body, local, speed) -> bool:
        return float(np.linalg.norm(self._body_point(body, local)[1])) < speed

    def _grasp_on(self, eq: int, body: int) -> None:
        """Switch the grasp on: a point constraint (MuJoCo ``connect``) between the grasp site and the body point
        under it now, so the body may turn about the point between the pads but not leave it. A free body (the
        Bounce ball between two pads) is held at its centre of mass instead, the point a two-finger grip of a sphere
        fixes: held at the point between the pads, a fraction of a millimetre off its centre, it would swing about
        that point under its weight (its release was then ~0.1 mm and ~0.15 mm/s off)."""
        m, d = self.model, self.data
        site_p, _ = self.site_pose()
        if body in self._free_bodies:   # a free tool (the Bounce ball) is held at its centre of mass
            site_p = d.xipos[body].copy()
        h = self._hand
        m.eq_data[eq, 0:3] = d.xmat[h].reshape(3, 3).T @ (site_p - d.xpos[h])
        m.eq_data[eq, 3:6] = d.xmat[body].reshape(3, 3).T @ (site_p - d.xpos[body])
        d.eq_active[eq] = 1
        self._payload(body, True)

    def _grasp_off(self, eq: int, body: int) -> None:
        """Let go: the grasp constraint off and the tool's weight its own again."""
        self.data.eq_active[eq] = 0
        self._payload(body, False)

    def _payload(self, body: int, on: bool) -> None:
        """The held tool's weight compensated (on) or not: the Panda's controller compensates a payload it has been
        told about, so the servos do not sag under it; here its bodies' ``gravcomp``, on from the grasp to the
        release (when the tool, free again, falls or swings under its full weight)."""
        parts = list(self._subtree[body])
        self.model.body_gravcomp[parts] = 1.0 if on else self._gravcomp0[parts]

    def _latch_id(self, joint: str) -> int:
        return mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_EQUALITY, f"latch_{joint}")

    def _latch(self, joint: str) -> None:
        """Lock ``joint`` where it is now (its latch equality: ``q = q_now``)."""
        m, d = self.model, self.data
        eq = self._latch_id(joint)
        j = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, joint)
        m.eq_data[eq, :] = 0.0
        m.eq_data[eq, 0] = d.qpos[m.jnt_qposadr[j]]
        d.eq_active[eq] = 1
        dof = m.jnt_dofadr[j]
        d.qvel[dof] = 0.0
        m.dof_armature[dof] = LATCHED_ARMATURE   # a locked tool: the object's contacts barely move it
