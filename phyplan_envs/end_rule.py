"""The end rule of an attempt: step the physics from the released state until the object lands or rests, or
``MAX_SIM_TIME`` passes (called by :meth:`phyplan_envs.base.PhyPlanEnv._simulate`)."""
from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from . import assets


def simulate_until_end(env) -> dict[str, Any] | None:
    """Step ``env``'s physics until its end rule fires; the attempt's ``final_pos``, ``sim_time``, ``n_steps``,
    ``end_reason`` (and ``trajectory`` when recorded).

    The end rule (``env.end_rule``: ``"landed"`` when the object's centre falls through ``landing_height``, the
    crossing interpolated; otherwise, and also, ``"rest"`` once the object is slower than ``rest_speed`` after
    ``rest_min_time``) is checked every ``env.chunk`` steps on plain floats (the same arithmetic as on arrays; the
    Python work per check is kept small because it is the only overhead over MuJoCo's own stepping). Returns
    ``None`` if ``env._flight_watch`` (robot mode's arm-free flight) asks to stop.
    """
    m, d = env.model, env.data
    qa, qv = env._obj_qpos, env._obj_qvel
    qpos, qvel = d.qpos, d.qvel
    step = mujoco.mj_step
    watch = env._flight_watch
    max_steps = int(round(assets.MAX_SIM_TIME / m.opt.timestep))
    chunk = env.chunk
    landing = env.end_rule == "landed"
    z_land = env.landing_height
    rest_min_time = env.rest_min_time
    rest_speed2 = env.rest_speed ** 2
    start = qpos[qa:qa + 3].tolist()
    traj = [(0.0, *start)] if env._episode_record else None
    prev = start
    steps = 0
    reason = "timeout"
    final = None
    dt = m.opt.timestep
    while steps < max_steps:
        step(m, d, chunk)
        steps += chunk
        if watch is not None and watch():
            return None
        pos = qpos[qa:qa + 3].tolist()
        if traj is not None:
            traj.append((steps * dt, *pos))
        if landing and pos[2] <= z_land < prev[2]:
            f = (prev[2] - z_land) / (prev[2] - pos[2])
            p0 = np.array(prev)
            final = p0 + f * (np.array(pos) - p0)
            reason = "landed"
            break
        if steps * dt >= rest_min_time:
            vx, vy, vz = qvel[qv:qv + 3].tolist()
            if vx * vx + vy * vy + vz * vz < rest_speed2:
                reason = "rest"
                break
        prev = pos
    if final is None:
        final = qpos[qa:qa + 3].copy()
    out = {"final_pos": np.asarray(final, dtype=np.float64), "sim_time": steps * dt, "n_steps": steps,
           "end_reason": reason}
    if traj is not None:
        out["trajectory"] = np.asarray(traj, dtype=np.float64)
    return out

