"""The files a separate JSBSim process needs to fly a scenario for ``probing live``.

:func:`write_sim` writes a JSBSim root holding the scenario's aircraft as the project loads
it (the sanitised copy, :func:`probing.sim.aircraft.sanitised_root`) with an input socket
added (blocking: lock step), JSBSim's own engines and systems, an initialisation at the
scenario's condition and a script that trims there exactly as :class:`probing.sim.plant.Plant`
does (gear up, engines running, JSBSim's full trim) and then holds for the flight computer.
No JSBSim is loaded here: files only.
"""

from __future__ import annotations

import shlex
import shutil
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

from probing.sim.aircraft import sanitised_root, stock_root
from probing.sim.flight import Flight

__all__ = ["LISTENS_EVERYWHERE", "SCRIPT", "jsbsim_executable", "sim_command", "write_sim"]

#: The script's path inside the written root.
SCRIPT = "scripts/probing_live.xml"

#: The initialisation file's name in the aircraft's folder (without ``.xml``).
IC_NAME = "probing_live_ic"

#: What the simulator's socket admits (``{port}`` is its port).  JSBSim's TCP input socket
#: takes a port and no address: ``FGInputSocket::Load`` (``src/input_output/FGInputSocket.cpp``)
#: reads ``port`` and ``action`` only, and the server constructor ``FGfdmSocket(int port, int
#: protocol, int precision)`` in ``src/input_output/FGfdmSocket.cpp`` zeroes the address
#: (``memset(&scktName, 0, ...)``: ``INADDR_ANY``) and binds it; with JSBSim 1.3.3, ``ss -ltn``
#: shows ``0.0.0.0:PORT`` (docs/live.md).
LISTENS_EVERYWHERE = (
    "the simulator's input socket listens on every interface (0.0.0.0:{port}), not on "
    "loopback only: JSBSim's socket takes no address (src/input_output/FGfdmSocket.cpp binds "
    "INADDR_ANY); keep port {port} closed to other machines"
)

#: JSBSim's initialisation element for each speed kind (:data:`probing.sim.flight.SPEED_KINDS`).
_IC_SPEED = {
    "speed_kcas": ("vc", "KTS"),
    "speed_ktas": ("vt", "KTS"),
    "speed_keas": ("ve", "KTS"),
    "mach": ("mach", None),
}


def write_sim(flight: Flight, folder: Path, port: int, end_s: float) -> list[str]:
    """Write a JSBSim root for ``flight`` into ``folder`` and return the command that flies it.

    Parameters
    ----------
    flight : Flight
        The scenario's flight: model, condition, dt (trimmed undamaged: checked by the
        caller; its turbulence and a damage case in flight are written by the flight
        computer's side over the socket, :class:`probing.experiment.flight.live.SocketWorld`).
    folder : pathlib.Path
        The root to write (created; its ``aircraft``, ``engine``, ``systems`` and ``scripts``
        are replaced).
    port : int
        The TCP port of JSBSim's input socket.
    end_s : float
        Simulation time at which the script ends, s (the flight and a margin).

    Returns
    -------
    list of str
        The ``jsbsim`` command line (:func:`sim_command`), also written to
        ``folder/command.txt``.
    """
    folder.mkdir(parents=True, exist_ok=True)
    source = sanitised_root(flight.model) / "aircraft" / flight.model
    target = folder / "aircraft" / flight.model
    stock = stock_root()
    for name, src in (("engine", stock / "engine"), ("systems", stock / "systems")):
        shutil.rmtree(folder / name, ignore_errors=True)
        shutil.copytree(src, folder / name)
    shutil.rmtree(target, ignore_errors=True)
    shutil.copytree(source, target)
    _add_input_socket(target / f"{flight.model}.xml", port)
    _write_xml(target / f"{IC_NAME}.xml", _initialisation(flight))
    (folder / "scripts").mkdir(exist_ok=True)
    _write_xml(folder / SCRIPT, _script(flight, end_s))
    line = sim_command(folder, flight.dt_s)
    (folder / "command.txt").write_text(shlex.join(line) + "\n")
    return line


