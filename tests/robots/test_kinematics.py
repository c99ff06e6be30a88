"""Trunk height from the leg kinematics (sensors only) and the stall rule that reads it."""

import math

import numpy as np
import torch

from selfright.robots import get_robot
from selfright.robots.kinematics import KinematicHeight

A1 = get_robot("a1")


def test_stand_pose_upright_gives_the_stand_height():
    kh = KinematicHeight(A1)
    down = torch.tensor([[0.0, 0.0, -1.0]])
    q = torch.as_tensor(A1.stand_pose, dtype=torch.float32)[None]
    # hip axis to foot centre 2 × 0.2 m × cos 0.6, plus the foot radius; the hip axis lies in the trunk's x-y plane
    assert abs(float(kh(down, q)[0]) - (0.4 * math.cos(0.6) + 0.02)) < 1e-3


def test_height_follows_gravity_and_the_lowest_foot():
    kh = KinematicHeight(A1)
    q = torch.as_tensor(np.stack([A1.stand_pose, A1.tall_pose]), dtype=torch.float32)
    down = torch.tensor([[0.0, 0.0, -1.0], [0.0, 0.0, -1.0]])
    stand, tall = kh(down, q).tolist()
    assert tall > stand  # straighter legs stand the trunk higher
    pitched = torch.tensor([[math.sin(0.3), 0.0, -math.cos(0.3)]])  # nose down 0.3 rad: gravity leans to +x
    feet = kh.feet_in_trunk_frame(A1.stand_pose[None])[0]
    expected = max(feet @ pitched[0].numpy()) + 0.02
    assert abs(float(kh(pitched, q[:1])[0]) - expected) < 1e-5
    assert float(kh(pitched, q[:1])[0]) > stand  # the hind feet, now lowest, lie further down


def test_level_is_the_height_with_gravity_straight_down():
    kh = KinematicHeight(A1)
    poses = np.stack([A1.stand_pose, A1.tall_pose])
    down = torch.tensor([[0.0, 0.0, -1.0], [0.0, 0.0, -1.0]])
    np.testing.assert_array_equal(kh.level(poses), kh(down, torch.as_tensor(poses, dtype=torch.float32)).numpy())


def test_stall_rule_reads_the_kinematic_height_without_the_teacher_observation():
    from selfright.env.observations import joint_pos_columns
    from selfright.policies.stall import StallSwitch

    rule = StallSwitch(stall_steps=1, hand_steps=1, bar_m=0.32, robot=A1)
    assert not rule.needs_teacher
    x = torch.zeros(2, 42)  # student observations: upright and still
    x[:, 2] = -1.0
    cols = joint_pos_columns(12)
    x[0, cols] = torch.as_tensor(np.tile([0.0, 1.2, -2.4], 4) - A1.nominal_pose, dtype=torch.float32)  # deep crouch
    x[1, cols] = torch.as_tensor(A1.tall_pose - A1.nominal_pose, dtype=torch.float32)  # standing tall
    slots = torch.arange(2)
    rule.reset(slots)
    assert rule.step(x, slots).tolist() == [True, False]
