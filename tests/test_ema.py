"""The student's weight average (``selfright.train.ema``): the arithmetic, and a distillation
run that keeps it, deploys it, and resumes it."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest
import torch
from torch import nn

from selfright.policies.actor import actor_from_checkpoint
from selfright.train.checkpoints import latest_checkpoint
from selfright.train.ema import EMA_COUNT_KEY, EMA_KEY, WeightAverage

from test_learning_smoke import TINY, run, spec


class _Net(nn.Module):
    def __init__(self):
        super().__init__()
        self.w = nn.Parameter(torch.zeros(2))
        self.register_buffer("stat", torch.zeros(1))


def test_average_warms_up_then_decays_and_copies_buffers():
    net = _Net()
    ema = WeightAverage(net, decay=0.5)
    with torch.no_grad():
        net.w.fill_(10.0)
        net.stat.fill_(3.0)
    ema.update()  # warm-up decay min(0.5, 1/10) = 0.1: 0.1·0 + 0.9·10
    assert torch.allclose(ema.state_dict()["w"], torch.full((2,), 9.0))
    assert ema.state_dict()["stat"].item() == 3.0  # buffers are copied, not averaged
    with torch.no_grad():
        net.w.fill_(1.0)
    ema.update()  # min(0.5, 2/11) = 2/11
    assert torch.allclose(ema.state_dict()["w"], torch.full((2,), 9.0 * 2 / 11 + 1.0 * 9 / 11))
    for _ in range(50):
        ema.update()  # decay capped at 0.5 now: converges to the constant weights
    assert torch.allclose(ema.state_dict()["w"], torch.ones(2), atol=1e-6)
    with pytest.raises(ValueError, match="decay"):
        WeightAverage(net, decay=1.0)


def test_student_run_saves_deploys_and_resumes_its_average(tmp_path: Path):
    teacher = tmp_path / "teacher"
    run(spec(teacher))
    train = dataclasses.replace(TINY, distillation=dataclasses.replace(TINY.distillation, ema_decay=0.9))
    student = tmp_path / "student"
    run(spec(student, role="student", teacher=teacher, iterations=3, train=train))
    ckpt = torch.load(latest_checkpoint(student), weights_only=True)
    assert ckpt[EMA_COUNT_KEY] == 3
    raw, avg = ckpt["student_state_dict"], ckpt[EMA_KEY]
    assert set(raw) == set(avg)
    assert not torch.equal(raw["mlp.0.weight"], avg["mlp.0.weight"])  # training moved the raw weights
    assert torch.equal(raw["obs_normalizer._mean"], avg["obs_normalizer._mean"])
    actor = actor_from_checkpoint(ckpt, {"role": "student"})
    assert torch.equal(actor.state_dict()["mlp.0.weight"], avg["mlp.0.weight"])  # the average deploys

    run(spec(student, role="student", teacher=teacher, iterations=5, train=train, resume=True))
    resumed = torch.load(latest_checkpoint(student), weights_only=True)
    assert resumed[EMA_COUNT_KEY] == 5  # continued from the saved average, not restarted
    assert not torch.equal(resumed[EMA_KEY]["mlp.0.weight"], avg["mlp.0.weight"])