def jsbsim_executable() -> str:
    """The ``jsbsim`` executable JSBSim's Python package installs: beside the running Python
    (a virtual environment's ``bin``, which need not be on PATH), else the one on PATH, else
    the bare name."""
    beside = Path(sys.executable).parent / "jsbsim"
    if beside.is_file():
        return str(beside)
    return shutil.which("jsbsim") or "jsbsim"


def sim_command(folder: Path, dt_s: float) -> list[str]:
    """``/path/to/jsbsim --root=... --script=... --suspend`` (:func:`jsbsim_executable`):
    held after its trim, it waits for the flight computer (JSBSim's Python package's
    ``jsbsim`` polls its socket without sleeping while held: ``--nice`` would sleep 10 s
    between two looks).  Its ``--simulation-rate`` is the scenario's dt: that ``jsbsim``
    passes its own rate to the script, whose ``dt`` it overrides."""
    return [
        jsbsim_executable(),
        f"--root={folder.resolve()}",
        f"--script={SCRIPT}",
        f"--simulation-rate={dt_s!r}",
        "--suspend",
    ]


def _add_input_socket(xml_path: Path, port: int) -> None:
    """Add ``<input type="SOCKET" port=... protocol="TCP" action="BLOCKING_INPUT"/>`` to an
    aircraft file: once a client is connected, every frame waits for its message (lock
    step; ``iterate`` would run the flight-control system, engines and aerodynamics once
    more before each frame, so a command would act a frame early and the actuators would
    step twice per frame)."""
    parser = ET.XMLParser(target=ET.TreeBuilder(insert_comments=True))
    tree = ET.parse(xml_path, parser=parser)
    attributes = {"type": "SOCKET", "port": str(port), "protocol": "TCP"}
    ET.SubElement(tree.getroot(), "input", action="BLOCKING_INPUT", **attributes)
    tree.write(xml_path, encoding="utf-8", xml_declaration=True)


def _initialisation(flight: Flight) -> ET.Element:
    """The scenario's condition as a JSBSim initialisation file (engines running)."""
    ic = ET.Element("initialize", name=IC_NAME)
    ET.SubElement(ic, "altitude", unit="FT").text = repr(float(flight.altitude_ft))
    tag, unit = _IC_SPEED[flight.speed_kind]
    speed = ET.SubElement(ic, tag, **({"unit": unit} if unit else {}))
    speed.text = repr(float(flight.speed))
    ET.SubElement(ic, "gamma", unit="DEG").text = repr(float(flight.gamma_deg))
    ET.SubElement(ic, "beta", unit="DEG").text = "0.0"
    ET.SubElement(ic, "phi", unit="DEG").text = repr(float(flight.bank_deg))
    ET.SubElement(ic, "running").text = "-1"
    return ic


def _script(flight: Flight, end_s: float) -> ET.Element:
    """The script: load, gear up and JSBSim's full trim at the first frame, then fly to
    ``end_s`` (held by ``--suspend`` until the flight computer iterates it)."""
    script = ET.Element("runscript", name="probing live")
    ET.SubElement(script, "use", aircraft=flight.model, initialize=IC_NAME)
    run = ET.SubElement(script, "run", start="0", end=repr(float(end_s)), dt=repr(flight.dt_s))
    event = ET.SubElement(run, "event", name="trim")
    ET.SubElement(event, "condition").text = "simulation/sim-time-sec ge 0"
    ET.SubElement(event, "set", name="gear/gear-cmd-norm", value="0")
    ET.SubElement(event, "set", name="simulation/do_simple_trim", value="1")
    return script


def _write_xml(path: Path, element: ET.Element) -> None:
    ET.indent(element)
    ET.ElementTree(element).write(path, encoding="utf-8", xml_declaration=True)
