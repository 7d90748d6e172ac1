"""Goal environments (panda-gym's shape, for HER), registered ids, start and goal distributions, bounds, rewards,
termination, truncation and actions. Expectations are derived by hand from the tasks' definitions."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")

import robokit.gym  # noqa: E402
from robokit.msgs import EEDelta, GripperCommand, Twist  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
NAMES = ["Reach", "Push", "Pick", "GoTo"]
THRESHOLD = {"Reach": 0.05, "Push": 0.05, "Pick": 0.05, "GoTo": 0.15}  # the shipped configs' distance_threshold


def toward_goal(obs: dict, rng: np.random.Generator, size: int) -> np.ndarray:
    """Half the time a step at the goal (so that successes happen), else a random action."""
    if rng.random() < 0.5 or obs["achieved_goal"].shape[0] != 3:
        return rng.uniform(-1, 1, size).astype(np.float32)
    a = np.zeros(size, np.float32)
    a[:3] = np.clip((obs["desired_goal"] - obs["achieved_goal"]) / 0.05, -1, 1)
    return a


def transitions(env_id: str, n: int, seed: int = 0) -> list[tuple[dict, float, dict]]:
    env = gymnasium.make(env_id, goal_env=True)
    rng = np.random.default_rng(seed)
    obs, _ = env.reset(seed=seed)
    out = []
    for _ in range(n):
        obs, reward, terminated, truncated, info = env.step(toward_goal(obs, rng, env.action_space.shape[0]))
        out.append((obs, reward, info))
        if terminated or truncated:
            obs, _ = env.reset()
    env.close()
    return out


@pytest.mark.slow
@pytest.mark.parametrize(("name", "n"), [("Reach", 1000), ("Push", 150), ("Pick", 150), ("GoTo", 150)])
def test_compute_reward_equals_the_env_reward(name: str, n: int) -> None:
    """Sparse by default in a goal env: 0 within the threshold, else -1 (by hand from the two goals); compute_reward,
    vectorised over the whole batch, gives the same numbers."""
    rows = transitions(f"robokit/{name}-v0", n)
    achieved = np.stack([o["achieved_goal"] for o, _, _ in rows])
    desired = np.stack([o["desired_goal"] for o, _, _ in rows])
    rewards = np.array([r for _, r, _ in rows])
    by_hand = np.where(np.linalg.norm(achieved - desired, axis=1) < THRESHOLD[name], 0.0, -1.0)
    assert np.array_equal(rewards, by_hand)
    assert np.array_equal([i["is_success"] for _, _, i in rows], by_hand == 0.0)
    env = gymnasium.make(f"robokit/{name}-v0", goal_env=True)
    batch = env.unwrapped.compute_reward(achieved, desired, np.array([i for _, _, i in rows]))
    assert batch.shape == (n,) and np.array_equal(batch, rewards)
    if name == "Reach":
        assert {0.0, -1.0} <= set(rewards.tolist())  # both signs happened
        relabelled = env.unwrapped.compute_reward(achieved, achieved[::-1], {})  # HER: other goals
        assert np.array_equal(relabelled, np.where(np.linalg.norm(achieved - achieved[::-1], axis=1) < 0.05, 0, -1))
    env.close()


def test_dense_variant_reward_is_minus_the_distance() -> None:
    rows = transitions("robokit/ReachDense-v0", 60, seed=3)
    env = gymnasium.make("robokit/ReachDense-v0", goal_env=True)
    for obs, reward, info in rows:
        d = float(np.linalg.norm(obs["achieved_goal"].astype(np.float64) - obs["desired_goal"]))
        # the reward of the goals as observed (float32 positions): exactly compute_reward's, and the distance of
        # the true positions to within that rounding
        assert reward == -d and reward == pytest.approx(-info["distance"], abs=1e-6)
        assert env.unwrapped.compute_reward(obs["achieved_goal"], obs["desired_goal"], info) == reward
    env.close()


@pytest.mark.parametrize("name", NAMES)
def test_registered_ids_and_their_variants(name: str) -> None:
    plain = gymnasium.make(f"robokit/{name}-v0")
    assert isinstance(plain.observation_space, gymnasium.spaces.Box)
    assert plain.unwrapped.task.config.reward == "dense"  # a flat env keeps the config's (dense) reward
    goal = gymnasium.make(f"robokit/{name}-v0", goal_env=True)
    assert set(goal.observation_space.spaces) == {"observation", "achieved_goal", "desired_goal"}
    assert goal.unwrapped.task.config.reward == "sparse"
    assert gymnasium.make(f"robokit/{name}Dense-v0", goal_env=True).unwrapped.task.config.reward == "dense"
    assert gymnasium.make(f"robokit/{name}Sparse-v0").unwrapped.task.config.reward == "sparse"
    goal_dim = 2 if name == "GoTo" else 3
    assert goal.observation_space["desired_goal"].shape == (goal_dim,)
    obs, _ = goal.reset(seed=0)
    flat, _ = plain.reset(seed=0)
    # the goal env's observation is the flat one without the goal: HER may relabel it
    assert obs["observation"].size == flat.size - {"Reach": 3, "Push": 3, "Pick": 3, "GoTo": 4}[name]
    for env in (plain, goal):
        env.close()


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("goal_env", [False, True])
def test_check_env_without_warnings(name: str, goal_env: bool) -> None:
    """Real (finite) bounds: no 'infinite bounds' or any other warning from Gymnasium's checker."""
    from gymnasium.utils.env_checker import check_env

    env = robokit.gym.make_shipped(name, goal_env=goal_env)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env, skip_render_check=True)
    assert [str(w.message) for w in caught] == []
    env.close()


