"""What every figure of the project shares: the style and the one way figures are saved.

Figures are saved without a creation date, so the same results give byte-identical files
(the committed figures stay unchanged when a documented command redraws them).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

__all__ = ["RC", "save_figure"]

#: Style of the project's figures (matplotlib rc parameters).
RC = {
    "font.size": 8,
    "axes.titlesize": 8,
    "axes.labelsize": 8,
    "legend.fontsize": 7,
    "xtick.labelsize": 7,
    "ytick.labelsize": 7,
    "lines.linewidth": 1.0,
    "axes.grid": True,
    "grid.alpha": 0.3,
}


def save_figure(
    fig: Any, stem: Path, formats: Sequence[str] = ("png",), dpi: int = 200
) -> list[Path]:
    """Save ``fig`` as ``<stem>.<format>`` for each format, then close it.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure.
    stem : pathlib.Path
        File name without extension; its folder is created.
    formats : sequence of str
        ``"png"``, ``"pdf"``, ...
    dpi : int
        Resolution of raster formats.

    Returns
    -------
    list of pathlib.Path
        The files written, in the order of ``formats``.
    """
    stem = Path(stem)
    stem.parent.mkdir(parents=True, exist_ok=True)
    paths = []
    for ext in formats:
        path = stem.with_name(f"{stem.name}.{ext}")
        meta = {"CreationDate": None} if ext == "pdf" else None  # same results, same bytes
        fig.savefig(path, dpi=dpi, metadata=meta)
        paths.append(path)
    plt.close(fig)
    return paths
