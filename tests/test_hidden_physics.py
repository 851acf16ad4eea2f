"""The hidden-physics track: hidden values never reach the agent, replay and seeds are exact, the train
and test spaces are what the splits draw, and the contacts obey the set restitution and friction."""
from __future__ import annotations

import math

import gymnasium as gym
import mujoco
import numpy as np
import pytest

import phyplan_envs
from phyplan_envs import hidden_physics as hp
from phyplan_envs.spaces import _process_secret
from phyplan_envs.splits import SPLITS

VARIED = list(phyplan_envs.VARIED_TASKS)
IDS = [phyplan_envs.env_id(t) for t in VARIED]


def _make(task: str, **kw):
    return gym.make(phyplan_envs.env_id(task), with_panda=False, **kw)


def _leaves(x, path="obs"):
    """Every (path, value) leaf of nested dicts, lists, tuples and arrays."""
    if isinstance(x, dict):
        for k, v in x.items():
            yield from _leaves(v, f"{path}[{k!r}]")
    elif isinstance(x, (list, tuple)):
        for i, v in enumerate(x):
            yield from _leaves(v, f"{path}[{i}]")
    elif isinstance(x, np.ndarray):
        for i, v in enumerate(np.asarray(x, dtype=object).ravel()):
            yield (f"{path}.flat[{i}]", v)
    else:
        yield (path, x)


def _keys(x):
    if isinstance(x, dict):
        for k, v in x.items():
            yield k
            yield from _keys(v)
    elif isinstance(x, (list, tuple)):
        for v in x:
            yield from _keys(v)


def test_ids_registered_and_named():
    assert IDS == ["PhyPlan/LaunchVaried-v0", "PhyPlan/SlideVaried-v1", "PhyPlan/BounceVaried-v0",
                   "PhyPlan/BridgeVaried-v1", "PhyPlan/LaunchBounceVaried-v1", "PhyPlan/PaddlesVaried-v3"]
    for i in IDS + list(phyplan_envs.LEGACY_IDS):
        assert i in gym.registry
    assert set(phyplan_envs.LEGACY_IDS) == {"PhyPlan/Bridge-v0", "PhyPlan/SlideVaried-v0", "PhyPlan/BridgeVaried-v0",
                                           "PhyPlan/LaunchBounce-v0", "PhyPlan/LaunchBounceVaried-v0",
                                           "PhyPlan/Paddles-v0", "PhyPlan/PaddlesVaried-v0", "PhyPlan/Paddles-v1",
                                           "PhyPlan/PaddlesVaried-v1", "PhyPlan/PaddlesVaried-v2"}
    assert set(phyplan_envs.TASKS) == {"launch", "slide", "bounce", "bridge", "launch-bounce", "paddles"}
    assert set(phyplan_envs.TRACKS["nominal"]) == {"launch", "slide", "bounce", "bridge", "launch-bounce"}
    assert phyplan_envs.TRACKS["depth"] == ("paddles", "paddles-varied")
    with pytest.raises(ValueError, match="unknown task"):
        phyplan_envs.env_id("launch-variied")


def test_one_declaration_of_the_hidden_parameters():
    """The hidden parameters are declared once, in the env package (phyplan_envs.hidden_physics.declaration): the
    agents' chains and identification read them from there, and the '-varied' suffix of a task name is read by one
    helper (hidden_physics.base_task) wherever a base task is needed."""
    import pathlib

    from phyplan_agents.phyplan import composer as chain_module
    from phyplan_agents.phyplan.varied import parameter_space

    assert not hasattr(chain_module, "PARAMETERS")
    assert hp.varied_tasks() == tuple(phyplan_envs.VARIED_TASKS)
    for task in hp.varied_tasks():
        assert hp.is_varied(task) and not hp.is_varied(hp.base_task(task))
        assert hp.varied_name(hp.base_task(task)) == task
        assert tuple(p.name for p in parameter_space(task)) == hp.parameter_names(task)
    root = pathlib.Path(__file__).resolve().parents[1]
    stripping = [str(f.relative_to(root)) for pkg in ("phyplan_envs", "phyplan_agents", "benchmarks")
                 for f in (root / pkg).rglob("*.py") if 'len("-varied")' in f.read_text(encoding="utf-8")]
    assert stripping == [], stripping