def test_reach_goals_are_panda_gyms() -> None:
    """PandaReach-v3 draws goals uniformly in [-0.15, 0.15] x [-0.15, 0.15] x [0, 0.3] with its base at x = -0.6:
    here (base at 0) x in [0.45, 0.75]; the start-to-goal distance follows from the box and the start alone."""
    env = robokit.gym.make_shipped("Reach", goal_env=True)
    goals, start = [], None
    for seed in range(300):
        obs, _ = env.reset(seed=seed)
        goals.append(obs["desired_goal"])
        start = obs["achieved_goal"]
    g = np.array(goals)
    low, high = np.array([0.45, -0.15, 0.0]), np.array([0.75, 0.15, 0.3])
    assert np.all(g >= low - 1e-6) and np.all(g <= high + 1e-6)
    assert np.all(g.min(0) < low + 0.02) and np.all(g.max(0) > high - 0.02)  # the whole box is used
    ref = np.random.default_rng(1).uniform(low, high, (20000, 3))
    expected_median = np.median(np.linalg.norm(ref - start, axis=1))
    assert np.median(np.linalg.norm(g - start, axis=1)) == pytest.approx(expected_median, abs=0.015)
    env.close()


def test_pick_goals_are_panda_gyms() -> None:
    """PandaPickAndPlace-v3: cube and goal x, y in a 30 cm square; goal z 2..22 cm, on the table 30 % of the time."""
    env = robokit.gym.make_shipped("Pick", goal_env=True)
    on_table, n = 0, 400
    for seed in range(n):
        obs, _ = env.reset(seed=seed)
        goal, cube = obs["desired_goal"], obs["achieved_goal"]
        assert 0.45 - 1e-6 <= goal[0] <= 0.75 + 1e-6 and abs(goal[1]) <= 0.15 + 1e-6 and 0.02 - 1e-6 <= goal[2] <= 0.22
        assert 0.45 - 1e-6 <= cube[0] <= 0.75 + 1e-6 and abs(cube[1]) <= 0.15 + 1e-6
        on_table += bool(abs(goal[2] - 0.02) < 1e-6)
    # 30 % of goals on the table (plus none of the others, which fall on it with probability 0): binomial, 4 sigma
    assert abs(on_table / n - 0.3) < 4 * np.sqrt(0.3 * 0.7 / n)
    env.close()


def test_push_observation_has_the_cube_orientation_and_angular_velocity() -> None:
    env = robokit.gym.make_shipped("Push")
    assert env.observation_space.shape == (3 + 3 + 3 + 4 + 3 + 3 + 3,)
    env.reset(seed=0)
    world, cube = env.unwrapped.world, env.unwrapped.world.body("cube")
    q = np.array([0.0, 0.0, np.sin(0.3), np.cos(0.3)])  # 0.6 rad about z
    world.client.resetBasePositionAndOrientation(cube, [0.6, 0.0, 0.02], q.tolist())
    world.client.resetBaseVelocity(cube, [0, 0, 0], [0.0, 0.0, 2.0])
    obs = env.unwrapped._observation()
    assert np.allclose(obs[9:13], q, atol=1e-6) and np.allclose(obs[16:19], [0, 0, 2.0], atol=1e-6)
    assert np.allclose(obs[6:9], [0.6, 0.0, 0.02], atol=1e-6)
    env.close()


