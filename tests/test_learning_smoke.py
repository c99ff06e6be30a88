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

from selfright.config import ActionConfig, BenchmarkConfig, RewardConfig, to_dict
from selfright.evaluate.runner import evaluate_grid
from selfright.policies.learned import load_policy_file
from selfright.train.commands import ExportArgs, export
from selfright.train.config import DistillationConfig, EpisodeConfig, PPOConfig, TrainConfig, ValidationConfig
from selfright.train.contexts import make_training_worlds
from selfright.train.checkpoints import list_checkpoints
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
    copy = TrainingRun(spec(tmp_path / "s2", role="student", teacher=student))  # a student's labels: a copy of it
    copy.setup()
    assert copy.label_student is not None and copy.runner.alg.teacher.target is None
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


def test_init_optimizer_takes_the_source_learning_rate(tmp_path: Path):
    """--init-optimizer: the fine-tune starts at the learning rate (and Adam state) the source
    ended at, not at the configured initial rate; without --init-from it is refused."""
    src = tmp_path / "flat"
    run(spec(src))
    path = src / "model_0.pt"
    data = torch.load(path, weights_only=False)
    data["optimizer_state_dict"]["param_groups"][0]["lr"] = 1e-5  # as an adaptive schedule leaves it
    torch.save(data, path)
    fresh = TrainingRun(spec(tmp_path / "fresh", init_from=src))
    fresh.setup()
    assert fresh.runner.alg.learning_rate != 1e-5
    fresh.env.close()
    kept = TrainingRun(spec(tmp_path / "kept", init_from=src, init_optimizer=True))
    kept.setup()
    assert kept.runner.alg.learning_rate == 1e-5
    assert kept.runner.alg.optimizer.param_groups[0]["lr"] == 1e-5
    kept.env.close()
    with pytest.raises(ValueError, match="init-optimizer"):
        TrainingRun(spec(tmp_path / "bad", init_optimizer=True)).setup()


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


def test_max_std_bounds_the_noise_a_resumed_run_explores_with(tmp_path: Path):
    """--train.policy.max-std: a resumed run draws its actions with each joint's std bounded,
    while the stored std and the deployed mean are those of the checkpoint."""
    out = tmp_path / "t"
    run(spec(out))  # init_std 0.5
    bounded = dataclasses.replace(TINY, policy=dataclasses.replace(TINY.policy, max_std=0.2))
    r = TrainingRun(spec(out, iterations=2, resume=True, train=bounded))
    r.setup()
    actor, obs = r.runner.alg.actor, r.env.get_observations()
    actor(obs, stochastic_output=True)
    assert torch.allclose(actor.output_std, torch.full_like(actor.output_std, 0.2))
    saved = torch.load(list_checkpoints(out)[-1][1], weights_only=False)["actor_state_dict"]["distribution.std_param"]
    assert torch.equal(actor.state_dict()["distribution.std_param"], saved) and bool((saved > 0.2).all())
    with pytest.raises(ValueError, match="max_std must be positive"):
        dataclasses.replace(TINY.policy, max_std=0.0)


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


def test_policy_records_its_motor_and_runs_in_the_dc_envelope_on_ideal_servos(tmp_path: Path):
    """A policy trained with DC motors says so, in its file and in ONNX; on the ideal servos
    it is wrapped in the DC torque envelope (unless asked not to), on DC motors it is not."""
    from selfright.policies.registry import make_policy
    from selfright.policies.torque_envelope import TorqueEnvelope

    dc = dataclasses.replace(CFG, robot=dataclasses.replace(CFG.robot, motor="dcmotor"))
    out = tmp_path / "dc"
    run(spec(out, bench=dc))
    assert make_policy(str(out), dc).trained_motor == ("dcmotor", 0.0)
    assert not isinstance(make_policy(str(out), dc), TorqueEnvelope)
    assert isinstance(make_policy(str(out), CFG), TorqueEnvelope)
    assert not isinstance(make_policy(str(out), CFG, envelope=False), TorqueEnvelope)
    onnx_path, policy_path = export(ExportArgs(checkpoint=out, onnx=tmp_path / "dc.onnx"))
    for p in (onnx_path, policy_path):
        assert load_policy_file(p).trained_motor == ("dcmotor", 0.0)
    # the checkpoint itself records its motor: copied out of its run folder it still runs as trained
    stray = tmp_path / "elsewhere" / "model_0.pt"
    stray.parent.mkdir()
    shutil.copy(out / "model_0.pt", stray)
    assert load_policy_file(stray).trained_motor == ("dcmotor", 0.0)


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


