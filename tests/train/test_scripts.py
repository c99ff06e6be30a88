"""The diagnostic scripts run and print what their docs promise."""

from __future__ import annotations

import runpy
import sys
from pathlib import Path

import numpy as np
import pytest

SCRIPTS = Path(__file__).resolve().parents[2] / "scripts"


def run_script(name: str, args: list[str], monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(sys, "argv", [name, *args])
    runpy.run_path(str(SCRIPTS / name), run_name="__main__")


def episode_rows(out: Path) -> list[tuple[str, str, str, str]]:
    """(episode, success, TTR, energy) of each row of an evaluation's ``episodes.csv``."""
    import csv

    with (out / "episodes.csv").open() as fh:
        return [(r["episode"], r["success"], r["ttr_s"], r["energy_j"]) for r in csv.DictReader(fh)]




def test_rough_ceiling_is_a_fraction_per_tile(monkeypatch, capsys):
    run_script("rough_ceiling.py", ["--grid", "rough", "--samples", "500", "--heights", "0.35", "0.7"], monkeypatch)
    out = capsys.readouterr().out.splitlines()
    rows = [line.split() for line in out if line.strip().startswith("0 ")]
    assert len(rows) == 3
    for row in rows:  # slope, level, extent, h=0.35, h=0.7, offset spread, R² of the feet
        low, high = (float(v.rstrip("%")) for v in row[3:5])
        assert 0.0 <= low <= high == 100.0  # 0.7 m minus the largest extent (0.32 m) still clears 0.32 m
        assert float(row[5]) > 0.0 and -0.05 <= float(row[6]) <= 1.0
    (mean,) = [line.split() for line in out if line.strip().startswith("grid mean")]
    assert float(mean[2].rstrip("%")) == pytest.approx(np.mean([float(r[3].rstrip("%")) for r in rows]), abs=0.06)


















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












def _student_checkpoint(gen, mean_shift: float) -> dict:
    import torch

    dims = (42, 16, 12)
    sd = {"obs_normalizer._mean": torch.randn(1, dims[0], generator=gen) + mean_shift,
          "obs_normalizer._std": torch.rand(1, dims[0], generator=gen) + 0.5,
          "obs_normalizer.count": torch.tensor(10), "distribution.std_param": torch.full((12,), 0.1)}
    sd["obs_normalizer._var"] = sd["obs_normalizer._std"] ** 2
    for i, (d_in, d_out) in enumerate(zip(dims[:-1], dims[1:])):
        sd[f"mlp.{2 * i}.weight"] = torch.randn(d_out, d_in, generator=gen) * 0.3
        sd[f"mlp.{2 * i}.bias"] = torch.randn(d_out, generator=gen) * 0.1
    return {"student_state_dict": sd, "iter": 0}








def tiny_checkpoint(tmp_path: Path) -> Path:
    """A one-layer PPO teacher checkpoint with a state-independent std of 0.3."""
    import torch

    ckpt = tmp_path / "run" / "model_0.pt"
    ckpt.parent.mkdir()
    g = torch.Generator().manual_seed(0)
    torch.save({"actor_state_dict": {"mlp.0.weight": 0.1 * torch.randn(12, 79, generator=g), "mlp.0.bias": torch.zeros(12),
                                     "distribution.std_param": torch.full((12,), 0.3)}, "iter": 0, "infos": {}}, ckpt)
    return ckpt






















def test_lineage_lists_every_run_a_policy_descends_from_oldest_first(tmp_path, monkeypatch, capsys):
    import json

    def meta(name: str, **kw) -> None:
        (tmp_path / "runs" / name).mkdir(parents=True)
        m = {"role": "teacher", "context": "incline", "iterations_done": 10, "env_steps": 1000, "wall_clock_s": 360.0,
             "command_lines": [f"/venv/bin/selfright train --out runs/{name} "], "command_devices": ["cpu"], **kw}
        (tmp_path / "runs" / name / "train_meta.json").write_text(json.dumps(m))

    meta("base")
    meta("escape", init_from="runs/base/model_9.pt")
    meta("student", role="student", teacher="runs/base/model_5.pt",
         train_config={"distillation": {"fallback_teacher": "runs/escape/model_3.pt"}, "episode": {}})
    meta("stance", role="student", teacher="runs/student/model_9.pt")
    run_script("lineage.py", ["--run", "runs/stance", "--root", str(tmp_path)], monkeypatch)
    out = capsys.readouterr().out
    heads = [line.split(":")[0] for line in out.splitlines() if line[:1].isdigit() and ". runs/" in line]
    assert heads == ["1. runs/base", "2. runs/escape", "3. runs/student", "4. runs/stance"]
    assert "from fallback teacher runs/escape (uses model_3.pt)" in out
    assert "$ selfright train --out runs/base" in out
    assert out.rstrip().endswith("4 runs, 4,000 env steps, 0.40 h of training in all "
                                 "(runs that went on past the checkpoint used count in full)")


def test_lineage_of_each_shipped_policy_but_the_renamed_flat_teacher_starts_at_a_committed_run(monkeypatch, capsys):
    from selfright.policies.registry import CHECKPOINT_DIR

    for card in sorted(CHECKPOINT_DIR.glob("*.md")):
        if card.stem == "flat-teacher":  # its run folder became runs/flat_teacher_best; the error names it
            with pytest.raises(SystemExit, match="flat_teacher_best"):
                run_script("lineage.py", ["--policy", card.stem], monkeypatch)
            continue
        run_script("lineage.py", ["--policy", card.stem], monkeypatch)
        assert " runs, " in capsys.readouterr().out.splitlines()[-1], card.stem






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


FAKE_TRAIN = r'''#!/usr/bin/env bash
# A stand-in for `selfright train`: logs its arguments, checks that what it reads exists, and
# writes the checkpoint a run with --iterations N ends with (model_<N-1>.pt).
set -eu
echo "$*" >> "$LOG"
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
touch "$out/model_$((its - 1)).pt"
'''


def fake_lineage(tmp_path, monkeypatch, capsys, *args: str):
    """Four fake runs under ``tmp_path/runs`` (base → escape, base + escape → student →
    stance) and the ``lineage.py --script`` of the last, written to ``retrain.sh``."""
    import json

    def meta(name: str, cmds: list[str], starts: list[int], done: int, **kw) -> None:
        (tmp_path / "runs" / name).mkdir(parents=True)
        m = {"role": "teacher", "context": "incline", "iterations_done": done, "env_steps": 10, "wall_clock_s": 1.0,
             "command_lines": [f"/venv/bin/selfright train --out runs/{name} {c}" for c in cmds],
             "command_start_iterations": starts, **kw}
        (tmp_path / "runs" / name / "train_meta.json").write_text(json.dumps(m))

    teacher = "--role teacher --context incline --iterations 100000"
    meta("base", [teacher, teacher + " --resume --train.ppo.desired-kl 0.005"], [0, 4], 12)
    meta("escape", [teacher + " --init-from runs/base/model_9.pt"], [0], 8, init_from="runs/base/model_9.pt")
    student = "--role student --context incline --iterations 300 --teacher runs/base/model_5.pt"
    meta("student", [student + " --train.distillation.fallback-teacher runs/escape/model_3.pt"], [0], 300,
         role="student", teacher="runs/base/model_5.pt",
         train_config={"distillation": {"fallback_teacher": "runs/escape/model_3.pt"}, "episode": {}})
    meta("stance", ["--role student --context incline --iterations 10 --teacher runs/student/model_9.pt"], [0], 10,
         role="student", teacher="runs/student/model_9.pt")
    run_script("lineage.py", ["--run", "runs/stance", "--root", str(tmp_path), "--script", *args], monkeypatch)
    script = tmp_path / "retrain.sh"
    script.write_text(capsys.readouterr().out)
    return script


def fake_selfright(tmp_path) -> dict[str, str]:
    """The environment that puts ``FAKE_TRAIN`` first on the PATH as ``selfright``, logging to
    ``tmp_path/calls.log``."""
    import os

    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    (bin_dir / "selfright").write_text(FAKE_TRAIN)
    (bin_dir / "selfright").chmod(0o755)
    return {**os.environ, "PATH": f"{bin_dir}:{os.environ['PATH']}", "LOG": str(tmp_path / "calls.log")}


def test_lineage_script_retrains_every_run_to_the_checkpoints_its_children_read_and_resumes(tmp_path, monkeypatch, capsys):
    """``lineage.py --script``: each invocation stops where the next began and where a child
    reads a checkpoint, the runs land under the prefix with their sources' paths rewritten, a
    rerun skips what is done, and a step with an earlier checkpoint goes on with --resume (its
    --init-from dropped)."""
    import subprocess

    script = fake_lineage(tmp_path, monkeypatch, capsys)
    steps = [line.split()[1:3] for line in script.read_text().splitlines() if line.startswith("step ")]
    assert steps == [["runs/retrain/base", "4"], ["runs/retrain/base", "6"], ["runs/retrain/base", "10"],
                     ["runs/retrain/escape", "4"], ["runs/retrain/student", "10"], ["runs/retrain/stance", "10"]]
    assert "train_config: " in script.read_text()  # the metas record no configuration: all of today's is new

    log = tmp_path / "calls.log"
    env = {**fake_selfright(tmp_path), "EXTRA": "--physics-threads 2"}

    def replay() -> list[str]:
        before = log.read_text().splitlines() if log.exists() else []
        subprocess.run(["bash", str(script)], cwd=tmp_path, env=env, check=True, capture_output=True)
        return log.read_text().splitlines()[len(before):]

    calls = replay()
    assert len(calls) == 6
    assert "--out runs/retrain/base" in calls[0] and "--iterations 4 " in calls[0] and "--resume" not in calls[0]
    assert "desired-kl 0.005" in calls[1] and calls[1].count("--resume") == 1 and "--iterations 6 " in calls[1]
    assert "--iterations 10 " in calls[2]
    assert "--init-from runs/retrain/base/model_9.pt" in calls[3]
    assert "--teacher runs/retrain/base/model_5.pt" in calls[4] and "fallback-teacher runs/retrain/escape/model_3.pt" in calls[4]
    assert all(c.endswith("--physics-threads 2") and "--train.keep-checkpoints 0" in c for c in calls)
    assert all((tmp_path / "runs/retrain" / r / f"model_{k}.pt").exists()
               for r, k in [("base", 5), ("base", 9), ("escape", 3), ("student", 9), ("stance", 9)])

    assert replay() == []  # everything is there
    (tmp_path / "runs/retrain/escape/model_3.pt").unlink()
    (tmp_path / "runs/retrain/escape/model_1.pt").touch()  # a run killed after a timed checkpoint
    calls = replay()
    assert len(calls) == 1 and "--out runs/retrain/escape" in calls[0]
    assert "--init-from" not in calls[0] and calls[0].count("--resume") == 1


def test_lineage_script_from_a_later_step_copies_the_earlier_runs_checkpoints_in(tmp_path, monkeypatch, capsys):
    """``--from-step 3``: the first two runs are not retrained; the checkpoints the later runs
    read from them are copied from the committed runs (with their metas), and the script stops
    with a clear message where one is missing."""
    import subprocess

    script = fake_lineage(tmp_path, monkeypatch, capsys, "--from-step", "3")
    text = script.read_text()
    steps = [line.split()[1:3] for line in text.splitlines() if line.startswith("step ")]
    assert steps == [["runs/retrain/student", "10"], ["runs/retrain/stance", "10"]]
    assert "# runs/escape/model_3.pt is not here" in text  # said when the script is written, too
    assert [line.split()[1:] for line in text.splitlines() if line.startswith("reuse ")] == [
        ["runs/base/model_5.pt", "runs/retrain/base"], ["runs/base/model_9.pt", "runs/retrain/base"],
        ["runs/escape/model_3.pt", "runs/retrain/escape"]]
    env = fake_selfright(tmp_path)
    failed = subprocess.run(["bash", str(script)], cwd=tmp_path, env=env, capture_output=True, text=True)
    assert failed.returncode != 0 and "runs/base/model_5.pt is not here" in failed.stderr
    for ckpt in ["base/model_5.pt", "base/model_9.pt", "escape/model_3.pt"]:
        (tmp_path / "runs" / ckpt).write_text(ckpt)
    subprocess.run(["bash", str(script)], cwd=tmp_path, env=env, check=True, capture_output=True)
    calls = (tmp_path / "calls.log").read_text().splitlines()
    assert len(calls) == 2 and "--teacher runs/retrain/base/model_5.pt" in calls[0]
    assert (tmp_path / "runs/retrain/escape/model_3.pt").read_text() == "escape/model_3.pt"
    assert (tmp_path / "runs/retrain/base/train_meta.json").exists()
    with pytest.raises(SystemExit, match="runs 1 to 4"):
        fake_lineage(tmp_path / "again", monkeypatch, capsys, "--from-step", "5")


def test_lineage_script_of_the_shipped_incline_reads_its_own_checkpoints_and_says_what_changed_since(monkeypatch, capsys):
    """The replay of ``incline`` ends at the shipped iteration, and its first run, trained
    before the hard joint stops, is replayed with the softer stops it had."""
    run_script("lineage.py", ["--policy", "incline", "--script"], monkeypatch)
    out = capsys.readouterr().out
    steps = [line.split()[1:3] for line in out.splitlines() if line.startswith("step ")]
    assert steps[-1] == ["runs/retrain/incline_h25_sel31_479_stance03", "340"]  # iteration 339, the shipped one
    assert "--teacher runs/retrain/incline_dc_teacher_e512/model_395.pt" in out
    first = next(line for line in out.splitlines() if line.startswith("step runs/retrain/incline_scratch_narrow "))
    assert first.endswith("--joint-stop-timeconst-s 0.02")  # trained before the hard stops, and replayed so
    assert "robot.joint_stop_timeconst_s" not in out


def test_lineage_drift_check_resolves_a_command_as_selfright_train_does():
    """The configuration ``lineage.py`` compares with a run's record is the one ``selfright
    train`` builds from the same command (``train.commands.bench_config``), e.g. the stiffness
    of the joint stops, which runs before 2026-12-04 trained softer."""
    lineage = runpy.run_path(str(Path(__file__).resolve().parents[2] / "scripts" / "lineage.py"), run_name="lineage")
    cmd = "/venv/bin/selfright train --out runs/x --motor dcmotor --joint-stop-timeconst-s 0.02 --train.ppo.desired-kl 0.005"
    got = lineage["resolved_configs"](cmd)
    assert got["benchmark_config"]["robot.joint_stop_timeconst_s"] == 0.02
    assert got["benchmark_config"]["robot.motor"] == "dcmotor"
    assert got["train_config"]["ppo.desired_kl"] == 0.005
    meta = {"command_lines": [cmd], "benchmark_config": {"robot": {"motor": "ideal"}}, "train_config": {}}
    assert 'benchmark_config.robot.motor: recorded "ideal", now "dcmotor"' in lineage["config_drift"](meta, [])
    assert lineage["restored_settings"](meta) == [("--joint-stop-timeconst-s", "0.02")]
    meta["benchmark_config"]["robot"]["joint_stop_timeconst_s"] = 0.01
    assert lineage["restored_settings"](meta) == []


def test_lineage_drift_check_passes_over_settings_added_with_the_value_older_runs_had():
    """A run recorded before ``robot.motor`` existed ran the ideal servos: resolving to them
    today is not drift, resolving to the DC motors is."""
    lineage = runpy.run_path(str(Path(__file__).resolve().parents[2] / "scripts" / "lineage.py"), run_name="lineage")
    meta = {"command_lines": ["selfright train --out runs/x"], "benchmark_config": {"robot": {}}, "train_config": {}}
    drift = lineage["config_drift"](meta, [])
    assert not any("robot.motor" in line for line in drift), drift
    meta["command_lines"] = ["selfright train --out runs/x --motor dcmotor"]
    drift = lineage["config_drift"](meta, [])
    assert 'benchmark_config.robot.motor: not recorded (before it existed), now "dcmotor"' in drift
    assert not any("motor_speed_rad_s" in line for line in drift), drift






def test_select_checkpoints_expands_runs_scores_each_once_and_ranks(tmp_path, monkeypatch, capsys):
    import shutil

    run = tmp_path / "runs" / "cand"
    run.mkdir(parents=True)
    src = Path("runs/incline_h25_sel31_479_stance03")  # committed: the shipped incline's run
    shutil.copy(src / "train_meta.json", run / "train_meta.json")
    for k in (0, 1, 2, 3):
        shutil.copy(src / "model_339.pt", run / f"model_{k}.pt")
    shutil.copy(src / "model_339.pt", run / "model_best.pt")
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
