"""Text normalisation (mimika.speech.normalize): spoken forms in en / de / pl."""

from __future__ import annotations

import itertools

import pytest

from mimika.errors import ParameterError
from mimika.speech.normalize import (
    Span,
    cardinal_words,
    no_break_after,
    ordinal_words,
    say_as,
    spans,
    spoken_text,
    year_words,
)

EN = [
    ("It costs $3.5 million.", "It costs 3.5 million dollars."),
    ("$100", "100 dollars"),
    ("$1 only", "1 dollar only"),
    ("€20 and £5", "20 euros and 5 pounds"),
    ("In 1999 it rained.", "In nineteen ninety-nine it rained."),
    ("2005", "two thousand five"),
    ("since 2024", "since twenty twenty-four"),
    ("in 1900", "in nineteen hundred"),
    ("in 1066", "in 1066"),
    ("the 3rd and the 21st", "the third and the twenty-first"),
    ("the 12th and 2nd", "the twelfth and second"),
    ("Dr. Smith", "Doctor Smith"),
    ("Mr. and Mrs. Jones", "Mister and Missus Jones"),
    ("St. Paul", "Saint Paul"),
    ("fruit, e.g. apples, i.e. food", "fruit, for example apples, that is food"),
    ("pears etc. Then", "pears et cetera. Then"),
    ("pears, etc., and", "pears, et cetera, and"),
    ("Ali vs. Frazier", "Ali versus Frazier"),
    ("No. 5", "number 5"),
    ("up 50% or 3.5 %", "up 50 percent or 3.5 percent"),
    ("1,000 people", "1,000 people"),
    ("£2bn deal", "2 billion pounds deal"),
    ("call 555-1999", "call 5 5 5, 1 9 9 9"),
    ("On 3/10/2024 at 14:30", "On March tenth, twenty twenty-four at fourteen thirty"),
    ("at 7:05 p.m. Then", "at seven oh five p m. Then"),
    ("at 7:05 p.m. sharp", "at seven oh five p m sharp"),
    ("The ratio was 1:25.", "The ratio was 1:25."),
    ("13/10/2024", "13/10/2024"),
    ("the 1990s and the '80s", "the nineteen nineties and the eighties"),
    ("the 2000s, the 2010s", "the two thousands, the twenty tens"),
    ("since 2024-03-10.", "since March tenth, twenty twenty-four."),
    ("The $3.5 million deal", "The 3.5 million dollar deal"),
    ("Sen. Warren met Lt. Col. Smith Jr. today", "Senator Warren met Lieutenant Colonel Smith "
     "Junior today"),
    ("a $5 fine, the $3 million was spent", "a 5 dollar fine, the 3 million dollars was spent"),
    ("Call 555-0199 now.", "Call 5 5 5, 0 1 9 9 now."),
    ("Phone: +44 20 7946 0958.", "Phone: plus 4 4, 2 0, 7 9 4 6, 0 9 5 8."),
    ("Tel. 555 0199", "Telephone 5 5 5, 0 1 9 9"),
    ("free on 0800 123 456", "free on 0 8 0 0, 1 2 3, 4 5 6"),
    ("1 000 000 people in 1990-2000, 3-1, 007", "1 000 000 people in 1990-2000, 3-1, 007"),
]

