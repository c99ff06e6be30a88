"""Evaluate variants of learned policies that do not ship: a policy that samples its actions
from its own training noise instead of acting with the mean, an ensemble acting with the
mean of its members' actions, one whose hip actions go to 0 once upright, one that
blends its actions to a fixed stance once upright, or a policy that hands over to a second one when it stalls or
while it is tilted over.
Writes an ordinary ``selfright evaluate`` results folder, so ``scripts/seed_table.py`` and
``scripts/failure_overlap.py`` read it.

    python scripts/policy_variants.py --policies runs/flat_teacher/model_3445.pt --noise-scale 0.5 \\
        --grid flat --seed 4 --out results/flat_teacher_noisy_s4
    python scripts/policy_variants.py --policies incline --noise-std 1e-6 --noise-stream 1 --grid incline \\
        --seed 4 --out results/incline_nudged_s4
    python scripts/policy_variants.py --policies incline --sensor-noise 1 --grid incline \\
        --seed 4 --out results/incline_noisy_sensors_s4
    python scripts/policy_variants.py --policies runs/A/model_1.pt runs/B/model_2.pt --grid flat \\
        --seed 4 --out results/ensemble_s4
    python scripts/policy_variants.py --policies runs/A/model_1.pt runs/B/model_2.pt --fallback-s 9 \\
        --grid flat --seed 4 --out results/fallback_s4
    python scripts/policy_variants.py --policies runs/A/model_1.pt runs/B/model_2.pt --tilt-deg 45 \\
        --grid flat --seed 4 --out results/tilt45_s4
    python scripts/policy_variants.py --policies rough --zero-hips-upright-s 2 --grid rough \\
        --seed 4 --out results/rough_hips0_s4
    python scripts/policy_variants.py --policies rough --pose-upright-s 1 --pose-upright-delay-s 2 \\
        --grid rough --seed 4 --out results/rough_pose_s4
    python scripts/policy_variants.py --policies incline --pose-upright-s 0.5 --pose-upright-delay-s 0.3 \\
        --pose-upright-weight 0.3 --pose-upright-level --zero-hips-tilt-deg 35 --grid incline --seed 4 \\
        --out results/incline_level_s4
    python scripts/policy_variants.py --policies incline --side-mirror 1 --grid incline \\
        --seed 20 --out results/incline_side_s20
    python scripts/policy_variants.py --policies incline --brake-pose 0 0.46 0.46 -0.92 --grid incline \\
        --seed 4 --out results/incline_brake_s4
    python scripts/policy_variants.py --policies rough --latch-upright-s 0.5 --grid rough \\
        --seed 4 --out results/rough_latched_s4
    python scripts/policy_variants.py --policies incline-dc --envelope-speed-rad-s 15 --grid incline \\
        --seed 4 --out results/incline_dc_v15_s4

The noise is the checkpoint's Gaussian std (rsl_rl ``distribution.std_param``) times
``--noise-scale`` (or ``--noise-std`` for any policy), drawn from a generator seeded per episode, so results do not depend on
batching.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import torch
import tyro

from selfright.config import BenchmarkConfig
from selfright.env.goal import goal_height_m
from selfright.evaluate.runner import evaluate_grid
from selfright.policies.base import Policy
from selfright.policies.level_stance import LevelStance, LevelStanceTarget
from selfright.policies.pose_blend import LeanedPose, lean_gains, splayed_action, stance_action
from selfright.policies.registry import _make_policy, check_action_mapping, make_policy
from selfright.policies.sensor_noise import NoisySensors
from selfright.policies.stall import ScanSwitch, hand_over_rule
from selfright.policies.variants import (
    Blinded, Braked, EstimatedVelocity, Fallback, Latched, MeanOf, PoseUpright, Noisy, SideMirrored, Smoothed,
    trained_std,
)
from selfright.robots import get_robot


@dataclass(frozen=True)
class Args:
    policies: tuple[str, ...]
    """One policy (with ``--noise-scale``), or several to average: any ``--policy`` value."""
    out: Path
    """Results folder."""
    grid: str = "flat"
    episodes: int = 64
    seed: int = 0
    noise_scale: float = 0.0
    """Action noise as a multiple of the checkpoint's trained std (0 = the mean action)."""
    noise_std: float = 0.0
    """Action noise of this std (action units), for any one policy; tiny values (1e-6) ask how
    many outcomes hang on a rounding-sized nudge (docs/training.md, forty-fifth session)."""
    sensor_noise: float = 0.0
    """Read the sensors with additive Gaussian noise of this many ``SENSOR_NOISE_STD`` (IMU 0.05 /
    0.2 rad/s, joints 0.01 rad / 1.5 rad/s at 1; ``selfright.policies.sensor_noise.NoisySensors``), for
    any policy or variant: how a policy trained on exact sensors fares on real ones. 0 = exact."""
    noise_stream: int = 0
    """Which of independent noise sequences ``--noise-scale`` / ``--noise-std`` / ``--sensor-noise``
    draw (0 = the original one); other values give further draws on the same falls."""
    fallback_s: float = 0.0
    """With two policies: the second takes over for this long (s) whenever the first has
    stalled, tilted over, for ``stall_s`` (``selfright.policies.variants.Fallback``); 0 = average them."""
    stall_s: float = 0.5
    """How long the first policy must have lain still before the second takes over (s)."""
    tilt_deg: float = 0.0
    """With two policies: the second acts whenever the robot is tilted more than this from
    upright, the first otherwise (``selfright.policies.stall.TiltSwitch``); 0 = off."""
    release_deg: float | None = None
    """With ``tilt_deg``: hysteresis. Once upright within ``tilt_deg``, the first policy keeps
    acting until the tilt passes this (deg)."""
    scan_std_m: float = 0.0
    """With ``tilt_deg`` and three policies: the first two share the upright states, the second
    where the teacher's height scan spreads over this (m; rough ground,
    ``selfright.policies.stall.ScanSwitch``); the third acts while tilted. 0 = off."""
    blind_first: tuple[str, ...] = ()
    """Privileged blocks hidden from the first policy (a teacher): ``velocity`` (read as 0),
    ``friction`` (1.0), ``factors`` (1.0), ``scan`` (every point at the trunk's height above the
    ground beneath it: a flat ground); ``selfright.policies.variants.Blinded``."""
    estimate_first: str | None = None
    """A student policy file, checkpoint or run folder with a velocity estimator: the first policy (a
    teacher with the same action mapping) reads the estimate from the student's observation
    history instead of its true trunk velocity (``selfright.policies.variants.EstimatedVelocity``)."""
    feed_both: bool = False
    """With two policies: the second sees every step, not only those it acts in (needed when
    it reads a history of observations: a student)."""
    stall_below_bar: bool = False
    """Also hand over when the robot stands or sits still upright with its trunk under the
    goal bar (read from the privileged teacher observation)."""
    smooth: float = 0.0
    """Low-pass actions per episode: a_t = β a_(t−1) + (1 − β) π(o_t) with this β
    (``selfright.policies.variants.Smoothed``); 0 = off."""
    zero_hips_upright_s: float = 0.0
    """Ramp the hip abduction actions to 0 over this long (s) once the trunk is upright within
    ``zero_hips_tilt_deg`` (``selfright.policies.variants.PoseUpright`` on the hips); 0 = off."""
    zero_hips_tilt_deg: float = 15.0
    """With ``zero_hips_upright_s`` or ``pose_upright_s``: how upright counts as upright (deg)."""
    pose_upright_s: float = 0.0
    """Blend all actions, over this long (s), to the fixed stance ``pose_upright`` once the
    trunk has been upright within ``zero_hips_tilt_deg`` for ``pose_upright_delay_s``
    (``selfright.policies.variants.PoseUpright``); 0 = off."""
    pose_upright_delay_s: float = 0.0
    """With ``pose_upright_s``: how long the trunk must have been upright before the blend starts (s)."""
    pose_upright_weight: float = 1.0
    """With ``pose_upright_s`` or ``zero_hips_upright_s``: how far the blend goes, in (0, 1]: 1 =
    all the way to the stance, 0.3 = the policy's action moved 30 % of the way there (its own
    corrections kept)."""
    pose_upright_joints: tuple[str, ...] = ("hip", "thigh", "calf")
    """With ``pose_upright_s``: which joints of each leg blend (``hip``, ``thigh``, ``calf``); the
    others keep the policy's action."""
    pose_upright_lean: tuple[float, float] = (0.0, 0.0)
    """With ``pose_upright_s``: lean the stance's legs towards gravity, read from the IMU each
    step (``selfright.policies.pose_blend.gravity_lean``): the hips turn by the first gain times
    the trunk's roll, the thighs by the second times its pitch. ``0 1`` puts the feet under the
    hips in the world fore and aft (on the 20° slope a held stance then stands facing up or down
    it, where a square one tips: ``python scripts/slope_stance.py --lean 0 1``); 0 0 = a fixed stance."""
    pose_upright_level: bool = False
    """With ``pose_upright_s``: blend to the level stance ``pose_upright_level_law`` (leg
    lengths and lean from the IMU's gravity each step; ``selfright.policies.level_stance``)
    instead of ``pose_upright``."""
    pose_upright_level_law: LevelStance = LevelStance()
    pose_upright: tuple[float, float, float] = (0.0, 0.46, -0.92)
    """With ``pose_upright_s``: the stance's hip, thigh and knee angles (rad), the same on
    every leg. The default has the knee at its limit and the foot under the hip: 0.38 m from
    hip axis to ground."""
    side_mirror: int = 0
    """+1 or -1: act in the mirror image of the world unless the projected gravity's body y
    component has this sign when control starts, so that the ground falls away to the same
    side of the trunk in every episode (``selfright.policies.variants.SideMirrored``); 0 = off."""
    brake_pose: tuple[float, float, float, float] | None = None
    """Hip abduction away from the body, front thigh, rear thigh and knee angles (rad) that a
    robot tumbling over again after getting up holds until it lies still
    (``selfright.policies.variants.Braked``): e.g. ``0 0.46 0.46 -0.92`` (the tall stance) or
    ``0.8 -1.0 1.5 -0.92`` (legs splayed out, fore and aft); None = off."""
    brake_tilt_deg: float = 60.0
    """With ``brake_pose``: the tilt past which a robot that has been upright within 45° brakes (deg)."""
    brake_spin_rps: float = 0.0
    """With ``brake_pose``: brake only while the trunk turns faster than this (rad/s)."""
    brake_release_rps: float = 1.0
    """With ``brake_pose``: the brake ends after 0.2 s under this angular speed (rad/s), or after 2 s."""
    latch_upright_s: float = 0.0
    """Once the trunk has been upright within ``latch_tilt_deg`` and turning slower than
    ``latch_still_rps`` for this long (s), keep the action of that moment until it tilts past
    ``latch_release_deg`` (``selfright.policies.variants.Latched``); 0 = off."""
    latch_tilt_deg: float = 20.0
    """With ``latch_upright_s``: how upright counts as upright (deg)."""
    latch_still_rps: float = 0.5
    """With ``latch_upright_s``: how slowly the trunk must turn to count as still (rad/s)."""
    latch_release_deg: float = 45.0
    """With ``latch_upright_s``: the tilt past which the policy acts again (deg)."""
    latch_hold_s: float | None = None
    """With ``latch_upright_s``: release the latch after this long (s) even if the trunk stays
    upright, so the policy moves on and may latch again elsewhere; None = hold until it tilts."""
    envelope_speed_rad_s: float | None = None
    """Hold every policy to the DC torque-speed envelope of motors with this no-load speed (rad/s)
    on the ideal servos (``selfright.policies.torque_envelope``), instead of a DC-trained policy's
    own training speed; None = as ``selfright evaluate``."""
    threads: int = 0
    """Physics worker threads; 0 = one per CPU core."""
    smooth_last: bool = False
    """With ``smooth``: low-pass only the last policy of a composite (the tilted one: the escape),
    which then sees every step (``feed_both``) so its filter runs on between hand-overs; off =
    low-pass the composite's actions."""


