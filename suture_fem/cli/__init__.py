"""The ``suture-fem`` command line: argument parsing and commands only. Nothing else imports it."""

from suture_fem.cli.main import main

__all__ = ["main"]
