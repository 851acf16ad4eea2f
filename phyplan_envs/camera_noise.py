"""Camera realism for the ``obs`` camera: pixel noise, depth noise, lighting jitter and a pose error per context.

Off by default. ``gym.make(id, camera_noise="default")`` (or a dict overriding some of :data:`DEFAULT`'s values,
e.g. ``camera_noise={"depth_noise": 0.002}``; missing entries keep the default, ``0`` turns a part off) makes the
``image``, ``state_image`` and ``rgbd`` observations those of an imperfect camera. The state vector, ``render()``
frames and every outcome are unchanged, and so is :meth:`~phyplan_envs.base.PhyPlanEnv.camera_model`: it reports
the *nominal* calibration, which the camera no longer quite has.

The model, per context (drawn once at ``reset``, the same for every picture of the context):

* **pose error**: the camera draws from its nominal pose moved by ``t`` (each axis uniform in
  ``[-pose_translation, pose_translation]`` m, world frame) and turned about its centre by a rotation of angle
  uniform in ``[0, pose_rotation]`` degrees about an axis uniform on the sphere: world-to-true-camera
  ``R_true = R_err @ R_nominal`` (camera-to-world matrices), ``c_true = c_nominal + t``;
* **lighting and colour**: exposure gain ``g`` uniform in ``[1 - gain, 1 + gain]`` (light intensity), per-channel
  white balance ``w_c`` uniform in ``[1 - white_balance, 1 + white_balance]`` and offset ``o_c`` uniform in
  ``[-offset, offset]`` (digital numbers, DN): the light reaching the sensor is ``I' = g w_c I + o_c`` for the clean
  uint8 picture ``I``;

and per picture (fresh for each observation, reproducible):

* **pixel noise** (Gaussian approximation of Poisson shot noise plus read noise): each channel value becomes
  ``round(I' + n)``, ``n ~ N(0, read_noise**2 + shot_noise * max(I', 0))`` (DN), clipped to ``[0, 255]``;
* **depth noise** (structured-light sensors: the axial error grows with the square of the distance, e.g. Kinect v1's
  about ``1.4e-3 z**2`` m): ``z' = max(z + depth_noise * z**2 * e, 0)``, ``e ~ N(0, 1)`` (``depth_noise`` in 1/m);
  then each pixel independently with probability ``depth_dropout`` is invalid, reported as ``0.0`` (the convention
  of Kinect and RealSense drivers: no depth measured; never NaN).

Randomness: the context gets an entry ``camera_noise_seed`` (an integer drawn from the env's ``np_random`` after the
context's other entries, so ``reset(seed=s)`` gives the same context, goal and hidden physics as without the
option, and the same noise every time). Passing the context back (``reset(options={"context": ...})``, the harness's
attempts, :func:`~phyplan_envs.simulate_batch` and vector envs' workers, pickled copies) replays the same pose error,
lighting and per-picture noise: the first picture of an episode (the reset's) and the second (the step's) are each
the same as before. A context without the entry (a goal only, or one from an env without the option) gets a fresh
one from ``np_random``. Three independent streams are seeded from it (:class:`numpy.random.SeedSequence` children:
the per-context draws, the colour noise and the depth noise), so ``rgbd``'s ``rgb`` is the ``image`` observation bit
for bit, and turning one part off does not change the others' draws.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any, Callable, Mapping

import numpy as np

from .camera import CameraModel
from .spaces import as_real, short_repr

SEED_KEY = "camera_noise_seed"
SEED_LIMIT = 2 ** 63 - 1


@dataclass(frozen=True)
class CameraNoise:
    """The parameters of the noise model (module docstring); every one ``0`` turns its part off.

    Attributes:
        read_noise: read noise std (DN).
        shot_noise: shot-noise variance per DN of signal (DN): variance ``read_noise**2 + shot_noise * I``.
        depth_noise: depth std over depth squared (1/m): std ``depth_noise * z**2`` m at z-depth ``z`` m.
        depth_dropout: the probability that a depth pixel is invalid (reported as 0.0).
        gain: exposure gain half-range (``g`` uniform in ``[1 - gain, 1 + gain]``).
        white_balance: per-channel gain half-range.
        offset: per-channel offset half-range (DN).
        pose_translation: the camera centre's error per axis, half-range (m).
        pose_rotation: the largest rotation error (degrees).
    """

    read_noise: float = 2.0
    shot_noise: float = 0.05
    depth_noise: float = 1.0e-3
    depth_dropout: float = 0.01
    gain: float = 0.15
    white_balance: float = 0.05
    offset: float = 5.0
    pose_translation: float = 0.01
    pose_rotation: float = 1.0

    def as_dict(self) -> dict[str, float]:
        return asdict(self)


DEFAULT = CameraNoise()
# the largest value each parameter takes (the checks): beyond these the pictures are no longer of the scene
LIMITS = {"read_noise": 64.0, "shot_noise": 16.0, "depth_noise": 0.1, "depth_dropout": 0.99, "gain": 0.9,
          "white_balance": 0.9, "offset": 64.0, "pose_translation": 0.2, "pose_rotation": 20.0}


def check_camera_noise(value: Any, name: str = "camera_noise") -> CameraNoise | None:
    """The :class:`CameraNoise` of the env argument ``camera_noise``: ``None`` (off), ``"default"``
    (:data:`DEFAULT`) or a dict of some of :class:`CameraNoise`'s fields (the others default). ``TypeError`` for a
    wrong type, ``ValueError`` for an unknown name or a value outside ``[0, LIMITS[field]]``, naming the argument."""
    if value is None:
        return None
    if isinstance(value, CameraNoise):
        value = value.as_dict()
    if isinstance(value, str):
        if value != "default":
            raise ValueError(f"{name} must be None, 'default' or a dict of noise parameters, got {value!r}")
        return DEFAULT
    if not isinstance(value, Mapping):
        raise TypeError(f"{name} must be None, 'default' or a dict of noise parameters "
                        f"({', '.join(LIMITS)}), got {type(value).__name__} {short_repr(value)}")
    unknown = [k for k in value if k not in LIMITS]
    if unknown:
        raise ValueError(f"{name} has unknown entries {sorted(map(str, unknown))}; known: {', '.join(LIMITS)}")
    out = {}
    for key, v in value.items():
        a = as_real(v)
        if a is None or a.shape != ():
            raise TypeError(f"{name}[{key!r}] must be a real number, got {type(v).__name__} {short_repr(v)}")
        if not 0.0 <= float(a) <= LIMITS[key]:       # NaN fails this too
            raise ValueError(f"{name}[{key!r}] must be in [0, {LIMITS[key]}], got {float(a)!r}")
        out[key] = float(a)
    return CameraNoise(**{**DEFAULT.as_dict(), **out})


def check_seed_entry(value: Any) -> int:
    """A context's ``camera_noise_seed``: an integer in ``[0, 2**63 - 1]``."""
    what = f"options['context'][{SEED_KEY!r}]"
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{what} must be an integer (as in info['context']), got {type(value).__name__} "
                        f"{short_repr(value)}")
    if not 0 <= int(value) <= SEED_LIMIT:
        raise ValueError(f"{what} must be an integer in [0, {SEED_LIMIT}], got {value!r}")
    return int(value)


def rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """The rotation matrix of ``angle`` (rad) about the unit vector ``axis`` (Rodrigues)."""
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + np.sin(angle) * k + (1.0 - np.cos(angle)) * (k @ k)


class NoiseRealisation:
    """One context's camera: its pose error and lighting (drawn from ``seed`` under ``params``) and the streams of
    its pictures' pixel and depth noise."""

    def __init__(self, params: CameraNoise, seed: int):
        self.params, self.seed = params, int(seed)
        context_ss, rgb_ss, depth_ss = np.random.SeedSequence(self.seed).spawn(3)
        rng = np.random.default_rng(context_ss)
        u = rng.uniform(-1.0, 1.0, size=10)            # every draw made whatever the parameters (module docstring)
        axis = rng.normal(size=3)
        angle = rng.uniform(0.0, 1.0)
        p = params
        self.gain = (1.0 + p.gain * u[0]) * (1.0 + p.white_balance * u[1:4])       # (3,)
        self.offset = p.offset * u[4:7]                                             # (3,) DN
        self.translation = p.pose_translation * u[7:10]                             # (3,) m
        self.angle = np.radians(p.pose_rotation) * angle                            # rad
        self.axis = axis / np.linalg.norm(axis)
        self.rotation = rotation(self.axis, self.angle)                             # world frame
        self._rgb = np.random.default_rng(rgb_ss)
        self._depth = np.random.default_rng(depth_ss)

    def true_camera(self, nominal: CameraModel) -> CameraModel:
        """The camera that draws this context's pictures (``nominal`` moved by the pose error)."""
        return CameraModel(nominal.name, nominal.width, nominal.height, nominal.fovy,
                           nominal.position + self.translation, self.rotation @ nominal.rotation)

    def posed(self, data, camera: int):
        """A context manager that moves camera id ``camera`` of ``data`` to its true pose while it is held (the
        renderer reads ``data.cam_xpos``/``cam_xmat``; the physics does not) and puts it back after."""
        return _Posed(self, data, camera)

    def colour(self, rgb: np.ndarray) -> np.ndarray:
        """The noisy picture of the clean uint8 ``rgb`` (H x W x 3): lighting, then shot and read noise."""
        p = self.params
        n = self._rgb.standard_normal(rgb.shape)
        lit = rgb.astype(np.float64) * self.gain + self.offset
        sigma = np.sqrt(p.read_noise ** 2 + p.shot_noise * np.maximum(lit, 0.0))
        return np.clip(np.rint(lit + sigma * n), 0, 255).astype(np.uint8)

    def depth(self, depth: np.ndarray) -> np.ndarray:
        """The noisy z-depth (float32) of the clean ``depth`` (H x W, metres); dropped pixels are 0.0."""
        p = self.params
        n = self._depth.standard_normal(depth.shape)
        drop = self._depth.random(depth.shape) < p.depth_dropout
        z = depth.astype(np.float64)
        out = np.maximum(z + p.depth_noise * z * z * n, 0.0)
        out[drop] = 0.0
        return out.astype(np.float32)


