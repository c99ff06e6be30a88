"""``selfright train`` and ``selfright export``: argument dataclasses (tyro subcommands) and
the functions that run them.

Also runnable on its own: ``python -m selfright.train.commands train --role teacher ...``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Literal

from selfright.config import ActionConfig, BenchmarkConfig, Motor, RobotConfig
from selfright.train.config import Context, Role, TrainConfig

if TYPE_CHECKING:
    from selfright.policies.actor import ActorMLP


@dataclass(frozen=True, kw_only=True)
class TrainArgs:
    """Train a teacher (PPO, privileged observations) or distil a student from a teacher."""

    out: Path
    """Run folder: checkpoints, tensorboard logs, train_meta.json."""
    role: Role = "teacher"
    """teacher: PPO on the teacher observations; student: distillation from --teacher."""
    context: Context = "flat"
    """Training context: flat plane, rough level ground, or 20° incline."""
    teacher: Path | None = None
    """Needed with ``--role student``: a teacher run folder (its latest checkpoint) or a teacher
    checkpoint file (a student's is refused)."""
    envs: int = 64
    """Parallel environments (64–256 suit a few CPU cores)."""
    iterations: int = 10_000
    """Total learning iterations of the run (a resumed run continues up to this number)."""
    resume: bool = False
    """Continue the run in --out from its latest checkpoint."""
    init_from: Path | None = None
    """Teacher: start a new run from another teacher's weights (actor, critic, observation
    normaliser; fresh optimiser, iteration 0), e.g. a rough or incline teacher from the flat one."""
    seed: int = 0
    """Seed of the terrain tiles, the episodes and the network initialisation."""
    physics_threads: int = 1
    """MuJoCo worker threads stepping the environments."""
    torch_threads: int = 1
    """Threads torch uses for the network updates."""
    device: str = "cpu"
    """Torch device of the networks and their updates (cpu, cuda, cuda:1); physics always
    runs on the CPU (MuJoCo C), observations are moved to this device each step."""
    action_reference: Literal["stand", "current", "tall"] = "stand"
    """Joint targets = the standing pose (stand), a taller standing pose (tall) or the current
    angles (current) + 0.5 rad × action; recorded in the checkpoints (evaluate with the same
    --action-reference)."""
    motor: Motor = "dcmotor"
    """Motor model (``RobotConfig.motor``): the A1's DC motors, whose torque along the motion
    falls to 0 at the rated joint speed (the benchmark's default), or ideal servos with full
    torque at any speed, for comparison (evaluate with the same ``--motor``)."""
    train: TrainConfig = field(default_factory=TrainConfig)
    """Rewards, randomisation, networks, PPO/distillation settings, checkpoint interval."""


@dataclass(frozen=True, kw_only=True)
class ExportArgs:
    """Export a checkpoint's actor (the student if distilled) for deployment and evaluation."""

    checkpoint: Path
    """Training checkpoint model_<it>.pt, a run folder (its latest checkpoint), a shipped policy's
    name (``flat``, ``incline``, ...) or a ``selfright export`` policy file."""
    onnx: Path | None = None
    """ONNX output (obs -> mean action); default: <checkpoint>_policy.onnx next to it (a shipped
    policy: NAME.onnx here)."""
    policy: Path | None = None
    """Policy file output (.pt, weights_only-loadable); default: the ONNX path with suffix .pt."""


def train(args: TrainArgs, bench: BenchmarkConfig | None = None) -> Path:
    """Run ``selfright train``; returns the final checkpoint. User errors raise ``ValueError``."""
    from selfright.train.runner import RunSpec, run_training

    spec = RunSpec(
        role=args.role,
        context=args.context,
        out=args.out,
        num_envs=args.envs,
        iterations=args.iterations,
        seed=args.seed,
        resume=args.resume,
        teacher=args.teacher,
        init_from=args.init_from,
        physics_threads=args.physics_threads,
        torch_threads=args.torch_threads,
        device=args.device,
        train=args.train,
        bench=bench or bench_config(args),
    )
    return run_training(spec)


def bench_config(args: TrainArgs) -> BenchmarkConfig:
    """The benchmark configuration a ``selfright train`` run trains in: the defaults with its
    action reference and motor model."""
    return BenchmarkConfig(action=ActionConfig(reference=args.action_reference), robot=RobotConfig(motor=args.motor))


def load_checkpoint_actor(checkpoint: Path, source: str | None = None) -> tuple[ActorMLP, Path]:
    """The deployable actor of a training checkpoint (or a run folder's latest one, or a
    ``selfright export`` policy file) and that checkpoint's path; ``source`` (default: the path)
    is recorded in the metadata of an actor read from a checkpoint.
    Reads tensors and plain containers only. User errors raise ``ValueError``."""
    import torch

    from selfright.policies.actor import FILE_FORMAT, actor_from_checkpoint, actor_from_payload
    from selfright.policies.run_files import latest_checkpoint, policy_hint

    if not checkpoint.exists():
        raise ValueError(f"checkpoint {checkpoint} not found; pass a model_<it>.pt, a run folder, a policy file or a shipped "
                         "policy's name (flat, rough, incline, ...; sr is three policies: export each)")
    ckpt = latest_checkpoint(checkpoint)
    try:
        data = torch.load(ckpt, map_location="cpu", weights_only=True)
    except Exception as e:  # noqa: BLE001 - any unpickling failure means the same to the user
        raise ValueError(f"checkpoint {ckpt} cannot be read ({str(e).splitlines()[0][:200]})") from e
    if not isinstance(data, dict):
        raise ValueError(f"{ckpt} is not a training checkpoint")
    if data.get("format") == FILE_FORMAT:  # a `selfright export` policy file (a shipped policy's too)
        return actor_from_payload(data), ckpt
    hint = policy_hint(ckpt, data.get("infos"))
    hint["source"] = str(ckpt) if source is None else source
    return actor_from_checkpoint(data, hint), ckpt


def export(args: ExportArgs) -> tuple[Path, Path]:
    """Run ``selfright export``; returns (onnx path, policy file path). User errors raise ``ValueError``."""
    from selfright.policies.actor import export_onnx, save_actor_file
    from selfright.policies.registry import shipped_path

    shipped = shipped_path(str(args.checkpoint))
    by_name = not args.checkpoint.exists() and shipped.exists()  # a shipped policy
    actor, ckpt = load_checkpoint_actor(shipped if by_name else args.checkpoint)
    onnx_path = args.onnx or (Path(f"{args.checkpoint}.onnx") if by_name else ckpt.with_name(f"{ckpt.stem}_policy.onnx"))
    policy_path = args.policy or onnx_path.with_suffix(".pt")
    if policy_path.resolve() == ckpt.resolve():
        policy_path = ckpt.with_name(f"{ckpt.stem}_policy.pt")
    export_onnx(actor, onnx_path)
    save_actor_file(policy_path, actor)
    frames = f" × {actor.meta.obs_history} frames" if actor.meta.obs_history > 1 else ""
    print(f"exported {actor.meta.obs_group}{frames} actor ({actor.meta.role}, {actor.meta.context or 'context ?'}) "
          f"of {ckpt}: {onnx_path}, {policy_path}")
    if actor.meta.obs_group == "student":
        print(f"deployment contract (sensors, action mapping, PD gains, rate): python -m selfright.deploy {onnx_path}")
    return onnx_path, policy_path


def main() -> None:
    """Stand-alone entry point (the package CLI wires the same dataclasses)."""
    import sys

    import tyro

    args = tyro.extras.subcommand_cli_from_dict({"train": TrainArgs, "export": ExportArgs})
    try:
        if isinstance(args, TrainArgs):
            train(args)
        else:
            export(args)
    except ValueError as e:
        sys.exit(f"error: {e}")


if __name__ == "__main__":
    main()
