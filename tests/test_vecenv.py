"""Training env adapter and domain randomisation on the real MJCF: a few envs, a few steps."""

from __future__ import annotations

import dataclasses
import math
from types import SimpleNamespace

import mujoco
import numpy as np
import pytest
import torch

from selfright.config import BenchmarkConfig, RewardConfig
from selfright.env.randomization import ModelRandomizer, sample_factors
from selfright.robots import get_robot
from selfright.sim.scene import TERRAIN_GEOM
from selfright.train.config import EpisodeConfig, RandomizationConfig, TrainConfig
from selfright.train.contexts import make_training_worlds, training_bench, training_cells
from selfright.train.stand_starts import ground_normal
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
    np.testing.assert_allclose(m.actuator_gainprm[:12, 0], 0.8 * CFG.robot.kp)
    np.testing.assert_allclose(m.actuator_biasprm[:12, 1], -0.8 * CFG.robot.kp)
    np.testing.assert_allclose(m.actuator_biasprm[:12, 2], -1.2 * CFG.robot.kd)


def test_training_contexts():
    rough = training_cells("rough", CFG)
    extents = [c.roughness_extent_m for c in rough]
    assert len(rough) == EpisodeConfig().rough_variants and max(extents) == pytest.approx(EpisodeConfig().rough_max_extent_m)
    assert all(c.slope_pct == 0 for c in rough)
    hard = training_cells("rough", CFG, EpisodeConfig(rough_variants=4, rough_min_extent_m=0.15))
    assert [c.roughness_extent_m for c in hard] == pytest.approx([0.2, 0.25, 0.3, 0.35])
    assert [c.roughness_level for c in hard] == sorted(c.roughness_level for c in hard)
    with pytest.raises(ValueError, match="rough_min_extent_m"):
        training_cells("rough", CFG, EpisodeConfig(rough_min_extent_m=0.4))
    (incline,) = training_cells("incline", CFG)
    assert incline.slope_deg == pytest.approx(20.0)
    steep = training_cells("incline", CFG, EpisodeConfig(incline_slopes_deg=(20.0, 25.0)))
    assert [c.slope_deg for c in steep] == pytest.approx([20.0, 25.0])
    with pytest.raises(ValueError):
        training_cells("moon", CFG)


def test_training_between_walls_and_on_soft_ground():
    """``wall_gap_ratios`` / ``ground_timeconsts_s`` build every tile in each further-factor
    context; episodes in a walled world start midway between the walls and stay between them."""
    ep = EpisodeConfig(wall_gap_ratios=(1.5,), ground_timeconsts_s=(0.05,))
    worlds = make_training_worlds("flat", CFG, seed=0, episode=ep)
    assert [(w.context.wall_gap_ratio, w.context.ground_timeconst_s) for w in worlds] == [
        (None, 0.02), (1.5, 0.02), (None, 0.05), (1.5, 0.05)]
    assert np.array_equal(worlds[0].tile.heights, worlds[3].tile.heights)  # the same tile in each
    wall = worlds[1].model.geom("wall_left")
    assert wall.contype[0] == 1 and wall.pos[1] == pytest.approx(1.5 * get_robot(CFG.robot.name).body_length_m / 2 + 0.05)
    assert worlds[0].model.geom("wall_left").contype[0] == 0
    g = worlds[2].model.geom(TERRAIN_GEOM).id
    assert worlds[2].model.geom_solref[g, 0] == pytest.approx(0.05)
    env = RecoveryVecEnv(CFG, dataclasses.replace(TrainConfig(), episode=ep), worlds, num_envs=8, seed=2)
    walled = np.isin(env.env.world_idx, [1, 3])
    assert walled.any() and (~walled).any()
    y = env.env.sl.pos.start + 1
    with torch.inference_mode():
        for _ in range(25):
            env.step(torch.randn(8, 12, generator=torch.Generator().manual_seed(0)))
    half_gap = 1.5 * get_robot(CFG.robot.name).body_length_m / 2
    assert (np.abs(env.env.state[walled, y]) < half_gap).all()
    env.close()
    with pytest.raises(ValueError, match="curriculum"):
        make_training_worlds("incline", CFG, 0, EpisodeConfig(curriculum=True, wall_gap_ratios=(2.0,)))
    with pytest.raises(ValueError, match="positive"):
        make_training_worlds("flat", CFG, 0, EpisodeConfig(wall_gap_ratios=(0.0,)))
    with pytest.raises(ValueError, match="at least"):
        make_training_worlds("flat", CFG, 0, EpisodeConfig(ground_timeconsts_s=(0.005,)))


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


