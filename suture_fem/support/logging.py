"""Logging: the package logs to "suture_fem" (never prints); the command line shows rank 0's records."""

from __future__ import annotations

import logging
import os
import sys
from pathlib import Path
from typing import Any


class _RankFilter(logging.Filter):
    def __init__(self, rank: int):
        super().__init__()
        self.rank = rank

    def filter(self, record: logging.LogRecord) -> bool:
        return self.rank == 0


def setup_logging(comm: Any, verbose: bool = False) -> None:
    """Log "suture_fem" records of rank 0 to stderr (DEBUG with ``verbose``), compiler chatter off."""
    logger = logging.getLogger("suture_fem")
    logger.handlers.clear()
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("suture-fem: %(message)s"))
    handler.addFilter(_RankFilter(comm.rank))
    logger.addHandler(handler)
    logger.setLevel(logging.DEBUG if verbose else logging.INFO)
    logger.propagate = False
    quiet_compiler_logs()
    announce_compilation()


def quiet_compiler_logs() -> None:
    """Keep the C compiler's chatter (setuptools/distutils, run by FFCx's JIT) off the terminal.

    setuptools installs a root handler at import and distutils lowers the root level on every
    compile, so the root handlers themselves are raised to WARNING.
    """
    import setuptools  # noqa: F401  (installs its root handler now, so it can be quietened)

    for handler in logging.getLogger().handlers:
        handler.setLevel(logging.WARNING)


#: Wall time of the first run's form compilation (FFCx generates C, gcc compiles it; cached in
#: ~/.cache/fenics afterwards), measured for the paper scene on this project's 2-core machine.
FIRST_COMPILE_S = 10


_announced = False
_cache_checked = False


def say_compiling() -> None:
    """Log the first run's compilation notice, once per process."""
    global _announced
    if not _announced:
        _announced = True
        logging.getLogger("suture_fem").info("compiling forms (first run only, about %d s; cached in ~/.cache/fenics)",
                                             FIRST_COMPILE_S)


def announce_if_nothing_cached() -> None:
    """Say it before a form is built when the form cache is empty (a first run).

    dolfinx 0.9's JIT compiles without a word (no distutils records for :class:`_CompilerNotice`), so
    on Debian 13 an empty cache is how a first run is recognised; on Debian 12 the compiler's own
    records say it too, and the notice is still said once.
    """
    global _cache_checked
    if _announced or _cache_checked:
        return
    _cache_checked = True  # once per process: the cache only fills from here on
    cache = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "fenics"
    if not cache.is_dir() or not any(cache.iterdir()):
        say_compiling()


class _CompilerNotice(logging.Handler):
    """The compiler's lines (root-logger records of distutils) to "suture_fem" at DEBUG, with one notice.

    The first time FFCx's JIT builds a C extension in this process, "compiling forms (first run
    only, about N s)" is logged once at INFO; the gcc command lines go to DEBUG (``-v`` shows them).
    """

    def __init__(self) -> None:
        super().__init__(logging.DEBUG)

    def emit(self, record: logging.LogRecord) -> None:
        if record.name != "root":
            return
        message = record.getMessage()
        logger = logging.getLogger("suture_fem")
        if message.startswith("building 'libffcx"):
            say_compiling()
        logger.debug("compiler: %s", message)


def announce_compilation() -> None:
    """Install the one-line notice of the first run's form compilation (once per process)."""
    root = logging.getLogger()
    if not any(isinstance(h, _CompilerNotice) for h in root.handlers):
        root.addHandler(_CompilerNotice())
