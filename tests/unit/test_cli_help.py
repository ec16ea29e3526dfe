"""Every command's ``--help`` prints its usage and exits 0 (argparse formats help strings with %)."""

from __future__ import annotations

import pytest

from suture_fem.cli.main import main

COMMANDS = ["run", "mesh", "scenes", "show", "sweep", "ledger-rung", "convergence", "reproduce", "maxload", "calibrate",
            "holding"]


@pytest.mark.parametrize("argv", [["--help"]] + [[c, "--help"] for c in COMMANDS])
def test_help_exits_zero_and_prints_usage(argv, capsys):
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 0
    assert capsys.readouterr().out.startswith("usage: suture-fem")
