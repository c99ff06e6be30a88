"""Left-right mirror of observations and actions (PPO symmetry augmentation).

The physics checks: put a robot and its mirror image (state reflected in the world's x-z
plane) side by side on the 20° incline, which rises along x and so is its own mirror image:
the second robot's observations must be the mirror of the first's; and in flight, mirrored
actions must keep the pair mirrored.
"""

from __future__ import annotations

import numpy as np
import pytest
import torch
from tensordict import TensorDict

from selfright.config import BenchmarkConfig
from selfright.env.recovery_env import RecoveryEnv
from selfright.robots import get_robot
from selfright.train.config import PPOConfig, TrainConfig
from selfright.train.contexts import make_training_worlds
from selfright.train.symmetry import augment_left_right, group_mirrors, mirror

CFG = BenchmarkConfig()
ROBOT = get_robot(CFG.robot.name)


def mirror_state(env: RecoveryEnv, state: np.ndarray) -> np.ndarray:
    """(nstate,) full-physics state of the robot's mirror image in the world x-z plane."""
    sl, out = env.sl, state.copy()
    joints, signs = ROBOT.mirror_joints, ROBOT.mirror_signs
    out[sl.pos] = state[sl.pos] * [1, -1, 1]
    out[sl.quat] = state[sl.quat] * [1, -1, 1, -1]  # R -> M R M, M = diag(1, -1, 1)
    out[sl.qpos_joints] = state[sl.qpos_joints][joints] * signs
    out[sl.lin_vel] = state[sl.lin_vel] * [1, -1, 1]
    out[sl.ang_vel] = state[sl.ang_vel] * [-1, 1, -1]
    out[sl.qvel_joints] = state[sl.qvel_joints][joints] * signs
    return out


def test_mirrors_are_involutions_and_fix_the_stand_pose():
    maps = group_mirrors(CFG.robot.name)
    g = torch.Generator().manual_seed(0)
    for name, (idx, sgn) in maps.items():
        assert sorted(idx) == list(range(len(idx)))  # a permutation
        x = torch.randn(5, len(idx), generator=g)
        torch.testing.assert_close(mirror(mirror(x, idx, sgn), idx, sgn), x)
    stand = torch.as_tensor(ROBOT.stand_pose).float()
    torch.testing.assert_close(mirror(stand, *maps["actions"]), stand)
    with pytest.raises(ValueError, match="wide"):
        mirror(torch.zeros(2, 3), *maps["actions"])


@pytest.fixture(scope="module")
def twin_env():
    worlds = make_training_worlds("incline", CFG, seed=0)
    env = RecoveryEnv(CFG, worlds, num_envs=2, threads=1)
    rngs = [np.random.default_rng(7), np.random.default_rng(7)]
    env.reset(np.arange(2), np.zeros(2, dtype=np.int64), rngs)
    env.state[1] = mirror_state(env, env.state[0])
    env.friction[1] = env.friction[0]
    env._last = None
    yield env
    env.close()


def test_mirror_image_observes_the_mirrored_observation(twin_env):
    env, maps = twin_env, group_mirrors(CFG.robot.name)
    obs = env.observe()
    assert abs(float(obs["teacher"][0, 46])) > 0.01  # the uphill direction has a y component to flip
    for group in ("student", "teacher"):
        torch.testing.assert_close(obs[group][1], mirror(obs[group][0], *maps[group]), atol=1e-5, rtol=0)


def _pair_error_in_flight(joint_map: tuple[np.ndarray, np.ndarray]) -> float:
    """Largest |student obs of twin 2 − mirror(student obs of twin 1)| over 8 control steps of
    random actions, twin 2 getting twin 1's actions through ``joint_map``, both 1.5 m up in
    the air (contacts are not mirror-exact: MuJoCo's pyramidal friction cone is not)."""
    worlds = make_training_worlds("flat", CFG, seed=0)
    env = RecoveryEnv(CFG, worlds, num_envs=2, threads=1)
    env.reset(np.arange(2), np.zeros(2, dtype=np.int64), [np.random.default_rng(7), np.random.default_rng(7)])
    env.state[0, env.sl.pos.start + 2] += 1.5
    env.state[1] = mirror_state(env, env.state[0])
    env._last = None
    maps, g, err = group_mirrors(CFG.robot.name), torch.Generator().manual_seed(1), 0.0
    for _ in range(8):
        a = torch.randn(1, ROBOT.num_joints, generator=g)
        env.step(torch.cat([a, mirror(a, *joint_map)]))
        obs = env.observe(groups=("student",))["student"]
        err = max(err, float((obs[1] - mirror(obs[0], *maps["student"])).abs().max()))
    env.close()
    return err


def test_mirrored_actions_move_the_mirror_image():
    """Trunk angular velocities reach 3.5–6.5 rad/s here; the trunk's 4 mm COM offset and
    products of inertia keep the twins 0.2 rad/s apart at most. A wrong joint map is off by
    more than the signal."""
    idx, sgn = group_mirrors(CFG.robot.name)["actions"]
    assert _pair_error_in_flight((idx, sgn)) < 0.25
    assert _pair_error_in_flight((idx, np.ones_like(sgn))) > 1.0  # abduction not flipped
    assert _pair_error_in_flight((np.arange(len(idx)), sgn)) > 1.0  # legs not swapped


def test_augment_left_right_appends_mirrors(twin_env):
    class _Env:
        env = twin_env

    obs = TensorDict({k: v for k, v in twin_env.observe().items()}, batch_size=[2])
    acts = torch.arange(24.0).reshape(2, 12)
    aug_obs, aug_act = augment_left_right(_Env(), obs=obs, actions=acts)
    assert aug_obs.batch_size[0] == 4 and aug_act.shape == (4, 12)
    torch.testing.assert_close(aug_obs["teacher"][:2], obs["teacher"])
    torch.testing.assert_close(aug_act[2:], mirror(acts, *group_mirrors(CFG.robot.name)["actions"]))
    assert augment_left_right(_Env(), obs=None, actions=acts)[0] is None


def test_ppo_config_enables_rsl_rl_symmetry():
    off = TrainConfig().to_rsl_rl("teacher")["algorithm"]["symmetry_cfg"]
    assert off is None
    on = TrainConfig(ppo=PPOConfig(symmetry_augmentation=True, mirror_loss_coef=0.5)).to_rsl_rl("teacher")
    cfg = on["algorithm"]["symmetry_cfg"]
    assert cfg["use_data_augmentation"] and cfg["use_mirror_loss"] and cfg["mirror_loss_coeff"] == 0.5


def test_warns_when_augmenting_from_weights_trained_without_it(capsys):
    from pathlib import Path

    from selfright.train.runner import _warn_symmetry_on_init

    sym = TrainConfig(ppo=PPOConfig(symmetry_augmentation=True))
    _warn_symmetry_on_init(sym, {"train_config": {"ppo": {"symmetry_augmentation": False}}}, Path("a/model_1.pt"))
    assert "warning" in capsys.readouterr().out
    _warn_symmetry_on_init(sym, {"train_config": {"ppo": {"symmetry_augmentation": True}}}, Path("a/model_1.pt"))
    _warn_symmetry_on_init(TrainConfig(), {}, Path("a/model_1.pt"))
    assert capsys.readouterr().out == ""
