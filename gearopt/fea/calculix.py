"""CalculiX (``ccx``) input writer, runner and a small reader of its ``.dat`` output.

Units throughout: mm, N, MPa, N*mm; rotations in rad. See ``docs/theory.md`` section 12 and ``docs/fea.md`` for the
measured behaviour this module relies on (a closing step before the torque, LINEAR penalty ~50 E, no ADJUST).
"""

from __future__ import annotations

import functools

import math
import os
import re
import shutil
import subprocess
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..errors import CalculixError, GearoptError  # noqa: F401  (CalculixError lives in errors.py; re-exported)
from ..compiled import idle_cpus as load_average_idle_cpus

if TYPE_CHECKING:
    from collections.abc import Sequence

CCX_ENV = "GEAROPT_CCX"  #: environment variable naming the ccx executable (default: ``ccx`` on PATH)


def ccx_path() -> str | None:
    """Path of the ccx executable, or None."""
    exe = os.environ.get(CCX_ENV) or "ccx"
    return shutil.which(exe)


def require_ccx() -> str:
    exe = ccx_path()
    if exe is None:
        raise CalculixError("CalculiX (ccx) is not installed or not on PATH: the finite element step needs it. "
                            "Install it (Debian/Ubuntu: apt-get install calculix-ccx; `make ccx` tries that) or set "
                            f"{CCX_ENV} to the executable.")
    return exe


# ---------------------------------------------------------------------------------------------
# input deck
# ---------------------------------------------------------------------------------------------
def _id_lines(ids, per_line: int = 16) -> str:
    ids = [int(i) for i in ids]
    return "\n".join(", ".join(str(i) for i in ids[k:k + per_line]) for k in range(0, len(ids), per_line))


@dataclass
class Deck:
    """Everything the writer needs (1-based ids)."""

    nodes: np.ndarray  # (N, 3)
    elements: np.ndarray  # (E, 8) 1-based node ids
    nsets: dict  # name -> ids
    elsets: dict  # name -> ids
    surfaces: dict  # name -> list of (element id, face number)
    contact_pairs: list  # (slave surface, master surface)
    ref_node: int
    rot_node: int
    rigid_nset: str
    fixed_nset: str
    E: float
    nu: float
    penalty: float  # N/mm^3
    close_rotation: float  # rad (signed, about +z)
    moment: float  # N*mm (signed, about +z)
    print_elsets: list = field(default_factory=list)
    element_type: str = "C3D8"
    increments: tuple = (1.0, 1.0)  # (initial increment of step 1, of steps 2 and 3)


