"""The diagnostic scripts run and print what their docs promise."""

from __future__ import annotations

import runpy
import sys
from pathlib import Path

import numpy as np
import pytest

SCRIPTS = Path(__file__).resolve().parent.parent / "scripts"


def run_script(name: str, args: list[str], monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(sys, "argv", [name, *args])
    runpy.run_path(str(SCRIPTS / name), run_name="__main__")


def episode_rows(out: Path) -> list[tuple[str, str, str, str]]:
    """(episode, success, TTR, energy) of each row of an evaluation's ``episodes.csv``."""
    import csv

    with (out / "episodes.csv").open() as fh:
        return [(r["episode"], r["success"], r["ttr_s"], r["energy_j"]) for r in csv.DictReader(fh)]


def failure_classes(out: str) -> list[int]:
    """Episode counts of ``failure_modes.py``'s classes (one per episode; not the bracketed markers)."""
    return [int(line.split()[-1]) for line in out.splitlines()[1:] if line.startswith("  ")
            and not line.strip().startswith(("(", "low:", "feet off:", "successes end", "stance ("))]


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


def test_slope_stance_stands_on_the_plane_and_tips_facing_up_the_incline(monkeypatch, capsys):
    run_script("slope_stance.py", ["--slopes-deg", "0", "20", "--headings-deg", "0", "90"], monkeypatch)
    tilts = {tuple(line.split()[1:4]): [float(v) for v in line.split()[-4::2]]
             for line in capsys.readouterr().out.splitlines() if line.strip().startswith("slope")}
    assert max(tilts[("0.0°", "tall", "stance")] + tilts[("0.0°", "A1", "stand")]) < 5.0
    assert min(tilts[("20.0°", "tall", "stance")] + tilts[("20.0°", "A1", "stand")]) > 60.0  # tipped over


def test_slope_stance_leaning_to_gravity_stands_facing_up_and_down_the_incline(monkeypatch, capsys):
    run_script("slope_stance.py", ["--slopes-deg", "20", "--headings-deg", "0", "180", "--lean", "0", "1"], monkeypatch)
    rows = {" ".join(line.split()[2:-4]): [float(v) for v in line.split()[-4::2]]
            for line in capsys.readouterr().out.splitlines() if line.strip().startswith("slope")}
    assert min(rows["tall stance"]) > 60.0  # square to the slope, it tips
    assert max(rows["tall stance, leaning 0 1"]) < 25.0  # feet under the hips: stands, square to the 20° slope


def test_slope_stance_level_stands_at_every_heading_over_the_bar(monkeypatch, capsys):
    run_script("slope_stance.py", ["--slopes-deg", "20", "--headings-deg", "0", "90", "180", "--level"], monkeypatch)
    (row,) = [line.split() for line in capsys.readouterr().out.splitlines() if "level stance" in line]
    tilts, heights = [float(v) for v in row[-6::2]], [float(v) for v in row[-5::2]]
    assert max(tilts) < 20.0  # up, across and down the 20° slope, held by the servos alone
    assert min(heights) > 0.33  # over the goal bar (0.32 m) above the ground beneath the trunk


def test_failure_modes_accounts_for_every_episode(monkeypatch, capsys):
    run_script("failure_modes.py", ["--policy", "zero", "--grid", "flat", "--episodes", "4"], monkeypatch)
    assert sum(failure_classes(capsys.readouterr().out)) == 4


def test_tumbles_finds_each_upright_spell_that_ends_tilted():
    sys.path.insert(0, str(SCRIPTS))
    try:
        from tumbles import final_stay, refalls
    finally:
        sys.path.remove(str(SCRIPTS))
    up_z = np.array([0.0, 0.9, 0.9, 0.9, 0.2, 0.95, 0.95])  # up for 3 steps, tilted, up to the end
    tip = np.array([0.0, 0.0, 0.0, 0.0, 180.0, 0.0, 0.0])
    feet = np.array([0, 4, 4, 1, 0, 4, 4])
    height = np.array([0.1, 0.3, 0.35, 0.3, 0.1, 0.33, 0.33])
    (e,) = refalls(up_z, tip, feet, height, ok=False, dt=0.02)  # the spell still upright at the end is no re-fall
    assert e.upright_s == pytest.approx(0.06) and e.mean_feet == 3.0 and e.max_height_m == 0.35 and e.tip_deg == 180.0
    assert np.isnan(e.downhill_mps)  # no speed series given
    downhill = np.array([0.0, 1.0, 2.0, 3.0, 0.0, 0.5, 0.7])
    (e,) = refalls(up_z, tip, feet, height, ok=False, dt=0.1, downhill=downhill)
    assert e.downhill_mps == pytest.approx(1.5)  # over its first 0.2 s: steps 1 and 2
    assert final_stay(up_z, height, downhill, dt=0.1) == pytest.approx((0.6, 0.33))  # the spell it ends in
    assert final_stay(up_z[:5], height[:5], downhill[:5], dt=0.1) is None  # ends tilted over


def test_tumbles_runs_on_the_incline(monkeypatch, capsys):
    run_script("tumbles.py", ["--policy", "zero", "--grid", "incline", "--episodes", "2"], monkeypatch)
    assert "re-falls in 2 episodes" in capsys.readouterr().out


def test_downhill_bins_every_episode_of_every_seed(monkeypatch, capsys):
    run_script("downhill.py", ["--policy", "zero", "--episodes", "2", "--seeds", "0", "1"], monkeypatch)
    out = capsys.readouterr().out
    assert "0 / 4 = 0.0 %" in out
    by_x, by_tilt = out.split("tilt when control starts")
    for table in (by_x, by_tilt):  # by position along the slope, then by the trunk's tilt
        counts = [int(line.split()[-3]) for line in table.splitlines() if line.strip().startswith("[")]
        assert sum(counts) == 4
    assert "travel of the failures" in out


def test_replays_take_a_tilt_composite(monkeypatch, capsys):
    run_script("failure_modes.py", ["--policy", "zero", "--tilted-policy", "random", "--grid", "flat", "--episodes", "2"],
               monkeypatch)
    assert sum(failure_classes(capsys.readouterr().out)) <= 2
    from selfright.config import BenchmarkConfig
    from selfright.evaluate.runner import ReplayArgs
    from selfright.policies.variants import Fallback

    a = ReplayArgs(policy="zero", tilted_policy="random", tilt_deg=30.0)
    assert isinstance(a.make_policy(BenchmarkConfig()), Fallback) and "tilted over 30 deg" in a.label
    from selfright.policies.variants import PoseUpright

    b = ReplayArgs(policy="zero", stance_weight=0.3)  # --stance-weight: blended a share of the way to the stance
    p = b.make_policy(BenchmarkConfig())
    assert isinstance(p, PoseUpright) and p.weight == 0.3 and p.delay == p.ramp == 50
    assert "0.3 of the way to the stance" in b.label


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


def test_reward_terms_averages_each_window(tmp_path, monkeypatch, capsys):
    from torch.utils.tensorboard import SummaryWriter

    w = SummaryWriter(str(tmp_path))
    for it in range(10):
        w.add_scalar("Episode_Reward/feet_contact", float(it), it)
        w.add_scalar("Metrics/in_goal", 1.0 if it < 5 else 0.0, it)
        w.add_scalar("Loss/value", 123.0, it)  # not a reward term: left out
    w.close()
    run_script("reward_terms.py", ["--run", str(tmp_path), "--windows", "0", "5", "5", "10"], monkeypatch)
    rows = {line.split()[0]: [float(v) for v in line.split()[1:]] for line in capsys.readouterr().out.splitlines()[1:]}
    assert rows == {"feet_contact": [2.0, 7.0], "Metrics/in_goal": [1.0, 0.0]}


def test_mirror_asymmetry_separates_symmetric_from_random(monkeypatch, capsys):
    """A joint-space P controller is its own mirror image (0); a random policy's action on the
    mirrored observation is an independent draw, so its gap is twice the action power (~2)."""
    import torch

    from selfright.policies.base import CallablePolicy

    probe_cls = runpy.run_path(str(SCRIPTS / "mirror_asymmetry.py"))["_MirrorProbe"]
    probe = probe_cls(CallablePolicy(lambda o: -o[:, 6:18]), "a1")  # a = −(q − nominal)
    obs = torch.randn(8, 42, generator=torch.Generator().manual_seed(0))
    probe.act({"student": obs}, None, [None] * 8)
    assert probe.gap < 1e-9 * probe.power
    run_script("mirror_asymmetry.py", ["--policy", "random", "--grid", "flat", "--episodes", "2"], monkeypatch)
    value = float(capsys.readouterr().out.split("asymmetry ")[1].split()[0])
    assert 1.5 < value < 2.5


def test_replay_on_a_larger_tile_keeps_the_falls(monkeypatch, capsys):
    """``--tile-size-m`` grows the tile around the same drop square; the default is the benchmark's."""
    from selfright.config import BenchmarkConfig
    from selfright.evaluate.runner import ReplayArgs, replay_env

    assert ReplayArgs().bench_config() == BenchmarkConfig()
    a = ReplayArgs(policy="zero", grid="incline", episodes=2, tile_size_m=12.0)
    env, _ = replay_env(a, a.bench_config())
    assert env.half_size == pytest.approx(6.0)
    env.close()
    run_script("failure_modes.py", ["--policy", "zero", "--grid", "incline", "--episodes", "2", "--tile-size-m", "12"],
               monkeypatch)
    assert sum(failure_classes(capsys.readouterr().out)) == 2


def test_replay_under_the_further_factors(monkeypatch, capsys):
    """The diagnostic scripts take ``selfright evaluate``'s factors (walls, softer ground,
    friction, sensor noise) into the worlds they replay, so a miss between walls can be classed."""
    from selfright.evaluate.runner import ReplayArgs, replay_env

    a = ReplayArgs(policy="zero", episodes=2, wall_gap_ratio=1.5, ground_timeconst=0.05, friction=0.8, sensor_noise=0.5)
    cfg = a.bench_config()
    assert (cfg.eval.wall_gap_ratio, cfg.eval.ground_timeconst_s, cfg.eval.friction, cfg.eval.sensor_noise) == (1.5, 0.05, 0.8, 0.5)
    env, _ = replay_env(a, cfg)
    world = env.worlds[0]
    assert (world.context.wall_gap_ratio, world.context.ground_timeconst_s, world.context.friction) == (1.5, 0.05, 0.8)
    assert world.model.geom("wall_left").contype[0] == 1
    env.close()
    run_script("failure_modes.py", ["--policy", "zero", "--episodes", "2", "--wall-gap-ratio", "1.5"], monkeypatch)
    assert sum(failure_classes(capsys.readouterr().out)) == 2


def test_average_checkpoints_means_the_actor_and_keeps_the_rest(tmp_path, monkeypatch):
    import torch

    paths = []
    for k in range(3):
        ckpt = {"actor_state_dict": {"mlp.0.weight": torch.full((2, 2), float(k)), "obs_normalizer._mean": torch.full((2,), float(k * k))},
                "critic_state_dict": {"mlp.0.weight": torch.full((1, 2), float(k))}, "iter": k}
        paths.append(tmp_path / f"model_{k}.pt")
        torch.save(ckpt, paths[-1])
    out = tmp_path / "avg.pt"
    run_script("average_checkpoints.py", ["--out", str(out), "--checkpoints", *map(str, paths)], monkeypatch)
    avg = torch.load(out, weights_only=True)
    assert torch.equal(avg["actor_state_dict"]["mlp.0.weight"], torch.full((2, 2), 1.0))
    assert torch.equal(avg["actor_state_dict"]["obs_normalizer._mean"], torch.full((2,), 1.0))  # the middle one's (the mean would be 5/3)
    assert avg["iter"] == 1 and torch.equal(avg["critic_state_dict"]["mlp.0.weight"], torch.full((1, 2), 1.0))


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


def test_a_soup_with_folded_normalisers_acts_as_the_mean_of_folded_actors(tmp_path, monkeypatch):
    """Folding a normaliser into the first layer is exact, so a soup of one checkpoint with
    itself acts as it does; a soup of two has the mean first-layer weights of the folded pair."""
    import torch

    from selfright.policies.actor import actor_from_checkpoint

    gen = torch.Generator().manual_seed(0)
    a, b = _student_checkpoint(gen, 0.0), _student_checkpoint(gen, 1.0)
    b["student_ema_state_dict"] = b.pop("student_state_dict")  # the deployed weights of a run with an average
    paths = [tmp_path / "a.pt", tmp_path / "b.pt"]
    torch.save(a, paths[0])
    torch.save(b, paths[1])
    obs = torch.randn(64, 42, generator=gen)
    run_script("average_checkpoints.py", ["--fold-normaliser", "--out", str(tmp_path / "aa.pt"),
                                          "--checkpoints", str(paths[0]), str(paths[0])], monkeypatch)
    same = torch.load(tmp_path / "aa.pt", weights_only=True)
    assert torch.allclose(actor_from_checkpoint(same)(obs), actor_from_checkpoint(a)(obs), atol=1e-5)
    with pytest.raises(SystemExit, match="different keys"):  # a student and a weight average are not mixed silently
        run_script("average_checkpoints.py", ["--out", str(tmp_path / "ab.pt"), "--checkpoints", *map(str, paths)], monkeypatch)
    b["student_state_dict"] = b.pop("student_ema_state_dict")
    torch.save(b, paths[1])
    run_script("average_checkpoints.py", ["--fold-normaliser", "--out", str(tmp_path / "ab.pt"),
                                          "--checkpoints", *map(str, paths)], monkeypatch)
    soup = torch.load(tmp_path / "ab.pt", weights_only=True)["student_state_dict"]
    folded = [c["student_state_dict"]["mlp.0.weight"] / (c["student_state_dict"]["obs_normalizer._std"] + 1e-2)
              for c in (a, b)]
    assert torch.allclose(soup["mlp.0.weight"], (folded[0] + folded[1]) / 2, atol=1e-6)
    assert torch.allclose(soup["mlp.2.weight"], (a["student_state_dict"]["mlp.2.weight"] + b["student_state_dict"]["mlp.2.weight"]) / 2)


def test_actor_to_run_makes_a_teacher_run_of_a_shipped_teacher(tmp_path, monkeypatch):
    from selfright.policies.actor import actor_from_checkpoint, load_actor_file
    from selfright.policies.registry import shipped_path
    from selfright.train.checkpoints import latest_checkpoint
    from selfright.train.config import PolicyConfig
    from selfright.train.runner import teacher_policy_config
    from selfright.train.ship import card_record

    import torch

    out = tmp_path / "rough_teacher"
    run_script("actor_to_run.py", ["--policy", "rough-teacher", "--out", str(out)], monkeypatch)
    ckpt = latest_checkpoint(out)
    cfg, meta = teacher_policy_config(ckpt, PolicyConfig())
    assert meta["role"] == "teacher" and meta["context"] == "rough" and cfg.hidden_dims == (256, 128, 64)
    steps = card_record(shipped_path("rough-teacher").with_suffix(".md").read_text())["env_steps"]
    assert steps > 0 and meta["env_steps"] == steps and meta["train_config"]["reward"]["feet_contact"] == 8.0  # from its card
    back = actor_from_checkpoint(torch.load(ckpt, weights_only=True), meta["policy"])
    shipped = load_actor_file(shipped_path("rough-teacher"))
    assert all(torch.equal(a, b) for a, b in zip(back.state_dict().values(), shipped.state_dict().values()))
    with pytest.raises(SystemExit):  # a student cannot be a distillation teacher
        run_script("actor_to_run.py", ["--policy", "rough", "--out", str(tmp_path / "student")], monkeypatch)


def test_seed_table_pools_seeds(tmp_path, monkeypatch, capsys):
    import json

    for seed, k in [(0, 3), (1, 1)]:
        (tmp_path / f"s{seed}").mkdir()
        (tmp_path / f"s{seed}" / "summary.json").write_text(json.dumps({
            "policy": "p", "grid": "flat", "episodes_per_cell": 4, "seed": seed,
            "overall": {"success_rate": k / 4, "n": 4}}))
    run_script("seed_table.py", [str(tmp_path / "s0"), str(tmp_path / "s1")], monkeypatch)
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split() == ["seed", "0:", "3", "/", "4", "=", "75.0", "%", "[30,", "95]"]
    assert lines[-1].split()[:7] == ["pooled:", "4", "/", "8", "=", "50.0", "%"]
    with pytest.raises(SystemExit, match="seed 0 appears twice"):
        run_script("seed_table.py", [str(tmp_path / "s0"), str(tmp_path / "s0")], monkeypatch)


def tiny_checkpoint(tmp_path: Path) -> Path:
    """A one-layer PPO teacher checkpoint with a state-independent std of 0.3."""
    import torch

    ckpt = tmp_path / "run" / "model_0.pt"
    ckpt.parent.mkdir()
    g = torch.Generator().manual_seed(0)
    torch.save({"actor_state_dict": {"mlp.0.weight": 0.1 * torch.randn(12, 79, generator=g), "mlp.0.bias": torch.zeros(12),
                                     "distribution.std_param": torch.full((12,), 0.3)}, "iter": 0, "infos": {}}, ckpt)
    return ckpt


def test_policy_variants_noise_is_seeded_an_ensemble_of_one_policy_is_that_policy_and_smoothing_acts(tmp_path, monkeypatch, capsys):
    ckpt = tiny_checkpoint(tmp_path)
    common = ["--grid", "tiny", "--episodes", "1", "--seed", "3"]
    outs = {}
    for tag, extra in [("a", ["--policies", str(ckpt), "--noise-scale", "1"]), ("b", ["--policies", str(ckpt), "--noise-scale", "1"]),
                       ("mean", ["--policies", str(ckpt)]), ("zero", ["--policies", "zero"]), ("zz", ["--policies", "zero", "zero"]),
                       ("fb", ["--policies", "zero", "random", "--fallback-s", "2"]),
                       ("rand", ["--policies", "random"]), ("smooth", ["--policies", "random", "--smooth", "0.9"]),
                       ("fb_smooth", ["--policies", "zero", "random", "--fallback-s", "2", "--smooth", "0.9", "--smooth-last"]),
                       ("brake", ["--policies", "random", "--brake-pose", "0", "0.46", "0.46", "-0.92", "--brake-tilt-deg", "90"])]:
        outs[tag] = tmp_path / tag
        run_script("policy_variants.py", [*common, *extra, "--out", str(outs[tag])], monkeypatch)
    printed = capsys.readouterr().out
    assert "noise x1" in printed and "low-passed, beta 0.9" in printed
    assert "braked to (0.0, 0.46, 0.46, -0.92) past 90 deg after upright" in printed
    assert episode_rows(outs["smooth"]) != episode_rows(outs["rand"])  # the filter changes what the random policy does
    assert episode_rows(outs["fb_smooth"]) != episode_rows(outs["fb"])  # the same filter on the fallback alone
    with pytest.raises(SystemExit, match="--smooth-last takes"):
        run_script("policy_variants.py", [*common, "--policies", "zero", "--smooth", "0.5", "--smooth-last", "--out", str(tmp_path / "y")], monkeypatch)
    assert episode_rows(outs["a"]) == episode_rows(outs["b"]) and episode_rows(outs["a"]) != episode_rows(outs["mean"])
    assert episode_rows(outs["zz"]) == episode_rows(outs["zero"])
    assert episode_rows(outs["fb"]) != episode_rows(outs["zero"])  # the held pose stalls tilted; random actions take over
    with pytest.raises(SystemExit, match="no state-independent action std"):
        run_script("policy_variants.py", [*common, "--policies", "zero", "--noise-scale", "1", "--out", str(tmp_path / "x")], monkeypatch)


def test_policy_variants_noise_std_nudges_any_policy_and_streams_draw_apart(tmp_path, monkeypatch, capsys):
    """``--noise-std`` is ``--noise-scale`` in action units (the same draws), for policies with no
    trained std too; ``--noise-stream`` draws other noise on the same falls."""
    ckpt = tiny_checkpoint(tmp_path)  # trained std 0.3
    common = ["--grid", "tiny", "--episodes", "1", "--seed", "3"]
    outs = {}
    for tag, extra in [("scale", ["--policies", str(ckpt), "--noise-scale", "1"]), ("std", ["--policies", str(ckpt), "--noise-std", "0.3"]),
                       ("k1", ["--policies", str(ckpt), "--noise-std", "0.3", "--noise-stream", "1"]),
                       ("zero", ["--policies", "zero", "--noise-std", "0.05", "--noise-stream", "2"])]:
        outs[tag] = tmp_path / tag
        run_script("policy_variants.py", [*common, *extra, "--out", str(outs[tag])], monkeypatch)
    assert "noise std 0.05) (noise stream 2)" in capsys.readouterr().out
    assert episode_rows(outs["std"]) == episode_rows(outs["scale"]) != episode_rows(outs["k1"])
    with pytest.raises(SystemExit, match="not both"):
        run_script("policy_variants.py", [*common, "--policies", str(ckpt), "--noise-std", "0.1", "--noise-scale", "1",
                                          "--out", str(tmp_path / "x")], monkeypatch)


def test_failure_overlap_counts_shared_failures(tmp_path, monkeypatch, capsys):
    import json

    outcomes = {"p": [1, 0, 0, 1], "q": [1, 1, 0, 0]}
    for name, ok in outcomes.items():
        d = tmp_path / name
        d.mkdir()
        (d / "summary.json").write_text(json.dumps({"policy": name, "grid": "flat", "seed": 0}))
        (d / "episodes.csv").write_text("slope_level,roughness_level,episode,success\n"
                                        + "".join(f"0,0,{e},{s}\n" for e, s in enumerate(ok)))
    run_script("failure_overlap.py", [str(tmp_path / "p"), str(tmp_path / "q")], monkeypatch)
    out = capsys.readouterr().out
    assert "   0: 1" in out and "   1: 2" in out and "   2: 1" in out
    assert "at least one policy succeeded: 75.0%; all failed: 1 episodes" in out
    assert "paired: only p on flat got up in 1, only q on flat in 1; McNemar p = 1.000" in out
    with pytest.raises(SystemExit, match="at least two policies"):
        run_script("failure_overlap.py", [str(tmp_path / "p")], monkeypatch)


def test_stance_under_noise_prints_shares_per_checkpoint_and_scale(tmp_path, monkeypatch, capsys):
    ckpt = tiny_checkpoint(tmp_path)
    run_script("stance_under_noise.py", ["--checkpoints", str(ckpt), "--episodes", "2", "--noise-scales", "0", "1"], monkeypatch)
    lines = [ln.split() for ln in capsys.readouterr().out.splitlines()[1:]]
    assert [ln[1] for ln in lines] == ["0.00", "1.00"]
    assert all(0.0 <= float(x) <= 1.0 for ln in lines for x in ln[2:4])


def test_stall_rotation_hands_a_stalled_robot_over(tmp_path, monkeypatch, capsys):
    common = ["--grid", "tiny", "--episodes", "1", "--seed", "3", "--first", "zero"]
    for tag, extra in [("same", ["--second", "zero"]), ("rand", ["--second", "random"]),
                       ("kin", ["--second", "random", "--kinematic"]), ("esc", ["--second", "zero", "--escape", "random"])]:
        run_script("stall_rotation.py", [*common, *extra, "--out", str(tmp_path / tag)], monkeypatch)
    assert "then (stalled 0.5 s, for 1 s) random" in capsys.readouterr().out
    assert episode_rows(tmp_path / "rand") != episode_rows(tmp_path / "same")  # the held pose stalls; random actions take over
    assert episode_rows(tmp_path / "kin") != episode_rows(tmp_path / "same")  # sensors only: tilted stalls are seen without the teacher
    assert episode_rows(tmp_path / "esc") != episode_rows(tmp_path / "same")  # the escape acts while tilted


def test_kinematic_height_reports_the_error_and_final_readings(monkeypatch, capsys):
    run_script("kinematic_height.py", ["--policy", "flat", "--grid", "flat", "--episodes", "4"], monkeypatch)
    head = capsys.readouterr().out.splitlines()[0]
    mean_m = float(head.split("mean ")[1].split(" m")[0])
    assert 0.0 < mean_m < 0.03  # feet sink a little into the contact: the estimate reads a bit high


def test_graft_actor_keeps_the_runs_critic_and_std_and_takes_the_other_actor(tmp_path, monkeypatch, capsys):
    import json

    import torch

    def actor(v: float) -> dict:
        return {"mlp.0.weight": torch.full((2, 3), v), "distribution.std_param": torch.full((2,), v)}

    run = tmp_path / "ppo"
    run.mkdir()
    torch.save({"actor_state_dict": actor(1.0), "critic_state_dict": {"w": torch.ones(1)}, "iter": 7}, run / "model_7.pt")
    (run / "train_meta.json").write_text(json.dumps({"latest_checkpoint": str(run / "model_7.pt")}))
    torch.save({"student_state_dict": actor(2.0)}, tmp_path / "student.pt")
    out = tmp_path / "fork"
    run_script("graft_actor.py", ["--run", str(run / "model_7.pt"), "--actor", str(tmp_path / "student.pt"),
                                  "--out", str(out)], monkeypatch)
    ck = torch.load(out / "model_7.pt", weights_only=False)
    assert ck["actor_state_dict"]["mlp.0.weight"].eq(2.0).all()  # the other actor's weights
    assert ck["actor_state_dict"]["distribution.std_param"].eq(1.0).all()  # the run's own std
    assert ck["critic_state_dict"]["w"].eq(1.0).all() and ck["iter"] == 7
    meta = json.loads((out / "train_meta.json").read_text())
    assert meta["latest_checkpoint"] == str(out / "model_7.pt") and meta["grafted_actor"] == str(tmp_path / "student.pt")
    torch.save({"student_state_dict": {"mlp.0.weight": torch.ones(4, 3)}}, tmp_path / "other.pt")
    with pytest.raises(SystemExit, match="differ"):
        run_script("graft_actor.py", ["--run", str(run / "model_7.pt"), "--actor", str(tmp_path / "other.pt"),
                                      "--out", str(tmp_path / "fork2")], monkeypatch)


def test_joint_stops_reports_each_joint_kind_and_the_rated_speed(monkeypatch, capsys):
    run_script("joint_stops.py", ["--policy", "random", "--grid", "flat", "--episodes", "2"], monkeypatch)
    out = capsys.readouterr().out
    assert " / 2 successes" in out
    for kind in ("abduction", "hip", "knee"):
        assert kind in out
    assert "faster than 21 rad/s" in out


def test_train_tiles_swaps_in_the_training_tiles_or_fresh_draws(tmp_path, monkeypatch):
    import csv

    from selfright.config import BenchmarkConfig
    from selfright.train.contexts import make_training_worlds

    rs = {}
    for tiles in ("train", "fresh"):
        out = tmp_path / tiles
        run_script("train_tiles.py", ["--policy", "zero", "--tiles", tiles, "--episodes", "1", "--out", str(out)], monkeypatch)
        with (out / "episodes.csv").open() as fh:
            rs[tiles] = {r["roughness_level"]: float(r["roughness_R"]) for r in csv.DictReader(fh)}
    assert sorted(rs["train"], key=int) == ["4", "8", "12"]
    trained = make_training_worlds("rough", BenchmarkConfig(), seed=0)
    assert rs["train"]["12"] == pytest.approx(trained[6].tile.roughness(), rel=1e-3)  # 0.306 m, nearest level 12
    assert all(rs["train"][k] != pytest.approx(rs["fresh"][k], rel=1e-3) for k in rs["train"])


def test_policy_variants_envelope_speed_is_the_trained_one_by_default_and_cuts_a_slower_one(tmp_path, monkeypatch, capsys):
    """``--envelope-speed-rad-s`` at a DC policy's own training speed runs it as ``selfright
    evaluate`` does; a slower envelope changes its episodes."""
    common = ["--policies", "rough", "--grid", "tiny", "--episodes", "2", "--seed", "1"]
    outs = {tag: tmp_path / tag for tag in ("own", "v21", "v8")}
    for tag, extra in [("own", []), ("v21", ["--envelope-speed-rad-s", "21"]), ("v8", ["--envelope-speed-rad-s", "8"])]:
        run_script("policy_variants.py", [*common, *extra, "--out", str(outs[tag])], monkeypatch)
    assert "DC envelope at 8 rad/s" in capsys.readouterr().out
    assert episode_rows(outs["v21"]) == episode_rows(outs["own"])
    assert episode_rows(outs["v8"]) != episode_rows(outs["own"])


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


def test_lineage_follows_a_shipped_policy_named_as_a_source_into_its_runs(monkeypatch, capsys):
    """``flat-walls`` started ``--init-from flat``: the listing goes on into the runs of the shipped
    ``flat`` (its card's run and checkpoint), and the script feeds the retrained checkpoint to the
    source flag only, not to ``--context flat``."""
    run_script("lineage.py", ["--policy", "flat-walls"], monkeypatch)
    out = capsys.readouterr().out
    assert "from --init-from flat (shipped): runs/flat_student_stance (uses model_394.pt)" in out
    assert out.index("runs/flat_student_stance:") < out.index("runs/flat_walls_sppo:")
    run_script("lineage.py", ["--policy", "flat-walls", "--script", "--from-step", "5"], monkeypatch)
    sppo = next(line for line in capsys.readouterr().out.splitlines() if line.startswith("step runs/retrain/flat_walls_sppo"))
    assert "--context flat --init-from runs/retrain/flat_student_stance/model_394.pt" in sppo


def test_noise_sweep_tabulates_each_policy_at_each_scale_on_the_same_falls(tmp_path, monkeypatch, capsys):
    import json

    out = tmp_path / "sweep"
    args = ["--policies", "zero", "flat", "--grid", "tiny", "--scales", "0", "2", "--episodes", "1", "--out", str(out)]
    run_script("factor_sweep.py", args, monkeypatch)
    lines = capsys.readouterr().out.splitlines()
    assert lines[1] == "| policy | noise 0 | noise 2 |" and len(lines) == 5
    assert lines[3].startswith("| `zero` |") and lines[4].startswith("| `flat` |")
    noisy = json.loads((out / "flat" / "noise2" / "s4" / "summary.json").read_text())
    assert noisy["config"]["eval"]["sensor_noise"] == 2.0 and noisy["overall"]["n"] == 4
    exact = json.loads((out / "flat" / "noise0" / "s4" / "summary.json").read_text())
    assert exact["config"]["eval"]["sensor_noise"] == 0.0
    run_script("factor_sweep.py", args, monkeypatch)  # a rerun reads the folders back
    assert capsys.readouterr().out.splitlines() == lines


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
    lineage = runpy.run_path(str(Path(__file__).parents[1] / "scripts" / "lineage.py"), run_name="lineage")
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
    lineage = runpy.run_path(str(Path(__file__).parents[1] / "scripts" / "lineage.py"), run_name="lineage")
    meta = {"command_lines": ["selfright train --out runs/x"], "benchmark_config": {"robot": {}}, "train_config": {}}
    drift = lineage["config_drift"](meta, [])
    assert not any("robot.motor" in line for line in drift), drift
    meta["command_lines"] = ["selfright train --out runs/x --motor dcmotor"]
    drift = lineage["config_drift"](meta, [])
    assert 'benchmark_config.robot.motor: not recorded (before it existed), now "dcmotor"' in drift
    assert not any("motor_speed_rad_s" in line for line in drift), drift


def test_soft_ground_sink_reads_the_stand_pose_under_the_bar_only_on_soft_ground(monkeypatch, capsys):
    run_script("soft_ground_sink.py", ["--timeconsts", "0.02", "0.1", "--seconds", "1"], monkeypatch)
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].endswith(", in the goal set") and lines[1].endswith("not in the goal set")
    heights = [float(line.split("trunk ")[1].split(" m")[0]) for line in lines]
    assert heights[0] > 0.32 > heights[1]


