"""Typed, frozen configuration for every part of selfright.

Every field carries its unit. Defaults are the benchmark's standard settings; change them
only deliberately, since results are comparable only under the same configuration (the
resolved configuration is written into every ``summary.json``).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any, Literal

BODY_LENGTH_M = 0.5
"""Unitree A1 overall length (m): the benchmark's unit for drop height and roughness bound."""

BENCHMARK_VERSION = 1
"""Version of the benchmark's definition (goal set, motor model, reward), recorded in every
result (``summary.json``, ``run.json``, ``train_meta.json``, model cards); results of different
versions are not comparable (docs/benchmark.md, *Benchmark versions*)."""


@dataclass(frozen=True, kw_only=True)
class TerrainConfig:
    """Geometry of one terrain tile (a heightfield)."""

    tile_size_m: float = 8.0
    """Side of the square heightfield (m). Large, so a rolling robot stays on it."""
    spawn_size_m: float = 2.0
    """Side of the central square in which robots are dropped (m); x, y ~ U(0.1, 0.9) of it."""
    resolution_m: float = 0.05
    """Grid spacing of the heightfield (m). Also sets N/A in the roughness metric R."""
    num_slope_levels: int = 11
    """Slope levels 0..10 = 0 %, 10 %, ..., 100 % grade."""
    slope_step_pct: float = 10.0
    """Grade added per slope level (%)."""
    num_roughness_levels: int = 20
    """Roughness levels 0..19; level 0 is a perfect plane."""
    max_roughness_extent_m: float = BODY_LENGTH_M
    """Peak-to-peak vertical extent of the noise at the top roughness level (m); never exceeded."""
    noise_wavelength_m: float = 0.5 * BODY_LENGTH_M
    """Spacing of the random lattice of the roughness noise (m): half a body length (seed §V)."""


@dataclass(frozen=True, kw_only=True)
class ContextConfig:
    """Physical factors of one evaluation context beyond the tile geometry."""

    friction: float = 1.0
    """Sliding friction coefficient between the robot and the ground (dimensionless)."""
    wall_gap_ratio: float | None = None
    """Confined space: distance between two side walls / body length; ``None`` = no walls."""
    ground_timeconst_s: float = 0.02
    """Ground compliance: MuJoCo contact ``solref`` time constant (s); 0.02 = rigid default."""
    ground_dampratio: float = 1.0
    """Ground compliance: MuJoCo contact ``solref`` damping ratio (dimensionless)."""


Motor = Literal["dcmotor", "ideal"]
"""Motor models of the PD servos (``RobotConfig.motor``)."""


@dataclass(frozen=True, kw_only=True)
class RobotConfig:
    """Actuation of the robot model."""

    name: str = "a1"
    """Robot spec name (see ``selfright.robots``)."""
    kp: float = 50.0
    """PD stiffness of every joint (N·m/rad)."""
    kd: float = 1.0
    """PD damping of every joint (N·m·s/rad)."""
    motor: Motor = "dcmotor"
    """Motor model of the PD servos, applied by the MuJoCo actuator (``selfright.robots.a1``).
    ``dcmotor``, the benchmark's default: MuJoCo's DC-motor actuator run as a current-controlled
    driver (``input="pos"``, torque-space PD gains ``kp``, ``kd``) whose drive voltage saturates:
    at joint speed ω it pushes along the motion with at most τ_s (1 − |ω|/ω₀) and brakes with at
    most τ_s (stall torque τ_s = 33.5 N·m, no-load speed ω₀ = the rated 21 rad/s on the A1), as
    on the real robot (docs/benchmark.md, *Motor models*). ``ideal``: MuJoCo position servos,
    full torque (±33.5 N·m) at any speed, for comparison."""
    motor_speed_rad_s: float | None = None
    """``dcmotor`` only: the speed (rad/s) at which the motors' torque reaches 0; None = the
    robot's rated speed (``RobotSpec.rated_joint_speed``). Faster than the real motors, it moves
    the model toward the ideal servos."""
    joint_stop_timeconst_s: float = 0.01
    """Stiffness of the joints' hard stops: MuJoCo's joint-limit ``solreflimit`` time constant
    (s); smaller = stiffer, at least 2 × ``SimConfig.timestep_s`` (MuJoCo's stable minimum).
    MuJoCo's default, 0.02 s, let a saturated motor hold a knee 0.28 rad past its stop and
    impacts drive joints up to 0.4 rad past theirs; at 0.01 s the same knee stays within
    0.02 rad (``tests/robots/test_model.py``; docs/benchmark.md, *Choices where the seed is vague*)."""