def write_inp(deck: Deck, path: str | os.PathLike) -> Path:
    """Write the Abaqus-style input deck: mesh, rigid pinion rim, fixed gear rim, contact pairs and the
    three steps (close the contact with a prescribed rotation near the loaded one, release it and apply the
    torque, the same load again with the contact faces paired at the loaded state)."""
    path = Path(path)
    lines = ["** gearopt: automatic FE model of a gear drive (Litvin 9.5); units mm, N, MPa", "*NODE, NSET=NALL"]
    lines += [f"{i + 1}, {x:.12e}, {y:.12e}, {z:.12e}" for i, (x, y, z) in enumerate(deck.nodes)]
    lines.append(f"{deck.ref_node}, 0., 0., 0.")
    lines.append(f"{deck.rot_node}, 0., 0., 0.")
    lines.append(f"*ELEMENT, TYPE={deck.element_type}, ELSET=EALL")
    lines += [f"{i + 1}, " + ", ".join(str(int(n)) for n in e) for i, e in enumerate(deck.elements)]
    for name, ids in deck.nsets.items():
        lines += [f"*NSET, NSET={name}", _id_lines(ids)]
    for name, ids in deck.elsets.items():
        lines += [f"*ELSET, ELSET={name}", _id_lines(ids)]
    lines += ["*NSET, NSET=NREF", str(deck.ref_node), "*NSET, NSET=NROT", str(deck.rot_node)]
    for name, faces in deck.surfaces.items():
        lines.append(f"*SURFACE, NAME={name}, TYPE=ELEMENT")
        lines += [f"{e}, S{f}" for e, f in faces]
    lines += ["*MATERIAL, NAME=STEEL", "*ELASTIC", f"{deck.E:.6e}, {deck.nu:.6f}",
              "*SOLID SECTION, ELSET=EALL, MATERIAL=STEEL",
              f"*RIGID BODY, NSET={deck.rigid_nset}, REF NODE={deck.ref_node}, ROT NODE={deck.rot_node}",
              "*SURFACE INTERACTION, NAME=SI", "*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=LINEAR",
              f"{deck.penalty:.6e}"]
    for slave, master in deck.contact_pairs:
        lines += ["*CONTACT PAIR, INTERACTION=SI, TYPE=SURFACE TO SURFACE", f"{slave}, {master}"]
    fix = [f"{deck.fixed_nset}, 1, 3", "NREF, 1, 3", "NROT, 1, 2"]
    d0, d1 = deck.increments
    static = ["*STATIC", f"{d1}, 1.0"]
    load = ["*BOUNDARY, OP=NEW", *fix, "*CLOAD", f"NROT, 3, {deck.moment:.9e}"]
    # Step 1 only places the members near their loaded state: ccx's face-to-face contact pairs the slave
    # integration points with master faces at the start of each step and finds its contact set from the
    # penetrations of the last solution, so the rotation's rigid overlap would take ~10 iterations (one
    # SPOOLES factorisation each) to shrink to the set it settles on; delcon 1 ends the step when the set
    # stops doubling. Step 2 then converges the loaded contact, and step 3 (the same load) pairs the faces
    # again at the loaded state and converges once more: the result no longer depends on where step 1 left
    # the members (docs/fea.md "Solver cost").
    lines += ["** step 1: close the contact with a prescribed pinion rotation near the loaded one (docs/theory.md 12.3 rule 1)",
              "*STEP", "*STATIC", f"{d0}, 1.0", "*CONTROLS, PARAMETERS=CONTACT", "1.0",
              "*BOUNDARY", *fix, f"NROT, 3, 3, {deck.close_rotation:.9e}", "*END STEP",
              "** step 2: release the rotation, apply the torque about the pinion axis",
              "*STEP", *static, "*CONTROLS, RESET", *load, "*END STEP",
              "** step 3: the same load, the contact faces paired again at the loaded state",
              "*STEP", *static, *load,
              f"*NODE PRINT, NSET={deck.fixed_nset}, TOTALS=ONLY", "RF",
              "*NODE PRINT, NSET=NREF, TOTALS=ONLY", "RF",
              "*NODE PRINT, NSET=NROT", "U",
              "*CONTACT PRINT", "CSTR", "*CONTACT FILE", "CSTR",
              "*NODE FILE", "U", "*EL FILE", "S"]  # displacements and nodal stresses (the .vtu for ParaView)
    for slave, master in deck.contact_pairs:  # total contact force of each tooth pair (load sharing)
        lines += [f"*CONTACT PRINT, SLAVE={slave}, MASTER={master}, TOTALS=ONLY", "CF"]
    for es in deck.print_elsets:
        lines += [f"*EL PRINT, ELSET={es}", "S"]
    lines += ["*END STEP", ""]
    path.write_text("\n".join(lines))
    return path


# ---------------------------------------------------------------------------------------------
# runner
# ---------------------------------------------------------------------------------------------
PROC_STAT = "/proc/stat"  #: the kernel's CPU time counters (Linux)


def _cpu_times() -> tuple[int, int, int] | None:
    """(idle ticks, all ticks, CPUs) of the machine from :data:`PROC_STAT`, or None where unreadable."""
    try:
        with open(PROC_STAT) as fh:
            lines = fh.read().splitlines()
        t = [int(v) for v in lines[0].split()[1:9]]  # user nice system idle iowait irq softirq steal
        n = sum(1 for ln in lines if ln.startswith("cpu") and ln[3:4].isdigit())
    except (OSError, ValueError, IndexError):
        return None
    return t[3] + t[4], sum(t), n


