"""Training end to end on the flat context: rsl_rl runners, checkpoints, resume, distillation,
export, and a tiny PPO budget that must move the learning signal."""

from __future__ import annotations

import contextlib
import copy
import dataclasses
import io
import json
import math
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import torch
from rsl_rl.runners import OnPolicyRunner

from selfright.config import ActionConfig, BenchmarkConfig, to_dict
from selfright.env.rewards import RewardConfig
from selfright.evaluate.runner import evaluate_grid
from selfright.policies.learned import load_policy_file
from selfright.train.commands import ExportArgs, export
from selfright.train.config import DistillationConfig, EpisodeConfig, PPOConfig, TrainConfig
from selfright.train.contexts import make_training_worlds
from selfright.policies.run_files import list_checkpoints
from selfright.train.runner import RunSpec, TrainingRun
from selfright.train.ship import ShipArgs, reward_summary, ship
from selfright.train.vecenv import RecoveryVecEnv

CFG = BenchmarkConfig()
TINY = TrainConfig(ppo=PPOConfig(steps_per_env=8, num_mini_batches=2),
                   distillation=DistillationConfig(steps_per_env=8, gradient_length=4))


def spec(out: Path, **kw) -> RunSpec:
    base = dict(role="teacher", context="flat", out=out, num_envs=4, iterations=1, seed=0, resume=False,
                teacher=None, physics_threads=1, torch_threads=1, train=TINY, bench=CFG, quiet=True)
    return RunSpec(**{**base, **kw})


def run(s: RunSpec) -> TrainingRun:
    r = TrainingRun(s)
    r.setup()
    r.run()
    return r


def test_teacher_iteration_resume_distil_export(tmp_path: Path):
    out = tmp_path / "teacher"
    r = run(spec(out))
    assert r.last_loss and all(math.isfinite(v) for v in r.last_loss.values())
    assert [it for it, _ in list_checkpoints(out)][-1] == 0
    meta = json.loads((out / "train_meta.json").read_text())
    assert meta["role"] == "teacher" and meta["context"] == "flat" and meta["env_steps"] == 4 * 8
    assert meta["policy"]["obs_group"] == "teacher"

    # A second invocation continues from the checkpoint up to the new total.
    r = run(spec(out, iterations=2, resume=True))
    assert r.start_it == 1 and list_checkpoints(out)[-1][0] == 1
    meta = json.loads((out / "train_meta.json").read_text())
    assert meta["iterations_done"] == 2 and meta["env_steps"] == 2 * 4 * 8 and len(meta["command_lines"]) == 2
    assert meta["command_start_iterations"] == [0, 1]
    assert len(meta["command_devices"]) == 2 and meta["command_devices"][-1] == meta["device"]

    student = tmp_path / "student"
    r = run(spec(student, role="student", teacher=out))
    assert all(math.isfinite(v) for v in r.last_loss.values())
    stray = tmp_path / "stray.pt"  # a student's checkpoint away from its run's train_meta.json
    shutil.copy(list_checkpoints(student)[-1][1], stray)
    for taught_by in (student, list_checkpoints(student)[-1][1], stray):  # a student is no teacher
        with pytest.raises(ValueError, match="holds a student") as e:
            TrainingRun(spec(tmp_path / "s2", role="student", teacher=taught_by)).setup()
        assert "\n" not in str(e.value) and not (tmp_path / "s2" / "model_0.pt").exists()
    onnx_path, policy_path = export(ExportArgs(checkpoint=student, onnx=tmp_path / "student.onnx"))
    for p in (onnx_path, policy_path):
        policy = load_policy_file(p)
        assert policy.group == "student"
        a = policy.act({"student": torch.zeros(2, 42)}, np.arange(2), [None, None])
        assert a.shape == (2, 12) and torch.isfinite(a).all()

    # Ship it: evaluate the exported file on the tiny grid, then copy actor + model card.
    res = evaluate_grid(load_policy_file(policy_path), policy_name=str(policy_path), grid="tiny", episodes=1,
                        seed=0, out_dir=tmp_path / "eval", cfg=CFG, progress=False)
    dest = tmp_path / "ckpts"
    shipped = ship(ShipArgs(run=student, name="flat", evaluation=tmp_path / "eval", dest=dest))
    assert load_policy_file(shipped).group == "student"
    card = (dest / "flat.md").read_text()
    assert "student" in card and "N = 4" in card and "```bash" in card
    assert "its teacher: 64 env steps" in card  # the teacher's 2 iterations × 4 envs × 8 steps
    assert "**Reward**: the seed's Table I exactly" in card  # read off the teacher's run
    assert f"{100 * res.summary['overall']['success_rate']:.1f} %" in card

    # An earlier checkpoint of a run ships with its own steps, not the run's latest.
    notes = tmp_path / "notes.md"
    notes.write_text("Chosen on validation seeds 1-3.\n")
    ship(ShipArgs(run=out / "model_0.pt", name="flat-teacher", evaluation=tmp_path / "eval", dest=dest, notes=notes))
    card = (dest / "flat-teacher.md").read_text()
    assert "32 (1 iterations" in card and "teacher" in card
    commands = card.split("```bash\n")[1].split("```")[0].strip().splitlines()
    assert len(commands) == 1  # model_0 came from the first invocation alone, not the resumed one
    assert card.rstrip().endswith("## Notes\n\nChosen on validation seeds 1-3.")
    data = torch.load(out / "model_0.pt", weights_only=True)
    del data["infos"]["env_steps"]
    torch.save(data, out / "model_0.pt")
    try:
        ship(ShipArgs(run=out / "model_0.pt", name="x", evaluation=tmp_path / "eval", dest=dest))
        raise AssertionError("expected ValueError")
    except ValueError as e:
        assert "run folder" in str(e)


