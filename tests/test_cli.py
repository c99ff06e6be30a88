import json
import os
import subprocess
import sys

import mujoco

from selfright.cli import main


def run_cli(args, capsys):
    code = main(args)
    return code, capsys.readouterr()


def assert_clean_error(code, cap, fragment):
    assert code == 2
    lines = [l for l in cap.err.strip().splitlines() if l]
    assert len(lines) == 1 and lines[0].startswith("selfright: error:") and fragment in lines[0]


def test_unknown_policy(tmp_path, capsys):
    code, cap = run_cli(["evaluate", "--policy", "nope", "--grid", "tiny", "--out", str(tmp_path / "o")], capsys)
    assert_clean_error(code, cap, "unknown policy")
    assert not (tmp_path / "o" / "run.json").exists()


def test_missing_and_corrupt_policy_files(tmp_path, capsys):
    code, cap = run_cli(["evaluate", "--policy", str(tmp_path / "missing.onnx"), "--grid", "tiny", "--out", str(tmp_path / "o")], capsys)
    assert_clean_error(code, cap, "does not exist")
    bad = tmp_path / "bad.pt"
    bad.write_bytes(b"not a checkpoint")
    code, cap = run_cli(["evaluate", "--policy", str(bad), "--grid", "tiny", "--out", str(tmp_path / "o")], capsys)
    assert code == 2 and cap.err.startswith("selfright: error:")
    assert not (tmp_path / "o" / "episodes.csv").exists()


def test_unknown_grid_exits_2(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "selfright.cli", "evaluate", "--grid", "huge", "--out", str(tmp_path)],
                          capture_output=True, text=True)
    assert proc.returncode == 2 and "huge" in proc.stderr


def test_unwritable_out(tmp_path, capsys):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    if os.access(ro, os.W_OK):  # running as root: permissions do not bind, use a file as the parent
        blocker = tmp_path / "file"
        blocker.write_text("x")
        target = blocker / "out"
    else:
        target = ro / "out"
    code, cap = run_cli(["evaluate", "--policy", "zero", "--grid", "tiny", "--out", str(target)], capsys)
    assert_clean_error(code, cap, "cannot write")


def test_out_of_range_level(tmp_path, capsys):
    code, cap = run_cli(["scene", "--slope-level", "11", "--out", str(tmp_path / "s.xml")], capsys)
    assert_clean_error(code, cap, "out of range")


def test_scene_export_loads(tmp_path, capsys):
    out = tmp_path / "scene.xml"
    code, cap = run_cli(["scene", "--slope-level", "3", "--roughness-level", "5", "--out", str(out), "--wall-gap-ratio", "1.5"], capsys)
    assert code == 0
    m = mujoco.MjModel.from_xml_path(str(out))
    assert m.body("trunk").id > 0 and m.nu == 12
    d = mujoco.MjData(m)
    mujoco.mj_step(m, d)


def test_bench_sim_prints_json(capsys):
    code, cap = run_cli(["bench-sim", "--envs", "4", "--seconds", "0.3"], capsys)
    assert code == 0
    rec = json.loads(cap.out.strip().splitlines()[-1])
    assert {"env_steps_per_s", "physics_steps_per_env_step", "num_envs", "backend", "threads"} <= set(rec)
    assert rec["num_envs"] == 4 and rec["env_steps_per_s"] > 0


def test_evaluate_end_to_end_with_plots(tmp_path, capsys):
    out = tmp_path / "ev"
    code, cap = run_cli(["evaluate", "--policy", "open-loop", "--grid", "tiny", "--episodes", "1", "--episode-s", "1",
                         "--out", str(out), "--no-progress"], capsys)
    assert code == 0, cap.err
    for name in ("episodes.csv", "summary.json", "success.png", "ttr.png", "dtr.png", "ttr_hist.png", "dtr_hist.png"):
        assert (out / name).stat().st_size > 0
    assert "overall:" in cap.out


def test_action_reference_must_match_the_policy(tmp_path, capsys):
    code, cap = run_cli(["evaluate", "--policy", "flat", "--grid", "tiny", "--episodes", "1", "--action-reference", "current",
                         "--out", str(tmp_path / "o")], capsys)
    assert_clean_error(code, cap, "--action-reference tall")


def test_student_must_use_its_teachers_action_reference(tmp_path, capsys):
    from pathlib import Path

    teacher = Path(__file__).resolve().parent.parent / "runs" / "flat_teacher_v1_scratch"  # committed, a tall-reference run
    code, cap = run_cli(["train", "--role", "student", "--context", "flat", "--teacher", str(teacher),
                         "--out", str(tmp_path / "s"), "--envs", "2", "--iterations", "1", "--action-reference", "stand"],
                        capsys)
    assert_clean_error(code, cap, "--action-reference tall")


def test_evaluate_with_dc_motors_records_the_motor_model(tmp_path, capsys):
    out = tmp_path / "dc"
    code, cap = run_cli(["evaluate", "--policy", "flat", "--grid", "flat", "--episodes", "1", "--episode-s", "1",
                         "--motor", "dcmotor", "--out", str(out), "--no-progress", "--no-plots"], capsys)
    assert code == 0, cap.err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["config"]["robot"]["motor"] == "dcmotor" and summary["machine"]["cores"] >= 1 and len(summary["machine"]["date"]) == 10




def test_goal_height_reference_option_is_recorded(tmp_path, capsys):
    out = tmp_path / "terrain"
    code, cap = run_cli(["evaluate", "--policy", "zero", "--grid", "flat", "--episodes", "1", "--episode-s", "0.2",
                         "--goal-height-ref", "terrain", "--out", str(out), "--no-progress", "--no-plots"], capsys)
    assert code == 0, cap.err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["config"]["goal"]["height_ref"] == "terrain" and summary["benchmark_version"] == 1


def test_resuming_results_of_another_benchmark_version_is_refused(tmp_path, capsys):
    out = tmp_path / "old"
    out.mkdir()
    (out / "run.json").write_text(json.dumps({"policy": "zero", "grid": "flat", "episodes_per_cell": 1, "seed": 0}))
    code, cap = run_cli(["evaluate", "--policy", "zero", "--grid", "flat", "--episodes", "1", "--out", str(out),
                         "--no-progress", "--no-plots"], capsys)
    assert_clean_error(code, cap, f"{out} holds results of benchmark version 0; this is version 1: use a fresh --out directory")
    assert not (out / "episodes.csv").exists()
