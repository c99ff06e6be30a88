"""``selfright`` command line: evaluate, compare, yaw-study, report, replay, scene, bench-sim, train, export, ship (tyro subcommands)."""

from __future__ import annotations

import json
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import tyro

from selfright.config import ActionConfig, BenchmarkConfig, ContextConfig, EvalConfig, GoalConfig, Motor, RobotConfig, SimConfig
from selfright.evaluate.factors import FurtherFactors

Grid = Literal["tiny", "quick", "paper", "flat", "rough", "incline"]


def policy_stem(policy: str) -> str:
    """A policy's name for a default results folder: a file's stem, ``FILE-NAME`` for a Python
    policy ``FILE.py:NAME`` or ``package.module:NAME``."""
    where, sep, attr = policy.rpartition(":")
    if sep and where:
        return f"{Path(where).stem if where.endswith('.py') else where.rpartition('.')[2]}-{attr}"
    return Path(policy).stem


@dataclass(frozen=True)
class _Episodes(FurtherFactors):
    """Options shared by ``evaluate`` and ``replay``: which policy, which episodes, under what
    (the further factors: ``FurtherFactors``)."""

    policy: str = "open-loop"
    """zero | random | open-loop | a shipped policy (flat, rough, incline, sr, flat-teacher, rough-teacher, incline-teacher) | a .pt/.onnx file | a training run folder (its latest checkpoint) | your Python policy as FILE.py:NAME or package.module:NAME (README, *Your own policy*)."""
    grid: Grid = "quick"
    """tiny = 2×2 cells (tests), quick = every other level, paper = full 11×20 grid, or a training context."""
    seed: int = 0
    """Run seed: terrain and every episode's fall are derived from it."""
    threads: int = 0
    """Physics threads (0 = one per core)."""
    hold_s: float = 1.0
    """Seconds the goal set must be held for success."""
    episode_s: float = 10.0
    """Episode limit after settling (s)."""
    goal_height_ref: Literal["feet", "terrain"] = "feet"
    """The goal set's body height: over the mean of the feet's lowest points (the benchmark's) or over the ground beneath the trunk (for comparison)."""
    action_reference: Literal["stand", "current", "tall"] = "stand"
    """Joint targets = this pose + 0.5 rad × action; must be the one the policy was trained with."""
    motor: Motor = "dcmotor"
    """Motor model: dcmotor (the A1's DC motors, the benchmark's default: 33.5 N·m at stall, the torque along the motion falling to 0 at the rated 21 rad/s) or ideal (full torque at any speed, for comparison)."""
    fall_cache: bool = True
    """Read settled falls from (and write them to) $XDG_CACHE_HOME/selfright (default ~/.cache/selfright); --no-fall-cache settles every fall anew (same results)."""

    def bench_config(self, batch_size: int = 64) -> BenchmarkConfig:
        return _benchmark_config(
            threads=self.threads, batch_size=batch_size, hold_s=self.hold_s, episode_s=self.episode_s,
            height_ref=self.goal_height_ref, action_reference=self.action_reference, motor=self.motor, **self.factor_kwargs(),
        )


@dataclass(frozen=True)
class Evaluate(_Episodes):
    """Evaluate a policy on a grid of terrain contexts; writes episodes.csv, summary.json, plots."""

    episodes: int = 20
    """Episodes per cell."""
    out: Path | None = None
    """Results directory (default results/POLICY_GRID). Rerunning into it resumes."""
    batch_size: int = 64
    """Episodes simulated side by side."""
    plots: bool = True
    """Write the heatmaps and histograms."""
    executor: Literal["local", "ray"] = "local"
    """Where the batches run: local (this process) or ray (Ray tasks; pip install -e ".[ray]"; docs/ray.md). Same results."""
    ray_address: str | None = None
    """With --executor ray: the cluster to join (HOST:PORT of `ray start --head`, or auto); default a local Ray with --threads workers."""
    progress: bool = True
    """Show a progress bar."""


@dataclass(frozen=True)
class Replay(_Episodes):
    """Replay one episode of an evaluation (same fall and outcome as its episodes.csv row) and
    record it: trace.csv / trace.png (height, tilt, feet over time), episode.gif, filmstrip.png."""

    policy: str = "flat"
    """As for evaluate."""
    grid: Grid = "flat"
    """As for evaluate; pick the cell with --slope-level / --roughness-level if it has several."""
    episode: int = 0
    """Episode index within the cell (the episode column of episodes.csv)."""
    slope_level: int | None = None
    """Slope level of the cell (needed only if the grid has several)."""
    roughness_level: int | None = None
    """Roughness level of the cell (needed only if the grid has several)."""
    out: Path | None = None
    """Output folder (default results/replay_POLICY_GRID_SLOPE-ROUGHNESS_EPISODE_sSEED)."""
    video: bool = True
    """Render episode.gif and filmstrip.png (offscreen OpenGL: MUJOCO_GL=egl unless set)."""
    width: int = 320
    """Video width (pixels)."""
    height: int = 240
    """Video height (pixels)."""


