"""Train the DQN baselines' Q-networks and write them where the agents load them.

    python -m phyplan_agents.dqn.train --task launch          # one task
    python -m phyplan_agents.dqn.train --all                  # every task in phyplan_envs.TASKS (make baselines)
    python -m phyplan_agents.dqn.train --task paddles --paddles 1 2 3 4    # one model per Paddles-N scene

For each task: get the simulation cache (simulated once with a progress bar, then read from ``--cache-dir``), train
SB3's DQN on it (:mod:`.training`), measure the fit on a validation cache from the *dev* split (``--validate``
contexts x 20 actions; these simulations are reported separately and never used for training), and write
``<task>.pt`` plus its manifest entry (checksum, settings, simulations used, wall times) to ``--out`` (default: the
shipped models in ``phyplan_agents/dqn_models/``). A task with scene arguments gets one model per scene, named by
:func:`~.cache.scene_name` (``paddles-paddles4.pt`` for four paddles); the agents load the model of their env's scene.
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from .cache import (DEFAULT_ACTIONS_PER_CONTEXT, DEFAULT_IMAGE_SIZE, DEFAULT_SIMULATIONS, default_cache_dir, get_cache,
                    scene_name, scene_of, task_grid)
from .models import save_model, shipped_model_dir
from .training import TrainConfig, train_from_cache

VALIDATION_ACTIONS = 20


def validation_fit(q_net, cache) -> dict[str, float]:
    """Correlation and mean absolute error of the network's predictions against the simulated rewards."""
    import torch as th

    with th.no_grad():
        q = q_net(th.as_tensor(np.ascontiguousarray(cache.images.transpose(0, 3, 1, 2))))
        pred = q[th.as_tensor(cache.context_index), th.as_tensor(cache.action_index)].numpy()
    return {"corr": float(np.corrcoef(pred, cache.rewards)[0, 1]),
            "mae": float(np.mean(np.abs(pred - cache.rewards))),
            "contexts": cache.n_contexts, "simulations": cache.n_simulations}


def train_task(task: str, simulations: int = DEFAULT_SIMULATIONS,
               actions_per_context: int = DEFAULT_ACTIONS_PER_CONTEXT, image_size: int = DEFAULT_IMAGE_SIZE,
               grid_counts: tuple[int, ...] | None = None, seed: int = 0, cache_dir: str | Path | None = None,
               out: str | Path | None = None, config: TrainConfig = TrainConfig(), validate: int = 20,
               progress: bool = True, scene: dict | None = None) -> dict:
    """Train the model of one task (in ``scene``: its scene arguments, e.g. ``{"paddles": 4}``) and save it under
    :func:`~.cache.scene_name`; returns its manifest entry."""
    t0 = time.perf_counter()
    scene = scene_of(task, scene)
    cache, cache_file, simulated = get_cache(task, cache_dir, simulations, actions_per_context, image_size,
                                             grid_counts, seed, progress, scene=scene)
    model, stats = train_from_cache(cache, config, seed=seed, progress=progress)
    q_net = model.policy.q_net
    q_net.set_training_mode(False)
    entry = {
        "task": task, "scene": scene, "env_id": cache.meta.get("env_id"), "grid": cache.meta["grid"],
        "image_size": image_size,
        "train_config": stats["config"], "seed": seed,
        "data": {"simulations": cache.n_simulations, "contexts": cache.n_contexts,
                 "actions_per_context": actions_per_context, "split": cache.meta.get("split", "train"),
                 "cache_file": cache_file.name,
                 "simulation_wall_time_s": cache.meta.get("simulation_wall_time_s"),
                 "simulated_in_this_run": simulated},
        "training": {k: stats[k] for k in ("gradient_steps", "train_wall_time_s", "final_loss")},
        "library": "stable-baselines3 DQN (OfflineDQN over a pre-filled replay buffer)",
    }
    if validate > 0:
        dev, _, _ = get_cache(task, cache_dir, validate * VALIDATION_ACTIONS, VALIDATION_ACTIONS, image_size,
                              grid_counts, seed, progress, split="dev", scene=scene)
        entry["validation"] = validation_fit(q_net, dev)
    entry["total_wall_time_s"] = round(time.perf_counter() - t0, 3)
    save_model(scene_name(task, scene), q_net, entry, out)
    return entry


