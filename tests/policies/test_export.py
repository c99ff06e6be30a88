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


@pytest.mark.parametrize("width", [79, 1125])
def test_actor_rows_do_not_depend_on_the_batch(width: int):
    """``forward_rows`` gives each row the same bits whatever rows share its batch and wherever
    it falls in a block (a batched matrix product does not: BLAS sums in a batch-size-dependent
    order), and agrees with ``forward``; 1125 = a 25-frame student history."""
    from selfright.policies.learned import TorchPolicy

    actor = actor_from_checkpoint({"actor_state_dict": rsl_actor(width, "teacher").state_dict()})
    x = random_obs(200, width, seed=3)
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


def test_blocked_product_equals_one_product_per_block():
    """The rows' linear layer computes its (ROW_BLOCK, D) blocks in one batched product; each
    block's bits are those of the block's own product."""
    from selfright.policies.actor import ROW_BLOCK, _linear_rows

    gen = torch.Generator().manual_seed(5)
    w, b = torch.randn(512, 1125, generator=gen), torch.randn(512, generator=gen)
    x = torch.randn(3 * ROW_BLOCK + 5, 1125, generator=gen)
    xp = torch.nn.functional.pad(x, (0, 0, 0, ROW_BLOCK - 5))
    per_block = torch.cat([xp[i : i + ROW_BLOCK] @ w.t() for i in range(0, len(xp), ROW_BLOCK)])[: len(x)] + b
    assert torch.equal(_linear_rows(x, w, b), per_block)


def test_only_feed_forward_actors_load():
    """Metadata of older files may record the architecture keys at their no-op values (loaded);
    a recurrent or state-dependent-std actor is refused in one line."""
    sd = rsl_actor(42, "student").state_dict()
    legacy = {"gru_dim": 0, "estimator_dims": [], "state_dependent_std": False}
    assert actor_from_checkpoint({"student_state_dict": sd}, legacy).meta.obs_dim == 42
    for hint in ({"gru_dim": 16}, {"estimator_dims": [64]}, {"state_dependent_std": True}):
        with pytest.raises(ValueError, match="only feed-forward actors"):
            actor_from_checkpoint({"student_state_dict": sd}, hint)
    rnn = {**sd, "rnn.rnn.weight_hh_l0": torch.zeros(48, 16)}
    with pytest.raises(ValueError, match="rnn: only feed-forward actors"):
        actor_from_checkpoint({"student_state_dict": rnn})
    no_std = {k: v for k, v in rsl_actor(79, "teacher").state_dict().items() if not k.startswith("distribution.")}
    with pytest.raises(ValueError, match="state-dependent std"):
        actor_from_checkpoint({"actor_state_dict": no_std})


def test_onnx_policy_rows_do_not_depend_on_the_batch(tmp_path: Path):
    actor = actor_from_checkpoint({"actor_state_dict": rsl_actor(42, "student").state_dict()})
    export_onnx(actor, tmp_path / "a.onnx")
    policy = load_policy_file(tmp_path / "a.onnx")
    x = random_obs(40, 42, seed=9)
    batched = policy.act({"student": x}, np.arange(40), [None] * 40)
    for start, size in [(0, 1), (3, 7), (10, 30)]:
        part = policy.act({"student": x[start : start + size]}, np.arange(size), [None] * size)
        assert torch.equal(part, batched[start : start + size])


