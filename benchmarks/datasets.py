"""Build Minari datasets of attempts: one dataset per task, one one-step episode per attempt of an agent.

    python -m benchmarks.datasets --tasks launch slide-varied --policy random --episodes 1000 --out DIR [--images]

writes ``phyplan/<task>/<policy>-v0`` under ``--out`` (default ``$MINARI_DATASETS_PATH``, else
``~/.minari/datasets``), in the format of :mod:`phyplan_agents.datasets` (``docs/datasets.md``). Needs
``pip install 'phyplan[datasets]'``; no network at run time (Minari's local functions only).

Contexts: ``ceil(episodes / attempts-per-context)`` distinct seeds drawn with ``--seed`` from ``--split`` (default
``train``; ``dev``; ``test`` only with ``--allow-test-split``: test contexts in training data spoil the benchmark).
The agent runs through the agent protocol as in the harness: ``setup(task, seed)`` once, then per context
``reseed(cell_seed(seed, context))``, ``begin_context`` (with a counted simulator for the oracle) and
``attempts-per-context`` rounds of ``act``/``observe``, so the attempts are those a benchmark run with run seed
``--seed`` makes. Same arguments, same dataset: every array equal, bit for bit, on one machine.
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path
from typing import Sequence

import numpy as np

POLICIES = ("random", "oracle", "phyplan")
CONTEXT_TAG = 5501          # the context-drawing stream of a dataset: default_rng([seed, CONTEXT_TAG])


def context_seeds(split: str, n: int, seed: int) -> list[int]:
    """``n`` distinct context seeds of ``split`` drawn with ``seed`` (sorted)."""
    from phyplan_envs import splits

    return sorted(splits.sample_seeds(split, n, np.random.default_rng([int(seed), CONTEXT_TAG])))


def make_env(task: str, images: bool, image_size: int):
    """The env a dataset records (and ``recover_environment`` makes): no Panda, state or state + image."""
    import gymnasium as gym

    import phyplan_envs

    kwargs = {"obs_mode": "state_image" if images else "state", "with_panda": False}
    if images:
        kwargs["image_size"] = int(image_size)
    return gym.make(phyplan_envs.env_id(task), **kwargs)


def build(task: str, policy: str, episodes: int, out: str | Path | None = None, images: bool = False,
          image_size: int = 64, split: str = "train", attempts_per_context: int = 1, seed: int = 0,
          overwrite: bool = False, progress: bool = False):
    """Build ``phyplan/<task>/<policy>-v0`` in ``out``; returns ``(dataset, seconds)``."""
    import gymnasium as gym

    import phyplan_agents
    from phyplan_agents import Simulator, TaskInfo
    from phyplan_agents import datasets as pds
    from tqdm import tqdm

    from .harness.runner import cell_seed, reseed_agent, validate_action

    n_ctx = math.ceil(episodes / attempts_per_context)
    seeds = context_seeds(split, n_ctx, seed)
    ds_id = pds.dataset_id(task, policy)
    env = make_env(task, images, image_size)
    sim_env = None
    writer = None
    t0 = time.perf_counter()
    try:
        extra = pds.phyplan_metadata(env, policy=policy, split=split, seed=int(seed), episodes=int(episodes),
                                     contexts=n_ctx, attempts_per_context=int(attempts_per_context),
                                     images=bool(images), image_size=int(image_size) if images else None,
                                     image_encoding="jpeg (Minari's HDF5 storage)" if images else None,
                                     built_by="python -m benchmarks.datasets")
        writer = pds.DatasetWriter(ds_id, env, out, overwrite=overwrite, algorithm_name=policy,
                                   description=f"{policy} attempts on {env.spec.id}: {episodes} one-step episodes, "
                                               f"{attempts_per_context} per context, {split} split (phyplan)",
                                   extra=extra)
        agent = phyplan_agents.make(policy)
        if getattr(agent, "needs_simulator", False):
            sim_env = gym.make(env.spec.id, obs_mode="state", with_panda=False)
        info_t = TaskInfo.from_env(env)
        agent.setup(info_t, int(seed))
        varied = hasattr(env.unwrapped, "hidden_parameters")      # the varied tasks' privileged values
        bar = tqdm(total=episodes, desc=f"{task} {policy}", unit="ep", disable=not progress)
        done = 0
        for s in seeds:
            reseed_agent(agent, cell_seed(int(seed), int(s)))
            obs, info = env.reset(seed=int(s))
            ctx = info["context"]
            agent.begin_context(obs, info, Simulator(sim_env, ctx) if sim_env is not None else None)
            for k in range(1, min(attempts_per_context, episodes - done) + 1):
                action, reason = validate_action(agent.act(), info_t.action_low, info_t.action_high,
                                                 info_t.action_names)
                if reason is not None:
                    raise RuntimeError(f"{policy} gave a bad action on {task} context {s}: {reason}")
                obs0, info0 = env.reset(options={"context": ctx})
                hidden = env.unwrapped.hidden_physics if varied else None
                obs1, reward, _, _, step_info = env.step(action)
                writer.add(pds.attempt_episode(done, int(s), k, obs0, info0, action, reward, obs1, step_info,
                                               hidden))
                agent.observe(action.copy(), float(reward), step_info)
                done += 1
                bar.update(1)
        bar.close()
        dataset = writer.finish()
        writer = None
        close = getattr(agent, "close", None)
        if callable(close):
            close()
    finally:
        if writer is not None:
            writer.abort()
        env.close()
        if sim_env is not None:
            sim_env.close()
    return dataset, time.perf_counter() - t0


def dataset_bytes(dataset) -> int:
    """The dataset's size on disk (every file of its folder)."""
    folder = Path(dataset.storage.data_path).parent
    return sum(f.stat().st_size for f in folder.rglob("*") if f.is_file())


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    import phyplan_envs
    from phyplan_envs.splits import SPLITS

    p = argparse.ArgumentParser(prog="python -m benchmarks.datasets", description=__doc__.split("\n")[0])
    p.add_argument("--tasks", nargs="+", required=True, metavar="TASK",
                   help=f"task names ({', '.join(phyplan_envs.ALL_TASKS)})")
    p.add_argument("--policy", choices=POLICIES, default="random", help="the agent that makes the attempts")
    p.add_argument("--episodes", type=int, required=True, help="episodes (attempts) per task")
    p.add_argument("--out", default=None, help="Minari root folder (default $MINARI_DATASETS_PATH or "
                                               "~/.minari/datasets)")
    p.add_argument("--images", action="store_true", help="also record the obs camera's image (JPEG in the dataset)")
    p.add_argument("--image-size", type=int, default=64, help="image side in pixels with --images (default 64)")
    p.add_argument("--split", choices=tuple(SPLITS), default="train", help="context split (default train)")
    p.add_argument("--allow-test-split", action="store_true", help="needed with --split test")
    p.add_argument("--attempts-per-context", type=int, default=1, help="attempts per context (default 1)")
    p.add_argument("--seed", type=int, default=0, help="draws the contexts and seeds the agent (default 0)")
    p.add_argument("--overwrite", action="store_true", help="replace datasets of the same id in --out")
    p.add_argument("--no-progress", action="store_true")
    args = p.parse_args(argv)
    unknown = [t for t in args.tasks if t not in phyplan_envs.ALL_TASKS]
    if unknown:
        p.error(f"argument --tasks: unknown task(s) {unknown}; available: {', '.join(phyplan_envs.ALL_TASKS)}")
    if len(set(args.tasks)) != len(args.tasks):
        p.error(f"argument --tasks: a task is given twice: {args.tasks}")
    if args.episodes < 1:
        p.error(f"argument --episodes: must be >= 1, got {args.episodes}")
    if args.attempts_per_context < 1:
        p.error(f"argument --attempts-per-context: must be >= 1, got {args.attempts_per_context}")
    if args.images and not 16 <= args.image_size <= 1024:
        p.error(f"argument --image-size: must be in [16, 1024], got {args.image_size}")
    if args.split == "test" and not args.allow_test_split:
        p.error("argument --split: test contexts are the benchmark's; pass --allow-test-split to record them")
    n_ctx = math.ceil(args.episodes / args.attempts_per_context)
    if n_ctx > len(SPLITS[args.split]):
        p.error(f"argument --episodes: {n_ctx} contexts needed, split {args.split!r} has {len(SPLITS[args.split])} "
                f"(raise --attempts-per-context)")
    if args.seed < 0:
        p.error(f"argument --seed: must be >= 0, got {args.seed}")
    try:
        from phyplan_agents import datasets as pds

        pds.require_minari()
    except ImportError as exc:
        p.error(str(exc))
    root = Path(args.out) if args.out is not None else pds.default_root()
    if root.exists() and not root.is_dir():
        p.error(f"argument --out: {root} is not a folder")
    taken = [pds.dataset_id(t, args.policy) for t in args.tasks if pds.exists(root, pds.dataset_id(t, args.policy))]
    if taken and not args.overwrite:
        p.error(f"argument --out: {root} already holds {', '.join(taken)}; pass --overwrite to replace")
    args.root = root
    return args


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    for task in args.tasks:
        dataset, wall = build(task, args.policy, args.episodes, args.root, args.images, args.image_size, args.split,
                              args.attempts_per_context, args.seed, args.overwrite, not args.no_progress)
        size = dataset_bytes(dataset)
        rewards = np.concatenate([ep.rewards for ep in dataset.iterate_episodes()])
        print(f"{dataset.id}: {dataset.total_episodes} episodes in {wall:.1f} s "
              f"({wall / dataset.total_episodes * 1000:.1f} s per 1,000), {size / 1e6:.2f} MB "
              f"({size / dataset.total_episodes * 1000 / 1e6:.2f} MB per 1,000); mean reward {rewards.mean():.3f}; "
              f"{Path(dataset.storage.data_path).parent}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
