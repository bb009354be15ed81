"""Aircraft lookup, content digests and sanitised copies: files only, no JSBSim loaded.

An aircraft is a folder of the user's given by its path, or a name found in the project's
``aircraft/`` first, then among JSBSim's stock models (located through the installed
package's folder, without importing it).  The plant loads a
*sanitised* copy (every top-level ``<input>`` and ``<output>`` directive removed, so no model
opens a network socket or writes a log file of its own) kept in the cache.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.util
import math
import os
import shutil
import tempfile
import xml.etree.ElementTree as ET
from importlib import metadata
from pathlib import Path

from probing.core.tempfiles import nearest_existing, write_refusal
from probing.data import AIRCRAFT
from probing.sim.errors import AircraftNotFoundError, CacheFolderError

__all__ = [
    "GUST_AXES",
    "GUST_INPUTS",
    "PROJECT_AIRCRAFT",
    "ROLL_OBSERVER_GAIN_PER_S",
    "aircraft_digest",
    "aircraft_name",
    "alpha_range_rad",
    "cache_dir",
    "discard_sanitised",
    "find_aircraft",
    "is_path",
    "jsbsim_version",
    "model_file",
    "not_loaded",
    "sanitised_root",
    "stock_root",
    "usable_folder",
]

PROJECT_AIRCRAFT = AIRCRAFT


@functools.cache
def jsbsim_version() -> str:
    """The version of the installed JSBSim Python package (read from its metadata once per
    process: the library a process has loaded does not change under it)."""
    return metadata.version("jsbsim")


@functools.cache
def stock_root() -> Path:
    """JSBSim's own data folder (``aircraft/``, ``engine/``, ``systems/``), found without
    importing jsbsim: it is the installed package's folder."""
    spec = importlib.util.find_spec("jsbsim")
    if spec is None or not spec.submodule_search_locations:
        raise AircraftNotFoundError("the jsbsim package is not installed")
    return Path(next(iter(spec.submodule_search_locations)))


def is_path(model: str) -> bool:
    """True if ``aircraft.model`` names a folder by its path rather than by a plain name."""
    return "/" in model or os.sep in model or model in (".", "..") or model.startswith("~")


def aircraft_name(model: str) -> str:
    """The name JSBSim loads the aircraft by: the folder's own name (``<name>/<name>.xml``)."""
    return Path(model).name if is_path(model) else model


def find_aircraft(model: str) -> Path:
    """Folder of an aircraft: a folder given by its path, else a plain name looked up in the
    project's ``aircraft/`` first, then among JSBSim's stock models.

    Parameters
    ----------
    model : str
        Aircraft name, a plain folder name (e.g. ``"737"``), or the absolute path of a JSBSim
        aircraft folder ``<name>`` holding ``<name>.xml`` (a scenario file resolves a
        relative one against its own folder).

    Returns
    -------
    pathlib.Path
        The folder holding ``<name>.xml``.

    Raises
    ------
    AircraftNotFoundError
        For a name found nowhere, or a path that is not an aircraft folder.
    """
    if is_path(model):
        return _user_folder(Path(model))
    if not model or model.startswith("."):
        raise AircraftNotFoundError(f"aircraft.model must be a name or a path, got {model!r}")
    for base in (PROJECT_AIRCRAFT, stock_root() / "aircraft"):
        folder = base / model
        if (folder / f"{model}.xml").is_file():
            return folder
    raise AircraftNotFoundError(
        f"aircraft.model {model!r} is not in {PROJECT_AIRCRAFT} nor in JSBSim's aircraft"
        f" (a folder of your own: give its path, e.g. './{model}')"
    )


