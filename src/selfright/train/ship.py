"""Ship a trained policy inside the package: a weights-only actor file plus a model card.

``selfright ship --run runs/NAME --name flat-teacher --evaluation results/flat-teacher_flat``
exports the run's latest actor to ``src/selfright/checkpoints/flat-teacher.pt`` (loadable as
``--policy flat-teacher``) and writes ``flat-teacher.md`` next to it. Every number on the
card is read from files: the run's ``train_meta.json`` (steps, wall-clock, device, command)
and the evaluation's ``summary.json`` (success with its Wilson interval, N, TTR, DTR).
"""

from __future__ import annotations

import json
import re
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any

from selfright.config import RobotConfig
from selfright.env.rewards import RewardConfig
from selfright.evaluate.results import factor_flags, recorded_sensor_noise
from selfright.policies.registry import CHECKPOINT_DIR

if TYPE_CHECKING:
    from selfright.policies.actor import ActorMeta

TABLE_I_WORDS = "the seed's Table I exactly"
"""How a card's Reward line names the seed's Table I (``reward_summary``; read by ``card_record``)."""
STANDING_HEIGHT_WORDS = "the robot's standing height"
"""How a card names the default z* (``RewardConfig.target_height_m`` None)."""
VERSION_PREFIX = "- **Benchmark version**"
"""Start of a card's benchmark-version line (``version_line``)."""


def version_line(meta: dict[str, Any], summary: dict[str, Any]) -> str:
    """The card's line on the benchmark version its success was measured under (the
    evaluation's ``summary.json``) and, if another, the one it was trained under
    (``train_meta.json``); results without a version are of version 0."""
    measured, trained = summary.get("benchmark_version", 0), meta.get("benchmark_version", 0)
    return f"{VERSION_PREFIX}: {measured}" + (f" (trained under version {trained})" if trained != measured else "")


@dataclass(frozen=True, kw_only=True)
class ShipArgs:
    """Copy a run's actor into the package as a named policy, with its model card."""

    run: Path
    """Training run folder (its latest checkpoint is shipped) or one of its ``model_<it>.pt``."""
    name: str
    """Policy name: flat | rough | incline (students) or flat-teacher | ... (teachers)."""
    evaluation: Path
    """Results folder of ``selfright evaluate --policy <exported file> --grid <its context>``."""
    dest: Path = CHECKPOINT_DIR
    """Where shipped policies live (the package's checkpoints folder)."""
    notes: Path | None = None
    """Markdown appended to the model card under "Notes" (lineage, selection, caveats)."""


def ship(args: ShipArgs) -> Path:
    """Export and document; returns the policy file. User errors raise ``ValueError``."""
    from selfright.policies.actor import save_actor_file
    from selfright.train.commands import load_checkpoint_actor

    if args.notes is not None and not args.notes.is_file():
        raise ValueError(f"--notes {args.notes} not found; pass a markdown file or drop --notes")
    meta = checkpoint_meta(args.run)
    summary_path = args.evaluation / "summary.json"
    if not summary_path.exists():
        raise ValueError(f"{summary_path} not found; evaluate the policy first (`selfright evaluate --out {args.evaluation}`)")
    summary = json.loads(summary_path.read_text())
    source = f"{meta.get('role', '?')} run, iteration {meta.get('iterations_done', '?')}"
    actor, _ = load_checkpoint_actor(args.run, source)
    args.dest.mkdir(parents=True, exist_ok=True)
    out = args.dest / f"{args.name}.pt"
    save_actor_file(out, actor)
    notes = args.notes.read_text().strip() if args.notes is not None else ""
    (args.dest / f"{args.name}.md").write_text(model_card(args.name, meta, summary, actor.meta, notes))
    print(f"shipped {out} and its model card {out.with_suffix('.md')}")
    return out


def checkpoint_meta(run: Path) -> dict[str, Any]:
    """The run's ``train_meta.json``, with iterations, env steps and wall-clock of the shipped
    checkpoint: the latest one for a run folder, else the file ``run`` names. ``ValueError`` if
    those numbers are not known for that checkpoint."""
    import torch

    from selfright.policies.run_files import latest_checkpoint, read_meta

    folder = run.parent if run.is_file() else run
    meta = read_meta(folder)
    if not meta:
        raise ValueError(f"{folder} has no train_meta.json; pass a folder written by `selfright train`")
    ckpt = latest_checkpoint(run)
    if meta.get("latest_checkpoint") and Path(meta["latest_checkpoint"]).name == ckpt.name:
        return _invocations(meta, meta.get("iterations_done"))
    infos = torch.load(ckpt, map_location="cpu", weights_only=True).get("infos") or {}
    progress = ("iterations_done", "env_steps", "wall_clock_s")
    if not all(k in infos for k in progress):
        raise ValueError(f"{ckpt} does not record its env steps and wall-clock (an older checkpoint); "
                         f"ship the run folder (its latest checkpoint) instead")
    out = {**meta, **{k: infos[k] for k in progress}, "latest_checkpoint": str(ckpt)}
    return _invocations(out, int(infos["iterations_done"]))