def test_existing_run_needs_resume(tmp_path: Path):
    out = tmp_path / "r"
    run(spec(out))
    for bad in (spec(out), spec(tmp_path / "empty", resume=True), spec(tmp_path / "s", role="student")):
        try:
            TrainingRun(bad).setup()
        except ValueError as e:
            assert "\n" not in str(e)
        else:
            raise AssertionError("expected ValueError")


def test_resume_continues_the_checkpoints_curriculum_levels_and_progress(tmp_path: Path):
    """A resumed run picks up its slots' curriculum levels (saved with each checkpoint) instead of
    climbing again from the easiest, and counts steps and time from the checkpoint it resumes."""
    ep = EpisodeConfig(curriculum=True, incline_curriculum_deg=(5.0, 20.0), episode_s=0.1)
    train = dataclasses.replace(TINY, episode=ep)
    out = tmp_path / "incline"
    run(spec(out, context="incline", train=train))
    path = out / "model_0.pt"
    data = torch.load(path, weights_only=True)
    assert len(data["infos"]["curriculum_level"]) == 4
    data["infos"].update(curriculum_level=[1, 0, 1, 1], env_steps=999, wall_clock_s=12.0)
    torch.save(data, path)
    resumed = TrainingRun(spec(out, context="incline", train=train, iterations=2, resume=True))
    resumed.setup()
    assert resumed.env.level.tolist() == [1, 0, 1, 1]
    assert resumed.base_steps == 999 and resumed.base_wall == 12.0
    resumed.env.close()


def test_init_from_starts_new_teacher_from_weights(tmp_path: Path):
    src = tmp_path / "flat"
    run(spec(src))
    r = TrainingRun(spec(tmp_path / "rough", context="rough", init_from=src))
    r.setup()
    ref = torch.load(src / "model_0.pt", map_location="cpu", weights_only=True)["actor_state_dict"]
    got = r.runner.alg.get_policy().state_dict()
    assert r.start_it == 0 and all(torch.equal(got[k], v) for k, v in ref.items())
    r.run()
    meta = json.loads((tmp_path / "rough" / "train_meta.json").read_text())
    assert meta["init_from"].endswith("model_0.pt") and meta["context"] == "rough"
    for bad in (spec(tmp_path / "x", init_from=tmp_path / "nope"), spec(tmp_path / "y", role="student", teacher=src, init_from=src)):
        try:
            TrainingRun(bad).setup()
        except ValueError as e:
            assert "init-from" in str(e)
        else:
            raise AssertionError("expected ValueError")


