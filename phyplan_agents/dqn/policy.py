"""An SB3 ``DQNPolicy`` whose Q-network scores every discrete action from (image features, action encoding).

Why not SB3's default Q-network: it has one output unit per discrete action, so with 2,000 training simulations and
a 1,024-action grid almost every output is trained on one sample or none and the network cannot generalise from an
action to its neighbours. PHYRE's DQN baseline instead conditions the network on the action: an image encoder and an
action MLP fused with FiLM, regressing the reward. :class:`ActionConditionedQNetwork` does the same inside SB3:

    q(image, a) = < gamma(f), h(a) > + beta(f),     f = CNN(image),  h(a) = MLP(encode(a))

where ``encode`` is :meth:`ActionGrid.encode` (normalised action and sin/cos features) and ``gamma``, ``beta`` are
linear maps of the image features. This is FiLM conditioning (the image scales and shifts the action features) with
a linear readout: ``w . (gamma(f) * h(a) + beta(f))`` is the same bilinear form, so the readout is folded into
``gamma`` and ``beta``. For each image the Q-function over actions is a learned combination of ``hidden_dim``
learned action features. Why no nonlinearity after the fusion: it would make every (image, action) pair cost
``hidden_dim`` element-wise operations, and SB3's ``DQN.train`` evaluates every grid action for every sampled image
(online and target network): that element-wise work dominated the training time on a CPU, while the bilinear form
is one matrix product.

``forward(obs)`` evaluates ``q`` on every grid action at once (shape ``(batch, n_actions)``, what SB3's ``DQN.train``
expects), and :meth:`ActionConditionedQNetwork.score` evaluates it on any continuous actions (DQN-Adapted's
candidates). The action MLP runs once per forward pass, not once per (image, action) pair.

The image encoder (:class:`ContextCNN`) is small enough for a CPU: two coordinate channels appended to the image
(CoordConv), a 4 x 4 stride-4 patch convolution (64 x 64 -> 16 x 16), two 3 x 3 convolutions and a 1 x 1 convolution
to ``keypoints`` maps, then a spatial soft-argmax (the expected position of each map: where the goal, object and
tools are) plus each map's average, and a linear layer. About 4 M multiply-adds per 64 x 64 image.
"""
from __future__ import annotations

from typing import Any

import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3.common.policies import BasePolicy
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor
from stable_baselines3.dqn.policies import DQNPolicy
from torch import nn


