"""The settled-fall cache: hits give the rows a cold run gives, damaged entries are recomputed,
and the key changes with everything a settled fall depends on and nothing else."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from selfright.config import ActionConfig, BenchmarkConfig, ContextConfig, EvalConfig, FallConfig, GoalConfig, RobotConfig, SimConfig
from selfright.env.recovery_env import RecoveryEnv
from selfright.env.world import build_world
from selfright.evaluate.fall_cache import FallCache, default_cache_dir
from selfright.evaluate.runner import context_config, evaluate_grid
from selfright.policies.registry import make_policy
from selfright.terrain import grid_cells

CFG = BenchmarkConfig(goal=GoalConfig(episode_s=1.0, hold_s=0.2), sim=SimConfig(threads=1))


@pytest.fixture
def cache(tmp_path, monkeypatch) -> Path:
    """A cold cache of this test's own."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    return default_cache_dir() / "falls"


def run(out: Path, policy: str, **kw) -> bytes:
    evaluate_grid(make_policy(policy, CFG), policy_name=policy, grid="tiny", episodes=2, seed=0, out_dir=out, cfg=CFG,
                  progress=False, **kw)
    return (out / "episodes.csv").read_bytes()


def entries(cache: Path) -> list[Path]:
    return sorted(cache.rglob("*.bin")) if cache.exists() else []


def no_settling(monkeypatch) -> None:
    def fail(*a, **k):
        raise AssertionError("settled a fall the cache holds")

    monkeypatch.setattr(RecoveryEnv, "settle", fail)


def test_warm_runs_skip_the_settle_and_match_cold_and_uncached_runs(cache, tmp_path, monkeypatch):
    off = {p: run(tmp_path / f"{p}_off", p, fall_cache=False) for p in ("random", "open-loop")}
    assert entries(cache) == []  # --no-fall-cache writes nothing
    assert run(tmp_path / "random_cold", "random") == off["random"]
    assert len(entries(cache)) == 4 * 2
    no_settling(monkeypatch)
    assert run(tmp_path / "open-loop_warm", "open-loop") == off["open-loop"]  # another policy, same falls
    assert run(tmp_path / "random_warm", "random") == off["random"]


@pytest.mark.parametrize("damage", ["truncate", "flip", "garbage", "empty"])
def test_a_damaged_entry_is_recomputed_never_trusted(cache, tmp_path, damage):
    cold = run(tmp_path / "cold", "random")
    victim = entries(cache)[3]
    good = victim.read_bytes()
    bad = {"truncate": good[: len(good) // 2], "flip": good[:-40] + bytes([good[-40] ^ 1]) + good[-39:],
           "garbage": b"x" * len(good), "empty": b""}[damage]
    victim.write_bytes(bad)
    assert run(tmp_path / "again", "random") == cold
    assert victim.read_bytes() == good  # rewritten


def test_a_hit_leaves_the_episode_generator_where_settling_leaves_it(cache):
    cell = grid_cells("tiny", CFG.terrain)[1]
    world = build_world(cell, CFG, context_config(CFG), 0)
    env = RecoveryEnv(CFG, [world], 2, threads=1)
    falls = FallCache(default_cache_dir(), CFG)
    keys = [falls.key(world, 0, e, 100 + e) for e in range(2)]
    try:
        runs = []
        for _ in range(2):  # cold, then warm
            rngs = [np.random.default_rng(100 + e) for e in range(2)]
            s = falls.settle(env, np.zeros(2, dtype=np.int64), rngs, keys)
            runs.append((s, [r.random() for r in rngs]))
        plain_rngs = [np.random.default_rng(100 + e) for e in range(2)]
        plain = env.settle(np.zeros(2, dtype=np.int64), plain_rngs, [world.model] * 2)
    finally:
        env.close()
    assert (falls.misses, falls.hits) == (2, 2)
    for s, _ in runs:
        assert np.array_equal(s.state, plain.state) and np.array_equal(s.sens, plain.sens)
        assert np.array_equal(s.diverged, plain.diverged)
    assert runs[0][1] == runs[1][1] == [r.random() for r in plain_rngs]


def test_one_fall_twice_in_a_batch_is_settled_once(cache):
    world = build_world(grid_cells("tiny", CFG.terrain)[0], CFG, context_config(CFG), 0)
    env = RecoveryEnv(CFG, [world], 3, threads=1)
    falls = FallCache(default_cache_dir(), CFG)
    key = falls.key(world, 0, 0, 7)
    try:
        s = falls.settle(env, np.zeros(3, dtype=np.int64), [np.random.default_rng(7) for _ in range(3)], [key] * 3)
    finally:
        env.close()
    assert falls.misses == 1 and len(entries(cache)) == 1
    assert np.array_equal(s.state[0], s.state[2])


def key_of(cfg: BenchmarkConfig, seed=0, episode=0, cell_index=0, ctx: ContextConfig | None = None) -> str:
    cell = grid_cells("tiny", cfg.terrain)[cell_index]
    world = build_world(cell, cfg, ctx or context_config(cfg), seed)
    return FallCache(Path("unused"), cfg).key(world, seed, episode, 1234)


def test_the_key_covers_what_a_settled_fall_depends_on_and_not_the_rest():
    base = key_of(CFG)
    changed = [
        key_of(CFG, seed=1), key_of(CFG, episode=1), key_of(CFG, cell_index=1),
        key_of(dataclasses.replace(CFG, fall=FallConfig(drop_height_m=0.4))),
        key_of(dataclasses.replace(CFG, fall=FallConfig(settle_s=1.0))),
        key_of(dataclasses.replace(CFG, robot=RobotConfig(motor="ideal"))),
        key_of(dataclasses.replace(CFG, robot=RobotConfig(kp=40.0))),
        key_of(dataclasses.replace(CFG, sim=SimConfig(timestep_s=0.004, threads=1))),
        key_of(dataclasses.replace(CFG, eval=EvalConfig(friction=0.5))),
        key_of(dataclasses.replace(CFG, eval=EvalConfig(wall_gap_ratio=1.5))),
        key_of(CFG, ctx=ContextConfig(ground_dampratio=0.5)),
    ]
    assert len(set(changed + [base])) == len(changed) + 1
    same = [
        key_of(dataclasses.replace(CFG, goal=GoalConfig())),
        key_of(dataclasses.replace(CFG, action=ActionConfig(reference="tall"))),
        key_of(dataclasses.replace(CFG, sim=SimConfig(threads=2))),
        key_of(dataclasses.replace(CFG, eval=EvalConfig(batch_size=3, sensor_noise=1.0))),
    ]
    assert set(same) == {base}
