"""The DQN baselines on the agent protocol: ``dqn-simple`` and ``dqn-adapted`` (the paper's DQN-Simple/Adapted).

Both read only the context *image* (like the paper's baseline) and a trained Q-network (:mod:`.models`; the shipped
one by default, or ``model_dir=...``).

Where the image comes from: the agents ask the harness for image observations (``env_kwargs = {"obs_mode":
"image", "image_size": 64}``, an attribute the benchmark harness reads). If the observation they get has no image,
or one of another size, they make their own env copy (``TaskInfo.env_id`` and ``env_kwargs`` with ``obs_mode="image"``,
the model's image size and no Panda, which the observation camera hides anyway), reset it to ``info["context"]``
and take its observation: the same picture the model was trained on. That env only renders; it never simulates an
action, so it costs no simulator calls.

* :class:`DQNSimpleAgent`: at each attempt, the untried grid action with the highest predicted value.
* :class:`DQNAdaptedAgent`: the same network plus GP-UCB on the residual ``real - predicted`` reward (PhyPlan's
  adaptation, :class:`phyplan_agents.gp_ucb.ResidualGP`): after each attempt a GP is fitted to
  the residuals of the attempts so far, and the next action maximises
  ``predicted(a) + mu_GP(a) + sqrt(beta) * sigma_GP(a)`` (beta = 0.25, the paper's) over continuous candidates drawn
  near the best-scoring grid actions and near the best attempt so far.

Both are deterministic given the seed: all randomness comes from ``self.rng`` (seeded by ``setup``/the harness);
the network runs in inference mode.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping

import numpy as np

from phyplan_envs.hidden_physics import base_task

from ..base import Agent, Simulator, TaskInfo, scene_arguments
from ..gp_ucb import BETA, KernelPrior, ResidualGP
from .cache import scene_name
from .models import LoadedModel, load_model, read_manifest, shipped_model_dir


def model_task(task: str, model_dir: str | Path | None = None, env_kwargs: Mapping[str, Any] | None = None) -> str:
    """The name of the DQN model an agent on ``task`` uses (for an env made with ``env_kwargs``): its scene's
    (:func:`~.cache.scene_name`: the task's, or for Paddles-N ``paddles-paddles<N>``), or for a hidden-physics task
    without one (``<task>-varied``) the nominal task's (same actions and scene, trained on the nominal physics: a
    DQN that ignores the hidden physics)."""
    scene = scene_arguments(task, env_kwargs)
    own = scene_name(task, scene)
    base = base_task(task)
    if base == task:
        return own
    models = read_manifest(Path(model_dir) if model_dir is not None else shipped_model_dir())["models"]
    return own if own in models else scene_name(base, scene)


class _DQNAgent(Agent):
    """Shared part: load the model for the task, get the context image, score the grid."""

    def __init__(self, model_dir: str | Path | None = None, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.model_dir = Path(model_dir) if model_dir is not None else None
        self.model: LoadedModel | None = None
        self._render_env = None
        self.env_kwargs = {"obs_mode": "image", "image_size": 64}

    # -- life cycle ---------------------------------------------------------------------------------------------
    def setup(self, task: TaskInfo, seed: int = 0) -> None:
        super().setup(task, seed)
        name = model_task(task.task, self.model_dir, task.env_kwargs)
        if self.model is None or self.model.task != name:
            self.close()
            self.model = load_model(name, self.model_dir)
        grid = self.model.grid
        if grid.dim != task.action_dim or not (np.allclose(grid.low, task.action_low, atol=1e-6)
                                               and np.allclose(grid.high, task.action_high, atol=1e-6)):
            raise ValueError(f"the DQN model {self.model.path} was trained for action bounds "
                             f"{list(grid.low)}..{list(grid.high)}, but {task.env_id} has "
                             f"{task.action_low.tolist()}..{task.action_high.tolist()}; retrain it")
        self.env_kwargs = {"obs_mode": "image", "image_size": self.model.image_size}
        self._grid_points = grid.points()

    def begin_context(self, obs: Any, info: Mapping[str, Any], simulator: Simulator | None = None) -> None:
        super().begin_context(obs, info, simulator)
        if self.model is None:
            raise RuntimeError("setup() must be called before begin_context()")
        import torch as th

        image = self.context_image(obs, info)
        q = self.model.q_net
        with th.no_grad():
            x = th.as_tensor(np.ascontiguousarray(image.transpose(2, 0, 1))[None])
            self._features = q.image_features(x)
            self._grid_q = q.score(self._features, q.action_encoding)[0].double().numpy()
        self.count("q_evals", self.model.grid.n)
        self._tried = np.zeros(self.model.grid.n, dtype=bool)

    def observe(self, action: np.ndarray, reward: float, info: Mapping[str, Any]) -> None:
        super().observe(action, reward, info)
        a = np.asarray(action, dtype=np.float64)
        k = int(self.model.grid.nearest(a)[0])
        if np.allclose(self._grid_points[k], a, rtol=0.0, atol=1e-9):   # a grid action: never repeat it
            self._tried[k] = True

    def training_stats(self) -> dict[str, float]:
        if self.model is None:
            return {}
        e = self.model.entry
        data, train = e.get("data", {}), e.get("training", {})
        return {"sim_calls": data.get("simulations", 0),
                "wall_time_s": (data.get("simulation_wall_time_s") or 0.0) + (train.get("train_wall_time_s") or 0.0),
                "gradient_steps": train.get("gradient_steps", 0)}

    def close(self) -> None:
        if self._render_env is not None:
            self._render_env.close()
            self._render_env = None

    # -- helpers ------------------------------------------------------------------------------------------------
    def context_image(self, obs: Any, info: Mapping[str, Any]) -> np.ndarray:
        """The context image at the model's size: from ``obs`` if it has one, else rendered by an own env copy."""
        size = self.model.image_size
        image = obs.get("image") if isinstance(obs, Mapping) else obs
        if isinstance(image, np.ndarray) and image.shape == (size, size, 3):
            return np.asarray(image, dtype=np.uint8)
        if "context" not in info:
            raise ValueError(f"{self.name}: the observation has no {size}x{size} image and info has no 'context' "
                             f"to render one from")
        if self._render_env is None:
            import gymnasium as gym

            import phyplan_envs  # noqa: F401  (registers the ids)

            kwargs = {**dict(self.task.env_kwargs), "obs_mode": "image", "image_size": size, "render_mode": None,
                      "with_panda": False}
            self._render_env = gym.make(self.task.env_id, **kwargs)
        image, _ = self._render_env.reset(options={"context": info["context"]})
        return np.asarray(image, dtype=np.uint8)

    def predict(self, actions: np.ndarray) -> np.ndarray:
        """The network's predicted reward of continuous ``actions`` (M, D) in the current context."""
        import torch as th

        enc = th.as_tensor(self.model.grid.encode(np.atleast_2d(actions)))
        with th.no_grad():
            out = self.model.q_net.score(self._features, enc)[0].double().numpy()
        self.count("q_evals", len(enc))
        return out

    def _best_untried_grid(self, scores: np.ndarray) -> int:
        masked = np.where(self._tried, -np.inf, scores)
        if np.all(np.isinf(masked)):      # every grid action tried: start over
            self._tried[:] = False
            masked = scores
        return int(np.argmax(masked))


