"""Training env adapter and domain randomisation on the real MJCF: a few envs, a few steps."""

from __future__ import annotations

from dataclasses import replace

import dataclasses
from types import SimpleNamespace

import mujoco
import numpy as np
import pytest
import torch

from selfright.config import BenchmarkConfig
from selfright.env.observations import sensor_noise_std
from selfright.env.randomization import DCMOTOR_KD, DCMOTOR_KP, ModelRandomizer, sample_factors
from selfright.robots import get_robot
from selfright.sim.scene import TERRAIN_GEOM
from selfright.train.config import EpisodeConfig, RandomizationConfig, TrainConfig
from selfright.train.contexts import make_training_worlds, training_cells
from selfright.train.vecenv import RecoveryVecEnv

CFG = BenchmarkConfig()


@pytest.fixture(scope="module")
def flat_worlds():
    return make_training_worlds("flat", CFG, seed=0)


def test_sample_factors_ranges_and_seeding():
    cfg = RandomizationConfig()
    a = sample_factors(200, cfg, np.random.default_rng(3))
    b = sample_factors(200, cfg, np.random.default_rng(3))
    np.testing.assert_array_equal(a.friction, b.friction)
    for values, (lo, hi) in [(a.friction, cfg.friction), (a.kp_scale, cfg.kp_scale), (a.kd_scale, cfg.kd_scale),
                             (a.mass_scale, cfg.mass_scale)]:
        assert values.min() >= lo and values.max() <= hi and values.std() > 0
    assert a.as_tensor().shape == (200, 3)


def test_randomizer_writes_copies(flat_worlds):
    base = flat_worlds[0].model
    r = ModelRandomizer(base, get_robot(CFG.robot.name))
    m = r.apply(base, friction=0.5, mass=1.1, kp=0.8, kd=1.2)
    g = base.geom(TERRAIN_GEOM).id
    assert m.geom_friction[g, 0] == pytest.approx(0.5)
    assert base.geom_friction[g, 0] == pytest.approx(1.0)  # the world's model is untouched
    trunk = base.body("trunk").id
    assert m.body_mass[trunk] == pytest.approx(1.1 * base.body_mass[trunk])
    assert m.body_mass[0] == base.body_mass[0]  # world body is not the robot
    assert r.dcmotor  # the default motors: the DC controller's torque-space gains are scaled
    np.testing.assert_allclose(m.actuator_gainprm[:12, DCMOTOR_KP], 0.8 * base.actuator_gainprm[:12, DCMOTOR_KP])
    np.testing.assert_allclose(m.actuator_gainprm[:12, DCMOTOR_KD], 1.2 * base.actuator_gainprm[:12, DCMOTOR_KD])
    np.testing.assert_allclose(base.actuator_gainprm[:12, DCMOTOR_KP], CFG.robot.kp, rtol=1e-6)


def test_randomizer_scales_ideal_servo_gains():
    cfg = BenchmarkConfig(robot=replace(BenchmarkConfig().robot, motor="ideal"))
    base = make_training_worlds("flat", cfg, seed=0)[0].model
    r = ModelRandomizer(base, get_robot(cfg.robot.name))
    m = r.apply(base, friction=0.5, mass=1.1, kp=0.8, kd=1.2)
    assert not r.dcmotor
    np.testing.assert_allclose(m.actuator_gainprm[:12, 0], 0.8 * cfg.robot.kp)
    np.testing.assert_allclose(m.actuator_biasprm[:12, 1], -0.8 * cfg.robot.kp)
    np.testing.assert_allclose(m.actuator_biasprm[:12, 2], -1.2 * cfg.robot.kd)






