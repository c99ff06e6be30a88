"""Actor export: rsl_rl checkpoint -> actor, ONNX and policy file agree with torch; loaders
reject bad files with ValueError."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch
from rsl_rl.models import MLPModel
from tensordict import TensorDict

from selfright.policies.actor import (
    ActorMeta,
    ActorMLP,
    actor_from_checkpoint,
    export_onnx,
    load_actor_file,
    save_actor_file,
    teacher_checkpoint,
)
from selfright.policies.base import Policy
from selfright.policies.learned import load_policy_file

HIDDEN = (32, 16)


def rsl_actor(obs_dim: int, group: str, seed: int = 0) -> MLPModel:
    """An rsl_rl actor with non-trivial weights and normaliser statistics."""
    torch.manual_seed(seed)
    obs = TensorDict({group: torch.zeros(4, obs_dim)}, batch_size=[4])
    model = MLPModel(
        obs, {"actor": [group]}, "actor", 12, hidden_dims=HIDDEN, activation="elu", obs_normalization=True,
        distribution_cfg={"class_name": "GaussianDistribution", "init_std": 1.0},
    )
    model.train()
    model.update_normalization(TensorDict({group: 3.0 + 2.0 * torch.randn(256, obs_dim)}, batch_size=[256]))
    return model.eval()


def random_obs(n: int, dim: int, seed: int = 1) -> torch.Tensor:
    g = torch.Generator().manual_seed(seed)
    return 3.0 + 2.0 * torch.randn(n, dim, generator=g)


@pytest.mark.parametrize(("dim", "group"), [(42, "student"), (79, "teacher")])
def test_checkpoint_actor_matches_rsl_rl(dim: int, group: str):
    model = rsl_actor(dim, group)
    actor = actor_from_checkpoint({"actor_state_dict": model.state_dict(), "iter": 7}, {"context": "flat"})
    assert actor.meta.obs_group == group and actor.meta.hidden_dims == HIDDEN and actor.meta.iteration == 7
    x = random_obs(64, dim)
    with torch.no_grad():
        expected = model(TensorDict({group: x}, batch_size=[64]))
        torch.testing.assert_close(actor(x), expected, atol=1e-6, rtol=0)


def test_student_checkpoint_exports_the_student():
    student, teacher = rsl_actor(42, "student", 0), rsl_actor(79, "teacher", 1)
    ckpt = {"student_state_dict": student.state_dict(), "teacher_state_dict": teacher.state_dict()}
    actor = actor_from_checkpoint(ckpt)
    assert actor.meta.obs_group == "student" and actor.meta.role == "student"


def test_teacher_checkpoint_loads_into_rsl_rl_and_acts_the_same():
    """A policy file turned back into a PPO checkpoint (``scripts/actor_to_run.py``) loads
    strictly into rsl_rl's actor, as distillation loads its teacher, and acts as the file does."""
    model = rsl_actor(79, "teacher")
    actor = actor_from_checkpoint({"actor_state_dict": model.state_dict(), "iter": 7}, {"context": "rough"})
    ckpt = teacher_checkpoint(actor)
    fresh = rsl_actor(79, "teacher", seed=5)
    fresh.load_state_dict(ckpt["actor_state_dict"], strict=True)
    x = random_obs(32, 79)
    with torch.no_grad():
        torch.testing.assert_close(fresh.eval()(TensorDict({"teacher": x}, batch_size=[32])), actor(x), atol=0, rtol=0)
    assert ckpt["iter"] == 7 and ckpt["infos"]["context"] == "rough" and ckpt["infos"]["hidden_dims"] == list(HIDDEN)


def test_onnx_and_torch_agree(tmp_path: Path):
    actor = actor_from_checkpoint({"actor_state_dict": rsl_actor(42, "student").state_dict()})
    path = tmp_path / "actor.onnx"
    export_onnx(actor, path)
    policy = load_policy_file(path)
    assert isinstance(policy, Policy) and policy.group == "student"
    x = random_obs(128, 42, seed=5)
    out = policy.act({"student": x}, np.arange(128), [None] * 128)
    with torch.no_grad():
        torch.testing.assert_close(out, actor(x), atol=1e-5, rtol=0)