class DQNSimpleAgent(_DQNAgent):
    """DQN-Simple: the untried grid action with the highest predicted reward, attempt after attempt.

    Args:
        model_dir: folder with ``manifest.json`` and ``<task>.pt`` (default: the shipped models).
    """

    name = "dqn-simple"

    def act(self) -> np.ndarray:
        k = self._best_untried_grid(self._grid_q)
        self._tried[k] = True
        return self.clip(self._grid_points[k])


class DQNAdaptedAgent(_DQNAgent):
    """DQN-Adapted: the DQN's prediction corrected online by GP-UCB on the residual ``real - predicted`` reward.

    Attempt 1 is DQN-Simple's. From attempt 2 on: fit a GP (scikit-learn ``GaussianProcessRegressor``, kernel
    ``amplitude^2 * RBF(length_scale) + White(1e-4)`` on actions scaled to [0, 1] per dimension) to the residuals of
    the attempts so far; score every grid action by ``q + mu + sqrt(beta) sigma``;
    draw ``local`` continuous candidates around each of the ``top_k`` best grid actions and around the best attempt
    so far (Gaussian, ``spread`` grid steps wide, clipped to the bounds); take the candidate (or grid action) with
    the highest score, skipping actions already tried.

    Args:
        model_dir: folder with the models (default: the shipped ones).
        beta: the UCB weight (default 0.25, the paper's).
        top_k: grid actions whose neighbourhoods are searched (default 16).
        local: continuous candidates per neighbourhood (default 32).
        spread: standard deviation of the candidates, in grid steps (default 1.0).
        length_scale: RBF length scale in the scaled action units (default 0.1, ~3 steps of a 32-grid).
        amplitude: prior standard deviation of the residual (default 0.1; the validation MAE of the shipped
            networks is 0.02-0.04).
        optimize: fit the kernel's amplitude, length scale and noise by maximum likelihood (within bounds) at every
            attempt, scikit-learn's default. Default false: with 1-4 points the fit is ill-posed, and on 20 dev
            contexts of Launch and Slide the fixed kernel gave regret@5 0.022 and 0.037 against 0.049 and 0.070
            fitted (docs/dqn.md, "The agents").
    """

    name = "dqn-adapted"

    def __init__(self, model_dir: str | Path | None = None, beta: float = BETA, top_k: int = 16, local: int = 32,
                 spread: float = 1.0, length_scale: float = 0.1, amplitude: float = 0.1, optimize: bool = False,
                 **kwargs: Any) -> None:
        super().__init__(model_dir=model_dir, **kwargs)
        if not beta >= 0:
            raise ValueError(f"beta must be >= 0, got {beta!r}")
        if int(top_k) < 1 or int(local) < 0 or not spread > 0 or not length_scale > 0 or not amplitude > 0:
            raise ValueError("top_k must be >= 1, local >= 0, and spread, length_scale, amplitude > 0")
        self.beta, self.top_k, self.local, self.spread = float(beta), int(top_k), int(local), float(spread)
        self.length_scale, self.amplitude, self.optimize = float(length_scale), float(amplitude), bool(optimize)

    def act(self) -> np.ndarray:
        grid = self.model.grid
        if not self.history:
            k = self._best_untried_grid(self._grid_q)
            self._tried[k] = True
            return self.clip(self._grid_points[k])
        gp = self._fit_residual_gp()
        lo, hi = np.asarray(grid.low), np.asarray(grid.high)
        mu, sd = gp.predict(self._grid_points)
        grid_score = self._grid_q + mu + np.sqrt(self.beta) * sd
        seeds = np.argsort(-np.where(self._tried, -np.inf, grid_score), kind="stable")[:self.top_k]
        centres = [self._grid_points[i] for i in seeds]
        best_tried = max(self.history, key=lambda h: h[1])[0]
        centres.append(best_tried)
        cands = [np.asarray(centres)]
        if self.local:
            for c in centres:
                noise = self.rng.normal(0.0, self.spread, (self.local, grid.dim)) * grid.steps
                cands.append(np.clip(c + noise, lo, hi))
        cands = np.concatenate(cands)
        tried = np.asarray([h[0] for h in self.history])
        dist = np.min(np.abs(self._scale(cands)[:, None, :] - self._scale(tried)[None]).max(-1), axis=1)
        cands = cands[dist > 1e-9]
        if len(cands) == 0:        # every candidate was already tried (not reachable with local > 0): fall back
            k = self._best_untried_grid(grid_score)
            self._tried[k] = True
            return self.clip(self._grid_points[k])
        mu_c, sd_c = gp.predict(cands)
        score = self.predict(cands) + mu_c + np.sqrt(self.beta) * sd_c
        a = cands[int(np.argmax(score))]
        return self.clip(a)

    def _scale(self, actions: np.ndarray) -> np.ndarray:
        g = self.model.grid
        return (np.asarray(actions, dtype=np.float64) - np.asarray(g.low)) / (np.asarray(g.high) - np.asarray(g.low))

    def _fit_residual_gp(self) -> ResidualGP:
        """The GP on the residuals ``real - predicted`` of the attempts so far (fixed kernel unless ``optimize``)."""
        X = np.asarray([h[0] for h in self.history])
        y = np.asarray([h[1] for h in self.history]) - self.predict(X)
        prior = KernelPrior(amplitude=(self.amplitude ** 2, (1e-4, 1.0)), length_scale=(self.length_scale, (0.01, 1.0)),
                            noise=(1e-4, (1e-6, 1e-2)))
        g = self.model.grid
        gp = ResidualGP(g.low, g.high, beta=self.beta, seed=int(self.rng.integers(2**31 - 1)), n_restarts=0,
                        prior=prior, optimize=self.optimize)
        gp.set_data(X, y)
        return gp