def stance_target(a: Args, robot, cfg: BenchmarkConfig, cols: list[int]):
    """The stance ``--pose-upright-s`` blends to: fixed, leaning or level."""
    if a.pose_upright_level:
        return LevelStanceTarget(a.pose_upright_level_law, robot, cfg.action, cols)
    fixed = stance_action(robot, cfg.action, a.pose_upright)[cols]
    gains = lean_gains(robot, a.pose_upright_lean, cols, cfg.action.scale_rad)
    return fixed if gains is None else LeanedPose(fixed, gains)


def stance_label(a: Args) -> str:
    if a.pose_upright_level:
        law = a.pose_upright_level_law
        return (f"level stance (leg {law.leg_m:g} m, roll level {law.roll_level:g}, pitch lean {law.pitch_lean:g}, "
                f"pitch level {law.pitch_level:g})")
    return f"stance {a.pose_upright}" + (f" leaning {a.pose_upright_lean}" if any(a.pose_upright_lean) else "")


def make_variant(a: Args, cfg: BenchmarkConfig) -> Policy:
    if a.smooth_last and not (a.smooth > 0 and (a.tilt_deg > 0 or a.fallback_s > 0)):
        raise ValueError("--smooth-last takes --smooth and a composite (--tilt-deg or --fallback-s)")
    if a.zero_hips_upright_s > 0 and a.pose_upright_s > 0:
        raise ValueError("give --zero-hips-upright-s or --pose-upright-s, not both")
    policy = _make_variant(a, cfg)
    robot, dt = get_robot(cfg.robot.name), cfg.sim.control_dt_s
    if a.zero_hips_upright_s > 0:
        hips = [i for i, n in enumerate(robot.joint_names) if "hip" in n]
        policy = PoseUpright(policy, a.zero_hips_tilt_deg, max(1, round(a.zero_hips_upright_s / dt)), hips,
                             weight=a.pose_upright_weight)
    if a.pose_upright_s > 0:
        cols = [i for i, n in enumerate(robot.joint_names) if n.split("_")[1] in a.pose_upright_joints]
        if not cols:
            raise ValueError(f"--pose-upright-joints {a.pose_upright_joints} names none of hip, thigh, calf")
        policy = PoseUpright(policy, a.zero_hips_tilt_deg, max(1, round(a.pose_upright_s / dt)), cols,
                             stance_target(a, robot, cfg, cols), round(a.pose_upright_delay_s / dt),
                             label=stance_label(a), weight=a.pose_upright_weight)
    if a.brake_pose is not None:
        policy = Braked(policy, splayed_action(robot, cfg.action, *a.brake_pose),
                        tilt_deg=a.brake_tilt_deg, spin_rps=a.brake_spin_rps, release_rps=a.brake_release_rps,
                        calm_steps=max(1, round(0.2 / dt)), max_steps=max(1, round(2.0 / dt)))
    if a.latch_upright_s > 0:
        if cfg.action.reference == "current":
            raise ValueError("--latch-upright-s holds actions, which move the targets under ActionConfig.reference 'current'")
        policy = Latched(policy, max(1, round(a.latch_upright_s / dt)), a.latch_tilt_deg, a.latch_still_rps,
                         a.latch_release_deg,
                         None if a.latch_hold_s is None else max(1, round(a.latch_hold_s / dt)))
    if a.side_mirror:
        policy = SideMirrored(policy, a.side_mirror, cfg.robot.name)
    policy = Smoothed(policy, a.smooth) if a.smooth > 0 and not a.smooth_last else policy
    return NoisySensors(policy, a.sensor_noise, robot.num_joints, a.noise_stream) if a.sensor_noise > 0 else policy


