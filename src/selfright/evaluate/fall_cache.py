"""Settled falls on disk: an episode's start (fall sampling with rejection, the drop, the 2 s
passive settle) depends only on the benchmark configuration, the world (cell, run seed, terrain,
context) and the episode, never on the policy, so it is computed once and read back by every
later evaluation of the same falls.

One file per episode under ``$XDG_CACHE_HOME/selfright/falls`` (default
``~/.cache/selfright/falls``), named by the SHA-256 of everything the settled state depends on
(``FallCache.key``). Each file carries its key, its array sizes, the episode generator's state
after the fall was drawn and a SHA-256 of its contents; a file that fails any check is
recomputed and rewritten, never trusted. Writes go to a temporary file renamed into place, so
a killed run leaves no half-written entry.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import struct
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from selfright.config import BENCHMARK_VERSION, BenchmarkConfig, to_dict
from selfright.env.recovery_env import RecoveryEnv, SettledStarts
from selfright.env.world import World

FORMAT = 1
"""Version of the entry format and of the key's contents; bumping it invalidates every entry."""
MAGIC = b"SRFALL1\n"
_LEN = struct.Struct("<Q")

SETTLE_FREE_FIELDS = {("sim", "threads"), ("eval", "batch_size"), ("eval", "sensor_noise")}
"""Configuration fields that cannot change a settled fall (threads and batching do not change
one env's physics; sensor noise acts on the policy only). ``goal`` and ``action`` sections are
left out of the key too: the settle holds each joint at its own angle and never reads them.
Every other field is in the key, so a field added later is covered until shown harmless."""
SETTLE_FREE_SECTIONS = ("goal", "action")


def default_cache_dir() -> Path:
    """``$XDG_CACHE_HOME/selfright`` (``~/.cache/selfright`` when unset)."""
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "selfright"


def settle_config(cfg: BenchmarkConfig) -> dict[str, Any]:
    """The part of ``cfg`` a settled fall depends on, as plain data."""
    out = {k: dict(v) for k, v in to_dict(cfg).items() if k not in SETTLE_FREE_SECTIONS}
    for section, name in SETTLE_FREE_FIELDS:
        out[section].pop(name, None)
    return out


def _library_versions() -> dict[str, str]:
    import mujoco
    import scipy

    from selfright.machine import cpu_model

    # Float kernels differ across CPU models in the last bits (docs/benchmark.md, *Seeds and
    # determinism*): an entry is reused only where recomputing it gives the same bytes.
    return {"mujoco": mujoco.__version__, "numpy": np.__version__, "scipy": scipy.__version__, "cpu": cpu_model()}