def test_step_shapes_rewards_and_factors(flat_worlds):
    env = RecoveryVecEnv(CFG, TrainConfig(), flat_worlds, num_envs=3, seed=0)
    obs = env.get_observations()
    assert obs["student"].shape == (3, 42) and obs["teacher"].shape == (3, 79)
    # The teacher sees the randomised factors (its last three inputs) and friction.
    torch.testing.assert_close(obs["teacher"][:, -3:], env.env.factors)
    assert not torch.allclose(env.env.factors, torch.ones(3, 3))
    g = flat_worlds[0].model.geom(TERRAIN_GEOM).id
    frictions = [env.env.models[i].geom_friction[g, 0] for i in range(3)]
    np.testing.assert_allclose(frictions, env.env.friction.numpy(), rtol=1e-6)
    with torch.inference_mode():
        for _ in range(3):
            obs, rew, dones, extras = env.step(torch.zeros(3, 12))
    assert rew.shape == (3,) and torch.isfinite(rew).all()
    assert dones.shape == (3,) and extras["time_outs"].shape == (3,)
    log = extras["log"]
    for name in ("orientation", "torques", "feet_contact", "joint_limits"):
        assert f"Reward/{name}" in log
    env.close()




@pytest.mark.parametrize("term, weight, low, high", [("bar_ramp", 20.0, 0.0, 20.0), ("feet_under_hips", 5.0, -5.0, 0.0)])
def test_stance_terms_are_paid_and_logged_with_their_weight(flat_worlds, term, weight, low, high):
    """The terms beyond Table I that read the stance: paid within their bounds (per s × dt; a
    foot 0.5 m from its root in each of four legs costs 1 m²) and logged only with a weight."""
    from selfright.env.rewards import RewardConfig

    train = TrainConfig(reward=RewardConfig(**{term: weight}))
    env = RecoveryVecEnv(CFG, train, flat_worlds, num_envs=3, seed=0)
    with torch.inference_mode():
        _, _, _, extras = env.step(torch.zeros(3, 12))
    paid = float(extras["log"][f"Reward/{term}"])
    assert low * env.dt <= paid <= high * env.dt
    assert f"Reward/{term}" not in RecoveryVecEnv(CFG, TrainConfig(), flat_worlds, num_envs=1, seed=0).step(
        torch.zeros(1, 12))[3]["log"]
    env.close()


def test_feet_under_hips_needs_the_robots_leg_roots(flat_worlds, monkeypatch):
    from selfright.env import recovery_env
    from selfright.env.rewards import RewardConfig

    robot = dataclasses.replace(get_robot("a1"), leg_roots_m=None)
    monkeypatch.setattr(recovery_env, "get_robot", lambda name: robot)
    with pytest.raises(ValueError, match="leg roots of robot 'a1'"):
        RecoveryVecEnv(CFG, TrainConfig(reward=RewardConfig(feet_under_hips=5.0)), flat_worlds, num_envs=1, seed=0)


def test_time_out_resets_and_is_reported(flat_worlds):
    train = dataclasses.replace(TrainConfig(), episode=EpisodeConfig(episode_s=0.1))  # 5 control steps
    env = RecoveryVecEnv(CFG, train, flat_worlds, num_envs=2, seed=1)
    assert env.max_episode_length == 5
    with torch.inference_mode():
        for k in range(5):
            _, _, dones, extras = env.step(torch.zeros(2, 12))
            if k < 4:
                assert not dones.any()
    assert dones.all() and extras["time_outs"].all()
    assert "Episode_Reward/orientation" in extras["log"] and "Episode/success_rate" in extras["log"]
    assert (env.episode_length_buf == 0).all() and (env.env.step_count == 0).all()
    env.close()