def test_spaces_disjoint_and_test_wider():
    for task in hp.PARAMETERS:
        for p in hp.parameters(task):
            lo, hi = p.train
            (a, b), (c, d) = p.test
            assert a < b <= lo < p.nominal < hi <= c < d, p
            assert (d - a) > (hi - lo)


@pytest.mark.parametrize("task", VARIED)
def test_hidden_values_never_reach_the_agent(task):
    """Walk obs, reset info and step info (context included): no hidden value, no parameter name."""
    env = _make(task, obs_mode="state")
    names = {p.name for p in hp.parameters(task)}
    for seed in (3, SPLITS["dev"][4], SPLITS["test"][5]):
        obs, info = env.reset(seed=seed)
        hidden = env.unwrapped.hidden_physics
        assert set(hidden) == names
        assert set(info["context"]) == {"goal", "physics_token"}
        obs2, _, _, _, info2 = env.step(env.action_space.sample())
        for what in (obs, info, obs2, info2, env.unwrapped.context):
            assert not names & set(_keys(what)), f"{task}: a parameter name in {what}"
            for path, v in _leaves(what):
                if isinstance(v, (float, np.floating)) and not isinstance(v, bool):
                    for name, h in hidden.items():
                        assert not math.isclose(float(v), h, rel_tol=1e-9, abs_tol=0.0), \
                            f"{task}: hidden {name}={h} appears at {path}"
    env.close()


@pytest.mark.parametrize("task", VARIED)
def test_same_seed_same_hidden_values_and_outcome(task):
    a, b = _make(task), _make(task)
    action = np.asarray(a.action_space.sample(), dtype=np.float64)
    outs = []
    for env in (a, b):
        _, info = env.reset(seed=SPLITS["test"][7])
        _, r, _, _, inf = env.step(action)
        outs.append((env.unwrapped.hidden_physics, r, inf["final_pos"].tobytes(), info["context"]["physics_token"]))
    assert outs[0] == outs[1]
    a.reset(seed=SPLITS["test"][8])
    assert a.unwrapped.hidden_physics != outs[0][0]     # another context, other physics
    a.close()
    b.close()


@pytest.mark.parametrize("task", VARIED)
def test_replay_reproduces_the_context(task):
    env, fresh = _make(task), _make(task)
    _, info = env.reset(seed=SPLITS["test"][2])
    ctx, hidden = info["context"], env.unwrapped.hidden_physics
    action = np.asarray(env.action_space.sample(), dtype=np.float64)
    _, r1, _, _, i1 = env.step(action)
    env.reset(seed=11)                                  # other physics in between
    for e in (env, fresh):
        e.reset(options={"context": ctx})
        assert e.unwrapped.hidden_physics == hidden
        _, r2, _, _, i2 = e.step(action)
        assert r2 == r1 and i2["final_pos"].tobytes() == i1["final_pos"].tobytes()
    env.close()
    fresh.close()


@pytest.mark.parametrize("task", VARIED)
def test_splits_draw_from_their_space(task):
    env = _make(task)
    params = hp.parameters(task)
    for split, space in (("train", "train"), ("dev", "train"), ("test", "test")):
        for seed in list(SPLITS[split])[:5]:
            _, info = env.reset(seed=seed)
            assert hp.open_token(task, info["context"]["physics_token"], _process_secret())[1] == space
            for p in params:
                assert p.in_space(env.unwrapped.hidden_physics[p.name], space), (split, seed, p.name)
    forced = _make(task, physics_space="test")
    forced.reset(seed=1)
    assert hp.open_token(task, forced.unwrapped.context["physics_token"], _process_secret())[1] == "test"
    env.close()
    forced.close()


def test_physics_differ_between_spaces_in_outcome():
    """The hidden values change the outcome: the same action lands elsewhere under other physics."""
    env = _make("launch-varied")
    env.reset(seed=0, options={"physics": {"bob_mass": 0.5, "restitution": 0.35}})
    a = np.array([0.5, 1.2])
    near = env.step(a)[4]["final_pos"]
    env.reset(seed=0, options={"physics": {"bob_mass": 0.5, "restitution": 0.85}})
    far = env.step(a)[4]["final_pos"]
    assert np.linalg.norm(far[:2]) > 1.2 * np.linalg.norm(near[:2])
    env.close()