def _make_variant(a: Args, cfg: BenchmarkConfig) -> Policy:
    if not a.policies:
        raise ValueError("give --policies")
    if a.noise_scale > 0 and a.noise_std > 0:
        raise ValueError("give --noise-scale or --noise-std, not both")
    if a.noise_scale > 0 or a.noise_std > 0:
        if len(a.policies) != 1:
            raise ValueError("--noise-scale and --noise-std take one policy")
        member = load_member(a, a.policies[0], cfg)
        std = a.noise_scale * trained_std(a.policies[0]) if a.noise_scale > 0 else torch.tensor(a.noise_std)
        return Noisy(member, std, a.noise_stream)
    members = [load_member(a, p, cfg) for p in a.policies]
    if a.blind_first:
        members[0] = Blinded(members[0], a.blind_first)
    if a.estimate_first:
        members[0] = estimated_first(a.policies[0], a.estimate_first, cfg)
    if a.fallback_s > 0 and a.tilt_deg > 0:
        raise ValueError("give --fallback-s or --tilt-deg, not both")
    if a.scan_std_m > 0:
        if a.tilt_deg <= 0 or len(members) != 3:
            raise ValueError("--scan-std-m takes three policies and --tilt-deg")
        members = [Fallback(members[0], members[1], ScanSwitch(a.scan_std_m)), members[2]]
    if (a.fallback_s > 0 or a.tilt_deg > 0) and len(members) != 2:
        raise ValueError("--fallback-s and --tilt-deg take two policies (three with --scan-std-m)")
    if a.fallback_s > 0 or a.tilt_deg > 0:
        bar = goal_height_m(cfg.goal, get_robot(cfg.robot.name).leg_length_m) if a.stall_below_bar else None
        rule = hand_over_rule(a.tilt_deg, a.stall_s, a.fallback_s, cfg.sim.control_dt_s, bar, release_deg=a.release_deg)
        if a.smooth_last:
            members[-1] = Smoothed(members[-1], a.smooth)
        return Fallback(*members, rule, feed_both=a.feed_both or a.smooth_last)
    return members[0] if len(members) == 1 else MeanOf(members)


