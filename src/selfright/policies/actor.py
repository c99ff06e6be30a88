"""The shippable actor: observation normaliser + MLP, deterministic (mean) action.

A trained actor travels in three forms, all built here:

- an rsl_rl training checkpoint (``model_<it>.pt``: ``actor_state_dict`` from PPO, or
  ``student_state_dict`` from distillation), converted by ``actor_from_checkpoint``;
- a policy file (``.pt``): the actor's ``state_dict`` plus metadata, nothing else, so it
  loads with ``torch.load(..., weights_only=True)`` (``save_actor_file`` / ``load_actor_file``);
- an ONNX graph ``obs (batch, D) -> actions (batch, J)`` (``export_onnx``).

The MLP's layer names match rsl_rl's ``MLPModel.mlp`` (``mlp.0.weight`` ...), so weights
copy over unchanged.
"""

from __future__ import annotations

import io
import json
import logging
import re
import warnings
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import torch
from rsl_rl.utils import resolve_nn_activation
from torch import nn

FILE_FORMAT = "selfright.actor"
FILE_VERSION = 1
RSL_RL_NORMALIZER_EPS = 1e-2
"""``EmpiricalNormalization``'s default eps: rsl_rl normalises as (x − mean) / (std + eps)."""
GROUP_BY_DIM = {42: "student", 79: "teacher"}
"""Observation group by input size (A1: 9 + 3·12 = 42; + 37 privileged = 79)."""


def group_dim(group: str) -> int:
    """Size of one frame of observation group ``group``; ``ValueError`` for an unknown group."""
    for dim, name in GROUP_BY_DIM.items():
        if name == group:
            return dim
    raise ValueError(f"unknown observation group {group!r}; expected one of {sorted(GROUP_BY_DIM.values())}")


@dataclass(frozen=True, kw_only=True)
class ActorMeta:
    """What a policy file records besides the weights."""

    obs_group: str
    """Observation group read: ``student`` or ``teacher``."""
    obs_dim: int
    """Input size D."""
    action_dim: int
    """Output size J (joints)."""
    hidden_dims: tuple[int, ...]
    """Hidden layer widths."""
    activation: str
    """Hidden activation (rsl_rl name)."""
    obs_normalization: bool
    """Whether inputs are normalised by the stored running mean/std."""
    normalizer_eps: float = RSL_RL_NORMALIZER_EPS
    """eps of (x − mean) / (std + eps)."""
    role: str = ""
    """``teacher`` or ``student`` (how it was trained)."""
    context: str = ""
    """Training context (flat, rough, incline)."""
    iteration: int = -1
    """Learning iteration of the checkpoint it came from."""
    source: str = ""
    """Checkpoint it was exported from."""
    action_reference: str = ""
    """What its actions are relative to (``ActionConfig.reference``: ``stand`` or ``current``);
    empty if not recorded (files written before it was)."""
    action_scale_rad: float = 0.0
    """Radians of joint target per unit action it was trained with (0 = not recorded)."""
    obs_history: int = 1
    """Frames of ``obs_group`` in the input, oldest first (``obs_dim`` = frames × group size);
    the policy keeps them per env slot (``selfright.policies.history``)."""
    motor: str = ""
    """Motor model it was trained with (``RobotConfig.motor``: ``ideal`` or ``dcmotor``); empty
    if not recorded (files written before it was, all trained with ``ideal``)."""
    motor_speed_rad_s: float = 0.0
    """With ``motor`` ``dcmotor``: the no-load speed it was trained with (0 = the robot's rated
    speed)."""

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["hidden_dims"] = list(self.hidden_dims)
        return d

    @staticmethod
    def from_dict(d: dict[str, Any]) -> ActorMeta:
        """The meta of a policy file or checkpoint ``infos``; unknown keys are ignored, and
        ``ValueError`` if it describes an architecture other than normaliser + MLP."""
        refuse_other_architectures(d)
        d = dict(d)
        d["hidden_dims"] = tuple(int(h) for h in d["hidden_dims"])
        known = ActorMeta.__dataclass_fields__
        return ActorMeta(**{k: v for k, v in d.items() if k in known})