def test_init_from_recentres_features_constant_in_the_source(tmp_path: Path):
    """The slope angle never varies on the flat plane; on the incline it must not enter the
    network as (0.35 rad - 0) / eps. Only such features move; the other statistics stay."""
    src = tmp_path / "flat"
    run(spec(src))
    ref = torch.load(src / "model_0.pt", map_location="cpu", weights_only=True)["actor_state_dict"]
    r = TrainingRun(spec(tmp_path / "incline", context="incline", init_from=src))
    r.setup()
    mean = r.runner.alg.actor.obs_normalizer._mean[0]
    angle = 42  # first privileged feature, after the 42 student ones
    assert float(ref["obs_normalizer._std"][0, angle]) < 1e-3
    assert abs(float(mean[angle]) - math.atan(0.364)) < 1e-3  # 20° (36.4 % grade)
    others = torch.ones_like(mean, dtype=torch.bool)
    others[ref["obs_normalizer._std"][0] < 1e-3] = False
    assert torch.equal(mean[others], ref["obs_normalizer._mean"][0][others])
    r.env.close()


def _evaluate(policy, worlds, train: TrainConfig, steps: int = 100, n: int = 32, cfg: BenchmarkConfig = CFG) -> tuple[float, float]:
    """Mean reward per step and mean cos θ_z over the last half, on a fixed set of falls."""
    env = RecoveryVecEnv(cfg, train, worlds, n, seed=12345)
    rewards, upright = [], []
    with torch.inference_mode():
        obs = env.get_observations()
        for _ in range(steps):
            obs, r, _, extras = env.step(policy(obs))
            rewards.append(float(r.mean()))
            upright.append(float(extras["log"]["Metrics/upright_cos"]))
    env.close()
    return float(np.mean(rewards)), float(np.mean(upright[steps // 2 :]))


# Targets relative to the current joint angles: with them the first thing PPO learns (rolling
# from the back towards the belly) shows within 40 iterations. With the default stand-relative
# targets the policy first spends ~100 iterations of 3,072 steps (300k steps) with robots on
# their backs before rolling starts (flat teacher, 2026-11-22): too long for the fast tier.
SMOKE_CFG = dataclasses.replace(CFG, action=ActionConfig(reference="current"))


def test_ppo_learning_signal_moves():
    """40 PPO iterations × 16 envs (~15 s): on the same 32 falls, the trained mean policy earns
    more reward per step and is more upright than the initial one."""
    torch.manual_seed(1)
    train = TrainConfig()
    worlds = make_training_worlds("flat", SMOKE_CFG, seed=0)
    env = RecoveryVecEnv(SMOKE_CFG, train, worlds, 16, seed=1)
    with contextlib.redirect_stdout(io.StringIO()):
        runner = OnPolicyRunner(env, train.to_rsl_rl("teacher"), log_dir=None)
        initial = copy.deepcopy(runner.alg.get_policy()).eval()
        runner.learn(40, init_at_random_ep_len=True)
    env.close()
    r0, up0 = _evaluate(initial, worlds, train, cfg=SMOKE_CFG)
    r1, up1 = _evaluate(runner.get_inference_policy(), worlds, train, cfg=SMOKE_CFG)
    print(f"reward/step {r0:+.4f} -> {r1:+.4f}, cos θ_z {up0:+.3f} -> {up1:+.3f}")
    assert r1 > r0 + 0.01, (r0, r1)
    assert up1 > up0 + 0.05, (up0, up1)


def test_train_args_defaults_are_documented():
    from selfright.train.commands import TrainArgs

    fields = {f.name: f for f in dataclasses.fields(TrainArgs)}
    assert {"role", "context", "out", "envs", "iterations", "resume", "seed", "teacher"} <= set(fields)


def test_policy_records_its_action_mapping(tmp_path: Path):
    """A policy trained on current-relative targets says so, in its file and in ONNX, and is
    refused by an evaluation that maps actions relative to the standing pose."""
    from selfright.policies.registry import make_policy

    out = tmp_path / "cur"
    run(spec(out, bench=SMOKE_CFG))
    for path in (out, out / "model_0.pt"):
        assert make_policy(str(path), SMOKE_CFG).action_mapping == ("current", 0.5)
        try:
            make_policy(str(path), CFG)
            raise AssertionError("expected ValueError")
        except ValueError as e:
            assert "current" in str(e) and "\n" not in str(e)
    onnx_path, policy_path = export(ExportArgs(checkpoint=out, onnx=tmp_path / "cur.onnx"))
    for p in (onnx_path, policy_path):
        assert load_policy_file(p).action_mapping == ("current", 0.5)


def test_policy_records_its_motor(tmp_path: Path):
    """A policy says which motors it trained with, in its checkpoint, its policy file and its
    ONNX metadata."""
    import onnxruntime as ort

    from selfright.policies.learned import load_torch_actor

    fast = dataclasses.replace(CFG, robot=dataclasses.replace(CFG.robot, motor="dcmotor", motor_speed_rad_s=30.0))
    out = tmp_path / "dc"
    run(spec(out, bench=fast))
    onnx_path, policy_path = export(ExportArgs(checkpoint=out, onnx=tmp_path / "dc.onnx"))
    meta = load_torch_actor(policy_path).meta
    assert (meta.motor, meta.motor_speed_rad_s) == ("dcmotor", 30.0)
    props = ort.InferenceSession(str(onnx_path)).get_modelmeta().custom_metadata_map
    assert (json.loads(props["motor"]), json.loads(props["motor_speed_rad_s"])) == ("dcmotor", 30.0)
    # the checkpoint itself records its motor: copied out of its run folder it still says so
    stray = tmp_path / "elsewhere" / "model_0.pt"
    stray.parent.mkdir()
    shutil.copy(out / "model_0.pt", stray)
    meta = load_torch_actor(stray).meta
    assert (meta.motor, meta.motor_speed_rad_s) == ("dcmotor", 30.0)


def test_ship_checks_notes_before_writing(tmp_path: Path):
    out = tmp_path / "t"
    run(spec(out))
    res = evaluate_grid(load_policy_file(out / "model_0.pt"), policy_name="t", grid="tiny", episodes=1,
                        seed=0, out_dir=tmp_path / "eval", cfg=CFG, progress=False)
    assert res.summary
    dest = tmp_path / "ckpts"
    try:
        ship(ShipArgs(run=out, name="flat", evaluation=tmp_path / "eval", dest=dest, notes=tmp_path / "missing.md"))
        raise AssertionError("expected ValueError")
    except ValueError as e:
        assert "--notes" in str(e)
    assert not (dest / "flat.pt").exists()


def test_a_students_reward_line_is_the_first_trainer_up_its_chain_of_students(tmp_path: Path):
    table = to_dict(RewardConfig())
    runs = {"teacher": {"role": "teacher", "train_config": {"reward": {**table, "target_height_m": 0.38}}},
            "student": {"role": "student", "teacher": str(tmp_path / "teacher" / "model_5.pt"),
                        "train_config": {"reward": table}}}
    for name, meta in runs.items():
        (tmp_path / name).mkdir()
        (tmp_path / name / "train_meta.json").write_text(json.dumps(meta))
    restudent = {"role": "student", "teacher": str(tmp_path / "student" / "model_9.pt"), "train_config": {"reward": table}}
    assert reward_summary(restudent) == "the seed's Table I exactly (z* = 0.38 m)"


def test_the_reward_line_names_a_goal_set_term():
    reward = {**to_dict(RewardConfig()), "goal_set": 10.0}
    line = reward_summary({"role": "teacher", "train_config": {"reward": reward}})
    assert line.startswith("the seed's Table I terms **plus a goal-set term** (not in Table I), 10.0 per s")
    assert "Table I exactly" not in line


def test_the_reward_line_names_a_bar_ramp_beside_a_goal_set_term():
    reward = {**to_dict(RewardConfig()), "goal_set": 10.0, "bar_ramp": 20.0, "bar_ramp_width_m": 0.08}
    line = reward_summary({"role": "teacher", "train_config": {"reward": reward}})
    assert line.startswith("the seed's Table I terms **plus a goal-set term and a bar-ramp term** (not in Table I)")
    assert "up to 20.0 per s" in line and "0.08 m under a top 0.02 m over the goal bar" in line


def test_the_reward_line_names_a_feet_under_hips_term():
    reward = {**to_dict(RewardConfig()), "goal_set": 10.0, "feet_under_hips": 5.0}
    line = reward_summary({"role": "teacher", "train_config": {"reward": reward}})
    assert line.startswith("the seed's Table I terms **plus a goal-set term and a feet-under-hips term** (not in Table I)")
    assert "−5.0 per m²·s" in line and "feet_under_hips" not in line


def test_card_record_reads_back_what_a_card_states():
    from selfright.train.ship import card_record

    card = ("- **Environment steps**: 261,120 (85 iterations, 128 envs); its teacher: 1 env steps, 0.01 h\n"
            "- **Reward**: the seed's Table I exactly (z* = 0.37 m)\n- **Wall-clock**: 0.05 h\n")
    rec = card_record(card)
    assert (rec["env_steps"], rec["iterations_done"], rec["num_envs"], rec["wall_clock_s"]) == (261_120, 85, 128, 180.0)
    assert reward_summary({"role": "teacher", **rec}) == "the seed's Table I exactly (z* = 0.37 m)"
    assert "train_config" not in card_record("- **Reward**: **not** the seed's Table I: goal-set term weight 8.0")


def _distil_tiny_student(tmp_path: Path, **distillation: Any) -> tuple[TrainingRun, Path, Path, Path]:
    """A tiny teacher, then a student with the given ``DistillationConfig`` fields, exported:
    (the student's run, its folder, its ONNX graph, its policy file)."""
    teacher = tmp_path / "teacher"
    run(spec(teacher))
    train = dataclasses.replace(TINY, distillation=dataclasses.replace(TINY.distillation, **distillation))
    student = tmp_path / "student"
    r = run(spec(student, role="student", teacher=teacher, train=train))
    assert all(math.isfinite(v) for v in r.last_loss.values())
    onnx_path, policy_path = export(ExportArgs(checkpoint=student, onnx=tmp_path / "student.onnx"))
    return r, student, onnx_path, policy_path


def _evaluate_and_ship(tmp_path: Path, policy_file: Path, run_dir: Path) -> str:
    """Evaluate ``policy_file`` on the tiny grid, ship ``run_dir`` with that evaluation; returns
    the model card's text."""
    res = evaluate_grid(load_policy_file(policy_file), policy_name=policy_file.stem, grid="tiny", episodes=1, seed=0,
                        out_dir=tmp_path / "eval", cfg=CFG, progress=False)
    assert res.summary["overall"]["n"] == 4
    dest = tmp_path / "ckpts"
    ship(ShipArgs(run=run_dir, name="flat", evaluation=tmp_path / "eval", dest=dest))
    return (dest / "flat.md").read_text()


def test_student_with_history_trains_exports_and_deploys_the_same(tmp_path: Path):
    """A student reading 2 stacked frames: its checkpoint, policy file and ONNX graph all keep
    the history per env slot, and agree with the network on hand-stacked frames."""
    _, student, onnx_path, policy_path = _distil_tiny_student(tmp_path, student_history=2)
    assert json.loads((student / "train_meta.json").read_text())["policy"]["obs_history"] == 2
    frames = torch.randn(3, 2, 42, generator=torch.Generator().manual_seed(0))  # 3 steps of 2 slots
    actor = load_policy_file(policy_path).module
    assert actor.meta.obs_history == 2 and actor.meta.obs_dim == 84
    expected = [actor(torch.cat([frames[max(t - 1, 0)], frames[t]], dim=1)) for t in range(3)]
    for p in (list_checkpoints(student)[-1][1], policy_path, onnx_path):
        policy = load_policy_file(p)
        assert policy.history == 2
        policy.reset(np.arange(2))
        for t in range(3):
            a = policy.act({"student": frames[t]}, np.arange(2), [None, None])
            torch.testing.assert_close(a, expected[t], atol=1e-5, rtol=0)
    assert "its last 2 frames stacked" in _evaluate_and_ship(tmp_path, onnx_path, student)
