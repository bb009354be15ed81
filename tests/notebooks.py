"""Executing a notebook in a test: nbclient and a kernel of this interpreter's environment.

The kernel is ipykernel's native ``python3`` spec, which jupyter_client starts with this
interpreter (``sys.executable``). Every folder the kernel, IPython, Jupyter or Matplotlib
would write to (home, profile, runtime, caches, the system's temporary folder) is a
temporary one for the run, so that a test writes nothing outside its ``workdir``: not into
the repository, not into the home, nothing left in /tmp.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from unittest import mock

import nbformat
from nbclient import NotebookClient
from nbclient.exceptions import CellExecutionError

#: The variables that name where the kernel and its client write, each set to a folder of
#: its own in a temporary directory for the run.
SCRATCH_VARIABLES = (
    "HOME",
    "IPYTHONDIR",
    "JUPYTER_CONFIG_DIR",
    "JUPYTER_DATA_DIR",
    "JUPYTER_RUNTIME_DIR",
    "MPLCONFIGDIR",
    "XDG_CACHE_HOME",
    "XDG_CONFIG_HOME",
    "XDG_DATA_HOME",
    "TMPDIR",
)


#: The backend Jupyter uses: figures become the cells' ``image/png`` outputs.
INLINE = "module://matplotlib_inline.backend_inline"


def run_notebook(path: Path, workdir: Path, timeout_s: float = 900) -> nbformat.NotebookNode:
    """Execute a notebook on a kernel of this environment and return it with its outputs.

    Parameters
    ----------
    path : Path
        The notebook (``.ipynb``); it is read, not changed.
    workdir : Path
        The kernel's working directory: the only folder besides temporary ones that the
        notebook's code should write to.
    timeout_s : float
        The longest a single cell may run, in seconds.

    Returns
    -------
    nbformat.NotebookNode
        The executed notebook; each code cell's ``outputs`` hold what it printed.

    Raises
    ------
    nbclient.exceptions.CellExecutionError
        A cell raised; the message names the notebook and the cell (counted from 1 over all
        cells), then nbclient's own: the cell's source and the traceback.
    """
    notebook = nbformat.read(path, as_version=4)
    failed: list[int] = []
    client = NotebookClient(
        notebook,
        kernel_name="python3",
        timeout=timeout_s,
        on_cell_error=lambda cell, cell_index, execute_reply: failed.append(cell_index),
    )
    with tempfile.TemporaryDirectory(prefix="notebook-") as scratch:
        folders = {name: Path(scratch, name.lower()) for name in SCRATCH_VARIABLES}
        for folder in folders.values():
            folder.mkdir()
        # matplotlib's backend in a notebook: a figure a cell returns or draws is its output
        env = {name: str(folder) for name, folder in folders.items()} | {"MPLBACKEND": INLINE}
        # The client finds the kernel spec and writes the connection file, the kernel
        # inherits the rest: both see the same variables. JUPYTER_PATH would put a user's
        # kernel specs before this environment's.
        with mock.patch.dict(os.environ, env):
            os.environ.pop("JUPYTER_PATH", None)
            try:
                client.execute(cwd=str(workdir))
            except CellExecutionError as error:
                where = (
                    f"{path}, cell {failed[-1] + 1} of {len(notebook.cells)}" if failed else path
                )
                raise CellExecutionError(
                    f"{where}:\n{error.traceback}", error.ename, error.evalue
                ) from None
    return notebook