@dataclass(frozen=True)
class Compare:
    """Compare policies on the same falls: each policy's success with its 95 % interval and,
    for two policies, the exact McNemar test on the falls only one of them got up from. Give the
    results folders of ``selfright evaluate`` runs with the same grid and seeds (several seeds
    per policy pool); nothing is simulated."""

    folders: tyro.conf.Positional[tuple[Path, ...]]
    """Results folders (grouped by the policy named in their summary.json)."""
    by_cell: bool = False
    """Also print each policy's rate in every cell."""
    plot: Path | None = None
    """With two policies: write a heatmap of the per-cell success difference (the second policy
    in name order minus the first, with a per-cell McNemar mark) to this PNG."""


@dataclass(frozen=True)
class _Study:
    """Options shared by ``yaw-study`` and ``report``."""

    episodes: int = 20
    """Episodes per grid cell and per yaw-study slope and heading."""
    slopes_deg: tuple[float, ...] = (12.0, 15.0, 18.0)
    """Inclines of the yaw study (deg); the seed's Table II used 12, 15 and 18."""
    seed: int = 0
    """Run seed: terrain and every episode's fall and heading are derived from it."""
    threads: int = 0
    """Physics threads (0 = one per core)."""
    batch_size: int = 64
    """Episodes simulated side by side."""
    hold_s: float = 1.0
    """Seconds the goal set must be held for success."""
    episode_s: float = 10.0
    """Episode limit after settling (s)."""
    progress: bool = True
    """Show progress bars."""
    fall_cache: bool = True
    """Read settled falls from (and write them to) $XDG_CACHE_HOME/selfright (default ~/.cache/selfright); --no-fall-cache settles every fall anew (same results)."""
    executor: Literal["local", "ray"] = "local"
    """Where the batches run: local (this process) or ray (Ray tasks; pip install -e ".[ray]"; docs/ray.md). Same results."""
    ray_address: str | None = None
    """With --executor ray: the cluster to join (HOST:PORT of `ray start --head`, or auto); default a local Ray with --threads workers."""

    def bench_config(self) -> BenchmarkConfig:
        if self.batch_size < 1:
            raise ValueError("--batch-size must be >= 1")
        return _benchmark_config(threads=self.threads, batch_size=self.batch_size, hold_s=self.hold_s, episode_s=self.episode_s)


@dataclass(frozen=True)
class YawStudy(_Study):
    """The seed's Table II in simulation: recoveries on smooth inclines from headings within ±15°
    of down-, up- and cross-slope (docs/benchmark.md, *Yaw study*); writes episodes.csv, yaw.csv, yaw.png."""

    policy: str = "open-loop"
    """As for evaluate."""
    out: Path | None = None
    """Results directory (default results/POLICY_yaw). Rerunning into it resumes."""


@dataclass(frozen=True)
class Report(_Study):
    """The seed's experiments for a set of policies: each on a grid and in the yaw study, then
    DIR/report.md and DIR/index.html with the heatmaps, histograms, Table II and the seed's
    claims beside our numbers. Rerunning into DIR resumes."""

    grid: Literal["tiny", "quick", "paper"] = "quick"
    """tiny = 2×2 cells (tests), quick = every other level, paper = the full 11×20 grid."""
    policies: tuple[str, ...] = ("open-loop", "flat", "rough", "incline", "sr")
    """Policies to run (as for evaluate), in the report's order; default the seed's set. Give your own list, e.g. --policies flat mine.py:MyPolicy."""
    out: Path = Path("results/report")
    """Report directory: one results folder per policy (its yaw study in FOLDER/yaw), report.md, index.html."""


@dataclass(frozen=True)
class Scene:
    """Write a self-contained MJCF of the robot on one terrain tile (open it in the MuJoCo viewer)."""

    out: Path
    """Output .xml path."""
    slope_level: int = 0
    """Slope level 0..10 (0 %, 10 %, ..., 100 % grade)."""
    roughness_level: int = 0
    """Roughness level 0..19."""
    seed: int = 0
    """Terrain seed."""
    friction: float = 1.0
    """Ground friction."""
    wall_gap_ratio: float | None = None
    """Side walls this many body lengths apart (default: none)."""
    ground_timeconst: float = 0.02
    """Ground contact time constant (s)."""


