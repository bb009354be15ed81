"""Test-session settings: the reference-twin cache lives in a temporary folder, so the tests
neither read twins a developer's runs left behind nor fill the user's cache."""

from __future__ import annotations

import os
from collections.abc import Iterator

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
