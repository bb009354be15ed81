"""The ``probing.*`` keys of a file kept where pandas keeps a DataFrame's ``attrs``
(``PANDAS_ATTRS``): ``read_parquet`` fills ``attrs`` from it and ``to_parquet`` writes them
back, so a log a user reads and writes again with pandas keeps the keys its replay needs
(:class:`probing.experiment.output.storage.AtomicParquetWriter`, ``read_footer``).

A table a :class:`probing.Flight` hands back carries the keys decoded, without their prefix
(``attrs["scenario"]``, :func:`probing.api.flight.attrs_of`): written with ``to_parquet``,
they are read back as the ``probing.*`` keys they were (:func:`from_pandas_attrs`), so an
edited ``flight.sensors`` replays as the file does.
"""

from __future__ import annotations

import json
from typing import Any

__all__ = ["ATTRS_FILE", "PANDAS_ATTRS", "from_pandas_attrs", "stored_text", "to_pandas_attrs"]

#: The schema key under which pandas keeps a DataFrame's ``attrs``.
PANDAS_ATTRS = b"PANDAS_ATTRS"
#: The key of a Flight's table's ``attrs`` naming its file (no key of the file's own).
ATTRS_FILE = "file"


def stored_text(value: Any) -> str:
    """A ``probing.*`` key's value as a file stores it: a string as itself, anything else as
    JSON with sorted keys (:func:`probing.experiment.output.storage.metadata`)."""
    return value if isinstance(value, str) else json.dumps(value, sort_keys=True)


def to_pandas_attrs(meta: dict[bytes, bytes]) -> dict[bytes, bytes]:
    """The ``probing.*`` keys of ``meta`` as pandas' ``attrs``: ``{PANDAS_ATTRS: JSON}``."""
    attrs = {k.decode(): v.decode() for k, v in meta.items() if k.startswith(b"probing.")}
    return {PANDAS_ATTRS: json.dumps(attrs, sort_keys=True).encode()}


def from_pandas_attrs(meta: dict[bytes, bytes]) -> dict[bytes, bytes]:
    """The ``probing.*`` keys pandas kept in :data:`PANDAS_ATTRS` (none if it holds none):
    those it holds as written (``pd.read_parquet`` of a file), and those of a Flight's table
    (decoded, without the prefix), stored again as :func:`stored_text`; the first win."""
    try:
        attrs = json.loads(meta.get(PANDAS_ATTRS, b"{}"))
    except ValueError:
        return {}
    if not isinstance(attrs, dict):
        return {}
    keys = {
        f"probing.{k}".encode(): stored_text(v).encode()
        for k, v in attrs.items()
        if isinstance(k, str) and not k.startswith("probing.") and k != ATTRS_FILE
    }
    written = {
        k.encode(): v.encode()
        for k, v in attrs.items()
        if isinstance(k, str) and k.startswith("probing.") and isinstance(v, str)
    }
    return {**keys, **written}
