"""Where things are: the project, its docs, the scenario scripts and the maps in ../shared."""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]  # the project (checkout) root
DOCS = ROOT / "docs"
SCENARIOS = ROOT / "tests" / "scenarios"  # the thesis's scenarios A-D and their checks
SHARED = ROOT.parent / "shared"  # beside the checkout: the real maps, not shipped in the package
MAPS = SHARED / "maps"
GLASSGARDEN = MAPS / "glassgarden.map"