def test_model_card_reward_line_flags_anything_but_table_i():
    table = to_dict(RewardConfig())
    assert reward_summary({"role": "teacher", "train_config": {"reward": {**table, "target_height_m": 0.37}}}) == (
        "the seed's Table I exactly (z* = 0.37 m)"
    )
    line = reward_summary({"role": "teacher", "train_config": {"reward": {**table, "goal_set": 8.0, "torques": 0.002}}})
    assert line.startswith("**not** the seed's Table I") and "goal-set term weight 8.0" in line
    assert "torques 0.002 (Table I: 0.001)" in line
    line = reward_summary({"role": "teacher", "train_config": {"reward": {**table, "stance": 4.0}}})
    assert line.startswith("**not** the seed's Table I") and "stance term weight 4.0 towards (0.0, 0.46, -0.92)" in line
    line = reward_summary({"role": "teacher", "train_config": {"reward": {**table, "upright_spin": 0.5}}})
    assert line.startswith("**not** the seed's Table I") and "upright-spin term −0.5 · ‖ω‖² within 45.0° of upright" in line
    line = reward_summary({"role": "teacher", "train_config": {"reward": {**table, "upright_speed": 4.0}}})
    assert line.startswith("**not** the seed's Table I") and "upright-speed term −4.0 · ‖v_xy‖² within 45.0° of upright" in line
    line = reward_summary({"role": "teacher", "train_config": {"reward": {**table, "refall": 20.0},
                                                               "episode": {"terminate_on_refall": True}}})
    assert "re-fall penalty 20.0 per tip past 90.0° after upright (not in Table I)" in line
    assert line.endswith("; training episodes ended as terminal at a tip past 90.0° after upright (not in the seed)")
    line = reward_summary({"role": "teacher", "train_config": {"reward": {**table, "off_tile": 30.0}}})
    assert line.startswith("**not** the seed's Table I") and "penalty 30.0 for leaving the tile (not in Table I)" in line
    assert "off_tile" not in line  # worded, not listed as a changed Table I weight
    edge = {"reward": {**table, "off_tile": 30.0}, "episode": {"off_tile_is_timeout": False}}
    assert reward_summary({"role": "teacher", "train_config": edge}).endswith(
        "; leaving the tile ended training episodes as terminal (the project's default ends them as a time-out)"
    )
    edge["episode"]["off_tile_is_timeout"] = True
    assert "leaving the tile ended" not in reward_summary({"role": "teacher", "train_config": edge})
    assert reward_summary({"role": "teacher"}).startswith("unknown")
    ended = {"reward": {**table, "target_height_m": 0.37}, "episode": {"terminate_low_stance_s": 1.0}}
    assert reward_summary({"role": "teacher", "train_config": ended}) == (
        "the seed's Table I exactly (z* = 0.37 m); training episodes ended as terminal after 1.0 s upright on four"
        " feet under the goal bar (not in the seed)"
    )
    ended["episode"]["low_stance_leaky"] = True
    assert "upright on three or four feet (a leaky count) under the goal bar" in reward_summary({"role": "teacher", "train_config": ended})
    ended["episode"]["low_stance_over_feet_m"] = 0.34
    assert "(a leaky count) under 0.34 m above the ground under the feet (not" in reward_summary({"role": "teacher", "train_config": ended})
    steep = {"reward": table, "episode": {"incline_slopes_deg": [20.0, 22.5, 25.0]}}
    assert reward_summary({"role": "student-ppo", "train_config": steep}).endswith(
        "; incline training tiles of 20°, 22.5°, 25°, one drawn per episode (the benchmark's: 20°)"
    )
    walls = {"reward": table, "episode": {"wall_gap_ratios": [1.5, 2.0], "ground_timeconsts_s": [0.05]}}
    assert reward_summary({"role": "student-ppo", "train_config": walls}).endswith(
        "; training worlds between side walls 1.5, 2 body lengths apart besides open ground, one drawn per episode"
        "; training worlds on softer ground (contact time constants 0.05 s) besides the benchmark's 0.02 s"
    )
    arrivals = {"reward": table, "episode": {"restart_arrivals": 0.3}}
    assert reward_summary({"role": "student-ppo", "train_config": arrivals}).endswith(
        "; 30% of training episodes restarted at recorded arrivals upright instead of with the seed's fall (not in the seed)"
    )
    standing = {"reward": table, "episode": {"stand_start": 0.3}}
    assert reward_summary({"role": "student-ppo", "train_config": standing}).endswith(
        "; 30% of training episodes started standing with a random trunk velocity instead of with the seed's fall"
        " (not in the seed)"
    )


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


