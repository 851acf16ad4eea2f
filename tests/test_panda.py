"""The Franka Panda (phyplan_envs.panda): visual only (no DOF, no contacts, same physics), IK reaches its targets,
the kinematic posing matches MuJoCo's own kinematics of the jointed arm, and frames show it while observations do not.
Also the package's layout (model, grasp, ik, posing; every public name re-exported), the bad-input errors of its
modules, and the stepping measurement ``benchmarks.panda_speed``.
"""
from __future__ import annotations

import importlib.util
import re

import gymnasium as gym
import mujoco
import numpy as np
import pytest

import phyplan_envs
from phyplan_envs import panda

TASKS = list(phyplan_envs.TASKS)
IDS = [phyplan_envs.env_id(t) for t in TASKS]
# Stated IK tolerance: the solver stops within 0.1 mm of the target rounded to 0.1 mm; 1 mm leaves room for both.
REACH_TOL = 1e-3          # m
ORIENT_TOL = 0.01         # rad

_cache: dict = {}


def _env(env_id, with_panda, **kw):
    """One env per (id, with_panda, options) for the whole module: making a Panda scene costs ~0.3 s."""
    key = (env_id, with_panda, tuple(sorted(kw.items())))
    if key not in _cache:
        _cache[key] = gym.make(env_id, with_panda=with_panda, **kw).unwrapped
    return _cache[key]


@pytest.fixture(scope="module", autouse=True)
def _close_envs():
    yield
    for env in _cache.values():
        env.close()
    _cache.clear()


def _actions(env, n, seed=0):
    rng = np.random.default_rng(seed)
    lo, hi = env.action_space.low.astype(np.float64), env.action_space.high.astype(np.float64)
    return [lo + (hi - lo) * rng.random(len(lo)) for _ in range(n)]


def _panda_geoms(model) -> np.ndarray:
    return np.array([g for g in range(model.ngeom) if (model.geom(g).name or "").startswith("panda/")])


# ---------------------------------------------------------------------------------------------------- no physics
@pytest.mark.parametrize("env_id", IDS)
def test_panda_adds_no_degrees_of_freedom_and_collides_with_nothing(env_id):
    m1 = _env(env_id, True).model
    m0 = _env(env_id, False).model
    for field in ("nq", "nv", "nu", "na", "njnt", "neq", "nmocap", "nsensor"):
        assert getattr(m1, field) == getattr(m0, field), field
    assert m1.nbody == m0.nbody + 1          # the attachment frame only; no link bodies
    geoms = _panda_geoms(m1)
    assert len(geoms) >= 10                  # link0-7, hand, two fingers
    assert np.all(m1.geom_contype[geoms] == 0) and np.all(m1.geom_conaffinity[geoms] == 0)
    assert np.all(m1.geom_group[geoms] == panda.PANDA_GEOM_GROUP)
    assert np.all(m1.geom_type[geoms] == mujoco.mjtGeom.mjGEOM_MESH)
    # no collision meshes were carried over
    names = {m1.mesh(i).name for i in range(m1.nmesh)}
    assert not any(n.endswith("_col") for n in names)


@pytest.mark.parametrize("env_id", IDS)
def test_same_physics_outcome_with_and_without_panda(env_id):
    e1, e0 = _env(env_id, True), _env(env_id, False)
    for seed, action in enumerate(_actions(e0, 2, seed=3)):
        out = []
        for env in (e0, e1):
            env.reset(seed=seed)
            if env.with_panda:       # a posed arm (here: at some other attempt's release) must not matter either
                env.executor.panda.pose_for(env, _actions(env, 1, seed=seed + 10)[0])
            _, reward, _, _, info = env.step(action)
            out.append((info["final_pos"], info["n_steps"], reward))
        np.testing.assert_array_equal(out[0][0], out[1][0])
        assert out[0][1:] == out[1][1:]


