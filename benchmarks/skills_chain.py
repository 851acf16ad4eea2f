"""Chain accuracy of the shipped skill models (``python -m benchmarks.skills --chain``): Launch, Slide and Bounce
outcomes predicted by chaining the skills as the agent does, against the tasks' own simulations."""
from __future__ import annotations

import math

import numpy as np

def _crossing(model, inputs, out_index: int, level, t_max: float, n_grid: int = 2001):
    """Outputs where ``model(inputs, t)[:, out_index]`` first falls to ``level`` on a dense time grid (linear
    interpolation between grid points); rows that never cross get NaN."""
    import torch

    inputs = torch.as_tensor(inputs, dtype=torch.float32)
    n = inputs.shape[0]
    t = torch.linspace(0.0, t_max, n_grid)
    x = torch.cat([inputs.repeat_interleave(n_grid, 0), t.repeat(n)[:, None]], dim=1)
    y = model.predict(x).reshape(n, n_grid, -1).double()
    g = y[:, :, out_index] - torch.as_tensor(level, dtype=torch.float64).reshape(-1, 1)
    out = torch.full((n, y.shape[2]), float("nan"), dtype=torch.float64)
    for i in range(n):
        idx = torch.nonzero((g[i, :-1] > 0) & (g[i, 1:] <= 0))
        if len(idx):
            k = int(idx[0])
            f = g[i, k] / (g[i, k] - g[i, k + 1])
            out[i] = y[i, k] + f * (y[i, k + 1] - y[i, k])
    return out.numpy()


def chain_accuracy(n_theta: int = 9, phi: float = 0.3) -> list[dict]:
    """Launch, Slide and Bounce outcomes predicted by the shipped skills against the tasks' simulations.

    For release angles evenly spread over [pi/4, pi/2]: the swing model's omega where theta first reaches 0 gives the
    bob speed |omega| * PENDULUM_LENGTH; the hit model gives the object's speed; the throw model's x where y reaches
    the landing height (Launch) or the slide model's x where v reaches 0 (Slide) gives the distance, compared with
    the distance from the object's start to where the task's episode ends. Bounce: drop heights over [0.5, 1.5]
    m; throw (free fall) to the impact height, bounce (the wedge's nominal restitution, 45 degrees), throw from the
    impact point down to the landing height.
    """
    import gymnasium as gym

    import phyplan_envs
    from phyplan_agents.skills import SkillSet
    from phyplan_envs import assets

    sk = SkillSet.load()
    thetas = np.linspace(math.pi / 4, math.pi / 2, n_theta)
    bottom = _crossing(sk.swing, thetas[:, None], 0, np.zeros(n_theta), 0.6)
    v_bob = np.abs(bottom[:, 1]) * assets.PENDULUM_LENGTH
    rows = []
    for task, m2 in (("launch", assets.BALL_MASS), ("slide", assets.PUCK_MASS)):
        env = gym.make(phyplan_envs.env_id(task)).unwrapped
        import torch

        x = torch.tensor(np.stack([np.full(n_theta, assets.BOB_MASS), np.full(n_theta, m2), v_bob], 1),
                         dtype=torch.float32)
        v = sk.hit.predict(x)[:, 0].double().numpy()
        for i, th in enumerate(thetas):
            env.reset(seed=0)
            start = env.object_pos()
            _, _, _, _, info = env.step(np.array([phi, th]))
            real = float(np.linalg.norm(info["final_pos"][:2] - start[:2]))
            if task == "launch":
                drop = start[2] - env.landing_height
                pred = _crossing(sk.throw, [[v[i], 0.0]], 1, [-drop], 1.0)[0, 0]
            else:
                pred = _crossing(sk.slide, [[v[i]]], 1, [0.0], 1.7)[0, 0]
            rows.append({"task": task, "action": float(th), "v_in": float(v_bob[i]), "v_object": float(v[i]),
                         "predicted": float(pred), "simulated": real, "error": float(pred - real)})
        env.close()
    # Bounce: free fall (throw) to the impact height -> bounce off the 45 degree wedge -> throw to the landing height
    import torch

    from phyplan_envs.skill_scenes import restitution_of_solref
    from phyplan_envs.tasks.bounce import BounceEnv

    env = BounceEnv()
    e = restitution_of_solref(assets.ELASTIC_SOLREF)
    for h in np.linspace(0.5, 1.5, n_theta):
        env.reset(seed=0)
        _, _, _, _, info = env.step(np.array([0.7, h]))
        real = float(np.linalg.norm(info["final_pos"][:2]))
        z_imp = assets.WEDGE_IMPACT_Z
        v_in = _crossing(sk.throw, [[0.0, 0.0]], 1, [-(h - z_imp)], 1.0)[0, 2]
        out = sk.bounce.predict(torch.tensor([[e, assets.WEDGE_ANGLE, v_in, 0.0]], dtype=torch.float32))[0]
        v_ver, v_hor = float(out[0]), float(out[1])
        pred = _crossing(sk.throw, [[v_hor, v_ver]], 1, [-(z_imp - env.landing_height)], 1.0)[0, 0]
        rows.append({"task": "bounce", "action": float(h), "v_in": float(-v_in), "v_object": math.hypot(v_hor, v_ver),
                     "predicted": float(pred), "simulated": real, "error": float(pred - real)})
    env.close()
    return rows
