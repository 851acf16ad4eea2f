"""Training the DQN baselines with stable-baselines3's ``DQN`` on a simulation cache, without re-simulating.

The task is a one-step contextual bandit: an episode is one attempt, the observation is the context image, the
action is a grid index (:class:`~phyplan_agents.dqn.grid.ActionGrid`), the reward is the task's ``1 - d/d0`` and the
episode ends after the one step. With ``done = 1`` on every transition SB3's TD target ``r + (1 - done) * gamma * ...``
is the reward itself, so DQN regresses Q(image, action) onto the simulated reward (Huber loss), as PHYRE's DQN does.

How SB3 is used:

* :class:`CacheBanditEnv` is the bandit over the cache (what SB3 is given as its env: spaces, and a ``step`` that
  answers from the cache).
* The replay buffer is **pre-filled** with every cached transition (:func:`prefill_replay_buffer`).
* :class:`OfflineDQN` is SB3's ``DQN`` with its ``learn`` loop, ``train`` step (replay sampling, target network,
  Huber loss, gradient clipping, Adam), callbacks and logger unchanged; only ``collect_rollouts`` is replaced by a
  step that advances the clock without touching an env, so no simulation happens during training. One "timestep"
  is one gradient step on a batch from the buffer.
"""
from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass
from typing import Any

import gymnasium as gym
import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3 import DQN
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.logger import Logger
from stable_baselines3.common.type_aliases import RolloutReturn

from .cache import SimulationCache
from .policy import ActionConditionedDQNPolicy


@dataclass(frozen=True)
class TrainConfig:
    """Hyperparameters of one training run; the defaults are what the shipped models were trained with.

    Attributes:
        epochs: passes over the cache, counted in gradient steps of ``batch_size`` samples (default 40, i.e.
            1,280 steps for 2,000 simulations; PHYRE's DQN used 50 epochs). Each model's validation fit is
            recorded in the manifest; ``--epochs`` of the training CLI changes it.
        batch_size: transitions per gradient step (default 64).
        learning_rate: Adam's step size (default 1e-3, PHYRE's/PhyPlan's DQN).
        features_dim: image feature size (default 128).
        channels: CNN width (default 32).
        keypoints: spatial soft-argmax keypoints (default 16).
        temperature: initial spatial-softmax sharpness (default 50; see :class:`~.policy.ContextCNN`).
        subtract_mean: subtract the training images' per-pixel mean from the input (default true; see
            :class:`~.policy.ContextCNN`; false exists for the ablation in docs/dqn.md).
        hidden_dim: action MLP / FiLM width (default 128).
        max_grad_norm: SB3's gradient clipping (default 10, SB3's DQN default).
    """

    epochs: int = 40
    batch_size: int = 64
    learning_rate: float = 1e-3
    features_dim: int = 128
    channels: int = 32
    keypoints: int = 16
    temperature: float = 50.0
    subtract_mean: bool = True
    hidden_dim: int = 128
    max_grad_norm: float = 10.0

    def __post_init__(self) -> None:
        for name in ("epochs", "batch_size", "features_dim", "channels", "keypoints", "hidden_dim"):
            if int(getattr(self, name)) < 1:
                raise ValueError(f"TrainConfig.{name} must be >= 1, got {getattr(self, name)!r}")
        if not (self.learning_rate > 0 and math.isfinite(self.learning_rate)):
            raise ValueError(f"TrainConfig.learning_rate must be a positive number, got {self.learning_rate!r}")

    def policy_kwargs(self, action_encoding: np.ndarray, mean_image: np.ndarray | None = None) -> dict[str, Any]:
        """SB3 ``policy_kwargs`` for :class:`ActionConditionedDQNPolicy` (``mean_image`` channel-first, in [0, 1])."""
        return dict(action_encoding=action_encoding, hidden_dim=self.hidden_dim,
                    features_extractor_kwargs=dict(features_dim=self.features_dim, channels=self.channels,
                                                   keypoints=self.keypoints, temperature=self.temperature,
                                                   mean_image=mean_image))


class CacheBanditEnv(gym.Env):
    """The one-step bandit over a simulation cache: image observation (channel-first uint8), grid-index actions.

    ``reset`` draws a cached context with the env's ``np_random``; ``step(a)`` returns the cached reward of
    action ``a`` in that context and ends the episode. Only (context, action) pairs that were simulated have a
    reward: any other action raises ``LookupError`` (the cache never simulates; training reads the replay buffer).
    """

    metadata = {"render_modes": []}

    def __init__(self, cache: SimulationCache) -> None:
        self.cache = cache
        grid = cache.grid
        h, w = cache.images.shape[1:3]
        self.observation_space = spaces.Box(0, 255, shape=(3, h, w), dtype=np.uint8)
        self.action_space = spaces.Discrete(grid.n)
        self._rewards: dict[tuple[int, int], float] = {
            (int(c), int(a)): float(r) for c, a, r in zip(cache.context_index, cache.action_index, cache.rewards)}
        self._ctx: int | None = None

    def observation(self, context: int) -> np.ndarray:
        return np.ascontiguousarray(self.cache.images[context].transpose(2, 0, 1))

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        self._ctx = int(self.np_random.integers(self.cache.n_contexts))
        return self.observation(self._ctx), {"context_index": self._ctx}

    def step(self, action):
        if self._ctx is None:
            raise RuntimeError("call reset() before step()")
        key = (self._ctx, int(action))
        if key not in self._rewards:
            raise LookupError(f"action {int(action)} was not simulated for cached context {self._ctx}; the cache "
                              f"answers only simulated pairs")
        obs = self.observation(self._ctx)
        self._ctx = None
        return obs, self._rewards[key], True, False, {"context_index": key[0]}


