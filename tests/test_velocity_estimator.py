"""The student's trunk-velocity estimator (``selfright.train.velocity_estimator``): where its
gradients flow, that it learns its target, that the deployed actor (policy file, ONNX) computes
what the trained model does, and a distillation run that trains, saves and resumes it."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import numpy as np
import pytest
import torch
from tensordict import TensorDict

from selfright.env.observations import privileged_columns
from selfright.policies.actor import actor_from_checkpoint, export_onnx, load_actor_file, save_actor_file, teacher_checkpoint
from selfright.policies.base import Policy
from selfright.policies.learned import load_policy_file
from selfright.policies.variants import EstimatedVelocity
from selfright.train.checkpoints import latest_checkpoint
from selfright.train.velocity_estimator import OPTIMIZER_KEY, EstimatorMLPModel, EstimatorTrainer

from test_export import rsl_actor
from test_scripts import run_script
from test_learning_smoke import TINY, run, spec

FRAMES = 3
STUDENT, TEACHER = 42, 79


def rollout(n: int, seed: int = 0) -> TensorDict:
    """Observation groups of ``n`` samples whose true velocity is a fixed linear map of the
    student's latest frame (so an estimator can learn it)."""
    g = torch.Generator().manual_seed(seed)
    student = torch.randn(n, STUDENT, generator=g)
    teacher = torch.cat([student, torch.randn(n, TEACHER - STUDENT, generator=g)], dim=-1)
    w = torch.linspace(-1.0, 1.0, STUDENT * 3).reshape(STUDENT, 3) / 4.0
    teacher[:, privileged_columns(12)["velocity"]] = student @ w
    history = torch.cat([torch.randn(n, (FRAMES - 1) * STUDENT, generator=g), student], dim=-1)
    return TensorDict({"student": student, "student_history": history, "teacher": teacher}, batch_size=[n])


def model(seed: int = 0) -> EstimatorMLPModel:
    torch.manual_seed(seed)
    m = EstimatorMLPModel(rollout(4), {"student": ["student_history"]}, "student", 12, hidden_dims=(32, 16),
                          activation="elu", obs_normalization=True, estimator_dims=(24, 8),
                          distribution_cfg={"class_name": "GaussianDistribution", "init_std": 0.1})
    m.train()
    m.update_normalization(rollout(256, seed=7))
    return m


def test_target_is_the_body_velocity_and_only_the_regression_trains_the_estimator():
    m = model()
    obs = rollout(16)
    assert m.target_columns == slice(47, 50)  # 42 student + slope 1 + uphill 3 + friction 1
    torch.testing.assert_close(m.target(obs), obs["teacher"][:, 47:50])
    m(obs).pow(2).sum().backward()  # a behaviour-cloning-like loss
    assert all(p.grad is None for p in m.estimator.parameters())
    assert m.mlp[0].weight.grad is not None
    m.zero_grad()
    m.estimate(obs).pow(2).sum().backward()
    assert all(p.grad is not None for p in m.estimator.parameters())
    assert m.mlp[0].weight.grad is None
    with pytest.raises(ValueError, match="target group"):
        EstimatorMLPModel(obs, {"student": ["student", "teacher"]}, "student", 12, estimator_dims=(8,))


def test_trainer_fits_the_velocity():
    m = model()
    trainer = EstimatorTrainer(m, 3e-3, torch.Generator().manual_seed(0))
    data = rollout(512, seed=3).reshape(8, 64)  # (steps, envs), as rsl_rl's storage holds it
    first, explained = trainer.fit(data)
    assert explained < 0.5  # untrained
    for _ in range(60):
        last, explained = trainer.fit(data)
    assert last < 0.2 * first and explained > 0.8


def test_deployed_actor_matches_the_trained_model(tmp_path: Path):
    m = model().eval()
    actor = actor_from_checkpoint({"student_state_dict": m.state_dict()}, {"obs_history": FRAMES})
    assert actor.meta.estimator_dims == (24, 8) and actor.meta.obs_dim == FRAMES * STUDENT
    obs = rollout(70, seed=5)
    x = obs["student_history"]
    with torch.no_grad():
        expected = m(obs)
        torch.testing.assert_close(actor(x), expected, atol=1e-6, rtol=0)
        rows = actor.forward_rows(x)
        torch.testing.assert_close(rows, expected, atol=1e-5, rtol=0)
        for start, size in [(0, 1), (5, 9), (20, 50)]:
            assert torch.equal(actor.forward_rows(x[start : start + size]), rows[start : start + size])
    save_actor_file(tmp_path / "a.pt", actor)
    again = load_actor_file(tmp_path / "a.pt")
    assert again.meta.estimator_dims == (24, 8)
    with torch.no_grad():
        assert torch.equal(again(x), actor(x))
    export_onnx(actor, tmp_path / "a.onnx")
    policy = load_policy_file(tmp_path / "a.onnx")
    out = policy.act({"student": x[:1, -STUDENT:]}, np.arange(1), [None])  # one env: its history fills with the frame
    with torch.no_grad():
        first = actor(x[:1, -STUDENT:].repeat(1, FRAMES))
    torch.testing.assert_close(out, first, atol=1e-5, rtol=0)
    with pytest.raises(ValueError, match="estimator"):
        teacher_checkpoint(actor)


