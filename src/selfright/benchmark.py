"""Simulation throughput: the env's control-step rate against raw MuJoCo physics on the same
scene, states and controls (so the ratio isolates the cost of env logic).

Each round runs the env (observations, random actions, PD targets, goal bookkeeping) for a
while, recording the PD targets, then replays exactly those controls from the same start
states with plain ``mujoco.rollout`` calls of 100 physics steps. Rounds alternate so that
machine noise hits both sides alike; medians are reported.
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
    env_rates, raw_rates = [], []
    for _ in range(rounds):
        start = env.state.copy()
        controls: list[np.ndarray] = []
        t0 = time.perf_counter()
        while time.perf_counter() - t0 < seconds / rounds:
            env.observe(ids, ("student",))
            actions = torch.rand(num_envs, env.robot.num_joints, generator=gen) * 2 - 1
            controls.append(env.targets(ids, actions))
            env.step(actions)
        env_rates.append(len(controls) * num_envs / (time.perf_counter() - t0))
        ctrl = np.repeat(np.stack(controls, axis=1), sub, axis=1)  # (n, steps·sub, nu)
        state = start
        t1 = time.perf_counter()
        for k in range(0, ctrl.shape[1], RAW_CHUNK_STEPS):
            seg = ctrl[:, k : k + RAW_CHUNK_STEPS]
            states = np.empty((num_envs, seg.shape[1], start.shape[1]))
            env.stepper._pool.rollout(
                env.models, env.stepper._datas, state, seg, state=states,
                initial_warmstart=np.zeros((num_envs, world.model.nv)), chunk_size=env.stepper.chunk_size(num_envs),
            )
            state = np.ascontiguousarray(states[:, -1])
        raw_rates.append(ctrl.shape[1] * num_envs / (time.perf_counter() - t1))
    env.close()
    env_rate = statistics.median(env_rates)
    raw_rate = statistics.median(raw_rates)
    return {
        "env_steps_per_s": round(env_rate, 1),
        "physics_steps_per_env_step": sub,
        "num_envs": num_envs,
        "backend": "mujoco-cpu",
        "threads": env.stepper.threads,
        "slope_level": slope_level,
        "roughness_level": roughness_level,
        "raw_physics_steps_per_s": round(raw_rate, 1),
        "env_physics_steps_per_s": round(env_rate * sub, 1),
        "env_over_raw": round(env_rate * sub / raw_rate, 3),
    }
