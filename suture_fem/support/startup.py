"""Nothing from the current folder or a stray environment setting configures PETSc or Open MPI.

PETSc reads ``~/.petscrc``, ``./.petscrc``, ``./petscrc`` and the environment's ``PETSC_OPTIONS`` when
it starts; an option there can start a debugger running any program (``-start_in_debugger
-debug_terminal ./evil.sh``) or write any file (``-log_view :PATH``, ``-history PATH``). Here PETSc
starts with ``-skip_petscrc`` and with ``PETSC_OPTIONS`` / ``PETSC_OPTIONS_YAML`` hidden from it, so
every PETSc option comes from the scene's checked ``solver.petsc_options``.

:func:`install` (run by ``import suture_fem``) puts a finder before Python's own that starts PETSc
this way the first time anything imports ``petsc4py.PETSc``; it imports nothing itself, so
``import suture_fem`` stays cheap. A process that imported ``petsc4py.PETSc`` before ``suture_fem``
started PETSc on its own terms (``options_files_skipped`` says so).

Open MPI's settings (``OMPI_MCA_*``, ``PMIX_MCA_*``) are the user's or the batch system's and are
honoured, except those that load plug-ins from a folder, read parameter files or name a program to
start: :func:`check_environment` refuses them in one line (exit 2) before MPI starts.
"""

from __future__ import annotations

import importlib.abc
import importlib.machinery
import os
import sys
from typing import Any

from suture_fem.support.errors import SutureFemError

#: PETSc's environment settings: never read (the scene's solver.petsc_options is the one source).
PETSC_ENVIRONMENT = ("PETSC_OPTIONS", "PETSC_OPTIONS_YAML")
#: The arguments PETSc starts with: no option file (~/.petscrc, ./.petscrc, ./petscrc) is read.
PETSC_ARGS = ("suture-fem", "-skip_petscrc")
#: Parts of an Open MPI / PMIx parameter name that load code, read a parameter file or start a program.
MPI_REFUSED = ("component_path", "param_file", "envar_file", "_agent", "debugger", "output_filename")
MPI_PREFIXES = ("OMPI_MCA_", "PMIX_MCA_", "PRTE_MCA_")


class EnvironmentRefused(SutureFemError):
    """An environment setting would load code, read a file or start a program (exit code 2)."""

    exit_code = 2


def check_environment(environ: Any = None) -> list[str]:
    """Refuse the Open MPI settings that load or run code; returns the PETSc settings that are ignored.

    Raises:
        EnvironmentRefused: one line naming the variable and why.
    """
    environ = os.environ if environ is None else environ
    for name in sorted(environ):
        if name.startswith(MPI_PREFIXES) and any(part in name.lower() for part in MPI_REFUSED):
            raise EnvironmentRefused(
                f"environment variable {name} is refused: it makes Open MPI load plug-ins, read a parameter "
                f"file or start a program (settings naming {', '.join(MPI_REFUSED)}); unset it")
    return [name for name in PETSC_ENVIRONMENT if environ.get(name)]


_started: dict[str, Any] = {}


def start_petsc() -> None:
    """Start PETSc without option files and without ``PETSC_OPTIONS`` (once per process; then a no-op)."""
    if "petsc4py.PETSc" in sys.modules or _started:
        _started.setdefault("skipped", False)
        return
    import petsc4py

    hidden = {name: os.environ.pop(name) for name in PETSC_ENVIRONMENT if name in os.environ}
    try:
        petsc4py.init(list(PETSC_ARGS))
    finally:
        os.environ.update(hidden)  # the environment of this process and its children stays as it was
    _started["skipped"] = True


def options_files_skipped() -> bool:
    """Whether this process's PETSc was started here, without option files and ``PETSC_OPTIONS``."""
    return bool(_started.get("skipped"))


class _StartPETSc(importlib.abc.MetaPathFinder):
    """The first import of ``petsc4py.PETSc`` starts PETSc through :func:`start_petsc`."""

    def find_spec(self, name: str, path: Any, target: Any = None) -> Any:
        if name != "petsc4py.PETSc" or "petsc4py.PETSc" in sys.modules:
            return None
        start_petsc()  # petsc4py.init puts the started extension module in sys.modules
        return importlib.machinery.ModuleSpec(name, _Started(), origin="petsc4py.init")


class _Started(importlib.abc.Loader):
    def create_module(self, spec: Any) -> Any:
        import petsc4py.lib

        return petsc4py.lib.ImportPETSc(None)  # the extension module petsc4py.init loaded and started

    def exec_module(self, module: Any) -> None:
        """Already executed by petsc4py.init."""


def install() -> None:
    """Start PETSc through :func:`start_petsc` whenever it is first imported (idempotent)."""
    if not any(isinstance(f, _StartPETSc) for f in sys.meta_path):
        sys.meta_path.insert(0, _StartPETSc())