def test_card_record_reads_back_what_a_card_states():
    from selfright.train.ship import card_record

    card = ("- **Environment steps**: 261,120 (85 iterations, 128 envs); its teacher: 1 env steps, 0.01 h\n"
            "- **Reward**: the seed's Table I exactly (z* = 0.37 m)\n- **Wall-clock**: 0.05 h\n")
    rec = card_record(card)
    assert (rec["env_steps"], rec["iterations_done"], rec["num_envs"], rec["wall_clock_s"]) == (261_120, 85, 128, 180.0)
    assert reward_summary({"role": "teacher", **rec}) == "the seed's Table I exactly (z* = 0.37 m)"
    assert "train_config" not in card_record("- **Reward**: **not** the seed's Table I: goal-set term weight 8.0")


def test_model_card_names_the_fallback_teacher_and_its_rule():
    from selfright.train.ship import _fallback_teacher

    assert _fallback_teacher({"train_config": {"distillation": {"fallback_teacher": None}}}) == (None, "")
    tilt = {"train_config": {"distillation": {"fallback_teacher": "runs/e/model_1.pt", "fallback_tilt_deg": 45.0}}}
    fb, words = _fallback_teacher(tilt)
    assert fb == "runs/e/model_1.pt" and "within 45°" in words and "`runs/e/model_1.pt` where it is tilted more" in words
    three = {"train_config": {"distillation": {"fallback_teacher": "e.pt", "fallback_tilt_deg": 45.0,
                                                "rough_teacher": "r.pt", "rough_scan_std_m": 0.027}}}
    assert "from `r.pt` where it is upright and the height scan spreads over 0.027 m, and from `e.pt`" in _fallback_teacher(three)[1]
    stall = {"train_config": {"distillation": {"fallback_teacher": "b.pt", "fallback_tilt_deg": 0.0, "fallback_s": 1.0}}}
    assert "1.0 s after each stall" in _fallback_teacher(stall)[1]


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


def test_gru_student_trains_exports_and_deploys_the_same(tmp_path: Path):
    """A recurrent (GRU) student: rsl_rl trains it; its checkpoint, policy file and ONNX graph
    keep a hidden state per env slot, zeroed by ``reset``, and agree with rsl_rl's model."""
    from tensordict import TensorDict

    r, student, onnx_path, policy_path = _distil_tiny_student(tmp_path, student_gru=8)
    assert json.loads((student / "train_meta.json").read_text())["policy"]["gru_dim"] == 8
    model = r.runner.alg.student
    model.eval()
    frames = torch.randn(4, 2, 42, generator=torch.Generator().manual_seed(0))  # 4 steps of 2 slots
    with torch.no_grad():
        model.reset(hidden_state=None)
        expected = [model(TensorDict({"student": frames[t]}, batch_size=[2])) for t in range(4)]
    assert not torch.allclose(expected[0], expected[3])
    for p in (list_checkpoints(student)[-1][1], policy_path, onnx_path):
        policy = load_policy_file(p)
        for _ in range(2):  # a reset starts the memory again
            policy.reset(np.arange(2))
            for t in range(4):
                a = policy.act({"student": frames[t]}, np.arange(2), [None, None])
                torch.testing.assert_close(a, expected[t], atol=1e-5, rtol=0)
        # slot 1 alone, after its own reset: the same actions (memory is per slot)
        policy.reset(np.array([1]))
        for t in range(4):
            a = policy.act({"student": frames[t, 1:]}, np.array([1]), [None])
            torch.testing.assert_close(a, expected[t][1:], atol=1e-5, rtol=0)
    assert "GRU of 8 units" in _evaluate_and_ship(tmp_path, policy_path, student)


def test_state_dependent_std_starts_as_the_source_policy_and_deploys_its_mean(tmp_path: Path):
    """--init-from a teacher with one std vector into a teacher whose std depends on the state:
    the same means and stds at the start; after training, the run's checkpoint, its exported
    files and a student distilled from it all see the mean head only."""
    src = tmp_path / "flat"
    run(spec(src))
    train = dataclasses.replace(TINY, policy=dataclasses.replace(TINY.policy, state_dependent_std=True))
    r = TrainingRun(spec(tmp_path / "sds", init_from=src, train=train))
    r.setup()
    obs = r.env.get_observations()
    new = r.runner.alg.get_policy()
    source = load_policy_file(src / "model_0.pt")
    torch.testing.assert_close(new(obs), source.act(obs, np.arange(4), [None] * 4), atol=1e-5, rtol=0)
    new(obs, stochastic_output=True)
    std = torch.load(src / "model_0.pt", weights_only=True)["actor_state_dict"]["distribution.std_param"]
    torch.testing.assert_close(new.distribution.std, std.expand(4, -1))
    r.run()
    sds = tmp_path / "sds"
    assert json.loads((sds / "train_meta.json").read_text())["policy"]["state_dependent_std"] is True
    ckpt = list_checkpoints(sds)[-1][1]
    trained = r.runner.alg.get_policy()
    onnx_path, policy_path = export(ExportArgs(checkpoint=ckpt, onnx=tmp_path / "sds.onnx"))
    for p in (ckpt, policy_path, onnx_path):
        policy = load_policy_file(p)
        torch.testing.assert_close(policy.act(obs, np.arange(4), [None] * 4), trained(obs)[:, :12], atol=1e-5, rtol=0)
    s = run(spec(tmp_path / "student", role="student", teacher=sds))
    assert all(math.isfinite(v) for v in s.last_loss.values())
    with pytest.raises(ValueError, match="state-dependent-std"):
        TrainingRun(spec(tmp_path / "plain", init_from=sds)).setup()


