"""Which runner flies a scenario, and which commands it offers: the one table the command
line, the sweep spec and the runners consult, in place of ``is not None`` chains over the
scenario's sections.

A scenario with ``[simultaneous]`` is flown by
:func:`probing.experiment.studies.simultaneous.run_simultaneous`, one with ``[manoeuvre]`` by
:func:`probing.experiment.studies.manoeuvre.run_manoeuvre`, every other one by
:func:`probing.experiment.flight.run.run_scenario` (a steady condition: ``probing run``, ``truth``,
``monitor`` and sweeps).  Adding a runner is one entry here and its handler in
``probing.cli.run.RUN_HANDLERS`` (``docs/architecture.md``, "How to add a runner"); every
command asks :meth:`Runner.refuses` before any work.  Loads no simulator.
"""

from __future__ import annotations

from dataclasses import dataclass

from probing.experiment.scenario import Scenario

__all__ = ["RUNNERS", "Runner", "runner_of"]


@dataclass(frozen=True)
class Runner:
    """A way of flying a scenario.

    Attributes
    ----------
    name : str
        ``"steady"``, ``"simultaneous"`` or ``"manoeuvre"``.
    section : str or None
        The scenario section that selects it (None: the default runner).
    commands : frozenset of str
        What flies it: ``run``, ``truth``, ``monitor``, ``sweep`` (a sweep's base),
        ``live`` (against a separate JSBSim process).
    refusal : str
        Why another command cannot, after ``probing <command>`` (``{command}`` is not used).
    """

    name: str
    section: str | None
    commands: frozenset[str]
    refusal: str = ""

    def refuses(self, command: str) -> str | None:
        """The one line refusing ``probing <command>`` for this runner's scenarios, or None
        if the command flies them."""
        return None if command in self.commands else f"probing {command} {self.refusal}"


#: The runners, the section-selected ones first (a scenario holds at most one of them).
RUNNERS: tuple[Runner, ...] = (
    Runner(
        "simultaneous",
        "simultaneous",
        frozenset({"run"}),
        "takes one probed surface; a [simultaneous] scenario is flown by probing run (its "
        "--truth flies each surface alone)",
    ),
    Runner(
        "manoeuvre",
        "manoeuvre",
        frozenset({"run"}),
        "flies a steady condition; a [manoeuvre] scenario is flown by probing run (with its "
        "single-pulse truth along the manoeuvre)",
    ),
    Runner("steady", None, frozenset({"run", "truth", "monitor", "sweep", "live"})),
)


def runner_of(scn: Scenario) -> Runner:
    """The runner that flies ``scn``: the first whose section the scenario has."""
    return next(r for r in RUNNERS if r.section is None or getattr(scn, r.section) is not None)
