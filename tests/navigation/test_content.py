"""The shipped content: default places and sentences are YAML data, checked with errors that say the fix."""

from __future__ import annotations

from pathlib import Path

import pytest

from cyborg.errors import ConfigError
from cyborg.navigation import content
from cyborg.navigation.content import load_places, load_sentences
from cyborg.navigation.models import ResponseType


def write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def test_the_shipped_files_load_and_are_what_a_new_database_starts_with() -> None:
    assert content.PLACES_FILE.is_file() and content.SENTENCES_FILE.is_file()
    places = load_places()
    assert places == content.DEFAULT_LOCATIONS
    assert [p.name for p in places][:2] == ["information desk", "cafeteria"]
    assert all(p.position is None for p in places)  # a map's goals place them
    sentences = load_sentences()
    assert sentences == content.DEFAULT_RESPONSES
    for kind in ResponseType:
        assert any(r.type is kind and r.emotion is None for r in sentences), kind


def test_a_broken_places_file_names_the_file_the_entry_and_the_fix(tmp_path: Path) -> None:
    path = write(
        tmp_path,
        "places.yaml",
        "- name: cafeteria\n"
        "  aliases: [canteen]\n"
        "  pleasantness: 1.5\n"
        "- name: kiosk\n"
        "  aliases: [canteen]\n"
        "- name: hall\n"
        "  colour: red\n"
        "- name: '!!'\n"
        "- aliases: [x]\n",
    )
    with pytest.raises(ConfigError) as caught:
        load_places(path)
    problems = caught.value.problems
    text = str(caught.value)
    assert all(line.startswith(f"{path}: ") for line in text.splitlines())
    assert any(
        "place 1 ('cafeteria')" in p and "pleasantness" in p and "1.5" in p and "fix:" in p for p in problems
    )
    assert any("place 5 > name: missing 'name'; fix:" in p for p in problems)
    assert any("place 3 ('hall')" in p and "unknown key 'colour'" in p for p in problems)
    assert any("place 4 ('!!')" in p and "no letters or digits" in p for p in problems)
    # the bad first entry is left out, so the second one's alias is not reported as taken
    assert not any("already used" in p for p in problems)


def test_a_place_name_or_alias_used_twice_is_refused(tmp_path: Path) -> None:
    path = write(tmp_path, "places.yaml", "- name: cafeteria\n  aliases: [canteen]\n- name: Canteen\n")
    with pytest.raises(
        ConfigError, match=r"place 2 \('Canteen'\): 'Canteen' is already used by place 'cafeteria'"
    ):
        load_places(path)


def test_yaml_that_reads_as_no_text_is_refused_with_the_fix(tmp_path: Path) -> None:
    path = write(tmp_path, "places.yaml", "- name: hall\n  aliases: [no, lift]\n")
    with pytest.raises(
        ConfigError,
        match=r"place 1 \('hall'\) > aliases > entry 1: must be text, not the boolean false; fix: .*'no'",
    ):
        load_places(path)


def test_a_broken_sentences_file_names_the_file_the_entry_and_the_fix(tmp_path: Path) -> None:
    path = write(
        tmp_path,
        "sentences.yaml",
        "opinion:\n"
        "  - sentence: I like it.\n"  # no LOCATION
        "  - sentence: I like the LOCATION.\n"
        "  - sentence: I like the LOCATION.\n"  # twice
        "arrived:\n"
        "  - sentence: Here is the LOCATION.\n"
        "    emotion: [angry]\n"
        "opinon:\n"
        "  - sentence: typo\n",
    )
    with pytest.raises(ConfigError) as caught:
        load_sentences(path)
    problems = caught.value.problems
    assert caught.value.source == str(path)
    assert any("opinion sentence 1" in p and "lacks the placeholder LOCATION" in p for p in problems)
    assert any("opinion sentence 3" in p and "appears twice" in p and "fix:" in p for p in problems)
    assert any(
        "arrived sentence 1 > emotion: must be text" in p and "fix: give an emotion's name" in p
        for p in problems
    )
    assert any("'opinon' is no kind of sentence; fix: use one of opinion, arrived" in p for p in problems)
    assert any(p.startswith("stuck: no sentence fits any emotion") and "fix: add one" in p for p in problems)


def test_a_file_that_is_not_yaml_or_not_data_is_refused(tmp_path: Path) -> None:
    bad = write(tmp_path, "places.yaml", "- name: hall\n  aliases: [lift\n")
    with pytest.raises(ConfigError, match=r"(?s)places.yaml: not valid YAML.*line \d+.*fix:"):
        load_places(bad)
    code = write(tmp_path, "sentences.yaml", "opinion: !!python/object/apply:os.system ['true']\n")
    with pytest.raises(ConfigError, match="not valid YAML"):  # the safe loader builds no objects
        load_sentences(code)
    empty = write(tmp_path, "empty.yaml", "# nothing\n")
    with pytest.raises(ConfigError, match="it is empty; fix: it should hold a list of places"):
        load_places(empty)
    mapping = write(tmp_path, "map.yaml", "cafeteria: {}\n")
    with pytest.raises(ConfigError, match="holds a dict, not a list of places; fix:"):
        load_places(mapping)
    with pytest.raises(ConfigError, match=r"cannot read it \(.*\); fix: reinstall cyborg"):
        load_sentences(tmp_path / "missing.yaml")