def test_low_stance_streak_ends_only_an_unbroken_crouch(flat_worlds):
    """``terminate_low_stance_s``: an episode ends once the robot has stood upright on four feet
    under the goal bar for that long without a break; a stance above the bar, a foot off or a
    tilted trunk resets the count."""
    ep = EpisodeConfig(terminate_low_stance_s=3 * CFG.sim.control_dt_s)
    env = RecoveryVecEnv(CFG, dataclasses.replace(TrainConfig(), episode=ep), flat_worlds, num_envs=4, seed=1)
    bar = env.goal_bar_m
    feet = torch.ones(4, 4, dtype=torch.bool)
    feet[2, 0] = False  # slot 2: a foot off
    tilted = torch.tensor([0.0, 0.0, 0.0, 0.7])  # slot 3: 40° of roll

    def state(h0: float):
        heights = torch.tensor([h0, bar + 0.03, bar - 0.02, bar - 0.02])
        return SimpleNamespace(roll=tilted, pitch=torch.zeros(4), feet_contact=feet, height_over_feet=heights)

    out = torch.zeros(4, dtype=torch.bool)
    ended = [env._low_stance_ended(state(h), out).tolist() for h in (bar - 0.02, bar - 0.02, bar + 0.01, bar - 0.02, bar - 0.02)]
    assert ended == [[False] * 4] * 5  # the third step, above the bar, broke slot 0's streak
    assert env._low_stance_ended(state(bar - 0.02), out).tolist() == [True, False, False, False]
    env.close()
    off = RecoveryVecEnv(CFG, TrainConfig(), flat_worlds, num_envs=4, seed=1)
    assert not off._low_stance_ended(state(bar - 0.02), out).any()
    off.close()


def test_leaky_low_stance_count_outlasts_a_lifted_foot(flat_worlds):
    """``low_stance_leaky``: three feet count, a step off the stance takes one off the count
    (a robot creeping with a foot up now and then is still ended), the goal set clears it."""
    ep = EpisodeConfig(terminate_low_stance_s=4 * CFG.sim.control_dt_s, low_stance_leaky=True)
    env = RecoveryVecEnv(CFG, dataclasses.replace(TrainConfig(), episode=ep), flat_worlds, num_envs=3, seed=1)
    bar = env.goal_bar_m
    zero = torch.zeros(3)

    def step(heights, feet_down, in_goal=(False, False, False)):
        feet = torch.zeros(3, 4, dtype=torch.bool)
        for i, k in enumerate(feet_down):
            feet[i, :k] = True
        st = SimpleNamespace(roll=zero, pitch=zero, feet_contact=feet, height_over_feet=torch.tensor(heights))
        return env._low_stance_ended(st, torch.tensor(in_goal)).tolist()

    low = bar - 0.02
    assert step([low, low, low], [4, 3, 4]) == [False] * 3
    assert step([low, low, low], [4, 2, 4]) == [False] * 3  # slot 1: two feet, one off its count
    assert step([low, low, bar + 0.01], [4, 3, 4], in_goal=(False, False, True)) == [False] * 3  # slot 2 in goal: cleared
    assert step([low, low, low], [4, 3, 4]) == [True, False, False]
    assert env.low_streak.tolist() == [4, 2, 1]
    env.close()




def test_feet_sensors_are_the_foot_geoms(flat_worlds):
    env = RecoveryVecEnv(CFG, TrainConfig(), flat_worlds, num_envs=2, seed=1)
    with torch.inference_mode():
        for _ in range(40):  # hold the stand pose until the robots lie nearly still
            env.step(torch.zeros(2, 12))
    inner = env.env
    model = inner.models[1]
    data = mujoco.MjData(model)
    mujoco.mj_setState(model, data, inner.state[1], mujoco.mjtState.mjSTATE_FULLPHYSICS)
    mujoco.mj_kinematics(model, data)
    want = np.stack([data.geom_xpos[model.geom(g).id] for g in inner.robot.foot_geoms])
    # sensors are read in the last physics step before its integration: millimetres apart
    assert np.allclose(inner.feet_xyz(np.array([1]))[0], want, atol=5e-3)
    env.close()


