"""Logging: the package logs to "suture_fem" (never prints); the command line shows rank 0's records."""

from __future__ import annotations

import logging
import sys
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


def quiet_compiler_logs() -> None:
    """Keep the C compiler's chatter (setuptools/distutils, run by FFCx's JIT) off the terminal.

    setuptools installs a root handler at import and distutils lowers the root level on every
    compile, so the root handlers themselves are raised to WARNING.
    """
    import setuptools  # noqa: F401  (installs its root handler now, so it can be quietened)

    for handler in logging.getLogger().handlers:
        handler.setLevel(logging.WARNING)
