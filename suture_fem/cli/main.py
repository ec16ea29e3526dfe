"""The ``suture-fem`` command line.

    suture-fem run SCENE [--set KEY=VALUE ...] [--out DIR] [--fields] [--no-pictures]
    suture-fem mesh SCENE [--set KEY=VALUE ...] [--out FILE.msh]
    suture-fem scenes                      list the built-in scenes
    suture-fem show SCENE [--set ...]      print the fully resolved scene as JSON

Exit codes: 0 success, 1 a failure (e.g. a full disk), 2 bad scene or arguments, 3 a solve that
stopped with a diagnosis, 130 interrupted (Ctrl-C, SIGINT), 143 terminated (SIGTERM), 129 hung up (SIGHUP).
Under mpirun every rank runs the same command; logs and files come from rank 0 only.
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import signal
import sys
import threading
from pathlib import Path
from typing import Any

from suture_fem.support import children, signals, startup
from suture_fem.support.errors import Interrupted, SutureFemError, one_line
from suture_fem.support.logging import setup_logging

#: Modules that add a subcommand: each has ``register(subparsers, scene_args)``, which adds its
#: parser and sets ``handler=fn`` with ``fn(args, comm) -> int`` as the parser's default.
COMMAND_MODULES: tuple[str, ...] = ("suture_fem.cli.sweep", "suture_fem.cli.convergence",
                                     "suture_fem.cli.reproduce", "suture_fem.cli.maxload",
                                     "suture_fem.cli.calibrate", "suture_fem.cli.holding")

#: The commands whose interruption leaves a results.json with the last converged step.
WRITES_RESULTS = ("run", "sweep", "maxload")


def _scene_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("scene", help="a scene TOML file or the name of a built-in scene (see `suture-fem scenes`)")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scene key by its dotted name, e.g. --set geometry.cones=2 (repeatable)")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of every command (the studies' commands register themselves)."""
    parser = argparse.ArgumentParser(prog="suture-fem", description=__doc__.split("\n\n")[0])
    parser.add_argument("-v", "--verbose", action="store_true", help="debug logging")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("run", help="solve a scene and write DIR/results.json")
    _scene_args(p)
    p.add_argument("--out", default=None, help="output folder (default: results/<scene name>)")
    p.add_argument("--fields", action="store_true", help="also write XDMF fields (same as --set output.fields=true)")
    p.add_argument("--no-pictures", action="store_true",
                   help="do not draw usum.png, force_displacement.png and interface.png beside results.json")
    p.add_argument("--error-estimate", action="store_true",
                   help="solve once more one refinement coarser and attach 'USUM = x mm +- y' "
                   "(see suture_fem/studies/convergence/estimate.py)")

    p = sub.add_parser("mesh", help="write a scene's mesh as a gmsh .msh file (mm) with a JSON record")
    _scene_args(p)
    p.add_argument("--out", default=None, help="output .msh path (default: meshes/<scene name>.msh)")

    sub.add_parser("scenes", help="list the built-in scenes")
    p = sub.add_parser("show", help="print the fully resolved scene as JSON")
    _scene_args(p)
    for name in COMMAND_MODULES:
        importlib.import_module(name).register(sub, _scene_args)
    return parser


def _scene_name(source: str) -> str:
    return Path(source).stem if source.endswith(".toml") else source


def main(argv: list[str] | None = None) -> int:
    """Run one command on MPI's world communicator; returns the exit code (0, 2 bad input, 3 stopped)."""
    try:
        ignored = startup.check_environment()  # before MPI starts
    except SutureFemError as exc:
        if os.environ.get("OMPI_COMM_WORLD_RANK", "0") == "0":
            print(f"suture-fem: error: {exc}", file=sys.stderr)
        return exc.exit_code
    from mpi4py import MPI

    comm = MPI.COMM_WORLD  # the command line is the one place that picks the communicator
    parser = build_parser()
    args = parser.parse_args(argv)
    setup_logging(comm, args.verbose)
    if ignored and comm.rank == 0:
        print(f"suture-fem: {' and '.join(ignored)} ignored: PETSc options come only from the scene's "
              "solver.petsc_options", file=sys.stderr)
    previous = _catch_signals(comm)
    try:
        return _dispatch(args, comm)
    except Interrupted as exc:
        if comm.rank == 0:
            kept = "; results.json keeps the last converged step" if args.command in WRITES_RESULTS else ""
            print(f"suture-fem: interrupted ({exc.name}){kept}", file=sys.stderr)
        return exc.exit_code
    except SutureFemError as exc:
        if comm.rank == 0:
            print(f"suture-fem: error: {one_line(str(exc))}", file=sys.stderr)
        return exc.exit_code
    except Exception:
        if comm.size == 1:
            raise
        # Raised on this rank only: the others may wait in a collective call forever. End them all.
        import traceback

        print(f"suture-fem: unexpected error on rank {comm.rank}; aborting all ranks\n{traceback.format_exc()}",
              file=sys.stderr, flush=True)
        comm.Abort(1)
        raise
    finally:
        signals.restore(previous)  # handled (or never raised): later solves in this process start clean
        if previous and "gmsh" in sys.modules:
            sys.modules["gmsh"].oldsig = previous[signal.SIGINT]