def main(argv=None) -> None:
    import phyplan_envs

    p = argparse.ArgumentParser(prog="python -m phyplan_agents.dqn.train", description=__doc__.split("\n")[0])
    which = p.add_mutually_exclusive_group(required=True)
    which.add_argument("--task", action="append", help="task name (repeatable)")
    which.add_argument("--all", action="store_true", help="every task in phyplan_envs.TASKS")
    p.add_argument("--simulations", type=int, default=DEFAULT_SIMULATIONS,
                   help="training simulations per task (default 2000, the paper's budget)")
    p.add_argument("--actions-per-context", type=int, default=DEFAULT_ACTIONS_PER_CONTEXT,
                   help="random actions per training context (default 20: 100 contexts x 20 actions)")
    p.add_argument("--image-size", type=int, default=DEFAULT_IMAGE_SIZE, help="image side in pixels (default 64)")
    p.add_argument("--grid", type=int, nargs="+", default=None, help="grid values per action dimension "
                   "(default: the task's resolution, see phyplan_agents/dqn/grid.py)")
    p.add_argument("--epochs", type=int, default=TrainConfig.epochs)
    p.add_argument("--batch-size", type=int, default=TrainConfig.batch_size)
    p.add_argument("--lr", type=float, default=TrainConfig.learning_rate)
    p.add_argument("--temperature", type=float, default=TrainConfig.temperature,
                   help="initial spatial-softmax sharpness (default 50)")
    p.add_argument("--no-mean-image", action="store_true",
                   help="do not subtract the training images' mean (ablation; worse, see docs/dqn.md)")
    p.add_argument("--seed", type=int, default=0, help="picks the training contexts and actions, seeds training")
    p.add_argument("--cache-dir", default=None, help=f"simulation cache folder (default {default_cache_dir()})")
    p.add_argument("--out", default=None, help=f"model folder (default: the shipped models, {shipped_model_dir()})")
    p.add_argument("--paddles", type=int, nargs="+", default=None,
                   help="Paddles-N: train one model per N given (a task with the 'paddles' scene argument)")
    p.add_argument("--validate", type=int, default=20, help="dev contexts for the validation fit (0: skip)")
    p.add_argument("--no-progress", action="store_true")
    args = p.parse_args(argv)

    import torch as th

    th.set_num_threads(1)
    tasks = list(phyplan_envs.TRACKS["nominal"]) if args.all else args.task
    unknown = [t for t in tasks if t not in phyplan_envs.TASKS]
    if unknown:
        p.error(f"unknown task(s) {unknown}; available tasks: {', '.join(phyplan_envs.TASKS)}")
    runs = [(t, {}) for t in tasks]
    if args.paddles is not None:
        bad = [t for t in tasks if "paddles" not in getattr(phyplan_envs.task_class(t), "scene_args", ())]
        if bad:
            p.error(f"--paddles: task(s) {bad} have no 'paddles' scene argument")
        runs = [(t, {"paddles": n}) for t in tasks for n in args.paddles]
        for t, scene in runs:
            try:
                task_grid(t, None, scene)          # builds the scene: the task's own check of the value
            except (TypeError, ValueError) as exc:
                p.error(f"--paddles {scene['paddles']}: {exc}")
    config = TrainConfig(epochs=args.epochs, batch_size=args.batch_size, learning_rate=args.lr,
                         temperature=args.temperature, subtract_mean=not args.no_mean_image)
    for task, scene in runs:
        entry = train_task(task, args.simulations, args.actions_per_context, args.image_size,
                           tuple(args.grid) if args.grid else None, args.seed, args.cache_dir, args.out, config,
                           args.validate, progress=not args.no_progress, scene=scene)
        d, t = entry["data"], entry["training"]
        line = (f"{scene_name(task, scene)}: {d['simulations']} simulations ({d['contexts']} contexts x "
                f"{d['actions_per_context']}; "
                f"{'simulated now' if d['simulated_in_this_run'] else 'from the cache'}, "
                f"{d['simulation_wall_time_s']:.1f} s when simulated); {t['gradient_steps']} gradient steps in "
                f"{t['train_wall_time_s']:.1f} s; final loss {t['final_loss']:.4f}")
        if "validation" in entry:
            v = entry["validation"]
            line += f"; dev fit corr {v['corr']:.3f}, MAE {v['mae']:.3f} ({v['simulations']} dev simulations)"
        print(line, flush=True)
    if args.out is None:
        print(f"models written to {shipped_model_dir()} (manifest.json)")
    else:
        print(f"models written to {args.out}")


if __name__ == "__main__":
    main()
