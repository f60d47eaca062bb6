"""docs/thesis.md, the page a thesis reader opens first: every row names its evidence, and it exists.

A row's last cell names tests as ``tests/FILE.py::name`` (each must be a test in that file) or a
run of a scenario script (which must exist).
"""

from __future__ import annotations

import re

from tests.support.paths import DOCS, ROOT

PAGE = DOCS / "thesis.md"
TEST = re.compile(r"`(tests/[\w/]+\.py)::(\w+)`")
RUN = re.compile(r"run `(tests/scenarios/[\w.]+\.yaml)`")


def rows() -> list[list[str]]:
    table = [line for line in PAGE.read_text(encoding="utf-8").splitlines() if line.startswith("| ")]
    cells = [[cell.strip() for cell in line.strip("|").split(" | ")] for line in table]
    return [row for row in cells if row[0] not in ("§", "---")]


def test_every_row_names_evidence_that_exists() -> None:
    found = rows()
    assert len(found) >= 20, "the page lists the thesis's items"
    for row in found:
        evidence = row[-1]
        tests, runs = TEST.findall(evidence), RUN.findall(evidence)
        assert tests or runs, f"no test or run named in the row about {row[0]}: {row}"
        for path, name in tests:
            source = (ROOT / path).read_text(encoding="utf-8")
            assert re.search(rf"^def {name}\(", source, re.MULTILINE), (
                f"{path}::{name} is no test (row {row[0]})"
            )
        for path in runs:
            assert (ROOT / path).is_file(), f"{path} does not exist (row {row[0]})"


def test_the_readme_points_a_thesis_reader_to_the_page() -> None:
    assert "docs/thesis.md" in (ROOT / "README.md").read_text(encoding="utf-8")
