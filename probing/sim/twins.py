"""The unprobed reference twin, shared between runs through a content-addressed cache.

With ``drift = "reference"`` a run subtracts the outputs of an unprobed twin of the
trimmed aircraft (``docs/method.md``).  The twin's outputs depend only on the aircraft, its
trim condition, the step, the run length, the disturbances and the output channels, not on
the probe, the nonlinearity or the sensor noise, so scenarios that differ only in those
share one twin: it is simulated once and read back afterwards, and a sweep over
nonlinearity parameters costs about one simulation per point instead of two.

Cache layout (see ``docs/method.md``, "Reference-twin cache"): one ``<key>.npy`` file
(float64, ``(total_steps, n_channels)``) per twin in :func:`twin_cache_dir`, where ``key``
is :func:`twin_key`, the SHA-256 of :func:`twin_spec`.  A simulated twin is written
progressively to a temporary file unique to the process and thread and renamed into place
only after the last step succeeded, so a failed or diverged run leaves no entry, and
processes computing the same twin concurrently each write their own file; the last rename
wins, with identical content.  The temporary's name carries its writer's process id and
host (:mod:`probing.core.tempfiles`): one a killed run left is removed by the next run that
simulates a twin, once that process no longer exists.  Entries are read back one period at a time.
Nothing is ever evicted: delete the folder to reclaim the space.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import threading
import uuid
from collections.abc import Sequence
from pathlib import Path
from types import TracebackType
from typing import Any, BinaryIO

import numpy as np

from probing.core.tempfiles import remove_dead_writers_files, writer_tag
from probing.sim import aircraft as _aircraft_module
from probing.sim import autopilot as _autopilot_module
from probing.sim import channels as _channels_module
from probing.sim import control as _control_module
from probing.sim import drive as _drive_module
from probing.sim import plant as _plant_module
from probing.sim import turn_trim as _turn_trim_module
from probing.sim import world as _world_module
from probing.sim.aircraft import cache_dir, usable_folder
from probing.sim.control import ClosedLoop, control_power
from probing.sim.flight import Flight
from probing.sim.fork import trim_spec
from probing.sim.plant import Plant, make_plant
from probing.sim.surfaces import DEFAULT_SURFACE
from probing.sim.world import JSBSimWorld

__all__ = [
    "TWIN_FORMAT",
    "ReferenceTwin",
    "open_twin",
    "store_twin",
    "twin_cache_dir",
    "twin_key",
    "twin_spec",
    "twin_stored",
]

#: Version of the stored layout and of what a twin is; part of every key.
TWIN_FORMAT = 1


def twin_cache_dir() -> Path:
    """Folder of the twin cache: ``$PROBING_TWIN_CACHE``, else ``<cache root>/twins``.

    The cache root is :func:`probing.sim.aircraft.cache_dir` (``$PROBING_CACHE`` or
    ``~/.cache/probing``).
    """
    env = os.environ.get("PROBING_TWIN_CACHE")
    if env:
        return usable_folder(Path(env), "$PROBING_TWIN_CACHE")
    return usable_folder(cache_dir() / "twins", "cache folder")


@functools.cache
def _source_digest() -> str:
    """SHA-256 of the code that defines the twin's numbers: the plant (trim, stepping), the
    aircraft's sanitising, the channel table, the surface drive, the turn trim, the autopilot,
    the stepping function and this module."""
    digest = hashlib.sha256()
    modules = (
        _aircraft_module,
        _channels_module,
        _plant_module,
        _drive_module,
        _turn_trim_module,
        _control_module,
        _autopilot_module,
        _world_module,
    )
    for path in (*(Path(m.__file__) for m in modules), Path(__file__)):
        digest.update(path.name.encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def twin_spec(flight: Flight, channels: Sequence[str], steps: int) -> dict[str, Any]:
    """Everything that determines the twin's outputs, as plain JSON-able values.

    Parameters
    ----------
    flight : Flight
        Aircraft, trim condition, step, turbulence and seed.
    channels : sequence of str
        Output channels, in order.
    steps : int
        Steps of the whole run.

    Returns
    -------
    dict
        Model name and digest of its files, trim condition (ft; kt or Mach), dt (s), total
        step count, turbulence level, seed, channels in order, JSBSim version, digest of
        the twin's source code and :data:`TWIN_FORMAT`.  Probe, nonlinearity, sensor noise
        and everything else of a scenario do not enter.
    """
    return {
        "format": TWIN_FORMAT,
        **trim_spec(flight),
        "steps": int(steps),
        "turbulence": flight.turbulence,
        "seed": int(flight.seed),
        # a damage case switched on in flight (the twin flies it too); absent when none
        **(
            {"fault": {"case": flight.damage_case, "onset_s": float(flight.damage_onset_s)}}
            if flight.damage_onset_s is not None
            else {}
        ),
        # the autopilot the twin flies with (absent in open loop), and the surface whose
        # command it passes through the probe path (absent for the elevator)
        **({"control": flight.control.to_dict()} if flight.closed_loop else {}),
        **(
            {"surface": flight.surface}
            if flight.closed_loop and flight.surface != DEFAULT_SURFACE
            else {}
        ),
        "channels": list(channels),
        "source_sha256": _source_digest(),
    }


def twin_key(flight: Flight, channels: Sequence[str], steps: int) -> str:
    """SHA-256 (hex) of the canonical JSON of :func:`twin_spec`: the twin's cache key."""
    text = json.dumps(twin_spec(flight, channels, steps), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


_DTYPE = np.dtype("<f8")


def _open_entry(path: Path, steps: int, n_channels: int) -> BinaryIO | None:
    """The stored entry at ``path``, positioned after its header, if it is complete and fits."""
    try:
        fp = open(path, "rb")  # closed by the caller
    except OSError:
        return None
    try:
        version = np.lib.format.read_magic(fp)
        read_header = {
            (1, 0): np.lib.format.read_array_header_1_0,
            (2, 0): np.lib.format.read_array_header_2_0,
        }[version]
        shape, fortran_order, dtype = read_header(fp)
        size = os.fstat(fp.fileno()).st_size
        if (
            dtype == _DTYPE
            and not fortran_order
            and shape == (steps, n_channels)
            and size == fp.tell() + steps * n_channels * _DTYPE.itemsize
        ):
            return fp
    except (KeyError, OSError, ValueError):
        pass
    fp.close()
    return None


class ReferenceTwin:
    """The unprobed twin's outputs, handed out period by period; use :func:`open_twin`.

    The entry is read and written sequentially through a plain file (no memory map), so
    the memory a run needs does not grow with its length.

    Attributes
    ----------
    key : str
        The cache key (:func:`twin_key`).
    cached : bool
        True if the outputs are read from the cache (nothing is simulated).
    steps_simulated : int
        JSBSim steps simulated so far by the twin (0 on a cache hit).
    path : pathlib.Path
        The cache entry (present only once a simulated twin completed, or on a hit).
    """

    def __init__(
        self,
        flight: Flight,
        channels: Sequence[str],
        steps: int,
        *,
        use_cache: bool,
        plant: Plant | None = None,
    ) -> None:
        self.key = twin_key(flight, channels, steps)
        self.total_steps = int(steps)
        self.n_channels = len(channels)
        self.cached = False
        self.steps_simulated = 0
        self.path = twin_cache_dir() / f"{self.key}.npy"
        self._next = 0
        self._reader: BinaryIO | None = None  # a stored entry, positioned at step _next
        self._writer: BinaryIO | None = None  # the temporary file of a new entry
        self._tmp: Path | None = None
        self._plant: Plant | None = None
        self._loop: ClosedLoop | None = None
        self._nodes: list = []
        if use_cache:
            self._reader = _open_entry(self.path, self.total_steps, self.n_channels)
            self.cached = self._reader is not None
            if not self.cached:
                self._open_temporary()
        if not self.cached:
            try:
                power = control_power(flight) if flight.closed_loop else None
                self._plant = plant if plant is not None else make_plant(flight)
                self._nodes = self._plant.channel_nodes(list(channels))
                if power is not None:
                    self._loop = ClosedLoop(
                        self._plant, flight.control, power, surface=flight.surface
                    )
            except BaseException:
                self.close(success=False)
                raise

    def _open_temporary(self) -> None:
        """Start a new entry under a name unique to this process and thread (if writable)."""
        token = f"{writer_tag()}.{threading.get_ident()}.{uuid.uuid4().hex[:8]}"
        tmp = self.path.with_name(f".{self.key}.{token}.tmp.npy")
        header = {
            "descr": np.lib.format.dtype_to_descr(_DTYPE),
            "fortran_order": False,
            "shape": (self.total_steps, self.n_channels),
        }
        try:
            tmp.parent.mkdir(parents=True, exist_ok=True)
            remove_dead_writers_files(tmp.parent, ".tmp.npy")  # left by killed runs
            fp = open(tmp, "wb")  # closed in close()
        except OSError:  # a read-only cache: simulate without storing
            return
        self._writer, self._tmp = fp, tmp
        try:
            np.lib.format.write_array_header_1_0(fp, header)
        except OSError:
            self._drop_temporary()

    def _drop_temporary(self) -> None:
        writer, self._writer = self._writer, None
        tmp, self._tmp = self._tmp, None
        if writer is not None:
            try:
                writer.close()
            except OSError:
                pass
        if tmp is not None:
            tmp.unlink(missing_ok=True)

    def next(self, n: int) -> np.ndarray:
        """The twin's outputs for the next ``n`` steps, shape ``(n, n_channels)`` (a new array).

        Simulated twins check their state after the block and raise
        :class:`probing.sim.errors.DivergenceError` when they leave the meaningful region.
        """
        stop = self._next + n
        if stop > self.total_steps:
            raise ValueError(f"the twin has {self.total_steps} steps, asked for {stop}")
        block = np.empty((n, self.n_channels), dtype=_DTYPE)
        if self._reader is not None:
            got = self._reader.readinto(memoryview(block).cast("B"))
            if got != block.nbytes:
                raise OSError(f"{self.path}: truncated at step {self._next}")
        else:
            assert self._plant is not None
            world = self._loop.world if self._loop is not None else JSBSimWorld(self._plant)
            autopilot = self._loop.autopilot if self._loop is not None else None
            world.fly_probe(autopilot, None, self._nodes, block)
            self._plant.check_state()
            self.steps_simulated += n
            if self._writer is not None:
                try:
                    self._writer.write(memoryview(block).cast("B"))
                except OSError:  # disk full: finish the run, store nothing
                    self._drop_temporary()
        self._next = stop
        return block

    def close(self, success: bool) -> None:
        """Store a complete simulated twin (if ``success``), drop an incomplete one.

        A failure to store (disk full, ...) only means that the next run simulates again.
        """
        self._plant = self._loop = None
        if self._reader is not None:
            self._reader.close()
            self._reader = None
        if self._writer is None or self._tmp is None:
            return
        if success and self._next == self.total_steps:
            try:
                self._writer.close()
                os.replace(self._tmp, self.path)
            except OSError:
                pass
        self._drop_temporary()  # after a rename: nothing left to remove

    def __enter__(self) -> ReferenceTwin:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close(success=exc_type is None)


def open_twin(
    flight: Flight,
    channels: Sequence[str],
    steps: int,
    *,
    use_cache: bool = True,
    plant: Plant | None = None,
) -> ReferenceTwin:
    """The reference twin of a flight: read from the cache, or simulated (and stored).

    Parameters
    ----------
    flight : Flight
        Aircraft, trim condition, step, turbulence and seed.
    channels : sequence of str
        Output channels, in order.
    steps : int
        Steps of the whole run.
    use_cache : bool
        Read a stored twin when there is one, and store a simulated one; False simulates
        and stores nothing.
    plant : Plant, optional
        The trimmed and disturbed aircraft to simulate the twin with, if it is not read
        from the cache (default: :func:`~probing.sim.plant.make_plant` of ``flight``); it
        is stepped, so use it for nothing else.

    Returns
    -------
    ReferenceTwin
        A context manager: on a clean exit after all ``steps`` steps a simulated twin is
        stored; on an exception (or if fewer steps were taken) it is dropped.
    """
    return ReferenceTwin(flight, channels, steps, use_cache=use_cache, plant=plant)


def twin_stored(flight: Flight, channels: Sequence[str], steps: int) -> bool:
    """True if the cache holds this twin, complete (it would be read, not simulated)."""
    path = twin_cache_dir() / f"{twin_key(flight, channels, steps)}.npy"
    entry = _open_entry(path, int(steps), len(channels))
    if entry is None:
        return False
    entry.close()
    return True


def store_twin(
    flight: Flight, channels: Sequence[str], steps: int, block_steps: int, plant: Plant
) -> None:
    """Simulate the twin with ``plant`` (trimmed and disturbed) and store it in the cache.

    It is stepped ``block_steps`` at a time, its state checked after each block, as a run
    steps it period by period, so it diverges (and is not stored) exactly where a run's
    twin would.

    Raises
    ------
    probing.sim.errors.DivergenceError
        If the twin leaves the meaningful region; nothing is stored.
    """
    with open_twin(flight, channels, steps, plant=plant) as twin:
        if twin.cached:
            return
        for _ in range(steps // block_steps):
            twin.next(block_steps)