def _catch_signals(comm: Any) -> dict[int, Any]:
    """SIGINT, SIGTERM and SIGHUP end the command in order (:mod:`~suture_fem.support.signals`); the old handlers.

    A child process started by :func:`~suture_fem.support.children.popen` also ends with its parent.
    """
    if threading.current_thread() is not threading.main_thread():
        return {}
    import gmsh
    from petsc4py import PETSc  # noqa: F401  (PETSc's initialisation sets its own handlers: ours come after)

    # gmsh sets SIGINT to its default at import and restores the handler it found then at every
    # gmsh.finalize(): make that ours, so Ctrl-C after meshing still ends the run cleanly
    gmsh.oldsig = signals.handler
    previous = signals.install(comm.size)
    children.end_with_parent()
    return previous


def _dispatch(args: argparse.Namespace, comm: Any) -> int:
    from suture_fem.pipeline import check_ranks, load_scene
    from suture_fem.scene import builtin_names

    if getattr(args, "handler", None) is not None:
        return args.handler(args, comm)
    if args.command == "scenes":
        if comm.rank == 0:
            print("\n".join(builtin_names()))
        return 0
    overrides = list(args.overrides)
    if args.command == "run" and args.fields:
        overrides.append("output.fields=true")
    scene = load_scene(args.scene, overrides)
    if args.command == "run":
        check_ranks(scene, comm)
    if args.command == "show":
        if comm.rank == 0:
            print(json.dumps(scene.as_dict(), indent=2))
        return 0
    if args.command == "mesh":
        from suture_fem.geometry.mesh import check_msh_path, write_msh

        path = check_msh_path(args.out or f"meshes/{_scene_name(args.scene)}.msh")
        if comm.rank == 0:
            path.parent.mkdir(parents=True, exist_ok=True)
            record = write_msh(scene.geometry, scene.mesh, path, scene.effects.thread_track, scene.effects.cone_contact)
            cells = "triangles" if "triangles" in record else "tetrahedra"
            print(f"suture-fem: wrote {path} ({record[cells]} {cells}) and {path.with_suffix('.json')}")
        return 0
    if args.command == "run":
        return _run(args, scene, comm)
    raise AssertionError(args.command)


#: The lock file a run holds in its --out for its life (a second run into the folder is refused).
RUN_LOCK = ".run.lock"


def _run(args: argparse.Namespace, scene: Any, comm: Any) -> int:
    """``suture-fem run`` with its --out locked (rank 0 holds ``OUT/.run.lock``) before anything is written."""
    from suture_fem.support.folder_lock import lock_folder, release_folder
    from suture_fem.support.parallel import on_root

    out = Path(args.out or f"results/{_scene_name(args.scene)}")
    lock = on_root(comm, f"locking {out}", lock_folder, out, RUN_LOCK, "run")
    try:
        return _run_locked(args, scene, comm, out)
    finally:
        if lock is not None:
            release_folder(lock, out, RUN_LOCK)


def _run_locked(args: argparse.Namespace, scene: Any, comm: Any, out: Path) -> int:
    """Solve, draw the pictures (unless --no-pictures), print the answer."""
    from suture_fem.cli.run_report import Pictures, summary
    from suture_fem.pipeline import scene_model
    from suture_fem.support.errors import SolveStopped
    from suture_fem.support.io import read_json

    name = _scene_name(args.scene)
    pictures = None if args.no_pictures else Pictures(out, comm)
    model = scene_model(scene, out, comm)
    try:
        results = model.solve(out)
    except SolveStopped:
        if pictures is not None:  # the converged part, drawn before the diagnosis
            pictures.capture(model)
            if comm.rank == 0:
                pictures.draw(read_json(out / "results.json"), name)
        raise
    finally:
        model.close()  # the solver's matrices and options (the model's state stays for the pictures)
    if pictures is not None:
        pictures.capture(model)
    del model  # its mesh and forms are not needed past here (the error estimate builds its own)
    if args.error_estimate:
        from suture_fem.studies.convergence.estimate import attach_error_estimate

        results = attach_error_estimate(scene, results, comm, out)
    written = pictures.draw(results, name) if pictures is not None else []
    signals.check(comm)  # a signal that arrived after the solve (on any rank) still ends every rank alike
    if comm.rank == 0:
        print(summary(results, out, written))
    return 0


if __name__ == "__main__":
    sys.exit(main())
