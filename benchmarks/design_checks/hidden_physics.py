"""Design checks of the varied tasks' hidden physics: the contacts obey the set values, the physics is converged in
the timestep, Bounce's range is monotone in the drop height, and what an episode costs.

    python -m benchmarks.design_checks.hidden_physics               # everything (~3 min on one core)
    python -m benchmarks.design_checks.hidden_physics --only restitution friction
    python -m benchmarks.design_checks.hidden_physics --only convergence --tasks slide bridge --n 40

The slide and bridge rows check the current versions (``SlideVaried-v1``, ``BridgeVaried-v1``).

Each check prints a table; the numbers in the README come from this command.
"""
from __future__ import annotations

import argparse
import math
import time

import mujoco
import numpy as np

import phyplan_envs  # noqa: F401  (registers the ids)
from phyplan_envs import assets
from phyplan_envs import hidden_physics as hp
from phyplan_envs.tasks.varied import (BounceVariedEnv, BridgeVariedEnv, LaunchVariedEnv, SlideVariedEnv,
                                       VariedPhysicsMixin)

CLASSES: dict[str, type[VariedPhysicsMixin]] = {"launch": LaunchVariedEnv, "slide": SlideVariedEnv,
                                                "bounce": BounceVariedEnv, "bridge": BridgeVariedEnv}


def make(task: str, timestep: float | None = None):
    """A varied env without the Panda; ``timestep`` overrides the task's (the convergence check halves it)."""
    cls = CLASSES[task]
    if timestep is not None:
        cls = type(cls.__name__, (cls,), {"timestep": float(timestep)})
    return cls(with_panda=False)


def _pair_touching(env, g1: int, g2: int) -> bool:
    d = env.data
    return any({int(c.geom1), int(c.geom2)} == {g1, g2} for c in d.contact[:d.ncon])


# ============================================================================================== restitution
def hit_restitution(env, values: dict, phi: float, theta: float) -> float:
    """Measured bob-object restitution of one hit: (v_object - v_bob) / v_bob_before along the hit direction."""
    env.reset(seed=0, options={"physics": values})
    env._execute(np.array([phi, theta] + [0.0] * (len(env.action_dims) - 2)))
    m, d = env.model, env.data
    bob = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, hp.BOB_COLLIDER)
    obj = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, env.object_geom)
    hv = env._hinge_dof()
    u = np.array([math.cos(phi), math.sin(phi)])
    l = assets.PENDULUM_LENGTH
    v_in = -d.qvel[hv] * l
    for _ in range(int(0.2 / m.opt.timestep)):
        mujoco.mj_step(m, d)
        if not _pair_touching(env, bob, obj):
            break
    v_obj = float(d.qvel[env._obj_qvel:env._obj_qvel + 2] @ u)
    return (v_obj - (-d.qvel[hv] * l)) / v_in


def incline_restitution(env, restitution: float, yaw: float, height: float) -> float:
    """Measured ball-incline restitution: normal speed after / before the contact."""
    env.reset(seed=0, options={"physics": {"restitution": restitution}})
    env._execute(np.array([yaw, height]))
    m, d = env.model, env.data
    n = np.array([math.cos(yaw), math.sin(yaw), 1.0]) / math.sqrt(2)
    v_in = d.qvel[env._obj_qvel:env._obj_qvel + 3] @ n
    ball = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "ball_geom")
    incline = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "wedge_incline")
    for _ in range(int(0.2 / m.opt.timestep)):
        mujoco.mj_step(m, d)
        if not _pair_touching(env, ball, incline):
            break
    return float(-(d.qvel[env._obj_qvel:env._obj_qvel + 3] @ n) / v_in)


def restitution_table(n_values: int = 5, hits: int = 3, seed: int = 0) -> list[tuple]:
    """Rows (task, set e, measured min, max, worst |error|) over the hull of each task's restitution range."""
    rng = np.random.default_rng(seed)
    rows = []
    for task in ("launch", "slide", "bounce"):
        env = make(task)
        p = hp.parameters(task)
        e_par = [q for q in p if q.name == "restitution"][0]
        lo, hi = e_par.hull()
        for e in np.linspace(lo, hi, n_values):
            got = []
            for _ in range(hits):
                if task == "bounce":
                    got.append(incline_restitution(env, float(e), rng.uniform(-math.pi, math.pi),
                                                   rng.uniform(0.5, 1.5)))
                else:
                    values = {q.name: q.nominal for q in p}
                    mass = [q for q in p if q.name == "bob_mass"][0]
                    values.update(restitution=float(e), bob_mass=float(np.exp(rng.uniform(*np.log(mass.hull())))))
                    got.append(hit_restitution(env, values, rng.uniform(0, math.pi / 2),
                                               rng.uniform(math.pi / 4, math.pi / 2)))
            rows.append((task, float(e), min(got), max(got), max(abs(g - e) for g in got)))
        env.close()
    return rows