def test_low_stance_end_is_terminal(flat_worlds, monkeypatch):
    """The low-stance end is a terminal state (no bootstrapped value), logged per episode."""
    ep = EpisodeConfig(terminate_low_stance_s=1.0)
    env = RecoveryVecEnv(CFG, dataclasses.replace(TrainConfig(), episode=ep), flat_worlds, num_envs=2, seed=1)
    monkeypatch.setattr(env, "_low_stance_ended", lambda state, in_goal: torch.tensor([True, False]))
    with torch.inference_mode():
        _, _, dones, extras = env.step(torch.zeros(2, 12))
    assert dones.tolist() == [True, False]
    assert extras["time_outs"].tolist() == [False, False]
    assert float(extras["log"]["Episode/low_stance_end_rate"]) == 1.0
    env.close()




def test_incline_curriculum_levels_move_with_the_goal_window():
    ep = EpisodeConfig(curriculum=True, incline_curriculum_deg=(5.0, 20.0), episode_s=0.1)
    cells = training_cells("incline", CFG, ep)
    assert [round(c.slope_deg, 3) for c in cells] == [5.0, 20.0]
    worlds = make_training_worlds("incline", CFG, 0, ep)
    env = RecoveryVecEnv(CFG, dataclasses.replace(TrainConfig(), episode=ep), worlds, num_envs=3, seed=0)
    assert env.curriculum and (torch.from_numpy(env.env.world_idx) == 0).all()  # everyone starts easy
    ids = torch.arange(3)
    env.tail_goal_steps[:] = torch.tensor([env.window, env.window, 0])

    def update(rows, left_tile):
        env._update_levels(rows, env._ended_in_goal(rows), left_tile)

    update(ids, torch.tensor([False, True, False]))
    assert env.level.tolist() == [1, 0, 0]  # promoted; left the tile; never in the goal
    update(ids[:1], torch.tensor([False]))
    assert env.level.tolist() == [1, 0, 0]  # clamped at the top
    env._reset(np.arange(3))
    assert env.env.world_idx.tolist() == [1, 0, 0]
    env.tail_goal_steps[:] = 0
    update(ids, torch.zeros(3, dtype=torch.bool))
    assert env.level.tolist() == [0, 0, 0]
    env.close()


def test_networks_device_is_checked(tmp_path, monkeypatch):
    """--device cuda on a machine without CUDA is a clear user error, raised before any work."""
    from selfright.train.commands import TrainArgs, train

    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    with pytest.raises(ValueError, match="no CUDA device"):
        train(TrainArgs(out=tmp_path / "run", device="cuda", iterations=1))
    assert not (tmp_path / "run").exists()




@pytest.mark.parametrize("prepare", [True, False])
def test_prepared_starts_settle_in_one_batch(flat_worlds, prepare):
    """Staggered episode ends: with prepare_starts the first end settles the next start of
    every slot in one call, and the later ends take theirs; without it each end settles alone.
    Either way every new episode begins from a settled fall (time = settle_s)."""
    ep = EpisodeConfig(episode_s=0.1, prepare_starts=prepare)  # 5 control steps
    env = RecoveryVecEnv(CFG, dataclasses.replace(TrainConfig(), episode=ep), flat_worlds, num_envs=4, seed=3)
    calls = []
    settle = env.env.settle
    env.env.settle = lambda w, r, m: calls.append(len(w)) or settle(w, r, m)
    env.episode_length_buf[:] = torch.tensor([4, 3, 2, 1])  # slot k ends at step k + 1
    with torch.inference_mode():
        for k in range(4):
            if prepare and k > 0:
                expected = env.next_start.state[k].copy()
            _, _, dones, _ = env.step(torch.zeros(4, 12))
            assert dones.tolist() == [j == k for j in range(4)]
            assert env.env.state[k, 0] == pytest.approx(CFG.fall.settle_s)
            if prepare and k > 0:
                np.testing.assert_array_equal(env.env.state[k], expected)  # the start prepared for it
            # The episode runs on the randomised model its start settled on (rebuilt from the
            # kept factors) and the teacher observes those factors.
            g = flat_worlds[0].model.geom(TERRAIN_GEOM).id
            assert env.env.models[k].geom_friction[g, 0] == pytest.approx(float(env.env.friction[k]), rel=1e-6)
            trunk = flat_worlds[0].model.body("trunk").id
            ratio = env.env.models[k].body_mass[trunk] / flat_worlds[0].model.body_mass[trunk]
            assert ratio == pytest.approx(float(env.env.factors[k, 0]), rel=1e-6)
    assert calls == ([4] if prepare else [1, 1, 1, 1])
    if prepare:
        assert not env.next_start.ready.any()  # all four taken
    env.close()


