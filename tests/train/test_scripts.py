"""The scripts in scripts/ run and print what their headers promise; the recipe
(``scripts/train_policies.sh``) parses as ``selfright train`` and resolves to the recorded
configuration of each shipped policy's run."""

from __future__ import annotations

import json
import os
import runpy
import shlex
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

REPO = Path(__file__).resolve().parents[2]
SCRIPTS = REPO / "scripts"


def run_script(name: str, args: list[str], monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(sys, "argv", [name, *args])
    runpy.run_path(str(SCRIPTS / name), run_name="__main__")


def test_factor_sweep_sets_walls_friction_and_compliance(tmp_path, monkeypatch, capsys):
    import json

    for factor, values, recorded in (("wall_gap_ratio", ["0", "2"], [None, 2.0]), ("friction", ["0.5"], [0.5]),
                                     ("ground_timeconst_s", ["0.05"], [0.05])):
        out = tmp_path / factor
        args = ["--policies", "zero", "--grid", "tiny", "--factor", factor, "--values", *values, "--episodes", "1",
                "--seeds", "0", "--out", str(out)]
        run_script("factor_sweep.py", args, monkeypatch)
        header = capsys.readouterr().out.splitlines()[1]
        label = {"wall_gap_ratio": "walls", "friction": "friction", "ground_timeconst_s": "ground"}[factor]
        assert header == "| policy | " + " | ".join(f"{label} {v}" for v in values) + " |"
        for v, want in zip(values, recorded):
            summary = json.loads((out / "zero" / f"{label}{v}" / "s0" / "summary.json").read_text())
            assert summary["config"]["eval"][factor] == want


def test_select_checkpoints_expands_runs_scores_each_once_and_ranks(tmp_path, monkeypatch, capsys):
    import shutil

    run = tmp_path / "runs" / "cand"
    run.mkdir(parents=True)
    src = Path("runs/incline_student_v1")  # committed: the shipped incline's run
    shutil.copy(src / "train_meta.json", run / "train_meta.json")
    for k in (0, 1, 2, 3):
        shutil.copy(src / "model_373.pt", run / f"model_{k}.pt")
    shutil.copy(src / "model_373.pt", run / "model_best.pt")
    mod = runpy.run_path(str(SCRIPTS / "select_checkpoints.py"))
    assert [p.name for p in mod["expand"]((run,), every=2)] == ["model_1.pt", "model_3.pt"]  # every 2nd and the last
    assert [p.name for p in mod["expand"]((run, run / "model_3.pt"), min_iteration=3)] == ["model_3.pt"]
    with pytest.raises(ValueError, match="numbered"):
        mod["expand"]((run / "model_best.pt",))
    out = tmp_path / "sel"
    args = [str(run / "model_2.pt"), str(run / "model_3.pt"), "--grid", "incline", "--seeds", "4",
            "--episodes", "1", "--threads", "1", "--out", str(out)]
    run_script("select_checkpoints.py", args, monkeypatch)
    first = capsys.readouterr().out
    assert "ranked on incline, seeds 4" in first and first.count("/    1  ") == 2
    summary = out / "cand_3" / "s4" / "summary.json"
    stamp = summary.stat().st_mtime_ns
    run_script("select_checkpoints.py", args, monkeypatch)  # a second call reads the results it left
    assert summary.stat().st_mtime_ns == stamp and capsys.readouterr().out == first


def test_remeasure_cards_rewrites_each_evaluated_cards_success_line(tmp_path, monkeypatch, capsys):
    import shutil

    from selfright.policies.registry import CHECKPOINT_DIR
    from selfright.train.ship import SUCCESS_PREFIX

    dest, evals = tmp_path / "checkpoints", tmp_path / "remeasure"
    dest.mkdir()
    shutil.copy(CHECKPOINT_DIR / "flat.md", dest / "flat.md")
    (evals / "flat").mkdir(parents=True)
    overall = {"n": 64, "successes": 48, "success_rate": 0.75, "success_ci95": [0.63, 0.84], "ttr_mean_s": 2.0,
               "dtr_mean_m": 0.5}
    (evals / "flat" / "summary.json").write_text(json.dumps(
        {"policy": "flat", "grid": "flat", "episodes_per_cell": 64, "seed": 0, "overall": overall,
         "machine": {"cpu": "Test CPU"}}))
    run_script("remeasure_cards.py", ["--evaluations", str(evals), "--why", "a change", "--dest", str(dest)], monkeypatch)
    assert capsys.readouterr().out.strip() == "re-measured: flat 75.0 %"
    card = (dest / "flat.md").read_text()
    assert "**75.0 %**" in next(x for x in card.splitlines() if x.startswith(SUCCESS_PREFIX)) and "*Before a change*" in card
    (evals / "rough").mkdir()
    (evals / "rough" / "summary.json").write_text("{}")
    with pytest.raises(SystemExit, match="no shipped policy 'rough'"):
        run_script("remeasure_cards.py", ["--evaluations", str(evals), "--why", "x", "--dest", str(dest)], monkeypatch)


def test_actor_to_run_makes_a_teacher_run_of_a_shipped_teacher(tmp_path, monkeypatch):
    import torch

    from selfright.policies.actor import actor_from_checkpoint, load_actor_file
    from selfright.policies.registry import shipped_path
    from selfright.policies.run_files import latest_checkpoint
    from selfright.train.config import PolicyConfig
    from selfright.train.runner import teacher_policy_config
    from selfright.train.ship import card_record

    out = tmp_path / "rough_teacher"
    run_script("actor_to_run.py", ["--policy", "rough-teacher", "--out", str(out)], monkeypatch)
    ckpt = latest_checkpoint(out)
    cfg, meta = teacher_policy_config(ckpt, PolicyConfig())
    assert meta["role"] == "teacher" and meta["context"] == "rough" and cfg.hidden_dims == (256, 128, 64)
    steps = card_record(shipped_path("rough-teacher").with_suffix(".md").read_text())["env_steps"]
    assert steps > 0 and meta["env_steps"] == steps
    back = actor_from_checkpoint(torch.load(ckpt, weights_only=True), meta["policy"])
    shipped = load_actor_file(shipped_path("rough-teacher"))
    assert all(torch.equal(a, b) for a, b in zip(back.state_dict().values(), shipped.state_dict().values()))
    with pytest.raises(SystemExit):  # a student cannot be a distillation teacher
        run_script("actor_to_run.py", ["--policy", "rough", "--out", str(tmp_path / "student")], monkeypatch)


def test_device_train_passes_flags_selfright_train_takes():
    """``device_train.sh`` builds one ``selfright train`` command; every flag it passes parses."""
    import re

    import tyro

    from selfright.train.commands import TrainArgs

    text = (SCRIPTS / "device_train.sh").read_text()
    call = text[text.index("python3 -m selfright.cli train"):].split(">>")[0]
    flags = re.findall(r"(--[a-z-]+) \"\$\{?(\w+)", call)
    assert {f for f, _ in flags} >= {"--role", "--context", "--out", "--envs", "--iterations", "--physics-threads", "--device"}
    args = {"--role": "student", "--context": "rough", "--out": "runs/x", "--envs": "8", "--iterations": "2",
            "--physics-threads": "1", "--torch-threads": "1", "--device": "cpu"}
    tyro.cli(TrainArgs, args=[t for f, _ in flags for t in (f, args[f])] + ["--teacher", "runs/t", "--resume"])


# --- scripts/train_policies.sh -------------------------------------------------------------

SHIPPED = {
    "flat-teacher": ("flat_teacher_v1_scratch", 1805),
    "flat": ("flat_student_v1", 1003),
    "rough-teacher": ("rough_teacher_v1", 3246),
    "rough": ("rough_student_v1", 332),
    "incline-teacher": ("incline_teacher_v1_goal", 842),
    "incline": ("incline_student_v1", 373),
}
"""Each shipped learned policy: its run in ``runs/`` (committed with its ``train_meta.json``) and
the iteration shipped."""

BOOKKEEPING = {"train_config.checkpoint_every_s", "train_config.keep_checkpoints", "train_config.validation.episodes",
               "train_config.validation.seed", "train_config.validation.grid"}
"""Recorded settings that do not change what a run learns (checkpoints and their validation)."""

ADDED_AS_BEFORE = {
    "train_config.episode.terminate_low_stance_s": 0.0,
    "train_config.episode.low_stance_leaky": False,
    "train_config.episode.curriculum": False,
    "train_config.episode.incline_curriculum_deg": (5.0, 10.0, 15.0, 20.0),  # these two act only with the curriculum
    "train_config.episode.curriculum_window_s": 1.0,
    "train_config.episode.off_tile_is_timeout": False,
    "train_config.episode.prepare_starts": False,
    "train_config.recenter_on_init": False,
    "train_config.randomization.sensor_noise": 0.0,
    "train_config.reward.goal_set": 0.0,
    "train_config.reward.bar_ramp": 0.0,
    "train_config.reward.bar_ramp_width_m": 0.1,  # these two act only with a bar-ramp weight
    "train_config.reward.bar_ramp_over_m": 0.02,
    "train_config.reward.feet_under_hips": 0.0,
    "benchmark_config.robot.motor": "ideal",
    "benchmark_config.robot.motor_speed_rad_s": None,
    "benchmark_config.robot.joint_stop_timeconst_s": 0.02,
    "benchmark_config.eval.sensor_noise": 0.0,
}
"""Settings added after a run's meta was written, with the value the code ran with before them."""

REMOVED_OFF = {
    "train_config.episode.restart_stuck": 0.0,
    "train_config.distillation.fallback_teacher": None,
    "train_config.distillation.stance_ramp_s": 0.0,
}
"""Recorded settings the train command has no option for (``git show 36476615:src/selfright/train/config.py``),
at the value that turns each off: a shipped run that recorded another could not be retrained."""

NOT_SETTABLE: dict[str, set[str]] = {}
"""Where a recipe command cannot reproduce its run's recorded configuration: settings that are no
longer options (the recipe's header says so)."""


def recipe(stage: str, root: Path, env: dict[str, str] | None = None) -> list[str]:
    """What ``train_policies.sh STAGE`` runs, one command a line (its ``SELFRIGHT_DRY_RUN``)."""
    done = subprocess.run(["bash", str(SCRIPTS / "train_policies.sh"), stage], capture_output=True, text=True, check=True,
                          env={**os.environ, "SELFRIGHT_DRY_RUN": "1", "ROOT": str(root), **(env or {})})
    return done.stdout.splitlines()


def train_commands(lines: list[str]) -> list[list[str]]:
    """The arguments after ``selfright train`` of each training command."""
    return [shlex.split(line)[2:] for line in lines if line.startswith("selfright train ")]


def parse_train(args: list[str]):
    import tyro

    from selfright.train.commands import TrainArgs

    return tyro.cli(TrainArgs, args=args)


def flat_dict(d: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """``{"a": {"b": 1}}`` → ``{"a.b": 1}``, lists as tuples."""
    out: dict[str, Any] = {}
    for k, v in d.items():
        if isinstance(v, dict):
            out.update(flat_dict(v, f"{prefix}{k}."))
        else:
            out[f"{prefix}{k}"] = tuple(v) if isinstance(v, list) else v
    return out


def resolved(args) -> dict[str, Any]:
    """The train and benchmark configurations ``selfright train`` builds from ``args``, keyed as
    a run meta records them, flattened."""
    from selfright.config import to_dict
    from selfright.train.commands import bench_config

    return {**flat_dict(to_dict(args.train), "train_config."), **flat_dict(to_dict(bench_config(args)), "benchmark_config.")}


def runs_of(commands: list[list[str]], root: Path) -> dict[str, list]:
    """Each run folder's parsed commands, in order, by the run's name under ``root``."""
    out: dict[str, list] = {}
    for args in commands:
        a = parse_train(args)
        assert a.out.parent == root, a.out
        out.setdefault(a.out.name, []).append(a)
    return out


def test_every_recipe_command_parses_as_selfright_train(tmp_path):
    root = tmp_path / "retrain"
    lines = recipe("all", root)
    commands = train_commands(lines)
    assert len(commands) == 7  # one a run
    runs = runs_of(commands, root)
    assert len(runs) == 7
    for stage in ("flat-teacher", "flat", "rough-teacher", "rough", "incline-teacher", "incline"):
        assert set(recipe(stage, root)) <= set(lines), stage
    failed = subprocess.run(["bash", str(SCRIPTS / "train_policies.sh"), "ship"], capture_output=True, text=True)
    assert failed.returncode == 2 and "usage:" in failed.stderr


def test_the_recipe_trains_each_checkpoint_a_later_run_reads_and_ships_the_six(tmp_path):
    """Every checkpoint a run starts from (``--init-from``) or is taught by (``--teacher``) is
    the last one an earlier run of the recipe writes; the six shipped checkpoints are the last of
    their runs, evaluated and shipped."""
    root = tmp_path / "retrain"
    lines = recipe("all", root)
    written: dict[Path, int] = {}
    for args in train_commands(lines):
        a = parse_train(args)
        for src in (a.init_from, a.teacher):
            if src is None:
                continue
            assert written.get(Path(src).parent) == int(Path(src).stem.removeprefix("model_")), (a.out, src)
        written[a.out] = a.iterations - 1
    shipped = [shlex.split(line) for line in lines if line.startswith("selfright ship ")]
    assert {(s[s.index("--name") + 1], s[s.index("--run") + 1]) for s in shipped} == {
        (name, str(root / run / f"model_{it}.pt")) for name, (run, it) in SHIPPED.items()}
    assert all(written[root / run] == it for run, it in SHIPPED.values())
    evaluated = [shlex.split(line) for line in lines if line.startswith("selfright evaluate ")]
    assert len(evaluated) == 6 and all(
        e[e.index("--episodes") + 1] == "256" and e[e.index("--seed") + 1] == "1000" for e in evaluated)


@pytest.mark.parametrize("name", sorted(SHIPPED))
def test_the_recipe_resolves_to_the_recorded_configuration_of_each_shipped_run(name, tmp_path):
    """The recipe's last command of a shipped policy's run builds the training and benchmark
    configuration its ``train_meta.json`` records (bookkeeping aside; settings added since at
    the value the code had before them; recorded settings without an option ignored),
    with its role, context, seed, envs and sources."""
    run, _ = SHIPPED[name]
    meta = json.loads((REPO / "runs" / run / "train_meta.json").read_text())
    root = tmp_path / "retrain"
    runs = runs_of(train_commands(recipe("all", root)), root)
    first, last = runs[run][0], runs[run][-1]
    assert (last.role, last.context, last.seed, last.envs) == (meta["role"], meta["context"], meta["seed"], meta["num_envs"])

    def moved(path: str | None) -> str | None:  # a recorded runs/RUN/model_K.pt, retrained under root
        return None if path is None else str(root / Path(path).relative_to("runs"))

    assert (str(first.init_from) if first.init_from else None) == moved(meta.get("init_from"))
    assert (str(last.teacher) if last.teacher else None) == moved(meta.get("teacher"))

    now = resolved(last)  # what the code still has: a recorded setting without an option is left out
    recorded = flat_dict({"train_config": meta["train_config"], "benchmark_config": meta["benchmark_config"]})
    assert not meta.get("labels_from_student")  # taught by a teacher, not by a student
    assert all(recorded.get(k, off) == off for k, off in REMOVED_OFF.items()), {k: recorded.get(k) for k in REMOVED_OFF}
    if recorded.get("benchmark_config.robot.motor") == "envelope":
        # incline's two student runs recorded an approximation of the DC motors (the ideal servos
        # with the targets held to their torque-speed limit), not an option any more: the recipe
        # trains them with the DC motors themselves (the header of the recipe's incline stage)
        recorded["benchmark_config.robot.motor"] = "dcmotor"
    if "benchmark_version" not in meta:
        # a run of benchmark version 0 measured the trunk's height over the terrain beneath it; the
        # recipe trains under the current version, whose goal set and reward read it over the feet
        recorded["benchmark_config.goal.height_ref"] = now["benchmark_config.goal.height_ref"]
    skip = BOOKKEEPING | ({k for k in now if k.startswith("train_config.distillation.")} if meta["role"] == "teacher" else set())
    differ = {k for k, v in now.items()
              if k not in skip and recorded.get(k, ADDED_AS_BEFORE.get(k, "not recorded")) != v}
    assert differ == NOT_SETTABLE.get(run, set()), {k: (recorded.get(k, ADDED_AS_BEFORE.get(k)), now[k]) for k in differ}


FAKE_SELFRIGHT = r'''#!/usr/bin/env bash
# Stands in for `selfright`: logs its arguments; `train` checks that what it reads exists and
# writes the checkpoint a run with --iterations N ends with (model_<N-1>.pt).
set -eu
echo "$*" >> "$LOG"
[ "$1" = train ] || exit 0
out= its= resume=0 prev=
for a in "$@"; do
  case $prev in
    --out) out=$a ;;
    --iterations) its=$a ;;
    --init-from|--teacher) [ -e "$a" ] || { echo "missing $a" >&2; exit 1; } ;;
  esac
  [ "$a" = --resume ] && resume=1
  prev=$a
done
if [ $resume = 1 ]; then ls "$out"/model_*.pt > /dev/null; fi
mkdir -p "$out"
touch "$out/model_$((its - 1)).pt" "$out/train_meta.json"
'''


def test_the_recipe_resumes_and_skips_what_is_done(tmp_path):
    """Run for real against a stand-in ``selfright``: a second call trains nothing, and a run
    cut short goes on from its latest checkpoint (``--resume``, without ``--init-from``)."""
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    (bin_dir / "selfright").write_text(FAKE_SELFRIGHT)
    (bin_dir / "selfright").chmod(0o755)
    log, root = tmp_path / "calls.log", tmp_path / "retrain"
    env = {**os.environ, "PATH": f"{bin_dir}:{os.environ['PATH']}", "LOG": str(log), "ROOT": str(root),
           "EXTRA": "--physics-threads 1"}

    def replay() -> list[str]:
        before = log.read_text().splitlines() if log.exists() else []
        subprocess.run(["bash", str(SCRIPTS / "train_policies.sh"), "flat"], env=env, check=True, capture_output=True)
        return [c for c in log.read_text().splitlines()[len(before):] if c.startswith("train ")]

    calls = replay()
    assert len(calls) == 2 and all(c.endswith("--physics-threads 1") and "--resume" not in c for c in calls)
    assert f"--out {root}/flat_teacher_v1_scratch --iterations 1806 " in calls[0]
    assert f"--out {root}/flat_student_v1 --iterations 1004 " in calls[1]
    assert f"--teacher {root}/flat_teacher_v1_scratch/model_1805.pt" in calls[1]
    assert (root / "flat_student_v1" / "model_1003.pt").exists()
    assert replay() == []
    (root / "flat_student_v1" / "model_1003.pt").unlink()
    (root / "flat_student_v1" / "model_120.pt").touch()  # a run stopped after a timed checkpoint
    calls = replay()
    assert len(calls) == 1 and f"--out {root}/flat_student_v1 " in calls[0] and calls[0].count("--resume") == 1
    assert "--init-from" not in calls[0]


def test_train_throughput_benchmark_prints_a_scaling_line(monkeypatch, capsys):
    import json

    monkeypatch.setattr(sys, "argv", ["train_throughput.py", "--envs", "4", "--threads", "1", "2", "--steps", "3",
                                      "--contexts", "flat", "--loop-context", "flat", "--loop-envs", "4"])
    runpy.run_path(str(SCRIPTS.parent / "benchmarks" / "train_throughput.py"), run_name="__main__")
    rows = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [r.get("threads") for r in rows[1:3]] == [1, 2]
    assert all(r["env_steps_per_s"] > 0 and r["reset_ms_per_episode"] > 0 for r in rows[1:3])
    assert rows[3]["context"] == "flat" and rows[3]["scaling"] > 0
    loops = [r for r in rows if "loop" in r]
    assert [(r["threads"], r.get("prepare_starts")) for r in loops] == [
        (1, False), (1, True), (1, None), (2, False), (2, True), (2, None)]
    assert all(r["speedup"] > 0 for r in loops if "speedup" in r)


def test_policy_forward_benchmark_prints_both_timings(monkeypatch, capsys):
    import json

    monkeypatch.setattr(sys, "argv", ["policy_forward.py", "--batches", "3", "64", "--seconds", "0.2"])
    runpy.run_path(str(SCRIPTS.parent / "benchmarks" / "policy_forward.py"), run_name="__main__")
    rows = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [r["batch"] for r in rows] == [3, 64]
    assert all(r["forward_us"] > 0 and r["forward_rows_us"] > 0 for r in rows)
    assert rows[1]["env_step_us_64_envs"] > 0 and "extra_share_of_env_step" in rows[1]


@pytest.mark.slow
def test_mjx_throughput_benchmark_runs_where_jax_is_installed(monkeypatch, capsys):
    """The MJX planning benchmark (optional deps: jax, mujoco-mjx; ~2 min of compiling on CPU)."""
    import json

    pytest.importorskip("jax")
    pytest.importorskip("mujoco.mjx")
    monkeypatch.setattr(sys, "argv", ["mjx_throughput.py", "--envs", "2", "--steps", "1", "--threads", "1"])
    runpy.run_path(str(SCRIPTS.parent / "benchmarks" / "mjx_throughput.py"), run_name="__main__")
    rows = [json.loads(line) for line in capsys.readouterr().out.splitlines() if line.startswith("{")]
    assert rows[1]["context"] == "flat" and rows[1]["mjx_nonfinite_envs"] == 0
    assert rows[1]["mjx_physics_steps_per_s"] > 0 and rows[1]["mean_abs_dz_m"] < 0.05


def test_check_replays_measures_a_success_over_its_feet_with_mujoco_alone(tmp_path, capsys):
    """A replayed success of the shipped `flat` passes the 0.32 m bar through its hold, measured
    from its trajectory.npz and scene.xml; the same record under a 1 m bar fails with exit 1."""
    from selfright.config import BenchmarkConfig
    from selfright.evaluate.replay import replay_episode, select_cell, write_replay
    from selfright.policies.registry import make_policy

    cfg = BenchmarkConfig()
    r = replay_episode(make_policy("flat", cfg), cfg, select_cell("flat", cfg, None, None), 0, seed=1000)
    assert r.success  # episode 0 of seed 1000 gets up (the card's evaluation)
    write_replay(tmp_path / "r", r, {"policy": "flat", "grid": "flat", "seed": 1000}, cfg)
    check = runpy.run_path(str(SCRIPTS / "check_replays.py"))
    meta, heights = check["hold_heights"](tmp_path / "r")
    assert len(heights) == round(cfg.goal.hold_s / cfg.sim.control_dt_s)
    # selfright's record of the hold agrees with MuJoCo's positions; it reads the kinematics that
    # mj_step computed before its last integration, one physics step (a fraction of a mm) earlier
    assert heights.min() == pytest.approx(meta["hold_min_height_over_feet_m"], abs=2e-3)
    assert check["main"]([str(tmp_path / "r")]) == 0 and "ok" in capsys.readouterr().out
    assert check["main"]([str(tmp_path / "r"), "--bar-m", "1.0"]) == 1
