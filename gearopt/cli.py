"""The ``gearopt`` command line.

::

    gearopt run SCENE.toml [--out DIR] [--quiet] [--scheduler ADDRESS]
                                                   run the scene's study, write results.json + plots
                                                   into DIR: a new or empty directory or a previous
                                                   gearopt output (only its own files are replaced;
                                                   gearopt.io.results); progress lines on stderr
                                                   unless --quiet (--scheduler: a Dask cluster for
                                                   the montecarlo and sweep studies)
    gearopt compare A B [C ...] --out DIR [--labels a,b,c]
                                                   compare designs of the same pair: each a result
                                                   directory of gearopt run or a scene (run first
                                                   into DIR/<label>/); writes key_numbers.csv, the
                                                   overlaid figures and report.html into DIR
                                                   (gearopt.io.compare, docs/compare.md)
    gearopt check SCENE.toml                       validate a scene (and build its study), write nothing
    gearopt studies [NAME]                         list the studies, one line each; with NAME (a study
                                                   or "common"), the keys of its scene sections
    gearopt studies --markdown                     the tables of the studies' options (docs/scenes.md)

Errors in the input (any :class:`~gearopt.errors.GearoptError`) print ``error: <message>`` to
stderr and exit with status 2, without a traceback; anything else is a bug and propagates.

At its start the command sets CasADi's OpenBLAS (its solvers' BLAS) to one thread
(:func:`limit_blas_threads`), unless ``OPENBLAS_NUM_THREADS``, ``GOTO_NUM_THREADS`` or ``OMP_NUM_THREADS`` is set.
"""

from __future__ import annotations

import argparse
import inspect
import os
import sys
import time
from pathlib import Path

from .version import __version__
from .errors import GearoptError