def _user_folder(folder: Path) -> Path:
    """A user's aircraft folder, checked: absolute, holding ``<name>.xml``, a JSBSim model."""
    if not folder.is_absolute():
        raise AircraftNotFoundError(f"aircraft.model {str(folder)!r}: the path must be absolute")
    main = folder / f"{folder.name}.xml"
    if not main.is_file():
        raise AircraftNotFoundError(
            f"aircraft.model {str(folder)!r} is not a JSBSim aircraft folder"
            f" (no {folder.name}.xml in it)"
        )
    try:
        tag = ET.parse(main).getroot().tag
    except (ET.ParseError, OSError) as exc:
        raise AircraftNotFoundError(
            f"aircraft.model {str(folder)!r}: {main.name} cannot be read ({exc})"
        ) from None
    if tag != "fdm_config":
        raise AircraftNotFoundError(
            f"aircraft.model {str(folder)!r}: {main.name} is not a JSBSim aircraft"
            f" (<{tag}>, not <fdm_config>)"
        )
    return folder


def cache_dir() -> Path:
    """The project's cache root: ``$PROBING_CACHE``, else ``$XDG_CACHE_HOME/probing``.

    ``$XDG_CACHE_HOME`` defaults to ``~/.cache``.  Sanitised aircraft live in
    ``<root>/jsbsim-root``, reference twins (:mod:`probing.sim.twins`) in ``<root>/twins``.
    """
    env = os.environ.get("PROBING_CACHE")
    if env:
        return usable_folder(Path(env), "$PROBING_CACHE")
    root = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "probing"
    return usable_folder(root, "cache folder")


def usable_folder(path: Path, source: str) -> Path:
    """``path``, a cache folder that is a folder we can write in, or can be made one: the
    nearest of it and its parents that exists is a folder that takes something new
    (:func:`probing.core.tempfiles.write_refusal`: tried, not read off its permissions).

    The one check of where a cache lives (:func:`cache_dir`,
    :func:`probing.sim.twins.twin_cache_dir`); ``source`` names where the path came from
    (``$PROBING_CACHE``, say) for the message.

    Raises
    ------
    CacheFolderError
        If ``path``, or the part of it that exists, is a file (or anything but a folder), or
        a folder in which nothing can be made (no write permission, ``/proc``).
    """
    there = nearest_existing(path)
    if not there.is_dir():
        what = "" if there == path else f" ({there} is not a folder)"
        raise CacheFolderError(f"{source} {path} is not a folder{what}")
    reason = write_refusal(there)
    if reason is not None:
        raise CacheFolderError(
            f"{source} {path} cannot be used: cannot write in {there} ({reason})"
        )
    return path


def _sanitise(xml_path: Path, out_path: Path) -> None:
    """Copy an aircraft XML without its top-level <input>/<output> directives."""
    parser = ET.XMLParser(target=ET.TreeBuilder(insert_comments=True))
    tree = ET.parse(xml_path, parser=parser)
    root = tree.getroot()
    for element in list(root):
        if element.tag in ("input", "output"):
            root.remove(element)
    tree.write(out_path, encoding="utf-8", xml_declaration=True)


#: aircraft folder -> (names, sizes and modification times of its files, their digest)
_DIGESTS: dict[Path, tuple[tuple, str]] = {}


def aircraft_digest(model: str) -> str:
    """SHA-256 (hex) over the relative names and contents of every file of the aircraft folder.

    The folder is the one :func:`find_aircraft` picks, i.e. the files the plant loads
    (before sanitising).  Engines and systems taken from JSBSim's own folders are covered
    by the JSBSim version, not by this digest.  The digest is remembered for the process
    while no file's name, size or modification time changes.
    """
    folder = find_aircraft(model)
    files = sorted(p for p in folder.rglob("*") if p.is_file())
    stamp = tuple((str(p.relative_to(folder)), *_size_mtime(p)) for p in files)
    known = _DIGESTS.get(folder)
    if known is not None and known[0] == stamp:
        return known[1]
    digest = hashlib.sha256()
    for path in files:
        digest.update(str(path.relative_to(folder)).encode())
        digest.update(path.read_bytes())
    _DIGESTS[folder] = (stamp, digest.hexdigest())
    return digest.hexdigest()


