"""The ``probing.*`` keys of a file kept where pandas keeps a DataFrame's ``attrs``
(``PANDAS_ATTRS``): ``read_parquet`` fills ``attrs`` from it and ``to_parquet`` writes them
back, so a log a user reads and writes again with pandas keeps the keys its replay needs
(:class:`probing.experiment.output.storage.AtomicParquetWriter`, ``read_footer``)."""

from __future__ import annotations

import json

__all__ = ["PANDAS_ATTRS", "from_pandas_attrs", "to_pandas_attrs"]

#: The schema key under which pandas keeps a DataFrame's ``attrs``.
PANDAS_ATTRS = b"PANDAS_ATTRS"


def to_pandas_attrs(meta: dict[bytes, bytes]) -> dict[bytes, bytes]:
    """The ``probing.*`` keys of ``meta`` as pandas' ``attrs``: ``{PANDAS_ATTRS: JSON}``."""
    attrs = {k.decode(): v.decode() for k, v in meta.items() if k.startswith(b"probing.")}
    return {PANDAS_ATTRS: json.dumps(attrs, sort_keys=True).encode()}


def from_pandas_attrs(meta: dict[bytes, bytes]) -> dict[bytes, bytes]:
    """The ``probing.*`` keys pandas kept in :data:`PANDAS_ATTRS` (none if it holds none)."""
    try:
        attrs = json.loads(meta.get(PANDAS_ATTRS, b"{}"))
    except ValueError:
        return {}
    if not isinstance(attrs, dict):
        return {}
    return {
        k.encode(): v.encode()
        for k, v in attrs.items()
        if isinstance(k, str) and k.startswith("probing.") and isinstance(v, str)
    }
