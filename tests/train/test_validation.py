"""Checkpoint selection on the benchmark: every saved checkpoint is scored, the best is kept."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest
import torch

from selfright.train import validation
from selfright.train.config import RandomizationConfig, ValidationConfig
from selfright.train.runner import TrainingRun
from selfright.train.validation import Score, best_score, read_scores, record

from test_learning_smoke import CFG, TINY, run, spec


def test_best_score_prefers_higher_then_earlier():
    s = [Score(10, 1, 1, 2), Score(20, 2, 3, 4), Score(30, 3, 3, 4)]
    assert best_score(s).iteration == 20
    # Equal counts tie; the earlier checkpoint wins.
    assert best_score([Score(208, 1, 29, 64), Score(599, 2, 29, 64)]).iteration == 208
    assert best_score([]) is None


def test_record_keeps_the_best_checkpoint(tmp_path: Path):
    a, b, c = (tmp_path / f"model_{i}.pt" for i in (1, 2, 3))
    for i, p in enumerate((a, b, c)):
        torch.save({"x": torch.tensor(i)}, p)
    assert record(tmp_path, Score(1, 10, 1, 4), a)
    assert record(tmp_path, Score(2, 20, 2, 4), b)
    assert not record(tmp_path, Score(3, 30, 2, 4), c)  # a tie keeps the earlier one
    assert [s.iteration for s in read_scores(tmp_path)] == [1, 2, 3]
    # A tie of 29/64 against the CSV's rounded 0.4531 is still a tie.
    other = tmp_path / "other"
    other.mkdir()
    assert record(other, Score(208, 1, 29, 64), a)
    assert not record(other, Score(599, 2, 29, 64), b)
    best = torch.load(tmp_path / validation.BEST_FILE, weights_only=True)
    assert int(best["x"]) == 1


def test_training_validates_each_checkpoint(tmp_path: Path):
    train = dataclasses.replace(TINY, validation=ValidationConfig(episodes=1, grid="tiny"))
    out = tmp_path / "t"
    run(spec(out, train=train))
    run(spec(out, train=train, iterations=2, resume=True))
    scores = read_scores(out)
    assert [s.iteration for s in scores] == [0, 1]
    assert all(s.episodes >= 1 and 0.0 <= s.success_rate <= 1.0 and s.env_steps > 0 for s in scores)
    assert (out / validation.BEST_FILE).exists() and (out / "validation" / "model_1" / "summary.json").exists()


def test_a_student_trained_under_sensor_noise_is_validated_under_it(tmp_path: Path):
    """``--train.randomization.sensor-noise``: the student's checkpoints are scored through the
    same noise (each validation's summary.json records it), train_meta.json records it, and a
    teacher run refuses it before writing anything."""
    noisy = dataclasses.replace(TINY, randomization=RandomizationConfig(sensor_noise=0.5))
    with pytest.raises(ValueError, match="applies to students; a teacher reads privileged, exact observations"):
        TrainingRun(spec(tmp_path / "refused", train=noisy)).setup()
    assert not (tmp_path / "refused").exists()
    teacher = tmp_path / "teacher"
    run(spec(teacher))
    student = tmp_path / "student"
    train = dataclasses.replace(noisy, validation=ValidationConfig(episodes=1, grid="tiny"))
    r = run(spec(student, role="student", teacher=teacher, train=train))
    assert r.validation_bench().eval.sensor_noise == 0.5 and r.spec.bench.eval.sensor_noise == 0.0
    summary = json.loads((student / "validation" / "model_0" / "summary.json").read_text())
    assert summary["config"]["eval"]["sensor_noise"] == 0.5
    meta = json.loads((student / "train_meta.json").read_text())
    assert meta["train_config"]["randomization"]["sensor_noise"] == 0.5
    assert meta["benchmark_config"]["eval"]["sensor_noise"] == 0.0  # the benchmark itself stays exact
    off = dataclasses.replace(train, randomization=RandomizationConfig(sensor_noise=0.5, enabled=False))
    assert TrainingRun(spec(tmp_path / "off", role="student", teacher=teacher, train=off)).validation_bench() == CFG




def test_a_checkpoint_saved_by_the_timer_on_the_last_iteration_is_validated_once(tmp_path: Path):
    # With checkpoint_every_s=0 the per-iteration timer saves (and validates) the last iteration,
    # and the run then saves it again over rsl_rl's own copy: that second save must not score
    # the same iteration again (its validation folder would hold a file of another digest).
    train = dataclasses.replace(TINY, checkpoint_every_s=0.0, validation=ValidationConfig(episodes=1, grid="tiny"))
    out = tmp_path / "t"
    run(spec(out, train=train, iterations=2))
    assert [s.iteration for s in read_scores(out)] == [0, 1]


def test_validating_checkpoints_does_not_change_what_trains(tmp_path: Path):
    # Checkpoints (and their validation) fall on a wall-clock timer; scoring one must not
    # draw from the generator that samples the training's actions, or the same command and
    # seed would train different policies on machines of different speed.
    weights = []
    for every in (0.0, 1e9):
        train = dataclasses.replace(TINY, checkpoint_every_s=every, validation=ValidationConfig(episodes=1, grid="tiny"))
        out = tmp_path / f"every_{every:g}"
        run(spec(out, train=train, iterations=3))
        weights.append(torch.load(out / "model_2.pt", weights_only=False)["actor_state_dict"])
    assert weights[0].keys() == weights[1].keys()
    for k in weights[0]:
        assert torch.equal(weights[0][k], weights[1][k]), k