def _size_mtime(path: Path) -> tuple[int, int]:
    st = path.stat()
    return st.st_size, st.st_mtime_ns


#: The body rates the aerodynamics see (JSBSim's ``velocities/<x>-aero-rad_sec``, the rate
#: minus the atmosphere's rotational turbulence); a gust-ready copy replaces each reference
#: to them with ``probing/gust/<x>-aero-rad_sec``.
GUST_AXES = ("p", "q", "r")

#: The properties a gust-ready copy reads each step: the estimated wind's rotational part
#: (body axes, rad/s), the measured roll rate its roll-gust observer tracks (rad/s), and the
#: observer's switch (1: on).
GUST_INPUTS = {
    **{f"{a}_gust_rad_s": f"probing/gust/{a}-rad_sec" for a in GUST_AXES},
    "p_measured_rad_s": "probing/gust/p-measured-rad_sec",
    "phi_measured_rad": "probing/gust/phi-measured-rad",
    "observer_on": "probing/gust/observer-on",
}

#: Bumped whenever the gust-ready copy's rewrite changes (its cached folder is named with it).
GUST_ROOT_VERSION = 3

#: The roll-gust observer's gain, 1/s: the roll gust it infers moves at this rate per rad/s of
#: roll-rate difference between the model and the measured aircraft (time constant 1/30 s,
#: 3.3 steps at 0.01 s).  The MIL-F-8785C roll gust is fast (its time constant L_p / V is
#: 0.2 s for the GTM at 800 ft): at 10/s the observer lagged it, and the gust reference's
#: per-period scatter in moderate turbulence was 1.46 times what it is at 30/s
#: (three seeds, 100 periods each; docs/monitoring.md).
ROLL_OBSERVER_GAIN_PER_S = 30.0

#: The weight of the bank-angle difference in the observer's error, rad/s per rad: the model
#: tracks the measured bank angle too, so a roll gyro's bias cannot wind it into a spiral.
ROLL_OBSERVER_BANK_RAD_S = 1.0


def sanitised_root(model: str, *, gust_inputs: bool = False) -> Path:
    """A JSBSim root folder holding a sanitised copy of the aircraft (cached, made atomically).

    Parameters
    ----------
    model : str
        Aircraft name (:func:`find_aircraft`).
    gust_inputs : bool
        Make the copy *gust-ready*: the aerodynamics see the body rates minus rotational gusts
        set from outside (:data:`GUST_INPUTS`) besides JSBSim's own turbulence, and a roll-gust
        observer (a JSBSim ``<integrator>``, gain :data:`ROLL_OBSERVER_GAIN_PER_S`) drives the
        model's roll rate towards ``probing/gust/p-measured-rad_sec`` while that is set.  With
        every input at 0 and the observer's measured rate equal to the model's, the copy
        steps exactly as the plain one (``difference(x, 0)`` is ``x``).  The flight
        computer's gust twin (``drift = "gust"``) flies it.
    """
    folder = find_aircraft(model)
    name = aircraft_name(model)
    flavour = f"-gust{GUST_ROOT_VERSION}" if gust_inputs else ""
    root = cache_dir() / "jsbsim-root" / f"{name}{flavour}-{aircraft_digest(model)[:16]}"
    if model_file(root, model).is_file():
        return root
    root.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{name}-", dir=root.parent))
    try:
        target = tmp / "aircraft" / name
        shutil.copytree(folder, target)
        for xml in target.rglob("*.xml"):
            _sanitise(xml, xml)
        if gust_inputs:
            _add_gust_inputs(target / f"{name}.xml")
        os.replace(tmp, root)
    except OSError:
        shutil.rmtree(tmp, ignore_errors=True)
        if not model_file(root, model).is_file():
            raise
    return root


