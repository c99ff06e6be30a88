"""Unitree A1, written from the published physical facts (``shared/robots/unitree_a1.md``).

Collision model: spheres, capsules and boxes only, margin 0, so that the same MJCF runs on
the MuJoCo C engine and on GPU backends (no cylinder: MJX lacks heightfield–cylinder).
The hip cylinder (r 0.046, length 0.04) becomes a sphere of radius 0.046; thigh and calf
boxes become capsules of radius 0.02 and 0.012.
"""

from __future__ import annotations

import numpy as np

from selfright.robots.spec import RobotSpec

LEGS = ("FR", "FL", "RR", "RL")
_SIGN = {"FR": (1, -1), "FL": (1, 1), "RR": (-1, -1), "RL": (-1, 1)}
_HIP_X, _HIP_Y = 0.183, 0.047  # abduction joint from the trunk origin (m), times the leg's signs
_THIGH_Y = 0.08505  # thigh joint from the abduction joint, sideways (m), times the leg's y sign
_ABD_RANGE = (-0.802851, 0.802851)
_HIP_RANGE = (-1.0472, 4.18879)
_KNEE_RANGE = (-2.69653, -0.916298)
TORQUE_LIMIT = 33.5
ARMATURE = 0.01  # reflected rotor inertia of the geared motor (kg·m²), typical for the A1
STOP_TIMECONST_S = 0.01  # hard joint stops: solreflimit time constant (RobotConfig's default)


def _leg_xml(leg: str) -> str:
    sx, sy = _SIGN[leg]
    hip_com = (-0.003311 * sx, 0.000635 * sy, 3.1e-05)
    thigh_com = (-0.003237, -0.022327 * sy, -0.027326)
    f = lambda v: " ".join(f"{x:.6g}" for x in v)  # noqa: E731
    return f"""
      <body name="{leg}_hip" pos="{f((_HIP_X * sx, _HIP_Y * sy, 0))}">
        <inertial pos="{f(hip_com)}" mass="0.696" diaginertia="0.000807752 0.00055293 0.000468983"/>
        <joint name="{leg}_hip_joint" class="abduction"/>
        <geom name="{leg}_hip" class="robot" type="sphere" size="0.046"/>
        <body name="{leg}_thigh" pos="{f((0, _THIGH_Y * sy, 0))}">
          <inertial pos="{f(thigh_com)}" mass="1.013" diaginertia="0.00555739 0.00513936 0.00133944"/>
          <joint name="{leg}_thigh_joint" class="hip"/>
          <geom name="{leg}_thigh" class="robot" type="capsule" size="0.02" fromto="0 0 0 0 0 -0.2"/>
          <body name="{leg}_calf" pos="0 0 -0.2">
            <inertial pos="0.00472659 0 -0.131975" mass="0.226" diaginertia="0.00340344 0.00339393 3.54834e-05"/>
            <joint name="{leg}_calf_joint" class="knee"/>
            <geom name="{leg}_calf" class="robot" type="capsule" size="0.012" fromto="0 0 0 0 0 -0.18"/>
            <geom name="{leg}_foot" class="robot" type="sphere" size="0.02" pos="0 0 -0.2"/>
            <site name="{leg}_foot_site" pos="0 0 -0.2" size="0.005"/>
          </body>
        </body>
      </body>"""


RATED_SPEED = 21.0  # published maximum joint speed of the motors (rad/s)
DRIVE_VOLTAGE = 24.0  # nominal drive voltage of the DC-motor model (V); only K and R depend on it