def idle_cpus_now(window: float = 0.1) -> int:
    """CPUs idle now: the machine's idle share of CPU time over ``window`` [s] (``/proc/stat``) times its
    CPUs, rounded down after a 15 % allowance, between 1 and this process's usable CPUs.

    Unlike the 1-minute load average (:func:`gearopt.compiled.idle_cpus`, the fallback where
    ``/proc/stat`` is unreadable), this sees a core that went idle a moment ago: a test worker that ran
    for the last minute keeps the load average at 1 or more, so a ccx started when the other core
    had just finished its work got one thread from the load average."""
    try:
        usable = max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        usable = max(1, os.cpu_count() or 1)
    a = _cpu_times()
    if a is None:
        return load_average_idle_cpus()
    time.sleep(window)
    b = _cpu_times()
    if b is None or b[1] <= a[1]:
        return load_average_idle_cpus()
    share = (b[0] - a[0]) / (b[1] - a[1])
    return int(min(usable, max(1, math.floor(share * b[2] + 0.15))))


@dataclass
class CcxRun:
    dat: str
    log: str
    seconds: float
    workdir: Path | None
    frd: str = ""


def run_ccx(deck: Deck | None, jobname: str = "gear", threads: int = 2, timeout: float = 900.0,
            keep_dir: str | os.PathLike | None = None, inp: str | None = None) -> CcxRun:
    """Write the deck (or the input text ``inp``) and run ``ccx -i jobname`` in a temporary directory
    (or ``keep_dir``, which keeps the files). Raises :class:`CalculixError` on a missing executable,
    timeout or failure.

    ``threads`` is an upper bound: ccx gets at most the CPUs idle now (:func:`idle_cpus_now`), because on
    busy cores a second solver thread only waits for a core (measured: 35-50 % more ccx CPU at the same
    wall time, the same results: SPOOLES on 1 and 2 threads writes the same ``.dat``)."""
    exe = require_ccx()
    threads = max(1, int(threads))
    if threads > 1:
        threads = max(1, min(threads, idle_cpus_now()))
    tmp = None
    if keep_dir is None:
        tmp = tempfile.TemporaryDirectory(prefix="gearopt-ccx-")
        wd = Path(tmp.name)
    else:
        wd = Path(keep_dir)
        wd.mkdir(parents=True, exist_ok=True)
    try:
        if inp is not None:
            (wd / f"{jobname}.inp").write_text(inp)
        else:
            write_inp(deck, wd / f"{jobname}.inp")
        env = dict(os.environ, OMP_NUM_THREADS=str(threads), CCX_NPROC_EQUATION_SOLVER=str(threads))
        t0 = time.perf_counter()
        try:
            proc = subprocess.run([exe, "-i", jobname], cwd=wd, env=env, capture_output=True, text=True,
                                  timeout=timeout)
        except subprocess.TimeoutExpired as e:
            size = f"{len(deck.elements)} elements" if deck is not None else "its input"
            raise CalculixError(f"ccx did not finish within {timeout:g} s ({size}); "
                                "coarsen the mesh or raise the timeout.") from e
        secs = time.perf_counter() - t0
        log = proc.stdout + proc.stderr
        dat = (wd / f"{jobname}.dat").read_text() if (wd / f"{jobname}.dat").exists() else ""
        frd = (wd / f"{jobname}.frd").read_text() if (wd / f"{jobname}.frd").exists() else ""
        if proc.returncode != 0 or "*ERROR" in log or "Job finished" not in log:
            tail = "\n".join([ln for ln in log.splitlines() if ln.strip()][-12:])
            raise CalculixError(f"ccx failed (exit code {proc.returncode}) in {wd}:\n{tail}")
        return CcxRun(dat=dat, log=log, seconds=secs, workdir=None if tmp else wd, frd=frd)
    finally:
        if tmp is not None:
            tmp.cleanup()


# ---------------------------------------------------------------------------------------------
# .dat reader
# ---------------------------------------------------------------------------------------------
_HEADER = re.compile(r"^\s*(?P<what>[a-z][a-z .()]*?)\s*\((?P<cols>[^)]*)\)\s*for\s+(?:set\s+(?P<set>\S+)|all contact elements)"
                     r"\s+and\s+time\s+(?P<time>\S+)", re.I)