def not_loaded(model: str, root: Path, log: str) -> str:
    """Why JSBSim could not load the aircraft, in one line: its own messages ``log`` (they
    name a missing file), with the cached copy's folder named as the aircraft's own; the
    copy is removed from the cache (:func:`discard_sanitised`), so the folder's next load
    starts afresh."""
    copy = str(model_file(root, model).parent)
    why = log.replace(copy, str(find_aircraft(model)))
    discard_sanitised(root)
    return f"JSBSim could not load aircraft {model!r}" + (f": {why}" if why else "")


def discard_sanitised(root: Path) -> None:
    """Remove a copy made by :func:`sanitised_root` that JSBSim could not load: renamed out of
    the cache's names first (a temporary beside it), so no process finds it half-removed."""
    tmp = root.parent / f".{root.name}-discarded-{os.getpid()}"
    try:
        os.replace(root, tmp)
    except OSError:
        return  # gone already (another process discarded it)
    shutil.rmtree(tmp, ignore_errors=True)


def model_file(root: Path, model: str) -> Path:
    """The aircraft's main file in a JSBSim root made by :func:`sanitised_root`."""
    name = aircraft_name(model)
    return root / "aircraft" / name / f"{name}.xml"


def _add_gust_inputs(xml_path: Path) -> None:
    """Make an aircraft file gust-ready (:func:`sanitised_root`): its aerodynamics read
    ``probing/gust/<x>-aero-rad_sec`` = JSBSim's aero rate - the set gust - the observer's
    roll gust's component on that axis (:func:`_observed_roll_gust`), computed as the
    aerodynamics' first functions, so after JSBSim's own."""
    parser = ET.XMLParser(target=ET.TreeBuilder(insert_comments=True))
    tree = ET.parse(xml_path, parser=parser)
    root = tree.getroot()
    aero = root.find("aerodynamics")
    if aero is None or aero.get("file"):
        raise AircraftNotFoundError(
            f"{xml_path.name}: a gust twin needs the <aerodynamics> inside the aircraft file"
        )
    for element in aero.iter():
        if element.tag == "property" and element.text:
            name = element.text.strip()
            for a in GUST_AXES:
                if name == f"velocities/{a}-aero-rad_sec":
                    element.text = f"probing/gust/{a}-aero-rad_sec"
    head: list[ET.Element] = []
    for prop in GUST_INPUTS.values():
        declared = ET.Element("property", value="0")
        declared.text = prop
        head.append(declared)
    for a in GUST_AXES:
        function = ET.Element("function", name=f"probing/gust/{a}-aero-rad_sec")
        difference = ET.SubElement(function, "difference")
        for term in (f"velocities/{a}-aero-rad_sec", f"probing/gust/{a}-rad_sec"):
            ET.SubElement(difference, "property").text = term
        difference.append(_observed_roll_gust(a))
        head.append(function)
    for i, element in enumerate(head):
        aero.insert(i, element)
    root.append(_roll_observer())
    tree.write(xml_path, encoding="utf-8", xml_declaration=True)


def _trig(kind: str, angle: str) -> ET.Element:
    """``<cos>`` or ``<sin>`` of an Euler angle of the model (``phi``, ``theta``, ``psi``)."""
    element = ET.Element(kind)
    ET.SubElement(element, "property").text = f"attitude/{angle}-rad"
    return element


def _product(*factors: ET.Element | str) -> ET.Element:
    """``<product>`` of elements, or of properties named by a string."""
    product = ET.Element("product")
    for factor in factors:
        if isinstance(factor, str):
            ET.SubElement(product, "property").text = factor
        else:
            product.append(factor)
    return product


def _observed_roll_gust(axis: str) -> ET.Element:
    """The observer's roll gust on body ``axis``: the MIL-F-8785C roll gust lies along the
    turbulence's own axes (north: JSBSim orients them by the mean wind's azimuth, 0 in a
    calm mean wind), so its body components are those of the local north, the first column
    of the local-to-body matrix: (cos th cos psi, sin ph sin th cos psi - cos ph sin psi,
    cos ph sin th cos psi + sin ph sin psi)."""
    observed = "probing/gust/p-observed-rad_sec"
    if axis == "p":
        return _product(observed, _trig("cos", "theta"), _trig("cos", "psi"))
    first, second = ("sin", "cos") if axis == "q" else ("cos", "sin")
    direction = ET.Element("difference" if axis == "q" else "sum")
    direction.append(_product(_trig(first, "phi"), _trig("sin", "theta"), _trig("cos", "psi")))
    direction.append(_product(_trig(second, "phi"), _trig("sin", "psi")))
    return _product(observed, direction)


