"""What the voice says for numbers, dates, currency and abbreviations (en, de, pl), while the
words and sentences keep the text as written."""

import pytest

from mimika.speech.tts import split_sentences, synthesize


def _said(text, lang, **kw):
    return [p.symbol for p in synthesize(text, lang=lang, engine="espeak", **kw).phonemes
            if not p.is_pause]


@pytest.mark.parametrize(("lang", "written", "spoken"), [
    ("en", "It was 1999.", "It was nineteen ninety-nine."),
    ("en", "It cost $3.5 million.", "It cost 3.5 million dollars."),
    ("en", "Ask Dr. Smith.", "Ask Doctor Smith."),
    ("en", "On the 21st we met.", "On the twenty-first we met."),
    ("de", "Am 3. Oktober.", "Am dritten Oktober."),
    ("de", "Er wurde der 2. Sieger.", "Er wurde der zweite Sieger."),
    ("de", "Das war 1999.", "Das war neunzehnhundertneunundneunzig."),
    ("de", "Frag Dr. Weber z. B. morgen.", "Frag Doktor Weber zum Beispiel morgen."),
    ("pl", "Zapłacił 2 mln zł.", "Zapłacił 2 miliony złotych."),
    ("pl", "Spytaj np. prof. Nowaka.", "Spytaj na przykład profesor Nowaka."),
    ("de", "Um 14:30 Uhr am 1.1.2025.", "Um vierzehn Uhr dreißig am ersten Januar "
     "zweitausendfünfundzwanzig."),
    ("pl", "W 1999 r. o godz. 8 padało.", "W tysiąc dziewięćset dziewięćdziesiątym "
     "dziewiątym roku o godzinie ósmej padało."),
    ("en", "We met at 7:05 p.m. on 3/10/2024.", "We met at seven oh five p m on March tenth, "
     "twenty twenty-four."),
    ("en", "Call 0800 123 456.", "Call 0 8 0 0, 1 2 3, 4 5 6."),
    ("de", "Tel. 030 1234567.", "Telefon 0 3 0, 1 2 3 4 5 6 7."),
    ("pl", "Infolinia 801 123 456.", "Infolinia 8 0 1, 1 2 3, 4 5 6."),
])
def test_the_voice_says_what_a_newsreader_says(lang, written, spoken):
    assert _said(written, lang) == _said(spoken, lang)


@pytest.mark.parametrize(("lang", "date", "reading"), [
    ("en", "10/03/2024", "October third, twenty twenty-four"),
    ("de", "10/03/2024", "zehnter März zweitausendvierundzwanzig"),
    ("pl", "10/03/2024", "dziesiątego marca dwa tysiące dwudziestego czwartego"),
])
def test_say_as_date_is_read_as_a_date(lang, date, reading):
    doc = f'<speak>Heute <say-as interpret-as="date">{date}</say-as>.</speak>'
    u = synthesize(doc, lang=lang, ssml=True, engine="espeak")
    assert [w.text for w in u.words] == ["Heute", date]
    assert _said(doc, lang, ssml=True) == _said(f"<speak>Heute {reading}.</speak>", lang,
                                                ssml=True)


def test_say_as_time_ordinal_telephone():
    doc = ('<speak>At <say-as interpret-as="time">9:05</say-as> the '
           '<say-as interpret-as="ordinal">3</say-as> call: '
           '<say-as interpret-as="telephone">0171 234</say-as></speak>')
    plain = "<speak>At nine oh five the third call: 0 1 7 1, 2 3 4</speak>"
    assert _said(doc, "en", ssml=True) == _said(plain, "en", ssml=True)


def test_times_dates_and_years_keep_their_words_as_written():
    """A reading spans what it reads ("14:30 Uhr" is one word, as "z. B." is); no sentence
    ends inside a date or after "godz."."""
    u = synthesize("Um 14:30 Uhr am 1.1.2025 sprach er. Danach ging er.", lang="de",
                   engine="espeak")
    assert [w.text for w in u.words][:5] == ["Um", "14:30 Uhr", "am", "1.1.2025", "sprach"]
    assert [s.text for s in u.sentences] == ["Um 14:30 Uhr am 1.1.2025 sprach er.",
                                             "Danach ging er."]
    u = synthesize("O godz. 14:30 w 1999 r. padało. Potem nie.", lang="pl", engine="espeak")
    assert [w.text for w in u.words][:5] == ["O godz.", "14:30", "w", "1999", "r."]
    assert [s.text for s in u.sentences] == ["O godz. 14:30 w 1999 r. padało.", "Potem nie."]


def test_a_telephone_number_is_one_word_as_written_and_tel_ends_no_sentence():
    u = synthesize("Tel. 030 1234567. Danach nichts.", lang="de", engine="espeak")
    assert [w.text for w in u.words][:2] == ["Tel.", "030 1234567"]
    assert [s.text for s in u.sentences] == ["Tel. 030 1234567.", "Danach nichts."]


def test_german_ordinals_and_abbreviations_do_not_end_sentences():
    text = "Am 3. Oktober sprach Prof. Dr. Weber, z. B. über den 2. Platz. Danach ging er."
    assert [s for s, _ in split_sentences(text, "de")] == [
        "Am 3. Oktober sprach Prof. Dr. Weber, z. B. über den 2. Platz.", "Danach ging er."]
    u = synthesize(text, lang="de", engine="espeak")
    assert [s.text for s in u.sentences] == [s for s, _ in split_sentences(text, "de")]
    assert "3." in [w.text for w in u.words] and "z. B." in [w.text for w in u.words]
