"""A small evaluation loop for the DQN baselines: mean regret after each attempt on held-out contexts.

    python -m phyplan_agents.dqn.evaluate --task launch --task slide --contexts 20 --attempts 5

runs each agent on the first ``--contexts`` seeds of the test split (:mod:`benchmarks.splits`), ``--attempts``
attempts per context, following the agent protocol (the env is reset to the context before every attempt), for
``--seeds`` run seeds, and prints a Markdown table of mean regret ``max(0, 1 - best reward so far)`` after attempt 1
and after the last attempt, with 95% confidence half-widths (normal approximation over contexts, each context's
regret averaged over the seeds first: the DQN agents are deterministic apart from DQN-Adapted's candidate draws, so
seeds are not independent samples). The full
benchmark (plots, resume, parallel runs) is ``python -m benchmarks.run``; this loop exists so the baselines can be
checked on their own.
"""
from __future__ import annotations

import argparse
import time

import numpy as np


def run_agent(task: str, agent_name: str, contexts: list[int], attempts: int, seed: int,
              agent_kwargs: dict | None = None) -> np.ndarray:
    """Regret after each attempt, shape ``(len(contexts), attempts)``."""
    import gymnasium as gym

    import phyplan_agents
    import phyplan_envs

    agent = phyplan_agents.make(agent_name, **(agent_kwargs or {}))
    env_kwargs = dict(getattr(agent, "env_kwargs", None) or {"obs_mode": getattr(agent, "obs_mode", "state")})
    env = gym.make(phyplan_envs.env_id(task), **env_kwargs)
    sim_env = gym.make(phyplan_envs.env_id(task), obs_mode="state") if agent.needs_simulator else None
    regrets = np.zeros((len(contexts), attempts))
    try:
        agent.setup(phyplan_agents.TaskInfo.from_env(env), seed)
        for i, ctx_seed in enumerate(contexts):
            agent.reseed(int(np.random.SeedSequence([seed, int(ctx_seed)]).generate_state(1)[0]))
            obs, info = env.reset(seed=int(ctx_seed))
            context = info["context"]
            sim = phyplan_agents.Simulator(sim_env, context) if sim_env is not None else None
            agent.begin_context(obs, info, sim)
            best = -np.inf
            for k in range(attempts):
                action = agent.act()
                env.reset(options={"context": context})
                _, reward, _, _, step_info = env.step(action)
                agent.observe(action, reward, step_info)
                best = max(best, reward)
                regrets[i, k] = max(0.0, 1.0 - best)
    finally:
        if callable(getattr(agent, "close", None)):
            agent.close()
        env.close()
        if sim_env is not None:
            sim_env.close()
    return regrets


def main(argv=None) -> None:
    from .cache import test_seeds

    p = argparse.ArgumentParser(prog="python -m phyplan_agents.dqn.evaluate", description=__doc__.split("\n")[0])
    p.add_argument("--task", action="append", required=True, help="task name (repeatable)")
    p.add_argument("--agent", action="append", default=None,
                   help="agent name (repeatable; default dqn-adapted, dqn-simple, random)")
    p.add_argument("--contexts", type=int, default=20)
    p.add_argument("--attempts", type=int, default=5)
    p.add_argument("--seeds", type=int, default=1, help="run seeds 0 .. seeds-1")
    p.add_argument("--split", default="test", choices=["test", "dev"])
    p.add_argument("--model-dir", default=None, help="DQN model folder (default: the shipped models)")
    p.add_argument("--agent-kw", action="append", default=[], metavar="KEY=VALUE",
                   help="extra keyword for the agents whose constructor takes it (repeatable; values parsed as "
                        "Python literals), e.g. optimize=True for dqn-adapted")
    args = p.parse_args(argv)

    import torch as th

    th.set_num_threads(1)
    import ast
    import inspect

    import phyplan_agents

    agents = args.agent or ["dqn-adapted", "dqn-simple", "random"]
    extra = {}
    for kv in args.agent_kw:
        key, sep, value = kv.partition("=")
        if not sep:
            p.error(f"--agent-kw needs KEY=VALUE, got {kv!r}")
        try:
            extra[key] = ast.literal_eval(value)
        except (ValueError, SyntaxError):
            extra[key] = value
    for key in extra:
        if not any(key in inspect.signature(phyplan_agents.resolve(n)).parameters for n in agents):
            p.error(f"--agent-kw {key}: none of the agents {agents} takes that option")
    print(f"| task | agent | regret @1 | regret @{args.attempts} | s/context |")
    print("|---|---|---|---|---|")
    for task in args.task:
        contexts = [int(s) for s in test_seeds(task, args.contexts, split=args.split)]
        for name in agents:
            accepted = inspect.signature(phyplan_agents.resolve(name)).parameters
            kwargs = {k: v for k, v in extra.items() if k in accepted}
            if args.model_dir and "model_dir" in accepted:
                kwargs["model_dir"] = args.model_dir
            t0 = time.perf_counter()
            runs = [run_agent(task, name, contexts, args.attempts, s, kwargs) for s in range(args.seeds)]
            per_ctx = (time.perf_counter() - t0) / (len(contexts) * args.seeds)
            r = np.mean(runs, axis=0)                                  # (contexts, attempts), mean over seeds
            ci = 1.96 * r.std(axis=0, ddof=1) / np.sqrt(len(r)) if len(r) > 1 else np.zeros(r.shape[1])
            print(f"| {task} | {name} | {r[:, 0].mean():.3f} ± {ci[0]:.3f} | {r[:, -1].mean():.3f} ± {ci[-1]:.3f} "
                  f"| {per_ctx:.2f} |", flush=True)


if __name__ == "__main__":
    main()
