"""Stacked observation history (``selfright.policies.history``): hand-checked frames."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from selfright.policies.history import ObsHistory


def frame(*values: float) -> torch.Tensor:
    return torch.tensor([[v, -v] for v in values])


def test_first_frame_fills_then_frames_roll_oldest_first():
    h = ObsHistory(frames=3, dim=2)
    out = h.push(np.array([0, 1]), frame(1.0, 10.0))
    torch.testing.assert_close(out[0], torch.tensor([1.0, -1.0] * 3))  # no zeros from before the episode
    out = h.push(np.array([0, 1]), frame(2.0, 20.0))
    torch.testing.assert_close(out[1], torch.tensor([10.0, -10.0, 10.0, -10.0, 20.0, -20.0]))
    out = h.push(np.array([1]), frame(30.0))  # only slot 1 steps
    torch.testing.assert_close(out[0], torch.tensor([10.0, -10.0, 20.0, -20.0, 30.0, -30.0]))
    out = h.push(np.array([0]), frame(3.0))
    torch.testing.assert_close(out[0], torch.tensor([1.0, -1.0, 2.0, -2.0, 3.0, -3.0]))


def test_reset_starts_the_slot_over_and_slots_grow_on_demand():
    h = ObsHistory(frames=2, dim=2, slots=1)
    h.push(np.array([0]), frame(1.0))
    h.reset(np.array([0]))
    torch.testing.assert_close(h.push(np.array([0]), frame(5.0))[0], torch.tensor([5.0, -5.0, 5.0, -5.0]))
    out = h.push(np.array([4]), frame(7.0))  # a slot never seen is fresh
    torch.testing.assert_close(out[0], torch.tensor([7.0, -7.0, 7.0, -7.0]))
    assert h.push(np.array([], dtype=np.int64), torch.zeros(0, 2)).shape == (0, 4)
    with pytest.raises(ValueError):
        ObsHistory(frames=0, dim=2)
