"""Every training run a shipped policy (or a run) descends from, oldest first, with each run's
env steps, wall-clock, machines and exact command lines, read from the runs' ``train_meta.json``
(committed for the shipped policies' runs). A model card lists the commands of the last run
only; the weights descend through ``--init-from``, ``--teacher`` and the second teachers and
frozen partners a run names (``--train.distillation.fallback-teacher`` / ``rough-teacher`` /
``rescue-student``, ``--train.episode.upright-policy`` / ``tilted-policy``). Replaying the
commands in this order retrains the policy (a draw of its recipe, not its bits: see
docs/training.md).

    python scripts/lineage.py --policy incline
    python scripts/lineage.py --run runs/incline_env395_stance03

A run whose command says ``--iterations 100000`` was stopped by hand: train it to the checkpoint
its child uses (``uses model_K.pt``: ``--iterations K+1``). A run that went on past the checkpoint its child used (``uses model_K.pt``), or the last run
past the checkpoint that shipped (its card names it), is listed with all its steps, so the total
is an upper bound where that happens.

``--script`` prints that replay instead, as a bash script that does it for you:

    python scripts/lineage.py --policy incline --script > retrain_incline.sh
    EXTRA="--physics-threads 2" bash retrain_incline.sh   # rerun it to resume

Every invocation of every run, in order, each stopped at the iteration where the next one began
or where a child took its checkpoint (so each ``model_K.pt`` a child reads is written), the run
folders under ``--prefix`` (``runs/retrain``) so the committed ones stay as they are. A step whose
run already holds its last checkpoint is skipped; one with an earlier checkpoint goes on from it
(``--resume``, without ``--init-from``). ``EXTRA`` is appended to every command (the last value of
a flag wins): the GPU machine's invocations say ``--device cuda --physics-threads 8``, so on a
laptop give ``EXTRA="--device cpu --physics-threads 2"``. A run trained before its meta
recorded a setting that has changed since is replayed with the value it had
(``BEFORE_RECORDED``: the joint stops' stiffness, 0.02 s before 2026-12-04), and a comment above
each run names any other setting today's code resolves its command to differently.
``--from-step K`` retrains runs K on only: the checkpoints the later runs read from runs 1 to
K − 1 are copied from the committed runs (a replay of the later steps from the same start,
which separates the recipe's later steps from the draw of the first). A source with no run meta here (a
shipped policy's file, a run whose meta was never committed) is read from where the meta names
it, and the script says so; a run of several invocations whose meta does not record where each
began (metas written before 2026-11-23) cannot be replayed and is refused.
"""

from __future__ import annotations

import csv
import json
import re
import shlex
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import tyro

from selfright.policies.registry import shipped_path

META = "train_meta.json"


@dataclass(frozen=True)
class Args:
    policy: str | None = None
    """A shipped policy name (its card's ``--out`` names the last run)."""
    run: Path | None = None
    """A run folder (or a checkpoint in one) instead of ``--policy``."""
    root: Path = Path(".")
    """Where the ``runs/`` paths in the metas are relative to (the repository root)."""
    script: bool = False
    """Print a resumable bash script that retrains the lineage instead of listing it."""
    prefix: str = "runs/retrain"
    """With ``--script``: the folder the retrained runs go in (each keeps its name)."""
    from_step: int = 1
    """With ``--script``: retrain from this run of the listing on; the runs before it are not
    retrained, and the checkpoints their children read are copied from the committed runs."""


def card_run(name: str) -> Path:
    """The run a shipped policy's card says trained it (the ``--out`` of its command block)."""
    card = shipped_path(name).with_suffix(".md")
    if not card.exists():
        raise SystemExit(f"no shipped policy {name!r} (no {card})")
    block = card.read_text().partition("Trained with")[2].partition("```bash")[2].partition("```")[0]
    outs = re.findall(r"--out (\S+)", block)
    if not outs:
        raise SystemExit(f"{card} names no training run (no --out in its commands)")
    return Path(outs[0])


SOURCE_FLAGS = ("init-from", "teacher", "rescue-student", "upright-policy", "tilted-policy")
"""Endings of the ``selfright train`` flags whose value is a policy a run starts from or learns
from (``--train.distillation.fallback-teacher`` and ``rough-teacher`` end in ``teacher``)."""