def test_policy_file_roundtrip_weights_only(tmp_path: Path):
    actor = actor_from_checkpoint({"actor_state_dict": rsl_actor(79, "teacher").state_dict()})
    path = tmp_path / "actor.pt"
    save_actor_file(path, actor)
    torch.load(path, weights_only=True)  # must not need arbitrary unpickling
    again = load_actor_file(path)
    policy = load_policy_file(path)
    assert policy.group == "teacher"
    x = random_obs(16, 79)
    with torch.no_grad():
        torch.testing.assert_close(again(x), actor(x))
        torch.testing.assert_close(policy.act({"teacher": x}, np.arange(16), [None] * 16), actor(x))


def test_torchscript_loads_and_group_from_input_size(tmp_path: Path):
    meta = ActorMeta(obs_group="student", obs_dim=42, action_dim=12, hidden_dims=(8,), activation="tanh",
                     obs_normalization=False)
    actor = ActorMLP(meta).eval()
    path = tmp_path / "actor.jit"
    torch.jit.script(actor).save(str(path))
    policy = load_policy_file(path)
    assert policy.group == "student"
    x = torch.randn(3, 42)
    with torch.no_grad():
        torch.testing.assert_close(policy.act({"student": x}, np.arange(3), [None] * 3), actor(x))


