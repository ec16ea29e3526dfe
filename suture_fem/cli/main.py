"""The ``suture-fem`` command line.

    suture-fem run SCENE [--set KEY=VALUE ...] [--out DIR] [--fields]
    suture-fem mesh SCENE [--set KEY=VALUE ...] [--out FILE.msh]
    suture-fem scenes                      list the built-in scenes
    suture-fem show SCENE [--set ...]      print the fully resolved scene as JSON

Exit codes: 0 success, 2 bad scene or arguments, 3 a solve that stopped with a diagnosis.
Under mpirun every rank runs the same command; logs and files come from rank 0 only.
"""

from __future__ import annotations

import argparse
import importlib
import json
import sys
from pathlib import Path
from typing import Any

from suture_fem.support.errors import SutureFemError
from suture_fem.support.logging import setup_logging

#: Modules that add a subcommand: each has ``register(subparsers, scene_args)``, which adds its
#: parser and sets ``handler=fn`` with ``fn(args, comm) -> int`` as the parser's default.
COMMAND_MODULES: tuple[str, ...] = ("suture_fem.cli.sweep", "suture_fem.cli.convergence",
                                     "suture_fem.cli.reproduce", "suture_fem.cli.maxload")


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
    from mpi4py import MPI

    comm = MPI.COMM_WORLD  # the command line is the one place that picks the communicator
    parser = build_parser()
    args = parser.parse_args(argv)
    setup_logging(comm, args.verbose)
    try:
        return _dispatch(args, comm)
    except SutureFemError as exc:
        if comm.rank == 0:
            print(f"suture-fem: error: {exc}", file=sys.stderr)
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


def _dispatch(args: argparse.Namespace, comm: Any) -> int:
    from suture_fem.pipeline import load_scene
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
    if args.command == "show":
        if comm.rank == 0:
            print(json.dumps(scene.as_dict(), indent=2))
        return 0
    if args.command == "mesh":
        from suture_fem.geometry.mesh import write_msh

        path = Path(args.out or f"meshes/{_scene_name(args.scene)}.msh")
        if comm.rank == 0:
            path.parent.mkdir(parents=True, exist_ok=True)
            record = write_msh(scene.geometry, scene.mesh, path)
            print(f"suture-fem: wrote {path} ({record['triangles']} triangles) and {path.with_suffix('.json')}")
        return 0
    if args.command == "run":
        from suture_fem.pipeline import run_scene

        out = Path(args.out or f"results/{_scene_name(args.scene)}")
        results = run_scene(scene, out, comm)
        if args.error_estimate:
            from suture_fem.studies.convergence.estimate import attach_error_estimate

            results = attach_error_estimate(scene, results, comm, out)
        if comm.rank == 0:
            print(_summary(results, out))
        return 0
    raise AssertionError(args.command)


def _summary(results: dict[str, Any], out: Path) -> str:
    lines = [f"suture-fem: results in {out / 'results.json'}"]
    for rec in results["at_forces"]:
        asked = [f"{name} = {rec[key]:.4g}{unit}" for name, key, unit in
                 (("USUM", "usum_mm", " mm"), ("SEQV", "seqv_pa", " Pa"), ("EPTOEQV", "eptoeqv", "")) if key in rec]
        lines.append(  # only the quantities the scene asked for (output.quantities)
            f"  F = {rec['force_n']:.3g} N: {', '.join(asked)}, thread end {rec['thread_end_displacement_mm']:.4g} mm, "
            f"reaction {rec['reaction_force_n']:.6g} N"
        )
    if "error_estimate" in results:
        lines.append(f"  {results['error_estimate'].get('usum_text', 'no error estimate')}")
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
