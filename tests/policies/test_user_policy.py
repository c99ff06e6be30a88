"""A user's Python policy named on the command line as FILE.py:NAME or package.module:NAME."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from selfright.cli import main, policy_stem
from selfright.config import BenchmarkConfig
from selfright.policies.registry import make_policy
from selfright.policies.user import is_user_policy, load_user_policy

EXAMPLE = Path(__file__).parents[2] / "examples" / "tuck_and_stand.py"

POLICIES = """
import torch
from selfright.policies.base import Policy, CallablePolicy

class Still(Policy):
    def act(self, obs, ids, contexts):
        return torch.zeros(len(ids), 12)

instance = Still()

def factory(cfg):
    return CallablePolicy(lambda o: torch.zeros(len(o), 12))

def not_a_factory(cfg):
    return 3

number = 3
"""


def test_names_that_read_as_python_policies():
    assert is_user_policy("my_policy.py:Recover") and is_user_policy("pkg.mod:make")
    assert is_user_policy("dir/sub dir/p.py:P")
    for name in ("flat", "open-loop", "runs/flat_student", "model_1.pt", "x.onnx", "pkg.mod:", ":P", "a.py:1x"):
        assert not is_user_policy(name), name


def test_instances_classes_and_factories_load(tmp_path):
    path = tmp_path / "pols.py"
    path.write_text(POLICIES)
    cfg = BenchmarkConfig()
    for attr in ("Still", "instance", "factory"):
        policy = load_user_policy(f"{path}:{attr}", cfg)
        assert policy.digest is not None
    assert load_user_policy(f"{path}:Still", cfg).name == "Still"
    example = make_policy(f"{EXAMPLE}:TuckAndStand", cfg)  # a class that takes the config
    assert example.name == "TuckAndStand"


@pytest.mark.parametrize("attr, message", [
    ("missing", "defines no 'missing'"),
    ("number", "is a int"),
    ("not_a_factory", "returned a int"),
])
def test_what_is_not_a_policy_is_said_in_one_line(tmp_path, attr, message):
    path = tmp_path / "pols.py"
    path.write_text(POLICIES)
    with pytest.raises(ValueError, match=message):
        load_user_policy(f"{path}:{attr}", BenchmarkConfig())


def test_missing_files_and_failing_imports(tmp_path):
    with pytest.raises(ValueError, match="not found"):
        load_user_policy(f"{tmp_path / 'nope.py'}:P", BenchmarkConfig())
    bad = tmp_path / "bad.py"
    bad.write_text("raise RuntimeError('boom')\n")
    with pytest.raises(ValueError, match="importing .* failed: RuntimeError: boom"):
        load_user_policy(f"{bad}:P", BenchmarkConfig())
    with pytest.raises(ValueError, match="cannot import"):
        load_user_policy("no_such_package_here.mod:P", BenchmarkConfig())


def test_evaluate_runs_a_python_policy_and_refuses_to_resume_an_edited_one(tmp_path, capsys):
    path = tmp_path / "pols.py"
    path.write_text(POLICIES)
    out = tmp_path / "res"
    args = ["evaluate", "--policy", f"{path}:Still", "--grid", "tiny", "--episodes", "1",
            "--no-plots", "--no-progress", "--threads", "1", "--out", str(out)]
    assert main(args) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["policy"] == f"{path}:Still" and summary["overall"]["n"] == 4
    path.write_text(POLICIES + "\n# edited\n")
    capsys.readouterr()
    assert main(args) != 0  # another version of the policy: a fresh --out is asked for
    assert "differs in: policy_digest" in capsys.readouterr().err
    assert policy_stem(f"{path}:Still") == "pols-Still" and policy_stem("pkg.mod:make") == "mod-make"


def test_the_readmes_python_example_runs(tmp_path, monkeypatch):
    """The README's Python API example, as written (it writes under results/ of the working folder)."""
    readme = (Path(__file__).parents[2] / "README.md").read_text()
    start = readme.index("```python\nfrom pathlib import Path\n\nimport torch")
    code = readme[start + len("```python\n"): readme.index("```", start + 10)]
    monkeypatch.chdir(tmp_path)
    exec(compile(code, "README.md", "exec"), {})
    summary = json.loads((tmp_path / "results/stand_still_tiny/summary.json").read_text())
    assert summary["overall"]["n"] == 16 and (tmp_path / "results/stand_still_tiny/success.png").exists()
