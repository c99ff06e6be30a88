"""Training runs: rsl_rl's ``OnPolicyRunner`` (teacher PPO) and ``DistillationRunner``
(student), plus what a long CPU run needs around them: time-based checkpoints, resume from
the latest checkpoint, a one-line progress report, clean stop on SIGINT/SIGTERM, and
``train_meta.json`` for model cards.

Run directory layout (``--out``)::

    model_<it>.pt      rsl_rl checkpoints (``infos``: policy metadata, iterations, env steps, wall-clock)
    events.out.tfevents.*   tensorboard logs (rewards per term, losses, FPS)
    train_meta.json    context, role, env steps, wall-clock, device, command lines
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import re
import shlex
import signal
import sys
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import torch
from rsl_rl.runners import DistillationRunner, OnPolicyRunner
from rsl_rl.utils.logger import Logger

from selfright.config import BENCHMARK_VERSION, BenchmarkConfig, to_dict
from selfright.machine import cpu_model, versions
from selfright.policies.run_files import (
    CHECKPOINT_RE,
    META_FILE,
    latest_checkpoint,
    list_checkpoints,
    read_meta,
)
from selfright.train.config import PolicyConfig, Role, TrainConfig
from selfright.train.contexts import make_training_worlds
from selfright.train.run_lock import run_lock
from selfright.train.vecenv import RecoveryVecEnv

PROGRESS_EVERY_S = 10.0
"""Seconds between one-line progress reports (the first iterations always report)."""


@dataclass(frozen=True, kw_only=True)
class RunSpec:
    """A resolved training request (what ``commands.TrainArgs`` turns into)."""

    role: Role
    context: str
    out: Path
    num_envs: int
    iterations: int
    """Total learning iterations of the run, counting those before a resume."""
    seed: int
    resume: bool
    teacher: Path | None
    physics_threads: int
    init_from: Path | None = None
    """A teacher's weights to start a new teacher run from (a fine-tuning curriculum)."""
    torch_threads: int
    device: str = "cpu"
    """Torch device of the networks (physics stays on the CPU)."""
    train: TrainConfig = field(default_factory=TrainConfig)
    bench: BenchmarkConfig = field(default_factory=BenchmarkConfig)
    quiet: bool = False
    """Suppress the progress lines (tests)."""


# ------------------------------------------------------------------ checkpoints
def teacher_policy_config(
    ckpt: Path, fallback: PolicyConfig, flag: str = "--teacher"
) -> tuple[PolicyConfig, dict[str, Any]]:
    """The network config of a trained teacher, from its run's ``train_meta.json``, else read off
    the weights (activation then defaults to ``fallback``'s). Also returns the teacher's meta.
    ``ValueError`` (one line, naming ``flag``) if ``ckpt`` holds a student or no teacher."""
    meta = read_meta(ckpt.parent)
    try:
        data = torch.load(ckpt, map_location="cpu", weights_only=True)
    except Exception as e:  # noqa: BLE001 - any unpickling failure means the same to the user
        why = type(e).__name__
        raise ValueError(f"{flag} {ckpt} cannot be read ({why}); pass a teacher run or model_<it>.pt") from None
    data = data if isinstance(data, dict) else {}
    infos = data.get("infos") if isinstance(data.get("infos"), dict) else {}
    payload = data.get("meta") if isinstance(data.get("meta"), dict) else {}  # a `selfright export` policy file
    if (meta.get("role", "teacher") != "teacher" or "student_state_dict" in data
            or "student" in (infos.get("obs_group"), infos.get("role"), payload.get("obs_group"))):
        raise ValueError(f"{flag} {ckpt} holds a student; {flag} takes a teacher run or checkpoint (--role teacher)")
    pol = meta.get("policy")
    if pol:
        return (
            replace(
                fallback,
                hidden_dims=tuple(pol["hidden_dims"]),
                activation=pol["activation"],
                obs_normalization=bool(pol["obs_normalization"]),
            ),
            meta,
        )
    sd = data.get("actor_state_dict")
    if sd is None:
        raise ValueError(f"{ckpt} is not a teacher checkpoint (no 'actor_state_dict'); pass a teacher run")
    ws = sorted((int(k.split(".")[1]), v) for k, v in sd.items() if re.fullmatch(r"mlp\.\d+\.weight", k))
    hidden = tuple(int(w.shape[0]) for _, w in ws[:-1])
    return replace(fallback, hidden_dims=hidden, obs_normalization="obs_normalizer._mean" in sd), meta