def _roll_observer() -> ET.Element:
    """The roll-gust observer's system: integrate the model's roll rate minus the measured
    one, plus :data:`ROLL_OBSERVER_BANK_RAD_S` times its bank angle minus the measured one,
    while ``probing/gust/observer-on`` is 1 (off, so not integrating, by default)."""
    system = ET.Element("system", name="probing gust observer")
    channel = ET.SubElement(system, "channel", name="roll gust")
    error = ET.SubElement(channel, "fcs_function", name="probing/gust/p-error-rad_sec")
    function = ET.SubElement(error, "function")
    total = ET.SubElement(function, "sum")
    rate = ET.SubElement(total, "difference")
    ET.SubElement(rate, "property").text = "velocities/p-rad_sec"
    ET.SubElement(rate, "property").text = "probing/gust/p-measured-rad_sec"
    bank = ET.SubElement(total, "product")
    ET.SubElement(bank, "value").text = repr(ROLL_OBSERVER_BANK_RAD_S)
    angle = ET.SubElement(bank, "difference")
    ET.SubElement(angle, "property").text = "attitude/phi-rad"
    ET.SubElement(angle, "property").text = "probing/gust/phi-measured-rad"
    gate = ET.SubElement(channel, "switch", name="probing/gust/p-error-gated-rad_sec")
    ET.SubElement(gate, "default", value="0")
    test = ET.SubElement(gate, "test", value="probing/gust/p-error-rad_sec")
    test.text = "probing/gust/observer-on EQ 1"
    integrator = ET.SubElement(channel, "integrator", name="probing/gust/p-observed-rad_sec")
    ET.SubElement(integrator, "input").text = "probing/gust/p-error-gated-rad_sec"
    # d(observed gust)/dt = -gain * (model's rate - measured): a roll gust the model lacks
    # makes it roll less than the aircraft (aero roll rate p - gust), so the gust grows
    ET.SubElement(integrator, "c1").text = repr(-ROLL_OBSERVER_GAIN_PER_S)
    return system


@functools.lru_cache(maxsize=32)
def alpha_range_rad(xml_path: Path) -> tuple[float, float]:
    """Alpha range covered by every aerodynamic table indexed by alpha (rad).

    Memoised: the sanitised copy lives in a folder named after the aircraft's digest, so a
    path always holds the same content.
    """
    lo, hi = -math.inf, math.inf
    root = ET.parse(xml_path).getroot()
    aero = root.find("aerodynamics")
    if aero is None:
        return (-math.radians(30), math.radians(30))
    for table in aero.iter("table"):
        variables = table.findall("independentVar")
        row = [v for v in variables if v.get("lookup", "row") == "row"]
        if not row or row[0].text is None:
            continue
        name = row[0].text.strip()
        if name not in ("aero/alpha-rad", "aero/alpha-deg"):
            continue
        data = table.find("tableData")
        if data is None or data.text is None:
            continue
        lines = [ln.split() for ln in data.text.strip().splitlines() if ln.strip()]
        if len(variables) > 1:
            lines = lines[1:]  # first line holds the column breakpoints
        keys = [float(ln[0]) for ln in lines if ln]
        if not keys:
            continue
        scale = math.pi / 180 if name.endswith("deg") else 1.0
        lo, hi = max(lo, min(keys) * scale), min(hi, max(keys) * scale)
    if not (math.isfinite(lo) and math.isfinite(hi)) or lo >= hi:
        return (-math.radians(30), math.radians(30))
    return (lo, hi)