@dataclass(frozen=True, kw_only=True)
class SimConfig:
    """Physics stepping."""

    timestep_s: float = 0.005
    """Physics time step (s)."""
    control_substeps: int = 4
    """Physics steps per control step: 4 × 5 ms = 50 Hz control."""
    solver_iterations: int = 20
    """Newton solver iterations per physics step."""
    threads: int = 0
    """Worker threads of the batched CPU stepper; 0 = one per CPU core."""

    @property
    def control_dt_s(self) -> float:
        """Duration of one control step (s)."""
        return self.timestep_s * self.control_substeps


@dataclass(frozen=True, kw_only=True)
class ActionConfig:
    """How policy actions become PD joint targets: target = reference + scale · action,
    clipped to the joint range."""

    reference: Literal["stand", "current", "tall"] = "stand"
    """``stand``: the robot's standing pose (action 0 = stand, as in legged_gym-style
    controllers); ``current``: the joint angles at the start of the control step (MuJoCo
    Playground's Go1 get-up); ``tall``: a standing pose with straighter legs
    (``RobotSpec.tall_pose``). The seed does not say; ``flat`` and its teacher use ``stand``,
    the rough and incline lineages ``tall`` (docs/training.md, *Choices that are not in the seed*)."""
    scale_rad: float = 0.5
    """Radians of joint target per unit action."""
    clip: float = 10.0
    """Actions are clipped to ±clip before scaling (dimensionless)."""


@dataclass(frozen=True, kw_only=True)
class FallConfig:
    """The seed's fall protocol (§V)."""

    drop_height_m: float = BODY_LENGTH_M
    """Trunk origin starts this high above the highest ground near the spawn point (m)."""
    settle_s: float = 2.0
    """Passive settling time after the drop, before the policy starts (s)."""
    spawn_low: float = 0.1
    """Spawn x, y ~ U(spawn_low, spawn_high) in units of the spawn square's side."""
    spawn_high: float = 0.9
    """See ``spawn_low``."""
    max_joint_tries: int = 1000
    """Rejection-sampling attempts for a self-collision-free joint configuration."""


@dataclass(frozen=True, kw_only=True)
class GoalConfig:
    """The goal set (seed §IV) and the success rule."""

    max_tilt_deg: float = 30.0
    """Roll and pitch must each be within this of gravity (deg)."""
    height_fraction: float = 0.8
    """Body height ≥ this × fully extended leg length (``height_ref`` says which height)."""
    height_ref: Literal["feet", "terrain"] = "feet"
    """What the body height is measured from, along gravity. ``feet``: the trunk origin above the
    mean of the four feet's lowest points (foot centre minus radius), the height the legs produce
    (the benchmark's definition). ``terrain``: the trunk origin above the ground beneath it, for
    comparison only (it credits crouches on slopes and over hollows)."""
    hold_s: float = 1.0
    """Success needs the goal set held continuously this long (s)."""
    episode_s: float = 10.0
    """Episode limit after settling (s)."""


@dataclass(frozen=True, kw_only=True)
class EvalConfig:
    """Grid evaluation."""

    batch_size: int = 64
    """Episodes simulated side by side in one batch."""
    friction: float = 1.0
    """Ground friction of every cell (dimensionless)."""
    wall_gap_ratio: float | None = None
    """Side walls at this gap / body length in every cell; ``None`` = open terrain."""
    ground_timeconst_s: float = 0.02
    """Ground contact time constant of every cell (s)."""
    sensor_noise: float = 0.0
    """Additive Gaussian noise on what every policy senses, as a multiple of
    ``selfright.env.observations.SENSOR_NOISE_STD`` (``selfright.policies.sensor_noise``); 0 =
    exact sensors, the benchmark's default."""


@dataclass(frozen=True, kw_only=True)
class BenchmarkConfig:
    """Everything that defines a benchmark run (written resolved into summary.json)."""

    terrain: TerrainConfig = field(default_factory=TerrainConfig)
    robot: RobotConfig = field(default_factory=RobotConfig)
    sim: SimConfig = field(default_factory=SimConfig)
    action: ActionConfig = field(default_factory=ActionConfig)
    fall: FallConfig = field(default_factory=FallConfig)
    goal: GoalConfig = field(default_factory=GoalConfig)
    eval: EvalConfig = field(default_factory=EvalConfig)


def to_dict(cfg: Any) -> dict[str, Any]:
    """Resolved configuration as plain JSON-serialisable data."""
    return dataclasses.asdict(cfg)