def test_prepared_start_on_a_stale_curriculum_level_is_redrawn():
    ep = EpisodeConfig(curriculum=True, incline_curriculum_deg=(5.0, 20.0), episode_s=0.1)
    worlds = make_training_worlds("incline", CFG, 0, ep)
    env = RecoveryVecEnv(CFG, dataclasses.replace(TrainConfig(), episode=ep), worlds, num_envs=2, seed=0)
    env._reset(np.array([0]))  # prepares both slots' next starts on level 0 and takes slot 0's
    assert env.next_start.ready.tolist() == [False, True] and env.next_start.world[1] == 0
    env.level[1] = 1  # promoted since
    env._reset(np.array([1]))
    assert env.env.world_idx.tolist() == [0, 1]
    env.close()


def test_student_history_group_stacks_frames_and_restarts_with_the_episode(flat_worlds):
    train = dataclasses.replace(TrainConfig(), episode=EpisodeConfig(episode_s=0.06),  # 3 control steps
                                distillation=dataclasses.replace(TrainConfig().distillation, student_history=3))
    env = RecoveryVecEnv(CFG, train, flat_worlds, num_envs=2, seed=0)
    obs = env.get_observations()
    assert obs["student_history"].shape == (2, 3 * 42)
    torch.testing.assert_close(obs["student_history"], obs["student"].repeat(1, 3))
    frames = [obs["student"]]
    with torch.inference_mode():
        for _ in range(2):
            obs, _, dones, _ = env.step(torch.zeros(2, 12))
            frames.append(obs["student"])
        assert not dones.any()
        torch.testing.assert_close(obs["student_history"], torch.cat(frames, dim=1))
        obs, _, dones, _ = env.step(torch.zeros(2, 12))  # time-out: new episodes start
    assert dones.all()
    torch.testing.assert_close(obs["student_history"], obs["student"].repeat(1, 3))
    env.close()


def noisy_train(noise: float, **randomization) -> TrainConfig:
    """Default training with ``sensor_noise`` = ``noise`` and a 2-frame student history."""
    return dataclasses.replace(
        TrainConfig(), randomization=RandomizationConfig(sensor_noise=noise, **randomization),
        distillation=dataclasses.replace(TrainConfig().distillation, student_history=2))


def rollout(train: TrainConfig, worlds, n: int, steps: int, seed: int = 5) -> list[dict]:
    """The observation groups and robot states of ``steps`` + 1 control steps of ``n`` envs under
    the same fixed actions (drawn from their own generator)."""
    env = RecoveryVecEnv(CFG, train, worlds, num_envs=n, seed=seed)
    actions = torch.from_numpy(np.random.default_rng(7).uniform(-1, 1, (steps, n, 12))).float()
    out = [{**env.get_observations().to_dict(), "state": env.env.state.copy()}]
    with torch.inference_mode():
        for a in actions:
            obs, rew, dones, _ = env.step(a)
            assert not dones.any()
            out.append({**obs.to_dict(), "state": env.env.state.copy(), "reward": rew})
    env.close()
    return out


