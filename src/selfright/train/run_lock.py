"""One writer per run folder.

A stopped run (SIGINT/SIGTERM) first saves and validates its last checkpoint, which takes tens
of seconds; a ``--resume`` (or a fresh run after deleting the folder) started in that time would
write the same checkpoints, validation files and tensorboard log as the old process. The lock
file ``train.lock`` in the run folder names the process that writes there; a second
``selfright train`` into the folder refuses to start while that process lives on this machine.
A lock left by a process that died (SIGKILL, power loss) or written on another machine (a
folder brought back from the GPU machine) is taken over.
"""

from __future__ import annotations

import contextlib
import json
import os
import socket
import time
from pathlib import Path
from typing import Iterator

LOCK_NAME = "train.lock"


def proc_state(pid: int) -> str:
    """The one-letter state of ``pid`` in ``/proc/PID/stat`` (``Z`` for a zombie); the command
    name before it is in parentheses and may itself hold spaces or parentheses."""
    return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]


def _alive(pid: int) -> bool:
    """Whether ``pid`` runs and could be a ``selfright train`` (a Python process). Where
    ``/proc`` tells the command line, a process that is not Python is a reused pid: stale."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # someone else's process: it exists
        pass
    try:
        cmdline = Path(f"/proc/{pid}/cmdline").read_bytes()
        if not cmdline:  # a zombie, or a process inside execve (its new image not yet in place)
            return proc_state(pid) != "Z"
    except (OSError, IndexError):
        return True  # no /proc (macOS) or not ours to read: trust the pid
    return b"python" in cmdline or b"selfright" in cmdline


def lock_holder(out: Path) -> dict | None:
    """The lock's record if a live process on this machine holds ``out``, else None."""
    try:
        rec = json.loads((out / LOCK_NAME).read_text())
        pid, host = int(rec["pid"]), str(rec["host"])
    except (OSError, ValueError, KeyError, TypeError):
        return None  # no lock, or a torn one: nobody we can name holds it
    if host != socket.gethostname() or not _alive(pid):
        return None
    return rec


def _create_whole(path: Path, record: dict) -> None:
    """Create ``path`` holding ``record``, or raise ``FileExistsError``. The record is written to a
    file of this process's own first and hard-linked into place, so another process never sees the
    lock without its pid (which it would take for a torn, stale lock). Where the file system has no
    hard links, the lock is created empty and then written (a window of microseconds)."""
    tmp = path.with_name(f"{path.name}.{os.getpid()}.tmp")
    tmp.write_text(json.dumps(record))
    try:
        os.link(tmp, path)
    except FileExistsError:
        raise
    except OSError:  # no hard links here (FAT, some network mounts)
        fd = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        with os.fdopen(fd, "w") as fh:
            json.dump(record, fh)
    finally:
        tmp.unlink(missing_ok=True)


@contextlib.contextmanager
def run_lock(out: Path) -> Iterator[None]:
    """Hold ``out``'s lock for the block; raises ``ValueError`` if a live process holds it."""
    path = out / LOCK_NAME
    mine = {"pid": os.getpid(), "host": socket.gethostname(), "since": time.strftime("%Y-%m-%d %H:%M:%S")}
    for _ in range(2):
        try:
            _create_whole(path, mine)
        except FileExistsError:
            holder = lock_holder(out)
            if holder is not None and holder["pid"] != os.getpid():
                raise ValueError(
                    f"{out} is being written by another selfright train (pid {holder['pid']}, since "
                    f"{holder.get('since', '?')}); a stopped run saves and validates its last checkpoint "
                    f"before it exits. Wait for it, or stop that process, then rerun"
                ) from None
            if holder is not None:
                raise ValueError(f"{out} is already held by this process; runs into one folder cannot nest")
            path.unlink(missing_ok=True)  # stale: its process is gone, or it came from another machine
            continue
        break
    else:  # pragma: no cover - another process took the stale lock between our two tries
        raise ValueError(f"{out}: another selfright train took the run folder as this one started; rerun")
    try:
        yield
    finally:
        with contextlib.suppress(OSError, ValueError):
            if json.loads(path.read_text()).get("pid") == os.getpid():
                path.unlink()