def load_member(a: Args, name: str, cfg: BenchmarkConfig) -> Policy:
    """Policy ``name`` as ``selfright evaluate`` runs it, or with ``--envelope-speed-rad-s`` held
    to the DC envelope of that speed whatever motor it trained with."""
    if a.envelope_speed_rad_s is None:
        return make_policy(name, cfg)
    from selfright.policies.torque_envelope import TorqueEnvelope

    motor = replace(cfg.robot, motor_speed_rad_s=a.envelope_speed_rad_s)
    return TorqueEnvelope(make_policy(name, cfg, envelope=False), get_robot(cfg.robot.name), cfg.action, motor)


def estimated_first(teacher: str, student: str, cfg: BenchmarkConfig) -> Policy:
    """``teacher`` reading ``student``'s velocity estimate, then converted to the env's action
    mapping as a whole (so the student's history sees the previous action in its own units)."""
    from selfright.policies.actor import load_actor_file
    from selfright.train.commands import load_checkpoint_actor

    try:  # a policy file (selfright export), else a training checkpoint or run folder
        actor = load_actor_file(student)
    except (ValueError, OSError, RuntimeError):
        actor, _ = load_checkpoint_actor(Path(student))
    raw = _make_policy(teacher, cfg)
    own = (raw.action_mapping or ("stand",))[0]
    if (actor.meta.action_reference or "stand") != own:
        raise ValueError(f"--estimate-first {student} was trained around {actor.meta.action_reference!r}, the teacher around {own!r}")
    return check_action_mapping(EstimatedVelocity(raw, actor), cfg.action, teacher, cfg.robot.name)