def test_cube_falling_off_the_table_terminates_as_failed() -> None:
    env = robokit.gym.make_shipped("Push")
    env.reset(seed=0)
    env.unwrapped.world.set_pose("cube", [1.2, 0.0, -0.2])  # beyond the table's end (x 0.85), below fall_height
    _, reward, terminated, truncated, info = env.step(np.zeros(3, np.float32))
    assert terminated and not truncated and not info["is_success"] and "cube fell" in info["failure"]
    goal = env.unwrapped.task.goal
    cube = env.unwrapped.world.pose("cube")[0]
    assert reward == pytest.approx(-np.linalg.norm(np.array(cube) - goal))  # dense: minus the cube's distance
    env.close()


def test_truncated_at_the_time_limit_not_before() -> None:
    """max_time 2.0 s at 25 Hz: the 50th step is truncated; a still arm far from the goal never terminates."""
    env = robokit.gym.make_shipped("Reach")
    for seed in range(20):
        obs, info = env.reset(seed=seed)
        if info["distance"] > 0.1:
            break
    flags = [env.step(np.zeros(3, np.float32))[2:4] for _ in range(50)]
    assert flags[:49] == [(False, False)] * 49 and flags[49] == (False, True)
    env.close()


def test_action_spaces_and_scaling() -> None:
    """Actions are Box(-1, 1); values beyond are clipped; each kind maps 1.0 to its stated physical unit."""
    spaces = {n: robokit.gym.make_shipped(n) for n in NAMES}
    shapes = {"Reach": 3, "Push": 3, "Pick": 4, "GoTo": 2}
    for name, env in spaces.items():
        box = env.action_space
        assert box.dtype == np.float32 and box.shape == (shapes[name],)
        assert np.all(box.low == -1) and np.all(box.high == 1)
    cmds = spaces["Pick"].actions.commands([2.0, -3.0, 0.5, 0.0])
    assert cmds["arm"] == EEDelta((0.05, -0.05, 0.025))  # max_step 0.05 m, clipped at +-1
    assert cmds["gripper"] == GripperCommand("width", width=0.04, force=None)  # 0 -> half of 8 cm
    twist = spaces["GoTo"].actions.commands([0.5, -7.0])["drive"]
    assert twist == Twist(0.25, -2.0)  # max_speed 0.5 m/s, max_turn_rate 2 rad/s
    reach = spaces["Reach"]
    for action in ([1.0, 0, 0], [5.0, 0, 0]):  # clipping happens before the command: the same motion
        obs0, _ = reach.reset(seed=4)
        obs1 = reach.step(np.array(action, np.float32))[0]
        moved = obs1[0] - obs0[0]
        assert 0.03 < moved <= 0.0501  # one 5 cm step (the arm gets most of it within one 0.04 s step)
        if action[0] == 1.0:
            first = obs1
    assert np.array_equal(first, obs1)
    for env in spaces.values():
        env.close()


def test_pick_succeeds_under_a_scripted_grasp() -> None:
    """The task is solvable as declared: above the cube, down, close, carry to the goal (10 seeds, all succeed)."""
    env = robokit.gym.make_shipped("Pick")
    for seed in range(10):
        obs, info = env.reset(seed=seed)
        phase, closing = "above", 0
        for _ in range(50):
            ee, cube, goal = obs[0:3], obs[7:10], obs[20:23]
            grip, target = 1.0, cube + [0.0, 0.0, 0.06]
            if phase == "above" and np.linalg.norm(ee[:2] - cube[:2]) < 0.01:
                phase = "down"
            if phase == "down":
                target = cube
                phase = "close" if abs(ee[2] - cube[2]) < 0.01 else phase
            if phase == "close":
                target, grip, closing = cube, -1.0, closing + 1
                phase = "carry" if closing >= 4 else phase
            if phase == "carry":
                target, grip = goal, -1.0
            obs, _, terminated, truncated, info = env.step(
                np.append(np.clip((target - ee) / 0.05, -1, 1), grip).astype(np.float32))
            if terminated or truncated:
                break
        assert terminated and info["is_success"], (seed, info)
        assert np.linalg.norm(obs[7:10] - goal) < 0.05  # by hand: the cube, not the hand, is at the goal
    env.close()


def test_registered_ids_find_their_configs_without_a_source_tree(monkeypatch, tmp_path) -> None:
    """A wheel install has no configs/gym next to the package: the ids read the copy installed as
    ``robokit_configs.gym`` (the same files: pyproject maps that package to configs/gym)."""
    import robokit.gym as rgym

    monkeypatch.setattr(rgym, "CONFIG_DIR", tmp_path / "no-such-checkout" / "configs" / "gym")
    found = rgym._config_dir()
    assert found != rgym.CONFIG_DIR
    assert sorted(p.name for p in found.glob("*.toml")) == sorted(rgym.SHIPPED.values())
    env = rgym.make_shipped("Reach")
    try:
        obs, _ = env.reset(seed=0)
        assert env.observation_space.contains(obs)
    finally:
        env.close()
