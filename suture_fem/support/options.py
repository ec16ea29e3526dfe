"""PETSc's options database: the options a solver sets under its own prefix, removed when it is done.

PETSc 3.18 (Debian 12) holds at most 512 options in the database: a process that builds solver after solver
(a sweep, a notebook, the test suite's in-process runs) must not leave each one's options behind.
"""

from __future__ import annotations

import weakref
from typing import Any

from petsc4py import PETSc


def forget_options(prefix: str) -> None:
    """Remove every option under ``prefix`` from PETSc's options database."""
    opts = PETSc.Options()
    for key in [k for k in opts.getAll() if k.startswith(prefix)]:
        opts.delValue(key)


def forget_when_collected(owner: Any, prefix: str) -> None:
    """Remove ``prefix``'s options once ``owner`` is garbage collected, if nothing did before.

    Not at exit: the database goes with PETSc then.
    """
    weakref.finalize(owner, forget_options, prefix).atexit = False