def test_student_distils_from_a_teacher_with_a_stall_fallback(tmp_path: Path):
    """--train.distillation.fallback-teacher: the composite labels with the second teacher once
    the robot has lain still, per env; a resumed student keeps both teachers."""
    from selfright.train.fallback_teacher import FallbackTeacher

    run(spec(tmp_path / "a"))
    run(spec(tmp_path / "b", seed=1))
    train = dataclasses.replace(TINY, distillation=dataclasses.replace(
        TINY.distillation, fallback_teacher=str(tmp_path / "b"), stall_s=0.02, fallback_s=0.04))
    r = run(spec(tmp_path / "student", role="student", teacher=tmp_path / "a", train=train))
    teacher = r.runner.alg.teacher
    assert isinstance(teacher, FallbackTeacher) and all(math.isfinite(v) for v in r.last_loss.values())
    # A robot lying still on its back: the second teacher labels from the first stalled step, for 2 steps.
    obs = r.env.get_observations()
    x = obs["teacher"].clone()
    x[:, 2], x[:, 3:6], x[:, 18:30] = 1.0, 0.0, 0.0
    obs["teacher"] = x
    teacher.reset(torch.ones(4, dtype=torch.bool))
    a, b = teacher.primary(obs), teacher.fallback(obs)
    got = [teacher(obs) for _ in range(3)]
    torch.testing.assert_close(got[0], b)
    torch.testing.assert_close(got[1], b)
    torch.testing.assert_close(got[2], b)  # still lying: a new stall is detected at once (stall_s = one step)
    resumed = TrainingRun(spec(tmp_path / "student", role="student", teacher=tmp_path / "a", train=train, iterations=2, resume=True))
    resumed.setup()
    assert isinstance(resumed.runner.alg.teacher, FallbackTeacher)
    torch.testing.assert_close(resumed.runner.alg.teacher.fallback(obs), b)
    assert not torch.equal(a, b)
    # The tilt rule: the second teacher labels exactly the tilted-over rows, whatever came before.
    tilt = dataclasses.replace(train, distillation=dataclasses.replace(train.distillation, fallback_tilt_deg=45.0))
    t = TrainingRun(spec(tmp_path / "student_tilt", role="student", teacher=tmp_path / "a", train=tilt))
    t.setup()
    x[:2, 2] = -1.0  # rows 0 and 1 upright, rows 2 and 3 on their back
    obs["teacher"] = x
    got = t.runner.alg.teacher(obs)
    torch.testing.assert_close(got[:2], a_up := t.runner.alg.teacher.primary(obs)[:2])
    torch.testing.assert_close(got[2:], t.runner.alg.teacher.fallback(obs)[2:])
    assert not torch.equal(a_up, t.runner.alg.teacher.fallback(obs)[:2])


