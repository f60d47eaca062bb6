"""Configuration files: one way to read them and one way to word their problems.

A foundation package (it imports only :mod:`cyborg.errors`, :mod:`cyborg.limits`, PyYAML
and pydantic), so every layer can read its files the same way:

* :func:`read_text_file`, :func:`load_yaml` and :func:`read_yaml_file` read UTF-8 text and
  YAML within the limits of :mod:`cyborg.limits`, refusing duplicate keys and alias bombs;
  :class:`KeyRules` words the duplicate-key messages for a file's layout.
* :func:`describe_errors` turns a pydantic ``ValidationError`` of any model into lines
  ``where: what is wrong (what was given); fix: how``.

Reading is :mod:`~cyborg.configfile.reader`'s, wording :mod:`~cyborg.configfile.errors`'.
Every problem is raised as :class:`cyborg.errors.ConfigError`.
"""

from __future__ import annotations

from cyborg.configfile.errors import (
    Fixes,
    Location,
    Namer,
    describe_errors,
    name_location,
    suggest,
    yaml_kind,
)
from cyborg.configfile.reader import (
    PLAIN_KEYS,
    KeyRules,
    item_lines,
    key_lines,
    load_yaml,
    read_text_file,
    read_yaml_file,
    yaml_loader,
)

__all__ = [
    "PLAIN_KEYS",
    "Fixes",
    "KeyRules",
    "Location",
    "Namer",
    "describe_errors",
    "item_lines",
    "key_lines",
    "load_yaml",
    "name_location",
    "read_text_file",
    "read_yaml_file",
    "suggest",
    "yaml_kind",
    "yaml_loader",
]
