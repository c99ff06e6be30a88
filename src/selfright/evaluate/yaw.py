"""The seed's yaw study (Table II) in simulation: recoveries on smooth inclines from a heading
set relative to the fall line (docs/benchmark.md, *Yaw study*).

Each episode is the benchmark's fall (inverted, random joints, dropped, settled 2 s) on a smooth
incline; once settled, the whole robot is turned about the slope's normal through its trunk so
that the trunk's forward axis, projected on the slope, points within ±``HEADING_WINDOW_DEG`` of
downhill, uphill or across, and the policy starts at once. Episode ``e`` of a slope is the same
fall for the three directions (a paired design); only the heading differs. Results are written
like ``selfright evaluate``'s: ``episodes.csv`` (one row per episode, resumable), ``run.json``
(the run's identity) and ``yaw.csv`` (one row per slope and direction).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import torch
from scipy.spatial.transform import Rotation

from selfright.config import BENCHMARK_VERSION, BenchmarkConfig, to_dict
from selfright.env.recovery_env import RecoveryEnv, SettledStarts, StepOutput
from selfright.env.world import build_world
from selfright.evaluate.results import check_run_identity
from selfright.evaluate.fall_cache import FallCache, default_cache_dir
from selfright.evaluate.runner import Executor, context_config, episode_seed, prepare_out_dir, rollout_batch, run_jobs
from selfright.evaluate.yaw_results import (
    DIRECTIONS, EPISODE_COLUMNS, TABLE_COLUMNS, Appender, read_yaw_episodes, write_csv, yaw_table,
)
from selfright.policies.base import Policy
from selfright.sim.batch import STATE_SPEC
from selfright.terrain import Cell

DIRECTION_DEG = {"down": 0.0, "up": 180.0, "cross": 90.0}
"""Centre of each heading window: the angle (deg) in the slope plane from downhill, counter-
clockwise about the slope's normal; ``cross`` is ±90°, its side drawn per episode."""
HEADING_WINDOW_DEG = 15.0
"""The forward axis lies within ± this of its direction at policy start (deg), uniformly drawn."""
SEED_SLOPES_DEG = (12.0, 15.0, 18.0)
"""The inclines of the seed's Table II (deg)."""
FULL_ROLL_TURNS = 1.0
"""The seed's hardware rule: a recovery within less than this many net roll rotations."""
TRAVEL_MIN_M = 0.05
"""A recovery point closer than this to the start (in the slope plane) travelled ``none`` (m)."""


def slope_cell(slope_deg: float) -> Cell:
    """The smooth incline of ``slope_deg`` degrees (off the grid, slope level -1)."""
    return Cell(slope_level=-1, roughness_level=0, slope_pct=100.0 * math.tan(math.radians(slope_deg)), roughness_extent_m=0.0)


