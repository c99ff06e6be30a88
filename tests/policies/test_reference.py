"""Policies trained around one standing pose run unchanged in an env mapping actions around
another (``ShiftedReference``)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch

from selfright.config import ActionConfig, BenchmarkConfig
from selfright.env.recovery_env import RecoveryEnv
from selfright.policies.base import CallablePolicy
from selfright.policies.multiplexer import ContextMultiplexer
from selfright.policies.reference import ShiftedReference
from selfright.policies.registry import check_action_mapping
from selfright.robots import get_robot
from selfright.train.contexts import make_training_worlds

CFG = BenchmarkConfig()


def _linear_policy(reference: str) -> CallablePolicy:
    """A fixed random linear feedback on the student observation (previous action included)."""
    w = torch.randn(42, 12, generator=torch.Generator().manual_seed(0)) * 0.2
    pol = CallablePolicy(lambda o: torch.tanh(o @ w) * 2.0, name="linear")
    pol.action_mapping = (reference, 0.5)
    return pol


def _final_state(reference: str, policy) -> np.ndarray:
    cfg = dataclasses.replace(CFG, action=ActionConfig(reference=reference))
    env = RecoveryEnv(cfg, make_training_worlds("flat", cfg, seed=0), num_envs=1, threads=1)
    # A fall whose first 0.4 s is not chaotic: most other falls (fall seeds 0-6), and this one
    # later, amplify the 1e-8 rounding of the shifted actions into different contacts.
    env.reset(np.arange(1), np.zeros(1, dtype=np.int64), [np.random.default_rng(7)])
    policy.reset(np.arange(1))
    for _ in range(20):
        env.step(policy.act(env.observe(), np.arange(1), ["flat"]))
    state = env.state.copy()
    env.close()
    return state


def test_tall_policy_in_a_stand_env_moves_as_in_its_own():
    own = _final_state("tall", _linear_policy("tall"))
    adapted = check_action_mapping(_linear_policy("tall"), ActionConfig(reference="stand"), "linear")
    assert isinstance(adapted, ShiftedReference) and adapted.action_mapping == ("stand", 0.5)
    np.testing.assert_allclose(_final_state("stand", adapted), own, atol=1e-3)
    unadapted = _final_state("stand", _linear_policy("tall"))
    assert np.abs(unadapted - own).max() > 0.05  # the shift matters


def test_shift_contract():
    """Actions are clipped in the policy's own units and shifted by (tall − stand) / scale; the
    previous action it observes is its own clipped one, whatever the env reports, except on an
    episode's first step (the env's 0 = "none yet")."""
    seen = []
    own = torch.full((12,), 0.3)
    own[2] = 12.0  # saturates: beyond the ±10 clip
    inner = CallablePolicy(lambda o: seen.append(o.clone()) or own.expand(len(o), 12).clone(), name="rec")
    inner.action_mapping = ("tall", 0.5)
    adapted = check_action_mapping(inner, ActionConfig(reference="stand"), "rec")
    robot = get_robot("a1")
    np.testing.assert_allclose(robot.stand_pose + 0.5 * adapted.offset.numpy(), robot.tall_pose, atol=1e-7)
    clipped = own.clamp(-10.0, 10.0)
    adapted.reset(np.array([0, 1]))
    a = adapted.act({"student": torch.zeros(2, 42)}, np.array([0, 1]), [None, None])
    torch.testing.assert_close(a, (clipped + adapted.offset).expand(2, 12))
    adapted.reset(np.array([1]))  # slot 1 starts a new episode, slot 0 goes on
    env_obs = torch.zeros(2, 42)
    env_obs[0, 30:42] = 99.0  # what the env reports is not what the policy observes
    adapted.act({"student": env_obs}, np.array([0, 1]), [None, None])
    assert torch.all(seen[0] == 0)
    torch.testing.assert_close(seen[1][0, 30:42], clipped)
    assert torch.all(seen[1][0, :30] == 0) and torch.all(seen[1][1] == 0)


def test_multiplexer_policies_are_adapted_one_by_one_and_current_is_refused():
    mux = ContextMultiplexer({"flat": _linear_policy("tall"), "rough": _linear_policy("stand")})
    out = check_action_mapping(mux, ActionConfig(reference="stand"), "sr")
    assert isinstance(out.policies["flat"], ShiftedReference)
    assert not isinstance(out.policies["rough"], ShiftedReference)
    with pytest.raises(ValueError, match="--action-reference tall"):
        check_action_mapping(_linear_policy("tall"), ActionConfig(reference="current"), "linear")