def sources(meta: dict[str, Any]) -> list[tuple[str, str]]:
    """(relation, path) of every policy a run's weights or labels came from."""
    tc = meta.get("train_config", {})
    dist, ep = tc.get("distillation", {}), tc.get("episode", {})
    named = [
        ("--init-from", meta.get("init_from")),
        ("--teacher", meta.get("teacher")),
        ("fallback teacher", dist.get("fallback_teacher")),
        ("rough teacher", dist.get("rough_teacher")),
        ("rescue student", dist.get("rescue_student")),
        ("upright policy", ep.get("upright_policy")),
        ("tilted policy", ep.get("tilted_policy")),
    ]
    return [(rel, str(p)) for rel, p in named if p]


def run_dir(path: str, root: Path) -> Path | None:
    """The run folder holding ``path`` (a run or one of its checkpoints), if it has a meta."""
    p = root / path
    d = p if p.is_dir() else p.parent
    return d if (d / META).exists() else None


@dataclass
class Lineage:
    """The runs behind a policy, oldest first, and what each one's children took from it."""

    order: list[Path]
    """Run folders (resolved), each after the runs it descends from."""
    metas: dict[Path, dict[str, Any]]
    """Each run's ``train_meta.json``."""
    edges: dict[Path, list[str]]
    """Each run's sources, as the listing prints them."""
    uses: dict[Path, list[int | None]]
    """Per run, the iteration of each checkpoint a child read from it (``None``: the folder)."""
    missing: list[str]
    """Sources with no run meta here (a shipped policy's file, an uncommitted run)."""
    shipped: dict[str, str] = field(default_factory=dict)
    """Sources given as a shipped policy's name (``--init-from flat``) → the run checkpoint its
    card names (``runs/flat_student_stance/model_394.pt``), walked as that checkpoint."""


def checkpoint_iteration(path: str) -> int | None:
    """K of ``…/model_K.pt``; ``None`` for a folder (its latest checkpoint)."""
    from selfright.policies.run_files import CHECKPOINT_RE  # (imports torch: only where needed)

    m = CHECKPOINT_RE.fullmatch(Path(path).name)
    return int(m.group(1)) if m else None


def walk(run: Path, root: Path, lin: Lineage) -> None:
    """Depth-first over the sources, appending each run after its own sources."""
    run = run.resolve()
    if run in lin.metas:
        return
    meta = json.loads((run / META).read_text())
    lin.metas[run] = meta
    lin.edges[run] = []
    for rel, src in sources(meta):
        parent = run_dir(src, root)
        if parent is None and shipped_path(src).with_suffix(".md").exists():
            lin.shipped[src] = f"{card_run(src).as_posix()}/model_{card_iterations(src) - 1}.pt"
            rel, src = f"{rel} {src} (shipped):", lin.shipped[src]
            parent = run_dir(src, root)
        used = f" (uses {Path(src).name})" if Path(src).suffix == ".pt" else ""
        if parent is None:
            lin.edges[run].append(f"{rel} {src}{used}: no run meta here (a shipped policy or a file)")
            lin.missing.append(src)
            continue
        lin.edges[run].append(f"{rel} {rel_path(parent, root)}{used}")
        walk(parent, root, lin)
        lin.uses.setdefault(parent.resolve(), []).append(checkpoint_iteration(src))
    lin.order.append(run)


def lineage(first: Path, root: Path) -> Lineage:
    lin = Lineage(order=[], metas={}, edges={}, uses={}, missing=[])
    walk(first, root, lin)
    return lin


def rel_path(p: Path, root: Path) -> str:
    try:
        return str(p.resolve().relative_to(root.resolve()))
    except ValueError:
        return str(p)


def card_iterations(name: str) -> int:
    """The iterations of a shipped policy's checkpoint (its card's ``(K iterations, …``)."""
    text = shipped_path(name).with_suffix(".md").read_text()
    m = re.search(r"\*\*Environment steps\*\*: [\d,]+ \((\d+) iterations", text)
    if m is None:
        raise SystemExit(f"the card of {name!r} gives no iteration count; use --run runs/NAME/model_K.pt")
    return int(m.group(1))


