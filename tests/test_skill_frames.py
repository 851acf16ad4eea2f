"""Throw skill data from camera frames (phyplan_envs.skill_scenes.frames.throw_frames, read by
phyplan_agents.perception.skill_data.throw_data): the readings against the simulator's values of the same rows, the
camera's coverage of the whole flight domain, and the errors of bad arguments and unreadable frames.

Every tolerance is set from what was measured on the running machine (numbers in the comments), with a margin, and
every comparison of floats is between two computations made here.
"""
from __future__ import annotations

import mujoco
import numpy as np
import pytest

from phyplan_envs import assets, skill_scenes
from phyplan_envs.skill_scenes import frames as F

DT = assets.TIMESTEP
G = assets.GRAVITY
SEED = 7           # its first 8 rows include a query in the first frame period (k = 4): the one-sided difference


@pytest.fixture(scope="module")
def seen():
    from phyplan_agents.perception.skill_data import throw_data

    return throw_data(8, seed=SEED)


def test_throw_frames_rows_are_the_throw_data_rows(seen):
    sim = skill_scenes.generate("throw", 8, seed=SEED)
    # the same launches and query times, row for row (the camera changes nothing in the physics)
    assert np.array_equal(seen.inputs[:, 2], sim.inputs[:, 2])
    assert np.array_equal(seen.extras["true_v_hor"], sim.inputs[:, 0])
    assert np.array_equal(seen.extras["true_v_ver"], sim.inputs[:, 1])
    for key, col in (("true_x", 0), ("true_y", 1), ("true_v_ver_t", 2)):
        assert np.array_equal(seen.extras[key], sim.outputs[:, col])


def test_throw_readings_agree_with_the_simulator(seen):
    sim = skill_scenes.generate("throw", 8, seed=SEED)
    d_in, d_out = seen.inputs - sim.inputs, seen.outputs - sim.outputs
    k = np.rint(sim.inputs[:, 2] / DT).astype(int)
    # positions: measured here max 0.07 mm over 20 samples (a sphere fit to the ~40 surface points of the ball, with
    # depth); 0.5 mm is 7x that and under a tenth of a pixel (5.8 mm in the flight plane), so a reader off by a
    # pixel fails. Not copied from the simulator: the errors are not all 0.
    assert np.abs(d_out[:, :2]).max() < 5e-4
    assert np.abs(d_out[:, :2]).max() > 0
    # v_ver at t: the central difference of MuJoCo's semi-implicit Euler heights over +-20 steps is the mean velocity
    # of steps k-19..k+20, i.e. v_k - g dt / 2 (-4.9 mm/s) exactly, plus the position error / 40 ms (measured: the
    # error minus that bias within 0.7 mm/s); 3 mm/s of margin. Rows with k < 20 are one-sided: mean velocity of
    # steps 1..k+20, an error of g dt (k - 21) / 2 (>= -0.11 m/s), plus the same noise.
    central = k >= F.FRAME_STEPS
    assert central.any() and not central.all()               # both cases are checked
    assert np.abs(d_out[central, 2] + G * DT / 2).max() < 3e-3
    one_sided = G * DT * (k[~central] - 21) / 2
    assert np.all(np.abs(d_out[~central, 2] - one_sided) < 3e-3)
    # launch velocities: fit d = v t - a t^2 / 2 over the frames at 20, 40, 60 ms. The discrete heights are
    # v0 t - g t^2 / 2 - (g dt / 2) t, so v_ver reads -4.9 mm/s off and v_hor 0 off, plus the position error times
    # the fit's gain for v (|row of the pseudo-inverse|_1 = 95 /s: 0.1 mm -> 9.5 mm/s). Measured: max 2.7 mm/s
    # (v_hor) and 4.5 mm/s (v_ver) over 20 samples; 15 mm/s allows 0.1 mm positions.
    assert np.abs(d_in[:, 0]).max() < 0.015
    assert np.abs(d_in[:, 1] + G * DT / 2).max() < 0.015
    assert np.array_equal(d_in[:, 2], np.zeros(len(k)))       # the query times are the frames' time stamps