def test_sensor_noise_must_be_finite_and_not_negative():
    for bad in (-0.1, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="sensor-noise must be a finite number >= 0"):
            RandomizationConfig(sensor_noise=bad)
    assert RandomizationConfig(sensor_noise=0.5).active_sensor_noise == 0.5
    assert RandomizationConfig(sensor_noise=0.5, enabled=False).active_sensor_noise == 0.0


def test_no_sensor_noise_leaves_the_observations_exact(flat_worlds):
    """At 0 (or with randomisation off) every group is what ``RecoveryEnv.observe`` reads off the
    states, the student history stacks those exact frames, and nothing is drawn for noise."""
    for train in (noisy_train(0.0), noisy_train(1.0, enabled=False)):
        env = RecoveryVecEnv(CFG, train, flat_worlds, num_envs=3, seed=2)
        assert env.sensor_noise_std is None
        before = env.noise_rng.bit_generator.state
        with torch.inference_mode():
            prev = env.get_observations()["student"]
            obs, _, _, _ = env.step(torch.zeros(3, 12))
        exact = env.env.observe()
        torch.testing.assert_close(obs["student"], exact["student"], rtol=0, atol=0)
        torch.testing.assert_close(obs["teacher"], exact["teacher"], rtol=0, atol=0)
        torch.testing.assert_close(obs["student_history"], torch.cat([prev, exact["student"]], dim=1), rtol=0, atol=0)
        assert env.noise_rng.bit_generator.state == before
        env.close()


def test_sensor_noise_reaches_the_student_only_at_its_scale_and_leaves_the_episodes_alone(flat_worlds):
    """``--train.randomization.sensor-noise``: the ``student`` group and its history frames read
    noisy sensors, S × ``sensor_noise_std`` per column (none on the previous action); the teacher
    group, the physics and the rewards are those of the run without noise."""
    n, steps, scale = 32, 6, 0.5
    clean = rollout(noisy_train(0.0), flat_worlds, n, steps)
    noisy = rollout(noisy_train(scale), flat_worlds, n, steps)
    for c, z in zip(clean, noisy):
        np.testing.assert_array_equal(z["state"], c["state"])
        torch.testing.assert_close(z["teacher"], c["teacher"], rtol=0, atol=0)
        if "reward" in c:
            torch.testing.assert_close(z["reward"], c["reward"], rtol=0, atol=0)
        torch.testing.assert_close(z["student_history"][:, 42:], z["student"], rtol=0, atol=0)
    for k in range(1, len(noisy)):  # the history's older frame is the step before's noisy one
        torch.testing.assert_close(noisy[k]["student_history"][:, :42], noisy[k - 1]["student"], rtol=0, atol=0)
    residual = torch.cat([z["student"] - c["student"] for c, z in zip(clean, noisy)]).double()  # ((steps + 1) n, 42)
    want = scale * sensor_noise_std(12).double()
    assert residual.abs().mean(dim=0).tolist() == pytest.approx(
        (want * np.sqrt(2 / np.pi)).tolist(), rel=0.2)  # the Gaussian's mean absolute value
    got = residual.std(dim=0)
    for cols in (slice(0, 3), slice(3, 6), slice(6, 18), slice(18, 30)):  # gravity, gyro, joint angles, speeds
        assert float(got[cols].square().mean().sqrt()) == pytest.approx(float(want[cols][0]), rel=0.1), cols
    assert (residual[:, 30:] == 0).all()  # the previous action is the policy's own


def test_sensor_noise_is_drawn_the_same_for_the_same_seed(flat_worlds):
    a = rollout(noisy_train(1.0), flat_worlds, 4, 3)
    b = rollout(noisy_train(1.0), flat_worlds, 4, 3)
    other = rollout(noisy_train(1.0), flat_worlds, 4, 3, seed=6)
    for x, y in zip(a, b):
        for group in ("student", "student_history", "teacher"):
            torch.testing.assert_close(x[group], y[group], rtol=0, atol=0)
    assert not torch.equal(a[0]["student"], other[0]["student"])