def main(a: Args) -> None:
    if (a.policy is None) == (a.run is None):
        raise SystemExit("give one of --policy NAME or --run runs/NAME")
    start = card_run(a.policy) if a.policy else a.run
    assert start is not None
    first = run_dir(str(start), a.root)
    if first is None:
        # A run folder renamed after shipping (runs/flat_teacher → runs/flat_teacher_best) keeps
        # the --out it was trained with in its meta's command lines.
        renamed = sorted(m.parent for m in (a.root / "runs").glob(f"*/{META}")
                         if all(f"--out {start} " in c + " " for c in json.loads(m.read_text()).get("command_lines", [""])))
        hint = f"; runs whose commands wrote to {start}: {', '.join(rel_path(r, a.root) for r in renamed)}" if renamed else ""
        raise SystemExit(f"{start}: no {META} there (runs/ holds the committed metas of the shipped runs){hint}")
    lin = lineage(first, a.root)
    if a.script:
        last = card_iterations(a.policy) if a.policy else checkpoint_iteration(str(start))
        if a.run is not None and last is not None:
            last += 1  # model_K.pt is written at the end of K + 1 iterations
        target = a.policy or str(start)
        if not 1 <= a.from_step <= len(lin.order):
            raise SystemExit(f"--from-step {a.from_step}: the lineage has runs 1 to {len(lin.order)}")
        made_by = f"python scripts/lineage.py {'--policy' if a.policy else '--run'} {target} --script"
        if a.from_step > 1:
            made_by += f" --from-step {a.from_step}"
        print(replay_script(lin, a.root, a.prefix, last, made_by, a.from_step))
        return
    steps = hours = 0.0
    order, seen, edges = lin.order, lin.metas, lin.edges
    for i, run in enumerate(order, 1):
        m = seen[run]
        devices = sorted({d for d in m.get("command_devices", []) if d}) or [m.get("device", "?")]
        print(f"{i}. {rel_path(run, a.root)}: {m.get('role')} / {m.get('context')}, "
              f"{m.get('iterations_done')} iterations, {m.get('env_steps', 0):,} env steps, "
              f"{m.get('wall_clock_s', 0) / 3600:.2f} h on {' | '.join(devices)}")
        for e in edges[run]:
            print(f"   from {e}")
        for cmd in m.get("command_lines", []):
            print("   $ " + as_selfright(cmd))
        steps += m.get("env_steps", 0)
        hours += m.get("wall_clock_s", 0) / 3600
    print(f"{len(order)} runs, {steps:,.0f} env steps, {hours:.2f} h of training in all "
          "(runs that went on past the checkpoint used count in full)")


def as_selfright(cmd: str) -> str:
    """A recorded command line with its executable's path (``…/.venv/bin/selfright``,
    ``…/src/selfright/cli.py``) written as ``selfright``."""
    return re.sub(r"^\S*/(selfright|cli\.py) ", r"selfright ", cmd)


def segments(meta: dict[str, Any], ends: set[int]) -> list[tuple[str, int]]:
    """(command line, stop iteration) for each step that replays a run: each recorded
    invocation stopped where the next one began, and again at every iteration in ``ends``
    (so ``model_{end-1}.pt`` is written), up to the largest of them."""
    cmds = meta.get("command_lines") or [meta["command_line"]]
    starts = meta.get("command_start_iterations") or [0]
    if len(starts) != len(cmds):
        raise SystemExit(f"{cmds[0].split('--out ')[-1].split()[0]}: its meta does not record where each of its "
                         f"{len(cmds)} invocations began (written before 2026-11-23), so it cannot be replayed "
                         f"(scripts/train_policies.sh is the recipe of the policies shipped up to the fourteenth session)")
    final = max(ends)
    stops = sorted({s for s in starts[1:] if 0 < s < final} | ends)
    out = []
    for stop in stops:
        i = max(j for j, s in enumerate(starts) if s < stop)  # the invocation that ran up to `stop`
        out.append((cmds[i], stop))
    return out