def test_sensor_noise_reaches_the_student_only_and_leaves_the_episodes_alone(flat_worlds):
    """``--train.randomization.sensor-noise``: the student observation is noisy, the teacher's
    (the distillation's labels) exact, and the falls and randomisation are the clean run's."""
    noisy_cfg = dataclasses.replace(TrainConfig(), randomization=RandomizationConfig(sensor_noise=1.0))
    clean = RecoveryVecEnv(CFG, TrainConfig(), flat_worlds, num_envs=2, seed=3)
    noisy = RecoveryVecEnv(CFG, noisy_cfg, flat_worlds, num_envs=2, seed=3)
    a, b = clean.get_observations(), noisy.get_observations()
    torch.testing.assert_close(a["teacher"], b["teacher"])
    torch.testing.assert_close(a["teacher"][:, :42], a["student"])
    diff = b["student"] - a["student"]
    assert diff[:, 3:6].abs().max() > 0.01 and diff[:, 30:].abs().max() == 0  # the gyro is noisy, the last action not
    clean.close()
    noisy.close()


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


@pytest.mark.parametrize("as_timeout", [True, False])
def test_leaving_the_tile_ends_as_a_time_out(flat_worlds, as_timeout):
    """Off the tile the episode ends; by default as a bootstrapped time-out, not a terminal
    state that would pay a robot with negative returns for rolling away. The opt-in off-tile
    penalty is charged to the robot that leaves, and to no other."""
    train = dataclasses.replace(TrainConfig(), episode=EpisodeConfig(off_tile_is_timeout=as_timeout),
                                reward=RewardConfig(off_tile=30.0))
    env = RecoveryVecEnv(CFG, train, flat_worlds, num_envs=2, seed=1)
    x = env.env.sl.pos.start
    env.env.state[0, x] = CFG.terrain.tile_size_m / 2 - 0.1  # inside the edge margin
    with torch.inference_mode():
        _, _, dones, extras = env.step(torch.zeros(2, 12))
    assert dones.tolist() == [True, False]
    assert extras["time_outs"].tolist() == [as_timeout, False]
    assert float(extras["log"]["Episode/left_tile_rate"]) == 1.0
    assert float(extras["log"]["Reward/off_tile"]) == -30.0 / 2  # the event term, paid by the leaver only
    env.close()


@pytest.mark.parametrize(("on", "as_timeout"), [(False, False), (True, False), (True, True)])
def test_success_ends_the_episode_only_when_asked(flat_worlds, monkeypatch, on, as_timeout):
    """``terminate_on_success``: the episode ends when the goal hold completes, as a terminal
    state or (``success_is_timeout``) as a bootstrapped time-out; off, the robot keeps holding."""
    train = dataclasses.replace(TrainConfig(), episode=EpisodeConfig(terminate_on_success=on, success_is_timeout=as_timeout))
    env = RecoveryVecEnv(CFG, train, flat_worlds, num_envs=2, seed=1)
    monkeypatch.setattr(env.env.goal, "update", lambda ids, in_goal, *args: torch.arange(len(in_goal)) == 0)  # slot 0 completes its hold
    with torch.inference_mode():
        _, _, dones, extras = env.step(torch.zeros(2, 12))
    assert dones.tolist() == [on, False]
    assert extras["time_outs"].tolist() == [on and as_timeout, False]
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
        return SimpleNamespace(roll=tilted, pitch=torch.zeros(4), feet_contact=feet, height=heights)

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
        st = SimpleNamespace(roll=zero, pitch=zero, feet_contact=feet, height=torch.tensor(heights))
        return env._low_stance_ended(st, torch.tensor(in_goal)).tolist()

    low = bar - 0.02
    assert step([low, low, low], [4, 3, 4]) == [False] * 3
    assert step([low, low, low], [4, 2, 4]) == [False] * 3  # slot 1: two feet, one off its count
    assert step([low, low, bar + 0.01], [4, 3, 4], in_goal=(False, False, True)) == [False] * 3  # slot 2 in goal: cleared
    assert step([low, low, low], [4, 3, 4]) == [True, False, False]
    assert env.low_streak.tolist() == [4, 2, 1]
    env.close()