DE = [
    ("am 3. Oktober", "am dritten Oktober"),
    ("der 2. Platz", "der zweite Platz"),
    ("den 3. und den 4. Mai", "den dritten und den vierten Mai"),
    ("an der 2. Stelle", "an der zweiten Stelle"),
    ("Berlin, 3. März", "Berlin, dritter März"),
    ("vom 21. bis zum 31. Dezember", "vom einundzwanzigsten bis zum einunddreißigsten Dezember"),
    ("Dr. Müller und Prof. Schmidt", "Doktor Müller und Professor Schmidt"),
    ("z. B. und z.B.", "zum Beispiel und zum Beispiel"),
    ("Äpfel usw. und Birnen usw.", "Äpfel und so weiter und Birnen und so weiter."),
    ("bzw. ca. Nr. 5", "beziehungsweise circa Nummer 5"),
    ("d. h. das, u. a. dies", "das heißt das, unter anderem dies"),
    ("1999 und 1848", "neunzehnhundertneunundneunzig und achtzehnhundertachtundvierzig"),
    ("im Jahr 2024", "im Jahr 2024"),
    ("3,5 Millionen Euro", "3,5 Millionen Euro"),
    ("€20 und 20 € und $5", "20 Euro und 20 Euro und 5 Dollar"),
    ("5 Mio. €", "5 Millionen Euro"),
    ("50 % mehr", "50 Prozent mehr"),
    ("Das Spiel endete 3:1. Danach", "Das Spiel endete 3:1. Danach"),
    ("um 14:30 Uhr", "um vierzehn Uhr dreißig"),
    ("gegen 9:45 kam er", "gegen neun Uhr fünfundvierzig kam er"),
    ("am 01.01.2025 um 20.15 Uhr", "am ersten Januar zweitausendfünfundzwanzig um zwanzig Uhr "
     "fünfzehn"),
    ("Der 3.10.2024 war", "Der dritte Oktober zweitausendvierundzwanzig war"),
    ("Es kostet 14.30 Euro.", "Es kostet 14.30 Euro."),
    ("in den 1990er Jahren, die 20er", "in den neunzehnhundertneunziger Jahren, die zwanziger"),
    ("Tel. 030 1234567", "Telefon 0 3 0, 1 2 3 4 5 6 7"),
    ("Rufen Sie 030/1234567 an.", "Rufen Sie 0 3 0, 1 2 3 4 5 6 7 an."),
    ("Hotline: 0800 22 33 44", "Hotline: 0 8 0 0, 2 2, 3 3, 4 4"),
    ("unter 25000 Euro", "unter 25000 Euro"),
    ("+49 (0)30 1234567", "plus 4 9, 3 0, 1 2 3 4 5 6 7"),
]

PL = [
    ("dr Kowalski i dr. Nowak", "doktor Kowalski i doktor Nowak"),
    ("prof. Nowak", "profesor Nowak"),
    ("owoce, np. jabłka", "owoce, na przykład jabłka"),
    ("tzn. dziś", "to znaczy dziś"),
    ("ul. Długa 5", "ulica Długa 5"),
    ("jabłka itd. i gruszki itp.", "jabłka i tak dalej i gruszki i tym podobne."),
    ("5 mln", "5 milionów"),
    ("2 mln zł", "2 miliony złotych"),
    ("20 zł", "20 złotych"),
    ("1 zł", "1 złoty"),
    ("22 zł", "22 złote"),
    ("50% więcej", "50 procent więcej"),
    ("w 1999 r. było", "w tysiąc dziewięćset dziewięćdziesiątym dziewiątym roku było"),
    ("w 1999 roku", "w tysiąc dziewięćset dziewięćdziesiątym dziewiątym roku"),
    ("od 2020 r. do 2024 roku", "od dwa tysiące dwudziestego roku do dwa tysiące "
     "dwudziestego czwartego roku"),
    ("w 2000 roku", "w dwutysięcznym roku"),
    ("Rok 1999 był", "Rok tysiąc dziewięćset dziewięćdziesiąty dziewiąty był"),
    ("3 października 2024 r. o godz. 14:30", "trzeciego października dwa tysiące dwudziestego "
     "czwartego roku o godzinie czternastej trzydzieści"),
    ("3.10.2024 r.", "trzeciego października dwa tysiące dwudziestego czwartego roku."),
    ("o godz. 8 rano", "o godzinie ósmej rano"),
    ("Spotkanie o 14:30.", "Spotkanie o czternastej trzydzieści."),
    ("Mecz skończył się 2:1.", "Mecz skończył się 2:1."),
    ("wyniosła 4,9 proc. w maju", "wyniosła 4,9 procent w maju"),
    ("To 5 proc. Potem", "To 5 procent. Potem"),
    ("w latach 90. było", "w latach dziewięćdziesiątych było"),
    ("Lata 80. minęły. Potem", "Lata osiemdziesiąte minęły. Potem"),
    ("od lat 70-tych", "od lat siedemdziesiątych"),
    ("m.in. posłowie, tj. 20, wg policji, w marcu br. Potem szkoła im. Kopernika",
     "między innymi posłowie, to jest 20, według policji, w marcu bieżącego roku. Potem szkoła "
     "imienia Kopernika"),
    ("$5 i €20", "5 dolarów i 20 euro"),
    ("Np. tak", "Na przykład tak"),
    ("Infolinia 801 123 456.", "Infolinia 8 0 1, 1 2 3, 4 5 6."),
    ("Dzwoń pod numer 22 123 45 67", "Dzwoń pod numer 2 2, 1 2 3, 4 5, 6 7"),
    ("tel. +48 601 234 567", "telefon plus 4 8, 6 0 1, 2 3 4, 5 6 7"),
    ("Było 1 000 000 osób", "Było 1 000 000 osób"),
]


