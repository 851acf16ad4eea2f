"""The end rule of an attempt: step the physics from the released state until the object lands or rests, or the
env's ``max_sim_time`` (default ``assets.MAX_SIM_TIME``) passes (the executors' flight:
:mod:`phyplan_envs.execution`); and the attempt's reward."""
from __future__ import annotations

from typing import Any, Callable, Mapping

import numpy as np

from . import assets

CHECK_INTERVAL = 0.005    # s: the end rule is checked every 5 ms of simulated time


def chunk_for(timestep: float) -> int:
    """The steps between end-rule checks at ``timestep`` (s): :data:`CHECK_INTERVAL` worth, at least one."""
    return max(1, int(round(CHECK_INTERVAL / timestep)))


def simulate_until_end(env, record: bool = False, watch: Callable[[], bool] | None = None) -> dict[str, Any] | None:
    """Step ``env``'s physics until its end rule fires; the attempt's ``final_pos``, ``sim_time``, ``n_steps``,
    ``end_reason`` (and ``trajectory``, rows ``(t, x, y, z)``, if ``record``).

    The end rule (``env.end_rule``: ``"landed"`` when the object's centre falls through ``landing_height``, the
    crossing interpolated; otherwise, and also, ``"rest"`` once the object is slower than ``rest_speed`` after
    ``rest_min_time``; ``"timeout"`` once ``env.max_sim_time`` passes) is checked every ``env.chunk`` steps on plain floats (the same arithmetic as on arrays; the
    Python work per check is kept small because it is the only overhead over MuJoCo's own stepping). ``watch``
    (robot mode's arm-free flight: :mod:`phyplan_envs.panda.robot.flight`) is called after every chunk; the flight stops
    and ``None`` is returned when it returns true.
    """
    m, d = env.model, env.data
    qa, qv = env.scene.object_qpos, env.scene.object_qvel
    qpos, qvel = d.qpos, d.qvel
    step = env.hidden.stepper()
    max_steps = int(round(env.max_sim_time / m.opt.timestep))
    chunk = env.chunk
    landing = env.end_rule == "landed"
    z_land = env.landing_height
    rest_min_time = env.rest_min_time
    rest_speed2 = env.rest_speed ** 2
    start = qpos[qa:qa + 3].tolist()
    traj = [(0.0, *start)] if record else None
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



def outcome(result: Mapping[str, Any], goal: np.ndarray, d0: float) -> tuple[float, dict[str, Any]]:
    """The reward ``1 - d/d0`` and ``info`` of an attempt that ended as ``result`` (:func:`simulate_until_end`): d
    the xy distance of the end point from ``goal``, ``d0`` that of the object's start; ``is_success`` when the end
    point lies within the goal box's footprint."""
    final = result["final_pos"]
    d = float(np.linalg.norm(final[:2] - goal))
    reward = 1.0 - d / d0
    in_box = bool(np.all(np.abs(final[:2] - goal) <= assets.GOAL_HALF))
    info = {"goal": goal.copy(), "final_pos": final, "distance": d, "initial_distance": d0,
            "is_success": in_box, "sim_time": result["sim_time"], "n_steps": result["n_steps"],
            "end_reason": result["end_reason"]}
    return float(reward), info
