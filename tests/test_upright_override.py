"""Training a specialist inside its composite (``selfright.train.upright_override``): the
frozen policy's actions replace the trained policy's exactly in the upright slots, converted
between action references, and a teacher run trains with it."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest
import torch

from selfright.policies.actor import ActorMeta, ActorMLP
from selfright.train.upright_override import UprightOverride

from test_learning_smoke import TINY, run, spec

J = 12
D = 79  # the teacher observation


def _constant_actor(value: float) -> ActorMLP:
    meta = ActorMeta(obs_group="teacher", obs_dim=D, action_dim=J, hidden_dims=(4,), activation="elu",
                     obs_normalization=False, role="teacher", context="flat", iteration=0, source="",
                     action_reference="stand", action_scale_rad=0.5, obs_history=1, gru_dim=0)
    actor = ActorMLP(meta)
    with torch.no_grad():
        for p in actor.parameters():
            p.zero_()
        actor.mlp[-1].bias.fill_(value)
    return actor


def _obs(gravity_z: list[float]) -> torch.Tensor:
    x = torch.zeros(len(gravity_z), D)
    x[:, 2] = torch.tensor(gravity_z)  # projected gravity's z: −1 upright, +1 upside down
    return x


def test_upright_slots_get_the_frozen_action_tilted_keep_theirs():
    ov = UprightOverride(_constant_actor(0.7), tilt_deg=45.0, num_envs=3)
    acts = torch.full((3, J), -2.0)
    # upright (0°), tilted 60° (cos 0.5 < cos 45°), upside down
    out = ov(_obs([-1.0, -0.5, 1.0]), acts)
    assert torch.equal(out[0], torch.full((J,), 0.7))
    assert torch.equal(out[1:], acts[1:])
    assert torch.equal(acts, torch.full((3, J), -2.0))  # the caller's tensor is not written
    assert ov.share.item() == pytest.approx(1 / 3)


def test_tilted_side_overrides_exactly_the_tilted_slots():
    ov = UprightOverride(_constant_actor(0.7), tilt_deg=45.0, num_envs=3, acts_when="tilted")
    acts = torch.full((3, J), -2.0)
    out = ov(_obs([-1.0, -0.5, 1.0]), acts)
    assert torch.equal(out[0], acts[0])
    assert torch.equal(out[1:], torch.full((2, J), 0.7))
    assert ov.overridden.tolist() == [False, True, True]


def test_other_reference_is_converted_both_ways():
    offset = torch.linspace(-1.0, 1.0, J)
    ov = UprightOverride(_constant_actor(0.0), tilt_deg=45.0, num_envs=1, offset=offset)
    x = _obs([-1.0])
    assert torch.allclose(ov(x, torch.zeros(1, J))[0], offset)  # its action 0 = its own pose, in env units
    # From the second step on it sees its previous action shifted back into its own units: an
    # actor that echoes the previous action column shows the shift.
    from selfright.env.observations import prev_action_columns

    cols = prev_action_columns(J)
    echo = _constant_actor(0.0)
    with torch.no_grad():
        echo.mlp[0].weight.zero_()
    ov2 = UprightOverride(echo, tilt_deg=45.0, num_envs=1, offset=offset)
    ov2(x, torch.zeros(1, J))
    seen = []
    ov2.actor.forward = lambda obs: (seen.append(obs.clone()), torch.zeros(len(obs), J))[1]
    x2 = x.clone()
    x2[:, cols] = 1.0
    ov2(x2, torch.zeros(1, J))
    assert torch.allclose(seen[-1][0, cols], 1.0 - offset)
    ov2.reset(torch.tensor([0]))
    ov2(x2, torch.zeros(1, J))
    assert torch.allclose(seen[-1][0, cols], torch.ones(J))  # an episode's first step: 0 in any units


def test_teacher_trains_inside_a_composite(tmp_path: Path):
    frozen = tmp_path / "frozen"
    run(spec(frozen))
    ep = dataclasses.replace(TINY.episode, upright_policy=str(frozen), upright_tilt_deg=45.0)
    r = run(spec(tmp_path / "specialist", train=dataclasses.replace(TINY, episode=ep), iterations=2))
    assert r.env.action_override is not None and r.last_loss
    with pytest.raises(ValueError, match="upright-policy"):
        r2 = spec(tmp_path / "s", role="student", teacher=frozen, train=dataclasses.replace(TINY, episode=ep))
        from selfright.train.runner import TrainingRun

        TrainingRun(r2).setup()


def test_student_distils_on_the_states_a_frozen_escape_hands_over(tmp_path: Path):
    frozen = tmp_path / "frozen"
    run(spec(frozen))
    ep = dataclasses.replace(TINY.episode, tilted_policy=str(frozen), upright_tilt_deg=45.0)
    r = run(spec(tmp_path / "student", role="student", teacher=frozen, train=dataclasses.replace(TINY, episode=ep)))
    assert r.env.action_override is not None and r.env.action_override.acts_when == "tilted" and r.last_loss
    from selfright.train.runner import TrainingRun

    both = dataclasses.replace(ep, upright_policy=str(frozen))
    with pytest.raises(ValueError, match="not both"):
        TrainingRun(spec(tmp_path / "s2", train=dataclasses.replace(TINY, episode=both))).setup()