@pytest.mark.parametrize(("text", "expected"), EN)
def test_english_corpus(text: str, expected: str) -> None:
    assert spoken_text(text, "en-us") == expected


def test_british_english_dates_put_the_day_first() -> None:
    assert spoken_text("On 3/10/2024.", "en-gb") == "On the third of October, twenty twenty-four."
    assert say_as("10/03/2024", "date", "en-gb") == "the tenth of March, twenty twenty-four"
    assert say_as("10/03", "date", "en-gb", "dm") == "the tenth of March"


@pytest.mark.parametrize(("text", "expected"), DE)
def test_german_corpus(text: str, expected: str) -> None:
    assert spoken_text(text, "de") == expected


@pytest.mark.parametrize(("text", "expected"), PL)
def test_polish_corpus(text: str, expected: str) -> None:
    assert spoken_text(text, "pl") == expected


SAY_AS = [
    ("10/03/2024", "date", "en", None, "October third, twenty twenty-four"),
    ("10/03/2024", "date", "de", None, "zehnter März zweitausendvierundzwanzig"),
    ("10.03.2024", "date", "pl", None, "dziesiątego marca dwa tysiące dwudziestego czwartego"),
    ("2024-03-10", "date", "en", "ymd", "March tenth, twenty twenty-four"),
    ("2024-03-10", "date", "de", "ymd", "zehnter März zweitausendvierundzwanzig"),
    ("2024-03-10", "date", "pl", "ymd", "dziesiątego marca dwa tysiące dwudziestego czwartego"),
    ("12/25", "date", "en", "md", "December twenty-fifth"),
    ("03/1999", "date", "de", "my", "März neunzehnhundertneunundneunzig"),
    ("03/1999", "date", "pl", "my",
     "marzec tysiąc dziewięćset dziewięćdziesiątego dziewiątego"),
    ("14:30", "time", "en", None, "fourteen thirty"),
    ("9:05", "time", "en", None, "nine oh five"),
    ("9:00 pm", "time", "en", None, "nine o'clock p m"),
    ("14:30", "time", "de", None, "vierzehn Uhr dreißig"),
    ("1:05", "time", "de", None, "ein Uhr fünf"),
    ("14:30", "time", "pl", None, "czternasta trzydzieści"),
    ("21:05", "time", "pl", None, "dwudziesta pierwsza zero pięć"),
    ("3", "ordinal", "en", None, "third"),
    ("3", "ordinal", "de", None, "dritte"),
    ("3", "ordinal", "pl", None, "trzeci"),
    ("22nd", "ordinal", "en", None, "twenty-second"),
    ("1234", "cardinal", "en", None, "one thousand two hundred thirty-four"),
    ("1234", "cardinal", "de", None, "eintausendzweihundertvierunddreißig"),
    ("1234", "cardinal", "pl", None, "tysiąc dwieście trzydzieści cztery"),
    ("1,234", "cardinal", "en", None, "one thousand two hundred thirty-four"),
    ("-7", "cardinal", "de", None, "minus sieben"),
    ("10/03/2024", "date", "pl", None, "dziesiątego marca dwa tysiące dwudziestego czwartego"),
    ("ABC", "characters", "en", None, "A B C"),
    ("A1c", "characters", "de", None, "A 1 c"),
    ("XYZ", "characters", "pl", None, "X Y Z"),
    ("+48 123 456 789", "telephone", "pl", None, "plus 4 8, 1 2 3, 4 5 6, 7 8 9"),
    ("030-1234", "telephone", "de", None, "0 3 0, 1 2 3 4"),
    ("(555) 123", "telephone", "en", None, "5 5 5, 1 2 3"),
]