def slope_frame(slope_pct: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(normal, downhill, left) unit vectors (3,) of a tile rising along +x at ``slope_pct`` %;
    ``left`` = normal × downhill, so headings are counter-clockwise seen from above the slope."""
    s = slope_pct / 100.0
    normal = np.array([-s, 0.0, 1.0]) / math.hypot(s, 1.0)
    downhill = np.array([-1.0, 0.0, -s]) / math.hypot(s, 1.0)
    return normal, downhill, np.cross(normal, downhill)


def in_plane_deg(vec: np.ndarray, slope_pct: float) -> np.ndarray:
    """Angle (deg, in (-180, 180]) from downhill of vectors ``vec`` (k, 3) projected on the slope."""
    _, down, left = slope_frame(slope_pct)
    v = np.atleast_2d(vec)
    return np.degrees(np.arctan2(v @ left, v @ down))


def heading_deg(forward: np.ndarray, slope_pct: float) -> np.ndarray:
    """(k,) heading of trunks whose forward axes (world frame) are ``forward`` (k, 3)."""
    return in_plane_deg(forward, slope_pct)


def draw_heading(direction: str, rng: np.random.Generator) -> float:
    """Target heading (deg) of an episode: the direction's centre (a random side for ``cross``)
    plus a uniform offset within ±``HEADING_WINDOW_DEG``."""
    centre = DIRECTION_DEG[direction]
    if direction == "cross" and rng.random() < 0.5:
        centre = -centre
    return float(centre + rng.uniform(-HEADING_WINDOW_DEG, HEADING_WINDOW_DEG))


def angle_diff_deg(a: np.ndarray | float, b: np.ndarray | float) -> np.ndarray:
    """a − b wrapped to [-180, 180) (deg)."""
    return (np.asarray(a) - np.asarray(b) + 180.0) % 360.0 - 180.0


def turn_state(state: np.ndarray, layout, slope_pct: float, target_deg: float) -> np.ndarray:
    """A copy of full-physics state ``state`` (S,) turned about the slope's normal through the
    trunk origin so that the trunk's heading is ``target_deg``. The turn is an isometry of the
    inclined plane: every point keeps its distance to the ground, so nothing floats or sinks.
    The world-frame linear velocity turns with it; body-frame angular and joint velocities do not
    change."""
    out = state.copy()
    w, x, y, z = state[layout.quat]
    rot = Rotation.from_quat([x, y, z, w])
    now = heading_deg(rot.apply([1.0, 0.0, 0.0])[None], slope_pct)[0]
    normal, _, _ = slope_frame(slope_pct)
    turn = Rotation.from_rotvec(math.radians(float(angle_diff_deg(target_deg, now))) * normal)
    qx, qy, qz, qw = (turn * rot).as_quat()
    out[layout.quat] = [qw, qx, qy, qz]
    out[layout.lin_vel] = turn.apply(state[layout.lin_vel])
    return out


class HeadingEnv(RecoveryEnv):
    """``RecoveryEnv`` whose ``begin`` turns each settled fall to the heading in ``targets_deg``
    (one per started slot, set before each reset) before the policy starts; no further settling."""

    targets_deg: np.ndarray = np.zeros(0)
    """(k,) headings (deg) of the next ``reset``'s (``begin``'s) slots."""

    def begin(self, ids, world_idx, models, s: SettledStarts) -> None:
        state, sens = s.state.copy(), s.sens.copy()
        data = {}
        for k, w in enumerate(world_idx):
            if s.diverged[k]:
                continue
            state[k] = turn_state(s.state[k], self.sl, self.worlds[w].cell.slope_pct, self.targets_deg[k])
            d = data.setdefault(id(models[k]), mujoco.MjData(models[k]))
            mujoco.mj_setState(models[k], d, state[k], STATE_SPEC)
            mujoco.mj_forward(models[k], d)
            sens[k] = d.sensordata
        super().begin(ids, world_idx, models, SettledStarts(state=state, sens=sens, diverged=s.diverged))


def heading_rng(seed: int, slope_deg: float, episode: int, direction: str) -> np.random.Generator:
    """Generator of one episode's heading draw: a pure function of its identity."""
    key = (int(round(slope_deg * 1000)), episode, DIRECTIONS.index(direction), 0x1A3)
    return np.random.default_rng(np.random.SeedSequence(entropy=seed, spawn_key=key))


def travel(dxy: np.ndarray, slope_pct: float) -> tuple[str, float, float]:
    """(label, angle deg, downhill m) of a horizontal displacement ``dxy`` (2,) on the slope: its
    in-plane angle from downhill, ``down``/``up`` within 45° of the fall line, else ``cross``;
    ``none`` below ``TRAVEL_MIN_M``."""
    s = slope_pct / 100.0
    vec = np.array([dxy[0], dxy[1], s * dxy[0]])
    _, down, _ = slope_frame(slope_pct)
    deg = float(in_plane_deg(vec, slope_pct)[0])
    if np.linalg.norm(vec) < TRAVEL_MIN_M:
        label = "none"
    else:
        label = "down" if abs(deg) <= 45 else "up" if abs(deg) >= 135 else "cross"
    return label, deg, float(vec @ down)


@dataclass(frozen=True)
class YawResult:
    out_dir: Path
    table: list[dict[str, Any]]
    seconds: float
    episodes_run: int


def run_yaw_study(
    policy: Policy, *, policy_name: str, slopes_deg: tuple[float, ...], episodes: int, seed: int, out_dir: Path,
    cfg: BenchmarkConfig, progress: bool = True, fall_cache: bool = True, executor: Executor = "local",
    ray_address: str | None = None,
) -> YawResult:
    """Run (or resume) the yaw study into ``out_dir``: ``episodes`` per slope and direction
    (``fall_cache``, ``executor``, ``ray_address``: as for ``evaluate_grid``)."""
    if episodes < 1:
        raise ValueError(f"--episodes must be >= 1, got {episodes}")
    if not slopes_deg or any(not 0 < d < 60 for d in slopes_deg):
        raise ValueError(f"--slopes-deg must be angles between 0 and 60 degrees, got {list(slopes_deg)}")
    slopes = tuple(float(d) for d in slopes_deg)
    out_dir = Path(out_dir)
    prepare_out_dir(out_dir)
    identity = {"benchmark_version": BENCHMARK_VERSION, "study": "yaw", "policy": policy_name, "slopes_deg": list(slopes),
                "episodes_per_direction": episodes, "seed": seed, "heading_window_deg": HEADING_WINDOW_DEG,
                "config": to_dict(cfg)}
    if policy.digest is not None:
        identity["policy_digest"] = policy.digest
    check_run_identity(out_dir, identity)
    csv_path = out_dir / "episodes.csv"
    existing = [r for r in read_yaw_episodes(csv_path) if r["slope_deg"] in slopes and r["episode"] < episodes]
    done = {(r["slope_deg"], r["direction"], r["episode"]) for r in existing}
    jobs = [(k, d, e) for k, deg in enumerate(slopes) for d in DIRECTIONS for e in range(episodes) if (deg, d, e) not in done]
    t0 = time.time()
    rows = list(existing)
    if jobs:
        work = YawWork(cfg=cfg, slopes=slopes, seed=seed, num_envs=min(cfg.eval.batch_size, len(jobs)),
                       fall_cache_dir=default_cache_dir() if fall_cache else None)
        with Appender(csv_path, existing) as writer:
            rows += run_jobs(work, policy, jobs, writer.write, total=len(slopes) * 3 * episodes, done=len(done),
                             desc=f"{policy_name} yaw study", progress=progress, executor=executor,
                             ray_address=ray_address)
    rows.sort(key=lambda r: (slopes.index(r["slope_deg"]), DIRECTIONS.index(r["direction"]), r["episode"]))
    write_csv(csv_path, EPISODE_COLUMNS, rows)
    table = yaw_table(rows, slopes)
    write_csv(out_dir / "yaw.csv", TABLE_COLUMNS, table)
    return YawResult(out_dir=out_dir, table=table, seconds=time.time() - t0, episodes_run=len(jobs))


