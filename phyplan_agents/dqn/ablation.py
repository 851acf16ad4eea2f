"""Why the DQN baselines' network looks the way it does: the validation fit of design variants on the same cache.

    python -m phyplan_agents.dqn.ablation --task launch --task slide

trains, on each task's default simulation cache (2,000 simulations, reused from ``--cache-dir``), SB3's DQN with:

* ``ours``: the shipped design (action-conditioned Q-network, mean image subtracted, softmax sharpness 50);
* ``soft``: softmax sharpness 1 instead of 50;
* ``no-mean``: without subtracting the training images' mean;
* ``no-mean-soft``: without the mean and with softmax sharpness 1;
* ``sb3-cnn``: SB3's stock ``CnnPolicy`` (NatureCNN, one Q output per grid action), same buffer and steps;

and prints each variant's fit on the validation cache (dev split, 20 contexts x 20 actions): the correlation and
mean absolute error between predicted and simulated rewards. Nothing is written to the model folder.
"""
from __future__ import annotations

import argparse
import dataclasses
import math
import time

from .cache import get_cache
from .train import VALIDATION_ACTIONS, validation_fit
from .training import CacheBanditEnv, OfflineDQN, TrainConfig, prefill_replay_buffer, train_from_cache

VARIANTS = ("ours", "soft", "no-mean", "no-mean-soft", "sb3-cnn")


def train_stock_cnn(cache, config: TrainConfig, seed: int = 0):
    """SB3's DQN with its default ``CnnPolicy`` (one output per action) on the same pre-filled buffer."""
    import torch as th

    th.manual_seed(seed)
    env = CacheBanditEnv(cache)
    model = OfflineDQN("CnnPolicy", env, learning_rate=config.learning_rate, buffer_size=cache.n_simulations,
                       learning_starts=0, batch_size=config.batch_size, tau=1.0, gamma=0.0, train_freq=1,
                       gradient_steps=1, target_update_interval=1, exploration_initial_eps=0.0,
                       exploration_final_eps=0.0, max_grad_norm=config.max_grad_norm, seed=seed, device="cpu")
    prefill_replay_buffer(model, env)
    model.learn(total_timesteps=config.epochs * math.ceil(cache.n_simulations / config.batch_size))
    return model


def main(argv=None) -> None:
    p = argparse.ArgumentParser(prog="python -m phyplan_agents.dqn.ablation", description=__doc__.split("\n")[0])
    p.add_argument("--task", action="append", required=True)
    p.add_argument("--variant", action="append", choices=VARIANTS, default=None, help="default: all")
    p.add_argument("--cache-dir", default=None)
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args(argv)

    import torch as th

    th.set_num_threads(1)
    print("| task | variant | dev corr | dev MAE | train s |")
    print("|---|---|---|---|---|")
    for task in args.task:
        cache, _, _ = get_cache(task, args.cache_dir, seed=args.seed, progress=False)
        dev, _, _ = get_cache(task, args.cache_dir, 20 * VALIDATION_ACTIONS, VALIDATION_ACTIONS, seed=args.seed,
                              progress=False, split="dev")
        for variant in args.variant or VARIANTS:
            t0 = time.perf_counter()
            base = TrainConfig()
            if variant == "sb3-cnn":
                q_net = train_stock_cnn(cache, base, args.seed).policy.q_net
            else:
                cfg = {"ours": base, "soft": dataclasses.replace(base, temperature=1.0),
                       "no-mean": dataclasses.replace(base, subtract_mean=False),
                       "no-mean-soft": dataclasses.replace(base, subtract_mean=False, temperature=1.0)}[variant]
                q_net = train_from_cache(cache, cfg, seed=args.seed, progress=False)[0].policy.q_net
            q_net.set_training_mode(False)
            fit = validation_fit(q_net, dev)
            print(f"| {task} | {variant} | {fit['corr']:.3f} | {fit['mae']:.3f} | {time.perf_counter() - t0:.0f} |",
                  flush=True)


if __name__ == "__main__":
    main()