class OfflineDQN(DQN):
    """SB3 ``DQN`` that trains from a pre-filled replay buffer: ``collect_rollouts`` only advances the clock.

    Everything else (``learn``, ``train``, callbacks, target updates in ``_on_step``) is SB3's. Use with
    ``learning_starts=0``, ``train_freq=1``, ``gradient_steps=1``: one timestep = one gradient step.
    """

    def _setup_learn(self, *args, **kwargs):
        # without a logger of the caller's, SB3 makes an empty folder tempdir/SB3-<date> on every learn(); training
        # writes no log, so it keeps its values in memory only (the training stats read the last loss from it)
        if not self._custom_logger:
            self.set_logger(Logger(folder=None, output_formats=[]))
        return super()._setup_learn(*args, **kwargs)

    def collect_rollouts(self, env, callback, train_freq, replay_buffer, action_noise=None, learning_starts=0,
                         log_interval=None) -> RolloutReturn:
        if replay_buffer is None or replay_buffer.size() == 0:
            raise RuntimeError("OfflineDQN needs a pre-filled replay buffer (see prefill_replay_buffer)")
        callback.on_rollout_start()
        n = int(train_freq.frequency)
        for _ in range(n):
            self.num_timesteps += 1
            callback.update_locals(locals())
            if not callback.on_step():
                return RolloutReturn(n, 0, continue_training=False)
            self._update_current_progress_remaining(self.num_timesteps, self._total_timesteps)
            self._on_step()
        callback.on_rollout_end()
        return RolloutReturn(n, n, continue_training=True)


def prefill_replay_buffer(model: DQN, env: CacheBanditEnv) -> int:
    """Add every cached transition to ``model.replay_buffer`` (obs = next obs = the context image, done = 1)."""
    cache = env.cache
    rb = model.replay_buffer
    for c, a, r in zip(cache.context_index, cache.action_index, cache.rewards):
        obs = env.observation(int(c))[None]
        rb.add(obs, obs, np.array([[int(a)]]), np.array([r], dtype=np.float32), np.array([True]), [{}])
    return int(len(cache.rewards))


class TqdmCallback(BaseCallback):
    """A tqdm progress bar over gradient steps, showing the running Huber loss."""

    def __init__(self, total: int, desc: str, disable: bool = False) -> None:
        super().__init__()
        self.total, self.desc, self.disable = total, desc, disable
        self.bar = None

    def _on_training_start(self) -> None:
        from tqdm import tqdm

        self.bar = tqdm(total=self.total, desc=self.desc, unit="step", disable=self.disable)

    def _on_step(self) -> bool:
        self.bar.update(1)
        if self.n_calls % 50 == 0:
            loss = self.model.logger.name_to_value.get("train/loss")
            if loss is not None:
                self.bar.set_postfix(loss=f"{loss:.4f}")
        return True

    def _on_training_end(self) -> None:
        self.bar.close()


def mean_image(images: np.ndarray) -> np.ndarray:
    """The per-pixel mean of uint8 ``(N, H, W, 3)`` images, channel-first in [0, 1] (the CNN's input offset)."""
    return (np.asarray(images, np.float64).mean(axis=0) / 255.0).transpose(2, 0, 1).astype(np.float32)


def build_model(cache: SimulationCache, config: TrainConfig, seed: int = 0) -> tuple[OfflineDQN, CacheBanditEnv]:
    """An :class:`OfflineDQN` with the action-conditioned policy over ``cache`` and its buffer pre-filled."""
    env = CacheBanditEnv(cache)
    grid = cache.grid
    model = OfflineDQN(
        ActionConditionedDQNPolicy, env,
        learning_rate=config.learning_rate, buffer_size=max(cache.n_simulations, 1), learning_starts=0,
        batch_size=config.batch_size, tau=1.0, gamma=0.0, train_freq=1, gradient_steps=1,
        target_update_interval=1, exploration_initial_eps=0.0, exploration_final_eps=0.0,
        max_grad_norm=config.max_grad_norm,
        policy_kwargs=config.policy_kwargs(grid.encode(grid.points()),
                                           mean_image(cache.images) if config.subtract_mean else None),
        seed=seed, device="cpu", verbose=0)
    prefill_replay_buffer(model, env)
    return model, env


def train_from_cache(cache: SimulationCache, config: TrainConfig = TrainConfig(), seed: int = 0,
                     progress: bool = True) -> tuple[OfflineDQN, dict[str, Any]]:
    """Train on ``cache``; returns the model and its training stats (steps, wall time, final loss)."""
    if cache.n_simulations < 1:
        raise ValueError("the simulation cache is empty")
    th.manual_seed(seed)
    t0 = time.perf_counter()
    model, _ = build_model(cache, config, seed)
    steps = config.epochs * max(1, math.ceil(cache.n_simulations / config.batch_size))
    cb = TqdmCallback(steps, desc=f"train {cache.meta.get('task', '')}", disable=not progress)
    model.learn(total_timesteps=steps, callback=cb)
    wall = time.perf_counter() - t0
    stats = {"gradient_steps": int(model._n_updates), "train_wall_time_s": round(wall, 3),
             "final_loss": float(model.logger.name_to_value.get("train/loss", float("nan"))),
             "config": asdict(config), "seed": seed}
    return model, stats
