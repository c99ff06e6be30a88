import math

import torch

from selfright.config import GoalConfig
from selfright.env.goal import GoalTracker, in_goal_set

CFG = GoalConfig()
LEG = 0.4


def goal(roll_deg, pitch_deg, feet=(True, True, True, True), height=0.35):
    return bool(in_goal_set(torch.tensor([math.radians(roll_deg)]), torch.tensor([math.radians(pitch_deg)]),
                            torch.tensor([feet]), torch.tensor([height]), CFG, LEG)[0])


def test_upright_standing_is_in_goal():
    assert goal(0, 0)
    assert goal(29.9, -29.9)


def test_tilt_beyond_30_degrees_is_not():
    assert not goal(30.5, 0)
    assert not goal(0, -31)
    assert not goal(180, 0)


def test_all_four_feet_must_touch():
    assert not goal(0, 0, feet=(True, True, True, False))


def test_height_bar_is_80_percent_of_leg_length():
    assert goal(0, 0, height=0.321)
    assert not goal(0, 0, height=0.319)


def test_tracker_success_after_hold_and_ttr_from_final_stay():
    tr = GoalTracker(1, hold_steps=3)
    ids = torch.tensor([0])
    seq = [False, True, False, True, True, True]
    done = []
    for step, g in enumerate(seq, start=1):
        done.append(bool(tr.update(ids, torch.tensor([g]), torch.tensor([step]), torch.tensor([[float(step), 0.0]]))[0]))
    assert done == [False, False, False, False, False, True]
    assert int(tr.streak_start_step[0]) == 4  # the final stay began at step 4
    assert float(tr.streak_start_xy[0, 0]) == 4.0