def test_low_stance_over_the_feet_reads_the_ground_under_the_feet(flat_worlds):
    """``low_stance_over_feet_m``: the stance is low under that height above the mean ground under
    the feet (the foot sensors' x-y on the tile), whatever the goal bar says."""
    ep = EpisodeConfig(terminate_low_stance_s=2 * CFG.sim.control_dt_s, low_stance_over_feet_m=0.36)
    env = RecoveryVecEnv(CFG, dataclasses.replace(TrainConfig(), episode=ep), flat_worlds, num_envs=2, seed=1)
    bar = env.goal_bar_m
    zero = torch.zeros(2)
    env.env.state[:, env.env.sl.pos.start + 2] = (0.34, 0.38)  # trunk z; both above the 0.32 m bar
    st = SimpleNamespace(roll=zero, pitch=zero, feet_contact=torch.ones(2, 4, dtype=torch.bool),
                         height=torch.full((2,), bar + 0.02))
    ground = env.env.feet_ground_height(np.arange(2))
    assert np.allclose(ground, 0.0)  # the flat tile
    out = torch.zeros(2, dtype=torch.bool)
    assert [env._low_stance_ended(st, out).tolist() for _ in range(2)] == [[False, False], [True, False]]
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


def test_larger_training_tile_moves_the_edge_only():
    """``EpisodeConfig.tile_size_m`` widens the training tile around the same drop square: a
    robot where the benchmark's edge would end the episode keeps going."""
    ep = EpisodeConfig(tile_size_m=12.0)
    bench = training_bench(CFG, ep)
    assert bench.terrain.tile_size_m == 12.0 and bench.terrain.spawn_size_m == CFG.terrain.spawn_size_m
    assert training_bench(CFG, EpisodeConfig()) is CFG
    with pytest.raises(ValueError, match="no room"):
        training_bench(CFG, EpisodeConfig(tile_size_m=2.5))
    (world,) = make_training_worlds("flat", bench, seed=0, episode=ep)
    assert world.tile.heights.shape[0] == round(12.0 / CFG.terrain.resolution_m) + 1
    env = RecoveryVecEnv(bench, dataclasses.replace(TrainConfig(), episode=ep), [world], num_envs=2, seed=1)
    x = env.env.sl.pos.start
    env.env.state[0, x] = CFG.terrain.tile_size_m / 2 - 0.1  # past the benchmark tile's edge margin
    with torch.inference_mode():
        _, _, dones, _ = env.step(torch.zeros(2, 12))
    assert not dones.any()
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
    no = torch.zeros(3, dtype=torch.bool)  # none stopped on success

    def update(rows, left_tile):
        env._update_levels(rows, env._ended_in_goal(rows, no[: len(rows)]), left_tile)

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


def test_failed_starts_are_replayed(flat_worlds):
    """With replay 1.0 and no randomisation, episodes that end outside the goal set restart
    from exactly their own fall-protocol draw; with replay 0 they do not."""
    for share in (1.0, 0.0):
        ep = EpisodeConfig(episode_s=0.1, replay_failed=share)  # 5 control steps: nobody gets up
        train = dataclasses.replace(TrainConfig(), episode=ep, randomization=RandomizationConfig(enabled=False))
        env = RecoveryVecEnv(CFG, train, flat_worlds, num_envs=3, seed=2)
        first = env.env.state.copy()
        with torch.inference_mode():
            for _ in range(5):
                _, _, dones, extras = env.step(torch.zeros(3, 12))
        assert dones.all()
        if share:
            np.testing.assert_array_equal(env.env.state, first)
            assert env.replayed.all() and float(extras["log"]["Episode/replayed_share"]) == 0.0
            assert len(env.failed_starts) == 0  # all three were taken back out
        else:
            assert not np.allclose(env.env.state, first)
            assert "Episode/replayed_share" not in extras["log"]
        env.close()


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