def _invocations(meta: dict[str, Any], done: int | None) -> dict[str, Any]:
    """``meta`` with only the invocations that led to a checkpoint after ``done`` iterations
    (``command_lines``) and the machines they ran on (``device``: each one, in order, where the
    run records them per invocation; else the run's last machine)."""
    out = dict(meta)
    cmds, starts = meta.get("command_lines") or [], meta.get("command_start_iterations") or []
    if done is not None and cmds and len(starts) == len(cmds):
        out["command_lines"] = [c for c, s in zip(cmds, starts) if s < done]
        devices = meta.get("command_devices") or []
        if len(devices) == len(cmds):
            used = [d for d, s in zip(devices, starts) if s < done and d]
            out["device"] = "; then ".join(dict.fromkeys(used)) or meta.get("device")
    return out


def _budget(label: str, checkpoint: str | None) -> str:
    """"; LABEL: N env steps, H h" of another run's checkpoint (a teacher, an initialisation),
    read from its record; empty if unknown."""
    if not checkpoint:
        return ""
    try:
        t = checkpoint_meta(Path(checkpoint))
    except (ValueError, OSError):
        return ""
    return f"; {label}: {int(t.get('env_steps', 0)):,} env steps, {float(t.get('wall_clock_s', 0.0)) / 3600:.2f} h"


def _lineage(teacher: str | None) -> str:
    """How the policy came from its teacher: distilled from it."""
    return f", distilled from `{teacher}`" if teacher else ""


def model_card(
    name: str, meta: dict[str, Any], summary: dict[str, Any], actor: ActorMeta, notes: str = ""
) -> str:
    """Markdown model card from a run's meta, an evaluation summary, the shipped actor's
    metadata (what it reads: group, history frames) and optional notes."""
    steps = int(meta.get("env_steps", 0))
    hours = float(meta.get("wall_clock_s", 0.0)) / 3600
    cmds = meta.get("command_lines") or [meta.get("command_line", "?")]
    teacher = meta.get("teacher")
    pol = meta.get("policy") or {}
    lines = [
        f"# Model card: `{name}`",
        "",
        f"- **Role**: {meta.get('role')} (observation group `{actor.obs_group}`"
        + (f", its last {actor.obs_history} frames stacked oldest first" if actor.obs_history > 1 else "")
        + ")"
        + _lineage(teacher),
        f"- **Training context**: {meta.get('context')}"
        + (f"; initialised from the teacher `{meta['init_from']}`"
           if meta.get("init_from") and meta.get("role") == "teacher" else ""),
        f"- **Environment steps**: {steps:,} ({meta.get('iterations_done')} iterations, {meta.get('num_envs')} envs)"
        + _budget("its teacher", teacher)
        + _budget("before that, its initialisation", meta.get("init_from") if meta.get("role") == "teacher" else None),
        f"- **Action mapping**: joint targets = `{pol.get('action_reference', 'stand')}` reference + "
        f"{pol.get('action_scale_rad', 0.5)} rad × action (any `--action-reference` but `current` converts it)",
        *motor_lines(meta),
        *joint_stop_lines(meta),
        f"- **Reward**: {reward_summary(meta)}",
        f"- **Wall-clock**: {hours:.2f} h",
        f"- **Device**: {meta.get('device')}",
        version_line(meta, summary),
        *success_lines(name, summary),
        f"- **Versions**: {json.dumps(meta.get('versions', {}))}",
        "",
        "Trained with (each line one invocation; resumed runs list several):",
        "",
        "```bash",
        *[_cli(c) for c in cmds],
        "```",
        "",
    ]
    if notes:
        lines += ["## Notes", "", notes, ""]
    return "\n".join(lines)


def motor_lines(meta: dict[str, Any]) -> list[str]:
    """A card line naming the motors the run trained with when they are not the benchmark's
    (``RobotConfig.motor`` at the robot's rated speed)."""
    robot = (meta.get("benchmark_config") or {}).get("robot") or {}
    motor, speed = robot.get("motor", RobotConfig.motor), robot.get("motor_speed_rad_s")
    if motor == "ideal":
        return ["- **Motor model**: `ideal` (full torque at any speed, not the benchmark's DC motors; evaluate with "
                "`--motor ideal` for comparison)"]
    if motor == "envelope":  # recorded by runs that applied the DC-motor limit to their joint targets
        return ["- **Motor model**: trained with the DC motors' torque-speed limit applied to its joint targets "
                "each control step (an approximation of the benchmark's `dcmotor`, which `selfright evaluate` runs)"]
    if speed is None:
        return []
    return [f"- **Motor model**: `{motor}` with the torque reaching 0 at {speed:g} rad/s, not the robot's rated speed "
            "that `selfright evaluate` runs"]