def test_bad_inputs_name_the_argument():
    env = _make("slide-varied")
    with pytest.raises(ValueError, match="physics"):
        env.reset(seed=0, options={"physics": {"bob_mass": 0.5}})
    with pytest.raises(ValueError, match="friction"):
        env.reset(seed=0, options={"physics": {"bob_mass": 0.5, "restitution": 0.5, "friction": 5.0}})
    with pytest.raises(ValueError, match="physics_token"):
        env.reset(options={"context": {"goal": [1.0, 0.2]}})
    with pytest.raises(ValueError, match="context format before the physics was sealed"):
        env.reset(options={"context": {"goal": [1.0, 0.2], "physics_key": 3, "physics_space": "train"}})
    with pytest.raises(ValueError, match=r"options\['context'\]\['physics_token'\] must be a sealed token"):
        env.reset(options={"context": {"goal": [1.0, 0.2], "physics_token": "pt1-00"}})
    with pytest.raises(ValueError, match="physics space"):
        _make("slide-varied", physics_space="holdout")
    env.close()


def test_bob_mass_sets_mass_and_inertia_consistently():
    """After set_bob_mass the model's swing constants match MuJoCo's own mass matrix and subtree mass."""
    env = _make("launch-varied").unwrapped
    for m1 in (0.15, 0.5, 3.0):
        env.reset(seed=0, options={"physics": {"bob_mass": m1, "restitution": 0.5}})
        m, d = env.model, env.data
        mujoco.mj_forward(m, d)
        full = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, d, full)
        dof = env.pendulum.hinge_dof
        mgd, inertia = hp.pendulum_constants(m)
        assert full[dof, dof] == pytest.approx(inertia, rel=1e-9)
        arm = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "pendulum_arm")
        assert m.body_subtreemass[arm] == pytest.approx(m1 + 0.01, rel=1e-12)
    env.close()


def test_calibrated_restitution_is_speed_independent():
    for e in (0.2, 0.9):
        d = hp.calibrated_damping(e, hp.BOB_STIFFNESS, 0.0005)
        for v in (0.5, 3.0):
            assert hp.measured_restitution(hp.BOB_STIFFNESS, d, 0.0005, v) == pytest.approx(e, abs=1e-4)


@pytest.mark.parametrize("task", ["launch", "slide", "bounce", "bridge"])
def test_set_vs_measured_restitution_in_the_tasks(task):
    """Fast version of ``python -m benchmarks.design_checks.hidden_physics --only restitution`` on three fresh
    test-space contexts: within the documented bounds (0.011 Bounce, 0.004 the pendulum tasks). Bounce's error is
    gravity acting during the impact, which the calibration leaves out: switched off, the error vanishes."""
    from benchmarks.design_checks import contacts

    rows = contacts.restitution_samples(task, [7_310_000, 7_317_919, 7_325_838], "test")
    assert rows.shape == (3, 3)
    err, err_no_gravity = np.abs(rows[:, 1] - rows[:, 0]), np.abs(rows[:, 2] - rows[:, 0])
    assert err.max() <= (0.011 if task == "bounce" else 0.004), rows
    if task == "bounce":
        assert err.min() > 1e-4 and err_no_gravity.max() < 1e-6, rows
    else:
        assert err_no_gravity.max() <= 0.004, rows


def test_set_vs_measured_friction_and_the_blocks_contact():
    """Fast version of ``--only friction``: Slide's table and Bridge's plank give the set friction within 0.002. The
    block hops after leaving the pad; Bridge's round-table window (0.1 m, a hop or two) is out of contact in more of
    its steps than Slide's whole table, its fitted friction is off by more (within the documented 0.06 on training
    contexts), and Slide's table over the same stretch looks the same; the rise stays below the documented 0.8 mm."""
    from benchmarks.design_checks import contacts

    seeds = [7_310_000 + 7_919 * i for i in range(3)]
    on_slide = contacts.friction_samples("slide", seeds, "train")   # rows: set, measured, out of contact, rise (m)
    slide, stretch = on_slide["table"], on_slide["table, Bridge's stretch"]
    bridge = contacts.friction_samples("bridge", seeds, "train")
    assert len(slide) == 3 and len(bridge["table"]) == 3 and len(bridge["plank"]) == 3
    assert np.abs(slide[:, 1] - slide[:, 0]).max() <= 0.002
    assert np.abs(bridge["plank"][:, 1] - bridge["plank"][:, 0]).max() <= 0.002
    table_err = np.abs(bridge["table"][:, 1] - bridge["table"][:, 0])
    assert table_err.max() <= 0.06
    assert np.median(bridge["table"][:, 2]) > np.median(slide[:, 2]) + 0.1      # a window of hops, not of slides
    assert abs(np.median(stretch[:, 2]) - np.median(bridge["table"][:, 2])) < 0.15
    for rows in (slide, stretch, bridge["table"], bridge["plank"]):
        assert np.all((0 <= rows[:, 2]) & (rows[:, 2] <= 1)) and np.all(rows[:, 3] < 8e-4)