@dataclass(frozen=True)
class BenchSim:
    """Measure env-step throughput of the batched CPU simulator (prints one JSON line)."""

    envs: int = 64
    """Parallel envs."""
    seconds: float = 10.0
    """Measurement duration (s)."""
    slope_level: int = 0
    """Slope level of the tile."""
    roughness_level: int = 0
    """Roughness level of the tile."""
    threads: int = 0
    """Physics threads (0 = one per core)."""


def _benchmark_config(threads: int = 0, batch_size: int = 64, action_reference: str = "stand", motor: str = "dcmotor",
                      **eval_kw) -> BenchmarkConfig:
    goal = {k: eval_kw.pop(k) for k in ("hold_s", "episode_s", "height_ref") if k in eval_kw}
    return BenchmarkConfig(
        sim=SimConfig(threads=threads), eval=EvalConfig(batch_size=batch_size, **eval_kw), goal=GoalConfig(**goal),
        action=ActionConfig(reference=action_reference), robot=RobotConfig(motor=motor),
    )


def run_evaluate(a: Evaluate) -> None:
    """``selfright evaluate``."""
    from selfright.evaluate.runner import evaluate_grid, format_table
    from selfright.policies.registry import make_policy

    cfg = a.bench_config(a.batch_size)
    if a.batch_size < 1:
        raise ValueError("--batch-size must be >= 1")
    out = a.out or Path("results") / f"{policy_stem(a.policy)}_{a.grid}"
    policy = make_policy(a.policy, cfg)
    res = evaluate_grid(
        policy, policy_name=a.policy, grid=a.grid, episodes=a.episodes, seed=a.seed, out_dir=out, cfg=cfg,
        progress=a.progress, fall_cache=a.fall_cache, executor=a.executor, ray_address=a.ray_address,
    )
    if a.plots:
        from selfright.plots import make_plots

        make_plots(out)
    print(format_table(res.summary))
    print(f"{res.episodes_run} episodes simulated in {res.seconds:.1f} s; results in {out}/")


def run_yaw_study(a: YawStudy) -> None:
    """``selfright yaw-study``."""
    from selfright.evaluate.yaw import run_yaw_study as run
    from selfright.plots.yaw_table import plot_yaw
    from selfright.policies.registry import make_policy

    cfg = a.bench_config()
    out = a.out or Path("results") / f"{policy_stem(a.policy)}_yaw"
    res = run(make_policy(a.policy, cfg), policy_name=a.policy, slopes_deg=a.slopes_deg, episodes=a.episodes, seed=a.seed,
              out_dir=out, cfg=cfg, progress=a.progress, fall_cache=a.fall_cache, executor=a.executor,
              ray_address=a.ray_address)
    plot_yaw(out)
    print((out / "yaw.csv").read_text().rstrip())
    print(f"{res.episodes_run} episodes simulated in {res.seconds:.1f} s; results in {out}/ (yaw.csv, yaw.png)")


def run_report(a: Report) -> None:
    """``selfright report``."""
    from selfright.evaluate.report import context_boxes, run_report as run
    from selfright.plots.report_page import draw_figures, write_report
    from selfright.train.config import EpisodeConfig

    stems = [policy_stem(p) for p in a.policies]
    run(list(zip(a.policies, stems)), grid=a.grid, episodes=a.episodes, seed=a.seed, out_dir=a.out, cfg=a.bench_config(),
        boxes=context_boxes(EpisodeConfig().rough_max_extent_m), slopes_deg=a.slopes_deg, progress=a.progress,
        fall_cache=a.fall_cache, executor=a.executor, ray_address=a.ray_address)
    draw_figures(a.out)
    md, page = write_report(a.out)
    print(f"report: {page} ({md})")


def run_replay(a: Replay) -> None:
    from selfright.evaluate.replay import replay_episode, select_cell, write_replay
    from selfright.plots.trace import plot_trace
    from selfright.policies.registry import make_policy

    cfg = a.bench_config()
    cell = select_cell(a.grid, cfg, a.slope_level, a.roughness_level)
    out = a.out or Path("results") / (
        f"replay_{policy_stem(a.policy)}_{a.grid}_{cell.slope_level}-{cell.roughness_level}_{a.episode}_s{a.seed}"
    )
    policy = make_policy(a.policy, cfg)
    r = replay_episode(policy, cfg, cell, a.episode, a.seed, fall_cache=a.fall_cache)
    write_replay(out, r, {"policy": a.policy, "grid": a.grid, "seed": a.seed}, cfg)
    plot_trace(out)
    outcome = f"success: TTR {r.ttr_s:.2f} s, DTR {r.dtr_m:.2f} m" if r.success else "failure"
    print(f"episode {a.episode} of slope {cell.slope_pct:.0f} %, roughness level {cell.roughness_level} (seed {a.seed}): {outcome}")
    if a.video:
        _render(out, a.width, a.height)
    print(f"results in {out}/")