@pytest.mark.parametrize(("text", "kind", "lang", "fmt", "expected"), SAY_AS)
def test_say_as(text: str, kind: str, lang: str, fmt: str | None, expected: str) -> None:
    assert say_as(text, kind, lang, fmt) == expected


def test_say_as_other_language_keeps_text_but_spaces_characters() -> None:
    assert say_as("10/03/2024", "date", "fr") == "10/03/2024"
    assert say_as("3", "ordinal", "fr") == "3"
    assert say_as("AB", "characters", "fr") == "A B"
    assert say_as("+33 12", "telephone", "fr") == "+ 3 3, 1 2"


@pytest.mark.parametrize(("text", "kind", "fmt"), [
    ("10/03", "date", "dmy"), ("45/03/2024", "date", "dmy"), ("10/03/2024", "date", "dxy"),
    ("25:00", "time", None), ("abc", "cardinal", None), ("3.5", "cardinal", None),
    ("x", "spell", None),
])
def test_say_as_refuses_what_it_cannot_read(text: str, kind: str, fmt: str | None) -> None:
    with pytest.raises(ParameterError):
        say_as(text, kind, "en", fmt)


@pytest.mark.parametrize(("n", "en", "de", "pl"), [
    (0, "zero", "null", "zero"),
    (1, "one", "eins", "jeden"),
    (17, "seventeen", "siebzehn", "siedemnaście"),
    (21, "twenty-one", "einundzwanzig", "dwadzieścia jeden"),
    (101, "one hundred one", "einhunderteins", "sto jeden"),
    (1001, "one thousand one", "eintausendeins", "tysiąc jeden"),
    (5000, "five thousand", "fünftausend", "pięć tysięcy"),
    (12345, "twelve thousand three hundred forty-five", "zwölftausenddreihundertfünfundvierzig",
     "dwanaście tysięcy trzysta czterdzieści pięć"),
    (999999, "nine hundred ninety-nine thousand nine hundred ninety-nine",
     "neunhundertneunundneunzigtausendneunhundertneunundneunzig",
     "dziewięćset dziewięćdziesiąt dziewięć tysięcy dziewięćset dziewięćdziesiąt dziewięć"),
])
def test_cardinal_words(n: int, en: str, de: str, pl: str) -> None:
    assert (cardinal_words(n, "en"), cardinal_words(n, "de"), cardinal_words(n, "pl")) == (
        en, de, pl)


def test_ordinal_words_forms() -> None:
    assert [ordinal_words(n, "de", "en") for n in (1, 7, 8, 20, 101)] == [
        "ersten", "siebten", "achten", "zwanzigsten", "einhundertersten"]
    assert [ordinal_words(n, "pl", "gen") for n in (2, 3, 31, 121)] == [
        "drugiego", "trzeciego", "trzydziestego pierwszego", "sto dwudziestego pierwszego"]
    assert ordinal_words(22, "pl", "fem") == "dwudziesta druga"
    assert [ordinal_words(n, "en") for n in (1, 5, 20, 100)] == [
        "first", "fifth", "twentieth", "one hundredth"]


def test_year_words() -> None:
    assert year_words(1999, "en") == "nineteen ninety-nine"
    assert year_words(1905, "en") == "nineteen oh five"
    assert year_words(2000, "en") == "two thousand"
    assert year_words(1848, "de") == "achtzehnhundertachtundvierzig"
    assert year_words(1900, "de") == "neunzehnhundert"
    assert year_words(2024, "de") == "zweitausendvierundzwanzig"


