"""A sound device for tests, or its absence: an ALSA configuration in a folder of the test's own.

ALSA reads ``$XDG_CONFIG_HOME/alsa/asoundrc`` after the system's configuration. :func:`alsa_home`
writes one whose default device is ALSA's null device (it takes audio and gives silence, as a
speaker and a microphone that work), or a sound card that is not there (as a robot computer whose
USB speaker was pulled out); the test sets ``XDG_CONFIG_HOME`` to the folder for the processes
that should see it. espeak-ng and PortAudio (the microphone) both go through ALSA.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["alsa_home"]

_WORKING = "pcm.!default { type null }\nctl.!default { type hw card 0 }\n"
_MISSING = "pcm.!default { type hw card 29 }\nctl.!default { type hw card 29 }\n"


def alsa_home(folder: Path, *, device: bool) -> Path:
    """A folder for ``XDG_CONFIG_HOME`` whose ALSA default device works (``device``) or is missing."""
    (folder / "alsa").mkdir(parents=True, exist_ok=True)
    (folder / "alsa" / "asoundrc").write_text(_WORKING if device else _MISSING, encoding="utf-8")
    return folder
