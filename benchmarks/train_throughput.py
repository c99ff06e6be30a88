"""Training-env throughput and its scaling with physics threads, per training context.

For each context and thread count: the time the fall protocol + 2 s settle takes per
episode start (``reset_all``), and env steps/s of ``RecoveryVecEnv.step`` (random actions,
rewards and observations included, no resets inside the timed window). Prints one JSON line
per (context, threads) and, per context, ``scaling`` = steps/s at the most threads over
steps/s at the fewest, with ``per_thread_efficiency`` = scaling / thread ratio (1.0 = linear).

Then the training loop as rsl-rl runs it (``--loop-context``, ``--loop-envs``): episode
lengths start uniformly at random, done episodes restart inside ``step``, and one full
episode length (500 steps) is timed, so every slot restarts once in the window; with
``EpisodeConfig.prepare_starts`` off (a 2 s settle of the 1–3 episodes ending at each step)
and on (next starts settled ahead in one batch), side by side, with ``speedup`` = on / off.

    python benchmarks/train_throughput.py [--envs 512] [--threads 1 2] [--steps 40]
    python benchmarks/train_throughput.py --envs 1024 --loop-envs 1024 --threads 1 4 8 14   # GPU machine
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import time

import torch

from selfright.config import BenchmarkConfig
from selfright.train.config import TrainConfig
from selfright.train.contexts import make_training_worlds
from selfright.train.vecenv import RecoveryVecEnv


def make_env(context: str, envs: int, threads: int, seed: int, prepare_starts: bool = True) -> RecoveryVecEnv:
    """The training env of ``context`` with default configs (every slot already reset)."""
    cfg, train = BenchmarkConfig(), TrainConfig()
    train = dataclasses.replace(train, episode=dataclasses.replace(train.episode, prepare_starts=prepare_starts))
    worlds = make_training_worlds(context, cfg, seed, train.episode)
    return RecoveryVecEnv(cfg, train, worlds, envs, seed=seed, threads=threads)


def measure(context: str, envs: int, threads: int, steps: int, seed: int = 0) -> dict:
    """One (context, threads) measurement; the generator and actions are seeded."""
    env = make_env(context, envs, threads, seed)
    t0 = time.perf_counter()
    env.reset_all()  # a fresh fall + settle in every slot, without the env's construction
    reset_s = time.perf_counter() - t0
    gen = torch.Generator().manual_seed(seed)
    actions = [0.3 * torch.randn(envs, env.num_actions, generator=gen) for _ in range(steps)]
    env.step(actions[0])  # warm-up
    t0 = time.perf_counter()
    for a in actions[1:]:
        env.step(a)
    dt = time.perf_counter() - t0
    env.close()
    return {
        "context": context,
        "envs": envs,
        "threads": threads,
        "reset_ms_per_episode": round(1e3 * reset_s / envs, 3),
        "env_steps_per_s": round(envs * (steps - 1) / dt),
    }


def measure_loop(context: str, envs: int, threads: int, prepare: bool, seed: int = 0) -> dict:
    """Env steps/s over one episode length with auto-resets, as in training."""
    env = make_env(context, envs, threads, seed, prepare_starts=prepare)
    gen = torch.Generator().manual_seed(seed)
    env.episode_length_buf = torch.randint(0, env.max_episode_length, (envs,), generator=gen)
    for _ in range(2):  # warm-up; the first finished episode triggers the first batch (prepare on)
        env.step(0.3 * torch.randn(envs, env.num_actions, generator=gen))
    steps = env.max_episode_length
    actions = [0.3 * torch.randn(envs, env.num_actions, generator=gen) for _ in range(steps)]
    t0 = time.perf_counter()
    for a in actions:
        env.step(a)
    dt = time.perf_counter() - t0
    env.close()
    return {"loop": context, "envs": envs, "threads": threads, "prepare_starts": prepare,
            "env_steps_per_s": round(envs * steps / dt)}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--envs", type=int, default=512)
    p.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    p.add_argument("--steps", type=int, default=40, help="timed control steps per measurement")
    p.add_argument("--contexts", nargs="+", default=["flat", "rough", "incline"])
    p.add_argument("--loop-context", default="incline", help="context of the training-loop timing ('' = skip)")
    p.add_argument("--loop-envs", type=int, default=256)
    a = p.parse_args()
    print(json.dumps({"cpus": os.cpu_count(), "torch_threads": torch.get_num_threads()}), flush=True)
    for context in a.contexts:
        rows = [measure(context, a.envs, k, a.steps) for k in sorted(set(a.threads))]
        for r in rows:
            print(json.dumps(r), flush=True)
        lo, hi = rows[0], rows[-1]
        scaling = hi["env_steps_per_s"] / lo["env_steps_per_s"]
        print(json.dumps({
            "context": context,
            "scaling": round(scaling, 2),
            "threads": [lo["threads"], hi["threads"]],
            "per_thread_efficiency": round(scaling / (hi["threads"] / lo["threads"]), 2),
        }), flush=True)
    if not a.loop_context:
        return
    for k in sorted(set(a.threads)):
        off, on = (measure_loop(a.loop_context, a.loop_envs, k, prepare) for prepare in (False, True))
        print(json.dumps(off), flush=True)
        print(json.dumps(on), flush=True)
        print(json.dumps({"loop": a.loop_context, "threads": k,
                          "speedup": round(on["env_steps_per_s"] / off["env_steps_per_s"], 2)}), flush=True)


if __name__ == "__main__":
    main()