NO_BREAK = [
    ("am 3. Oktober", "de"), ("der 2. Platz", "de"), ("Dr. Müller kam", "de"),
    ("Prof. Schmidt", "de"), ("z. B. heute", "de"), ("Obst usw. und mehr", "de"),
    ("bzw. nicht", "de"), ("ca. 5 Meter", "de"), ("Nr. 5", "de"), ("Mr. Smith", "en"),
    ("Mrs. Smith", "en"), ("e.g. apples", "en"), ("i.e. pears", "en"), ("St. Paul", "en"),
    ("J. Smith", "en"), ("np. jabłka", "pl"), ("tzn. nie", "pl"), ("ul. Długa", "pl"),
    ("pi is 3.14", "en"), ("lata 80. minęły", "pl"), ("o godz. 8", "pl"),
]


@pytest.mark.parametrize(("text", "lang"), NO_BREAK)
def test_no_break_after_first_dot(text: str, lang: str) -> None:
    assert no_break_after(text, text.index("."), lang)


def test_no_break_inside_multi_part_abbreviations() -> None:
    text = "Er kam z. B. heute und d. h. morgen."
    dots = [i for i, ch in enumerate(text) if ch == "."]
    assert [no_break_after(text, i, "de") for i in dots] == [True, True, True, True, False]


BREAK = [
    ("Das Spiel endete 3:1. Danach", "de"), ("Er ist da. Dann", "de"),
    ("Obst usw. Dann kam er", "de"), ("apples etc. Then", "en"), ("It rained. Then", "en"),
    ("Padało. Potem", "pl"), ("Er wurde 3. Danach", "de"), ("Es war am 3.", "de"),
]


@pytest.mark.parametrize(("text", "lang"), BREAK)
def test_sentence_ends(text: str, lang: str) -> None:
    assert not no_break_after(text, text.index("."), lang)


def test_no_break_after_needs_a_dot() -> None:
    assert not no_break_after("Dr. Müller", 0, "de")
    assert not no_break_after("abc", 10, "de")


@pytest.mark.parametrize(("text", "lang", "written"), [
    ("Mr. Smith paid $3.5 million in 1999 for No. 5, e.g. 50%.", "en",
     ["Mr.", "$3.5 million", "1999", "No.", "e.g.", "%"]),
    ("Am 3. Oktober 1999 zahlte Dr. Müller z. B. €20.", "de",
     ["3.", "1999", "Dr.", "z. B.", "€20"]),
    ("W 2020 r. dr Nowak zapłacił np. 5 mln zł.", "pl", ["2020", "r.", "dr", "np.", "5 mln zł"]),
    ("Um 14:30 Uhr am 1.1.2025", "de", ["14:30 Uhr", "1.1.2025"]),
])
def test_span_offsets_point_at_the_original_text(text: str, lang: str,
                                                 written: list[str]) -> None:
    found = spans(text, lang)
    assert [text[s.start:s.end].strip() for s in found] == written
    assert all(a.end <= b.start for a, b in itertools.pairwise(found))
    rebuilt = text
    for s in reversed(found):
        rebuilt = rebuilt[:s.start] + s.spoken + rebuilt[s.end:]
    assert rebuilt == spoken_text(text, lang)


def test_span_values() -> None:
    assert spans("am 3. Oktober", "de") == [Span(3, 5, "dritten")]
    assert spans("$100", "en") == [Span(0, 4, "100 dollars")]


@pytest.mark.parametrize("lang", ["en", "en-gb", "de", "pl"])
def test_plain_text_has_no_spans(lang: str) -> None:
    text = "The quick brown fox jumps over the lazy dog, and 42 cats sleep."
    assert spans(text, lang) == []
    assert spoken_text(text, lang) == text


def test_unknown_language_is_left_alone() -> None:
    assert spans("Dr. Smith paid $100 in 1999.", "fr") == []
    assert spoken_text("Dr. Smith", "fr") == "Dr. Smith"