def test_throw_camera_sees_the_ball_over_the_whole_flight_domain():
    """Both the geometry (the ball's image inside the picture, >= 6 pixels across, at every position a frame of the
    data set can show) and the rendering (the ball read within 0.5 mm, with >= 30 green pixels) at the domain's
    extreme flights."""
    from phyplan_agents.perception import vision as V
    from phyplan_agents.perception.skill_data import ball_centre
    from phyplan_envs.camera import DepthView, camera_model
    from phyplan_envs.rendering import CameraView
    from phyplan_envs.skill_scenes.throw import THROW_T, THROW_V_HOR, THROW_V_VER, throw_release, throw_scene

    h, w = F.THROW_SIZE
    s = throw_scene(camera=F.THROW_CAMERA)
    m, d = s.model, s.data
    cam_id = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_CAMERA, "frames")
    cam = camera_model(m, d, cam_id, h, w)
    t_last = THROW_T[1] + F.FRAME_STEPS * DT       # the last frame: one period after the latest query time
    t = np.linspace(0.0, t_last, 400)
    r_px = []
    for vh in THROW_V_HOR:
        for vv in THROW_V_VER:
            p = np.column_stack([vh * t, np.zeros_like(t), skill_scenes.THROW_START_Z + vv * t - G * t * t / 2])
            u, v, z = cam.project(p)
            r = assets.BALL_RADIUS * cam.fx / z           # the ball's image radius (pixels)
            r_px.append(r)
            assert np.all((u - r > 1) & (u + r < w - 1) & (v - r > 1) & (v + r < h - 1)), (vh, vv)
    assert 2 * np.concatenate(r_px).min() >= 6            # ~6.9 pixels across everywhere

    m.vis.global_.offwidth, m.vis.global_.offheight = w, h
    views = (CameraView(m, cam_id, h, w), DepthView(m, cam_id, h, w))
    q = s.joint_qpos_adr("ball_free")
    try:
        apex = int(round(THROW_V_VER[1] / G / DT))
        last = int(round(t_last / DT))
        for vh, vv, k in [(THROW_V_HOR[0], THROW_V_VER[0], last), (THROW_V_HOR[1], THROW_V_VER[0], last),
                          (THROW_V_HOR[0], THROW_V_VER[1], apex), (THROW_V_HOR[1], THROW_V_VER[1], last),
                          (THROW_V_HOR[1], THROW_V_VER[1], apex), (0.0, 0.0, 0)]:
            throw_release(s, vh, vv)
            if k:
                mujoco.mj_step(m, d, nstep=k)
            mujoco.mj_kinematics(m, d)
            mujoco.mj_camlight(m, d)                      # the camera's pose in data (the renderer reads it there)
            frame = {"rgb": views[0].draw(d), "depth": views[1].draw(d)}
            assert V.colour_masks(frame["rgb"])["green"].sum() >= 30, (vh, vv, k)   # measured 37-40
            true = d.qpos[q:q + 3][[0, 2]]
            assert np.abs(ball_centre(frame, cam) - true).max() < 5e-4, (vh, vv, k)
    finally:
        for view in views:
            view.close()


def test_throw_frames_and_data_reject_bad_arguments():
    from phyplan_agents.perception.skill_data import throw_data

    salt = skill_scenes._SKILL_SALT["throw"]
    for n in (0, -3, 2.5, "3", None, True):
        with pytest.raises(ValueError, match="n must be"):
            F.throw_frames(n, 0, salt)          # at the call, not at the first frame
        with pytest.raises(ValueError, match="n must be"):
            throw_data(n, 0)
    for seed in (-1, 1.5, "0"):
        with pytest.raises(ValueError, match="seed must be"):
            F.throw_frames(2, seed, salt)
    with pytest.raises(ValueError, match="salt must be"):
        F.throw_frames(2, 0, -13)


def test_unreadable_throw_frames_raise_clear_errors():
    from phyplan_agents.perception import PerceptionError
    from phyplan_agents.perception.skill_data import read_throw_sample

    sample = next(F.throw_frames(1, 0, skill_scenes._SKILL_SALT["throw"]))
    k = sample["k"]
    read_throw_sample(sample)                                # readable as filmed
    lacking = dict(sample, frames={j: f for j, f in sample["frames"].items() if j != k + F.FRAME_STEPS})
    with pytest.raises(ValueError, match=rf"no frames at steps \[{k + F.FRAME_STEPS}\]"):
        read_throw_sample(lacking)
    blank = {j: dict(f) for j, f in sample["frames"].items()}
    blank[k]["rgb"] = np.full_like(blank[k]["rgb"], 128)      # the ball painted out of the query frame
    with pytest.raises(PerceptionError, match="ball: not detected"):
        read_throw_sample(dict(sample, frames=blank))