class _StopTraining(Exception):
    """Raised from the per-iteration hook to leave ``runner.learn`` after a clean save."""


class _HookLogger(Logger):
    """rsl_rl's logger, plus a callback after every iteration and a compact progress line
    instead of rsl_rl's multi-line console block (tensorboard still gets everything)."""

    def __init__(self, *args: Any, hook: Any, **kwargs: Any):
        super().__init__(*args, **kwargs)
        self.hook = hook

    def log(self, it: int, *args: Any, **kwargs: Any) -> None:
        extras = {k: _mean_extra(self.ep_extras, k) for k in ("Episode/success_rate", "Metrics/in_goal", "Curriculum/mean_level")}
        loss = kwargs.get("loss_dict", {})  # rsl_rl's runner passes every argument by keyword
        with contextlib.redirect_stdout(io.StringIO()):
            super().log(it, *args, **kwargs)
        self.hook(it, extras, loss)


def _mean_extra(ep_extras: list[dict], key: str) -> float | None:
    vals = [float(torch.as_tensor(e[key]).float().mean()) for e in ep_extras if key in e]
    return sum(vals) / len(vals) if vals else None


# ------------------------------------------------------------------------- run
class TrainingRun:
    """One invocation of ``selfright train`` (a fresh run or a resumed one)."""

    def __init__(self, spec: RunSpec):
        self.spec = spec
        self.out = spec.out
        self.stop_requested = False
        self.validated: set[int] = set()
        self.last_ckpt_time = time.time()
        self.last_progress = 0.0
        self.progress_lines = 0
        self.last_loss: dict[str, float] = {}
        """Losses of the latest iteration (rsl_rl's loss dict)."""

    # ------------------------------------------------------------- set-up
    def _check(self) -> None:
        s = self.spec
        if s.num_envs < 1:
            raise ValueError(f"--envs must be ≥ 1 (got {s.num_envs})")
        if s.iterations < 0:
            raise ValueError(f"--iterations must be ≥ 0 (got {s.iterations})")
        if s.iterations == 0 and not s.resume:
            raise ValueError("--iterations 0: a new run needs at least 1 iteration to train")
        if s.role == "student" and s.teacher is None:
            raise ValueError(f"--role {s.role} needs --teacher RUN_DIR (a trained teacher run or checkpoint)")
        if s.teacher is not None and not s.teacher.exists():
            raise ValueError(f"teacher {s.teacher} not found; pass a teacher run folder or model_<it>.pt")
        if s.device.startswith("cuda") and not torch.cuda.is_available():
            raise ValueError(f"--device {s.device}: torch sees no CUDA device here; use --device cpu")
        has_ckpt = bool(list_checkpoints(self.out))
        if s.resume and not has_ckpt:
            raise ValueError(f"--resume: no checkpoint in {self.out}; drop --resume to start a new run")
        if s.train.randomization.sensor_noise > 0 and s.role != "student":
            raise ValueError("--train.randomization.sensor-noise applies to students; a teacher reads privileged, "
                             "exact observations")
        if s.init_from is not None:
            if s.role == "student":
                raise ValueError("--init-from is for teachers; a student starts afresh from its --teacher's labels")
            if s.resume:
                raise ValueError("--init-from starts a new run; drop --resume (a resumed run keeps its own weights)")
            if not s.init_from.exists():
                raise ValueError(f"--init-from {s.init_from} not found; pass a teacher run folder or model_<it>.pt")
        if not s.resume and has_ckpt:
            raise ValueError(f"{self.out} already holds checkpoints; pass --resume to continue or choose another --out")

    def setup(self) -> None:
        s = self.spec
        self._check()
        self.out.mkdir(parents=True, exist_ok=True)
        torch.set_num_threads(s.torch_threads)
        self.prev_meta = read_meta(self.out) if s.resume else {}
        self.resume_ckpt = latest_checkpoint(self.out) if s.resume else None
        self.teacher_ckpt = latest_checkpoint(s.teacher) if s.teacher is not None else None
        self.init_ckpt: Path | None = None
        teacher_policy, teacher_meta = (None, {})
        if s.role == "student":
            teacher_policy, teacher_meta = teacher_policy_config(self.teacher_ckpt, s.train.policy)
            if teacher_meta.get("context") not in (None, s.context):
                print(f"warning: teacher was trained on {teacher_meta['context']!r}, student trains on {s.context!r}")
            teacher_ref = (teacher_meta.get("policy") or {}).get("action_reference", "stand")
            if teacher_ref != s.bench.action.reference:
                raise ValueError(
                    f"the teacher was trained with --action-reference {teacher_ref}; distil with the same "
                    f"(its action labels mean joint targets around that reference)"
                )
        self.teacher_policy = teacher_policy

        start_it = self._saved_iteration(self.resume_ckpt) + 1 if self.resume_ckpt else 0
        torch.manual_seed(s.seed + start_it)
        bench = s.bench
        worlds = make_training_worlds(s.context, bench, s.seed, s.train.episode)
        # A resumed run draws new episodes: the generator is keyed by the start iteration.
        self.env = RecoveryVecEnv(
            bench, s.train, worlds, s.num_envs, seed=(s.seed, start_it), threads=s.physics_threads,
            device=s.device,
        )
        self.cfg = s.train.to_rsl_rl(s.role, teacher_policy)
        runner_cls = DistillationRunner if s.role == "student" else OnPolicyRunner
        with contextlib.redirect_stdout(io.StringIO()):  # rsl_rl prints the model layouts
            self.runner = runner_cls(self.env, self.cfg, log_dir=str(self.out), device=s.device)
        r = self.runner
        r.logger = _HookLogger(
            log_dir=str(self.out), cfg=r.cfg, env_cfg=self.env.cfg, num_envs=self.env.num_envs,
            is_distributed=r.is_distributed, gpu_world_size=r.gpu_world_size, gpu_global_rank=r.gpu_global_rank,
            device=r.device, hook=self._on_iteration,
        )
        resumed_infos: dict = {}
        if self.resume_ckpt is not None:
            resumed_infos = r.load(str(self.resume_ckpt), map_location=s.device) or {}  # a GPU run resumes on the CPU too
            r.current_learning_iteration = start_it  # rsl_rl stores the last finished iteration
            self.env.restore_curriculum(resumed_infos.get("curriculum_level"))
        elif s.role == "student":
            r.load(str(self.teacher_ckpt), map_location=s.device)  # loads the teacher only (rsl_rl: from an RL checkpoint)
        elif s.init_from is not None:
            init = latest_checkpoint(s.init_from)
            teacher_policy_config(init, s.train.policy, "--init-from")  # refuses students
            source = torch.load(init, map_location=self.spec.device, weights_only=False)
            if not any(k.startswith("distribution.") for k in source["actor_state_dict"]):
                raise ValueError(f"--init-from {init} has a state-dependent action std, which selfright train does not build")
            r.alg.load(source, {"actor": True, "critic": True, "optimizer": False}, True)
            self.init_ckpt = init
            if s.train.recenter_on_init:
                moved = _recenter_constant_features(r.alg, self.env.get_observations())
                if moved and not s.quiet:
                    print(f"--init-from: re-centred observation features constant in the source run: {moved}")
        self.start_it = start_it
        self.steps_per_it = self.cfg["num_steps_per_env"] * s.num_envs
        # Progress of the checkpoint resumed (its own infos), not of the run's latest meta file:
        # they differ when an earlier checkpoint is continued in a copy of the run folder.
        self.base_steps = int(resumed_infos.get("env_steps", self.prev_meta.get("env_steps", 0)))
        self.base_wall = float(resumed_infos.get("wall_clock_s", self.prev_meta.get("wall_clock_s", 0.0)))
        self.t0 = time.time()

    @staticmethod
    def _saved_iteration(ckpt: Path) -> int:
        m = CHECKPOINT_RE.fullmatch(ckpt.name)
        if m:
            return int(m.group(1))
        return int(torch.load(ckpt, map_location="cpu", weights_only=True).get("iter", 0))

    # -------------------------------------------------------------- metadata
    def policy_meta(self) -> dict[str, Any]:
        pol = self.spec.train.policy
        student = self.spec.role == "student"
        return {
            "obs_group": "student" if student else "teacher",
            "hidden_dims": list(pol.hidden_dims),
            "activation": pol.activation,
            "obs_normalization": pol.obs_normalization,
            "role": "student" if student else "teacher",
            "context": self.spec.context,
            "action_reference": self.spec.bench.action.reference,
            "action_scale_rad": self.spec.bench.action.scale_rad,
            "obs_history": self.spec.train.distillation.student_history if student else 1,
            # the motor model it trains with: a checkpoint copied out of its run still runs as trained
            "motor": self.spec.bench.robot.motor,
            "motor_speed_rad_s": self.spec.bench.robot.motor_speed_rad_s or 0.0,
        }

    def _prev_devices(self) -> list[str | None]:
        """The machine of each earlier invocation (``command_devices``, aligned with
        ``command_lines``); a meta written before that field names only its last machine."""
        prev, cmds = self.prev_meta.get("command_devices"), self.prev_meta.get("command_lines", [])
        if prev is not None and len(prev) == len(cmds):
            return list(prev)
        return [self.prev_meta.get("device")] * len(cmds)

    def meta(self, done_it: int, checkpoint: Path | None) -> dict[str, Any]:
        """``train_meta.json`` after ``done_it`` learning iterations in total."""
        s = self.spec
        cmd = shlex.join(sys.argv)
        device = _device_string(s.physics_threads, s.torch_threads, s.device)
        return {
            "benchmark_version": BENCHMARK_VERSION,
            "role": s.role,
            "context": s.context,
            "seed": s.seed,
            "num_envs": s.num_envs,
            "iterations_done": done_it,
            "iterations_target": s.iterations,
            "env_steps": self.base_steps + (done_it - self.start_it) * self.steps_per_it,
            "wall_clock_s": round(self.base_wall + time.time() - self.t0, 1),
            "device": device,
            "command_devices": [*self._prev_devices(), device],
            "command_line": cmd,
            "command_lines": [*self.prev_meta.get("command_lines", []), cmd],
            "command_start_iterations": [*self.prev_meta.get("command_start_iterations", []), self.start_it],
            "teacher": str(self.teacher_ckpt) if self.teacher_ckpt else None,
            "init_from": str(self.init_ckpt) if self.init_ckpt else self.prev_meta.get("init_from"),
            "latest_checkpoint": str(checkpoint) if checkpoint else None,
            "policy": self.policy_meta(),
            "teacher_policy": to_dict(self.teacher_policy) if self.teacher_policy else None,
            "versions": versions(),
            "train_config": to_dict(s.train),
            "benchmark_config": to_dict(s.bench),
        }

    def save(self, it: int) -> Path:
        """Checkpoint after iteration ``it`` (0-based), write the meta file, prune old checkpoints."""
        path = self.out / f"model_{it}.pt"
        self.runner.current_learning_iteration = it
        meta = self.meta(it + 1, path)
        progress = {k: meta[k] for k in ("iterations_done", "env_steps", "wall_clock_s")}
        if self.env.curriculum:  # a resumed run continues at the levels its slots had reached
            progress["curriculum_level"] = self.env.level.tolist()
        self.runner.save(str(path), infos={**self.policy_meta(), "source": str(path), **progress})
        tmp = self.out / (META_FILE + ".tmp")
        tmp.write_text(json.dumps(meta, indent=2))
        os.replace(tmp, self.out / META_FILE)
        keep = self.spec.train.keep_checkpoints
        if keep > 0:
            for _, old in list_checkpoints(self.out)[:-keep]:
                old.unlink(missing_ok=True)
        if it not in self.validated:  # the final save repeats one the timer made on the last iteration
            self._validate(path, it, meta["env_steps"])
            self.validated.add(it)
        self.last_ckpt_time = time.time()
        return path

    def validation_bench(self) -> BenchmarkConfig:
        """The benchmark configuration checkpoints are validated in: the run's, and for a student
        trained under sensor noise (``RandomizationConfig.sensor_noise``) that noise as
        ``EvalConfig.sensor_noise``, so the best checkpoint is chosen under the sensors it trained
        for (each evaluation's ``summary.json`` records it)."""
        bench = self.spec.bench
        noise = self.spec.train.randomization.active_sensor_noise
        if noise > 0 and self.spec.role == "student":
            bench = replace(bench, eval=replace(bench.eval, sensor_noise=noise))
        return bench

    def _validate(self, ckpt: Path, it: int, env_steps: int) -> None:
        """Benchmark the checkpoint just saved (``TrainConfig.validation``); keep the best."""
        v = self.spec.train.validation
        if v.episodes <= 0:
            return
        from selfright.train import validation

        bench = self.validation_bench()
        noise = bench.eval.sensor_noise
        t = time.time()
        # Loading the checkpoint builds networks from torch's global generator, which also draws
        # the training's action noise; checkpoints fall on a wall-clock timer, so without the fork
        # the same command and seed would train a different policy on a faster or slower machine.
        cuda = [torch.cuda.current_device()] if str(self.spec.device).startswith("cuda") else []
        with torch.random.fork_rng(devices=cuda):
            score = validation.evaluate_checkpoint(
                ckpt, iteration=it, env_steps=env_steps, grid=v.grid or self.spec.context, episodes=v.episodes,
                seed=v.seed, out_dir=self.out / "validation" / ckpt.stem, bench=bench,
            )
        best = validation.record(self.out, score, ckpt)
        writer = self.runner.logger.writer
        if writer is not None:
            writer.add_scalar("Validation/success_rate", score.success_rate, score.iteration)
        if not self.spec.quiet:
            print(
                f"[{self.spec.role}/{self.spec.context}] validation of {ckpt.name}"
                + f": {score.successes}/{score.episodes} "
                f"= {100 * score.success_rate:.1f} % (seed {v.seed}"
                + (f", sensor noise x{noise:g}" if noise > 0 else "")
                + f", {time.time() - t:.0f} s)"
                + (f"; best so far -> {validation.BEST_FILE}" if best else ""),
                flush=True,
            )

    # ---------------------------------------------------------------- hooks
    def _on_iteration(self, it: int, extras: dict[str, float | None], loss: dict[str, float]) -> None:
        now = time.time()
        self.last_loss = dict(loss)
        if not self.spec.quiet and (now - self.last_progress >= PROGRESS_EVERY_S or self.progress_lines < 3):
            self._progress(it, extras, loss, now)
        if self.stop_requested:
            self.save(it)
            raise _StopTraining
        if now - self.last_ckpt_time >= self.spec.train.checkpoint_every_s:
            self.save(it)

    def _progress(self, it: int, extras: dict[str, float | None], loss: dict[str, float], now: float) -> None:
        done = it + 1 - self.start_it
        elapsed = now - self.t0
        total = self.spec.iterations
        rate = self.steps_per_it * done / max(elapsed, 1e-9)
        eta = elapsed / done * (total - it - 1)
        lb = self.runner.logger
        ep_ret = f"{sum(lb.rewbuffer) / len(lb.rewbuffer):7.2f}" if lb.rewbuffer else "    n/a"
        succ, goal = extras.get("Episode/success_rate"), extras.get("Metrics/in_goal")
        level = extras.get("Curriculum/mean_level")
        losses = " ".join(f"{k} {v:.4f}" for k, v in loss.items())
        print(
            f"[{self.spec.role}/{self.spec.context}] it {it + 1}/{total}  "
            f"steps {self.base_steps + done * self.steps_per_it:,}  {rate:,.0f} steps/s  "
            f"{60 * done / max(elapsed, 1e-9):.1f} it/min  ep_return {ep_ret}  "
            f"success {'n/a' if succ is None else f'{succ:.2f}'}  in_goal {'n/a' if goal is None else f'{goal:.2f}'}  "
            + ("" if level is None else f"level {level:.2f}  ")
            + f"{losses}  "
            f"elapsed {_hms(elapsed)}  eta {_hms(eta)}",
            flush=True,
        )
        self.last_progress = now
        self.progress_lines += 1

    def _request_stop(self, signum: int, frame: Any) -> None:
        if self.stop_requested:  # second signal: give up at once
            raise KeyboardInterrupt
        print(f"signal {signum}: stopping after this iteration (checkpoint will be saved)", flush=True)
        self.stop_requested = True

    # ------------------------------------------------------------------ run
    def run(self) -> Path:
        """Train up to ``iterations`` in total; returns the final checkpoint."""
        remaining = self.spec.iterations - self.start_it
        if remaining <= 0:
            print(f"{self.out}: already at {self.start_it} ≥ {self.spec.iterations} iterations; nothing to do")
            self.env.close()
            return latest_checkpoint(self.out)
        old = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}
        in_main = _is_main_thread()
        if in_main:
            for sig in old:
                signal.signal(sig, self._request_stop)
        try:
            with contextlib.redirect_stdout(io.StringIO()) if self.spec.quiet else contextlib.nullcontext():
                self.runner.learn(remaining, init_at_random_ep_len=True)
        except _StopTraining:
            return latest_checkpoint(self.out)
        finally:
            if in_main:
                for sig, handler in old.items():
                    signal.signal(sig, handler)
            writer = self.runner.logger.writer
            if writer is not None and hasattr(writer, "close"):
                writer.close()
            self.env.close()
        # rsl_rl saved model_<last>.pt without metadata; save it again with ours.
        return self.save(self.runner.current_learning_iteration)