def test_student_distils_from_a_rough_ground_teacher_where_the_scan_spreads(tmp_path: Path):
    """--train.distillation.rough-teacher: of the upright states, those whose height scan
    spreads over rough_scan_std_m are labelled by the third teacher; tilted ones still by the
    fallback; a resumed student keeps all three."""
    from selfright.env.observations import privileged_columns
    from selfright.train.fallback_teacher import FallbackTeacher

    for name, seed in (("a", 0), ("b", 1), ("c", 2)):
        run(spec(tmp_path / name, seed=seed))
    train = dataclasses.replace(TINY, distillation=dataclasses.replace(
        TINY.distillation, fallback_teacher=str(tmp_path / "b"), fallback_tilt_deg=45.0,
        rough_teacher=str(tmp_path / "c"), rough_scan_std_m=0.03))
    r = run(spec(tmp_path / "student", role="student", teacher=tmp_path / "a", train=train))
    teacher = r.runner.alg.teacher
    assert isinstance(teacher.primary, FallbackTeacher) and all(math.isfinite(v) for v in r.last_loss.values())
    obs = r.env.get_observations()
    x = obs["teacher"].clone()
    scan = privileged_columns(12)["scan"]
    x[:, scan] = 0.3
    x[:3, 2] = -1.0  # rows 0-2 upright, row 3 on its back
    x[1:, scan] += 0.05 * torch.tensor([1.0, -1.0] * 12 + [0.0])  # rows 1-3 over rough ground
    obs["teacher"] = x
    a, b, c = teacher.primary.primary(obs), teacher.fallback(obs), teacher.primary.fallback(obs)
    got = teacher(obs)
    torch.testing.assert_close(got[0], a[0])
    torch.testing.assert_close(got[1:3], c[1:3])
    torch.testing.assert_close(got[3], b[3])
    assert not torch.equal(a, c)
    resumed = TrainingRun(spec(tmp_path / "student", role="student", teacher=tmp_path / "a", train=train, iterations=2, resume=True))
    resumed.setup()
    torch.testing.assert_close(resumed.runner.alg.teacher.primary.fallback(obs), c)
    with pytest.raises(ValueError, match="rough-teacher"):
        no_fallback = dataclasses.replace(train, distillation=dataclasses.replace(train.distillation, fallback_teacher=None))
        TrainingRun(spec(tmp_path / "s2", role="student", teacher=tmp_path / "a", train=no_fallback)).setup()


def test_student_ppo_starts_as_the_student_with_the_teachers_critic_and_deploys_as_a_student(tmp_path: Path):
    """--role student-ppo: PPO whose actor is a distilled student (2 frames of history), copied
    exactly, with the teacher's critic and action std; its checkpoints load as that student."""
    _, student, _, policy_path = _distil_tiny_student(tmp_path, student_history=2)
    teacher = tmp_path / "teacher"
    out = tmp_path / "student_ppo"
    warm = dataclasses.replace(TINY, ppo=dataclasses.replace(TINY.ppo, critic_warmup_iterations=1))
    r = TrainingRun(spec(out, role="student-ppo", teacher=teacher, init_from=student, train=warm))
    r.setup()
    t = torch.load(list_checkpoints(teacher)[-1][1], weights_only=False)
    alg = r.runner.alg
    for k, v in t["critic_state_dict"].items():
        assert torch.equal(alg.critic.state_dict()[k], v)
    assert torch.equal(alg.actor.state_dict()["distribution.std_param"], t["actor_state_dict"]["distribution.std_param"])
    obs = r.env.get_observations()
    expected = load_policy_file(policy_path).module(obs["student_history"].float())
    torch.testing.assert_close(r.runner.get_inference_policy()(obs), expected, atol=1e-5, rtol=0)
    actor_before = copy.deepcopy(alg.actor.state_dict())
    r.run()  # its one iteration is the critic's warm-up: only the critic moves
    assert all(torch.equal(v, actor_before[k]) for k, v in alg.actor.state_dict().items() if not k.startswith("obs_"))
    assert not torch.equal(alg.critic.state_dict()["mlp.0.weight"], t["critic_state_dict"]["mlp.0.weight"])
    meta = json.loads((out / "train_meta.json").read_text())
    assert meta["role"] == "student-ppo" and meta["policy"]["obs_group"] == "student" and meta["policy"]["obs_history"] == 2
    policy = load_policy_file(list_checkpoints(out)[-1][1])
    assert policy.history == 2 and policy.module.meta.role == "student"
    r = run(spec(out, role="student-ppo", teacher=teacher, iterations=2, resume=True))  # resumes without --init-from
    assert list_checkpoints(out)[-1][0] == 1
    moved = torch.load(list_checkpoints(out)[-1][1], weights_only=False)["actor_state_dict"]
    assert not torch.equal(moved["mlp.0.weight"], actor_before["mlp.0.weight"])  # after the warm-up PPO moves the actor
    with pytest.raises(ValueError, match="must be a student"):
        TrainingRun(spec(tmp_path / "bad", role="student-ppo", teacher=teacher, init_from=teacher)).setup()
    # a student-ppo run lends its critic and action std to another (a fork under a new reward)
    fork = TrainingRun(spec(tmp_path / "fork", role="student-ppo", teacher=out, init_from=student))
    fork.setup()
    for k, v in torch.load(list_checkpoints(out)[-1][1], weights_only=False)["critic_state_dict"].items():
        assert torch.equal(fork.runner.alg.critic.state_dict()[k], v)
    with pytest.raises(ValueError, match="needs a teacher run"):  # a distilled student has no critic
        TrainingRun(spec(tmp_path / "bad2", role="student-ppo", teacher=student, init_from=student)).setup()
    card = _evaluate_and_ship(tmp_path, list_checkpoints(out)[-1][1], out)
    assert f"PPO on its own observations from the distilled student `{student}`" in card
    assert "its last 2 frames stacked" in card and "distilled from" not in card