@pytest.mark.parametrize("name", ["missing.pt", "garbage.pt", "garbage.onnx", "truncated.pt", "other.pt", "x.txt"])
def test_bad_files_raise_value_error(tmp_path: Path, name: str):
    good = tmp_path / "good.pt"
    save_actor_file(good, ActorMLP(ActorMeta(obs_group="student", obs_dim=42, action_dim=12, hidden_dims=(8,),
                                             activation="elu", obs_normalization=True)))
    path = tmp_path / name
    if name.startswith("garbage") or name == "x.txt":
        path.write_bytes(b"\x00not a model" * 20)
    elif name == "truncated.pt":
        data = good.read_bytes()
        path.write_bytes(data[: len(data) // 2])
    elif name == "other.pt":
        torch.save({"weights": torch.zeros(3)}, path)
    with pytest.raises(ValueError) as info:
        load_policy_file(path)
    msg = str(info.value)
    assert "\n" not in msg and str(path) in msg


def test_actor_rows_do_not_depend_on_the_batch():
    """``forward_rows`` gives each row the same bits whatever rows share its batch (a batched
    matrix product does not: BLAS sums in a batch-size-dependent order), and agrees with
    ``forward``."""
    from selfright.policies.learned import TorchPolicy

    actor = actor_from_checkpoint({"actor_state_dict": rsl_actor(79, "teacher").state_dict()})
    x = random_obs(200, 79, seed=3)
    alone = torch.cat([actor.forward_rows(x[i : i + 1]) for i in range(70)])
    with torch.no_grad():
        torch.testing.assert_close(actor.forward_rows(x), actor(x), atol=1e-5, rtol=0)
        for start, size in [(0, 2), (0, 7), (3, 33), (0, 64), (5, 195)]:
            rows = actor.forward_rows(x[start : start + size])
            n = min(size, 70 - start)
            assert torch.equal(rows[:n], alone[start : start + n]), (start, size)
    policy = TorchPolicy(actor, "teacher", "t")
    out = policy.act({"teacher": x[:9]}, np.arange(9), [None] * 9)
    assert torch.equal(out, alone[:9])


def test_gru_actor_matches_rsl_rl_and_rows_do_not_depend_on_the_batch():
    """A recurrent student from an rsl_rl ``RNNModel`` checkpoint: step by step it gives rsl_rl's
    actions, and ``forward_rows`` (a hand-written GRU step) gives each row the same bits
    whatever rows share its batch."""
    from rsl_rl.models import RNNModel

    torch.manual_seed(0)
    obs = TensorDict({"student": torch.zeros(4, 42)}, batch_size=[4])
    model = RNNModel(obs, {"student": ["student"]}, "student", 12, hidden_dims=HIDDEN, obs_normalization=True,
                     distribution_cfg={"class_name": "GaussianDistribution", "init_std": 1.0},
                     rnn_type="gru", rnn_hidden_dim=16)
    model.train()
    model.update_normalization(TensorDict({"student": 3.0 + 2.0 * torch.randn(256, 42)}, batch_size=[256]))
    model.eval()
    actor = actor_from_checkpoint({"student_state_dict": model.state_dict()})
    assert actor.recurrent and actor.meta.gru_dim == 16 and actor.meta.obs_dim == 42
    xs = [random_obs(50, 42, seed=s) for s in range(3)]
    h = h_rows = torch.zeros(50, 16)
    with torch.no_grad():
        model.reset(hidden_state=None)
        for x in xs:
            expected = model(TensorDict({"student": x}, batch_size=[50]))
            a, h = actor(x, h)
            a_rows, h_new = actor.forward_rows(x, h_rows)
            torch.testing.assert_close(a, expected, atol=1e-5, rtol=0)
            torch.testing.assert_close(a_rows, expected, atol=1e-5, rtol=0)
            for start, size in [(0, 1), (3, 7), (10, 40)]:
                part, h_part = actor.forward_rows(x[start : start + size], h_rows[start : start + size])
                assert torch.equal(part, a_rows[start : start + size]) and torch.equal(h_part, h_new[start : start + size])
            h_rows = h_new
    with pytest.raises(ValueError, match="hidden state"):
        actor(xs[0])


def test_onnx_policy_rows_do_not_depend_on_the_batch(tmp_path: Path):
    actor = actor_from_checkpoint({"actor_state_dict": rsl_actor(42, "student").state_dict()})
    export_onnx(actor, tmp_path / "a.onnx")
    policy = load_policy_file(tmp_path / "a.onnx")
    x = random_obs(40, 42, seed=9)
    batched = policy.act({"student": x}, np.arange(40), [None] * 40)
    for start, size in [(0, 1), (3, 7), (10, 30)]:
        part = policy.act({"student": x[start : start + size]}, np.arange(size), [None] * size)
        assert torch.equal(part, batched[start : start + size])


class _Const(Policy):
    """Acts with the same value on every joint."""

    def __init__(self, v):
        self.v = v

    def act(self, obs, ids, contexts):
        return torch.full((len(ids), 12), self.v)


def test_fallback_hands_over_only_after_a_tilted_stall():
    from selfright.policies.stall import StallSwitch
    from selfright.policies.variants import Fallback

    fb = Fallback(_Const(1.0), _Const(2.0), StallSwitch(stall_steps=2, hand_steps=3))
    ids = np.arange(2)
    fb.reset(ids)
    obs = torch.zeros(2, 42)
    obs[0, 2] = 1.0   # slot 0 on its back, still
    obs[1, 2] = -1.0  # slot 1 upright, still
    got = [fb.act({"student": obs}, ids, [None, None])[:, 0].tolist() for _ in range(6)]
    assert got == [[1.0, 1.0], [2.0, 1.0], [2.0, 1.0], [2.0, 1.0], [1.0, 1.0], [2.0, 1.0]]


def test_tilt_fallback_acts_exactly_while_tilted_over():
    from selfright.policies.stall import TiltSwitch
    from selfright.policies.variants import Fallback

    fb = Fallback(_Const(1.0), _Const(2.0), TiltSwitch(45.0))
    ids = np.arange(4)
    fb.reset(ids)
    obs = torch.zeros(4, 42)
    tilt = torch.deg2rad(torch.tensor([0.0, 44.0, 46.0, 180.0]))
    obs[:, 0], obs[:, 2] = torch.sin(tilt), -torch.cos(tilt)  # projected gravity of a trunk tilted about y
    for _ in range(2):  # no memory: the same answer every step
        assert fb.act({"student": obs}, ids, [None] * 4)[:, 0].tolist() == [1.0, 1.0, 2.0, 2.0]


def test_tilt_fallback_with_release_keeps_a_caught_robot_until_the_release_tilt():
    from selfright.policies.stall import TiltSwitch
    from selfright.policies.variants import Fallback

    fb = Fallback(_Const(1.0), _Const(2.0), TiltSwitch(45.0, release_deg=90.0))
    ids = np.arange(2)
    fb.reset(ids)

    def at(deg0: float, deg1: float) -> list[float]:
        obs = torch.zeros(2, 42)
        tilt = torch.deg2rad(torch.tensor([deg0, deg1]))
        obs[:, 0], obs[:, 2] = torch.sin(tilt), -torch.cos(tilt)
        return fb.act({"student": obs}, ids, [None] * 2)[:, 0].tolist()

    assert at(60.0, 60.0) == [2.0, 2.0]  # tilted over 45 deg from the start: the second acts
    assert at(30.0, 60.0) == [1.0, 2.0]  # slot 0 comes upright: caught
    assert at(80.0, 80.0) == [1.0, 2.0]  # caught until past 90 deg; slot 1 never was
    assert at(100.0, 40.0) == [2.0, 1.0]
    fb.reset(np.array([1]))
    assert at(60.0, 60.0) == [2.0, 2.0]  # a new episode starts uncaught
    with pytest.raises(ValueError, match="release_deg"):
        TiltSwitch(45.0, release_deg=30.0)


def test_scan_switch_hands_over_where_the_height_scan_spreads():
    from selfright.env.observations import privileged_columns
    from selfright.policies.stall import ScanSwitch
    from selfright.policies.variants import Fallback

    scan = privileged_columns(12)["scan"]
    fb = Fallback(_Const(1.0), _Const(2.0), ScanSwitch(0.027))
    assert "teacher" in fb.groups  # the scan is privileged: the teacher observation is computed
    x = torch.zeros(3, 79)
    x[:, scan] = 0.3  # level ground under a trunk 0.3 m up: no spread
    x[1, scan] += 0.02 * torch.tensor([1.0, -1.0] * 12 + [0.0])  # std 0.02 m: level-4-like
    x[2, scan] += 0.05 * torch.tensor([1.0, -1.0] * 12 + [0.0])  # std 0.05 m
    got = fb.act({"student": x[:, :42], "teacher": x}, np.arange(3), [None] * 3)[:, 0].tolist()
    assert got == [1.0, 1.0, 2.0]
    with pytest.raises(ValueError):
        ScanSwitch(0.0)


class _Count(Policy):
    """Counts the steps each slot was shown; acts with that count."""

    def __init__(self):
        self.seen = np.zeros(8)

    def act(self, obs, ids, contexts):
        self.seen[ids] += 1
        return torch.as_tensor(self.seen[ids], dtype=torch.float32).unsqueeze(1).repeat(1, 12)


def test_tilt_fallback_feeding_both_shows_the_second_every_step():
    from selfright.policies.stall import TiltSwitch
    from selfright.policies.variants import Fallback

    ids = np.arange(2)
    obs = torch.zeros(2, 42)
    obs[:, 2] = torch.tensor([-1.0, 1.0])  # slot 0 upright, slot 1 on its back
    for feed_both, second_seen in ((False, [0, 3]), (True, [3, 3])):
        second = _Count()
        fb = Fallback(_Const(1.0), second, TiltSwitch(45.0), feed_both=feed_both)
        fb.reset(ids)
        for _ in range(3):
            a = fb.act({"student": obs}, ids, [None, None])
        assert a[:, 0].tolist() == [1.0, 3.0]  # the same actions either way
        assert second.seen[:2].tolist() == second_seen


def test_teacher_height_column_is_the_trunk_height():
    from selfright.config import BenchmarkConfig
    from selfright.env.observations import teacher_height_column
    from selfright.env.recovery_env import RecoveryEnv
    from selfright.env.world import build_world
    from selfright.evaluate.runner import context_config
    from selfright.terrain.grid import grid_cells

    cfg = BenchmarkConfig()
    cell = grid_cells("tiny", cfg.terrain)[3]
    env = RecoveryEnv(cfg, [build_world(cell, cfg, context_config(cfg), 0)], 2)
    ids = np.arange(2)
    env.reset(ids, np.zeros(2, int), [np.random.default_rng(s) for s in (1, 2)])
    obs = env.observe(ids, ("teacher",))["teacher"]
    torch.testing.assert_close(obs[:, teacher_height_column(12)], env.robot_state(ids).height.float())
    env.close()


def test_fallback_with_a_bar_counts_a_low_upright_stall():
    from selfright.env.observations import teacher_height_column
    from selfright.policies.stall import StallSwitch
    from selfright.policies.variants import Fallback

    fb = Fallback(_Const(1.0), _Const(2.0), StallSwitch(stall_steps=1, hand_steps=1, bar_m=0.32))
    assert "teacher" in fb.groups
    ids = np.arange(2)
    fb.reset(ids)
    obs = torch.zeros(2, 79)
    obs[:, 2] = -1.0  # both upright and still
    obs[:, teacher_height_column(12)] = torch.tensor([0.2, 0.35])  # slot 0 sits low, slot 1 stands
    assert fb.act({"teacher": obs}, ids, [None, None])[:, 0].tolist() == [2.0, 1.0]


def test_blinded_teacher_sees_fixed_privileged_blocks():
    from selfright.env.observations import privileged_columns
    from selfright.policies.variants import Blinded

    seen = []

    class _Echo(Policy):
        def act(self, obs, ids, contexts):
            seen.append(obs["teacher"].clone())
            return torch.zeros(len(ids), 12)

    cols = privileged_columns(12)
    assert cols["factors"].stop == 79  # the teacher observation's width
    x = torch.randn(3, 79)
    Blinded(_Echo(), ["velocity", "factors"]).act({"teacher": x}, np.arange(3), [None] * 3)
    got = seen[-1]
    assert torch.equal(got[:, cols["velocity"]], torch.zeros(3, 3))
    assert torch.equal(got[:, cols["factors"]], torch.ones(3, 3))
    keep = torch.ones(79, dtype=torch.bool)
    keep[cols["velocity"]] = keep[cols["factors"]] = False
    assert torch.equal(got[:, keep], x[:, keep])  # the rest untouched, the caller's tensor too
    Blinded(_Echo(), ["scan"]).act({"teacher": x}, np.arange(3), [None] * 3)
    got = seen[-1]  # a flat ground at the trunk's own height above the ground beneath it
    assert torch.equal(got[:, cols["scan"]], x[:, cols["height"]].expand(3, cols["scan"].stop - cols["scan"].start))
    keep = torch.ones(79, dtype=torch.bool)
    keep[cols["scan"]] = False
    assert torch.equal(got[:, keep], x[:, keep])
    with pytest.raises(ValueError, match="cannot blind"):
        Blinded(_Echo(), ["slope"])


def test_smoothed_policy_low_passes_each_slot_from_its_episode_start():
    from selfright.policies.variants import Smoothed

    class _Echo(Policy):
        def act(self, obs, ids, contexts):
            return obs["student"][:, :12].clone()

    def obs(*values):
        return {"student": torch.tensor(values, dtype=torch.float32).unsqueeze(1).repeat(1, 42)}

    p = Smoothed(_Echo(), 0.75)
    ids = np.array([3, 5])
    p.reset(ids)
    assert p.act(obs(4.0, -4.0), ids, [None] * 2)[:, 0].tolist() == [4.0, -4.0]  # the first action as is
    assert p.act(obs(0.0, 0.0), ids, [None] * 2)[:, 0].tolist() == [3.0, -3.0]  # 0.75 of the last
    assert p.act(obs(0.0), ids[1:], [None])[:, 0].tolist() == [-2.25]  # slots are independent
    p.reset(ids[:1])  # a new episode in slot 3 starts afresh; slot 5 keeps its filter
    assert p.act(obs(1.0, 1.0), ids, [None] * 2)[:, 0].tolist() == [1.0, -1.4375]
    with pytest.raises(ValueError, match="beta"):
        Smoothed(_Echo(), 1.0)


def test_pose_upright_ramps_only_its_columns_of_upright_slots():
    from selfright.policies.variants import PoseUpright

    class _Ones(Policy):
        def act(self, obs, ids, contexts):
            return torch.ones(len(ids), 12)

    def obs(*gz):  # the projected gravity's z of each slot: −1 upright, 0 on its side
        x = torch.zeros(len(gz), 42)
        x[:, 2] = torch.tensor(gz)
        return {"student": x}

    p = PoseUpright(_Ones(), 15.0, 4, [0, 3, 6, 9])
    ids = np.array([0, 1])
    p.reset(ids)
    for _ in range(2):
        a = p.act(obs(-1.0, 0.0), ids, [None] * 2)
    assert a[0, [0, 3, 6, 9]].tolist() == [0.5] * 4 and a[0].sum().item() == 10.0  # half-way down its ramp
    assert a[1].tolist() == [1.0] * 12  # tilted over: untouched
    for _ in range(3):
        a = p.act(obs(-1.0, -1.0), ids, [None] * 2)
    assert a[0, [0, 3, 6, 9]].tolist() == [0.0] * 4 and a[1, 0].item() == 0.25
    assert p.act(obs(0.0, -1.0), ids, [None] * 2)[0, 0].item() == 1.0  # tilting over restarts the count
    p.reset(ids[1:])
    assert p.act(obs(0.0, -1.0), ids, [None] * 2)[1, 0].item() == 0.75  # a new episode starts its ramp afresh
    with pytest.raises(ValueError, match="ramp"):
        PoseUpright(_Ones(), 15.0, 0, [0])
    q = PoseUpright(_Ones(), 15.0, 2, [1, 2], target=[3.0, -1.0], delay_steps=2)  # a stance, after a delay
    q.reset(ids)
    got = [q.act(obs(-1.0, 0.0), ids, [None] * 2)[0, [1, 2]].tolist() for _ in range(4)]
    assert got == [[1.0, 1.0], [1.0, 1.0], [2.0, 0.0], [3.0, -1.0]]
    with pytest.raises(ValueError, match="one target per column"):
        PoseUpright(_Ones(), 15.0, 2, [1, 2], target=[3.0])
    w = PoseUpright(_Ones(), 15.0, 2, [1, 2], target=[3.0, -1.0], weight=0.25)  # a share of the way there
    w.reset(ids)
    got = [w.act(obs(-1.0, 0.0), ids, [None] * 2)[0, [1, 2]].tolist() for _ in range(2)]
    assert got == [[1.25, 0.75], [1.5, 0.5]]  # 1 + 0.25 · (3 − 1) · ramp, 1 + 0.25 · (−1 − 1) · ramp
    for bad in (0.0, 1.5):
        with pytest.raises(ValueError, match="weight"):
            PoseUpright(_Ones(), 15.0, 2, [1, 2], target=[3.0, -1.0], weight=bad)


def test_gravity_lean_turns_the_legs_towards_gravity_and_pose_upright_follows_it():
    """The stance leans with the trunk: nose up (gravity towards the trunk's −x) turns the
    thighs forward by the pitch (feet back, downhill); rolled (gravity towards +y) turns the
    hips by the roll; upright, nothing."""
    import math

    from selfright.config import ActionConfig
    from selfright.policies.pose_blend import LeanedPose, gravity_lean, lean_gains
    from selfright.policies.variants import PoseUpright
    from selfright.robots import get_robot

    robot, action = get_robot("a1"), ActionConfig()
    assert lean_gains(robot, (0.0, 0.0)) is None
    gains = torch.as_tensor(lean_gains(robot, (0.5, 1.0), scale_rad=action.scale_rad))
    assert gains.shape == (2, 12)
    a = math.radians(20)
    g = torch.tensor([[0.0, 0.0, -1.0], [-math.sin(a), 0.0, -math.cos(a)], [0.0, math.sin(a), -math.cos(a)]])
    out = gravity_lean(g, gains) * action.scale_rad  # back in rad
    torch.testing.assert_close(out[0], torch.zeros(12))
    torch.testing.assert_close(out[1, 1::3], torch.full((4,), a))  # thighs by the pitch, hips and knees still
    assert out[1, 0::3].abs().max() < 1e-6 and out[1, 2::3].abs().max() < 1e-6
    torch.testing.assert_close(out[2, 0::3], torch.full((4,), 0.5 * a))  # hips by half the roll
    assert out[2, 1::3].abs().max() < 1e-6

    class _Zeros(Policy):
        def act(self, obs, ids, contexts):
            return torch.zeros(len(ids), 12)

    x = torch.zeros(1, 42)
    x[0, :3] = g[1]  # nose up 20°: upright within 35°
    p = PoseUpright(_Zeros(), 35.0, 1, list(range(12)), weight=0.5,
                    target=LeanedPose(torch.zeros(12), lean_gains(robot, (0.0, 1.0), scale_rad=action.scale_rad)))
    p.reset(np.array([0]))
    got = p.act({"student": x}, np.array([0]), [None])[0] * action.scale_rad
    torch.testing.assert_close(got[1::3], torch.full((4,), 0.5 * a))  # half-way to the leaned stance
    with pytest.raises(ValueError, match="lean gains"):
        LeanedPose(torch.zeros(2), np.zeros((2, 3)))


def test_level_stance_levels_the_trunk_with_its_legs_and_leans_them_to_gravity():
    """The low side's legs reach further (roll), the front legs shorten nose up (pitch level),
    the thighs turn by the pitch (lean); upright it is the same square stance on every leg, and
    as actions it maps back to its joint angles."""
    import math

    from selfright.config import ActionConfig
    from selfright.policies.level_stance import LINK_M, LevelStance, LevelStanceTarget
    from selfright.robots import get_robot

    robot = get_robot("a1")
    knee_high = float(robot.joint_high[2])
    law = LevelStance(leg_m=0.33, roll_level=1.0, pitch_lean=1.0, pitch_level=0.5)
    a = math.radians(10)
    g = torch.tensor([[0.0, 0.0, -1.0], [0.0, math.sin(a), -math.cos(a)], [-math.sin(a), 0.0, -math.cos(a)]])
    q = law.joints(g, knee_high).reshape(3, 4, 3)  # (case, leg FR FL RR RL, joint)
    length = 2 * LINK_M * torch.cos(q[..., 2] / 2)
    torch.testing.assert_close(length[0], torch.full((4,), 0.33))  # upright: square
    torch.testing.assert_close(q[0, :, 1], -q[0, :, 2] / 2)  # foot under the hip
    assert (q[:, :, 0] == 0).all()  # hips at 0 throughout
    assert length[1, 1] > 0.33 > length[1, 0] and length[1, 3] > 0.33 > length[1, 2]  # left down: left legs reach
    assert length[2, 0] < 0.33 < length[2, 2]  # nose up: front legs shorter, rear longer
    torch.testing.assert_close(q[2, :, 1] + q[2, :, 2] / 2, torch.full((4,), a))  # thighs leaned by the pitch
    steep = law.joints(torch.tensor([[0.0, 0.9, -0.44]]), knee_high).reshape(4, 3)
    assert steep[:, 2].max() <= knee_high + 1e-6  # never past the knee's limit
    action = ActionConfig(reference="tall")
    target = LevelStanceTarget(law, robot, action)
    back = target(g) * action.scale_rad + torch.as_tensor(robot.reference_pose("tall"), dtype=torch.float32)
    torch.testing.assert_close(back, law.joints(g, knee_high))
    assert LevelStanceTarget(law, robot, action, [1, 4])(g).shape == (3, 2)
    with pytest.raises(ValueError, match="leg_m"):
        LevelStance(leg_m=0.5)


def test_braked_holds_its_pose_from_a_re_fall_until_the_trunk_is_still():
    from selfright.policies.variants import Braked

    class _Ones(Policy):
        def act(self, obs, ids, contexts):
            return torch.ones(len(ids), 12)

    def obs(gz, spin):  # projected gravity's z (−1 upright, 0 on its side) and the trunk's angular speed
        x = torch.zeros(1, 42)
        x[0, 2], x[0, 3] = gz, spin
        return {"student": x}

    pose = torch.full((12,), -2.0)
    p = Braked(_Ones(), pose, arm_deg=45.0, tilt_deg=60.0, spin_rps=3.0, release_rps=1.0, calm_steps=2, max_steps=5)
    ids = np.array([0])
    p.reset(ids)
    act = lambda gz, spin: p.act(obs(gz, spin), ids, [None])[0, 0].item()  # noqa: E731
    assert act(0.0, 5.0) == 1.0  # tumbling before ever being upright: the policy's own get-up
    assert act(-1.0, 5.0) == 1.0  # upright: armed
    assert act(0.0, 1.0) == 1.0  # tilted over, but turning slowly
    assert [act(0.0, 5.0), act(0.0, 0.5), act(0.0, 0.5), act(0.0, 0.5)] == [-2.0, -2.0, 1.0, 1.0]  # still 2 steps: done
    assert act(0.0, 5.0) == 1.0  # not again until upright again
    act(-1.0, 0.0)
    assert [act(0.0, 5.0) for _ in range(7)] == [-2.0] * 5 + [1.0] * 2  # never still: released after max_steps
    assert p.brakes == 2
    p.reset(ids)
    assert act(0.0, 5.0) == 1.0  # a new episode is not armed
    with pytest.raises(ValueError, match="arm_deg"):
        Braked(_Ones(), pose, arm_deg=60.0, tilt_deg=45.0)


def test_latched_keeps_the_action_of_the_moment_it_stood_still_until_it_tilts_over():
    from selfright.policies.variants import Latched

    class _Count(Policy):  # a policy whose action changes every step
        n = 0.0

        def act(self, obs, ids, contexts):
            self.n += 1.0
            return torch.full((len(ids), 12), self.n)

    def obs(gz, spin):
        x = torch.zeros(1, 42)
        x[0, 2], x[0, 3] = gz, spin
        return {"student": x}

    p = Latched(_Count(), delay_steps=2, tilt_deg=20.0, still_rps=0.5, release_deg=45.0)
    ids = np.array([0])
    p.reset(ids)
    act = lambda gz, spin: p.act(obs(gz, spin), ids, [None])[0, 0].item()  # noqa: E731
    assert [act(-1.0, 1.0), act(-1.0, 1.0)] == [1.0, 2.0]  # upright but turning: the policy acts
    assert [act(-1.0, 0.1), act(-1.0, 0.1), act(-1.0, 2.0), act(-0.8, 0.1)] == [3.0, 4.0, 4.0, 4.0]  # latched at step 4
    assert act(0.0, 0.1) == 7.0  # tilted past 45 deg: released
    assert [act(-1.0, 0.1), act(-1.0, 0.1), act(-1.0, 0.1)] == [8.0, 9.0, 9.0]  # still again: latched again
    assert p.latches == 2
    p.reset(ids)
    assert act(-1.0, 0.1) == 11.0  # a new episode starts unlatched
    with pytest.raises(ValueError, match="tilt_deg"):
        Latched(_Count(), 2, tilt_deg=50.0, release_deg=45.0)
    q = Latched(_Count(), delay_steps=2, hold_steps=3)  # released after 3 steps held, upright or not
    q.reset(ids)
    held = [q.act(obs(-1.0, 0.1), ids, [None])[0, 0].item() for _ in range(8)]
    assert held == [1.0, 2.0, 2.0, 2.0, 5.0, 6.0, 6.0, 6.0]  # latched at step 2 for 3 steps, again after 2 still ones
    with pytest.raises(ValueError, match="at least one step"):
        Latched(_Count(), 2, hold_steps=0)


def test_splayed_action_turns_the_hips_out_on_both_sides():
    from selfright.config import ActionConfig
    from selfright.policies.pose_blend import splayed_action
    from selfright.robots import get_robot

    robot, mapping = get_robot("a1"), ActionConfig(reference="stand", scale_rad=0.5)
    a = splayed_action(robot, mapping, 0.5, -0.2, 1.5, -9.0)
    q = robot.reference_pose("stand") + 0.5 * a
    assert np.allclose(q[[0, 6]], -0.5) and np.allclose(q[[3, 9]], 0.5)  # FR, RR right; FL, RL left
    assert np.allclose(q[[1, 4]], -0.2) and np.allclose(q[[7, 10]], 1.5)
    assert np.allclose(q[2::3], robot.joint_low[2::3])  # knees clipped to their range


def test_side_mirrored_decides_once_per_episode_from_gravity_and_mirrors_both_ways():
    from selfright.policies.variants import SideMirrored
    from selfright.train.symmetry import group_mirrors, mirror

    seen = []

    class _Lin(Policy):  # a fixed linear map of the observation: not mirror-symmetric
        w = torch.randn(42, 12, generator=torch.Generator().manual_seed(0))

        def act(self, obs, ids, contexts):
            seen.append(obs["student"].clone())
            return obs["student"] @ self.w

    maps = group_mirrors("a1")
    p = SideMirrored(_Lin(), +1, "a1")
    ids = np.array([0, 1])
    p.reset(ids)
    x = torch.randn(2, 42, generator=torch.Generator().manual_seed(1))
    x[:, 1] = torch.tensor([0.3, -0.3])  # gravity's body y: + in slot 0 (kept), − in slot 1 (mirrored)
    a = p.act({"student": x}, ids, [None] * 2)
    assert torch.allclose(a[0], x[0] @ _Lin.w)
    mx = mirror(x[1:], *maps["student"])
    assert torch.allclose(seen[-1][1:], mx)
    assert torch.allclose(a[1:], mirror(mx @ _Lin.w, *maps["actions"]))
    y = x.clone()
    y[:, 1] = -y[:, 1]  # the sign changes later in the episode: the choice stands
    p.act({"student": y}, ids, [None] * 2)
    assert torch.allclose(seen[-1][0], y[0]) and torch.allclose(seen[-1][1:], mirror(y[1:], *maps["student"]))
    p.reset(ids[1:])  # a new episode in slot 1 decides afresh (now + : kept)
    p.act({"student": y}, ids, [None] * 2)
    assert torch.allclose(seen[-1][1], y[1]) and torch.allclose(seen[-1][0], y[0])
    with pytest.raises(ValueError, match="side"):
        SideMirrored(_Lin(), 0, "a1")
