"""Policies by name: baselines, shipped learned policies, the ``sr`` multiplexer, or a file."""

from __future__ import annotations

from pathlib import Path

from selfright.config import ActionConfig, BenchmarkConfig
from selfright.policies.base import Policy
from selfright.policies.baselines import OpenLoopPolicy, RandomPolicy, ZeroPolicy
from selfright.policies.multiplexer import CONTEXTS
from selfright.policies.reference import ShiftedReference, reference_offset
from selfright.robots import get_robot

BASELINES = ("zero", "random", "open-loop")
MULTIPLEXER = "sr"
"""The seed's π_SR over the shipped students of the three contexts (``flat``, ``rough``, ``incline``)."""
CHECKPOINT_DIR = Path(__file__).resolve().parent.parent / "checkpoints"


def shipped_path(name: str) -> Path:
    """Path of a shipped learned policy (``flat``, ``flat-teacher``, ...)."""
    return CHECKPOINT_DIR / f"{name}.pt"


def available_policies() -> list[str]:
    """The names ``make_policy`` knows: baselines, shipped policies and ``sr`` (when its members ship)."""
    shipped = sorted(p.stem for p in CHECKPOINT_DIR.glob("*.pt")) if CHECKPOINT_DIR.exists() else []
    extra = [MULTIPLEXER] if all(shipped_path(c).exists() for c in CONTEXTS) else []
    return list(BASELINES) + shipped + extra


def _fit_members(policy: Policy, fit) -> bool:
    """For a multiplexer (its ``policies``): replace each member by ``fit(member)`` and return
    True; for any other policy return False and change nothing."""
    subs = getattr(policy, "policies", None)
    if subs is None:
        return False
    for key, sub in subs.items():
        subs[key] = fit(sub)
    return True


def check_action_mapping(policy: Policy, action: ActionConfig, name: str, robot_name: str = "a1") -> Policy:
    """``policy`` ready for the env's action mapping ``action``: itself if its recorded mapping
    (``action_mapping``: reference, scale) is that one or unknown; converted
    (``ShiftedReference``) if both references are fixed poses (``stand``/``tall``) at the same
    scale; ``ValueError`` otherwise (its actions would mean other joint targets than the ones
    it learned)."""
    _fit_members(policy, lambda sub: check_action_mapping(sub, action, name, robot_name))
    mapping = policy.action_mapping
    if mapping is None:
        return policy
    ref, scale = mapping
    robot = get_robot(robot_name)
    try:
        offset = reference_offset(robot, mapping, action)
    except ValueError:
        raise ValueError(
            f"policy {name!r} was trained with joint targets = {ref} + {scale} rad × action, but this run maps "
            f"actions as {action.reference} + {action.scale_rad} rad × action; evaluate it with "
            f"--action-reference {ref} (API: BenchmarkConfig(action=ActionConfig(reference={ref!r})))"
        ) from None
    return policy if offset is None else ShiftedReference(policy, offset, (action.reference, action.scale_rad), action.clip)


def make_policy(name: str, cfg: BenchmarkConfig) -> Policy:
    """``_make_policy`` followed by ``check_action_mapping``."""
    return check_action_mapping(_make_policy(name, cfg), cfg.action, name, cfg.robot.name)


def _make_policy(name: str, cfg: BenchmarkConfig) -> Policy:
    """Build the policy called ``name``: a baseline, a shipped policy, ``sr``, a file path
    (``.pt`` actor file or rsl_rl checkpoint, TorchScript ``.pt``/``.jit``, or ``.onnx``), a
    training run folder (its latest checkpoint), or a Python policy ``FILE.py:NAME`` /
    ``package.module:NAME`` (``selfright.policies.user``). ``ValueError`` otherwise."""
    robot = get_robot(cfg.robot.name)
    if name == "zero":
        return ZeroPolicy(robot, cfg.action)
    if name == "random":
        return RandomPolicy(robot.num_joints)
    if name == "open-loop":
        return OpenLoopPolicy(robot, cfg.action, cfg.sim.control_dt_s)
    from selfright.policies import learned  # torch-model loading only when needed

    if name == MULTIPLEXER:
        missing = [c for c in CONTEXTS if not shipped_path(c).exists()]
        if missing:
            raise ValueError(f"policy {name!r} needs the shipped policies {', '.join(missing)}, which are not in this install")
        from selfright.policies.multiplexer import ContextMultiplexer

        return ContextMultiplexer({c: learned.load_policy_file(shipped_path(c)) for c in CONTEXTS})
    if shipped_path(name).exists():
        return learned.load_policy_file(shipped_path(name))
    if name.removesuffix("-teacher") in CONTEXTS:  # a learned policy by name, not shipped yet
        raise ValueError(
            f"policy {name!r} is not shipped in this install yet; train one (README, *Training in brief*) or choose one of: "
            f"{', '.join(available_policies())}"
        )
    from selfright.policies.user import is_user_policy, load_user_policy

    if is_user_policy(name):  # FILE.py:NAME or package.module:NAME
        return load_user_policy(name, cfg)
    path = Path(name)
    if path.is_dir():  # a training run folder: its latest checkpoint
        from selfright.policies.run_files import latest_checkpoint

        return learned.load_policy_file(latest_checkpoint(path))
    if path.suffix in (".pt", ".jit", ".onnx", ".pth") or path.exists():
        if not path.exists():
            raise ValueError(f"policy file {path} does not exist")
        return learned.load_policy_file(path)
    raise ValueError(f"unknown policy {name!r}; choose one of: {', '.join(available_policies())}, a .pt/.onnx file, "
                     "or a Python policy as FILE.py:NAME")
