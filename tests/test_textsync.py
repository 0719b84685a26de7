"""Text synchronisation without audio (seed 002 §6.4.1, Eq 6.4–6.13)."""

import doctest

import pytest

from mimika.errors import ParameterError
from mimika.knowledge import textsync
from mimika.knowledge.textsync import (
    frame_ranges,
    gap_frames,
    linked,
    split_sentences,
    sync_text,
    tokenize,
    unit_ranges,
    vowel_units,
)


@pytest.mark.parametrize(("word", "units"), [
    ("rozumiem", 4), ("Ból", 1), ("źle", 1), ("się", 2), ("dziękuję", 4), ("Grüße", 2),
    ("Äpfel", 2), ("über", 2), ("Ärger", 2), ("brr", 1), ("?!", 1), ("...", 1), ("ąę", 2),
])
def test_vowel_units_eq_6_6(word, units):
    assert vowel_units(word) == units


def test_vowel_groups_mode():
    assert vowel_units("nie", mode="groups") == 1
    assert vowel_units("Liebe", mode="groups") == 2
    with pytest.raises(ParameterError, match="mode"):
        vowel_units("x", mode="syllables")


def test_components_are_words_and_punctuation_runs():
    assert tokenize("Oh, really?! Yes...") == [
        ("Oh", "word"), (",", "punct"), ("really", "word"), ("?!", "punct"), ("Yes", "word"),
        ("...", "punct")]
    assert [len(s) for s in split_sentences("Tak. Co?! No dobrze\n\nNowy akapit")] == [2, 2, 2, 2]


def test_unit_ranges_eq_6_7_6_8():
    assert unit_ranges([2, 1, 3]) == [(1, 2), (3, 3), (4, 6)]


def test_frame_ranges_eq_6_9_6_10():
    # a constituent over frames 10..29 (L = 20), units 2 + 1 + 2 = 5 → 4 frames per unit
    assert frame_ranges([2, 1, 2], 10, 29) == [(10, 17), (18, 21), (22, 29)]


def test_sync_text_timing_is_proportional_to_units_and_contiguous():
    cs = sync_text("Ala ma kota. Tak?", rate=0.1, start=1.0)
    assert [c.start for c in cs] == [1.0, pytest.approx(1.6)]
    assert cs[0].end == cs[1].start  # Eq 6.4
    a = cs[0].components
    assert [(c.text, c.units) for c in a] == [("Ala", 2), ("ma", 1), ("kota", 2), (".", 1)]
    assert a[0].start == 1.0 and a[0].end == pytest.approx(1.2)
    assert a[3].end == pytest.approx(cs[0].end)
    assert cs[1].is_question and not cs[0].is_question


def test_sync_text_with_known_sentence_times():
    cs = sync_text("One. Two three!", sentence_times=[(0.0, 1.0), (2.0, 4.0)])
    assert cs[1].start == 2.0 and cs[1].end == 4.0 and cs[1].is_exclamation
    with pytest.raises(ParameterError, match="sentence_times has 1 entries"):
        sync_text("One. Two.", sentence_times=[(0, 1)])
    with pytest.raises(ParameterError, match="rate"):
        sync_text("One.", rate=0)


def test_link_eq_6_12_6_13():
    assert gap_frames((0.0, 1.0), (1.48, 2.0)) == pytest.approx(12.0)
    assert linked((0.0, 1.0), (1.48, 2.0))
    assert not linked((0.0, 1.0), (1.6, 2.0))
    assert linked((0.0, 1.0), (0.5, 0.6))


def test_docstring_examples_run():
    assert doctest.testmod(textsync).failed == 0
