import csv
import dataclasses
import json
from pathlib import Path

import pytest

from selfright.config import BenchmarkConfig, EvalConfig, GoalConfig
from selfright.evaluate.results import COLUMNS, ResultsError
from selfright.evaluate.runner import evaluate_grid
from selfright.evaluate.metrics import wilson_interval
from selfright.policies.registry import make_policy

# Short episodes keep the tier fast; the logic is the same at 10 s.
CFG = BenchmarkConfig(goal=GoalConfig(episode_s=1.0, hold_s=0.2))


def run(out: Path, policy="random", episodes=2, seed=0, cfg=CFG):
    return evaluate_grid(make_policy(policy, cfg), policy_name=policy, grid="tiny", episodes=episodes, seed=seed,
                         out_dir=out, cfg=cfg, progress=False)


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    out = tmp_path_factory.mktemp("ref")
    run(out)
    return out


def test_result_files_follow_the_contract(reference):
    with (reference / "episodes.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert tuple(rows[0].keys()) == COLUMNS
    assert len(rows) == 4 * 2
    for r in rows:
        assert r["success"] in ("0", "1")
        if r["success"] == "0":
            assert r["ttr_s"] == "" and r["dtr_m"] == ""
        assert float(r["energy_j"]) >= 0
    s = json.loads((reference / "summary.json").read_text())
    assert s["policy"] == "random" and s["grid"] == "tiny" and s["episodes_per_cell"] == 2
    assert "config" in s and s["config"]["goal"]["episode_s"] == 1.0
    assert len(s["cells"]) == 4
    for c in s["cells"]:
        assert {"slope_level", "roughness_level", "n", "success_rate", "success_ci95", "ttr_mean_s", "dtr_mean_m"} <= set(c)
        assert c["n"] == 2
    assert s["overall"]["n"] == 8
    rough = {(c["slope_level"], c["roughness_level"]): c["roughness_R"] for c in s["cells"]}
    assert rough[(0, 0)] == pytest.approx(0, abs=1e-9) and rough[(0, 1)] > 0


def test_same_seed_identical_episodes(reference, tmp_path):
    run(tmp_path)
    assert (tmp_path / "episodes.csv").read_bytes() == (reference / "episodes.csv").read_bytes()


def test_other_seed_differs(reference, tmp_path):
    run(tmp_path, seed=1)
    assert (tmp_path / "episodes.csv").read_bytes() != (reference / "episodes.csv").read_bytes()


def test_resume_after_interruption_loses_and_duplicates_nothing(reference, tmp_path):
    run(tmp_path)
    path = tmp_path / "episodes.csv"
    lines = path.read_text().splitlines(keepends=True)
    # Keep header + 3 rows, then a torn half line as a kill mid-write would leave.
    path.write_text("".join(lines[:4]) + lines[4][: len(lines[4]) // 2])
    res = run(tmp_path)
    assert res.episodes_run == 5
    assert path.read_bytes() == (reference / "episodes.csv").read_bytes()
    again = run(tmp_path)
    assert again.episodes_run == 0
    assert path.read_bytes() == (reference / "episodes.csv").read_bytes()


def test_learned_policy_results_do_not_depend_on_batching(tmp_path):
    """An episode's row is the same whether it runs alone or beside others (and so after a
    resume, whose batches differ): the shipped student acts on each env independently."""
    cfg = BenchmarkConfig(goal=GoalConfig(episode_s=2.0, hold_s=0.2))
    alone = dataclasses.replace(cfg, eval=EvalConfig(batch_size=1))
    run(tmp_path / "batched", policy="flat", episodes=3, cfg=cfg)
    run(tmp_path / "alone", policy="flat", episodes=3, cfg=alone)
    batched = (tmp_path / "batched" / "episodes.csv").read_bytes()
    assert batched == (tmp_path / "alone" / "episodes.csv").read_bytes()
    assert b",1," in batched  # some episodes succeed: the trajectories are not trivial


def test_sensor_noise_changes_what_a_policy_does_the_same_way_in_any_batch(tmp_path):
    """``EvalConfig.sensor_noise`` runs every policy on noisy sensors, drawn per episode (so not
    per batch), and is part of the run's identity: a clean run's folder is not resumed noisy."""
    cfg = BenchmarkConfig(goal=GoalConfig(episode_s=1.0, hold_s=0.2))
    noisy = dataclasses.replace(cfg, eval=EvalConfig(sensor_noise=3.0))
    noisy_alone = dataclasses.replace(cfg, eval=EvalConfig(sensor_noise=3.0, batch_size=1))
    run(tmp_path / "clean", policy="flat", episodes=2, cfg=cfg)
    run(tmp_path / "noisy", policy="flat", episodes=2, cfg=noisy)
    run(tmp_path / "noisy_alone", policy="flat", episodes=2, cfg=noisy_alone)
    rows = {k: (tmp_path / k / "episodes.csv").read_bytes() for k in ("clean", "noisy", "noisy_alone")}
    assert rows["noisy"] == rows["noisy_alone"] != rows["clean"]
    with pytest.raises(ResultsError):
        run(tmp_path / "clean", policy="flat", episodes=2, cfg=noisy)
    # a folder written before the field existed ran with exact sensors, and resumes as such
    path = tmp_path / "clean" / "run.json"
    old = json.loads(path.read_text())
    del old["config"]["eval"]["sensor_noise"]
    path.write_text(json.dumps(old))
    run(tmp_path / "clean", policy="flat", episodes=2, cfg=cfg)
    with pytest.raises(ResultsError):
        run(tmp_path / "clean", policy="flat", episodes=2, cfg=noisy)


def test_sensor_noise_reaches_the_sensed_columns_only():
    import torch

    from selfright.env.observations import JOINT_VEL_SCALE, joint_vel_columns, prev_action_columns, sensor_noise_std
    from selfright.policies.base import Policy
    from selfright.policies.sensor_noise import NoisySensors

    std = sensor_noise_std(12)
    assert std.shape == (42,) and float(std[0]) == pytest.approx(0.05) and float(std[3]) == pytest.approx(0.2)
    assert std[joint_vel_columns(12)].tolist() == pytest.approx([1.5 * JOINT_VEL_SCALE] * 12)
    assert torch.all(std[prev_action_columns(12)] == 0)

    class Echo(Policy):
        groups, action_mapping, digest, name = ("student", "teacher"), None, None, "echo"

        def reset(self, ids, seeds=None):
            pass

        def act(self, obs, ids, contexts):
            self.seen = obs
            return torch.zeros(len(ids), 12)

    inner = Echo()
    p = NoisySensors(inner, 1.0)
    p.reset([0, 1], [5, 6])
    obs = {"student": torch.zeros(2, 42), "teacher": torch.zeros(2, 79)}
    p.act(obs, [0, 1], [None, None])
    seen = inner.seen
    assert torch.equal(seen["teacher"][:, :42], seen["student"]) and torch.all(seen["teacher"][:, 42:] == 0)
    assert torch.all(seen["student"][:, prev_action_columns(12)] == 0) and seen["student"][:, :30].abs().min() > 0
    assert not torch.equal(seen["student"][0], seen["student"][1])  # each episode its own draw


def test_resume_refuses_a_different_run(reference, tmp_path):
    run(tmp_path)
    with pytest.raises(ResultsError, match="different run"):
        run(tmp_path, seed=5)


def test_results_record_the_benchmark_version_and_refuse_another(tmp_path):
    from selfright.config import BENCHMARK_VERSION

    run(tmp_path, episodes=1)
    for name in ("run.json", "summary.json"):
        assert json.loads((tmp_path / name).read_text())["benchmark_version"] == BENCHMARK_VERSION == 1
    path = tmp_path / "run.json"
    old = json.loads(path.read_text())
    for version in (None, 2):  # a folder without a version holds version 0
        rec = {k: v for k, v in old.items() if k != "benchmark_version"}
        path.write_text(json.dumps(rec if version is None else {**rec, "benchmark_version": version}))
        with pytest.raises(ResultsError) as e:
            run(tmp_path, episodes=1)
        assert str(e.value) == (f"{tmp_path} holds results of benchmark version {version or 0}; this is version 1: "
                                "use a fresh --out directory")


def test_wilson_interval_known_values():
    lo, hi = wilson_interval(8, 10)
    assert lo == pytest.approx(0.4902, abs=1e-3) and hi == pytest.approx(0.9433, abs=1e-3)
    assert wilson_interval(0, 0) == (0.0, 1.0)
    lo, hi = wilson_interval(0, 20)
    assert lo == 0.0 and hi == pytest.approx(0.1611, abs=1e-3)