EXIT_USAGE = 2  #: exit status for bad input (same as argparse's usage errors)


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="gearopt", description="Gear geometry and tooth contact analysis "
                                "(after Litvin & Fuentes). Scenes are TOML files; see docs/scenes.md.")
    p.add_argument("--version", action="version", version=f"gearopt {__version__}")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    r = sub.add_parser("run", help="run a scene's study and write results.json and plots")
    r.add_argument("scene", type=Path, help="scene file (.toml)")
    r.add_argument("--out", "-o", dest="out_text", type=str, default=None, metavar="DIR",
                   help="output directory (default out/<scene file stem>): created, or, when it is a previous "
                        "gearopt output, its files are replaced on success; a directory holding other files is "
                        "refused (gearopt never removes a file it did not write)")
    r.add_argument("--quiet", "-q", action="store_true", help="no progress lines or bars on stderr")
    r.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="Dask scheduler (tcp://host:port) that runs the samples of a montecarlo or sweep study")
    cp = sub.add_parser("compare", help="compare designs of the same gear pair: overlaid figures, key-numbers table, "
                        "report.html (docs/compare.md)")
    cp.add_argument("designs", nargs="+", metavar="DESIGN",
                    help="a result directory of gearopt run (with results.json) or a scene file (.toml, run first "
                         "into DIR/<label>/); two or more")
    cp.add_argument("--out", "-o", dest="out_text", type=str, required=True, metavar="DIR",
                    help="output directory: created, or, when it is a previous gearopt output, its files are replaced "
                         "on success; a directory holding other files is refused")
    cp.add_argument("--labels", default=None, metavar="A,B,...",
                    help="the designs' names in the figures and the table, comma-separated, one per design (default: "
                         "the scene names)")
    cp.add_argument("--quiet", "-q", action="store_true", help="no progress lines on stderr")
    c = sub.add_parser("check", help="validate a scene without running or writing anything")
    c.add_argument("scene", type=Path, help="scene file (.toml)")
    st = sub.add_parser("studies", help="list the studies (one line each); with NAME, the keys of that study's "
                        "scene sections")
    st.add_argument("name", nargs="?", default=None, metavar="NAME",
                    help="a study (e.g. tca) or 'common' (the sections of every scene): list its keys")
    st.add_argument("--markdown", action="store_true",
                    help="print the markdown tables of the studies' options (those of docs/scenes.md)")
    return p


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``gearopt`` console script; returns the exit status."""
    args = _parser().parse_args(argv)
    exit_without_collecting()
    limit_blas_threads()
    try:
        if args.command == "run":
            return _run(args)
        if args.command == "check":
            return _check(args)
        if args.command == "compare":
            return _compare(args)
        return _studies(args.name, markdown=args.markdown)
    except GearoptError as e:
        print(f"error: {e}", file=sys.stderr)
        return EXIT_USAGE


_EXIT_FREEZE: list[bool] = []  # exit_without_collecting registered (once per process)


def exit_without_collecting() -> None:
    """At the interpreter's exit, leave the objects alive then out of its final garbage collections
    (:func:`gc.freeze` as the last exit handler).

    Python ends with several full collections over every object still alive; after a run, that is
    every array, CasADi Function and module numpy and CasADi made, about 0.1-0.2 s (a tenth of the
    demo's run) that no one waits for. The frozen objects are still released as their modules are
    cleared; only objects in reference cycles are left to the end of the process, as with any
    interpreter that ends. Exit handlers registered before this one (a background compile's wait,
    :mod:`gearopt.compiled`) run after it, as before. Called by :func:`main`; registered once per
    process, and a process that goes on (a test calling :func:`main`) collects as usual until it
    exits."""
    if not _EXIT_FREEZE:
        import atexit
        import gc

        atexit.register(gc.freeze)
        _EXIT_FREEZE.append(True)


#: environment variables by which a user chooses OpenBLAS's thread count (then :func:`limit_blas_threads` does nothing)
BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS", "OMP_NUM_THREADS")


def limit_blas_threads(n: int = 1) -> list[str]:
    """Set CasADi's own OpenBLAS, the BLAS of its solvers (MUMPS in IPOPT), to ``n`` threads [-];
    the libraries set (their paths: none, or CasADi's).

    MUMPS factorises the loaded optimiser's KKT systems (7,300 unknowns) in frontal matrices of tens
    to a few hundred rows, whose products (``dgemm``, ``dtrsm``: 21 % of a warm run's samples) a
    second OpenBLAS thread does not speed up; between the calls its thread waits spinning, which on an
    idle machine took 2.8 s of the loaded optimiser's 14.9 s CPU for the same wall time
    (docs/benchmarks.md section 3) and, in a first run, the core the background compilers run on. A
    process-wide setting, so the library never makes it; the command line does, at its start
    (:func:`main`), and a user's choice comes first: nothing is done when one of
    :data:`BLAS_THREAD_VARIABLES` is set. The IPOPT iterates are the same bit for bit; the loaded
    optimiser's sensitivities move by round-off (``microgeometry_loaded``: 3 of 53,277 numbers, up to
    5.3e-9 relative, benchmarks/results_unchanged.py).

    CasADi loads this OpenBLAS with its first IPOPT solver; it is loaded here and set (the solver then
    finds it loaded), so it works whatever was imported before. numpy's and scipy's OpenBLAS are left
    as they are: their calls in gearopt are few and small (0.2 % of a warm loaded optimisation's
    samples under ``perf``)."""
    import ctypes

    if any(os.environ.get(v) for v in BLAS_THREAD_VARIABLES):
        return []
    try:
        import casadi
    except ImportError:
        return []
    path = os.path.join(os.path.dirname(casadi.__file__), "libcasadi-tp-openblas.so.0")
    if not os.path.isfile(path):  # a CasADi built against another BLAS: nothing to set
        return []
    try:
        setter = ctypes.CDLL(path).openblas_set_num_threads
    except (OSError, AttributeError):
        return []
    setter.argtypes, setter.restype = [ctypes.c_int], None
    setter(int(n))
    return [path]


def _run(args) -> int:
    from .cli_plots import PlotProcesses

    # first: a process that imports matplotlib while the scene is read and run, to draw the plots
    plotter = PlotProcesses.start()
    try:
        return _run_scene(args, plotter)
    finally:
        if plotter is not None:
            plotter.close()


def _run_scene(args, plotter) -> int:
    os.environ.setdefault("MPLBACKEND", "Agg")  # plots go to files; never open a window
    from .io.results import write_results
    from .io.scene import load_scene
    from .progress import reporting
    from .warning_log import WarningLog

    def say(msg: str) -> None:
        if not args.quiet:
            print(f"gearopt: {msg}", file=sys.stderr, flush=True)

    from .io.results import check_out_dir

    say(f"loading {args.scene}")
    scene = load_scene(args.scene)
    out = check_out_dir(args.out_text if args.out_text is not None else Path("out") / args.scene.stem, args.scene)
    if plotter is not None and (not scene.output.get("plots", True) or scene.output.get("svg", False)):
        plotter.close()  # no plots, or SVG copies drawn beside them: not for the drawing processes
        plotter = None
    say(f"building study {scene.study!r} for scene {scene.name!r}")
    sink = None if args.quiet else say  # long work deep in the library reports here (gearopt.progress)
    caught = WarningLog()
    with _in_scene(scene), reporting(sink), caught:
        study = scene.build()
    if plotter is not None:
        plotter.prepare(type(study).__module__)  # the result's class: imported while the study runs
    say("running")
    t0 = time.perf_counter()
    run = study.run
    try:
        params = inspect.signature(run).parameters
    except (TypeError, ValueError):
        params = {}
    kwargs = {}
    if "progress" in params:
        kwargs["progress"] = None if args.quiet else say
    if args.scheduler is not None:
        if "scheduler" not in params:
            from .errors import OptionError
            raise OptionError(f"--scheduler {args.scheduler}: study {scene.study!r} runs in this process; only the "
                              "montecarlo and sweep studies run on a Dask cluster.", param="--scheduler",
                              value=args.scheduler, valid="a montecarlo or sweep scene")
        kwargs["scheduler"] = args.scheduler
    with _in_scene(scene), reporting(sink), caught:
        result = run(**kwargs)
    run_time = time.perf_counter() - t0
    say(f"done in {run_time:.2f} s; writing {out}")
    paths = write_results(out, result, scene=scene, run_time=run_time, progress=say, warnings=caught.records,
                          plotter=plotter)
    for p in paths:
        print(p)
    return 0


def _compare(args) -> int:
    os.environ.setdefault("MPLBACKEND", "Agg")  # figures go to files; never open a window
    import contextlib
    import io

    from .io.compare import compare

    def say(msg: str) -> None:
        if not args.quiet:
            print(f"gearopt compare: {msg}", file=sys.stderr, flush=True)

    def run_scene(scene: Path, out: Path) -> None:
        """``gearopt run SCENE --out OUT`` (its progress on stderr; its list of files, in the temporary
        directory, is not printed: compare prints the files at their final place)."""
        with contextlib.redirect_stdout(io.StringIO()):
            status = main(["run", str(scene), "--out", str(out), *(["--quiet"] if args.quiet else [])])
        if status != 0:
            raise GearoptError(f"gearopt compare: the scene {scene} did not run (its error is above); nothing was "
                               "written.", param="DESIGN", value=str(scene))

    labels = None if args.labels is None else [s.strip() for s in args.labels.split(",")]
    paths = compare(args.designs, args.out_text, labels=labels, run_scene=run_scene, progress=say)
    for p in paths:
        print(p)
    return 0


class _in_scene:
    """Context manager: a GearoptError raised while a scene's study is built or run is re-raised as
    a SceneError that names the scene file, the study's ``[section] key`` and the keys as written
    (:meth:`~gearopt.io.scene.Scene.run_error`), unless it is a SceneError already stated for this
    scene (its ``source`` is the scene file)."""

    def __init__(self, scene):
        self.scene = scene

    def __enter__(self):
        return self

    def __exit__(self, typ, err, tb):
        from .errors import ResultsError, SceneError

        if err is None or not isinstance(err, GearoptError) or isinstance(err, ResultsError):
            return False
        if isinstance(err, SceneError) and err.source is not None and err.source == self.scene.source:
            return False  # already stated for this scene (by Scene.key_error, study_error, run_error...)
        raise self.scene.run_error(err) from err


def _check(args) -> int:
    from .io.scene import load_scene

    from .compiled import no_background

    scene = load_scene(args.scene)
    with _in_scene(scene), no_background():  # a check writes nothing, not even the compile cache
        scene.build()
    p, g = scene.pair.pinion, scene.pair.gear
    print(f"ok: {args.scene}: scene {scene.name!r}, study {scene.study!r}, z = {p.z}/{g.z}, "
          f"m_n = {p.m_n:.6g} mm, a = {scene.pair.a_w:.6g} mm")
    return 0


def _studies(name: str | None = None, markdown: bool = False) -> int:
    from .io.scene import COMMON_SECTIONS, format_field
    from .studies import broken_modules, markdown_tables, studies

    if markdown:
        print(markdown_tables(), end="")
        return 0

    def show(section, indent="  ", prefix=""):
        req = " (required)" if section.required else ""
        doc = f"  -- {section.doc}" if section.doc else ""
        br = ("[[", "]]") if getattr(section, "array", False) else ("[", "]")
        print(f"{indent}{br[0]}{prefix}{section.name}{br[1]}{req}{doc}")
        for f in section.fields:
            print(f"{indent}    {format_field(f)}")
        for kind, fs in getattr(section, "variants", {}).items():  # a tool = {kind = ...} table
            print(f"{indent}    kind = \"{kind}\":" + ("" if fs else " (no further keys)"))
            for f in fs:
                print(f"{indent}        {format_field(f)}")
        for s in section.subsections:
            show(s, indent + "    ", f"{prefix}{section.name}.")

    specs = studies()
    for mod, err in broken_modules().items():
        print(f"warning: study module {mod} failed to import: {err!r}", file=sys.stderr)
    units = ("lengths in mm, angles in deg unless written as \"<number> <unit>\"; micro-geometry amounts "
             "always with their unit (\"12 um\")")
    if name is None:  # the compact listing
        if not specs:
            print("no studies registered")
        width = max((len(n) for n in specs), default=0)
        for n in sorted(specs):
            print(f"  {n:<{width}}  {specs[n].doc}".rstrip())
        print(f"\ngearopt studies NAME for a study's keys; gearopt studies common for the sections of every scene "
              f"({', '.join(s.name for s in COMMON_SECTIONS)}). Units: {units}.")
        return 0
    if name == "common":
        print(f"common sections (every scene; {units}):")
        for s in COMMON_SECTIONS:
            show(s)
        return 0
    if name not in specs:
        from .errors import OptionError
        valid = ", ".join(sorted(specs)) + ", common"
        raise OptionError(f"gearopt studies {name}: no such study; valid: {valid}.", param="NAME", value=name,
                          valid=valid)
    spec = specs[name]
    print(f"{name}: {spec.doc}".rstrip(": "))
    print(f"(scene: [scene] study = \"{name}\"; {units})")
    for s in spec.sections:
        show(s)
    if not spec.sections:
        print("  (no extra sections)")
    if spec.settings:  # the option sets: where the keys are declared, and their names in the API
        renamed = [f"{f'{o.group}.' if o.group else ''}{o.key} = {n}" for cls in spec.settings
                   for n, (o, _) in cls.options().items() if o.key]
        print(f"\n(options declared by {', '.join(f'{c.__module__}.{c.__name__}' for c in spec.settings)}"
              + (f"; API keywords: {', '.join(renamed)}" if renamed else "") + ")")
    print("\ngearopt studies common for the sections of every scene.")
    return 0