def test_student_distils_a_fixed_stance_from_another_student(tmp_path: Path):
    """--train.distillation.stance-ramp-s: the teacher is a student whose actions are blended to a
    fixed stance once the trunk has been upright for the delay; the new student starts as a copy
    of it, trains, resumes, and its model card says the labels are not the seed's recipe."""
    _, base, _, base_file = _distil_tiny_student(tmp_path)
    stance = dataclasses.replace(TINY.distillation, stance_ramp_s=0.02, stance_delay_s=0.02, stance_tilt_deg=179.0)
    train = dataclasses.replace(TINY, distillation=stance)
    out = tmp_path / "stance"
    r = TrainingRun(spec(out, role="student", teacher=base, train=train))
    r.setup()
    obs = r.env.get_observations()
    base_actions = load_policy_file(base_file).module(obs["student"].float())
    torch.testing.assert_close(r.runner.get_inference_policy()(obs), base_actions, atol=1e-5, rtol=0)  # a copy
    teacher = r.runner.alg.teacher
    torch.testing.assert_close(teacher(obs), base_actions, atol=1e-5, rtol=0)  # upright 1 step: the delay
    target = teacher.target.expand_as(base_actions)
    torch.testing.assert_close(teacher(obs), target)  # 2 steps: delay and ramp done, the stance
    teacher.reset(torch.tensor([True, False, False, False]))
    labels = teacher(obs)
    torch.testing.assert_close(labels[0], base_actions[0], atol=1e-5, rtol=0)
    torch.testing.assert_close(labels[1:], target[1:])
    r.run()
    assert all(math.isfinite(v) for v in r.last_loss.values())
    r = run(spec(out, role="student", teacher=base, train=train, iterations=2, resume=True))
    assert list_checkpoints(out)[-1][0] == 1
    assert load_policy_file(list_checkpoints(out)[-1][1]).module.meta.role == "student"
    card = _evaluate_and_ship(tmp_path, list_checkpoints(out)[-1][1], out)
    assert f"distilled from `{list_checkpoints(base)[-1][1]}`" in card and "not the seed's recipe" in card
    partial = dataclasses.replace(stance, stance_weight=0.25)  # labels a quarter of the way to the stance
    p = TrainingRun(spec(tmp_path / "partial", role="student", teacher=base,
                         train=dataclasses.replace(TINY, distillation=partial)))
    p.setup()
    teacher = p.runner.alg.teacher
    teacher(obs)
    torch.testing.assert_close(teacher(obs), base_actions + 0.25 * (target - base_actions), atol=1e-5, rtol=0)
    with pytest.raises(ValueError, match="stance-ramp-s"):
        TrainingRun(spec(tmp_path / "bad", role="student-ppo", teacher=tmp_path / "teacher", init_from=base,
                         train=train)).setup()
    rescued = dataclasses.replace(stance, rescue_student=str(base_file))  # stalls labelled by a second student
    q = TrainingRun(spec(tmp_path / "rescued", role="student", teacher=base,
                         train=dataclasses.replace(TINY, distillation=rescued)))
    q.setup()
    assert q.runner.alg.teacher.rescue is not None and q.runner.alg.teacher.rescue_group == "student"
    no_stance = dataclasses.replace(TINY.distillation, rescue_student=str(base_file))
    with pytest.raises(ValueError, match="rescue-student"):
        TrainingRun(spec(tmp_path / "bad3", role="student", teacher=base,
                         train=dataclasses.replace(TINY, distillation=no_stance))).setup()
    noisy = dataclasses.replace(TINY, distillation=stance,  # a rescue student would read noisy sensors
                                randomization=dataclasses.replace(TINY.randomization, sensor_noise=1.0))
    with pytest.raises(ValueError, match="sensor-noise"):
        TrainingRun(spec(tmp_path / "bad4", role="student", teacher=base,
                         train=dataclasses.replace(noisy, distillation=rescued))).setup()
    with pytest.raises(ValueError, match="--init-from"):  # only a stance distillation starts from another student
        TrainingRun(spec(tmp_path / "bad5", role="student", teacher=tmp_path / "teacher", init_from=base)).setup()