@pytest.mark.parametrize("env_id", IDS)
def test_no_contact_involves_the_panda(env_id):
    """The fingers closed right through the moving object (they would push it if they could collide): no contact,
    same outcome. MuJoCo's midphase is off here, because it prunes with per-body bounding volumes computed at compile
    time, which do not follow the Panda's moved geoms; without it every geom pair is tested."""
    env, ref = _env(env_id, True), _env(env_id, False)
    geoms = set(_panda_geoms(env.model).tolist())
    action = _actions(env, 1, seed=5)[0]
    finals = []
    for e in (env, ref):
        m, d = e.model, e.data
        flags = m.opt.disableflags
        m.opt.disableflags = flags | mujoco.mjtDisableBit.mjDSBL_MIDPHASE
        try:
            e.reset(seed=0)
            e.apply_action(action)
            mujoco.mj_forward(m, d)
            if e is env:
                obj = e.object_pos()
                h = e.executor.panda
                h.hold(obj, panda.grasp_candidates(obj, h.shoulder), 0.0)
                mujoco.mj_forward(m, d)
                assert np.linalg.norm(h.grasp_site_pose()[0] - obj) < 0.01
            for _ in range(200):
                mujoco.mj_step(m, d, nstep=5)
                if e is env:
                    for c in d.contact[:d.ncon]:
                        assert c.geom1 not in geoms and c.geom2 not in geoms
            finals.append(e.object_pos())
        finally:
            m.opt.disableflags = flags
    np.testing.assert_array_equal(finals[0], finals[1])


# ------------------------------------------------------------------------------------------------ posing and IK
def _reference_panda() -> mujoco.MjModel:
    """The gymnasium-robotics Panda as shipped (joints, visual and collision meshes), compiled by MuJoCo itself."""
    folder = panda.franka_assets_dir()

    def body(name):
        text = (folder / name).read_text()
        text = re.sub(r"<!--.*?-->", "", text, flags=re.S)
        return text.replace("<mujocoinclude>", "").replace("</mujocoinclude>", "")

    assets = body("assets.xml").replace('meshdir="franka_assets/meshes"', f'meshdir="{folder / "meshes"}"')
    return mujoco.MjModel.from_xml_string(f"<mujoco>{assets}<worldbody>{body('chain.xml')}</worldbody></mujoco>")


def test_kinematic_posing_matches_mujoco_kinematics_of_the_jointed_arm():
    env = _env(IDS[0], True)
    h = env.executor.panda
    ref = _reference_panda()
    rd = mujoco.MjData(ref)
    viz = [g for g in range(ref.ngeom) if ref.geom_group[g] == 0 and ref.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH]
    ours = _panda_geoms(env.model)
    assert len(viz) == len(ours)
    rng = np.random.default_rng(0)
    lo, hi = ref.jnt_range[:7, 0], ref.jnt_range[:7, 1]
    R = np.array([[np.cos(h.base_yaw), -np.sin(h.base_yaw), 0], [np.sin(h.base_yaw), np.cos(h.base_yaw), 0], [0, 0, 1]])
    for _ in range(3):
        q = lo + (hi - lo) * rng.random(7)
        opening = 0.04 * rng.random()
        h.set_pose(q, opening)
        mujoco.mj_kinematics(env.model, env.data)
        rd.qpos[:7] = q
        rd.qpos[7:9] = opening
        mujoco.mj_kinematics(ref, rd)
        for g_ref, g in zip(viz, ours):
            assert ref.mesh(ref.geom_dataid[g_ref]).name == env.model.mesh(env.model.geom_dataid[g]).name.split("/")[-1]
            pos = R.T @ (env.data.geom_xpos[g] - h.base_pos)
            mat = R.T @ env.data.geom_xmat[g].reshape(3, 3)
            np.testing.assert_allclose(pos, rd.geom_xpos[g_ref], atol=1e-9)
            np.testing.assert_allclose(mat, rd.geom_xmat[g_ref].reshape(3, 3), atol=1e-9)


