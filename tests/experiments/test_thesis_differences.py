"""REPRODUCTION.md's "Why the thesis' numbers differ": one section per compared thesis table."""

import re

from sobolev_drake import experiments as exps
from sobolev_drake.report import Claim, ExperimentResult, write_reproduction


def test_every_compared_table_is_explained():
    text = exps.thesis_differences()
    found = re.findall(r"^### Table (\d\.\d+) \(([a-z0-9-]+)\)\n(.*?)(?=^### |\Z)", text, re.M | re.S)
    sections = {table: body for table, _, body in found}
    assert sorted(sections) == sorted(exps.THESIS_TABLES)
    registered = set(exps.discover())
    for table, experiment, _ in found:
        assert experiment in registered, (table, experiment)
    for table, body in sections.items():
        # a paragraph with evidence: thesis numbers and ours, i.e. several numbers
        assert len(body.split()) >= 60, table
        assert len(re.findall(r"\d+\.\d+", body)) >= 4, table


def test_reproduction_prints_the_section(tmp_path):
    result = ExperimentResult("x", {}, {}, [Claim("c", True)], "")
    path = write_reproduction([result], tmp_path / "R.md", differences=exps.thesis_differences())
    text = path.read_text()
    assert "# Why the thesis' numbers differ" in text and "### Table 5.3 (manipulator)" in text
    assert "Why the thesis" not in write_reproduction([result], tmp_path / "S.md").read_text()
