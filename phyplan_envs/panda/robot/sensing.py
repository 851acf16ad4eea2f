"""Robot mode's measurements: the arm's joints and fingers, the fingers' contacts, the grasp site, and the points
of a held tool (:class:`ArmSensing`, mixed into :class:`.arm.RobotArm`, whose ``bind`` sets the ids)."""
from __future__ import annotations

import mujoco
import numpy as np

from ..grasp import cross3

TRACK_TOL = 0.003           # rad: a move ends when every arm joint is this close to its set-point (robot.py)
HOLD_SPEED = 1e-4           # m/s: the held point is measured once it is slower than this ...
CREEP_TIME = 1.0            # s: ... or than its error over this


class ArmSensing:
    """What :class:`.arm.RobotArm` measures of the arm and of the tool it holds."""

    def arm_q(self) -> np.ndarray:
        return self.data.qpos[self._arm_qpos].copy()

    def _settled(self, body, local, target) -> bool:
        """The held point is still enough to measure its error: slower than HOLD_SPEED, or than the error itself
        over CREEP_TIME (what it may still creep is then a small part of the error the next correction removes)."""
        p, v = self._body_point(body, local)
        return float(np.linalg.norm(v)) < max(HOLD_SPEED, float(np.linalg.norm(target - p)) / CREEP_TIME)

    def _site_target(self, eq: int, body: int, err) -> np.ndarray:
        """Where the grasp site must go for the held body to move by ``err``: from where the site is now, plus the
        grasp constraint's own stretch (its body anchor less its hand anchor). Measured from the site's actual
        position, not from the previous target: the grasp holds a tool a fraction of a millimetre off its planned
        grasp point, and a target that ignores that offset is one a tool on a hinge (the bob, the plank) cannot
        follow; the constraint then loads the arm, which sags, and the held point creeps about its target."""
        d = self.data
        h = self._hand
        hand_anchor = d.xpos[h] + d.xmat[h].reshape(3, 3) @ self.model.eq_data[eq, 0:3]
        body_anchor = d.xpos[body] + d.xmat[body].reshape(3, 3) @ self.model.eq_data[eq, 3:6]
        return d.site_xpos[self._site] + (body_anchor - hand_anchor) + err

    def _tracked(self, tol: float = TRACK_TOL) -> bool:
        return float(np.max(np.abs(self.data.qpos[self._arm_qpos] - self.q_cmd))) < tol

    def fingers(self) -> np.ndarray:
        return self.data.qpos[self._fing_qpos].copy()

    def descends(self, i: int, root: int) -> bool:
        while i > 0:
            if i == root:
                return True
            i = self.model.body_parentid[i]
        return False

    def _touching(self, body: int) -> bool:
        """Both fingers touch ``body`` (or a body attached below it)."""
        d, m = self.data, self.model
        parts = self._subtree[body]
        hit = [False, False]
        for i in range(d.ncon):
            c = d.contact[i]
            b1, b2 = m.geom_bodyid[c.geom1], m.geom_bodyid[c.geom2]
            for k, fb in enumerate(self.finger_bodies):
                if (b1 == fb and b2 in parts) or (b2 == fb and b1 in parts):
                    hit[k] = True
        return hit[0] and hit[1]

    def site_pose(self) -> tuple[np.ndarray, np.ndarray]:
        d = self.data
        return d.site_xpos[self._site].copy(), d.site_xmat[self._site].reshape(3, 3).copy()

    def _body_point(self, body: int, local) -> tuple[np.ndarray, np.ndarray]:
        """World position and velocity of a point fixed in ``body``."""
        d = self.data
        p = d.xpos[body] + d.xmat[body].reshape(3, 3) @ local
        vel = np.zeros(6)
        mujoco.mj_objectVelocity(self.model, d, mujoco.mjtObj.mjOBJ_BODY, body, vel, 0)
        return p, vel[3:] + cross3(vel[:3], p - d.xpos[body])