@pytest.mark.parametrize("env_id", IDS)
def test_ik_puts_the_hand_on_the_target(env_id):
    env = _env(env_id, True)
    h = env.executor.panda
    env.reset(seed=0)
    for action in [None] + _actions(env, 4, seed=1):
        h.pose_for(env, action)
        mujoco.mj_forward(env.model, env.data)
        target = env.hand_target(action)
        site, rot = h.grasp_site_pose()
        assert np.linalg.norm(site - target) < REACH_TOL, (action, site, target)
        assert h.residual < REACH_TOL and h.orientation_residual < ORIENT_TOL
        assert abs(np.linalg.norm(site - target) - h.residual) < 1e-9
        if action is not None:        # fingers closed on the held object
            width = getattr(env, "grip_half_width", panda.DEFAULT_GRIP_HALF_WIDTH)
            assert h.finger_opening == pytest.approx(width + panda.FINGER_CLEARANCE)


def test_pendulum_grasp_is_perpendicular_to_the_rod():
    env = _env("PhyPlan/Launch-v0", True)
    env.reset(seed=0)
    action = np.array([0.6, 1.1])
    env.executor.panda.pose_for(env, action)
    mujoco.mj_forward(env.model, env.data)
    site, rot = env.executor.panda.grasp_site_pose()
    rod = env.pendulum.pivot() - site
    # the fingers close across the rod and the hand approaches perpendicular to it: the rod leaves between the fingers
    assert abs(rot[:, 2] @ rod) / np.linalg.norm(rod) < 0.02
    assert abs(rot[:, 1] @ rod) / np.linalg.norm(rod) < 0.02


def test_out_of_reach_gets_close_and_does_not_raise():
    env = _env(IDS[0], True)
    h = env.executor.panda
    far = h.shoulder + np.array([2.5, 0.5, 0.3])
    h.hold(far, panda.grasp_candidates(far, h.shoulder), panda.FINGER_OPEN)
    mujoco.mj_forward(env.model, env.data)
    site, _ = h.grasp_site_pose()
    dist = np.linalg.norm(far - h.shoulder)
    assert np.all(np.isfinite(h.q))
    ik = panda.ik_model()
    assert np.all(h.q >= ik.jnt_range[:, 0] - 1e-9) and np.all(h.q <= ik.jnt_range[:, 1] + 1e-9)
    assert h.residual == pytest.approx(np.linalg.norm(site - far), abs=1e-9)
    # the Panda reaches ~0.86 m (to the flange) + 0.13 m (hand to grasp point) from its shoulder; it must stretch out
    assert dist - 1.1 < h.residual < dist - 0.8
    with pytest.raises(ValueError, match="finite"):
        h.hold([np.nan, 0, 0], panda.grasp_candidates(far, h.shoulder), 0.0)


def test_ik_is_deterministic_and_cached():
    target = np.array([0.45, 0.1, 0.4])
    rots = panda.grasp_candidates(target, (0, 0, panda.SHOULDER_HEIGHT))
    a, _ = panda.PandaIK().solve_grasp(target, rots)
    b, _ = panda.PandaIK().solve_grasp(target, rots)
    np.testing.assert_array_equal(a.q, b.q)
    env = _env(IDS[0], True)
    action = _actions(env, 1, seed=7)[0]
    qs = []
    for _ in range(2):
        env.reset(seed=0)                       # (the task's hand_target(None) is defined for the reset scene)
        env.executor.panda.pose_for(env, None)
        env.executor.panda.pose_for(env, action)
        qs.append(env.executor.panda.q.copy())
        if len(qs) == 1:
            solves = panda.shared_ik().solves
    assert panda.shared_ik().solves == solves   # the second round came from the cache
    np.testing.assert_array_equal(qs[0], qs[1])


# ------------------------------------------------------------------------------------------------------ images
def _view(env, with_arm: bool) -> np.ndarray:
    """The env's ``view`` camera with the Panda's geom group shown or hidden (independent of render())."""
    opt = mujoco.MjvOption()
    opt.geomgroup[panda.PANDA_GEOM_GROUP] = int(with_arm)
    with mujoco.Renderer(env.model, 96, 96) as r:
        r.update_scene(env.data, camera="view", scene_option=opt)
        return r.render().copy()