NO_OP_ARCHITECTURE = {"gru_dim": 0, "estimator_dims": [], "state_dependent_std": False}
"""Metadata keys that older policy files and checkpoints record, at the values that describe
this module's actor (no recurrent layer, no velocity estimator, a state-independent std)."""


def refuse_other_architectures(d: dict[str, Any]) -> None:
    """``ValueError`` if metadata ``d`` records a ``NO_OP_ARCHITECTURE`` key at another value."""
    for key, no_op in NO_OP_ARCHITECTURE.items():
        value = d.get(key, no_op)
        if (list(value) if isinstance(value, (list, tuple)) else value) != no_op:
            raise ValueError(f"actor has {key}={value!r}: only feed-forward actors (normaliser + MLP, "
                             "state-independent std) are supported")


class ActorMLP(nn.Module):
    """Deterministic actor: ``mlp((obs − mean) / (std + eps))``, obs (k, D) -> actions (k, J)."""

    def __init__(self, meta: ActorMeta):
        super().__init__()
        self.meta = meta
        self.eps = float(meta.normalizer_eps)
        self.obs_normalization = bool(meta.obs_normalization)
        self.register_buffer("obs_mean", torch.zeros(meta.obs_dim))
        self.register_buffer("obs_std", torch.ones(meta.obs_dim))
        self.mlp = mlp_layers(meta.obs_dim, meta.hidden_dims, meta.action_dim, meta.activation)

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        """Actions (k, J) for inputs ``obs`` (k, D)."""
        return self.mlp(self._normalize(obs))

    def forward_rows(self, obs: torch.Tensor) -> torch.Tensor:
        """``forward``, computed so that each row's result is bitwise independent of the other
        rows and of their number. In a plain batched pass two things depend on the batch: a
        (k, D) @ (D, H) product sums in a k-dependent order (BLAS blocks differently), and an
        activation's vectorised and scalar code paths (which differ in the last bit) are chosen
        by an element's position in the whole tensor. The 1e-7 differences grow through the
        chaotic contact dynamics of a fall into different outcomes, so an episode's result
        would depend on the episodes batched with it. Here every product has one shape: rows
        go through in zero-padded blocks of ``ROW_BLOCK``, each a (ROW_BLOCK, D) @ (D, H) GEMM,
        in which a row's sums run in an order set by the shapes alone, not by its position or
        its neighbours (``tests/policies/test_export.py`` checks this bit for bit). Activations
        run on rows padded to whole vectors. Results agree with ``forward`` to float32
        rounding."""
        return _sequential_rows(self.mlp, self._normalize(obs))

    def _normalize(self, obs: torch.Tensor) -> torch.Tensor:
        if self.obs_normalization:
            return (obs - self.obs_mean) / (self.obs_std + self.eps)
        return obs


ROW_BLOCK = 16
"""Rows per matrix product in ``forward_rows``: every product is (ROW_BLOCK, D) @ (D, H), so
the BLAS takes one code path for all of them. 16 rows share each read of the weights (a
per-row product rereads a 2 MB first layer once per row, 3-4× slower at 64 rows) while a
nearly empty block costs little."""
ROW_PAD = 64
"""Row width multiple (floats) that fills whole SIMD vectors (2 × 16 for AVX-512) of an
elementwise kernel, so no element of a row falls to the scalar tail loop."""
ELEMENTWISE_GRAIN = 32768
"""Elements torch runs on one thread (``at::internal::GRAIN_SIZE``): a larger call is split
across threads at positions that need not fall on row boundaries."""


