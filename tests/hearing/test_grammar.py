"""The grammar holds the places (said as words the dictionary knows), and what was heard maps back to a place."""

from cyborg.hearing.grammar import PlaceWords, build_grammar, number_words, spoken_forms

WORDS = {
    "el",
    "e",
    "l",
    "six",
    "sixteen",
    "entrance",
    "two",
    "cafeteria",
    "hello",
    "where",
    "is",
    "yes",
    "canteen",
}
known = WORDS.__contains__


def test_digits_become_number_words_and_unknown_letters_are_spelled() -> None:
    assert spoken_forms("entrance 2", known) == ["entrance two"]
    assert spoken_forms("el6", known) == ["el six", "e l six"]
    assert spoken_forms("e16", known) == ["e sixteen"]
    assert spoken_forms("xyzzy", known) == []
    assert number_words("42") == ["forty", "two"]
    assert number_words("007") == ["zero", "zero", "seven"]


def test_a_heard_place_comes_out_under_its_stored_name() -> None:
    grammar = build_grammar(
        [PlaceWords("el6", ("e16",)), PlaceWords("cafeteria", ("canteen",))], ["where is"], ["hello"], known
    )
    assert "<trigger> = where is;" in grammar.jsgf
    assert grammar.canonical("where is e l six") == "where is el6"
    assert grammar.canonical("where is e sixteen") == "where is el6"
    assert grammar.canonical("where is the canteen") == "where is the cafeteria"
    assert grammar.canonical("hello") == "hello"


def test_phrases_the_dictionary_cannot_say_are_left_out_and_listed() -> None:
    grammar = build_grammar([PlaceWords("xyzzy")], ["where is", "wheres"], ["hello", "yup"], known)
    assert grammar.unsayable == ("xyzzy", "wheres", "yup")
    assert grammar.phrases == ("hello",)
    assert "xyzzy" not in grammar.jsgf and "<request>" not in grammar.jsgf