def _render(folder: Path, width: int, height: int) -> None:
    """Render in a child process, so that MuJoCo can load with an offscreen GL backend."""
    import os
    import subprocess

    env = dict(os.environ)
    if sys.platform.startswith("linux") and "DISPLAY" not in env:
        env.setdefault("MUJOCO_GL", "egl")
    cmd = [sys.executable, "-m", "selfright.evaluate.render", str(folder), "--width", str(width), "--height", str(height)]
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True)
    if proc.returncode != 0:
        tail = (proc.stderr or proc.stdout).strip().splitlines()[-1:] or ["(no output)"]
        print(
            f"selfright: warning: rendering failed ({tail[0]}); trace.csv and trace.png are written. "
            f"Retry with another MUJOCO_GL (egl, osmesa, glfw): MUJOCO_GL=osmesa python {' '.join(cmd[1:])}",
            file=sys.stderr,
        )
        return
    print(proc.stdout.strip())


def run_scene(a: Scene) -> None:
    from selfright.env.world import build_world
    from selfright.terrain import make_cell

    cfg = BenchmarkConfig()
    ctx = ContextConfig(friction=a.friction, wall_gap_ratio=a.wall_gap_ratio, ground_timeconst_s=a.ground_timeconst)
    world = build_world(make_cell(a.slope_level, a.roughness_level, cfg.terrain), cfg, ctx, a.seed)
    z = float(world.tile.max_height_near([[0.0, 0.0]], 0.5)[0]) + 0.45
    xml = world.xml.replace('<body name="trunk" pos="0 0 0.45">', f'<body name="trunk" pos="0 0 {z:.4f}">')
    try:
        a.out.parent.mkdir(parents=True, exist_ok=True)
        a.out.write_text(xml)
    except OSError as e:
        raise ValueError(f"cannot write {a.out}: {e.strerror or e}") from e
    print(f"wrote {a.out} (slope {world.cell.slope_pct:.0f} %, roughness level {a.roughness_level}, R = {world.tile.roughness():.2f})")


def run_bench(a: BenchSim) -> None:
    from selfright.benchmark import measure_throughput
    from selfright.terrain import make_cell

    cfg = _benchmark_config(threads=a.threads)
    make_cell(a.slope_level, a.roughness_level, cfg.terrain)  # validates the levels
    if a.envs < 1 or a.seconds <= 0:
        raise ValueError("--envs must be >= 1 and --seconds > 0")
    print(json.dumps(measure_throughput(cfg, num_envs=a.envs, seconds=a.seconds, slope_level=a.slope_level, roughness_level=a.roughness_level)))


def _commands() -> dict[str, type]:
    from selfright.train.commands import ExportArgs, TrainArgs
    from selfright.train.ship import ShipArgs

    return {"evaluate": Evaluate, "compare": Compare, "yaw-study": YawStudy, "report": Report, "replay": Replay, "scene": Scene, "bench-sim": BenchSim,
            "train": TrainArgs, "export": ExportArgs, "ship": ShipArgs}


def main(argv: list[str] | None = None) -> int:
    cmds = _commands()
    args = tyro.extras.subcommand_cli_from_dict(cmds, args=argv, prog="selfright")
    try:
        if isinstance(args, Evaluate):
            run_evaluate(args)
        elif isinstance(args, Compare):
            from selfright.evaluate.compare import read_outcomes, report

            print(report(read_outcomes(args.folders), by_cell=args.by_cell))
            if args.plot is not None:
                from selfright.plots.heatmaps import difference_heatmap

                print(f"difference heatmap: {difference_heatmap(args.folders, args.plot)}")
        elif isinstance(args, YawStudy):
            run_yaw_study(args)
        elif isinstance(args, Report):
            run_report(args)
        elif isinstance(args, Replay):
            run_replay(args)
        elif isinstance(args, Scene):
            run_scene(args)
        elif isinstance(args, BenchSim):
            run_bench(args)
        else:
            from selfright.train import commands

            name = type(args).__name__
            if name == "TrainArgs":
                commands.train(args)
            elif name == "ShipArgs":
                from selfright.train.ship import ship

                ship(args)
            else:
                commands.export(args)
    except (ValueError, FileNotFoundError, RuntimeError) as e:
        print(f"selfright: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("selfright: interrupted; rerun the same command to resume", file=sys.stderr)
        return 130
    return 0


if __name__ == "__main__":
    sys.exit(main())