class ContextCNN(BaseFeaturesExtractor):
    """Image encoder: CoordConv CNN -> spatial soft-argmax keypoints + average pool -> ``features_dim`` features.

    Args:
        observation_space: a channel-first image space ``(3, H, W)`` (SB3 divides uint8 images by 255 before this).
        features_dim: the output size (default 128).
        channels: width of the convolutions (default 32).
        keypoints: feature maps turned into (x, y) positions by the spatial soft-argmax (default 16).
        mean_image: ``(3, H, W)`` in [0, 1], subtracted from every input (the training images' per-pixel mean;
            default zeros). In a task's images only the context (the goal) moves, so after the subtraction the
            goal is nearly the only non-zero signal and the keypoints find it from the reward alone. Without it the
            network did not learn where the goal is in the 1,280 training steps (validation correlation 0.41
            against 0.996 on Launch; ``python -m phyplan_agents.dqn.ablation``, docs/dqn.md).
        temperature: initial sharpness of the spatial softmax (learned; default 50, so that from the start each
            map's soft-argmax follows its strongest response rather than averaging the whole map; with the mean
            subtracted, 1 and 50 gave the same validation fit on Launch and Slide).
    """

    def __init__(self, observation_space: spaces.Box, features_dim: int = 128, channels: int = 32,
                 keypoints: int = 16, mean_image: np.ndarray | None = None, temperature: float = 50.0) -> None:
        super().__init__(observation_space, features_dim)
        c_in, h, w = observation_space.shape
        if c_in != 3:
            raise ValueError(f"ContextCNN expects a channel-first RGB image (3, H, W), got {observation_space.shape}")
        if h % 4 or w % 4:
            raise ValueError(f"ContextCNN needs an image side divisible by 4, got {h} x {w}")
        self.convs = nn.Sequential(
            nn.Conv2d(c_in + 2, channels // 2, 4, stride=4), nn.ReLU(),
            nn.Conv2d(channels // 2, channels, 3, padding=1), nn.ReLU(),
            nn.Conv2d(channels, channels, 3, padding=1), nn.ReLU(),
            nn.Conv2d(channels, keypoints, 1),
        )
        self.keypoints = keypoints
        ys, xs = th.meshgrid(th.linspace(-1, 1, h), th.linspace(-1, 1, w), indexing="ij")
        self.register_buffer("coords", th.stack([xs, ys])[None], persistent=False)
        mean = np.zeros((c_in, h, w), np.float32) if mean_image is None else np.asarray(mean_image, np.float32)
        if mean.shape != (c_in, h, w):
            raise ValueError(f"mean_image must have shape {(c_in, h, w)}, got {mean.shape}")
        self.register_buffer("mean_image", th.as_tensor(mean))
        ys, xs = th.meshgrid(th.linspace(-1, 1, h // 4), th.linspace(-1, 1, w // 4), indexing="ij")
        self.register_buffer("map_xy", th.stack([xs.reshape(-1), ys.reshape(-1)]), persistent=False)
        if not temperature > 0:
            raise ValueError(f"temperature must be positive, got {temperature!r}")
        self.log_temperature = nn.Parameter(th.tensor(float(np.log(temperature))))
        self.head = nn.Sequential(nn.Linear(3 * keypoints, features_dim), nn.ReLU())

    def forward(self, obs: th.Tensor) -> th.Tensor:
        b = obs.shape[0]
        x = th.cat([obs - self.mean_image, self.coords.expand(b, -1, -1, -1)], dim=1)
        maps = self.convs(x)                                           # (B, K, h, w)
        flat = maps.flatten(2)                                         # (B, K, h*w)
        attn = th.softmax(flat * self.log_temperature.exp(), dim=-1)
        pos = attn @ self.map_xy.T                                     # (B, K, 2): expected (x, y) per map
        return self.head(th.cat([pos.flatten(1), flat.mean(-1)], dim=1))


class ActionConditionedQNetwork(BasePolicy):
    """Q-values of every grid action from (image features, action encoding), FiLM-fused (see the module docstring).

    Args:
        observation_space, action_space: the bandit's image space and ``Discrete(n_actions)``.
        features_extractor: the image encoder (a :class:`ContextCNN`).
        features_dim: its output size.
        action_encoding: ``(n_actions, E)`` array, the encoding of each grid action (:meth:`ActionGrid.encode`).
        hidden_dim: width of the action MLP and of the FiLM layer (default 128).
        normalize_images: divide uint8 images by 255 (SB3's convention; default true).
    """

    action_space: spaces.Discrete

    def __init__(self, observation_space: spaces.Space, action_space: spaces.Discrete,
                 features_extractor: BaseFeaturesExtractor, features_dim: int, action_encoding: np.ndarray,
                 hidden_dim: int = 128, normalize_images: bool = True) -> None:
        super().__init__(observation_space, action_space, features_extractor=features_extractor,
                         normalize_images=normalize_images)
        enc = np.asarray(action_encoding, dtype=np.float32)
        if enc.ndim != 2 or enc.shape[0] != action_space.n:
            raise ValueError(f"action_encoding must have one row per discrete action ({action_space.n}), "
                             f"got shape {enc.shape}")
        self.features_dim = features_dim
        self.hidden_dim = hidden_dim
        self.encoding_dim = enc.shape[1]
        self.register_buffer("action_encoding", th.as_tensor(enc), persistent=False)
        self.action_mlp = nn.Sequential(nn.Linear(self.encoding_dim, hidden_dim), nn.ReLU(),
                                        nn.Linear(hidden_dim, hidden_dim), nn.ReLU(),
                                        nn.Linear(hidden_dim, hidden_dim))
        self.film = nn.Linear(features_dim, hidden_dim + 1)           # gamma (hidden_dim) and beta (1)

    def image_features(self, obs: th.Tensor) -> th.Tensor:
        """The image encoder's features of a batch of observations (uint8 or float, channel-first)."""
        return self.extract_features(obs, self.features_extractor)

    def score(self, features: th.Tensor, encodings: th.Tensor) -> th.Tensor:
        """Q-values from image ``features`` (B, F) and action ``encodings``.

        ``encodings`` of shape (M, E) are scored for every image (result (B, M)); of shape (B, M, E), each image
        gets its own M actions (result (B, M)).
        """
        h = self.action_mlp(encodings)                                   # (M, H) or (B, M, H)
        gb = self.film(features)
        gamma, beta = gb[:, :-1], gb[:, -1:]                             # (B, H), (B, 1)
        if h.dim() == 2:
            return gamma @ h.T + beta                                    # (B, M)
        return th.einsum("bh,bmh->bm", gamma, h) + beta

    def forward(self, obs: th.Tensor) -> th.Tensor:
        """Q-values of all grid actions, shape (batch, n_actions)."""
        return self.score(self.image_features(obs), self.action_encoding)

    def _predict(self, observation: th.Tensor, deterministic: bool = True) -> th.Tensor:
        return self(observation).argmax(dim=1).reshape(-1)

    def _get_constructor_parameters(self) -> dict[str, Any]:
        data = super()._get_constructor_parameters()
        data.update(dict(features_dim=self.features_dim, features_extractor=self.features_extractor,
                         action_encoding=self.action_encoding.cpu().numpy(), hidden_dim=self.hidden_dim))
        return data


class ActionConditionedDQNPolicy(DQNPolicy):
    """SB3 ``DQNPolicy`` with :class:`ActionConditionedQNetwork` as Q-network and target network.

    Extra args (through ``policy_kwargs``): ``action_encoding`` (required, ``(n_actions, E)``) and ``hidden_dim``
    (default 128). ``features_extractor_class`` defaults to :class:`ContextCNN`.
    """

    q_net: ActionConditionedQNetwork
    q_net_target: ActionConditionedQNetwork

    def __init__(self, observation_space: spaces.Space, action_space: spaces.Discrete, lr_schedule,
                 action_encoding: np.ndarray | None = None, hidden_dim: int = 128,
                 features_extractor_class: type[BaseFeaturesExtractor] = ContextCNN,
                 features_extractor_kwargs: dict[str, Any] | None = None, normalize_images: bool = True,
                 optimizer_class: type[th.optim.Optimizer] = th.optim.Adam,
                 optimizer_kwargs: dict[str, Any] | None = None, **kwargs: Any) -> None:
        if action_encoding is None:
            raise ValueError("ActionConditionedDQNPolicy needs policy_kwargs['action_encoding'] (one row per "
                             "discrete action, e.g. ActionGrid.encode(ActionGrid.points()))")
        self._action_encoding = np.asarray(action_encoding, dtype=np.float32)
        self._hidden_dim = int(hidden_dim)
        super().__init__(observation_space, action_space, lr_schedule, net_arch=[],
                         features_extractor_class=features_extractor_class,
                         features_extractor_kwargs=features_extractor_kwargs, normalize_images=normalize_images,
                         optimizer_class=optimizer_class, optimizer_kwargs=optimizer_kwargs, **kwargs)

    def make_q_net(self) -> ActionConditionedQNetwork:
        args = self._update_features_extractor(self.net_args, features_extractor=None)
        args.pop("net_arch", None)
        args.pop("activation_fn", None)
        return ActionConditionedQNetwork(action_encoding=self._action_encoding, hidden_dim=self._hidden_dim,
                                         **args).to(self.device)

    def _get_constructor_parameters(self) -> dict[str, Any]:
        data = super()._get_constructor_parameters()
        data.pop("net_arch", None)
        data.update(dict(action_encoding=self._action_encoding, hidden_dim=self._hidden_dim))
        return data
