"""How much of a rough tile can a standing robot count as "in the goal set"?

The goal set measures trunk height above the ground *directly beneath the trunk*. On rough
tiles that ground is not the ground under the feet, so a robot standing perfectly, trunk at
``h`` above the mean ground under its four feet, reads ``h + mean(feet ground) - trunk ground``.
This script samples stance positions (uniform over the central 80 % of each tile, every
heading, feet at the A1's stance footprint) on the tiles of a named grid and prints, per
tile, the fraction of stances that clear the bar for several stance heights. It is the
success ceiling of a policy that stands at height ``h`` wherever it happens to get up; the
grid mean row is the grid's rate (cells weigh alike). The last columns say how much the
trunk's offset varies and how much of it (R²) the four feet's relative heights explain: what
a robot that feels the ground only with its feet could know of the ground under its trunk.

    python scripts/rough_ceiling.py                      # --grid rough, seed 0
    python scripts/rough_ceiling.py --grid quick --samples 5000
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
import tyro

from selfright.config import BenchmarkConfig, ContextConfig
from selfright.env.goal import goal_height_m
from selfright.env.world import build_world
from selfright.robots import get_robot
from selfright.terrain.grid import grid_cells

FOOTPRINT_M = np.array([[0.183, 0.13], [0.183, -0.13], [-0.183, 0.13], [-0.183, -0.13]])
"""Stance foot positions in the trunk frame (x, y), A1 (hip at ±0.183, ±0.047 plus the thigh offset)."""


def reach_m(robot) -> float:
    """Trunk over the feet's bottoms with every knee at its upper limit and the thigh at half
    that, so the foot is under the hip (the robot's own forward kinematics; 0.379 m on the A1,
    knee limit −0.916 rad). No leg pose stands taller; under load the PD-held knee sags below it."""
    model = mujoco.MjModel.from_xml_string(robot.mjcf(1.0, 0.0))
    data = mujoco.MjData(model)
    free = int(np.flatnonzero(model.jnt_type == mujoco.mjtJoint.mjJNT_FREE)[0])
    data.qpos[model.jnt_qposadr[free] + 3:model.jnt_qposadr[free] + 7] = (1.0, 0.0, 0.0, 0.0)  # trunk level
    joints = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in robot.joint_names]
    knee = robot.joint_high[2]
    data.qpos[model.jnt_qposadr[joints]] = [0.0, -knee / 2, knee] * (len(robot.joint_names) // 3)
    mujoco.mj_kinematics(model, data)
    feet = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, g) for g in robot.foot_geoms]
    trunk = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, robot.trunk_body)
    return float(np.max(data.xpos[trunk, 2] - data.geom_xpos[feet, 2] + model.geom_size[feet, 0]))


@dataclass(frozen=True)
class Args:
    grid: str = "rough"
    """Named grid whose tiles are sampled."""
    seed: int = 0
    """Terrain seed (the benchmark's run seed)."""
    samples: int = 20000
    """Stance positions per tile."""
    heights: tuple[float, ...] = (0.33, 0.35, 0.36, 0.37, 0.38)
    """Stance heights above the mean foot ground to report (m)."""


def sample_stances(tile, samples: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """(samples, 2) trunk x-y, uniform over the central 80 % of the tile at uniform headings,
    and (samples, 4) the ground height under each foot."""
    half = 0.4 * tile.size_m
    xy = rng.uniform(-half, half, size=(samples, 2))
    yaw = rng.uniform(0.0, 2 * np.pi, samples)
    c, s = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
    fx = xy[:, :1] + c * FOOTPRINT_M[:, 0] - s * FOOTPRINT_M[:, 1]
    fy = xy[:, 1:] + s * FOOTPRINT_M[:, 0] + c * FOOTPRINT_M[:, 1]
    return xy, tile.height_at(np.stack([fx.ravel(), fy.ravel()], -1)).reshape(samples, 4)


def clear_fraction(offset: np.ndarray, bar_m: float, heights: tuple[float, ...]) -> dict[float, float]:
    """Share of stances, trunk ``h`` over the mean foot ground and ``offset`` = mean foot ground
    − ground under the trunk, that clear the bar, for each ``h``."""
    return {h: float(np.mean(h + offset >= bar_m)) for h in heights}


def feet_r2(offset: np.ndarray, feet: np.ndarray) -> float:
    """How much of ``offset``'s variance the feet's relative heights explain (least squares on
    the heights about their mean, their squares and magnitudes): what a robot that feels the
    ground only at its feet could know of the ground under its trunk."""
    dev = feet - feet.mean(axis=1, keepdims=True)
    x = np.column_stack([np.ones(len(dev)), dev, dev**2, np.abs(dev)])
    coef, *_ = np.linalg.lstsq(x, offset, rcond=None)
    return float(1.0 - np.var(offset - x @ coef) / np.var(offset))


def main(a: Args) -> None:
    cfg = BenchmarkConfig()
    robot = get_robot(cfg.robot.name)
    bar = goal_height_m(cfg.goal, robot.leg_length_m)
    rng = np.random.default_rng(a.seed)
    print(f"goal bar {bar:.3f} m above the ground beneath the trunk; robot stand height {robot.stand_height_m} m")
    print("slope%  rough_lvl  extent_m  " + "  ".join(f"h={h:.2f}" for h in a.heights) + "  offset_std_m  feet_R2")
    rows = []
    for cell in grid_cells(a.grid, cfg.terrain):
        tile = build_world(cell, cfg, ContextConfig(), a.seed).tile
        xy, feet = sample_stances(tile, a.samples, rng)
        offset = feet.mean(axis=1) - tile.height_at(xy)
        frac = clear_fraction(offset, bar, a.heights)
        rows.append(frac)
        r2 = f"{feet_r2(offset, feet):7.2f}" if offset.std() > 1e-6 else "      –"
        print(f"{cell.slope_pct:6.0f}  {cell.roughness_level:9d}  {cell.roughness_extent_m:8.3f}  "
              + "  ".join(f"{100 * frac[h]:5.1f}%" for h in a.heights) + f"  {offset.std():12.3f}  {r2}")
    # The grid's success rate weighs every cell alike (same episodes per cell).
    print(f"{'grid mean':>27s}  " + "  ".join(f"{100 * np.mean([r[h] for r in rows]):5.1f}%" for h in a.heights))
    print(f"(the A1 stands at most {reach_m(robot):.3f} m over its feet: knee at its limit, foot under the hip,"
          " before the legs sag under load)")


if __name__ == "__main__":
    main(tyro.cli(Args))
