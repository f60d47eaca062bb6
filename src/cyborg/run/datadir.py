"""Where the robot keeps its data when no ``--db`` says: light on purpose (every node asks)."""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["default_data_dir"]


def default_data_dir() -> Path:
    """Where the robot keeps its databases: $CYBORG_DATA_DIR, else ~/.local/share/cyborg."""
    env = os.environ.get("CYBORG_DATA_DIR")
    return Path(env) if env else Path.home() / ".local" / "share" / "cyborg"
