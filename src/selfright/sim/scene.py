"""MJCF scene assembly: a robot on one terrain tile, with the context's friction, compliance
and optional side walls. The result is one self-contained MJCF document (no external files)."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from selfright.config import ContextConfig, RobotConfig, SimConfig
from selfright.robots import RobotSpec
from selfright.terrain import Tile

TERRAIN_GEOM = "terrain"
WALL_GEOMS = ("wall_left", "wall_right")


@dataclass(frozen=True)
class SensorLayout:
    """Slices of ``MjData.sensordata`` by meaning (built by name in ``sim.batch``)."""

    foot_contact: slice
    body_contact: slice
    gyro: slice
    actuator_force: slice
    foot_pos: slice
    """World positions of the foot geoms' centres, (x, y, z) per foot."""


def _sensors_xml(robot: RobotSpec) -> str:
    lines = [f'    <contact name="contact_{g}" geom1="{g}" geom2="{TERRAIN_GEOM}" data="found"/>' for g in robot.foot_geoms]
    lines += [f'    <contact name="contact_{g}" geom1="{g}" geom2="{TERRAIN_GEOM}" data="found"/>' for g in robot.collision_geoms]
    lines.append('    <gyro name="gyro" site="imu"/>')
    lines += [f'    <actuatorfrc name="tau_{j}" actuator="{j.removesuffix("_joint")}"/>' for j in robot.joint_names]
    lines += [f'    <framepos name="pos_{g}" objtype="geom" objname="{g}"/>' for g in robot.foot_geoms]
    return "\n".join(lines)


def _hfield_xml(tile: Tile) -> tuple[str, str]:
    h = tile.heights
    lo, hi = float(h.min()), float(h.max())
    span = max(hi - lo, 1e-3)
    norm = (h - lo) / span
    n = h.shape[0]
    half = tile.size_m / 2
    # MJCF's ``elevation`` lists rows from +y down to -y (image order); Tile rows run from -y.
    data = " ".join(f"{v:.5f}" for v in norm[::-1].ravel())
    asset = f'    <hfield name="terrain" nrow="{n}" ncol="{n}" size="{half} {half} {span} 0.5" elevation="{data}"/>'
    geom = f'    <geom name="{TERRAIN_GEOM}" type="hfield" hfield="terrain" pos="0 0 {lo}" material="ground" {{contact}}/>'
    return asset, geom


def _walls_xml(tile: Tile, ctx: ContextConfig, robot: RobotSpec, contact: str) -> str:
    theta = math.atan(tile.slope_pct / 100.0)
    half_len = tile.size_m / 2 / math.cos(theta)
    enabled = ctx.wall_gap_ratio is not None
    gap = (ctx.wall_gap_ratio or 1.0) * robot.body_length_m
    thick = 0.05
    quat = (math.cos(-theta / 2), 0.0, math.sin(-theta / 2), 0.0)
    attrs = contact if enabled else 'contype="0" conaffinity="0" rgba="0 0 0 0"'
    z = 0.5 if enabled else -100.0  # unused walls are parked far below the tile
    out = []
    for name, sign in zip(WALL_GEOMS, (1, -1)):
        y = sign * (gap / 2 + thick)
        out.append(
            f'    <geom name="{name}" type="box" size="{half_len} {thick} 1.0" pos="0 {y} {z}" '
            f'quat="{quat[0]} {quat[1]} {quat[2]} {quat[3]}" material="wall" {attrs}/>'
        )
    return "\n".join(out)


def scene_mjcf(robot: RobotSpec, tile: Tile, ctx: ContextConfig, robot_cfg: RobotConfig, sim: SimConfig) -> str:
    """Self-contained MJCF text: ``robot`` on ``tile`` under context ``ctx``."""
    if robot_cfg.joint_stop_timeconst_s < 2 * sim.timestep_s:
        raise ValueError(
            f"joint_stop_timeconst_s {robot_cfg.joint_stop_timeconst_s} s is under 2 × the {sim.timestep_s} s "
            "physics step, which MuJoCo would silently raise; use at least twice the step"
        )
    if ctx.ground_timeconst_s < 2 * sim.timestep_s:
        raise ValueError(
            f"ground_timeconst_s {ctx.ground_timeconst_s} s is under 2 × the {sim.timestep_s} s physics step, "
            "which MuJoCo would silently raise; use at least twice the step"
        )
    if ctx.wall_gap_ratio is not None and ctx.wall_gap_ratio <= 0:
        raise ValueError(f"wall_gap_ratio must be a positive number of body lengths, got {ctx.wall_gap_ratio}")
    # The actuators carry the motor model; a speed for the ideal servos is refused by the robot's mjcf.
    speed = {} if robot_cfg.motor_speed_rad_s is None else {"motor_speed": robot_cfg.motor_speed_rad_s}
    body = robot.mjcf(robot_cfg.kp, robot_cfg.kd, robot_cfg.joint_stop_timeconst_s, robot_cfg.motor, **speed)
    inner = re.search(r"<mujoco[^>]*>(.*)</mujoco>", body, re.S)
    assert inner is not None
    robot_xml = inner.group(1)
    contact = (
        f'contype="1" conaffinity="1" condim="3" priority="1" margin="0" '
        f'friction="{ctx.friction} 0.005 0.0001" solref="{ctx.ground_timeconst_s} {ctx.ground_dampratio}"'
    )
    asset, geom = _hfield_xml(tile)
    walls = _walls_xml(tile, ctx, robot, contact)
    # The trunk's default position is irrelevant: the fall protocol sets every state.
    return f"""<mujoco model="selfright_{robot.name}">
  <compiler angle="radian" autolimits="true"/>
  <option timestep="{sim.timestep_s}" integrator="implicitfast" iterations="{sim.solver_iterations}" ls_iterations="10"/>
  <size memory="8M"/>
  <visual><headlight diffuse="0.6 0.6 0.6" ambient="0.3 0.3 0.3"/><global offwidth="1280" offheight="720"/></visual>
  <asset>
    <texture name="grid" type="2d" builtin="checker" rgb1="0.35 0.45 0.3" rgb2="0.3 0.38 0.25" width="256" height="256"/>
    <material name="ground" texture="grid" texrepeat="16 16"/>
    <material name="wall" rgba="0.6 0.6 0.7 0.4"/>
{asset}
  </asset>
  <worldbody>
    <light pos="0 0 6" dir="0 0 -1" directional="true"/>
{geom.format(contact=contact)}
{walls}
  </worldbody>
{robot_xml.strip()}
  <sensor>
{_sensors_xml(robot)}
  </sensor>
</mujoco>
"""


def spawn_y_fixed(ctx: ContextConfig) -> bool:
    """With side walls the robot is dropped midway between them (y = 0)."""
    return ctx.wall_gap_ratio is not None

