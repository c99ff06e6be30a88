"""The policies shipped inside the package: they load weights-only, act, export to ONNX with
the same outputs, carry a model card, and ``sr`` multiplexes the three students."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import torch

from selfright.config import BenchmarkConfig
from selfright.policies.actor import export_onnx, load_actor_file
from selfright.policies.learned import load_policy_file
from selfright.policies.multiplexer import CONTEXTS, cell_context, sr_context
from selfright.policies.registry import CHECKPOINT_DIR, make_policy
from selfright.terrain import grid_cells

SHIPPED = sorted(p.stem for p in CHECKPOINT_DIR.glob("*.pt"))
DIMS = {"student": 42, "teacher": 79}


def test_the_three_students_and_teachers_ship():
    assert set(SHIPPED) >= {*CONTEXTS, *(f"{c}-teacher" for c in CONTEXTS)}


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_policy_loads_acts_and_has_a_card(name: str):
    policy = make_policy(name, BenchmarkConfig())
    expected_group = "teacher" if name.endswith("-teacher") else "student"
    assert policy.group == expected_group
    obs = {g: torch.randn(5, d) for g, d in DIMS.items()}
    a = policy.act(obs, np.arange(5), [None] * 5)
    assert a.shape == (5, 12) and torch.isfinite(a).all()
    card = (CHECKPOINT_DIR / f"{name}.md").read_text()
    for field in ("Training context", "Environment steps", "Wall-clock", "Device", "Success in its context", "```bash"):
        assert field in card, field


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_policy_onnx_matches_torch(name: str, tmp_path: Path):
    actor = load_actor_file(CHECKPOINT_DIR / f"{name}.pt")
    export_onnx(actor, tmp_path / f"{name}.onnx")
    onnx_policy = load_policy_file(tmp_path / f"{name}.onnx")
    frames = actor.meta.obs_history
    x = torch.randn(64, actor.meta.obs_dim, generator=torch.Generator().manual_seed(0))
    group = actor.meta.obs_group
    # A policy with an H-frame history takes one frame per call and stacks the last H itself
    # (oldest first), so feed the stacked input frame by frame.
    for frame in x.chunk(frames, dim=1):
        out = onnx_policy.act({group: frame}, np.arange(64), [None] * 64)
    with torch.no_grad():
        torch.testing.assert_close(out, actor(x), atol=1e-5, rtol=0)


def test_sr_routes_each_cell_to_its_context_policy():
    cfg = BenchmarkConfig()
    sr = make_policy("sr", cfg)
    assert sr.name == "sr"
    cells = [grid_cells(g, cfg.terrain)[0] for g in CONTEXTS]  # flat, rough, incline
    obs = {"student": torch.randn(3, 42, generator=torch.Generator().manual_seed(1))}
    out = sr.act(obs, np.arange(3), cells)
    for k, ctx in enumerate(CONTEXTS):
        single = make_policy(ctx, cfg).act({"student": obs["student"][k : k + 1]}, np.arange(1), [cells[k]])
        torch.testing.assert_close(out[k : k + 1], single)


def test_sr_rule_picks_incline_on_smooth_slopes_and_rough_elsewhere_on_rough_ground():
    assert [cell_context(c) for c in grid_cells("tiny", BenchmarkConfig().terrain)] == ["flat", "rough", "flat", "rough"]
    assert sr_context(20.0, 0) == "incline" and sr_context(20.0, 7) == "rough" and sr_context(14.9, 0) == "flat"
    assert cell_context(None) is None


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_policy_records_a_fixed_pose_reference(name: str):
    """Every shipped policy maps actions around a standing pose (``stand`` or ``tall``), which
    the benchmark's default ``stand`` mapping converts exactly (tests/policies/test_reference.py)."""
    assert load_policy_file(CHECKPOINT_DIR / f"{name}.pt").action_mapping in {("stand", 0.5), ("tall", 0.5)}


def test_a_resumed_evaluation_refuses_other_weights_under_the_same_name(tmp_path: Path):
    """run.json records the weights' digest: results of one `flat` are never resumed with another."""
    from selfright.evaluate.results import ResultsError
    from selfright.evaluate.runner import evaluate_grid

    cfg = BenchmarkConfig()
    flat, teacher = make_policy("flat", cfg), make_policy("flat-teacher", cfg)
    sr = make_policy("sr", cfg)
    assert flat.digest and teacher.digest and flat.digest != teacher.digest and sr.digest not in (None, flat.digest)
    assert make_policy("zero", cfg).digest is None
    evaluate_grid(flat, policy_name="flat", grid="tiny", episodes=1, seed=0, out_dir=tmp_path, cfg=cfg, progress=False)
    with pytest.raises(ResultsError, match="policy_digest"):
        evaluate_grid(teacher, policy_name="flat", grid="tiny", episodes=1, seed=0, out_dir=tmp_path, cfg=cfg, progress=False)


def test_a_remeasured_card_states_the_new_number_and_keeps_the_old():
    from selfright.train.ship import SUCCESS_PREFIX, remeasured_card

    card = (CHECKPOINT_DIR / "flat.md").read_text()
    overall = {"n": 64, "successes": 32, "success_rate": 0.5, "success_ci95": [0.38, 0.62], "ttr_mean_s": 2.0, "dtr_mean_m": None}
    summary = {"benchmark_version": 1, "policy": "flat", "grid": "flat", "episodes_per_cell": 64, "seed": 3, "overall": overall,
               "machine": {"cpu": "Test CPU"}}
    new = remeasured_card(card, "flat", summary, "a change")
    assert new.count(SUCCESS_PREFIX) == 1
    line = next(x for x in new.splitlines() if x.startswith(SUCCESS_PREFIX))
    assert "**50.0 %**" in line and "38–62 %" in line and "DTR n/a" in line and "measured on Test CPU" in line
    old = next(x for x in card.splitlines() if x.startswith(SUCCESS_PREFIX)).removeprefix(SUCCESS_PREFIX)
    assert f"  - *Before a change*{old}" in new
    assert "--seed 3`" in new and new.startswith(card.split(SUCCESS_PREFIX)[0])
    with pytest.raises(ValueError, match="not the shipped"):
        remeasured_card(card, "flat", {**summary, "policy": "rough"}, "a change")
    ideal = remeasured_card(card, "flat", {**summary, "config": {"robot": {"motor": "ideal"}}}, "a change")
    assert "--seed 3 --motor ideal`" in ideal


