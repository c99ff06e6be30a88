"""Learned policies from files: selfright policy files, rsl_rl checkpoints, ONNX, TorchScript.

``load_policy_file`` decides the format from the file itself and the observation group
(``student`` 42-D, ``teacher`` 79-D) from the stored metadata or the network's input size.
Every policy acts deterministically (the mean action). Any file that cannot be used ends in
one ``ValueError`` line naming the file and what to do.
"""

from __future__ import annotations

import hashlib
import json
import sys
import warnings
import zipfile
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch

from selfright.policies.actor import (
    DEPLOYED_ACTOR_KEYS,
    FILE_FORMAT,
    GROUP_BY_DIM,
    ActorMLP,
    actor_from_checkpoint,
    actor_from_payload,
    group_dim,
)
from selfright.policies.base import Policy
from selfright.policies.history import ObsHistory
from selfright.terrain import Cell

TORCH_SUFFIXES = (".pt", ".pth", ".jit", ".ts")


class _FilePolicy(Policy):
    """A learned policy reading one observation group, optionally its last ``history`` frames
    stacked (oldest first; ``selfright.policies.history``)."""

    def __init__(self, group: str, name: str, action_mapping: tuple[str, float] | None, history: int):
        self.group = group
        self.name = name
        self.action_mapping = action_mapping
        self.history = history
        self._frames = None if history <= 1 else ObsHistory(history, group_dim(group))

    def reset(self, ids: np.ndarray, seeds: np.ndarray | None = None) -> None:
        if self._frames is not None:
            self._frames.reset(ids)

    def _input(self, obs: dict[str, torch.Tensor], ids: np.ndarray) -> torch.Tensor:
        """The network input (k, D): the group's observation, or its stacked history."""
        x = obs[self.group].float()
        return x if self._frames is None else self._frames.push(ids, x)


class TorchPolicy(_FilePolicy):
    """A torch module ``obs (k, D) -> actions (k, J)`` reading one observation group.

    Each env's action is computed independently of the others in the batch (``ActorMLP``'s
    ``forward_rows``, other modules one row at a time), so an episode's outcome does not depend
    on which episodes share its batch: ``--batch-size`` and resuming leave results unchanged."""

    def __init__(
        self, module: Callable[[torch.Tensor], torch.Tensor], group: str, name: str,
        action_mapping: tuple[str, float] | None = None, history: int = 1,
    ):
        super().__init__(group, name, action_mapping, history)
        self.module = module

    @torch.no_grad()
    def act(self, obs: dict[str, torch.Tensor], ids: np.ndarray, cells: Sequence[Cell | None]) -> torch.Tensor:
        x = self._input(obs, ids)
        if isinstance(self.module, ActorMLP):
            return self.module.forward_rows(x).float()
        return _rows(lambda r: self.module(r).float(), x)


class OnnxPolicy(_FilePolicy):
    """An ONNX graph ``obs (k, D) -> actions (k, J)`` run by onnxruntime on the CPU."""

    def __init__(
        self, session: Any, group: str, name: str, action_mapping: tuple[str, float] | None = None, history: int = 1,
    ):
        super().__init__(group, name, action_mapping, history)
        self.session = session
        self.input_name = session.get_inputs()[0].name

    def act(self, obs: dict[str, torch.Tensor], ids: np.ndarray, cells: Sequence[Cell | None]) -> torch.Tensor:
        """One row per session run, for the batch independence ``TorchPolicy`` explains."""
        x = self._input(obs, ids).detach().cpu().numpy().astype(np.float32)
        if len(x) == 0:
            return torch.from_numpy(self.session.run(None, {self.input_name: x})[0]).float()
        outs = [self.session.run(None, {self.input_name: x[i : i + 1]})[0] for i in range(len(x))]
        return torch.from_numpy(np.concatenate(outs)).float()


def _rows(fn: Callable[[torch.Tensor], torch.Tensor], x: torch.Tensor) -> torch.Tensor:
    """``fn`` applied to each row of ``x`` (k, D) as a batch of one, stacked: (k, J)."""
    if len(x) == 0:
        return fn(x)
    return torch.cat([fn(x[i : i + 1]) for i in range(len(x))])


def load_policy_file(path: str | Path) -> Policy:
    """A deterministic ``Policy`` from ``path``.

    Accepted: ``.pt`` policy files from ``selfright export`` (loaded with
    ``weights_only=True``), rsl_rl training checkpoints ``model_<it>.pt``, ``.onnx`` graphs,
    and TorchScript ``.pt``/``.jit`` modules. Raises ``ValueError`` (one line) otherwise.
    """
    p = Path(path)
    if not p.exists():
        raise ValueError(f"policy file {p} not found; pass a .pt, .jit or .onnx policy (see `selfright export`)")
    if not p.is_file():
        raise ValueError(f"policy path {p} is not a file; pass a .pt, .jit or .onnx policy file")
    if p.suffix == ".onnx":
        policy = _load_onnx(p)
    elif p.suffix in TORCH_SUFFIXES:
        policy = _load_jit(p) if _is_torchscript(p) else _load_torch(p)
    else:
        raise ValueError(f"policy file {p} has unsupported type {p.suffix!r}; use .pt, .jit or .onnx")
    _probe(policy, p)
    policy.digest = hashlib.sha256(p.read_bytes()).hexdigest()[:16]
    return policy


# ------------------------------------------------------------------- formats
def _load_torch(p: Path) -> Policy:
    actor = load_torch_actor(p)
    m = actor.meta
    mapping = (m.action_reference, m.action_scale_rad) if m.action_reference else None
    return TorchPolicy(actor, m.obs_group, p.stem, mapping, m.obs_history)


