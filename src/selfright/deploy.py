"""Running an exported student outside selfright: its input/output contract, and a reference
control loop that needs only numpy and onnxruntime.

``selfright export`` writes the contract (``DeploymentSpec``) into the ONNX file's metadata under
``deployment`` (JSON); ``python -m selfright.deploy policy.onnx`` prints it. One control step at
``control_hz``, for one robot:

1. Read the IMU (orientation, body-frame angular velocity) and the joint encoders (angles, speeds,
   in ``joint_names`` order).
2. Build one observation frame, ``obs_columns`` in order: the gravity direction in the trunk frame
   (a unit vector, (0, 0, −1) when upright), the angular velocity (rad/s), the joint angles minus
   ``nominal_pose_rad``, the joint speeds × ``joint_vel_scale``, and the previous action (the
   network's own last output clipped to ±``action_clip``; zeros on the first step).
3. With ``obs_history`` H > 1 the network reads the last H frames, oldest first; at the start
   every slot holds the first frame.
4. Run the network: ``actions`` (1, J) from ``obs`` (1, H · frame).
5. Joint targets = reference pose (``action_reference_pose_rad``, or the angles read in step 1
   for ``current``) + ``action_scale_rad`` × clip(action, ±``action_clip``), clipped to the joint
   range.
6. Send the targets to PD servos with gains ``kp``, ``kd`` (torque = kp (q* − q) − kd q̇, at most
   ``torque_limit_nm``), held for one control period. A policy trained with DC motors
   (``motor_speed_rad_s`` set) expects the motors' own torque-speed limit: along the motion at
   most ``torque_limit_nm`` (1 − |q̇| / ``motor_speed_rad_s``). A real A1's motors have it by
   themselves; nothing in this loop applies it.

``OnnxController`` is that loop; ``tests/test_deploy.py`` checks that it commands the same joint
targets as ``selfright evaluate`` does on the same sensor readings.
"""

from __future__ import annotations

import json
import sys
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

DEPLOY_KEY = "deployment"
"""Key of the ``DeploymentSpec`` (JSON) in an exported ONNX file's metadata."""


@dataclass(frozen=True)
class DeploymentSpec:
    """What a robot must feed an exported student, and what to do with its output."""

    robot: str
    """Robot spec name (``selfright.robots``)."""
    joint_names: tuple[str, ...]
    """Order of every per-joint quantity: angles, speeds, actions, targets."""
    control_hz: float
    """Control rate: one network step per period, targets held in between."""
    kp: float
    """PD stiffness of every joint servo (N·m/rad)."""
    kd: float
    """PD damping of every joint servo (N·m·s/rad)."""
    torque_limit_nm: float
    """Servo torque limit (N·m)."""
    joint_low_rad: tuple[float, ...]
    """Lower joint limits; targets are clipped to them."""
    joint_high_rad: tuple[float, ...]
    """Upper joint limits."""
    nominal_pose_rad: tuple[float, ...]
    """Subtracted from the joint angles in the observation."""
    action_reference: str
    """``stand`` / ``tall`` (a fixed pose, ``action_reference_pose_rad``) or ``current`` (the
    joint angles at the start of the step)."""
    action_reference_pose_rad: tuple[float, ...] | None
    """The fixed reference pose; None for ``current``."""
    action_scale_rad: float
    """Radians of joint target per unit action."""
    action_clip: float
    """Actions are clipped to ±this before use (and as the previous action observed)."""
    joint_vel_scale: float
    """Joint speeds are multiplied by this in the observation."""
    obs_history: int
    """Frames the network reads, oldest first."""
    obs_columns: tuple[str, ...]
    """The columns of one frame."""
    motor: str
    """Motor model it trained with (``RobotConfig.motor``: ``dcmotor`` or ``ideal``; ``ideal`` if
    not recorded)."""
    motor_speed_rad_s: float | None
    """Trained with DC motors: their no-load speed (rad/s), at which the torque along the motion
    reaches 0; None: ideal servos."""

    def to_json(self) -> str:
        return json.dumps(asdict(self))

    @staticmethod
    def from_json(text: str) -> DeploymentSpec:
        d = json.loads(text)
        if "envelope_speed_rad_s" in d:  # the same no-load speed under its other recorded name
            d["motor_speed_rad_s"] = d.pop("envelope_speed_rad_s")
            d["motor"] = "dcmotor" if d["motor_speed_rad_s"] is not None else "ideal"
        if d.pop("gru_dim", 0):
            raise ValueError("this deployment contract is for a recurrent network; only feed-forward ones are supported")
        tuples = ("joint_names", "joint_low_rad", "joint_high_rad", "nominal_pose_rad", "obs_columns")
        d.update({k: tuple(d[k]) for k in tuples})
        if d["action_reference_pose_rad"] is not None:
            d["action_reference_pose_rad"] = tuple(d["action_reference_pose_rad"])
        return DeploymentSpec(**d)


