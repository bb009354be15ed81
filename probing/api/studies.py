"""The Python API's design and sweeps: ``probing.design`` (``probing design``),
``probing.check_simultaneous`` (``probing design --simultaneous``) and ``probing.fly_sweep``
(``probing sweep``).  A sweep is written to disk as it goes (it resumes where it stopped);
its table is :meth:`probing.sweep.SweepResult.summary`."""

from __future__ import annotations

import dataclasses
import inspect
import textwrap
import typing
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from probing.core.errors import refer
from probing.experiment.design.design_request import DesignRequest
from probing.experiment.scenario import Scenario

if TYPE_CHECKING:
    from probing.experiment.design.design import Design
    from probing.experiment.studies.simultaneous import SeparationCheck
    from probing.sim.modes import LongitudinalModes
    from probing.sweep import Sweep, SweepResult

__all__ = ["Recommendation", "check_simultaneous", "design", "fly_sweep"]


@dataclass(frozen=True)
class Recommendation:
    """What :func:`design` recommends.

    Attributes
    ----------
    design : Design
        Order, bit duration, amplitude (deg), estimator, drift and periods, each with its
        reason (``design.reasons``), and the predicted standard errors.
    modes : LongitudinalModes
        The aircraft's short-period and phugoid modes at the trim (rad/s, 1).
    scenario : Scenario
        The recommended scenario (named ``design``): :func:`probing.fly` flies it.
    """

    design: Design
    modes: LongitudinalModes
    scenario: Scenario


def design(request: DesignRequest | None = None, /, **options: Any) -> Recommendation:
    """Recommend a probe: order, bit duration and amplitude (``probing design``).

    Parameters
    ----------
    request : DesignRequest, optional
        The request; or its fields as keywords, listed below (each is the option
        ``--field-name`` of ``probing design``, with the same default).

    Returns
    -------
    Recommendation

    Raises
    ------
    probing.experiment.design.design.DesignInputError
        An option unknown, missing or refused (naming the keyword).
    probing.experiment.design.design.DesignError
        No design meets every rule or the target.
    TrimError
        The aircraft does not trim at the condition.
    """
    from probing.core.errors import ArgumentError
    from probing.experiment.design.design import recommend

    if request is None:
        request = DesignRequest.of(options)
    elif not isinstance(request, DesignRequest):
        raise ArgumentError("request", f"must be a DesignRequest, got {request!r}")
    elif options:
        raise ArgumentError("request", "give a request or its fields as keywords, not both")
    return Recommendation(*recommend(request))


def _design_keywords() -> None:
    """:func:`design`'s signature and docstring list the request's fields as keywords, with
    their types, defaults and help: one table of options (``DesignRequest``'s), which
    ``probing design`` also builds its options from."""
    hints = typing.get_type_hints(DesignRequest)
    first = inspect.Parameter("request", inspect.Parameter.POSITIONAL_ONLY, default=None)
    params, lines = [first], []
    for f in dataclasses.fields(DesignRequest):
        required = f.default is dataclasses.MISSING
        default = inspect.Parameter.empty if required else f.default
        hint = hints[f.name]
        params.append(
            inspect.Parameter(
                f.name, inspect.Parameter.KEYWORD_ONLY, default=default, annotation=hint
            )
        )
        option = f.metadata["option"]
        said = refer(option["help"], str).removesuffix(" (required)")
        if "choices" in option:
            said += f"; one of {', '.join(option['choices'])}"
        kind = hint.__name__ if isinstance(hint, type) else str(hint)
        lines += [
            f"    {f.name} : {kind}" + ("" if required else f", default {f.default!r}"),
            *textwrap.wrap(
                said + (" (required)" if required else ""),
                84,
                initial_indent=" " * 8,
                subsequent_indent=" " * 8,
            ),
        ]
    returns = inspect.signature(design).return_annotation
    design.__signature__ = inspect.Signature(params, return_annotation=returns)  # type: ignore[attr-defined]
    assert design.__doc__ is not None
    head, tail = design.__doc__.split("\n    Returns\n")
    keywords = "\n".join(lines)
    design.__doc__ = f"{head.rstrip()}\n{keywords}\n\n    Returns\n{tail}"


_design_keywords()


def check_simultaneous(scenario: Scenario | str | Path) -> SeparationCheck:
    """The memory condition and predicted cross-talk of a ``[simultaneous]`` scenario from
    the linearisation (``probing design --simultaneous``): ``.ok``, ``.table()``,
    ``.refusal()``.

    Raises
    ------
    ScenarioError
        A scenario the simultaneous runner does not fly.
    probing.experiment.studies.simultaneous.SeparationError
        Its surfaces cannot be linearised apart.
    """
    from probing.api.calls import load
    from probing.experiment.flight.runners import runner_of
    from probing.experiment.scenario import ScenarioError
    from probing.experiment.studies.simultaneous import check_separation

    scn = scenario if isinstance(scenario, Scenario) else load(scenario)
    runner = runner_of(scn).name
    if runner != "simultaneous":
        why = "has no [simultaneous] section" if runner == "steady" else f"is flown by {runner}"
        raise ScenarioError(
            "simultaneous", f"{why}; design --simultaneous checks a simultaneous design", scn.name
        )
    return check_separation(scn)


def fly_sweep(
    sweep: Sweep | str | Path,
    out: str | Path,
    *,
    jobs: int | None = None,
    executor: str = "local",
    scheduler: str | None = None,
    retry_failed: bool = False,
    progress: bool | Literal["lines"] | None = None,
    connect_timeout_s: float = 10.0,
) -> SweepResult:
    """Fly a sweep's missing points into ``out/<name>/`` (``probing sweep``; docs/sweeps.md).

    Parameters
    ----------
    sweep : Sweep or path
        The sweep, or its TOML file.
    out : path
        The results folder; the sweep resumes from what it holds.
    jobs : int, optional
        Worker processes, >= 1 (default: one per core).
    executor : {"local", "dask"}
        A local pool, or Dask (``scheduler``: an existing scheduler's address, else a
        LocalCluster).
    retry_failed : bool
        Fly again the points recorded as failed.
    progress : bool or "lines", optional
        A progress bar on stderr, or one line per finished run (``"lines"``, what the
        command line writes into a log); default: a bar in a Jupyter notebook, nothing in a
        script.
    connect_timeout_s : float
        How long to wait for ``scheduler``, s (> 0).

    Returns
    -------
    SweepResult
        What was done; ``.summary()`` is ``summary.parquet`` as a DataFrame.

    Raises
    ------
    ScenarioError
        The sweep file is invalid.
    probing.ArgumentError
        ``jobs``, ``executor``, ``scheduler``, ``connect_timeout_s`` or ``progress`` refused.
    OutputPathError
        ``out`` cannot be written.
    probing.sweep.SchedulerError, probing.sweep.SweepBusyError
        The scheduler does not answer; another process holds the sweep's folder.

    All are raised before anything is written.
    """
    from probing.api.calls import in_notebook
    from probing.core.errors import ArgumentError
    from probing.sweep import load_sweep, run_sweep

    shown = in_notebook() if progress is None else progress
    if not (isinstance(shown, bool) or shown == "lines"):
        raise ArgumentError("progress", f"must be True, False or 'lines', got {progress!r}")
    spec = load_sweep(sweep) if isinstance(sweep, str | Path) else sweep
    return run_sweep(
        spec,
        out,
        jobs=jobs,
        executor=executor,
        scheduler=scheduler,
        retry_failed=retry_failed,
        progress=shown is True,
        lines=shown == "lines",
        connect_timeout_s=connect_timeout_s,
    )