@dataclass(frozen=True)
class YawWork:
    """The batches of a yaw study (``runner.Work``): one smooth incline world per slope."""

    cfg: BenchmarkConfig
    slopes: tuple[float, ...]
    seed: int
    num_envs: int
    fall_cache_dir: Path | None
    """Settled falls are read from and written to this cache; None = settle every fall."""

    def open(self, threads: int | None = None) -> YawSession:
        return YawSession(self, threads)


class YawSession:
    def __init__(self, work: YawWork, threads: int | None = None):
        self.work = work
        self.cells = [slope_cell(d) for d in work.slopes]
        self.worlds = [build_world(c, work.cfg, context_config(work.cfg), work.seed) for c in self.cells]
        self.env = HeadingEnv(work.cfg, self.worlds, work.num_envs, threads)
        self.falls = None if work.fall_cache_dir is None else FallCache(work.fall_cache_dir, work.cfg)

    def run(self, policy: Policy, batch: list[tuple[int, str, int]]) -> list[dict[str, Any]]:
        return _run_batch(self.env, policy, batch, self.work.slopes, self.cells, self.work.seed, self.worlds, self.falls)

    def close(self) -> None:
        self.env.close()


def _run_batch(env: HeadingEnv, policy: Policy, batch, slopes, cells, seed: int, worlds=(), falls: FallCache | None = None) -> list[dict[str, Any]]:
    """Simulate one batch of (slope index, direction, episode) jobs; returns their rows."""
    n = len(batch)
    ids = np.arange(n)
    seeds = np.array([episode_seed(seed, cells[k], e) for k, _, e in batch], dtype=np.int64)
    keys = [falls.key(worlds[k], seed, e, int(seeds[i])) for i, (k, _, e) in enumerate(batch)] if falls else ()
    env.targets_deg = np.array([draw_heading(d, heading_rng(seed, slopes[k], e, d)) for k, d, e in batch])
    pct = [cells[k].slope_pct for k, _, _ in batch]
    start_heading = np.zeros(n)
    roll = np.zeros(n)

    def on_start() -> None:
        fwd = env.robot_state(ids).rot[:, :, 0].double().numpy()
        start_heading[:] = [heading_deg(fwd[i][None], pct[i])[0] for i in ids]

    def on_step(active: np.ndarray, out: StepOutput) -> None:
        roll[active] += out.state.ang_vel[:, 0].double().numpy() * env.control_dt

    success = rollout_batch(env, policy, np.array([k for k, _, _ in batch]), seeds, [cells[k] for k, _, _ in batch],
                            on_step=on_step, on_start=on_start, falls=falls, fall_keys=keys)
    m = env.metrics(ids)
    moved = (env.goal.streak_start_xy[torch.from_numpy(ids)] - env.start_xy[torch.from_numpy(ids)]).numpy()
    rows = []
    for i, (k, d, e) in enumerate(batch):
        ok = bool(success[i])
        label, deg, downhill = travel(moved[i], pct[i]) if ok else ("", None, None)
        turns = abs(roll[i]) / (2 * math.pi)
        rows.append({
            "slope_deg": slopes[k], "direction": d, "episode": e, "seed": int(seeds[i]),
            "heading_deg": float(start_heading[i]), "success": ok, "hardware_success": ok and turns < FULL_ROLL_TURNS,
            "ttr_s": float(m["ttr_s"][i]) if ok else None, "dtr_m": float(m["dtr_m"][i]) if ok else None,
            "travel": label, "travel_deg": deg, "downhill_m": downhill, "roll_turns": turns,
            "energy_j": float(m["energy_j"][i]), "diverged": bool(m["diverged"][i]),
        })
    return rows