# ================================================================================================= friction
def slide_friction(env, values: dict, phi: float, theta: float) -> float:
    """Measured puck-table friction: the deceleration / g fitted to the puck's speed while it slides on the table
    (after it has left the pad, until it slows below 0.2 m/s)."""
    env.reset(seed=0, options={"physics": values})
    env._execute(np.array([phi, theta] + [0.0] * (len(env.action_dims) - 2)))
    m, d = env.model, env.data
    qa, va = env._obj_qpos, env._obj_qvel
    start = env.object_start[:2]
    ts, vs = [], []
    for k in range(int(3.0 / m.opt.timestep)):
        mujoco.mj_step(m, d)
        r = float(np.linalg.norm(d.qpos[qa:qa + 2] - start))
        v = float(np.linalg.norm(d.qvel[va:va + 2]))
        if d.qpos[qa + 2] < env.object_start[2] - 0.01:
            break                                         # off the table's edge
        if r > hp.PAD_RADIUS + 0.05 and v > 0.2:
            ts.append(k * m.opt.timestep)
            vs.append(v)
        elif ts and v <= 0.2:
            break
    slope = np.polyfit(ts, vs, 1)[0]
    return float(-slope / assets.GRAVITY)


def friction_table(n_values: int = 5, hits: int = 3, seed: int = 0) -> list[tuple]:
    rng = np.random.default_rng(seed)
    env = make("slide")
    rows = []
    lo, hi = hp.FRICTION.hull()
    for mu in np.linspace(lo, hi, n_values):
        got = []
        for _ in range(hits):
            values = {"bob_mass": 0.5, "restitution": 0.5, "friction": float(mu)}
            got.append(slide_friction(env, values, rng.uniform(0, math.pi / 2), rng.uniform(1.2, math.pi / 2)))
        rows.append(("slide", float(mu), min(got), max(got), max(abs(g - mu) for g in got)))
    env.close()
    return rows


# ============================================================================================ convergence
def convergence(task: str, n: int = 20, seed: int = 0) -> np.ndarray:
    """How far the end point moves (m) when the timestep halves, for ``n`` random (test-space physics, action)."""
    rng = np.random.default_rng(seed)
    coarse, fine = make(task), make(task, timestep=CLASSES[task].timestep / 2)
    moves = []
    for _ in range(n):
        values = hp.draw(task, "test", rng)
        action = rng.uniform(coarse.action_space.low, coarse.action_space.high)
        ends = []
        for env in (coarse, fine):
            env.reset(seed=0, options={"physics": values})
            ends.append(env.step(action)[4]["final_pos"][:2])
        moves.append(float(np.linalg.norm(ends[0] - ends[1])))
    coarse.close()
    fine.close()
    return np.array(moves)


def bounce_monotonicity(restitution: float, step: float = 0.0025, yaw: float = -1.0) -> tuple[int, float, float]:
    """(number of decreases, worst decrease m, range span m) of the landing range over drop heights 0.5-1.5 m."""
    env = make("bounce")
    ranges = []
    for h in np.arange(0.5, 1.5 + 1e-9, step):
        env.reset(seed=0, options={"physics": {"restitution": restitution}})
        ranges.append(float(np.linalg.norm(env.step(np.array([yaw, h]))[4]["final_pos"][:2])))
    env.close()
    dr = np.diff(ranges)
    return int(np.sum(dr < 0)), float(min(dr.min(), 0.0)), float(ranges[-1] - ranges[0])


def episode_cost(task: str, n: int = 20, seed: int = 0) -> float:
    """Mean CPU milliseconds of reset + step over ``n`` random train-space contexts and actions (no Panda; CPU time,
    so that a loaded machine does not inflate it)."""
    rng = np.random.default_rng(seed)
    env = make(task)
    t0 = time.process_time()
    for i in range(n):
        env.reset(seed=i)
        env.step(rng.uniform(env.action_space.low, env.action_space.high))
    env.close()
    return (time.process_time() - t0) / n * 1000