def test_stance_labels_read_exact_sensors_and_the_student_can_start_as_another(tmp_path: Path):
    """Under --train.randomization.sensor-noise the stance labels come from the label student on the
    exact observation (group ``LABEL_GROUP``) while the student reads noisy sensors; with --init-from
    the student starts as that other student (its own history), and the card says both."""
    from selfright.train.config import LABEL_GROUP
    from selfright.train.student_ppo import load_student

    _, base, _, base_file = _distil_tiny_student(tmp_path)
    h2 = tmp_path / "student_h2"
    run(spec(h2, role="student", teacher=tmp_path / "teacher",
             train=dataclasses.replace(TINY, distillation=dataclasses.replace(TINY.distillation, student_history=2))))
    stance = dataclasses.replace(TINY.distillation, stance_ramp_s=0.02, stance_delay_s=1.0, stance_tilt_deg=179.0)
    train = dataclasses.replace(TINY, distillation=stance,
                                randomization=dataclasses.replace(TINY.randomization, sensor_noise=1.0))
    out = tmp_path / "noisy"
    r = TrainingRun(spec(out, role="student", teacher=base, init_from=h2, train=train))
    r.setup()
    obs = r.env.get_observations()
    torch.testing.assert_close(obs[LABEL_GROUP], obs["teacher"][:, :42])  # exact, one frame as the base reads
    assert (obs["student_history"][:, -42:] - obs[LABEL_GROUP]).abs().max() > 0.01  # the student's are noisy
    exact = load_policy_file(base_file).module(obs[LABEL_GROUP].float())
    torch.testing.assert_close(r.runner.alg.teacher(obs), exact, atol=1e-5, rtol=0)  # within the delay: the base
    start = load_student(h2)(obs["student_history"].float())
    torch.testing.assert_close(r.runner.get_inference_policy()(obs), start, atol=1e-5, rtol=0)  # a copy of h2
    r.run()
    r = run(spec(out, role="student", teacher=base, train=train, iterations=2, resume=True))  # keeps h2's network
    assert load_policy_file(list_checkpoints(out)[-1][1]).module.meta.obs_history == 2
    card = _evaluate_and_ship(tmp_path, list_checkpoints(out)[-1][1], out)
    assert f"started as a copy of the student `{h2}`" in card and "on exact sensors" in card
    assert "**Sensor noise**: trained reading its sensors through additive Gaussian noise at scale 1" in card
    copy = tmp_path / "copy"  # no stance: a copy of the base onto noisy sensors, labelled by it on exact ones
    validated = dataclasses.replace(train, distillation=TINY.distillation, validation=ValidationConfig(episodes=1))
    c = TrainingRun(spec(copy, role="student", teacher=base, train=validated))
    c.setup()
    obs = c.env.get_observations()
    for _ in range(3):  # never blended, however long upright
        torch.testing.assert_close(c.runner.alg.teacher(obs), load_policy_file(base_file).module(obs[LABEL_GROUP].float()),
                                   atol=1e-5, rtol=0)
    c.run()
    assert json.loads((copy / "train_meta.json").read_text())["labels_from_student"]
    summary = json.loads((copy / "validation" / "model_0" / "summary.json").read_text())
    assert summary["config"]["eval"]["sensor_noise"] == 1.0  # chosen through the noise it trained under
    with pytest.raises(ValueError, match="no fallback teacher"):
        fb = dataclasses.replace(TINY.distillation, fallback_teacher=str(tmp_path / "teacher"))
        TrainingRun(spec(tmp_path / "bad", role="student", teacher=base, train=dataclasses.replace(TINY, distillation=fb))).setup()


def test_stance_teacher_hands_a_tilted_stall_to_the_rescue_student():
    """--train.distillation.rescue-student: a robot lying still, tilted over, for the stall time is
    labelled by the rescue student (its actions and its previous-action input converted between
    references) until the hand-over time runs out; an episode's end resets the count."""
    from selfright.env.observations import prev_action_columns
    from selfright.policies.stall import StallSwitch
    from selfright.train.stance_teacher import StanceTeacher

    cols = prev_action_columns(12)
    base = lambda x: torch.zeros(x.shape[0], 12)  # noqa: E731
    rescue = lambda x: x[:, cols].clone()  # noqa: E731  (echoes the previous action it reads)
    offset = torch.full((12,), 0.5)
    teacher = StanceTeacher(base, "student", 3, 35.0, 100, 1, torch.zeros(12), rescue=rescue,
                            rescue_switch=StallSwitch(2, 2, None, 12), rescue_offset=offset)
    x = torch.zeros(3, 79)
    x[:, 0:3] = torch.tensor([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 0.0, -1.0]])  # lying on a side; upright
    x[:, cols] = 1.0
    obs = {"teacher": x, "student": x[:, :42]}
    assert torch.equal(teacher(obs), torch.zeros(3, 12))  # still for one step: not yet
    labels = teacher(obs)  # two steps: the tilted one is handed over, its input shifted into its own units
    torch.testing.assert_close(labels[0], torch.full((12,), 1.0))  # (1 − 0.5) + 0.5
    assert torch.equal(labels[1:], torch.zeros(2, 12))  # upright robots are never rescued
    teacher.reset(torch.tensor([True, False, False]))
    assert torch.equal(teacher(obs), torch.zeros(3, 12))
    with pytest.raises(ValueError, match="hand-over rule"):
        StanceTeacher(base, "student", 3, 35.0, 100, 1, torch.zeros(12), rescue=rescue)


