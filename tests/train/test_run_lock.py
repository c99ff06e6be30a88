"""The run folder's lock: one ``selfright train`` writes into a folder at a time."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from selfright.train.run_lock import LOCK_NAME, _create_whole, lock_holder, proc_state, run_lock


def write_lock(out: Path, pid: int, host: str | None = None) -> None:
    (out / LOCK_NAME).write_text(json.dumps({"pid": pid, "host": host or socket.gethostname(), "since": "then"}))


def started(argv: list[str]) -> subprocess.Popen:
    """A child process, returned once it runs ``argv`` (until its execve ends, /proc shows no
    command line, and the lock rightly cannot tell what the process is)."""
    proc = subprocess.Popen(argv)
    cmdline = Path(f"/proc/{proc.pid}/cmdline")
    deadline = time.monotonic() + 10
    while cmdline.exists() and argv[-1].encode() not in cmdline.read_bytes() and time.monotonic() < deadline:
        time.sleep(0.001)
    return proc


def test_a_live_writer_keeps_others_out_and_the_lock_goes_with_it(tmp_path: Path):
    sleeper = started([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        write_lock(tmp_path, sleeper.pid)
        assert lock_holder(tmp_path)["pid"] == sleeper.pid
        with pytest.raises(ValueError, match=f"pid {sleeper.pid}"):
            with run_lock(tmp_path):
                pass
        assert json.loads((tmp_path / LOCK_NAME).read_text())["pid"] == sleeper.pid  # left as it was
    finally:
        sleeper.kill()
        sleeper.wait()
    with run_lock(tmp_path):  # its process is gone: the lock is taken over
        assert json.loads((tmp_path / LOCK_NAME).read_text())["pid"] == os.getpid()
    assert not (tmp_path / LOCK_NAME).exists()


def test_a_lock_from_another_machine_or_torn_is_taken_over(tmp_path: Path):
    write_lock(tmp_path, os.getppid(), host="the-gpu-machine")
    with run_lock(tmp_path):
        assert lock_holder(tmp_path)["pid"] == os.getpid()
    (tmp_path / LOCK_NAME).write_text('{"pid": 12')
    with run_lock(tmp_path):
        pass
    assert not (tmp_path / LOCK_NAME).exists()


def test_a_pid_reused_by_another_program_is_stale(tmp_path: Path):
    other = started(["sleep", "60"])
    try:
        write_lock(tmp_path, other.pid)
        assert lock_holder(tmp_path) is None
    finally:
        other.kill()
        other.wait()


def test_a_dead_process_not_yet_reaped_is_stale(tmp_path: Path):
    zombie = subprocess.Popen(["true"])  # exits at once; its parent (this test) reaps it only at wait()
    try:
        deadline = time.monotonic() + 10
        while proc_state(zombie.pid) != "Z" and time.monotonic() < deadline:
            time.sleep(0.001)
        write_lock(tmp_path, zombie.pid)
        assert lock_holder(tmp_path) is None
    finally:
        zombie.wait()


def test_the_lock_appears_whole_and_leaves_no_scratch_file(tmp_path: Path):
    with run_lock(tmp_path):
        assert sorted(p.name for p in tmp_path.iterdir()) == [LOCK_NAME]
        assert json.loads((tmp_path / LOCK_NAME).read_text())["pid"] == os.getpid()
        with pytest.raises(FileExistsError):  # creation never replaces a lock that is there
            _create_whole(tmp_path / LOCK_NAME, {"pid": 1, "host": "x"})
        assert json.loads((tmp_path / LOCK_NAME).read_text())["pid"] == os.getpid()
    assert list(tmp_path.iterdir()) == []


def test_the_lock_is_released_when_the_run_fails(tmp_path: Path):
    with pytest.raises(RuntimeError):
        with run_lock(tmp_path):
            raise RuntimeError("boom")
    assert not (tmp_path / LOCK_NAME).exists()


def test_train_refuses_a_folder_another_process_writes_and_leaves_no_empty_folder(tmp_path: Path):
    from selfright.train.commands import TrainArgs, train

    sleeper = started([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        out = tmp_path / "busy"
        out.mkdir()
        write_lock(out, sleeper.pid)
        with pytest.raises(ValueError, match="another selfright train"):
            train(TrainArgs(out=out, envs=2, iterations=1))
    finally:
        sleeper.kill()
        sleeper.wait()
    with pytest.raises(ValueError):  # a user error before anything is written
        train(TrainArgs(out=tmp_path / "new", role="student"))
    assert not (tmp_path / "new").exists()
