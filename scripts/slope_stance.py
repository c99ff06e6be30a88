"""Does a fixed, symmetric stance stand on a slope? The robot is set down square to the slope
(trunk parallel to it, feet 2 cm above it) at each heading, its PD targets held at one pose
for ``--hold-s``, and the script prints its tilt from vertical at the end (the goal set asks
for roll and pitch within 30°; a robot that tipped over reads 60–180°).

Held PD targets are not rigid legs: the slope's pull along the ground loads the legs
sideways, the PD-held joints give (Kp 50 N·m/rad), the trunk shifts downhill, the downhill
legs take more load and give more, and the robot tips over. On the 20° incline neither the
A1's stand pose nor the tall stance of ``--train.reward.stance`` /
``--train.distillation.stance-pose`` stays up at any heading; from 10° facing uphill they tip
backwards. So on the incline standing is an active, heading-dependent posture the policy has
to keep adjusting, and the fixed-stance recipes that helped on rough ground
(docs/training.md) do not carry over to it. ``--level`` holds such a posture, set from the
IMU's gravity alone (``selfright.policies.level_stance``), and it stands at every heading.

    python scripts/slope_stance.py                       # 0°, 10°, 15°, 20°
    python scripts/slope_stance.py --slopes-deg 20 --friction 0.6
    python scripts/slope_stance.py --slopes-deg 10 20 --kp 100     # stiffer servos (not the A1's)
    python scripts/slope_stance.py --slopes-deg 20 --lean 0 1      # legs leaned to gravity, each step

With ``--lean R P`` each pose is also held with its legs leaned towards gravity every control
step (``selfright.policies.pose_blend.gravity_lean``: the hips turned by R times the trunk's
roll, the thighs by P times its pitch, read from the trunk's orientation as the IMU gives it).
``--lean 0 1`` puts the feet under the hips in the world fore and aft, and that stance stands
facing up or down the 20° slope (tilt 19–20°, square to it) where the fixed one tips; across
the slope it still tips, and a roll lean feeds itself back (turning the hips with the feet
planted rolls the trunk further), docs/training.md.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import mujoco
import numpy as np
import torch
import tyro

from selfright.config import BenchmarkConfig, ContextConfig, RewardConfig
from selfright.env.world import build_world
from selfright.policies.level_stance import LevelStance
from selfright.policies.pose_blend import gravity_lean, lean_gains
from selfright.robots import get_robot
from selfright.robots.kinematics import KinematicHeight
from selfright.terrain.grid import grid_cells

CLEARANCE_M = 0.02
"""How far above the slope the feet are set down (m)."""


@dataclass(frozen=True)
class Args:
    slopes_deg: tuple[float, ...] = (0.0, 10.0, 15.0, 20.0)
    headings_deg: tuple[float, ...] = (0.0, 45.0, 90.0, 135.0, 180.0)
    """Heading on the slope: 0 = facing uphill, 90 = across, 180 = facing downhill (the other
    side is the mirror image)."""
    friction: float = 1.0
    hold_s: float = 4.0
    lean: tuple[float, float] = (0.0, 0.0)
    """Also hold each pose leaned towards gravity: gains on the trunk's roll (hips) and pitch
    (thighs); 0 0 = fixed poses only."""
    level: bool = False
    """Also hold the level stance ``level_law`` (``selfright.policies.level_stance``)."""
    level_law: LevelStance = LevelStance()
    kp: float | None = None
    """PD stiffness of every joint (N·m/rad); ``None`` = the benchmark's (``RobotConfig.kp``, 50)."""


Law = Callable[[torch.Tensor], np.ndarray]
"""Joint targets (J,) for the trunk's projected gravity (1, 3), set every control step."""