@pytest.mark.parametrize("share", [1.0, 0.0])
def test_stuck_end_states_restart_episodes(flat_worlds, share):
    """With restart_stuck 1.0 every episode that ends outside the goal set hands its final
    state to a new episode (clock reset, on the ground, no new fall); with 0 new episodes
    are fresh falls."""
    ep = EpisodeConfig(episode_s=0.1, restart_stuck=share, prepare_starts=False)  # 5 steps: nobody gets up
    env = RecoveryVecEnv(CFG, dataclasses.replace(TrainConfig(), episode=ep), flat_worlds, num_envs=3, seed=4)
    with torch.inference_mode():
        for _ in range(5):
            _, _, dones, extras = env.step(torch.zeros(3, 12))
    assert dones.all() and np.allclose(env.env.state[:, 0], CFG.fall.settle_s)
    assert len(env.stuck_ends) == 0  # kept and taken back out (or never kept)
    assert env.replayed.all() == bool(share)
    if share:
        assert float(extras["log"]["Episode/replayed_share"]) == 0.0  # the episodes that ended were fresh
    else:
        assert "Episode/replayed_share" not in extras["log"]
    env.close()


def test_stuck_end_state_is_the_final_state(flat_worlds):
    """A restarted episode starts from exactly a kept end state, on that episode's tile and
    randomised model."""
    ep = EpisodeConfig(episode_s=0.1, restart_stuck=1.0, prepare_starts=False)
    env = RecoveryVecEnv(CFG, dataclasses.replace(TrainConfig(), episode=ep), flat_worlds, num_envs=2, seed=5)
    taken = []
    take = env.stuck_ends.take
    env.stuck_ends.take = lambda rng: taken.append(take(rng)) or taken[-1]
    kept = []
    put = env.stuck_ends.put
    env.stuck_ends.put = lambda e: kept.append(e) or put(e)
    with torch.inference_mode():
        for _ in range(5):
            env.step(torch.zeros(2, 12))
    assert len(kept) == 2 and len(taken) == 2 and {id(e) for e in kept} == {id(e) for e in taken}
    for i in range(2):
        e = next(e for e in taken if np.array_equal(e.state[1:], env.env.state[i, 1:]))
        assert env.env.world_idx[i] == e.world
        np.testing.assert_allclose(env.slot_factors[i], e.factors)
        assert float(env.env.friction[i]) == pytest.approx(e.factors[0], rel=1e-6)
    env.close()


def test_stuck_restarts_can_keep_only_tilted_end_states(flat_worlds):
    """With restart_tilted_only an upright end state (here: every slot is upright after the
    first steps of a settled stand) is not kept; tilted ones are."""
    kept = {}
    for tilted_only in (False, True):
        ep = EpisodeConfig(episode_s=0.1, restart_stuck=1.0, restart_tilted_only=tilted_only, prepare_starts=False)
        env = RecoveryVecEnv(CFG, dataclasses.replace(TrainConfig(), episode=ep), flat_worlds, num_envs=6, seed=4)
        kept[tilted_only] = []
        put = env.stuck_ends.put
        env.stuck_ends.put = lambda e, k=kept[tilted_only], put=put: k.append(e) or put(e)
        with torch.inference_mode():
            for _ in range(5):
                env.step(torch.zeros(6, 12))
        env.close()
    quat = env.env.sl.quat
    up = [mujoco_up_z(e.state[quat]) for e in kept[False]]
    limit = np.cos(np.radians(CFG.goal.max_tilt_deg))
    assert 0 < len(kept[True]) <= sum(u < limit for u in up) < len(kept[False])  # some upright, some not
    assert all(mujoco_up_z(e.state[quat]) < limit for e in kept[True])