def obs_columns(joint_names: tuple[str, ...]) -> tuple[str, ...]:
    """Names of the ``student`` observation's columns (``selfright.env.observations.student_obs``)."""
    return (*(f"gravity_{a}" for a in "xyz"), *(f"gyro_{a}" for a in "xyz"),
            *(f"angle-nominal:{j}" for j in joint_names), *(f"speed*scale:{j}" for j in joint_names),
            *(f"prev_action:{j}" for j in joint_names))


def deployment_spec(meta: Any, robot_cfg: Any = None, action_cfg: Any = None, sim_cfg: Any = None) -> DeploymentSpec:
    """The contract of an actor (``ActorMeta``) trained on the benchmark's robot, servos and
    control rate (``RobotConfig``, ``ActionConfig``, ``SimConfig``; defaults: the benchmark's).
    ``ValueError`` for a teacher, whose privileged observations no robot senses."""
    from selfright.config import ActionConfig, RobotConfig, SimConfig
    from selfright.env.observations import JOINT_VEL_SCALE
    from selfright.robots import get_robot

    if meta.obs_group != "student":
        raise ValueError(f"this actor reads the {meta.obs_group!r} observations (privileged simulator state); "
                         "deploy a student")
    robot_cfg, action_cfg, sim_cfg = robot_cfg or RobotConfig(), action_cfg or ActionConfig(), sim_cfg or SimConfig()
    robot = get_robot(robot_cfg.name)
    reference = meta.action_reference or action_cfg.reference
    pose = robot.reference_pose(reference)
    # Files recording "envelope" trained against the same DC-motor limit, applied to their targets.
    motor = "dcmotor" if meta.motor in ("dcmotor", "envelope") else "ideal"
    speed = float(meta.motor_speed_rad_s or robot.rated_joint_speed) if motor == "dcmotor" else None
    return DeploymentSpec(
        robot=robot.name,
        joint_names=tuple(robot.joint_names),
        control_hz=1.0 / sim_cfg.control_dt_s,
        kp=robot_cfg.kp,
        kd=robot_cfg.kd,
        torque_limit_nm=float(robot.torque_limit),
        joint_low_rad=_floats(robot.joint_low),
        joint_high_rad=_floats(robot.joint_high),
        nominal_pose_rad=_floats(robot.nominal_pose),
        action_reference=reference,
        action_reference_pose_rad=None if pose is None else _floats(pose),
        action_scale_rad=meta.action_scale_rad or action_cfg.scale_rad,
        action_clip=action_cfg.clip,
        joint_vel_scale=JOINT_VEL_SCALE,
        obs_history=meta.obs_history,
        obs_columns=obs_columns(tuple(robot.joint_names)),
        motor=motor,
        motor_speed_rad_s=speed,
    )


def spec_from_metadata(props: dict[str, str], where: str = "this ONNX file") -> DeploymentSpec:
    """The ``DeploymentSpec`` in an exported ONNX file's metadata (onnxruntime's
    ``custom_metadata_map``); ``ValueError`` if it has none."""
    if DEPLOY_KEY not in props:
        raise ValueError(f"{where} carries no deployment contract (a teacher, or exported before "
                         "2026-12-06); export the student again with `selfright export`")
    return DeploymentSpec.from_json(json.loads(props[DEPLOY_KEY]))


