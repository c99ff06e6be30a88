"""Simulation throughput: the env's control-step rate against raw MuJoCo physics on the same
scene, states and controls (so the ratio isolates the cost of env logic).

Each round runs the env (observations, random actions, PD targets, goal bookkeeping) for a
while, recording the PD targets, then replays exactly those controls from the same start
states twice with plain ``mujoco.rollout``:

- ``raw``: one call per control step (``control_substeps`` physics steps, solver warm start
  zeroed, sensors read), the physics any closed-loop 50 Hz controller has to run;
  ``env_over_raw`` is therefore the cost of the env's own logic.
- ``open-loop``: calls of 100 physics steps with no sensors, the most MuJoCo can do when
  nobody needs to look at the state in between; ``env_over_open_loop`` adds the cost of
  returning to Python every control step.

Rounds alternate so that machine noise hits all sides alike; medians are reported.
"""

from __future__ import annotations

import statistics
import time
from typing import Any

import numpy as np
import torch

from selfright.config import BenchmarkConfig, ContextConfig
from selfright.env.recovery_env import RecoveryEnv
from selfright.env.world import build_world
from selfright.terrain import make_cell

RAW_CHUNK_STEPS = 100
"""Physics steps per raw rollout call."""


def measure_throughput(
    cfg: BenchmarkConfig, *, num_envs: int, seconds: float, slope_level: int, roughness_level: int,
    seed: int = 0, rounds: int = 3,
) -> dict[str, Any]:
    """Throughput of ``num_envs`` envs on one tile over ~``seconds`` of env stepping in total."""
    cell = make_cell(slope_level, roughness_level, cfg.terrain)
    world = build_world(cell, cfg, ContextConfig(), seed)
    env = RecoveryEnv(cfg, [world], num_envs)
    ids = np.arange(num_envs)
    env.reset(ids, np.zeros(num_envs, dtype=np.int64), [np.random.default_rng([seed, i]) for i in ids])
    gen = torch.Generator().manual_seed(seed)
    sub = cfg.sim.control_substeps
    env_rates, raw_rates, open_rates = [], [], []
    for _ in range(rounds):
        start = env.state.copy()
        controls: list[np.ndarray] = []
        t0 = time.perf_counter()
        while time.perf_counter() - t0 < seconds / rounds:
            env.observe(ids, ("student",))
            actions = torch.rand(num_envs, env.robot.num_joints, generator=gen) * 2 - 1
            env.step(actions)
            controls.append(env.last_ctrl)
        env_rates.append(len(controls) * num_envs / (time.perf_counter() - t0))
        raw_rates.append(_replay_per_control_step(env, start, controls))
        open_rates.append(_replay_open_loop(env, start, np.repeat(np.stack(controls, axis=1), sub, axis=1)))
    env.close()
    env_rate = statistics.median(env_rates)
    raw_rate = statistics.median(raw_rates)
    open_rate = statistics.median(open_rates)
    return {
        "env_steps_per_s": round(env_rate, 1),
        "physics_steps_per_env_step": sub,
        "num_envs": num_envs,
        "backend": "mujoco-cpu",
        "threads": env.stepper.threads,
        "slope_level": slope_level,
        "roughness_level": roughness_level,
        "env_physics_steps_per_s": round(env_rate * sub, 1),
        "raw_physics_steps_per_s": round(raw_rate, 1),
        "open_loop_physics_steps_per_s": round(open_rate, 1),
        "env_over_raw": round(env_rate * sub / raw_rate, 3),
        "env_over_open_loop": round(env_rate * sub / open_rate, 3),
    }


def _replay_per_control_step(env: RecoveryEnv, start: np.ndarray, controls: list[np.ndarray]) -> float:
    """Physics steps/s of the env's own rollout calls on recorded controls, nothing else."""
    sub = env.cfg.sim.control_substeps
    state = start
    t = time.perf_counter()
    for ctrl in controls:
        states, _ = env.stepper.step(env.models, state, ctrl, sub)
        state = states[:, -1]
    return len(controls) * sub * env.num_envs / (time.perf_counter() - t)


def _replay_open_loop(env: RecoveryEnv, start: np.ndarray, ctrl: np.ndarray) -> float:
    """Physics steps/s of 100-step rollout calls (no sensors) on the recorded controls."""
    state = start
    t = time.perf_counter()
    for k in range(0, ctrl.shape[1], RAW_CHUNK_STEPS):
        state = env.stepper.rollout_open_loop(env.models, state, ctrl[:, k : k + RAW_CHUNK_STEPS])
    return ctrl.shape[1] * env.num_envs / (time.perf_counter() - t)
