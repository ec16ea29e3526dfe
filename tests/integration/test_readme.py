"""The README's Python example runs as written (its ```python block under "### Python API")."""

from __future__ import annotations

import re

from tests.conftest import ROOT


def readme_example() -> str:
    text = (ROOT / "README.md").read_text()
    section = text.split("### Python API", 1)[1]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)


def test_the_readme_python_example_runs(capsys):
    namespace: dict = {}
    exec(compile(readme_example(), "README.md (Python API)", "exec"), namespace)  # noqa: S102 (our own README)
    assert namespace["stiffer"].usum_mm < namespace["results"].usum_mm
    assert "USUM" in capsys.readouterr().out