def flat_dict(d: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """``{"a": {"b": 1}}`` → ``{"a.b": 1}``."""
    out: dict[str, Any] = {}
    for k, v in d.items():
        out.update(flat_dict(v, f"{prefix}{k}.") if isinstance(v, dict) else {f"{prefix}{k}": v})
    return out


def resolved_configs(cmd: str) -> dict[str, dict[str, Any]]:
    """The train and benchmark configurations today's ``selfright train`` resolves ``cmd`` to,
    keyed as a run meta records them (``train_config``, ``benchmark_config``), flattened."""
    from selfright.config import to_dict
    from selfright.train.commands import TrainArgs, bench_config

    a = tyro.cli(TrainArgs, args=shlex.split(as_selfright(cmd))[2:])
    return {"train_config": flat_dict(to_dict(a.train)), "benchmark_config": flat_dict(to_dict(bench_config(a)))}


def config_drift(meta: dict[str, Any], source_metas: list[dict[str, Any]]) -> list[str]:
    """Where today's defaults make a run's last recorded command resolve to another
    configuration than the one its meta records: ``key: recorded → now`` for changed values
    (a value the run took from a source run, such as a copied student's history, is not a
    change), and the settings added since, by name for the benchmark's (physics) and counted
    for training's."""
    try:
        now = resolved_configs((meta.get("command_lines") or [meta["command_line"]])[-1])
    except SystemExit:  # tyro said why on stderr
        return ["its last command no longer parses (a flag renamed or removed since)"]
    from selfright.evaluate.results import with_added_defaults

    lines, added_train = [], 0
    for group, values in now.items():
        recorded = meta.get(group) or {}
        # Fields added later whose default is what the code did before them are not drift.
        rec = flat_dict(with_added_defaults(recorded) if group == "benchmark_config" else recorded)
        inherited = [flat_dict(m.get(group) or {}) for m in source_metas]
        added = [k for k in values if k not in rec]
        changed = [k for k in values if k in rec and json.dumps(values[k]) != json.dumps(rec[k])
                   and not any(k in src and json.dumps(src[k]) == json.dumps(rec[k]) for src in inherited)]
        lines += [f"{group}.{k}: recorded {json.dumps(rec[k])}, now {json.dumps(values[k])}" for k in changed]
        if group == "benchmark_config":
            lines += [f"{group}.{k}: not recorded (before it existed), now {json.dumps(values[k])}"
                      for k in added if k not in BEFORE_RECORDED  # those are restored (restored_settings)
                      and not (k in ADDED_AS_BEFORE and values[k] == ADDED_AS_BEFORE[k])]
        else:
            added_train = len(added)
    if added_train:
        lines.append(f"train_config: {added_train} setting{'s' if added_train > 1 else ''} added since, "
                     f"at {'their defaults' if added_train > 1 else 'its default'}")
    return lines


# Benchmark settings added after older runs were recorded, with the value the code ran with before
# them: a run that lacks one and resolves to that value today has not drifted. (Kept to this report:
# ``selfright compare`` and the resume check still tell such folders apart from newer ones.)
ADDED_AS_BEFORE = {
    "robot.motor": "ideal",  # 2026-12-04: the ideal PD servos were the only motor before
    "robot.motor_speed_rad_s": None,  # 2026-12-04: None = the rated speed the DC motor had before
}

# Settings whose value changed before the run metas recorded them: the flag that sets the value
# the older runs had, which the replay passes to a run whose meta lacks the setting.
BEFORE_RECORDED = {
    # The hard joint stops (2026-12-04); the runs before had MuJoCo's default time constant.
    "robot.joint_stop_timeconst_s": ("--joint-stop-timeconst-s", "0.02"),
}


def restored_settings(meta: dict[str, Any]) -> list[tuple[str, str]]:
    """(flag, value) of each ``BEFORE_RECORDED`` setting the run trained with but did not record."""
    rec = flat_dict(meta.get("benchmark_config") or {})
    return [flag for key, flag in BEFORE_RECORDED.items() if key not in rec]


def recorded_validation(run: Path, iteration: int) -> str | None:
    """"S/N (P %)" of a run's checkpoint in its committed ``validation.csv``, if it was validated."""
    path = run / "validation.csv"
    if not path.exists():
        return None
    for row in csv.DictReader(path.open()):
        if int(row["iteration"]) == iteration:
            return f"{row['successes']}/{row['episodes']} ({100 * float(row['success_rate']):.1f} %)"
    return None


def set_flag(tokens: list[str], flag: str, values: list[str]) -> list[str]:
    """``tokens`` with ``flag``'s values replaced (or the flag appended)."""
    if flag not in tokens:
        return [*tokens, flag, *values]
    i = tokens.index(flag)
    j = i + 1
    while j < len(tokens) and not tokens[j].startswith("--"):
        j += 1
    return [*tokens[: i + 1], *values, *tokens[j:]]


def replay_script(lin: Lineage, root: Path, prefix: str, last_end: int | None, made_by: str,
                  from_step: int = 1) -> str:
    """A bash script that retrains every run of ``lin`` under ``prefix`` (module docstring),
    from its ``from_step``-th run on: the runs before it are copied in (``reuse``), each as
    the checkpoints its children read."""
    names = {}  # every path a run was known by → its new folder
    for run in lin.order:
        new = f"{prefix.rstrip('/')}/{run.name}"
        names[rel_path(run, root)] = new
        for cmd in lin.metas[run].get("command_lines") or []:
            for out in re.findall(r"--out (\S+)", cmd):
                names[out.rstrip("/")] = new

    def moved(token: str, after: str = "") -> str:
        if after.endswith(SOURCE_FLAGS):  # a shipped name stands for its run only as a source's value
            token = lin.shipped.get(token, token)
        head, sep, tail = token.partition("/model_")
        return names.get(head.rstrip("/"), head) + sep + tail

    lines = [
        "#!/usr/bin/env bash",
        (f"# Retrains the {len(lin.order)} runs of this lineage, oldest first, under {prefix}/ (written by:"
         if from_step == 1 else f"# Retrains runs {from_step} to {len(lin.order)} of this lineage, oldest first, "
                                f"under {prefix}/, from the committed checkpoints of the runs before (written by:"),
        f"#   {made_by}).",
        "# Rerun to resume: a step whose checkpoint exists is skipped, a started one goes on from its latest",
        "# checkpoint. EXTRA is appended to every command; the last value of a flag wins",
        '# (e.g. EXTRA="--device cpu --physics-threads 2" for the invocations that ran on the GPU machine).',
        "# A replay is a draw of the recipe, not its bits (docs/training.md). A run stopped by hand",
        "# (--iterations 100000 in its record) was stopped where its validation was good, and PPO from",
        "# scratch takes off after a varying number of iterations: where a replayed run's validation",
        "# is far under the recorded one, train it on (--resume --iterations K) and point its child",
        "# at the checkpoint that validates as well (its --init-from / --teacher below).",
    ]
    lines += [f"# Not retrained here, read as recorded: {src}" for src in dict.fromkeys(lin.missing)]
    lines += [
        "set -euo pipefail",
        'EXTRA=${EXTRA:-}',
        "",
        "# last_it DIR: the iteration of DIR's newest model_K.pt (-1: none)",
        "last_it() {",
        "  local k=-1 f n",
        '  for f in "$1"/model_*.pt; do',
        '    [ -e "$f" ] || continue',
        '    n=${f##*/model_}; n=${n%.pt}',
        '    [ "$n" -gt "$k" ] && k=$n',
        "  done",
        '  echo "$k"',
        "}",
        "",
        "# step DIR STOP COMMAND...: run COMMAND unless DIR holds model_{STOP-1}.pt or a later one;",
        "# if DIR holds an earlier checkpoint, go on from it (--resume, no --init-from)",
        "step() {",
        '  local dir=$1 stop=$2 last args=() skip=0 a',
        "  shift 2",
        '  last=$(last_it "$dir")',
        '  if [ "$last" -ge $((stop - 1)) ]; then echo "== $dir: model_$last.pt is there, skipped" >&2; return; fi',
        '  for a in "$@"; do',
        '    if [ "$skip" = 1 ]; then skip=0; continue; fi',
        '    if [ "$last" -ge 0 ]; then',
        '      if [ "$a" = --init-from ]; then skip=1; continue; fi',
        '      if [ "$a" = --resume ]; then continue; fi',
        "    fi",
        '    args+=("$a")',
        "  done",
        '  if [ "$last" -ge 0 ]; then args+=(--resume); fi',
        '  echo "== $dir: to model_$((stop - 1)).pt" >&2',
        '  mkdir -p "$dir"',
        '  # shellcheck disable=SC2086',
        '  "${args[@]}" $EXTRA',
        "}",
    ]
    if from_step > 1:
        lines += [
            "",
            "# reuse FILE DIR: copy a committed run's checkpoint (and its meta) into DIR, unless it is there",
            "reuse() {",
            '  [ -e "$1" ] || { echo "$1 is not here: retrain from an earlier step (--from-step)" >&2; exit 1; }',
            '  mkdir -p "$2"',
            '  [ -e "$2/${1##*/}" ] || cp "$1" "$2/"',
            '  [ -e "$2/train_meta.json" ] || cp "$(dirname "$1")/train_meta.json" "$2/"',
            "}",
        ]
    for n, run in enumerate(lin.order, 1):
        meta = lin.metas[run]
        old = rel_path(run, root)
        new = names[old]
        # The iteration each child reads stops the run after it (a folder: its last iteration).
        ends = {k + 1 if k is not None else int(meta["iterations_done"]) for k in lin.uses.get(run, [])}
        if n < from_step:
            lines += ["", f"# {n}. {old}: not retrained (--from-step {from_step}), its checkpoints copied in"]
            for end in sorted(ends):
                ckpt = f"{old}/model_{end - 1}.pt"
                if not (root / ckpt).exists():
                    lines.append(f"# {ckpt} is not here (not committed?): the reuse below stops; use a smaller --from-step")
                lines.append(f"reuse {shlex.quote(ckpt)} {shlex.quote(new)}")
            continue
        if n == len(lin.order):
            ends.add(last_end if last_end is not None else int(meta["iterations_done"]))
        lines += ["", f"# {n}. {old} ({meta.get('role')} / {meta.get('context')}), "
                      f"to iteration{'s' if len(ends) > 1 else ''} {', '.join(str(e) for e in sorted(ends))}"]
        source_metas = [lin.metas[p.resolve()] for _, src in sources(meta)
                        if (p := run_dir(src, root)) is not None]
        drift = config_drift(meta, source_metas)
        if drift:
            lines.append("# today's code resolves its last command otherwise than the run recorded:")
            lines += [f"#   {d}" for d in drift]
        restored = restored_settings(meta)
        if restored:
            lines.append("# trained here as it was then: " + ", ".join(f"{f} {v}" for f, v in restored))
        for cmd, stop in segments(meta, ends):
            raw = shlex.split(as_selfright(cmd))
            tokens = [moved(t, prev) for prev, t in zip(["", *raw], raw)]
            tokens = set_flag(tokens, "--iterations", [str(stop)])
            for flag, value in restored:
                tokens = set_flag(tokens, flag, [value])
            tokens = set_flag(tokens, "--train.keep-checkpoints", ["0"])  # every checkpoint a child reads stays
            recorded = recorded_validation(run, stop - 1)
            if recorded:
                lines.append(f"# the run recorded model_{stop - 1}.pt at {recorded} on validation; compare {new}/validation.csv")
            lines.append(f"step {shlex.quote(new)} {stop} {shlex.join(tokens)}")
    last = lin.metas[lin.order[-1]]
    final = f"{names[rel_path(lin.order[-1], root)]}/model_{(last_end or int(last['iterations_done'])) - 1}.pt"
    lines += ["", "# Score it as the model cards do (other seeds: --seed S), and pair it with the shipped one",
              "# on the same falls with selfright compare:",
              f"echo \"done: selfright evaluate --policy {final} --grid {last.get('context')} --episodes 64 --seed 0\" >&2"]
    return "\n".join(lines)


if __name__ == "__main__":
    main(tyro.cli(Args))