def load_torch_actor(p: Path) -> ActorMLP:
    """The actor of a weights-only torch file: a ``selfright export`` policy file or an rsl_rl
    training checkpoint (its run's metadata as the hint). ``ValueError`` (one line) otherwise."""
    try:
        payload = torch.load(p, map_location="cpu", weights_only=True)
    except Exception as e:  # noqa: BLE001 - any unpickling failure means the same to the user
        raise ValueError(
            f"policy file {p} is corrupt or not a weights-only torch file ({type(e).__name__}); "
            "re-export it with `selfright export`"
        ) from e
    if isinstance(payload, dict) and payload.get("format") == FILE_FORMAT:
        actor = _wrap(p, actor_from_payload, payload)
    elif isinstance(payload, dict) and any(k in payload for k in DEPLOYED_ACTOR_KEYS):
        from selfright.policies.run_files import policy_hint

        hint = policy_hint(p, payload.get("infos"))
        missing = [what for key, what in (("action_reference", "action mapping"), ("motor", "motor model"))
                   if key not in hint]
        if missing:
            print(
                f"selfright: warning: training checkpoint {p} has no train_meta.json beside it and records no "
                f"{' or '.join(missing)}; it runs as this evaluation's, which may not be what it trained with. "
                "Keep checkpoints in their run folder, or "
                "`selfright export` them.",
                file=sys.stderr,
            )
        actor = _wrap(p, actor_from_checkpoint, payload, hint)
    else:
        raise ValueError(
            f"policy file {p} holds no actor; pass a file from `selfright export` or a training checkpoint"
        )
    return actor


def _load_jit(p: Path) -> Policy:
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)  # TorchScript is deprecated, still supported
            module = torch.jit.load(str(p), map_location="cpu").eval()
    except Exception as e:  # noqa: BLE001
        raise ValueError(f"TorchScript policy {p} cannot be loaded ({_first_line(e)})") from e
    dim = next((t.shape[-1] for t in module.state_dict().values() if t.dim() == 2), None)
    group = GROUP_BY_DIM.get(int(dim)) if dim is not None else None
    if group is None:
        raise ValueError(f"TorchScript policy {p}: input size {dim} matches no observation group {GROUP_BY_DIM}")
    return TorchPolicy(module, group, p.stem)


def _load_onnx(p: Path) -> Policy:
    import onnxruntime as ort

    opts = ort.SessionOptions()
    opts.intra_op_num_threads = 1
    opts.inter_op_num_threads = 1
    try:
        session = ort.InferenceSession(str(p), sess_options=opts, providers=["CPUExecutionProvider"])
    except Exception as e:  # noqa: BLE001
        raise ValueError(f"ONNX policy {p} cannot be loaded ({_first_line(e)})") from e
    if len(session.get_inputs()) != 1:
        names = [i.name for i in session.get_inputs()]
        raise ValueError(f"ONNX policy {p} takes inputs {names}; only feed-forward graphs obs -> actions are supported")
    props = session.get_modelmeta().custom_metadata_map
    group = _json_or_none(props.get("obs_group"))
    if group is None:
        dim = session.get_inputs()[0].shape[-1]
        group = GROUP_BY_DIM.get(dim) if isinstance(dim, int) else None
    if group not in GROUP_BY_DIM.values():
        raise ValueError(f"ONNX policy {p}: cannot tell its observation group (no metadata, input size unknown)")
    ref, scale = _json_or_none(props.get("action_reference")), _json_or_none(props.get("action_scale_rad"))
    history = int(_json_or_none(props.get("obs_history")) or 1)
    return OnnxPolicy(session, group, p.stem, (str(ref), float(scale or 0.0)) if ref else None, history)


# ------------------------------------------------------------------- helpers
def _is_torchscript(p: Path) -> bool:
    """TorchScript archives are zip files with a ``code/`` folder and ``constants.pkl``."""
    if not zipfile.is_zipfile(p):
        return False
    with zipfile.ZipFile(p) as z:
        names = z.namelist()
    return any(n.endswith("/constants.pkl") for n in names) and any("/code/" in n for n in names)


def _wrap(p: Path, fn: Callable[..., Any], *args: Any) -> Any:
    try:
        return fn(*args)
    except (ValueError, KeyError, RuntimeError, TypeError) as e:
        raise ValueError(f"policy file {p}: {_first_line(e)}") from e


def _probe(policy: Policy, p: Path) -> None:
    """Run the policy once on zeros so a broken file fails at load time, not mid-evaluation."""
    obs = {policy.group: torch.zeros(1, group_dim(policy.group))}
    try:
        out = policy.act(obs, np.zeros(1, dtype=np.int64), [None])
        policy.reset(np.zeros(1, dtype=np.int64))  # the probe's frame is no episode's history
    except Exception as e:  # noqa: BLE001
        raise ValueError(f"policy file {p} does not run on {policy.group} observations ({_first_line(e)})") from e
    if out.dim() != 2 or out.shape[0] != 1 or not torch.isfinite(out).all():
        raise ValueError(f"policy file {p} returns {tuple(out.shape)} instead of finite (batch, joints) actions")


def _json_or_none(s: str | None) -> Any:
    if s is None:
        return None
    try:
        return json.loads(s)
    except ValueError:
        return s


def _first_line(e: BaseException) -> str:
    text = str(e).strip() or type(e).__name__
    return text.splitlines()[0][:200]