def _floats(a: Any) -> tuple[float, ...]:
    return tuple(float(x) for x in a)


def read_spec(onnx_path: str | Path) -> DeploymentSpec:
    """The ``DeploymentSpec`` an exported ONNX file carries (``ValueError`` if it has none)."""
    return spec_from_metadata(_session(onnx_path).get_modelmeta().custom_metadata_map, str(onnx_path))


def _session(onnx_path: str | Path) -> Any:
    import onnxruntime as ort

    if not Path(onnx_path).is_file():
        raise ValueError(f"{onnx_path} not found")
    return ort.InferenceSession(str(onnx_path), providers=["CPUExecutionProvider"])


def gravity_in_body(quat_wxyz: np.ndarray) -> np.ndarray:
    """(3,) the unit gravity direction in the trunk frame of orientation ``quat_wxyz`` (body to world)."""
    w, x, y, z = np.asarray(quat_wxyz, dtype=np.float64) / np.linalg.norm(quat_wxyz)
    # The world z axis in body coordinates is the third row of R(q); gravity points along −z.
    return -np.array([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)])


class OnnxController:
    """The control loop of the module docstring for one robot, around an exported ONNX student.

    Args:
        onnx_path: a ``selfright export`` ONNX file (it carries its ``DeploymentSpec``).
    """

    def __init__(self, onnx_path: str | Path):
        self.session = _session(onnx_path)
        self.spec = spec = spec_from_metadata(self.session.get_modelmeta().custom_metadata_map, str(onnx_path))
        self._nominal = np.asarray(spec.nominal_pose_rad)
        self._low, self._high = np.asarray(spec.joint_low_rad), np.asarray(spec.joint_high_rad)
        self._ref = None if spec.action_reference_pose_rad is None else np.asarray(spec.action_reference_pose_rad)
        self.reset()

    def reset(self) -> None:
        """Start a new episode: no previous action, an empty history."""
        J = len(self.spec.joint_names)
        self.prev_action = np.zeros(J, dtype=np.float32)
        self.frames: list[np.ndarray] = []

    def frame(self, quat_wxyz: np.ndarray, gyro: np.ndarray, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """One observation frame (``spec.obs_columns``) from the raw readings."""
        s = self.spec
        parts = (gravity_in_body(quat_wxyz), gyro, np.asarray(q) - self._nominal, np.asarray(qd) * s.joint_vel_scale,
                 self.prev_action)
        return np.concatenate([np.asarray(p, dtype=np.float64) for p in parts]).astype(np.float32)

    def step(self, quat_wxyz: np.ndarray, gyro: np.ndarray, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """(J,) joint targets (rad) for this control period from the trunk orientation (w, x, y, z,
        body to world), its body-frame angular velocity (rad/s), and the joint angles (rad) and
        speeds (rad/s)."""
        s = self.spec
        f = self.frame(quat_wxyz, gyro, q, qd)
        self.frames = (self.frames or [f] * s.obs_history)[1:] + [f]
        out = self.session.run(None, {"obs": np.concatenate(self.frames)[None]})
        action = np.clip(out[0][0], -s.action_clip, s.action_clip)
        self.prev_action = action.astype(np.float32)
        ref = np.asarray(q, dtype=np.float64) if self._ref is None else self._ref
        return np.clip(ref + s.action_scale_rad * action, self._low, self._high)


def main(argv: list[str] | None = None) -> int:
    """``python -m selfright.deploy POLICY.onnx``: print the file's deployment contract as JSON."""
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 1:
        print("usage: python -m selfright.deploy POLICY.onnx", file=sys.stderr)
        return 2
    try:
        spec = read_spec(args[0])
    except (ValueError, OSError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    print(json.dumps(asdict(spec), indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