@dataclass
class DatBlock:
    what: str
    columns: str
    set: str | None
    time: float
    rows: list


def read_dat(text: str) -> list[DatBlock]:
    """Blocks of a ccx ``.dat`` file: each header line ``<what> (<columns>) for set <S> and time <t>``
    followed by numeric rows (lists of floats; integer columns as floats)."""
    blocks: list[DatBlock] = []
    cur = None
    for line in text.splitlines():
        m = _HEADER.match(line)
        if m:
            cur = DatBlock(m.group("what").strip().lower(), m.group("cols"), m.group("set"),
                           float(m.group("time")), [])
            blocks.append(cur)
            continue
        if cur is None:
            continue
        s = line.strip()
        if not s:
            continue
        try:
            cur.rows.append([float(v) for v in s.split()])
        except ValueError:
            cur = None  # another section (e.g. step headers)
    return blocks


def last_block(blocks: Sequence[DatBlock], what: str, set_name: str | None = None) -> DatBlock | None:
    """The last block (latest time) whose description starts with ``what`` (and of ``set_name``)."""
    found = [b for b in blocks if b.what.startswith(what) and (set_name is None or (b.set or "").upper() == set_name.upper())]
    return found[-1] if found else None


def read_frd_block(text: str, name: str) -> dict[int, list[float]] | None:
    """The last result block ``name`` (e.g. "CONTACT", "STRESS", "DISP") of a ccx ``.frd`` file as
    {node id: values}. Fixed-width records: `` -1`` + node id (10 chars) + values (12 chars each).
    The text is parsed once for all its blocks (:func:`_frd_blocks`, kept for the last two texts: a
    run's results and its .vtu read the same .frd five times); each call gets its own dictionary."""
    blk = _frd_blocks(text).get(name.upper())
    return None if blk is None else dict(blk)


@functools.lru_cache(maxsize=2)
def _frd_blocks(text: str) -> dict[str, dict[int, list[float]]]:
    """Every result block of a ``.frd`` by its upper-case name, the last of each name."""
    out: dict[str, dict[int, list[float]]] = {}
    cur = None
    for line in text.splitlines():
        if line.startswith(" -4"):
            parts = line.split()
            cur = {} if len(parts) > 1 else None
            if cur is not None:
                out[parts[1].upper()] = cur
            continue
        if cur is None:
            continue
        if line.startswith(" -3"):
            cur = None
        elif line.startswith(" -1"):
            nid = int(line[3:13])
            vals = [float(line[13 + 12 * k: 25 + 12 * k]) for k in range((len(line.rstrip()) - 13) // 12)]
            cur[nid] = vals
    return out


_STATS = re.compile(r"^\s*statistics for slave set (?P<slave>\S+), master set (?P<master>\S+) and time\s+(?P<time>\S+)", re.I)


def read_contact_statistics(text: str) -> dict:
    """Per contact pair, the last ``*CONTACT PRINT, SLAVE=, MASTER=, TOTALS=ONLY`` statistics of a
    ``.dat``: {slave: {"master", "time", "area" [mm^2], "normal_force" [N] (+ = tension, so a pressed
    contact is negative), "shear_force" [N]}}; pairs out of contact have area and forces 0."""
    out: dict = {}
    lines = text.splitlines()
    for i, line in enumerate(lines):
        m = _STATS.match(line)
        if not m:
            continue
        rec = {"master": m.group("master"), "time": float(m.group("time"))}
        for j in range(i + 1, min(i + 30, len(lines))):
            if lines[j].strip().startswith("area,"):
                vals = [v for k in range(j + 1, min(j + 4, len(lines))) for v in lines[k].split()][:3]
                try:
                    a, fn, fs = (float(v) for v in vals)
                except ValueError:
                    a, fn, fs = 0.0, 0.0, 0.0
                rec.update(area=a, normal_force=fn, shear_force=fs)
                break
            if _STATS.match(lines[j]):
                break
        out[m.group("slave")] = rec
    return out