def final_state(model: mujoco.MjModel, slope_rad: float, heading_rad: float, pose: np.ndarray, height_m: float,
                hold_s: float, law: Law | None = None, control_dt_s: float = 0.02) -> tuple[float, float]:
    """Tilt of the trunk's up axis from world z (deg), and the trunk's height over the slope
    beneath it (m), after holding ``pose`` for ``hold_s``, set down square to a slope rising
    along +x (through the origin) at ``heading_rad``, the trunk ``height_m`` above it along its
    normal. ``law``: every ``control_dt_s`` the targets are ``law`` of the trunk's projected
    gravity instead of ``pose``."""
    d = mujoco.MjData(model)
    q_slope, q_head, quat = np.zeros(4), np.zeros(4), np.zeros(4)
    mujoco.mju_axisAngle2Quat(q_slope, np.array([0.0, 1.0, 0.0]), -slope_rad)  # nose up along +x
    mujoco.mju_axisAngle2Quat(q_head, np.array([0.0, 0.0, 1.0]), heading_rad)
    mujoco.mju_mulQuat(quat, q_slope, q_head)
    normal = np.array([-math.sin(slope_rad), 0.0, math.cos(slope_rad)])
    d.qpos[:3] = normal * height_m
    d.qpos[3:7] = quat
    d.qpos[7:] = pose
    d.ctrl[:] = pose
    every, rot = max(1, int(round(control_dt_s / model.opt.timestep))), np.zeros(9)
    for i in range(int(round(hold_s / model.opt.timestep))):
        if law is not None and i % every == 0:
            mujoco.mju_quat2Mat(rot, d.qpos[3:7])
            d.ctrl[:] = law(torch.as_tensor(rot.reshape(3, 3).T @ np.array([0.0, 0.0, -1.0]))[None])
        mujoco.mj_step(model, d)
    x, y = d.qpos[4], d.qpos[5]
    tilt = math.degrees(math.acos(float(np.clip(1 - 2 * (x * x + y * y), -1.0, 1.0))))
    return tilt, float(d.qpos[2] - d.qpos[0] * math.tan(slope_rad))


def main(a: Args) -> None:
    cfg = BenchmarkConfig()
    if a.kp is not None:
        cfg = replace(cfg, robot=replace(cfg.robot, kp=a.kp))
    robot = get_robot(cfg.robot.name)
    base = grid_cells("incline", cfg.terrain)[0]
    legs = len(robot.joint_names) // 3
    # The stance of --train.reward.stance / --train.distillation.stance-pose, and the A1's stand pose.
    poses = {"tall stance": np.tile(np.asarray(RewardConfig().stance_pose), legs), "A1 stand": robot.stand_pose}
    laws: dict[str, tuple[np.ndarray, Law | None]] = {name: (pose, None) for name, pose in poses.items()}
    if any(a.lean):
        gains = torch.as_tensor(lean_gains(robot, a.lean))  # rad per rad
        for name, pose in poses.items():
            laws[f"{name}, leaning {a.lean[0]:g} {a.lean[1]:g}"] = (
                pose, lambda g, pose=pose: pose + gravity_lean(g, gains).double().numpy()[0])
    if a.level:
        upright = torch.tensor([[0.0, 0.0, -1.0]])
        level_pose = a.level_law.joints(upright, float(robot.joint_high[2])).double().numpy()[0]
        laws["level stance"] = (level_pose, lambda g: a.level_law.joints(g, float(robot.joint_high[2])).double().numpy()[0])
    # Trunk over the feet's bottoms in each pose (the robot's own forward kinematics), plus the clearance.
    level = KinematicHeight(robot).level(np.stack([pose for pose, _ in laws.values()]))
    heights = {name: float(h) + CLEARANCE_M for name, h in zip(laws, level, strict=True)}
    print(f"tilt from vertical (deg) / trunk height over the ground beneath it (m) after {a.hold_s} s holding "
          f"the pose, friction {a.friction}, Kp {cfg.robot.kp:g}; headings {', '.join(f'{h:g}' for h in a.headings_deg)}° "
          "(0 = facing uphill)")
    for deg in a.slopes_deg:
        cell = replace(base, slope_pct=100.0 * math.tan(math.radians(deg)))
        model = build_world(cell, cfg, ContextConfig(friction=a.friction), 0, robot=robot).model
        for name, (pose, law) in laws.items():
            ends = [final_state(model, math.radians(deg), math.radians(h), pose, heights[name], a.hold_s, law,
                                cfg.sim.control_dt_s) for h in a.headings_deg]
            print(f"  slope {deg:4.1f}°  {name:26s} " + "  ".join(f"{t:5.0f} {z:.3f}" for t, z in ends))


if __name__ == "__main__":
    main(tyro.cli(Args))
