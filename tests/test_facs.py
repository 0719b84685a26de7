"""The FACS catalogue and the one canonical AU naming."""

import pytest

from mimika import AU_CATALOGUE, ParameterError, parse_au, parse_au_values
from mimika.facs import SEED_AUS


def test_catalogue_covers_every_facs_au():
    numbers = {a.number for a in AU_CATALOGUE.values()}
    face = set(range(1, 47)) - {3, 40}  # FACS does not use 3 or 40
    assert face <= numbers
    assert set(range(51, 59)) <= numbers
    assert set(range(61, 67)) <= numbers


def test_the_32_seed_aus_are_those_of_table_4_1():
    expected = [1, 2, 4, 5, 6, 7, 9, 10, 12, 15, 16, 17, 18, 20, 22, 23, 24, 25, 26, 27, 28, 43,
                51, 52, 53, 54, 55, 56, 61, 62, 63, 64]
    assert [AU_CATALOGUE[c].number for c in SEED_AUS] == expected


def test_seed_subobject_aus():
    sub = sorted(a.number for a in AU_CATALOGUE.values() if a.subobject)
    assert sub == [10, 16, 18, 22, 25, 27, 28]


@pytest.mark.parametrize(
    ("text", "code"),
    [("1", "AU01"), ("AU1", "AU01"), ("au12", "AU12"), ("AU012", "AU12"), ("12L", "AU12L"),
     ("au12r", "AU12R"), (6, "AU06"), (" AU 45 ", "AU45")],
)
def test_parse_au_accepts_common_spellings(text, code):
    assert parse_au(text) == code


def test_unknown_au_names_closest_codes():
    with pytest.raises(ParameterError, match=r"AU03.*did you mean AU02, AU04"):
        parse_au("AU03")
    with pytest.raises(ParameterError, match="did you mean"):
        parse_au("AU12X")


def test_head_aus_have_no_sides():
    with pytest.raises(ParameterError, match="no left/right"):
        parse_au("AU51L")


def test_parse_au_values():
    assert parse_au_values(["AU12=1", "6=0.7", "AU01", "au4=C"]) == {
        "AU12": 1.0, "AU06": 0.7, "AU01": 1.0, "AU04": pytest.approx(0.6)}
    with pytest.raises(ParameterError, match=r"outside \[0, 1\]"):
        parse_au_values(["AU12=1.5"])
    with pytest.raises(ParameterError, match="twice"):
        parse_au_values(["AU12=1", "12=0.5"])
    with pytest.raises(ParameterError, match="not a number"):
        parse_au_values(["AU12=big"])