class _Posed:
    def __init__(self, noise: NoiseRealisation, data, camera: int):
        self.noise, self.data, self.camera = noise, data, camera

    def __enter__(self):
        d, c = self.data, self.camera
        self.pos, self.mat = d.cam_xpos[c].copy(), d.cam_xmat[c].copy()
        d.cam_xpos[c] = self.pos + self.noise.translation
        d.cam_xmat[c] = (self.noise.rotation @ self.mat.reshape(3, 3)).ravel()
        return self

    def __exit__(self, *exc):
        self.data.cam_xpos[self.camera] = self.pos
        self.data.cam_xmat[self.camera] = self.mat
        return False


# ======================================================================================== the env's side of it
def context_keys(params: CameraNoise | None) -> tuple[str, ...]:
    """The context entries the option adds: ``camera_noise_seed`` when it is on."""
    return () if params is None else (SEED_KEY,)


def entry_check(params: CameraNoise | None, other: Callable[[str, Any], Any]) -> Callable[[str, Any], Any]:
    """The context-entry check of an env with ``params``: ``camera_noise_seed`` here, the others by ``other``."""
    if params is None:
        return other
    return lambda name, value: check_seed_entry(value) if name == SEED_KEY else other(name, value)


def realise(params: CameraNoise | None, context: dict, rng: np.random.Generator) -> NoiseRealisation | None:
    """The realisation of ``context`` (``None`` when the option is off); gives ``context`` a seed drawn from ``rng``
    if it has none."""
    if params is None:
        return None
    if SEED_KEY not in context:
        context[SEED_KEY] = int(rng.integers(0, SEED_LIMIT, endpoint=True))
    return NoiseRealisation(params, context[SEED_KEY])
