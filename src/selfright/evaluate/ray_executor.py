"""Batches of episodes as Ray tasks (``--executor ray``): on a local Ray instance, or on an
existing cluster (``ray start --head`` on one machine, ``ray start --address …`` on the others;
docs/ray.md).

Each task simulates one batch exactly as the local executor does (same env size, same worlds,
same fall cache) and returns its rows; the driver yields them as tasks finish, so the caller
writes them, shows progress and can resume from them. A task whose worker process or node dies
is resubmitted (``MAX_RETRIES``); an error raised by the simulation itself stops the run.
Ray is an optional dependency: ``pip install -e ".[ray]"``.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from typing import Any

from selfright.policies.base import Policy

MAX_RETRIES = 3
"""Resubmissions of a task whose worker died (Ray's ``max_retries``)."""
INSTALL_HINT = 'the ray executor needs Ray: pip install -e ".[ray]" (or pip install "ray>=2.40")'

_session: tuple[Any, Any] | None = None
"""(work, its open session) of this worker process: later tasks of one run reuse it."""


def _import_ray():
    try:
        import ray
    except ImportError:
        raise RuntimeError(INSTALL_HINT) from None
    return ray


def run_task(work: Any, policy: Policy, batch: list) -> list[dict[str, Any]]:
    """Body of one Ray task: the rows of ``batch``, on this process's session of ``work``
    (built by the first task of the run that lands here, one physics and torch thread)."""
    global _session
    import torch

    torch.set_num_threads(1)
    if _session is None or _session[0] != work:
        if _session is not None:
            _session[1].close()
        _session = (work, work.open(threads=1))
    return _session[1].run(policy, batch)


def ray_batches(
    work: Any, policy: Policy, batches: list[list], *, address: str | None = None, num_cpus: int = 0,
) -> Iterator[list[dict[str, Any]]]:
    """Rows of each of ``batches`` as its Ray task finishes (any order). ``address``: an
    existing cluster (``HOST:PORT``, or ``auto``); None starts a local Ray with ``num_cpus``
    workers (0 = one per core) for the call, unless this process is already connected to one."""
    ray = _import_ray()
    started = False
    if not ray.is_initialized():
        if address:
            ray.init(address=address, log_to_driver=False)
        else:
            ray.init(num_cpus=num_cpus if num_cpus > 0 else os.cpu_count(), include_dashboard=False, log_to_driver=False)
        started = True
    try:
        try:
            policy_ref = ray.put(policy)
        except Exception as e:  # noqa: BLE001 - pickling errors come in many types
            raise ValueError(f"the policy cannot be sent to Ray workers ({e}); use --executor local") from e
        task = ray.remote(num_cpus=1, max_retries=MAX_RETRIES)(run_task)
        work_ref = ray.put(work)
        pending = [task.remote(work_ref, policy_ref, b) for b in batches]
        try:
            while pending:
                done, pending = ray.wait(pending, num_returns=1)
                yield ray.get(done[0])
        finally:
            for ref in pending:
                ray.cancel(ref, force=True)
    finally:
        if started:
            ray.shutdown()
