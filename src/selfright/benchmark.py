"""Simulation throughput: the env's control-step rate against raw MuJoCo physics on the same
scene, states and controls (so the ratio isolates the cost of env logic)."""

from __future__ import annotations

import time
from typing import Any

import numpy as np
import torch

from selfright.config import BenchmarkConfig, ContextConfig
from selfright.env.recovery_env import RecoveryEnv
from selfright.env.world import build_world
from selfright.terrain import make_cell


def measure_throughput(
    cfg: BenchmarkConfig, *, num_envs: int, seconds: float, slope_level: int, roughness_level: int, seed: int = 0
) -> dict[str, Any]:
    """Run ``num_envs`` envs with random actions for ~``seconds``, then replay the recorded
    controls with one raw ``mujoco.rollout`` call from the same start states."""
    cell = make_cell(slope_level, roughness_level, cfg.terrain)
    world = build_world(cell, cfg, ContextConfig(), seed)
    env = RecoveryEnv(cfg, [world], num_envs)
    ids = np.arange(num_envs)
    env.reset(ids, np.zeros(num_envs, dtype=np.int64), [np.random.default_rng([seed, i]) for i in ids])
    gen = torch.Generator().manual_seed(seed)
    start = env.state.copy()
    sub = cfg.sim.control_substeps
    controls: list[np.ndarray] = []
    steps = 0
    t0 = time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        env.observe(ids)
        actions = torch.rand(num_envs, env.robot.num_joints, generator=gen) * 2 - 1
        controls.append(env.targets(ids, actions))
        env.step(actions)
        steps += 1
    env_time = time.perf_counter() - t0
    ctrl = np.repeat(np.stack(controls, axis=1), sub, axis=1)  # (n, steps·sub, nu)
    t1 = time.perf_counter()
    env.stepper._pool.rollout(env.models, env.stepper._datas, start, ctrl, initial_warmstart=np.zeros((num_envs, world.model.nv)))
    raw_time = time.perf_counter() - t1
    env.close()
    env_rate = steps * num_envs / env_time
    raw_rate = steps * num_envs * sub / raw_time
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
        "seconds": round(env_time, 2),
    }