def test_multiplexer_rule_scores_rules_from_the_members_cells(tmp_path, monkeypatch, capsys):
    import json

    # two slope rows (0° and 16.7°) × roughness levels 0 and 1, 10 falls each
    succ = {"flat": [10, 2, 1, 0], "rough": [9, 9, 3, 8], "incline": [5, 1, 7, 2]}
    cells = [(0, 0, 0.0), (0, 1, 0.0), (3, 0, 16.7), (3, 1, 16.7)]
    folders = []
    for member, ok in succ.items():
        f = tmp_path / member
        f.mkdir()
        summary = {"cells": [{"slope_level": s, "roughness_level": r, "slope_deg": d, "n": 10, "successes": k}
                             for (s, r, d), k in zip(cells, ok)]}
        (f / "summary.json").write_text(json.dumps(summary))
        folders += [f"--{member}", str(f)]
    run_script("multiplexer_rule.py", [*folders, "--thresholds-deg", "15", "20"], monkeypatch)
    out = capsys.readouterr().out
    assert "40 falls" in out
    # the shipped rule: flat 10, rough 9, incline 7 and 2 = 28 of 40
    assert "the rule until 2026-12-06 (T = 15°, incline at every roughness): 70.0 %" in out
    assert "the shipped rule (T = 15°, R = 7): 70.0 %" in out  # both rough levels here are under 7
    assert "per-cell oracle: 85.0 %" in out  # 10 + 9 + 7 + 8
    lines = out.splitlines()
    best = lines[lines.index("best rules (incline if slope ≥ T and roughness level < R):") + 1]
    assert best == "  T = 15°, R = 1: 85.0 %"  # incline on the smooth slope only


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