def a1_mjcf(kp: float, kd: float, stop_timeconst_s: float = STOP_TIMECONST_S, motor: str = "ideal",
            motor_speed: float | None = None) -> str:
    """MJCF text of the A1 alone, PD position servos with gains ``kp`` (N·m/rad), ``kd`` (N·m·s/rad),
    joint stops of ``solreflimit`` time constant ``stop_timeconst_s`` (s). ``motor``: ``ideal``
    (MuJoCo position servos, full torque at any speed) or ``dcmotor`` (a current-controlled DC
    motor whose voltage saturates: stall torque ``TORQUE_LIMIT``, no-load speed ``motor_speed``,
    by default the A1's ``RATED_SPEED``)."""
    if motor_speed is not None and (motor != "dcmotor" or motor_speed <= 0):
        raise ValueError(f"a motor speed ({motor_speed} rad/s) needs motor='dcmotor' and a positive value")
    legs = "".join(_leg_xml(leg) for leg in LEGS)
    if motor == "ideal":
        servo = '<position name="{name}" joint="{name}_joint" class="pd"/>'
    elif motor == "dcmotor":
        v = DRIVE_VOLTAGE
        servo = (f'<dcmotor name="{{name}}" joint="{{name}}_joint" nominal="{v} {TORQUE_LIMIT} {motor_speed or RATED_SPEED}" '
                 f'saturation="{TORQUE_LIMIT} 0 0" input="pos" controller="{kp} 0 {kd} 0 0 {v}"/>')
    else:
        raise ValueError(f"unknown motor model {motor!r}; choose ideal or dcmotor")
    actuators = "\n".join("    " + servo.format(name=f"{leg}_{j}") for leg in LEGS for j in ("hip", "thigh", "calf"))
    return f"""<mujoco model="unitree_a1">
  <compiler angle="radian" autolimits="true"/>
  <default>
    <joint limited="true" armature="{ARMATURE}" damping="0.01" solreflimit="{stop_timeconst_s} 1"/>
    <default class="abduction"><joint axis="1 0 0" range="{_ABD_RANGE[0]} {_ABD_RANGE[1]}"/></default>
    <default class="hip"><joint axis="0 1 0" range="{_HIP_RANGE[0]} {_HIP_RANGE[1]}"/></default>
    <default class="knee"><joint axis="0 1 0" range="{_KNEE_RANGE[0]} {_KNEE_RANGE[1]}"/></default>
    <default class="robot">
      <geom contype="1" conaffinity="1" condim="3" margin="0" density="0" friction="0.6 0.02 0.01" rgba="0.25 0.25 0.28 1"/>
    </default>
    <default class="pd">
      <position kp="{kp}" kv="{kd}" forcelimited="true" forcerange="-{TORQUE_LIMIT} {TORQUE_LIMIT}"/>
    </default>
  </default>
  <worldbody>
    <body name="trunk" pos="0 0 0.45">
      <freejoint name="root"/>
      <inertial pos="0 0.0041 -0.0005" mass="4.713"
        fullinertia="0.0158533 0.0377999 0.0456542 -3.66e-05 -6.11e-05 -2.75e-05"/>
      <geom name="trunk" class="robot" type="box" size="0.1335 0.097 0.057" rgba="0.8 0.55 0.1 1"/>
      <site name="imu" pos="0 0 0" size="0.01"/>{legs}
    </body>
  </worldbody>
  <actuator>
{actuators}
  </actuator>
</mujoco>
"""


def _per_leg(values: tuple[float, float, float]) -> np.ndarray:
    return np.array(values * len(LEGS), dtype=np.float64)


def _mirror_joints() -> np.ndarray:
    """Joint indices of the left-right mirror image: each leg swaps with the leg on the other
    side (FR <-> FL, RR <-> RL), joint by joint."""
    other = {leg: next(o for o in LEGS if _SIGN[o] == (_SIGN[leg][0], -_SIGN[leg][1])) for leg in LEGS}
    return np.array([3 * LEGS.index(other[leg]) + j for leg in LEGS for j in range(3)])


A1 = RobotSpec(
    name="a1",
    trunk_body="trunk",
    joint_names=tuple(f"{leg}_{j}_joint" for leg in LEGS for j in ("hip", "thigh", "calf")),
    foot_geoms=tuple(f"{leg}_foot" for leg in LEGS),
    collision_geoms=("trunk",) + tuple(f"{leg}_{p}" for leg in LEGS for p in ("hip", "thigh", "calf")),
    joint_low=_per_leg((_ABD_RANGE[0], _HIP_RANGE[0], _KNEE_RANGE[0])),
    joint_high=_per_leg((_ABD_RANGE[1], _HIP_RANGE[1], _KNEE_RANGE[1])),
    nominal_pose=_per_leg((0.0, 0.9, -1.8)),
    stand_pose=_per_leg((0.0, 0.6, -1.2)),
    # Feet under the hips with straighter legs: 2 × 0.2 m × cos 0.5 + 0.02 m = 0.37 m, 5 cm
    # above the goal bar (the knee's upper limit is −0.92 rad).
    tall_pose=_per_leg((0.0, 0.5, -1.0)),
    leg_length_m=0.4,
    leg_roots_m=np.array([(_HIP_X * _SIGN[leg][0], (_HIP_Y + _THIGH_Y) * _SIGN[leg][1], 0.0) for leg in LEGS]),
    # Hip axis to foot centre in the stand pose, 2 × 0.2 m × cos 0.6, plus the 0.02 m foot
    # radius: 0.35 m (it settles at 0.336 m under PD sag at Kp 50), 3 cm above the 0.32 m bar.
    stand_height_m=0.35,
    body_length_m=0.5,
    torque_limit=TORQUE_LIMIT,
    rated_joint_speed=RATED_SPEED,
    mjcf=a1_mjcf,
    # The abduction joint turns about x, so mirroring y flips its angle; hip and knee turn
    # about y and keep theirs. The model is mirror-symmetric up to the trunk's 4 mm COM offset
    # and its products of inertia (published values, kept).
    mirror_joints=_mirror_joints(),
    mirror_signs=_per_leg((-1.0, 1.0, 1.0)),
)
