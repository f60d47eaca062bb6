"""A place added to the navigation database (as `cyborg db locations add` does) is heard after the next reload."""

from __future__ import annotations

from pathlib import Path

from cyborg.hearing.module import SpeechInput
from cyborg.navigation.database import NavigationDatabase
from cyborg.navigation.models import Location
from cyborg.transport.clock import VirtualClock
from cyborg.transport.embedded import EmbeddedTransport


def test_a_new_place_and_its_alias_enter_the_grammar_on_the_next_look(tmp_path: Path) -> None:
    clock = VirtualClock()
    transport = EmbeddedTransport(clock)
    ears = SpeechInput(transport.node("ears"), NavigationDatabase(tmp_path / "nav.db"), reload_interval=5.0)
    editor = NavigationDatabase(tmp_path / "nav.db")
    assert ears.recogniser.grammar is not None and "library" not in ears.recogniser.grammar.jsgf

    async def main() -> None:
        editor.add_location(Location("library", aliases=("books",)))
        await clock.sleep(6.0)

    try:
        clock.run(main())
    finally:
        ears.close()
        editor.close()
        clock.close()
    grammar = ears.recogniser.grammar
    assert grammar.place_forms["library"] == "library" and grammar.place_forms["books"] == "library"
    assert grammar.canonical("where is the books") == "where is the library"
