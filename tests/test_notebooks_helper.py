"""tests/notebooks.py runs a notebook on a kernel of this environment, in temporary folders."""

from __future__ import annotations

import re
import sys
import tempfile
from pathlib import Path

import nbformat
import pytest
from nbclient.exceptions import CellExecutionError
from notebooks import INLINE, run_notebook


def write_notebook(path: Path, *sources: str) -> Path:
    """A notebook of one code cell per source, written to ``path``."""
    cells = [nbformat.v4.new_code_cell(source) for source in sources]
    nbformat.write(nbformat.v4.new_notebook(cells=cells), path)
    return path


def stdout(cell: nbformat.NotebookNode) -> str:
    """What an executed code cell printed."""
    return "".join(
        output["text"]
        for output in cell.outputs
        if output["output_type"] == "stream" and output["name"] == "stdout"
    )


def test_the_executed_notebook_is_returned_from_this_interpreter_in_workdir(
    tmp_path: Path,
) -> None:
    """A cell's output is read back; the kernel is this interpreter, run in ``workdir`` with
    the notebook's inline backend and its home, IPython and Jupyter folders temporary (gone
    afterwards)."""
    workdir = tmp_path / "work"
    workdir.mkdir()
    notebook = write_notebook(
        tmp_path / "reads.ipynb",
        "print(6 * 7)",
        "import os, sys\n"
        "import matplotlib\n"
        "print(sys.executable)\n"
        "print(os.getcwd())\n"
        "print(matplotlib.get_backend())\n"
        "for name in ('HOME', 'IPYTHONDIR', 'JUPYTER_RUNTIME_DIR', 'MPLCONFIGDIR'):\n"
        "    print(os.environ[name])",
    )

    executed = run_notebook(notebook, workdir)

    assert int(stdout(executed.cells[0])) == 42
    executable, cwd, backend, *folders = stdout(executed.cells[1]).splitlines()
    assert Path(executable) == Path(sys.executable)
    assert Path(cwd) == workdir
    assert backend == INLINE
    assert len(folders) == 4
    for folder in folders:
        assert Path(folder).is_relative_to(tempfile.gettempdir()), folder
        assert not Path(folder).exists(), f"{folder} was left behind"


def test_a_failing_cell_raises_naming_the_notebook_and_the_cell(tmp_path: Path) -> None:
    """The error names the notebook and the failing cell (the second here, not the first)."""
    notebook = write_notebook(
        tmp_path / "fails.ipynb", "print(6 * 7)", "raise ValueError('the second cell fails')"
    )

    with pytest.raises(CellExecutionError, match=re.escape(f"{notebook}, cell 2 of 2")) as raised:
        run_notebook(notebook, tmp_path)

    assert raised.value.ename == "ValueError"
    assert "raise ValueError('the second cell fails')" in str(raised.value)
