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


@pytest.fixture(scope="session")
def toy_linear() -> Any:
    """A made-up :class:`probing.sim.linear.LinearResponse`: a slow and a fast mode, two
    outputs (one with feed-through), a three-step actuator."""
    import numpy as np

    from probing.sim.linear import LinearResponse

    return LinearResponse(
        a=np.array([[0.995, 0.01], [0.0, 0.9]]),
        b=np.array([0.0, 1.0]),
        c=np.array([[1.0, 0.0], [0.2, 1.0]]),
        d=np.array([0.0, 0.3]),
        channels=("theta_rad", "q_rad_s"),
        actuator=np.array([0.6, 0.3, 0.1]),
    )


@pytest.fixture(scope="session")
def stepped() -> Callable[..., Any]:
    """``stepped(lin, asked)``: a LinearResponse stepped one step at a time, as its docstring
    defines it (the actuator as a convolution, then x(k+1) = A x(k) + B u(k), output
    C x(k) + D u(k-1)), from rest; shape (N, C).  The oracle of its vectorised methods."""
    import numpy as np

    def step(lin: Any, asked: Any) -> Any:
        asked = np.asarray(asked, dtype=float)
        u = np.convolve(asked, lin.actuator)[: asked.size]
        x = np.zeros(lin.a.shape[0])
        out = np.empty((asked.size, lin.c.shape[0]))
        for k in range(asked.size):
            out[k] = lin.c @ x + (lin.d * u[k - 1] if k else 0.0)
            x = lin.a @ x + lin.b * u[k]
        return out

    return step
