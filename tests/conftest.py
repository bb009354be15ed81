"""Test-session settings and the one factory of JSBSim aircraft for the tests.

The reference-twin cache lives in a temporary folder, so the tests neither read twins a
developer's runs left behind nor fill the user's cache.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator
from typing import Any

import pytest


@pytest.fixture(scope="session", autouse=True)
def _private_twin_cache(tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    old = os.environ.get("PROBING_TWIN_CACHE")
    os.environ["PROBING_TWIN_CACHE"] = str(tmp_path_factory.mktemp("twins"))
    yield
    if old is None:
        os.environ.pop("PROBING_TWIN_CACHE", None)
    else:
        os.environ["PROBING_TWIN_CACHE"] = old


@pytest.fixture(scope="session")
def new_plant() -> Callable[..., Any]:
    """``new_plant(model="gtm_t2", dt_s=1/200, **kwargs)``: a fresh, untrimmed
    :class:`probing.sim.plant.Plant` (sanitised model, quiet); its FGFDMExec is ``.fdm``.

    Trim it with :meth:`~probing.sim.plant.Plant.trim`, the project's one trim path.
    """
    from probing.sim.plant import Plant

    def make(model: str = "gtm_t2", dt_s: float = 1.0 / 200.0, **kwargs: Any) -> Plant:
        return Plant(model, dt_s, **kwargs)

    return make
