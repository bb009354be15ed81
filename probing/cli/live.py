"""``probing live``: a scenario flown on a JSBSim process started apart, with the monitor."""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from probing.cli.common import (
    Subcommands,
    UsageError,
    check_run_folder,
    command,
    files_of,
    out_folder,
    path_arg,
    scenario_arg,
    simulating,
)

if TYPE_CHECKING:
    from probing.experiment.scenario import Scenario

#: Simulated time the written script flies beyond the scenario, s (set-up and margin).
END_MARGIN_S = 60.0

#: ``--write-sim``'s port when ``--port`` is not given.
DEFAULT_PORT = 5139


def _cmd_live(args: argparse.Namespace) -> int:
    from probing.experiment.flight.live import LiveError, check_live
    from probing.experiment.flight.sim_socket import PORTS_TEXT, is_port

    if (args.connect is None) == (args.write_sim is None):
        raise UsageError("live: give --connect HOST:PORT or --write-sim DIR (one of them)")
    if args.port is not None and args.connect is not None:
        raise UsageError(
            f"--port {args.port}: --port is the port --write-sim writes; with --connect the "
            "port is the one in HOST:PORT"
        )
    if args.port is not None and not is_port(args.port):
        raise UsageError(f"--port {args.port}: give {PORTS_TEXT}")
    scn = scenario_arg(args.scenario)
    try:
        check_live(scn)
    except LiveError as exc:
        raise UsageError(str(exc)) from None
    if args.write_sim is not None:
        return _write_sim(scn, args)
    return _connect(scn, args)


def _write_sim(scn: Scenario, args: argparse.Namespace) -> int:
    """``--write-sim DIR``: the simulator's files, and the command that starts it."""
    from probing.sim.cache import check_cache
    from probing.sim.live_sim import LISTENS_EVERYWHERE, write_sim

    folder = out_folder(args.write_sim, "--write-sim")
    check_cache()  # the simulator's aircraft is the cache's sanitised copy
    end_s = scn.total_steps * scn.dt_s + END_MARGIN_S
    port = DEFAULT_PORT if args.port is None else args.port
    line = write_sim(scn.flight, folder, port, end_s)
    print(shlex.join(line))
    print(f"probing: note: {LISTENS_EVERYWHERE.format(port=port)}", file=sys.stderr)
    return 0


def _connect(scn: Scenario, args: argparse.Namespace) -> int:
    """``--connect HOST:PORT``: the live flight (the output folder checked first)."""
    from probing.experiment.flight.live import LiveError, live_monitor
    from probing.experiment.flight.sim_socket import SimConnectionError, is_loopback, parse_address

    try:
        host, port = parse_address(args.connect)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    if not is_loopback(host) and not args.allow_remote:
        raise UsageError(
            f"--connect {args.connect}: not this machine's loopback; give --allow-remote to "
            "fly a simulator elsewhere"
        )
    check_run_folder(args.out, scn)

    def job() -> int:
        try:
            result = live_monitor(scn, host, port, args.out, realtime=args.realtime)
        except (SimConnectionError, LiveError) as exc:
            raise UsageError(str(exc)) from None
        print(f"{scn.name} (live): {result.monitor.line()} -> {result.monitor.out_dir}")
        print(f"{scn.name} (live): {result.headroom_line()}")
        return 0

    return simulating(job, str(args.scenario))


def register(sub: Subcommands) -> None:
    """Add ``live`` to ``sub``."""
    live = command(
        sub,
        "live",
        "fly a scenario on a JSBSim process started apart (its input socket, lock step) with "
        f"the monitor: {files_of('live')} into OUT/<scenario name>/ (docs/live.md)",
        [
            "probing live examples/live/scenario.toml --write-sim /tmp/live-sim --port 5139   "
            "# prints the simulator's command",
            "probing live examples/live/scenario.toml --connect 127.0.0.1:5139 --out results",
        ],
    )
    live.add_argument("scenario", type=path_arg, help="scenario TOML file (docs/scenarios.md)")
    live.add_argument("--connect", metavar="HOST:PORT", help="the simulator's input socket")
    live.add_argument(
        "--write-sim",
        type=path_arg,
        metavar="DIR",
        help="write the simulator's JSBSim root into DIR and print the command that starts it",
    )
    live.add_argument(
        "--port",
        type=int,
        help=f"with --write-sim: the input socket's TCP port (default {DEFAULT_PORT})",
    )
    live.add_argument(
        "--out", type=path_arg, default=Path("results"), help="results go to OUT/<scenario name>/"
    )
    live.add_argument(
        "--realtime", action="store_true", help="pace the frames at the wall clock (dt each)"
    )
    live.add_argument(
        "--allow-remote",
        action="store_true",
        help="connect to a HOST other than this machine's loopback",
    )
    live.set_defaults(func=_cmd_live)