def mujoco_up_z(q: np.ndarray) -> float:
    """World z of the body's up axis for a (w, x, y, z) quaternion."""
    w, x, y, z = q
    return 1.0 - 2.0 * (x * x + y * y)


def test_refall_is_a_tip_past_the_limit_after_being_upright(flat_worlds):
    """``RewardConfig.refall``: a re-fall is counted once when the up axis tips past
    ``refall_tilt_deg`` after the robot has been upright (goal-set roll and pitch) since its
    episode began or its last re-fall; a robot that was never upright, or stays tipped, is not
    counted again."""
    train = dataclasses.replace(TrainConfig(), reward=dataclasses.replace(TrainConfig().reward, refall=20.0))
    env = RecoveryVecEnv(CFG, train, flat_worlds, num_envs=3, seed=1)
    env.upright_since_fall[:] = False

    def step(roll_rad):
        roll = torch.tensor(roll_rad)
        return env._refell(SimpleNamespace(roll=roll, pitch=torch.zeros(3), up_z=torch.cos(roll))).tolist()

    assert step([0.1, 2.0, 0.8]) == [False] * 3  # slot 0 upright; slot 1 on its back; slot 2 at 46°
    assert step([2.0, 2.0, 1.7]) == [True, False, False]  # slot 0 tipped past 90° after upright
    assert step([2.5, 0.2, 2.0]) == [False] * 3  # counted once; slot 1 now upright
    assert step([0.2, 1.8, 1.0]) == [False, True, False]
    env.close()
    off = RecoveryVecEnv(CFG, TrainConfig(), flat_worlds, num_envs=3, seed=1)
    off.upright_since_fall[:] = True
    assert not off._refell(SimpleNamespace(roll=torch.full((3,), 2.0), pitch=torch.zeros(3), up_z=torch.full((3,), -0.4))).any()
    off.close()


def test_terminate_on_refall_ends_the_episode_as_terminal(flat_worlds):
    """``terminate_on_refall``: the step with a re-fall ends its episode, not as a time-out, and
    pays the ``refall`` penalty once."""
    reward = dataclasses.replace(TrainConfig().reward, refall=20.0)
    train = dataclasses.replace(TrainConfig(), reward=reward, episode=EpisodeConfig(terminate_on_refall=True))
    env = RecoveryVecEnv(CFG, train, flat_worlds, num_envs=2, seed=1)
    env._refell = lambda state: torch.tensor([True, False])  # noqa: E731 (the detection is tested above)
    with torch.inference_mode():
        _, _, dones, extras = env.step(torch.zeros(2, 12))
    assert dones.tolist() == [True, False]
    assert extras["time_outs"].tolist() == [False, False]
    assert extras["log"]["Reward/refall"].item() == pytest.approx(-20.0 / 2)
    assert env.episode_length_buf.tolist() == [0, 1]  # slot 0 restarted
    env.close()


def test_finished_episodes_restart_with_every_option_off(flat_worlds):
    train = dataclasses.replace(TrainConfig(), episode=EpisodeConfig(episode_s=2 * CFG.sim.control_dt_s))
    env = RecoveryVecEnv(CFG, train, flat_worlds, num_envs=2, seed=1)
    with torch.inference_mode():
        env.step(torch.zeros(2, 12))
        _, _, dones, extras = env.step(torch.zeros(2, 12))
    assert dones.tolist() == [True, True] and extras["time_outs"].tolist() == [True, True]
    assert env.episode_length_buf.tolist() == [0, 0]
    assert "Metrics/refall_per_s" not in extras["log"] and extras["log"]["Episode/length_s"] == pytest.approx(0.04)
    env.close()


def test_ground_normal_of_the_incline_tile():
    """The finite-difference normal of the smooth 20° tile (rising along +x) is the plane's."""
    (world,) = make_training_worlds("incline", CFG, 0)
    n = ground_normal(world.tile, np.array([0.3, -0.4]))
    s = math.radians(20.0)
    np.testing.assert_allclose(n, [-math.sin(s), 0.0, math.cos(s)], atol=1e-6)


