"""Every ```python block of the README runs as written (each block is self-contained)."""

import os
import re
import warnings
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[2] / "README.md"
BLOCKS = re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), flags=re.S)


def test_the_readme_has_python_blocks():
    assert len(BLOCKS) >= 1         # the 30-second example; the guides hold the rest (tests/test_docs_site.py)


@pytest.mark.parametrize("index", range(len(BLOCKS)))
def test_readme_block_runs(index, tmp_path, capsys):
    if "import control" in BLOCKS[index]:
        pytest.importorskip("control")
    cwd = os.getcwd()
    os.chdir(tmp_path)                 # blocks write into out/
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            exec(compile(BLOCKS[index], f"README.md block {index}", "exec"), {"__name__": "readme"})
    finally:
        os.chdir(cwd)
