"""PPO inside a composite learns only from the steps the trained policy acted in
(``selfright.train.override_mask``): overridden steps get zero advantage, the kept ones are
normalised among themselves and scaled by 1 / their share, and a masked run trains."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest
import torch

from selfright.train.override_mask import OverrideMask

from test_learning_smoke import TINY, run, spec


def test_rewrite_by_hand():
    m = OverrideMask(steps=2, num_envs=2)
    m.record(0, torch.tensor([True, False]))
    m.record(1, torch.tensor([False, True]))
    adv = torch.tensor([[[5.0], [1.0]], [[3.0], [-7.0]]])  # kept: 1.0 (step 0, env 1), 3.0 (step 1, env 0)
    out = m.rewrite(adv, normalize=False)
    assert m.kept_share == 0.5
    assert torch.equal(out, torch.tensor([[[0.0], [2.0]], [[6.0], [0.0]]]))
    z = m.rewrite(adv, normalize=True)  # kept mean 2, std sqrt(2): ±1/sqrt(2), then × 2
    s = 2.0 / 2.0**0.5
    assert torch.allclose(z, torch.tensor([[[0.0], [-s]], [[s], [0.0]]]), atol=1e-6)
    m.record(0, torch.tensor([True, True]))
    m.record(1, torch.tensor([True, True]))
    assert torch.equal(m.rewrite(adv, normalize=True), torch.zeros_like(adv))
    assert m.kept_share == 0.0


def test_masked_specialist_trains_and_zeroes_overridden_steps(tmp_path: Path):
    frozen = tmp_path / "frozen"
    run(spec(frozen))
    # tilt 179.99°: (almost surely) every state counts as upright, so every step is overridden ...
    ep = dataclasses.replace(TINY.episode, upright_policy=str(frozen), upright_tilt_deg=179.99, upright_masked=True)
    from selfright.train.runner import TrainingRun

    r = TrainingRun(spec(tmp_path / "all", train=dataclasses.replace(TINY, episode=ep), iterations=1))
    r.setup()
    seen = []
    alg = r.runner.alg
    update = alg.update
    alg.update = lambda: (seen.append(alg.storage.advantages.clone()), update())[1]
    r.run()
    assert seen and torch.equal(seen[0], torch.zeros_like(seen[0]))
    # ... and at 45° the falls' tilted steps keep theirs (normalised among themselves).
    ep45 = dataclasses.replace(ep, upright_tilt_deg=45.0)
    r45 = run(spec(tmp_path / "some", train=dataclasses.replace(TINY, episode=ep45), iterations=2))
    assert r45.last_loss
    with pytest.raises(ValueError, match="upright-masked"):
        bad = dataclasses.replace(TINY.episode, upright_masked=True)
        TrainingRun(spec(tmp_path / "bad", train=dataclasses.replace(TINY, episode=bad))).setup()