def run_training(spec: RunSpec) -> Path:
    """Set up and run, holding the run folder's lock (``selfright.train.run_lock``); returns
    the final checkpoint path. A folder this call created and left empty (a user error before
    anything was written) is removed."""
    created = not spec.out.exists()
    spec.out.mkdir(parents=True, exist_ok=True)
    try:
        with run_lock(spec.out):
            run = TrainingRun(spec)
            run.setup()
            return run.run()
    finally:
        if created and spec.out.is_dir() and not any(spec.out.iterdir()):
            spec.out.rmdir()


# --------------------------------------------------------------------- helpers
def _recenter_constant_features(alg: Any, obs: Any, eps: float = 1e-3) -> list[int]:
    """Features that never varied in the source run (running std < ``eps``) get the mean of
    ``obs`` (the new context's first observations) as their running mean, in the actor's and
    critic's normalisers; every other statistic is left as it is. Returns those features'
    indices (of the actor's input)."""
    moved: list[int] = []
    for model, name in ((alg.actor, "actor"), (alg.critic, "critic")):
        norm = getattr(model, "obs_normalizer", None)
        if norm is None or not hasattr(norm, "_mean"):
            continue
        x = torch.cat([obs[g] for g in model.obs_groups], dim=-1).float()
        idx = (norm._std.squeeze(0) < eps).nonzero().flatten()
        if len(idx):
            norm._mean[0, idx] = x[:, idx].mean(dim=0)
        if name == "actor":
            moved = idx.tolist()
    return moved


def _device_string(physics_threads: int, torch_threads: int, device: str = "cpu") -> str:
    cpu = cpu_model()
    text = f"cpu ({cpu}, {os.cpu_count()} cores; physics threads {physics_threads}, torch threads {torch_threads})"
    if device.startswith("cuda"):
        text += f"; networks on {device} ({torch.cuda.get_device_name(torch.device(device))})"
    elif device != "cpu":
        text += f"; networks on {device}"
    return text


def _hms(s: float) -> str:
    s = int(max(s, 0))
    return f"{s // 3600}:{s % 3600 // 60:02d}:{s % 60:02d}"


def _is_main_thread() -> bool:
    import threading

    return threading.current_thread() is threading.main_thread()