def _geom(env, name: str) -> int:
    return mujoco.mj_name2id(env.model, mujoco.mjtObj.mjOBJ_GEOM, name)


@pytest.mark.parametrize("task", ["slide-varied", "bridge-varied"])
def test_v1_block_faces_the_swing_plane(task):
    """v1: the puck is a box, and block and pad are turned to the swing plane before the release."""
    env = _make(task, obs_mode="state").unwrapped
    env.reset(seed=3)
    assert env.model.geom_type[_geom(env, "puck_geom")] == mujoco.mjtGeom.mjGEOM_BOX
    phi = 0.9
    q = env.release(np.array([phi] + [1.2] * (len(env.action_dims) - 1))).quat
    assert abs(2 * math.atan2(q[3], q[0]) - phi) < 1e-3
    pad = env.model.body_quat[env.body_id(hp.PAD_BODY)]
    assert abs(2 * math.atan2(pad[3], pad[0]) - phi) < 1e-12


@pytest.mark.slow
@pytest.mark.parametrize("task", ["launch", "slide", "bounce", "bridge"])
def test_landing_converged_in_the_timestep(task):
    from benchmarks.design_checks import hidden_physics as dc

    moves = dc.convergence(task, list(range(10)))
    assert np.percentile(moves, 90) <= 0.005


@pytest.mark.slow
def test_bounce_range_monotone_in_drop_height():
    from benchmarks.design_checks import hidden_physics as dc

    for e in (0.5, 0.9):
        decreases, worst, span = dc.bounce_monotonicity(e)
        assert decreases == 0 and span > 0.2


def test_harness_varied_track_by_name(tmp_path, capsys):
    """``--track varied`` runs the four varied tasks with 10 attempts and reports regret@1, @5, @10 and AUC; the
    default track stays nominal."""
    import json

    from benchmarks import harness, run

    assert harness.check_tasks(None) == list(phyplan_envs.TRACKS["nominal"])
    assert run.main(["--track", "varied", "--agents", "random", "--contexts", "1", "--seeds", "1", "--quiet",
                     "--no-plots", "--out", str(tmp_path)]) == 0
    text = capsys.readouterr().out
    for col in ("regret@1", "regret@5", "regret@10", "AUC regret"):
        assert col in text
    config = json.loads((tmp_path / "config.json").read_text())
    assert config["attempts"] == 10 and config["tasks"] == list(phyplan_envs.TRACKS["varied"])


@pytest.mark.slow
@pytest.mark.parametrize("task", VARIED)
def test_robot_mode_matches_the_kinematic_start(task):
    """Robot mode on a varied task: the arm sets up and releases; the free swing (fall) to the first touch is in
    closed form from the released state, so the outcome matches the kinematic mode."""
    kin = gym.make(phyplan_envs.env_id(task), obs_mode="state", record_trajectory=True)
    rob = gym.make(phyplan_envs.env_id(task), obs_mode="state", robot="panda", record_trajectory=True)
    action = (kin.action_space.low + kin.action_space.high) / 2 + 0.1
    kin.reset(seed=7)
    rob.reset(seed=7)
    _, _, _, _, ik = kin.step(action)
    _, _, _, _, ir = rob.step(action)
    assert ir["robot_ok"], ir["robot_reason"]
    # PaddlesVaried's ball hops along the paddles; its exact impacts keep the landing converged and stable (on the
    # superseded v2's soft pair a 1e-6 rad change of the release angle moved this landing by 18 cm), so the landings
    # of the two modes agree as on the other tasks (here by under 0.01 mm)
    assert np.linalg.norm(ik["final_pos"][:2] - ir["final_pos"][:2]) <= 0.01