@pytest.mark.parametrize("share", [1.0, 0.5])
def test_stand_starts_put_the_robot_upright_over_the_slope_with_momentum(share):
    """stand_start 1.0: every episode starts standing, square to the 20° slope within the
    drawn tilt, feet just off the ground, moving, the clock at the settle's end, and marked as
    not a fall; 0.5: some do and the rest are fall-protocol draws (on their backs or sides)."""
    ep = EpisodeConfig(stand_start=share, stand_start_tilt_deg=10.0)
    worlds = make_training_worlds("incline", CFG, 0, ep)
    env = RecoveryVecEnv(CFG, dataclasses.replace(TrainConfig(), episode=ep), worlds, num_envs=12, seed=4)
    e, ids = env.env, np.arange(12)
    rs = e.robot_state(ids)
    tilt = np.degrees(np.arccos(np.clip(np.cos(rs.roll.numpy()) * np.cos(rs.pitch.numpy()), -1, 1)))
    standing = env.replayed.numpy()
    assert standing.all() if share == 1.0 else 0 < standing.sum() < 12
    assert (tilt[standing] <= 20.0 + 10.0 + 1.0).all()  # square to the slope, within the drawn tilt
    assert (tilt[~standing] > 30.0).all()  # the seed's falls land inverted or on a side
    feet = e.feet_xyz(ids)
    ground = e.ground_height(np.repeat(ids, 4), feet[:, :, :2].reshape(-1, 2)).reshape(12, 4)
    lowest = (feet[:, :, 2] - ground)[standing].min(axis=1) - 0.02  # under the foot sphere
    assert ((lowest > 0.005) & (lowest < 0.015)).all()  # the 1 cm clearance, one physics step on
    speed = np.linalg.norm(e.state[standing][:, e.sl.lin_vel], axis=1)
    assert (speed > 0.0).all()
    np.testing.assert_allclose(e.state[:, e.sl.time], CFG.fall.settle_s, atol=1e-9)
    env.close()


def test_arrival_restarts_resume_the_state_the_last_action_and_the_history(flat_worlds):
    """restart_arrivals 1.0: the first step of each episode within the arrival tilt (here any
    tilt) is recorded once, and the next episodes start there, with the action applied at that
    step and the student's history as it was before that step's frame."""
    ep = EpisodeConfig(episode_s=0.1, restart_arrivals=1.0, prepare_starts=False)
    train = dataclasses.replace(TrainConfig(), episode=ep, randomization=RandomizationConfig(enabled=False),
                                distillation=dataclasses.replace(TrainConfig().distillation, student_history=4))
    env = RecoveryVecEnv(CFG, train, flat_worlds, num_envs=3, seed=6)
    env.arrival_cos = -2.0  # the falls start tilted; count any tilt as arrived
    kept = []
    put = env.arrivals.put
    env.arrivals.put = lambda e: kept.append(e) or put(e)
    group = next(k for k in env.get_observations().keys() if k.startswith("student_"))
    with torch.inference_mode():
        for step in range(5):
            obs, _, dones, _ = env.step(torch.full((3, 12), 0.3 if step == 0 else -0.2))
    assert len(kept) == 3 and dones.all() and len(env.arrivals) == 0  # one arrival per episode, all taken
    for i in range(3):
        e = next(e for e in kept if np.array_equal(e.state[1:], env.env.state[i, 1:]))
        assert env.env.state[i, 0] == pytest.approx(CFG.fall.settle_s)
        torch.testing.assert_close(env.env.prev_action[i], torch.full((12,), 0.3))
        frames = obs[group][i].reshape(4, -1).cpu()
        torch.testing.assert_close(frames[:-1], e.memory.history[1:])  # the recorded history, rolled on
        torch.testing.assert_close(frames[-1], obs["student"][i].cpu())  # then the restart's own frame
    assert env.arrived.all()  # restarts begin arrived: no second recording from them
    env.close()