def joint_stop_lines(meta: dict[str, Any]) -> list[str]:
    """A card line naming the joint stops' stiffness when the run's ``train_meta.json`` records
    other stops than the benchmark's (``RobotConfig.joint_stop_timeconst_s``)."""
    robot = (meta.get("benchmark_config") or {}).get("robot") or {}
    trained = robot.get("joint_stop_timeconst_s")
    if trained is None or trained == RobotConfig.joint_stop_timeconst_s:
        return []
    return [f"- **Joint stops**: trained with a stop time constant of {trained:g} s (softer than the benchmark's "
            f"{RobotConfig.joint_stop_timeconst_s:g} s, which `selfright evaluate` uses)"]


SUCCESS_PREFIX = "- **Success in its context**"
SEED_PREFIX = "- **Evaluation seed**"


def success_lines(name: str, summary: dict[str, Any]) -> list[str]:
    """The card's two lines on the policy's success in its context (and the machine it was
    measured on, where the summary records it) and how to reproduce it."""
    o = summary["overall"]
    lo, hi = o["success_ci95"]
    ttr = "n/a" if o.get("ttr_mean_s") is None else f"{o['ttr_mean_s']:.2f} s"
    dtr = "n/a" if o.get("dtr_mean_m") is None else f"{o['dtr_mean_m']:.2f} m"
    cpu = (summary.get("machine") or {}).get("cpu")
    date = (summary.get("machine") or {}).get("date")
    motor = (((summary.get("config") or {}).get("robot") or {}).get("motor")) or RobotConfig.motor
    flags = "" if motor == RobotConfig.motor else f" --motor {motor}"
    noise = recorded_sensor_noise(summary)
    flags += f" --sensor-noise {noise:g}" if noise > 0 else ""
    words = f", through sensor noise ×{noise:g}" if noise > 0 else ""
    for flag, text in factor_flags(((summary.get("config") or {}).get("eval")) or {}):
        flags += f" {flag}"
        words += f", {text}"
    return [
        f"{SUCCESS_PREFIX} (`--grid {summary.get('grid')}`" + words + f", N = {o['n']}): "
        f"**{100 * o['success_rate']:.1f} %** (95 % Wilson interval {100 * lo:.0f}–{100 * hi:.0f} %), "
        f"mean TTR {ttr}, mean DTR {dtr}" + (f"; measured{' ' + date if date else ''} on {cpu}" if cpu else ""),
        f"{SEED_PREFIX}: {summary.get('seed', 0)}; {summary.get('episodes_per_cell')} episodes per cell; "
        f"reproduce with `selfright evaluate --policy {name} --grid {summary.get('grid')} "
        f"--episodes {summary.get('episodes_per_cell')} --seed {summary.get('seed', 0)}{flags}`",
    ]


def remeasured_card(card_text: str, name: str, summary: dict[str, Any], why: str) -> str:
    """``card_text`` with its success and seed lines rewritten from a new evaluation
    ``summary`` of the shipped policy, the lines they replace kept below them as
    "Before <why>" (the policy is unchanged; the benchmark or machine it is measured on is not)."""
    lines = card_text.splitlines()
    at = [i for i, line in enumerate(lines) if line.startswith(SUCCESS_PREFIX)]
    if len(at) != 1 or at[0] + 1 >= len(lines) or not lines[at[0] + 1].startswith(SEED_PREFIX):
        raise ValueError(f"the {name} card has no single success line followed by its seed line")
    if summary.get("policy") != name:
        raise ValueError(f"the evaluation is of --policy {summary.get('policy')!r}, not the shipped {name!r}")
    i = at[0]
    before = lines[i].removeprefix(SUCCESS_PREFIX)
    old = [k for k, line in enumerate(lines) if line.startswith(VERSION_PREFIX)]
    # the version it was trained under: the old line's "trained under", else what it was measured under
    m = re.search(r"(\d+)\D*$", lines[old[0]]) if old else None
    trained = {"benchmark_version": int(m.group(1)) if m else 0}
    head = [line for k, line in enumerate(lines[:i]) if k not in old]
    return "\n".join([*head, version_line(trained, summary), *success_lines(name, summary), f"  - *Before {why}*{before}",
                      *lines[i + 2:]]) + "\n"


OWN_WORDS = ("target_height_m", "goal_set", "bar_ramp", "bar_ramp_width_m", "bar_ramp_over_m", "feet_under_hips")
"""``RewardConfig`` fields that ``reward_summary`` words itself instead of listing as changed weights."""


