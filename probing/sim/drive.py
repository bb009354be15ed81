"""Driving a surface at a position: the model's command-to-position map measured on its own
flight-control system and inverted (:class:`SurfaceDrive`), built by
:meth:`probing.sim.plant.Plant.drive`."""

from __future__ import annotations

import bisect
import math
from typing import Any

import numpy as np

from probing.sim.surfaces import Surface

__all__ = ["SurfaceDrive", "calibrate"]


class SurfaceDrive:
    """One surface of a trimmed plant, driven by its position: the model's command-to-position
    map, measured on the model's own flight-control system and inverted.

    The stock models map the (normalised) command to the surface through piecewise-linear
    components (clip, zero-centred aerosurface_scale, possibly asymmetric, a trim added);
    sampled at their breakpoints the map is exact between samples, so its inverse by linear
    interpolation is exact too.  Only the strictly monotonic part is kept (clipped ends are
    flat and cannot be inverted).

    Attributes
    ----------
    surface : Surface
        What is driven (:data:`probing.sim.surfaces.SURFACES`).
    trim_position : float
        The position at the trim, in the surface's unit.
    trim_command : float
        The normalised command at the trim.
    """

    def __init__(
        self,
        surface: Surface,
        nodes: list,
        pos_node: object,
        trim_position: float,
        trim_command: float,
        map_cmd: np.ndarray,
        map_pos: np.ndarray,
    ) -> None:
        self.surface = surface
        self.nodes = nodes
        self.pos_node = pos_node
        self.trim_position = trim_position
        self.trim_command = trim_command
        self.map_cmd, self.map_pos = map_cmd, map_pos  # sorted by position
        self._cmd_list, self._pos_list = map_cmd.tolist(), map_pos.tolist()
        order = np.argsort(map_cmd)
        self._cmd_sorted, self._pos_by_cmd = map_cmd[order], map_pos[order]
        self._by_cmd = (self._cmd_sorted.tolist(), self._pos_by_cmd.tolist())
        if len(nodes) == 1:
            self.set = nodes[0].set_double_value  # the one write of a step
        else:
            setters = [n.set_double_value for n in nodes]

            def set_all(value: float) -> None:
                for write in setters:
                    write(value)

            self.set = set_all

    @property
    def range(self) -> tuple[float, float]:
        """Positions reachable through the command (the surface's unit)."""
        return float(self.map_pos[0]), float(self.map_pos[-1])

    def command(self, position: np.ndarray) -> np.ndarray:
        """Normalised commands that put the surface exactly at ``position`` (its unit).

        Raises
        ------
        ValueError
            If a position is outside :attr:`range`.
        """
        position = np.asarray(position, dtype=np.float64)
        lo, hi = self.range
        if position.size and (position.min() < lo or position.max() > hi):
            what = "deflection" if self.surface.unit == "deg" else "position"
            raise ValueError(
                f"{self.surface.name} {what} {position.min():.6g}..{position.max():.6g} "
                f"{self.surface.unit} is outside the model's range {lo:.6g}..{hi:.6g} "
                f"{self.surface.unit}"
            )
        return np.interp(position, self.map_pos, self.map_cmd)

    def command_clipped(self, position: float) -> float:
        """The normalised command for one ``position``, clipped to the range: the same map
        and the same bits as :meth:`command` (``numpy.interp``'s own formula), for a loop
        that computes its command one step at a time."""
        return _interp_clipped(position, self._pos_list, self._cmd_list)

    def position_of(self, command: float) -> float:
        """The position the model gives a normalised ``command`` (the forward map; beyond the
        invertible part, the position at its end), for a loop that commands the surface
        one step at a time in normalised units."""
        return _interp_clipped(command, *self._by_cmd)

    def gain_per_norm(self) -> float:
        """Local slope d(position)/d(command) at the trimmed command (unit per unit command)."""
        cmd, pos = self._cmd_sorted, self._pos_by_cmd  # the map is kept sorted by position
        i = int(np.clip(np.searchsorted(cmd, self.trim_command), 1, cmd.size - 1))
        return float((pos[i] - pos[i - 1]) / (cmd[i] - cmd[i - 1]))


def _interp_clipped(x: float, xs: list[float], ys: list[float]) -> float:
    """Piecewise-linear ``ys`` over increasing ``xs`` at one ``x``, clipped to the ends:
    ``numpy.interp``'s own formula, for one value at a time without building an array."""
    s = min(max(x, xs[0]), xs[-1])
    if s == xs[-1]:
        return ys[-1]
    j = bisect.bisect_right(xs, s) - 1  # xs[j] <= s < xs[j + 1]
    slope = (ys[j + 1] - ys[j]) / (xs[j + 1] - xs[j])
    return slope * (s - xs[j]) + ys[j]


def calibrate(fdm: Any, surface: Surface, nodes: list, pos_node: Any, model: str) -> SurfaceDrive:
    """Measure ``surface``'s command -> position on the model's own FCS (see
    :class:`SurfaceDrive`): its command nodes and position node, on the trimmed ``fdm`` of
    ``model``; the FCS is evaluated with integration suspended, and left as it was."""
    pm = fdm.get_property_manager()
    cmd0 = nodes[0].get_double_value()
    pos0 = pos_node.get_double_value()
    lo, hi = surface.command_range
    grid = np.linspace(lo, hi, 401)
    kinks = [cmd0]
    if surface.trim_command is not None and pm.hasNode(surface.trim_command):
        trim = float(fdm[surface.trim_command])
        kinks = [-trim, 1.0 - trim, -1.0 - trim, cmd0]
    kinks = np.array(kinks)
    grid = np.unique(np.concatenate((grid, kinks[(kinks >= lo) & (kinks <= hi)])))
    setters = [n.set_double_value for n in nodes]
    get_pos, run = pos_node.get_double_value, fdm.run

    def position_at(cmd: float) -> float:
        for write in setters:
            write(cmd)
        run()  # integration suspended: evaluates the FCS only
        return get_pos()

    time0 = fdm.get_sim_time()
    fdm.suspend_integration()
    try:
        position = np.array([position_at(c) for c in grid])
        back = position_at(cmd0)
    finally:
        fdm.resume_integration()
        fdm.set_sim_time(time0)
    if not math.isclose(back, pos0, rel_tol=0, abs_tol=1e-12):
        raise RuntimeError(f"{surface.name} calibration changed the trimmed position")
    if position[-1] < position[0]:
        grid, position = grid[::-1], position[::-1]
    keep = np.concatenate(([True], np.diff(position) > 0))
    if keep.sum() < 2:
        raise ValueError(f"no command moves the {surface.name} of {model}")
    return SurfaceDrive(surface, nodes, pos_node, pos0, cmd0, grid[keep], position[keep])