class FallCache:
    """Settled falls of one benchmark configuration, read from and written to ``root``."""

    def __init__(self, root: Path, cfg: BenchmarkConfig):
        self.root = Path(root) / "falls"
        self.base = {"format": FORMAT, "benchmark_version": BENCHMARK_VERSION, "config": settle_config(cfg),
                     "versions": _library_versions()}
        self._worlds: dict[int, tuple[World, str]] = {}
        self.hits = 0
        """Entries read back (episodes that skipped their settle)."""
        self.misses = 0
        """Episodes settled and written."""
        self.rejected = 0
        """Entries found but failing a check (corrupt, truncated, other sizes), recomputed."""

    def key(self, world: World, seed: int, episode: int, episode_seed: int) -> str:
        """Hex SHA-256 naming the settled fall of ``episode`` (seed ``episode_seed``) in
        ``world`` (built for run seed ``seed``): the configuration, the library versions and
        CPU, the world's full MJCF (robot, motor, tile heights, context), the cell and the episode."""
        memo = self._worlds.get(id(world))
        if memo is None or memo[0] is not world:
            memo = (world, hashlib.sha256(world.xml.encode()).hexdigest())
            self._worlds[id(world)] = memo
        c = world.cell
        ident = {**self.base, "world_xml": memo[1], "context": dataclasses.asdict(world.context),
                 "fixed_spawn_y": world.fixed_spawn_y,
                 "cell": [c.slope_level, c.roughness_level, c.slope_pct, c.roughness_extent_m],
                 "seed": int(seed), "episode": int(episode), "episode_seed": int(episode_seed)}
        return hashlib.sha256(json.dumps(ident, sort_keys=True).encode()).hexdigest()

    def path(self, key: str) -> Path:
        return self.root / key[:2] / f"{key}.bin"

    def settle(
        self, env: RecoveryEnv, world_idx: np.ndarray, rngs: list[np.random.Generator], keys: Sequence[str]
    ) -> SettledStarts:
        """``env.settle`` for the falls named ``keys`` (one per row of ``world_idx``), reading
        what is cached and settling the rest (each distinct key once) in one batched rollout.
        Every generator ends in the state settling would leave it in."""
        n, size, nsens = len(keys), env.sl.size, env.sens.shape[1]
        state, sens, diverged = np.zeros((n, size)), np.zeros((n, nsens)), np.zeros(n, dtype=bool)
        first: dict[str, int] = {}
        todo: list[int] = []
        for i, key in enumerate(keys):
            if key in first:
                continue
            first[key] = i
            entry = self._read(key, size, nsens)
            if entry is None:
                todo.append(i)
                continue
            state[i], sens[i], diverged[i], rngs[i].bit_generator.state = entry
            self.hits += 1
        if todo:
            models = [env.worlds[w].model for w in world_idx[todo]]
            s = env.settle(world_idx[todo], [rngs[i] for i in todo], models)
            for j, i in enumerate(todo):
                state[i], sens[i], diverged[i] = s.state[j], s.sens[j], s.diverged[j]
                self._write(keys[i], s.state[j], s.sens[j], bool(s.diverged[j]), rngs[i].bit_generator.state)
            self.misses += len(todo)
        for i, key in enumerate(keys):
            j = first[key]
            if j != i:  # the same fall twice in one batch (the yaw study's paired directions)
                state[i], sens[i], diverged[i] = state[j], sens[j], diverged[j]
                rngs[i].bit_generator.state = rngs[j].bit_generator.state
        return SettledStarts(state=state, sens=sens, diverged=diverged)

    # ------------------------------------------------------------------ entries
    def _write(self, key: str, state: np.ndarray, sens: np.ndarray, diverged: bool, rng_state: dict) -> None:
        header = json.dumps({"key": key, "state": len(state), "sens": len(sens), "diverged": diverged,
                             "rng": rng_state}).encode()
        body = MAGIC + _LEN.pack(len(header)) + header
        body += np.ascontiguousarray(state, dtype="<f8").tobytes() + np.ascontiguousarray(sens, dtype="<f8").tobytes()
        body += hashlib.sha256(body).digest()
        path = self.path(key)
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-")
            try:
                with os.fdopen(fd, "wb") as f:
                    f.write(body)
                os.replace(tmp, path)
            except BaseException:
                Path(tmp).unlink(missing_ok=True)
                raise
        except OSError:
            pass  # an unwritable cache costs time, never results

    def _read(self, key: str, size: int, nsens: int) -> tuple[np.ndarray, np.ndarray, bool, dict] | None:
        """The entry ``key`` if present and intact, else None (a damaged one counts in ``rejected``)."""
        try:
            body = self.path(key).read_bytes()
        except OSError:
            return None
        try:
            if len(body) < len(MAGIC) + _LEN.size + 32 or not body.startswith(MAGIC):
                raise ValueError("no entry header")
            if hashlib.sha256(body[:-32]).digest() != body[-32:]:
                raise ValueError("checksum mismatch")
            (hlen,) = _LEN.unpack_from(body, len(MAGIC))
            start = len(MAGIC) + _LEN.size
            header = json.loads(body[start : start + hlen])
            if header["key"] != key or header["state"] != size or header["sens"] != nsens:
                raise ValueError("another entry")
            arrays = np.frombuffer(body[start + hlen : -32], dtype="<f8")
            if len(arrays) != size + nsens:
                raise ValueError("truncated")
            return arrays[:size].copy(), arrays[size:].copy(), bool(header["diverged"]), header["rng"]
        except (ValueError, KeyError, TypeError, struct.error):
            self.rejected += 1
            return None
