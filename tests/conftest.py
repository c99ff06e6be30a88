"""The whole test session writes its fall cache (``selfright.evaluate.fall_cache``) into a
temporary folder, set before any fixture runs: no test reads settled falls an earlier run or
the user's own cache left behind (tests that need a cold cache take a fresh folder)."""

import pytest


@pytest.fixture(scope="session", autouse=True)
def _private_fall_cache(tmp_path_factory):
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("XDG_CACHE_HOME", str(tmp_path_factory.mktemp("xdg_cache")))
        yield