def test_arm_is_drawn_in_its_geom_group():
    env = _env("PhyPlan/Launch-v0", True)
    env.reset(seed=0)
    env.executor.panda.pose_for(env, np.array([0.3, 1.2]))
    mujoco.mj_forward(env.model, env.data)
    diff = np.any(_view(env, True) != _view(env, False), axis=-1)
    assert diff.mean() > 0.01


@pytest.mark.parametrize("env_id", IDS)
def test_image_observation_does_not_show_the_panda(env_id):
    e1, e0 = _env(env_id, True, obs_mode="image", image_size=64), _env(env_id, False, obs_mode="image", image_size=64)
    action = _actions(e0, 1, seed=2)[0]
    e1.reset(seed=4)
    e1.executor.panda.pose_for(e1, action)                  # arm at the release pose, in front of the task
    o1, _ = e1.reset(seed=4)
    o0, _ = e0.reset(seed=4)
    np.testing.assert_array_equal(o1, o0)
    s1 = e1.step(action)[0]
    s0 = e0.step(action)[0]
    np.testing.assert_array_equal(s1, s0)


def test_rendered_frame_shows_the_arm():
    frames = []
    for with_panda in (True, False):
        env = _env("PhyPlan/Launch-v0", with_panda, render_mode="rgb_array")
        env.reset(seed=0)
        env.step(np.array([0.5, 1.2]))
        frames.append(env.render())
    diff = np.any(frames[0] != frames[1], axis=-1)
    assert diff.mean() > 0.01


# ------------------------------------------------------------------------------------------- package and modules
# The public names of the single-module phyplan_envs.panda before it became a package (benchmark_stepping and main
# moved to benchmarks.panda_speed), by the module that holds them now (the shared ones in the package, the posed
# arm's in phyplan_envs.panda.posed).
PUBLIC_NAMES = {
    "model": ["FRANKA_SUBDIR", "ARM_LINKS", "ARM_JOINTS", "FINGER_BODIES", "HAND_LINK", "GRASP_SITE",
              "PANDA_GEOM_GROUP", "PANDA_SITE_GROUP", "GRASP_DEPTH", "GRASP_QUAT", "SHOULDER_HEIGHT", "FINGER_OPEN",
              "FINGER_CLEARANCE", "DEFAULT_GRIP_HALF_WIDTH", "ARM_RGBA", "HAND_RGBA", "franka_assets_dir",
              "ik_model"],
    "grasp": ["grasp_rotation"],
    "ik": ["HOME_Q", "IK_SOLVER", "IK_MAX_ITERS", "IK_POS_TOL", "IK_ORI_TOL", "IK_ACCEPT_POS", "IK_ACCEPT_ORI",
           "IK_CACHE_SIZE", "IKSolution", "PandaIK", "shared_ik"],
    "posed.scene_copy": ["panda_mjcf"],
    "posed.candidates": ["grasp_candidates"],
    "posed.posing": ["PandaHandle", "attach_panda"],
}


def test_every_public_name_is_reexported_from_the_package():
    import importlib

    listed = [n for names in PUBLIC_NAMES.values() for n in names]
    assert sorted(panda.__all__) == sorted(listed)
    for module, names in PUBLIC_NAMES.items():
        mod = importlib.import_module(f"phyplan_envs.panda.{module}")
        for name in names:
            assert getattr(panda, name) is getattr(mod, name), (module, name)


def test_panda_geom_group_is_the_one_the_env_hides_from_observations():
    from phyplan_envs import base

    assert panda.PANDA_GEOM_GROUP == base.ROBOT_GEOM_GROUP


def test_missing_gymnasium_robotics_is_a_clear_error(monkeypatch):
    from phyplan_envs.panda import model

    real = importlib.util.find_spec
    monkeypatch.setattr(model.importlib.util, "find_spec",
                        lambda name, *a: None if name == "gymnasium_robotics" else real(name, *a))
    with pytest.raises(ModuleNotFoundError, match="with_panda=False"):
        model.franka_assets_dir()