def test_a_card_names_a_motor_model_other_than_the_default():
    from selfright.train.ship import motor_lines

    assert motor_lines({}) == [] and motor_lines({"benchmark_config": {"robot": {"motor": "dcmotor"}}}) == []
    line = motor_lines({"benchmark_config": {"robot": {"motor": "ideal"}}})[0]
    assert "`--motor ideal`" in line
    fast = motor_lines({"benchmark_config": {"robot": {"motor": "dcmotor", "motor_speed_rad_s": 30.0}}})[0]
    assert "`dcmotor`" in fast and "30 rad/s" in fast
    assert "approximation" in motor_lines({"benchmark_config": {"robot": {"motor": "envelope"}}})[0]


def test_a_card_names_joint_stops_softer_than_the_benchmarks():
    from selfright.train.ship import joint_stop_lines

    assert joint_stop_lines({}) == []  # runs from before the record
    assert joint_stop_lines({"benchmark_config": {"robot": {"joint_stop_timeconst_s": 0.01}}}) == []
    line = joint_stop_lines({"benchmark_config": {"robot": {"joint_stop_timeconst_s": 0.02}}})[0]
    assert "0.02 s" in line and "0.01 s" in line


def test_a_card_measured_through_sensor_noise_says_so_and_how_to_reproduce_it():
    from selfright.train.ship import success_lines

    summary = {"overall": {"success_rate": 0.5, "success_ci95": [0.4, 0.6], "n": 64}, "grid": "flat", "seed": 0,
               "episodes_per_cell": 64, "config": {"eval": {"sensor_noise": 0.5}}}
    line, seed = success_lines("flat", summary)
    assert "through sensor noise ×0.5" in line and seed.endswith("--seed 0 --sensor-noise 0.5`")
    exact = success_lines("flat", {**summary, "config": {"eval": {"sensor_noise": 0.0}}})
    assert "noise" not in " ".join(exact)
    walled = {**summary, "config": {"eval": {"wall_gap_ratio": 1.5, "ground_timeconst_s": 0.05, "friction": 1.0}}}
    line, seed = success_lines("flat", walled)
    assert "side walls 1.5 body lengths apart, ground time constant 0.05 s, N = 64" in line
    assert seed.endswith("--seed 0 --wall-gap-ratio 1.5 --ground-timeconst 0.05`") and "friction" not in seed


def test_a_card_names_the_machines_that_trained_its_checkpoint(tmp_path: Path):
    """A run resumed elsewhere after the shipped checkpoint: the card keeps that checkpoint's
    invocations and machines, not the run's latest one; shipping the latest names them all."""
    from selfright.train.ship import checkpoint_meta

    meta = {"command_lines": ["a", "b", "c"], "command_start_iterations": [0, 462, 722],
            "command_devices": ["gpu 5", "gpu 8", "laptop"], "device": "laptop",
            "latest_checkpoint": str(tmp_path / "model_1199.pt"), "iterations_done": 1200}
    (tmp_path / "train_meta.json").write_text(json.dumps(meta))
    infos = {"iterations_done": 722, "env_steps": 4_435_968, "wall_clock_s": 617.0}
    torch.save({"infos": infos}, tmp_path / "model_721.pt")
    out = checkpoint_meta(tmp_path / "model_721.pt")
    assert out["command_lines"] == ["a", "b"] and out["device"] == "gpu 5; then gpu 8"
    assert out["env_steps"] == 4_435_968
    torch.save({"infos": {}}, tmp_path / "model_1199.pt")
    latest = checkpoint_meta(tmp_path)
    assert latest["command_lines"] == ["a", "b", "c"] and latest["device"] == "gpu 5; then gpu 8; then laptop"


def test_a_card_states_the_benchmark_version():
    from selfright.train.ship import VERSION_PREFIX, remeasured_card, version_line

    assert version_line({"benchmark_version": 1}, {"benchmark_version": 1}) == f"{VERSION_PREFIX}: 1"
    assert version_line({}, {"benchmark_version": 1}) == f"{VERSION_PREFIX}: 1 (trained under version 0)"
    card = (CHECKPOINT_DIR / "flat.md").read_text()
    overall = {"n": 64, "successes": 32, "success_rate": 0.5, "success_ci95": [0.38, 0.62], "ttr_mean_s": 2.0, "dtr_mean_m": None}
    summary = {"benchmark_version": 1, "policy": "flat", "grid": "flat", "episodes_per_cell": 64, "seed": 3, "overall": overall}
    once = remeasured_card(card, "flat", summary, "a change")
    twice = remeasured_card(once, "flat", summary, "another change")
    for text in (once, twice):
        lines = [x for x in text.splitlines() if x.startswith(VERSION_PREFIX)]
        want = [f"{VERSION_PREFIX}: 1"] if VERSION_PREFIX in card and "trained under" not in card else None
        assert len(lines) == 1 and (want is None or lines == want)
    if VERSION_PREFIX not in card:  # a card written without a version: trained under version 0
        assert f"{VERSION_PREFIX}: 1 (trained under version 0)" in twice