def test_student_run_trains_saves_and_resumes_its_estimator(tmp_path: Path, monkeypatch, capsys):
    teacher = tmp_path / "teacher"
    run(spec(teacher))
    train = dataclasses.replace(TINY, distillation=dataclasses.replace(
        TINY.distillation, velocity_estimator=(16,), student_history=2))
    student = tmp_path / "student"
    r = run(spec(student, role="student", teacher=teacher, iterations=2, train=train))
    assert np.isfinite(r.last_loss["velocity"]) and r.last_loss["velocity_r2"] <= 1.0
    ckpt = torch.load(latest_checkpoint(student), weights_only=True)
    assert OPTIMIZER_KEY in ckpt and "estimator.0.weight" in ckpt["student_state_dict"]
    actor = actor_from_checkpoint(ckpt, ckpt["infos"])
    assert actor.meta.estimator_dims == (16,) and actor.meta.obs_history == 2
    r = run(spec(student, role="student", teacher=teacher, iterations=3, train=train, resume=True))
    assert r.start_it == 2
    resumed = torch.load(latest_checkpoint(student), weights_only=True)
    assert not torch.equal(resumed["student_state_dict"]["estimator.0.weight"], ckpt["student_state_dict"]["estimator.0.weight"])
    # The diagnostics read it: its accuracy on its own rollouts, and a teacher reading its estimate.
    run_script("estimator_accuracy.py", ["--checkpoint", str(student), "--context", "flat", "--envs", "4",
                                         "--steps", "12", "--fit-histories", "1", "2", "--fit-epochs", "1"], monkeypatch)
    out = capsys.readouterr().out
    assert "48 states" in out and out.count("R²") == 6 and "linear probe" in out and "   2 frames:" in out
    # Another privileged target: the ground beneath the trunk against the scan's mean, one value.
    run_script("estimator_accuracy.py", ["--checkpoint", str(student), "--context", "flat", "--envs", "4",
                                         "--steps", "12", "--fit-histories", "1", "--fit-epochs", "1",
                                         "--target", "bump"], monkeypatch)
    out = capsys.readouterr().out
    assert "target bump" in out and "upright" in out and re.search(r"   1 frames: (-?[\d.]+|nan); (-?[\d.]+|nan)", out)
    run_script("policy_variants.py", ["--policies", str(teacher), "--estimate-first", str(student), "--grid", "tiny",
                                      "--episodes", "1", "--out", str(tmp_path / "estimated")], monkeypatch)
    assert "velocity estimate) on tiny" in capsys.readouterr().out
    with pytest.raises(ValueError, match="feed-forward students"):
        gru = dataclasses.replace(train, distillation=dataclasses.replace(train.distillation, student_gru=8))
        run(spec(tmp_path / "gru", role="student", teacher=teacher, train=gru))


class _Recorder(Policy):
    """Records the teacher observation it is given; acts with zeros."""

    groups, action_mapping, digest, name = ("teacher",), ("tall", 0.5), "d", "recorder"

    def reset(self, ids, seeds=None):
        pass

    def act(self, obs, ids, contexts):
        self.seen = obs["teacher"].clone()
        return torch.zeros(len(ids), 12)


def test_teacher_reads_the_estimate_of_the_students_history():
    actor = actor_from_checkpoint({"student_state_dict": model().eval().state_dict()}, {"obs_history": FRAMES})
    inner = _Recorder()
    policy = EstimatedVelocity(inner, actor)
    assert set(policy.groups) == {"student", "teacher"} and policy.action_mapping == ("tall", 0.5)
    frames = [rollout(2, seed=s) for s in range(FRAMES + 1)]
    policy.reset(np.arange(2))
    for obs in frames:
        policy.act({"student": obs["student"], "teacher": obs["teacher"]}, np.arange(2), [None, None])
    history = torch.cat([f["student"] for f in frames[1:]], dim=-1)  # the last FRAMES frames, oldest first
    cols = privileged_columns(12)["velocity"]
    with torch.no_grad():
        torch.testing.assert_close(inner.seen[:, cols], actor.estimator(actor._normalize(history)), atol=1e-5, rtol=0)
    rest = torch.ones(TEACHER, dtype=torch.bool)
    rest[cols] = False
    assert torch.equal(inner.seen[:, rest], frames[-1]["teacher"][:, rest])
    with pytest.raises(ValueError, match="velocity estimator"):
        EstimatedVelocity(inner, actor_from_checkpoint({"student_state_dict": rsl_actor(STUDENT, "student").state_dict()}))
