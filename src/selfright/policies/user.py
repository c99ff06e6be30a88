"""A policy written in Python by the user, named on the command line as ``FILE.py:NAME`` or
``package.module:NAME`` (``selfright evaluate --policy my_policy.py:Recover``).

``NAME`` is one of: a ``Policy`` instance; a ``Policy`` subclass, constructed with the run's
``BenchmarkConfig`` if its constructor takes an argument, else with none; or a factory function
``f(cfg: BenchmarkConfig) -> Policy``. A policy that does not set ``action_mapping`` runs under
the evaluation's (``stand`` + 0.5 rad × action by default). Its ``digest`` defaults to a hash of
the source file, so that a resumed evaluation refuses results of an edited policy.
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.util
import inspect
import sys
from pathlib import Path
from types import ModuleType

from selfright.config import BenchmarkConfig
from selfright.policies.base import Policy


def is_user_policy(name: str) -> bool:
    """Whether ``name`` reads as ``FILE.py:NAME`` or ``package.module:NAME``."""
    module, sep, attr = name.rpartition(":")
    return bool(sep and module and attr.isidentifier()
                and (module.endswith(".py") or all(p.isidentifier() for p in module.split("."))))


def load_user_policy(name: str, cfg: BenchmarkConfig) -> Policy:
    """The policy ``name`` (``FILE.py:NAME`` or ``package.module:NAME``) names; ``ValueError`` (one
    line) when it cannot be loaded or is not a ``Policy``."""
    where, _, attr = name.rpartition(":")
    module = _import(where)
    if not hasattr(module, attr):
        raise ValueError(f"{where} defines no {attr!r}")
    obj = getattr(module, attr)
    if isinstance(obj, Policy):
        policy = obj
    elif inspect.isclass(obj) and issubclass(obj, Policy):
        takes_cfg = len(inspect.signature(obj).parameters) > 0
        policy = obj(cfg) if takes_cfg else obj()
    elif callable(obj) and not inspect.isclass(obj):
        policy = obj(cfg)
        if not isinstance(policy, Policy):
            raise ValueError(f"{name}: the factory returned a {type(policy).__name__}, not a selfright Policy")
    else:
        raise ValueError(f"{name} is a {type(obj).__name__}; give a Policy, a Policy subclass or a factory f(cfg) -> Policy")
    if policy.name == Policy.name:
        policy.name = attr
    if policy.digest is None:
        source = getattr(module, "__file__", None)
        text = Path(source).read_bytes() if source else b""
        policy.digest = hashlib.sha256(text + b"/" + attr.encode()).hexdigest()[:16]
    return policy


def _import(where: str) -> ModuleType:
    if where.endswith(".py"):
        path = Path(where)
        if not path.is_file():
            raise ValueError(f"policy file {where} not found")
        spec = importlib.util.spec_from_file_location(f"selfright_user_policy_{path.stem}", path)
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        sys.modules[spec.name] = module
        try:
            spec.loader.exec_module(module)
        except Exception as e:  # noqa: BLE001 - the user's code: say where it failed, in one line
            raise ValueError(f"importing {where} failed: {type(e).__name__}: {e}") from e
        return module
    try:
        return importlib.import_module(where)
    except ImportError as e:
        raise ValueError(f"cannot import {where} ({e})") from e
