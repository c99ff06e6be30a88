"""The distillation teachers built around frozen policies: the tilt rule, the fallback
composite and the stance blend."""

import math

import numpy as np
import pytest
import torch


def test_composite_teacher_shifts_a_fallback_of_another_reference():
    """In distillation, a fallback teacher trained around another pose labels in the student's
    units: its action shifted by the offset, the previous action it sees shifted back, except
    on an episode's first step (where the env reports 0)."""
    from tensordict import TensorDict

    from selfright.env.observations import prev_action_columns
    from selfright.train.fallback_teacher import FallbackTeacher
    from selfright.train.tilt import TiltSwitch

    cols = prev_action_columns(12)
    offset = torch.linspace(-0.4, 0.4, 12)
    composite = FallbackTeacher(
        primary=lambda o: torch.zeros(len(o["teacher"]), 12),
        fallback=lambda o: o["teacher"][:, cols].clone(),  # echoes the previous action it sees
        num_envs=2, switch=TiltSwitch(45.0), fallback_offset=offset,
    )
    x = torch.zeros(2, 60)
    x[:, 2] = 1.0  # both upside down: the fallback acts
    x[:, cols] = torch.randn(2, 12)
    obs = TensorDict({"teacher": x}, batch_size=[2])
    torch.testing.assert_close(composite(obs), x[:, cols] + offset)  # first step: nothing shifted back
    torch.testing.assert_close(composite(obs), x[:, cols])  # later: seen in its own units, then shifted
    composite.reset(torch.tensor([True, False]))
    out = composite(obs)
    torch.testing.assert_close(out[0], x[0, cols] + offset)
    torch.testing.assert_close(out[1], x[1, cols])
    x[1, 2] = -1.0  # env 1 upright: the primary's label, unshifted
    assert torch.equal(composite(TensorDict({"teacher": x}, batch_size=[2]))[1], torch.zeros(12))


def test_tilt_switch_reads_the_projected_gravity():
    from selfright.train.tilt import TiltSwitch

    rule = TiltSwitch(45.0)
    a = math.radians(40), math.radians(50)
    x = torch.tensor([[0.0, 0.0, -1.0], [math.sin(a[0]), 0.0, -math.cos(a[0])], [0.0, math.sin(a[1]), -math.cos(a[1])],
                      [0.0, 0.0, 1.0]])
    assert rule.step(x).tolist() == [False, False, True, True]
    with pytest.raises(ValueError, match="tilt_deg"):
        TiltSwitch(0.0)


def test_stance_teacher_blends_to_the_stance_after_the_delay():
    """Labels are the base's until the trunk has been upright ``delay`` steps, then ramp to the
    stance (a share ``weight`` of the way); tilting over or an episode's end starts the count again."""
    from selfright.train.stance_teacher import StanceTeacher

    base = lambda x: torch.zeros(x.shape[0], 12)  # noqa: E731
    target = torch.ones(12)
    teacher = StanceTeacher(base, "student", 2, 15.0, delay_steps=1, ramp_steps=2, target=target, weight=0.5)
    x = torch.zeros(2, 42)
    x[:, 2] = -1.0  # upright
    obs = {"teacher": x, "student": x}
    weights = [float(teacher(obs)[0, 0]) for _ in range(4)]
    assert weights == pytest.approx([0.0, 0.25, 0.5, 0.5])
    teacher.reset(torch.tensor([True, False]))
    labels = teacher(obs)
    assert float(labels[0, 0]) == 0.0 and float(labels[1, 0]) == pytest.approx(0.5)
    tilted = x.clone()
    tilted[:, :3] = torch.tensor([1.0, 0.0, 0.0])
    assert torch.equal(teacher({"teacher": tilted, "student": tilted}), torch.zeros(2, 12))
    with pytest.raises(ValueError, match="weight"):
        StanceTeacher(base, "student", 2, 15.0, 1, 2, target, weight=0.0)


def test_stance_action_maps_a_leg_pose_to_actions():
    from selfright.config import ActionConfig
    from selfright.robots import get_robot
    from selfright.train.stance_teacher import stance_action

    robot = get_robot("a1")
    action = ActionConfig(reference="tall")
    a = stance_action(robot, action, (0.0, 0.46, -0.92))
    np.testing.assert_allclose(robot.reference_pose("tall") + action.scale_rad * a, np.tile([0.0, 0.46, -0.92], 4))
    with pytest.raises(ValueError, match="fixed action reference"):
        stance_action(robot, ActionConfig(reference="current"), (0.0, 0.46, -0.92))