def mlp_layers(width: int, hidden: tuple[int, ...], out: int, activation: str) -> nn.Sequential:
    """Linear layers ``width -> hidden... -> out`` with ``activation`` between (rsl_rl ``MLP``'s layout)."""
    dims = [width, *hidden]
    layers: list[nn.Module] = []
    for a, b in zip(dims[:-1], dims[1:]):
        layers += [nn.Linear(a, b), resolve_nn_activation(activation)]
    layers.append(nn.Linear(dims[-1], out))
    return nn.Sequential(*layers)


def _sequential_rows(seq: nn.Sequential, x: torch.Tensor) -> torch.Tensor:
    """``seq(x)`` for x (k, D) of linear layers and elementwise activations, row by row (see
    ``ActorMLP.forward_rows``)."""
    for layer in seq:
        if isinstance(layer, nn.Linear):
            x = _linear_rows(x, layer.weight, layer.bias)
        else:
            x = _padded_rows(layer, x)  # elementwise activation
    return x


def _linear_rows(x: torch.Tensor, weight: torch.Tensor, bias: torch.Tensor) -> torch.Tensor:
    """``x @ weight.T + bias`` for x (k, D), in zero-padded (ROW_BLOCK, D) @ (D, H) blocks: one
    batched product over the blocks, which runs the same (ROW_BLOCK, D) @ (D, H) GEMM per block
    as a loop of single products (bit for bit) without a dispatch per block. The bias is added
    after the product (an addition rounds the same on every code path)."""
    k = x.shape[0]
    kp = -(-max(k, 1) // ROW_BLOCK) * ROW_BLOCK
    xp = torch.nn.functional.pad(x, (0, 0, 0, kp - k))
    blocks = torch.matmul(xp.view(kp // ROW_BLOCK, ROW_BLOCK, x.shape[1]), weight.t())
    return blocks.reshape(kp, -1)[:k] + bias


def _padded_rows(fn: Callable[[torch.Tensor], torch.Tensor], x: torch.Tensor) -> torch.Tensor:
    """Elementwise ``fn`` of ``x`` (k, H), every element through the same (vector) code path:
    rows zero-padded to a multiple of ``ROW_PAD``, in single-threaded blocks of whole rows."""
    k, h = x.shape
    hp = -(-h // ROW_PAD) * ROW_PAD
    xp = torch.nn.functional.pad(x, (0, hp - h)) if hp != h else x.contiguous()
    step = max(1, ELEMENTWISE_GRAIN // hp)
    return torch.cat([fn(xp[i : i + step]) for i in range(0, max(k, 1), step)])[:k, :h]


# --------------------------------------------------------------- checkpoints
DEPLOYED_ACTOR_KEYS = ("student_state_dict", "actor_state_dict")
"""Where an rsl_rl checkpoint keeps the actor that deploys, first found first: a distilled
student, else the PPO actor."""


def deployed_actor_key(ckpt: dict[str, Any]) -> str:
    """The key of the checkpoint's deployed actor (``DEPLOYED_ACTOR_KEYS``); ``ValueError`` if none."""
    for key in DEPLOYED_ACTOR_KEYS:
        if key in ckpt:
            return key
    raise ValueError("checkpoint holds neither 'actor_state_dict' nor 'student_state_dict'")


def actor_from_checkpoint(ckpt: dict[str, Any], hint: dict[str, Any] | None = None) -> ActorMLP:
    """The deployable actor of an rsl_rl checkpoint (the student if distilled, else the PPO
    actor).

    Architecture is read off the weights; ``hint`` (e.g. the run's ``train_meta.json``
    ``policy`` entry, or the checkpoint's ``infos``) supplies the activation, role and context.
    Raises ``ValueError`` if the dict holds no actor or one that is not normaliser + MLP with a
    state-independent std.
    """
    hint = dict(hint or {})
    refuse_other_architectures(hint)
    key = deployed_actor_key(ckpt)
    sd, role = ckpt[key], "teacher" if key == "actor_state_dict" else "student"
    layers = _linear_layers(sd, "mlp")
    if not layers:
        raise ValueError("checkpoint actor has no MLP weights (mlp.<i>.weight)")
    # rsl_rl keeps a state-independent std in ``distribution.*``; a PPO actor without one has a
    # state-dependent std (its last layer outputs [mean; log std]).
    other = sorted({k.split(".")[0] for k in sd if not k.startswith(("mlp.", "obs_normalizer.", "distribution."))})
    if not other and role == "teacher" and not any(k.startswith("distribution.") for k in sd):
        other = ["a state-dependent std"]
    if other:
        raise ValueError(f"checkpoint actor has {', '.join(other)}: only feed-forward actors "
                         "(normaliser + MLP, state-independent std) are supported")
    shapes = [tuple(sd[k].shape) for _, k in layers]
    obs_dim = shapes[0][1]
    history = int(hint.get("obs_history", 1))
    if obs_dim % history:
        raise ValueError(f"actor input size {obs_dim} is not a multiple of its {history} observation frames")
    normalized = "obs_normalizer._mean" in sd
    meta = ActorMeta(
        obs_group=hint.get("obs_group")
        or GROUP_BY_DIM.get(obs_dim // history, "teacher" if role == "teacher" else "student"),
        obs_dim=obs_dim,
        action_dim=shapes[-1][0],
        hidden_dims=tuple(s[0] for s in shapes[:-1]),
        activation=hint.get("activation", "elu"),
        obs_normalization=normalized,
        role=hint.get("role", role),
        context=hint.get("context", ""),
        iteration=int(ckpt.get("iter", -1)),
        source=str(hint.get("source", "")),
        action_reference=str(hint.get("action_reference", "")),
        action_scale_rad=float(hint.get("action_scale_rad", 0.0)),
        obs_history=history,
        motor=str(hint.get("motor", "")),
        motor_speed_rad_s=float(hint.get("motor_speed_rad_s") or 0.0),
    )
    actor = ActorMLP(meta)
    state = OrderedDict((k, v) for k, v in sd.items() if k.startswith("mlp."))
    if normalized:
        state["obs_mean"] = sd["obs_normalizer._mean"].reshape(-1)
        state["obs_std"] = sd["obs_normalizer._std"].reshape(-1)
    else:
        state["obs_mean"] = actor.obs_mean
        state["obs_std"] = actor.obs_std
    actor.load_state_dict(state)
    return actor.eval()


def _linear_layers(sd: dict[str, torch.Tensor], prefix: str) -> list[tuple[int, str]]:
    """(index, key) of the ``PREFIX.<i>.weight`` entries of ``sd``, in layer order."""
    pattern = re.compile(rf"{prefix}\.(\d+)\.weight")
    return sorted((int(m.group(1)), k) for k in sd if (m := pattern.fullmatch(k)) is not None)


def teacher_checkpoint(actor: ActorMLP) -> dict[str, Any]:
    """An rsl_rl PPO-style checkpoint (``actor_state_dict``, ``iter``, ``infos``) holding
    ``actor``'s weights: the inverse of ``actor_from_checkpoint``, so that a shipped or exported teacher can be distilled from (``--teacher``). It has no critic
    or optimiser, so it cannot resume PPO; its action std (unused by a frozen teacher) is 1."""
    m = actor.meta
    sd: OrderedDict[str, torch.Tensor] = OrderedDict()
    if m.obs_normalization:
        mean, std = actor.obs_mean.detach().clone(), actor.obs_std.detach().clone()
        sd["obs_normalizer._mean"] = mean.reshape(1, -1)
        sd["obs_normalizer._var"] = (std * std).reshape(1, -1)
        sd["obs_normalizer._std"] = std.reshape(1, -1)
        sd["obs_normalizer.count"] = torch.tensor(0, dtype=torch.long)
    sd["distribution.std_param"] = torch.ones(m.action_dim)
    sd.update((k, v.detach().clone()) for k, v in actor.state_dict().items() if k.startswith("mlp."))
    infos = {
        "obs_group": m.obs_group,
        "hidden_dims": list(m.hidden_dims),
        "activation": m.activation,
        "obs_normalization": m.obs_normalization,
        "role": m.role or "teacher",
        "context": m.context,
        "action_reference": m.action_reference,
        "action_scale_rad": m.action_scale_rad,
        "obs_history": m.obs_history,
        "source": m.source,
    }
    return {"actor_state_dict": sd, "iter": m.iteration, "infos": infos}


# ---------------------------------------------------------------- policy file
def actor_payload(actor: ActorMLP) -> dict[str, Any]:
    """The policy-file content: plain tensors and primitives only (``weights_only``-safe)."""
    sd = OrderedDict((k, v.detach().cpu().clone()) for k, v in actor.state_dict().items())
    return {"format": FILE_FORMAT, "version": FILE_VERSION, "meta": actor.meta.to_dict(), "state_dict": sd}


def save_actor_file(path: str | Path, actor: ActorMLP) -> None:
    """Write the policy file of ``actor`` (``.pt``)."""
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    torch.save(actor_payload(actor), path)


def actor_from_payload(payload: Any) -> ActorMLP:
    """Rebuild an actor from a policy-file dict; ``ValueError`` if it is not one."""
    if not isinstance(payload, dict) or payload.get("format") != FILE_FORMAT:
        raise ValueError(f"not a selfright policy file (expected format {FILE_FORMAT!r})")
    if int(payload.get("version", 0)) > FILE_VERSION:
        raise ValueError(f"policy file version {payload.get('version')} is newer than supported ({FILE_VERSION})")
    try:
        actor = ActorMLP(ActorMeta.from_dict(payload["meta"]))
        actor.load_state_dict(payload["state_dict"])
    except (KeyError, TypeError, RuntimeError) as e:
        raise ValueError(f"policy file is inconsistent: {str(e).splitlines()[0]}") from e
    return actor.eval()


def load_actor_file(path: str | Path) -> ActorMLP:
    """Load a policy file written by ``save_actor_file`` (``weights_only=True``)."""
    return actor_from_payload(torch.load(path, map_location="cpu", weights_only=True))


# ----------------------------------------------------------------------- ONNX
def export_onnx(actor: ActorMLP, path: str | Path) -> None:
    """Write ``actor`` as ONNX: input ``obs`` (batch, D) float32 -> output ``actions`` (batch, J).
    With ``meta.obs_history`` H > 1, ``obs`` is the group's last H frames concatenated, oldest
    first, every frame the first one at an episode's start (the deployer keeps that history).

    The metadata (``ActorMeta``) is stored in the model's ``metadata_props`` (values as JSON),
    and for a student its ``selfright.deploy.DeploymentSpec`` under ``deployment``.
    """
    import onnx

    actor = actor.eval()
    quiet = [logging.getLogger(n) for n in ("torch.onnx", "torch.export", "torch._dynamo")]
    levels = [lg.level for lg in quiet]
    try:
        for lg in quiet:
            lg.setLevel(logging.ERROR)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            batch = torch.export.Dim("batch")
            program = torch.onnx.export(
                actor,
                (torch.zeros(1, actor.meta.obs_dim),),
                None,
                input_names=["obs"],
                output_names=["actions"],
                dynamic_shapes=({0: batch},),
                opset_version=18,
                dynamo=True,
                verbose=False,
            )
    finally:
        for lg, level in zip(quiet, levels):
            lg.setLevel(level)
    proto = program.model_proto
    props = dict(actor.meta.to_dict())
    if actor.meta.obs_group == "student":  # what a robot feeds it and does with its output
        from selfright.deploy import DEPLOY_KEY, deployment_spec

        props[DEPLOY_KEY] = deployment_spec(actor.meta).to_json()
    for key, value in props.items():
        prop = proto.metadata_props.add()
        prop.key, prop.value = key, json.dumps(value)
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    buf = io.BytesIO()
    onnx.save(proto, buf)
    Path(path).write_bytes(buf.getvalue())
