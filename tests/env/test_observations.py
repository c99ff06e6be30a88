"""Observation columns: the teacher's privileged height column reads the trunk height."""

import numpy as np
import torch


def test_privileged_height_column_is_the_trunk_height():
    from selfright.config import BenchmarkConfig
    from selfright.env.observations import privileged_columns
    from selfright.env.recovery_env import RecoveryEnv
    from selfright.env.world import build_world
    from selfright.evaluate.runner import context_config
    from selfright.terrain.grid import grid_cells

    cfg = BenchmarkConfig()
    cell = grid_cells("tiny", cfg.terrain)[3]
    env = RecoveryEnv(cfg, [build_world(cell, cfg, context_config(cfg), 0)], 2)
    ids = np.arange(2)
    env.reset(ids, np.zeros(2, int), [np.random.default_rng(s) for s in (1, 2)])
    obs = env.observe(ids, ("teacher",))["teacher"]
    torch.testing.assert_close(obs[:, privileged_columns(12)["height"].start], env.robot_state(ids).height_over_feet)
    env.close()
