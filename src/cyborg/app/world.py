"""Which map the simulated robot drives on when none is given: Glassgården, where the thesis ran.

The thesis's robot roams the hallways of Glassgården at NTNU (9.2, fig. 9.1), and its scenarios
(10.2) were run on that map. The real scan (an ARNL ``.map`` from the public NTNU Cyborg
repository) is not shipped in the package; the default world is the first of these that exists:

1. ``$CYBORG_MAPS/glassgarden.map``;
2. ``glassgarden.map`` in the data folder's ``maps`` (``$CYBORG_DATA_DIR/maps`` or
   ``~/.local/share/cyborg/maps``);
3. ``shared/maps/glassgarden.map`` beside a checkout of the project (the developers' copy).

Without one, the robot drives on the packaged example campus and says how to get Glassgården.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Mapping, Sequence
from pathlib import Path

from cyborg.maps import default_map_path

__all__ = ["GLASSGARDEN_FILE", "GLASSGARDEN_SOURCE", "default_world", "glassgarden_candidates"]

log = logging.getLogger(__name__)

GLASSGARDEN_FILE = "glassgarden.map"
GLASSGARDEN_SOURCE = (
    "https://github.com/thentnucyborg/CyborgRobot, "
    "'UnusedNodes/Behaviour Trees 2018/cyborg/cyborg_nav/maps/glassgarden.map'"
)
"""Where the scan comes from (for the message that says how to install it)."""


def glassgarden_candidates(env: Mapping[str, str] | None = None) -> list[Path]:
    """Where the Glassgården scan is looked for, in order."""
    env = os.environ if env is None else env
    found: list[Path] = []
    if env.get("CYBORG_MAPS"):
        found.append(Path(env["CYBORG_MAPS"]) / GLASSGARDEN_FILE)
    data = Path(env["CYBORG_DATA_DIR"]) if env.get("CYBORG_DATA_DIR") else Path.home() / ".local/share/cyborg"
    found.append(data / "maps" / GLASSGARDEN_FILE)
    checkout = Path(__file__).resolve().parents[3]  # src/cyborg/app/world.py -> the checkout
    found.append(checkout.parent / "shared" / "maps" / GLASSGARDEN_FILE)
    return found


def default_world(candidates: Sequence[Path] | None = None) -> Path:
    """The Glassgården scan if one of ``candidates`` exists, else the packaged campus (with a warning)."""
    candidates = glassgarden_candidates() if candidates is None else candidates
    for path in candidates:
        if path.is_file():
            return path
    log.warning(
        "the Glassgården map was not found (looked in %s); driving on the example campus. "
        "Fix: copy glassgarden.map (from %s) to %s, or pass --map FILE",
        ", ".join(str(p) for p in candidates),
        GLASSGARDEN_SOURCE,
        candidates[0] if candidates else "~/.local/share/cyborg/maps",
    )
    return default_map_path()