def reward_summary(meta: dict[str, Any]) -> str:
    """Which reward trained the policy (a student: its teacher's, up a chain of students to the
    first policy trained with a reward), against the seed's Table I: "Table I exactly (z* = …)"
    or the weights that differ, flagged as not Table I."""
    from selfright.policies.run_files import read_meta

    source = meta
    for _ in range(16):  # a student of a student of ... (bounded: a cycle of metas is a broken run)
        if source.get("role") != "student" or not source.get("teacher"):
            break
        teacher = Path(source["teacher"])
        source = read_meta(teacher.parent if teacher.suffix == ".pt" else teacher)
    reward = (source.get("train_config") or {}).get("reward")
    if not reward:
        return "unknown (no train_config recorded)"
    table = RewardConfig()
    z = reward.get("target_height_m")
    z_txt = STANDING_HEIGHT_WORDS if z is None else f"{z} m"
    changed = [
        f"{f.name} {reward[f.name]} (Table I: {getattr(table, f.name)})"
        for f in fields(RewardConfig)
        if f.name not in OWN_WORDS and f.name in reward and reward[f.name] != getattr(table, f.name)
    ]
    episode = (source.get("train_config") or {}).get("episode") or {}
    low = episode.get("terminate_low_stance_s")
    rule = ""
    if episode.get("off_tile_is_timeout") is False:
        rule += "; leaving the tile ended training episodes as terminal (the project's default ends them as a time-out)"
    if low:
        stance = "three or four feet (a leaky count)" if episode.get("low_stance_leaky") else "four feet"
        over_feet = episode.get("low_stance_over_feet_m")
        bar = "the goal bar" if over_feet is None else f"{over_feet} m above the ground under the feet"
        rule += f"; training episodes ended as terminal after {low} s upright on {stance} under {bar} (not in the seed)"
    extra = []
    if goal := reward.get("goal_set") or 0.0:
        extra.append(("a goal-set term", f"{goal} per s in the goal set"))
    if ramp := reward.get("bar_ramp") or 0.0:
        width = reward.get("bar_ramp_width_m", table.bar_ramp_width_m)
        over = reward.get("bar_ramp_over_m", table.bar_ramp_over_m)
        extra.append(("a bar-ramp term", f"up to {ramp} per s standing upright on four feet, rising over the "
                                         f"{width} m under a top {over} m over the goal bar"))
    if under := reward.get("feet_under_hips") or 0.0:
        extra.append(("a feet-under-hips term", f"−{under} per m²·s of the feet's squared horizontal offsets "
                                                "from their leg roots, standing upright on four feet"))
    if extra:
        names = " and ".join(name for name, _ in extra)
        what = "; ".join(words for _, words in extra)
        terms = f"; {'; '.join(changed)}" if changed else ""
        return f"the seed's Table I terms **plus {names}** (not in Table I), {what}{terms} (z* = {z_txt}){rule}"
    if not changed:
        return f"{TABLE_I_WORDS} (z* = {z_txt}){rule}"
    return f"**not** the seed's Table I: {'; '.join(changed)} (z* = {z_txt}){rule}"


def card_record(card_text: str) -> dict[str, Any]:
    """What a model card written by ``model_card`` says of its policy's training, as
    ``train_meta.json`` keys: env steps, iterations, envs, wall-clock (to the card's 0.01 h),
    and the reward when it is Table I. Lets a shipped teacher whose run is gone be quoted on its
    student's card (``scripts/actor_to_run.py``); keys the card does not state are left out."""
    out: dict[str, Any] = {}
    if m := re.search(r"\*\*Environment steps\*\*: ([\d,]+) \((\d+) iterations, (\d+) envs\)", card_text):
        out.update(env_steps=int(m.group(1).replace(",", "")), iterations_done=int(m.group(2)), num_envs=int(m.group(3)))
    if m := re.search(r"\*\*Wall-clock\*\*: ([\d.]+) h", card_text):
        out["wall_clock_s"] = float(m.group(1)) * 3600
    if m := re.search(r"\*\*Reward\*\*: " + re.escape(TABLE_I_WORDS) + r" \(z\* = ([^)]*)\)", card_text):
        z = None if m.group(1) == STANDING_HEIGHT_WORDS else float(m.group(1).removesuffix(" m"))
        out["train_config"] = {"reward": {**asdict(RewardConfig()), "target_height_m": z}}
    return out


def _cli(command_line: str) -> str:
    """A recorded ``sys.argv`` line as the equivalent ``selfright`` command."""
    parts = command_line.split()
    if parts and parts[0].endswith(("selfright", "commands.py", "cli.py")):
        parts[0] = "selfright"
    return " ".join(parts)
