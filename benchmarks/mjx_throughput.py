"""MJX (MuJoCo in JAX, on the GPU) physics throughput on selfright's own scenes, side by side
with the CPU engine (MuJoCo C, every core) on the same settled falls and PD targets.

A planning measurement for a GPU backend, not part of selfright: it needs ``jax`` and
``mujoco-mjx`` (not dependencies of the package). For each context and batch size it
settles ``envs`` falls of the seed's protocol on the CPU, then advances them ``--steps``
control steps (4 physics steps each, targets = the settled joint angles + noise) on both
engines and prints one JSON line: physics steps/s of each, ``mjx_over_cpu``, the compile
time, how many MJX envs went non-finite, and the mean |Δ trunk height| between the engines
after the window (a coarse agreement check: contact-rich motion diverges quickly anyway).

    python benchmarks/mjx_throughput.py --envs 1024 4096 --contexts flat rough   # GPU machine
"""

from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np

from selfright.config import BenchmarkConfig
from selfright.env.recovery_env import RecoveryEnv
from selfright.sim.batch import BatchStepper
from selfright.train.contexts import make_training_worlds


def settled(context: str, n: int, threads: int, seed: int = 0):
    """(model, (n, S) full-physics states after the fall protocol's settle) on the context's
    first training tile."""
    cfg = BenchmarkConfig()
    worlds = make_training_worlds(context, cfg, seed)[:1]
    env = RecoveryEnv(cfg, worlds, n, threads=threads)
    env.reset(np.arange(n), np.zeros(n, dtype=np.int64), [np.random.default_rng([seed, i]) for i in range(n)])
    state = env.state.copy()
    env.close()
    return worlds[0].model, state, env.sl, cfg.sim.control_substeps


WARMUP = 2
"""Leading control steps of each engine left out of the timing (MJX compiles, and may compile
again once its outputs' dtypes settle)."""


def run_cpu(model, state, ctrls, substeps: int, threads: int) -> tuple[float, np.ndarray]:
    stepper = BatchStepper(model, threads)
    models = [model] * len(state)
    s = state
    for k, c in enumerate(ctrls):
        if k == WARMUP:
            t0 = time.perf_counter()
        states, _ = stepper.step(models, s, c, substeps)
        s = states[:, -1]
    dt = time.perf_counter() - t0
    stepper.close()
    return dt, s


def run_mjx(model, state, ctrls, substeps: int) -> tuple[float, float, np.ndarray]:
    import jax
    import jax.numpy as jnp
    from mujoco import mjx

    mx = mjx.put_model(model)
    d0 = mjx.make_data(mx)
    nq, nv = model.nq, model.nv
    qpos = jnp.asarray(state[:, 1 : 1 + nq], dtype=jnp.float32)
    qvel = jnp.asarray(state[:, 1 + nq : 1 + nq + nv], dtype=jnp.float32)
    data = jax.vmap(lambda q, v: d0.replace(qpos=q, qvel=v))(qpos, qvel)

    def control_step(d, ctrl):
        d = d.replace(ctrl=ctrl)
        d, _ = jax.lax.scan(lambda x, _: (mjx.step(mx, x), None), d, None, length=substeps)
        return d

    step = jax.jit(jax.vmap(control_step))
    c = [jnp.asarray(x, dtype=jnp.float32) for x in ctrls]
    t0 = time.perf_counter()
    for x in c[:WARMUP]:
        data = jax.block_until_ready(step(data, x))
    compile_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    for x in c[WARMUP:]:
        data = step(data, x)
    jax.block_until_ready(data)
    dt = time.perf_counter() - t0
    return dt, compile_s, np.asarray(data.qpos)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--envs", type=int, nargs="+", default=[256])
    p.add_argument("--contexts", nargs="+", default=["flat"])
    p.add_argument("--steps", type=int, default=50, help="timed control steps (after 2 untimed ones)")
    p.add_argument("--threads", type=int, default=os.cpu_count() or 1, help="CPU engine threads")
    a = p.parse_args()
    import jax

    print(json.dumps({"jax": jax.__version__, "devices": [str(d) for d in jax.devices()], "cpus": os.cpu_count()}),
          flush=True)
    for context in a.contexts:
        for n in a.envs:
            model, state, sl, substeps = settled(context, n, a.threads)
            rng = np.random.default_rng(0)
            hold = state[:, sl.qpos_joints]
            ctrls = [hold + 0.3 * rng.standard_normal(hold.shape) for _ in range(WARMUP + a.steps)]
            cpu_s, cpu_final = run_cpu(model, state, ctrls, substeps, a.threads)
            mjx_s, compile_s, mjx_qpos = run_mjx(model, state, ctrls, substeps)
            phys = n * a.steps * substeps
            finite = np.isfinite(mjx_qpos).all(axis=1)
            dz = np.abs(mjx_qpos[finite, 2] - cpu_final[finite, sl.pos][:, 2])
            print(json.dumps({
                "context": context, "envs": n, "control_steps": a.steps,
                "cpu_physics_steps_per_s": round(phys / cpu_s), "cpu_threads": a.threads,
                "mjx_physics_steps_per_s": round(phys / mjx_s), "mjx_compile_and_warmup_s": round(compile_s, 1),
                "mjx_over_cpu": round(cpu_s / mjx_s, 2),
                "mjx_nonfinite_envs": int((~finite).sum()),
                "mean_abs_dz_m": round(float(dz.mean()), 4) if len(dz) else None,
                "solver": {"iterations": int(model.opt.iterations), "ls_iterations": int(model.opt.ls_iterations),
                           "cone": int(model.opt.cone), "timestep_s": float(model.opt.timestep)},
            }), flush=True)


if __name__ == "__main__":
    main()