def test_stance_teacher_leans_its_stance_to_gravity():
    """--train.distillation.stance-lean: the stance the labels blend to has its thighs turned by
    the trunk's pitch (read from the projected gravity each step)."""
    import math

    from selfright.policies.pose_blend import LeanedPose
    from selfright.train.stance_teacher import StanceTeacher

    base = lambda x: torch.zeros(x.shape[0], 12)  # noqa: E731
    lean = np.zeros((2, 12))
    lean[1, 1::3] = 2.0  # action units per rad of pitch on the thighs
    teacher = StanceTeacher(base, "student", 2, 35.0, 0, 1, LeanedPose(torch.zeros(12), lean))
    a = math.radians(20)
    x = torch.zeros(2, 42)
    x[0, :3] = torch.tensor([0.0, 0.0, -1.0])
    x[1, :3] = torch.tensor([-math.sin(a), 0.0, -math.cos(a)])  # nose up 20°, as facing up the incline
    labels = teacher({"teacher": x, "student": x})
    torch.testing.assert_close(labels[0], torch.zeros(12))
    torch.testing.assert_close(labels[1, 1::3], torch.full((4,), 2.0 * a))
    assert labels[1, 0::3].abs().max() == 0.0 and labels[1, 2::3].abs().max() == 0.0


def test_stance_teacher_holds_the_previous_action_once_still_over_the_bar():
    """--train.distillation.hold-after-s: a robot upright, over the height, with its trunk and
    joints still for the delay is labelled with the action it took the step before; one that
    moves, stands under the height or tilts over is labelled by the base; an episode's end resets
    the count."""
    from selfright.env.observations import JOINT_VEL_SCALE, joint_vel_columns, prev_action_columns, privileged_columns
    from selfright.train.stance_teacher import StanceTeacher, StillHold

    priv = privileged_columns(12)
    width = priv["factors"].stop
    base = lambda x: torch.zeros(x.shape[0], 12)  # noqa: E731
    hold = StillHold(4, 12, delay_steps=2, height_m=0.32, speed_mps=0.1, joint_speed_rad_s=1.0)
    teacher = StanceTeacher(base, "student", 4, 15.0, 0, 1, None, hold=hold)
    x = torch.zeros(4, width)
    x[:, 2] = -1.0  # upright
    x[:, priv["height"].start] = torch.tensor([0.35, 0.30, 0.35, 0.35])  # env 1 under the bar
    x[2, priv["velocity"].start] = 0.5  # env 2's trunk moves
    x[3, joint_vel_columns(12).start] = 3.0 * JOINT_VEL_SCALE  # env 3 has a leg in mid-step
    x[:, prev_action_columns(12)] = 0.7
    obs = {"teacher": x, "student": x[:, :42]}
    assert torch.equal(teacher(obs), torch.zeros(4, 12))  # still for one step: not yet
    labels = teacher(obs)
    torch.testing.assert_close(labels[0], torch.full((12,), 0.7))  # held: the previous action
    assert torch.equal(labels[1:], torch.zeros(3, 12))
    teacher.reset(torch.tensor([True, False, False, False]))
    assert torch.equal(teacher(obs)[0], torch.zeros(12))  # a new episode counts again
    tilted = x.clone()
    tilted[:, 0:3] = torch.tensor([1.0, 0.0, 0.0])
    assert torch.equal(teacher({"teacher": tilted, "student": tilted[:, :42]}), torch.zeros(4, 12))
    with pytest.raises(ValueError, match="delay"):
        StillHold(4, 12, 0, 0.32, 0.1, 1.0)


def test_hold_labels_need_a_student_to_hold(tmp_path):
    held = dataclasses.replace(TINY, distillation=dataclasses.replace(TINY.distillation, hold_after_s=0.5))
    with pytest.raises(ValueError, match="hold-after-s"):
        TrainingRun(spec(tmp_path / "bad", train=held)).setup()