def main(a: Args) -> None:
    cfg = BenchmarkConfig()
    cfg = replace(cfg, sim=replace(cfg.sim, threads=a.threads))
    try:
        policy = make_variant(a, cfg)
    except ValueError as e:
        raise SystemExit(f"policy_variants: {e}") from None
    if a.tilt_deg > 0 and a.scan_std_m > 0:
        joined = (f"{a.policies[0]} then (scan spread over {a.scan_std_m:g} m) {a.policies[1]} then "
                  f"(tilted over {a.tilt_deg:g} deg) {a.policies[2]}")
    elif a.tilt_deg > 0:
        joined = f" then (tilted over {a.tilt_deg:g} deg) ".join(a.policies)
    elif a.fallback_s > 0:
        joined = f" then (stalled {a.stall_s:g} s, for {a.fallback_s:g} s) ".join(a.policies)
    else:
        joined = " + ".join(a.policies)
    name = joined + (f" (noise x{a.noise_scale:g})" if a.noise_scale > 0 else "")
    name += f" (noise std {a.noise_std:g})" if a.noise_std > 0 else ""
    name += f" (sensor noise x{a.sensor_noise:g})" if a.sensor_noise > 0 else ""
    name += (f" (noise stream {a.noise_stream})"
             if a.noise_stream and (a.noise_scale > 0 or a.noise_std > 0 or a.sensor_noise > 0) else "")
    name += f" (first blind to {', '.join(a.blind_first)})" if a.blind_first else ""
    name += f" (first reads {a.estimate_first}'s velocity estimate)" if a.estimate_first else ""
    name += f" ({'last ' if a.smooth_last else ''}low-passed, beta {a.smooth:g})" if a.smooth > 0 else ""
    name += (f" (hips to 0 over {a.zero_hips_upright_s:g} s once upright within {a.zero_hips_tilt_deg:g} deg)"
             if a.zero_hips_upright_s > 0 else "")
    name += f" ({a.pose_upright_weight:g} of the way)" if a.pose_upright_weight != 1.0 else ""
    name += (f" ({stance_label(a)} over {a.pose_upright_s:g} s once upright within {a.zero_hips_tilt_deg:g} deg"
             f" for {a.pose_upright_delay_s:g} s)" if a.pose_upright_s > 0 else "")
    name += (f" (braked to {a.brake_pose} past {a.brake_tilt_deg:g} deg after upright)"
             if a.brake_pose is not None else "")
    name += (f" (latched after {a.latch_upright_s:g} s upright within {a.latch_tilt_deg:g} deg under "
             f"{a.latch_still_rps:g} rad/s, released past {a.latch_release_deg:g} deg"
             + (f" or after {a.latch_hold_s:g} s)" if a.latch_hold_s is not None else ")") if a.latch_upright_s > 0 else "")
    name += f" (mirrored unless gravity's body y is {a.side_mirror:+d} at the start)" if a.side_mirror else ""
    name += f" (DC envelope at {a.envelope_speed_rad_s:g} rad/s)" if a.envelope_speed_rad_s is not None else ""
    res = evaluate_grid(policy, policy_name=name, grid=a.grid, episodes=a.episodes, seed=a.seed,
                        out_dir=a.out, cfg=cfg, progress=True)
    o = res.summary["overall"]
    print(f"{name} on {a.grid} [seed {a.seed}]: {o['success_rate']:.1%} of {o['n']}")


if __name__ == "__main__":
    main(tyro.cli(Args))