def nominal_planner_regret(task: str, n: int = 20, attempts: int = 5, budget: int = 200) -> np.ndarray:
    """Regret (``(n, attempts)``: after 1 .. ``attempts`` attempts) of a planner that ignores the hidden physics but
    is otherwise perfect: the oracle's search run on the simulator with the *nominal* values (:func:`phyplan_envs.hidden_physics.nominal`), its
    ``attempts`` actions scored under the context's true physics; the first ``n`` test contexts. What the range
    requirement "an agent ignoring the hidden physics has regret >= 0.10 after 5 attempts" is checked against
    (``phyplan-nogp`` adds its skill models' errors on top)."""
    import gymnasium as gym

    from phyplan_agents import Simulator, TaskInfo
    from phyplan_agents.oracle import OracleAgent
    from phyplan_envs.splits import context_seeds

    nominal = hp.nominal(task)

    class NominalSimulator(Simulator):
        def evaluate(self, action):
            self._env.reset(options={"context": self._context, "physics": nominal})
            _, reward, _, _, info = self._env.step(np.asarray(action, dtype=np.float64))
            self.calls += 1
            return float(reward), info

        def evaluate_batch(self, actions):
            out = [self.evaluate(a) for a in np.atleast_2d(actions)]
            return np.array([r for r, _ in out]), [i for _, i in out]

    name = f"{task}-varied"
    env = gym.make(phyplan_envs.env_id(name), with_panda=False)
    sim_env = gym.make(phyplan_envs.env_id(name), with_panda=False)
    regrets = []
    for seed in context_seeds("test", n):
        agent = OracleAgent(budget=budget)
        agent.setup(TaskInfo.from_env(env), seed=0)
        obs, info = env.reset(seed=seed)
        agent.begin_context(obs, info, NominalSimulator(sim_env, info["context"]))
        best, curve = -math.inf, []
        for _ in range(attempts):
            env.reset(options={"context": info["context"]})
            action = agent.act()
            _, reward, _, _, step_info = env.step(action)
            agent.observe(action, reward, step_info)
            best = max(best, reward)
            curve.append(max(0.0, 1.0 - best))
        regrets.append(curve)
    env.close()
    sim_env.close()
    return np.array(regrets)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    checks = ["restitution", "friction", "convergence", "monotone", "cost", "nominal"]
    ap.add_argument("--only", nargs="+", choices=checks, default=checks)
    ap.add_argument("--n", type=int, default=20, help="random actions per convergence/cost check (default 20)")
    ap.add_argument("--tasks", nargs="+", choices=list(CLASSES), default=list(CLASSES),
                    help="the varied tasks of the convergence, nominal and cost checks (default all four)")
    args = ap.parse_args(argv)
    classes = {t: CLASSES[t] for t in args.tasks}
    if "restitution" in args.only:
        print("set vs measured restitution (3 random hits each; pendulum tasks: random bob mass in the hull)")
        print(f"{'task':8s} {'set':>6s} {'min':>7s} {'max':>7s} {'|err|':>7s}")
        for t, e, lo, hi, err in restitution_table():
            print(f"{t:8s} {e:6.3f} {lo:7.4f} {hi:7.4f} {err:7.4f}")
    if "friction" in args.only:
        print("\nset vs measured friction (Slide; deceleration/g on the table, 3 random hits each)")
        print(f"{'task':8s} {'set':>6s} {'min':>7s} {'max':>7s} {'|err|':>7s}")
        for t, mu, lo, hi, err in friction_table():
            print(f"{t:8s} {mu:6.3f} {lo:7.4f} {hi:7.4f} {err:7.4f}")
    if "convergence" in args.only:
        print(f"\nend point moved when dt halves ({args.n} random actions, test-space physics), mm")
        print(f"{'task':8s} {'dt ms':>6s} {'median':>7s} {'p90':>7s} {'max':>7s}")
        for t, cls in classes.items():
            mv = convergence(t, args.n) * 1000
            print(f"{t:8s} {cls.timestep * 1000:6.2f} {np.median(mv):7.2f} {np.percentile(mv, 90):7.2f} "
                  f"{mv.max():7.2f}")
    if "monotone" in args.only:
        print("\nBounce landing range over drop heights 0.5-1.5 m in 2.5 mm steps")
        print(f"{'e':>6s} {'decreases':>9s} {'worst mm':>9s} {'span m':>7s}")
        for e in (0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.99):
            k, worst, span = bounce_monotonicity(e)
            print(f"{e:6.2f} {k:9d} {worst * 1000:9.2f} {span:7.3f}")
    if "nominal" in args.only:
        print(f"\nregret after 5 attempts of a planner using the nominal physics (oracle search on the nominal "
              f"simulator), first {args.n} test contexts")
        print(f"{'task':8s} {'mean@1':>7s} {'mean@5':>7s} {'median@5':>9s} {'share@5 >= 0.10':>16s}")
        for t in classes:
            r = nominal_planner_regret(t, args.n)
            print(f"{t:8s} {r[:, 0].mean():7.3f} {r[:, -1].mean():7.3f} {np.median(r[:, -1]):9.3f} "
                  f"{np.mean(r[:, -1] >= 0.10):16.2f}")
    if "cost" in args.only:
        print(f"\nCPU ms per episode (reset + step, no Panda, {args.n} random contexts and actions)")
        for t in classes:
            print(f"{t:8s} {episode_cost(t, args.n):7.1f}")


if __name__ == "__main__":
    main()