def test_grasp_rotation_is_a_right_handed_frame_on_the_approach():
    approach, closing = np.array([0.3, -0.2, -1.0]), np.array([1.0, 1.0, 0.2])
    r = panda.grasp_rotation(approach, closing)
    np.testing.assert_allclose(r.T @ r, np.eye(3), atol=1e-12)
    assert np.linalg.det(r) == pytest.approx(1.0)
    np.testing.assert_allclose(r[:, 2], approach / np.linalg.norm(approach), atol=1e-12)
    assert r[:, 1] @ closing > 0          # the closing axis keeps its direction after orthogonalisation
    with pytest.raises(ValueError, match="parallel"):
        panda.grasp_rotation([0, 0, -1], [0, 0, 2])


def test_grasp_candidates_without_a_rod_are_top_down_in_both_finger_orders():
    shoulder = np.array([0.0, 0.0, panda.SHOULDER_HEIGHT])
    target = np.array([0.5, 0.2, 0.1])
    cands = panda.grasp_candidates(target, shoulder)
    assert len(cands) == 2
    for r in cands:
        np.testing.assert_allclose(r[:, 2], [0, 0, -1], atol=1e-12)
        reach = (target - shoulder)[:2]
        assert abs(r[:2, 1] @ reach) < 1e-12            # the fingers close across the reach
    np.testing.assert_allclose(cands[0][:, 1], -cands[1][:, 1], atol=1e-12)


def test_ik_rejects_bad_targets_and_its_cache_is_bounded(monkeypatch):
    from phyplan_envs.panda import ik

    solver = panda.PandaIK()
    rot = panda.grasp_candidates([0.45, 0.0, 0.3], (0, 0, panda.SHOULDER_HEIGHT))[0]
    with pytest.raises(ValueError, match="IK target"):
        solver.solve([0.4, np.inf, 0.3], rot)
    with pytest.raises(ValueError, match="IK target"):
        solver.solve([0.4, 0.0, 0.3], rot[:2])
    monkeypatch.setattr(ik, "IK_CACHE_SIZE", 2)
    targets = [np.array([0.45, y, 0.3]) for y in (-0.1, 0.0, 0.1)]
    first = [solver.solve(t, rot) for t in targets]
    assert solver.solves == 3 and len(solver._cache) == 2
    assert solver.solve(targets[2], rot) is first[2] and solver.solves == 3     # still cached
    again = solver.solve(targets[0], rot)                                          # evicted: solved anew
    assert solver.solves == 4
    np.testing.assert_array_equal(again.q, first[0].q)                            # and deterministic


def test_posing_rejects_bad_input():
    from dm_control import mjcf

    with pytest.raises(ValueError, match="base_pos"):
        panda.attach_panda(mjcf.RootElement(), base_pos=(0.0, np.nan, 0.0))
    handle = panda.attach_panda(mjcf.RootElement())
    with pytest.raises(RuntimeError, match="bind"):
        handle.set_pose(panda.HOME_Q, panda.FINGER_OPEN)
    h = _env(IDS[0], True).executor.panda
    with pytest.raises(ValueError, match="7 finite"):
        h.set_pose(np.zeros(6), panda.FINGER_OPEN)


def test_stepping_measurement_runs_and_compares_the_same_physics():
    from benchmarks import panda_speed

    rows = panda_speed.benchmark_stepping(["launch"], steps=20, repeats=1, episodes=1, frames=1)
    assert [r["with_panda"] for r in rows] == [False, True]
    without, with_ = rows
    assert with_["nq"] == without["nq"] and with_["nbody"] == without["nbody"] + 1
    for r in rows:
        for key in ("steps_per_s", "episodes_per_s", "render_ms", "paired_step_ratio", "paired_episode_ratio",
                    "paired_render_ratio"):
            assert np.isfinite(r[key]) and r[key] > 0, key
    with pytest.raises(ValueError, match="repeats"):
        panda_speed.benchmark_stepping(["launch"], repeats=0)
