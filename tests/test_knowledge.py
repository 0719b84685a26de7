"""Knowledge base: every rule shows its default or its warning; lexicon; mood; CLI."""

import json
import sys

import pytest

from mimika.errors import ParameterError
from mimika.knowledge import Event, check, default_lexicon, get_mood
from mimika.knowledge.lexicon import CATEGORIES


def rules_of(report, level=None):
    return [f.rule for f in report.findings if level is None or f.level == level]


def added(report, rule):
    return [s.event for s in report.suggestions if s.rule == rule]


# -- timing (Table 6.15) ------------------------------------------------------------------------
def test_timing_outside_possible_is_an_error_with_fix():
    r = check([Event("disgust", 1.0, 3.0)])
    f = r.errors[0]
    assert f.rule == "timing.possible" and f.fix == {"duration": 2.0} and f.time == 1.0


def test_timing_outside_probable_is_a_warning():
    r = check([Event("template/grief", 0.0, 1.5)])
    assert rules_of(r, "warning") == ["timing.probable"]
    assert r.warnings[0].fix == {"duration": 0.75}
    assert not rules_of(check([Event("grief", 0.0, 0.5), Event("surprise", 0, 0.5)]), "warning")


# -- co-occurrence ------------------------------------------------------------------------------
def test_sadness_within_one_second_after_another_expression_warns():
    r = check([Event("anger", 0.0, 1.0), Event("sadness", 1.5, 1.0)])
    w = [f for f in r.warnings if f.rule == "cooc.sadness-gap"]
    assert w and w[0].fix == {"start": 2.0}
    ok = check([Event("anger", 0, 1), Event("sadness", 2.1, 1)])
    assert "cooc.sadness-gap" not in rules_of(ok)


def test_astonishment_is_framed_by_three_frames_of_surprise():
    r = check([Event("astonishment", 1.0, 0.5)])
    ev = added(r, "cooc.astonishment-surprise")
    assert [(e.start, e.duration) for e in ev] == [(pytest.approx(0.88), pytest.approx(0.12)),
                                                    (1.5, pytest.approx(0.12))]
    # accepted: no more suggestion, and the 3-frame surprises raise no timing warning
    again = check([Event("astonishment", 1.0, 0.5), *ev])
    assert "cooc.astonishment-surprise" not in rules_of(again) and not again.warnings
    # it cannot be removed
    dropped = check([Event("astonishment", 1.0, 0.5)], dropped={"cooc.astonishment-surprise"})
    assert rules_of(dropped, "error") == ["cooc.astonishment-surprise"] * 2


def test_disgust_is_combined_with_anger_and_dropping_it_warns():
    r = check([Event("disgust", 1.0, 0.8)])
    (anger,) = added(r, "cooc.disgust-anger")
    assert anger.start <= 1.0 and anger.end >= 1.8
    d = check([Event("disgust", 1.0, 0.8)], dropped={r.suggestions[0].id})
    assert rules_of(d, "warning") == ["cooc.disgust-anger"] and not d.suggestions
    assert not added(check([Event("disgust", 1, 0.8), Event("anger", 0.5, 2)]),
                     "cooc.disgust-anger")


def test_disbelief_followed_by_anger_is_a_removable_suggestion():
    r = check([Event("disbelief", 0.0, 1.0)])
    (a,) = added(r, "cooc.disbelief-anger")
    assert a.start == 1.0 and a.kind == "anger"
    d = check([Event("disbelief", 0.0, 1.0)], dropped={"cooc.disbelief-anger"})
    assert not d.findings


def test_happiness_preceded_by_surprise_is_a_removable_suggestion():
    r = check([Event("happiness", 2.0, 1.0)])
    (s,) = added(r, "cooc.happiness-surprise")
    assert s.start < 2.0 <= s.end
    assert not check([Event("happiness", 2.0, 1.0)], dropped={"cooc.happiness-surprise"}).findings


def test_grief_suggests_blending_surprise():
    r = check([Event("grief", 1.0, 0.5)])
    (s,) = added(r, "cooc.grief-surprise")
    assert (s.start, s.end) == (1.0, 1.5) and "40%" in r.suggestions[0].reason


# -- listener, mood, context -----------------------------------------------------------------------
def test_listener_too_frequent_warns_and_suggests_expressions():
    evs = [Event("template/surprise", t, 0.5) for t in range(0, 20, 2)]
    r = check(evs, role="listener")
    assert "listener.frequency" in rules_of(r, "warning")
    assert "listener.expressions" in rules_of(r, "suggestion")
    assert "listener.frequency" not in rules_of(check(evs, role="speaker"))
    with pytest.raises(ParameterError, match="role"):
        check(evs, role="audience")


@pytest.mark.parametrize(("mood", "frequency", "longer"), [
    ("depressed", "rare", True), ("irritated", "rare", True), ("nervous", "rare", True),
    ("happy", "frequent", False), ("excited", "frequent", False),
    ("confused", "frequent", False), ("embarrassed", "frequent", False),
    ("distracted", "rare", False),
])
def test_mood_table(mood, frequency, longer):
    m = get_mood(mood)
    assert m.frequency == frequency and (m.duration_scale > 1) == longer
    r = check([Event("anger", 0, 1)], mood=mood)
    assert "mood.defaults" in rules_of(r, "suggestion")


def test_mood_scales_default_durations_and_warns_on_frequency():
    slow = check(text="Is it?", mood="depressed").suggestions[0].event
    fast = check(text="Is it?", mood="happy").suggestions[0].event
    assert slow.kind == fast.kind == "surprise"
    sad = added(check([Event("disbelief", 0, 1)], mood="depressed"), "cooc.disbelief-anger")[0]
    glad = added(check([Event("disbelief", 0, 1)], mood="happy"), "cooc.disbelief-anger")[0]
    assert sad.duration > glad.duration
    evs = [Event("anger", t * 0.5, 0.5) for t in range(6)]
    assert "mood.frequency" in rules_of(check(evs, mood="depressed"), "warning")
    with pytest.raises(ParameterError, match="did you mean depressed"):
        get_mood("depresed")


def test_context_sets_intensity():
    news = check(text="Really?", context="news").suggestions[0].event.intensity
    conv = check(text="Really?", context="conversation").suggestions[0].event.intensity
    assert 0.3 <= news <= 0.5 and 0.6 <= conv <= 0.8
    with pytest.raises(ParameterError, match="context"):
        check(text="x", context="opera")


# -- text defaults ----------------------------------------------------------------------------
def test_every_question_ends_with_surprise():
    r = check(text="Is that really true? No.")
    (s,) = added(r, "text.question")
    assert s.kind == "surprise" and s.end == pytest.approx(r.constituents[0].end)
    assert not check(text="Is it true?", dropped={"text.question"}).findings


def test_a_given_linked_event_satisfies_the_default():
    r = check([Event("template/surprise", 0.5, 0.4)], text="Is it true?")
    assert not added(r, "text.question")


def test_exclamation_gives_anger():
    (a,) = added(check(text="Get out!"), "text.exclamation")
    assert a.kind == "anger" and a.duration >= 0.25


@pytest.mark.parametrize(("text", "lang", "rule"), [
    ("He was irritated by it.", "en", "text.irritation"),
    ("Er war so wütend heute.", "de", "text.irritation"),
    ("Ona się zdenerwowała wczoraj.", "pl", "text.irritation"),
    ("That is plain nonsense, really.", "en", "text.disapproval"),
    ("Das ist doch Unsinn, oder.", "de", "text.disapproval"),
    ("To są bzdury, naprawdę.", "pl", "text.disapproval"),
])
def test_irritation_and_disapproval_words_give_anger(text, lang, rule):
    r = check(text=text, lang=lang)
    ev = added(r, rule)
    assert [e.kind for e in ev] == ["anger"]
    d = check(text=text, lang=lang, dropped={rule})
    assert rule in rules_of(d, "warning")


@pytest.mark.parametrize(("text", "lang"), [
    ("I was so frightened then.", "en"), ("Ich hatte Angst davor.", "de"),
    ("Straszne to było wczoraj.", "pl"),
])
def test_fright_words_give_surprise_and_grief(text, lang):
    ev = added(check(text=text, lang=lang), "text.fright")
    assert sorted(e.kind for e in ev) == ["grief", "surprise"]


@pytest.mark.parametrize(("text", "lang"), [
    ("Yes, of course.", "en"), ("Sure, go ahead.", "en"), ("Well, I understand that.", "en"),
    ("Ja, das geht.", "de"), ("Ich verstehe das.", "de"), ("Tak, oczywiście.", "pl"),
    ("No, rozumiem to.", "pl"), ("Owszem, było.", "pl"),
])
def test_assent_phrases_give_surprise(text, lang):
    ev = added(check(text=text, lang=lang), "text.assent")
    assert [e.kind for e in ev] == ["surprise"]


# -- lexicon -----------------------------------------------------------------------------------
def test_lexicon_has_the_126_words_in_8_categories_and_three_languages():
    lex = default_lexicon()
    assert len(lex) == 126 and [e.no for e in lex.entries] == list(range(1, 127))
    seed = [e for e in lex.entries if e.source == "D.2"]
    assert len(seed) == 65  # App. D.2 classifies 65 words
    assert {e.category for e in lex.entries} == {*CATEGORIES, "-"}
    assert all(e.patterns[lang] for e in lex.entries for lang in ("en", "de", "pl"))


@pytest.mark.parametrize(("word", "lang", "category"), [
    ("irritating", "en", "Irritation"), ("Gniewa", "pl", "Irritation"),
    ("smutna", "pl", "Sorrow"), ("traurig", "de", "Sorrow"), ("ciekawe", "pl", "Curiosity"),
    ("fascinated", "en", "Curiosity"), ("przeraził", "pl", "Fright"),
    ("genialen", "de", "Praise"),
])
def test_lexicon_matches_inflected_forms(word, lang, category):
    assert category in {e.category for e in default_lexicon().lookup(word, lang)}


def test_lexicon_avoids_false_friends():
    lex = default_lexicon()
    assert not lex.lookup("obraz", "pl")  # picture, not offence
    assert not lex.lookup("gemeinsam", "de")  # together, not mean
    assert not lex.lookup("Sturm", "de")  # storm, not stubborn
    assert not lex.lookup("iron", "en")
    with pytest.raises(ParameterError, match="lang"):
        lex.lookup("x", "fr")


def test_lexicon_phrases():
    m = default_lexicon().find(["to", "jest", "w", "porządku"], "pl")
    assert any(x.text == "w porządku" and x.category == "Assent" for x in m)


def test_unknown_event_name_suggests():
    with pytest.raises(ParameterError, match="did you mean astonishment"):
        check([{"name": "astonishmnt", "start": 0, "duration": 1}])
    with pytest.raises(ParameterError, match="needs name, start, duration"):
        check([{"name": "anger"}])
    with pytest.raises(ParameterError, match="intensity"):
        Event("anger", 0, 1, 2.0)


# -- CLI --------------------------------------------------------------------------------------
def run_cli(argv, capsys):
    from mimika import cli
    from mimika.commands import knowledge

    parser = cli._Parser(prog="mimika")
    parser.add_argument("--debug", action="store_true")
    knowledge.register(parser.add_subparsers(dest="command", required=True,
                                             parser_class=cli._Parser))
    args = parser.parse_args(argv)
    from mimika.errors import MimikaError

    try:
        rc = int(args.func(args) or 0)
    except MimikaError as e:
        print(f"mimika: error: {e}", file=sys.stderr)
        rc = 2
    out = capsys.readouterr()
    return rc, out.out, out.err


def test_cli_blend(capsys):
    rc, out, _ = run_cli(["blend", "--au", "AU06=1", "--au", "AU07=0.8"], capsys)
    assert rc == 0 and "AU07   0" in out and "7<6" in out
    rc, out, _ = run_cli(["blend", "--au", "AU06=1", "--au", "AU07=0.8", "--json"], capsys)
    data = json.loads(out)
    assert data == {"aus": {"AU06": 1.0, "AU07": 0.0},
                    "trace": [{"rule": "7<6", "inputs": {"AU06": 1.0, "AU07": 0.8},
                               "outputs": {"AU07": 0.0}}]}
    rc, out, _ = run_cli(["blend", "--au", "6=1", "--au", "7=0.8", "--disable", "7<6"], capsys)
    assert "AU07   0.8" in out
    rc, _, err = run_cli(["blend", "--au", "AU03=1"], capsys)
    assert rc == 2 and err.count("\n") == 1 and "AU03" in err


def test_cli_expressions(capsys, tmp_path):
    lib = ["--library", str(tmp_path / "e.json")]
    rc, out, _ = run_cli(["expressions", "list", *lib], capsys)
    assert rc == 0 and "template/astonishment" in out
    rc, out, _ = run_cli(["expressions", "create", "smirk", "--au", "AU12R=0.6", *lib], capsys)
    assert rc == 0 and "saved smirk" in out
    rc, out, _ = run_cli(["expressions", "show", "smirk", "--json", *lib], capsys)
    assert json.loads(out)["aus"] == {"AU12R": 0.6}
    rc, _, err = run_cli(["expressions", "create", "anger", "--au", "AU04=1", *lib], capsys)
    assert rc == 2 and "--force" in err
    rc, out, _ = run_cli(["expressions", "delete", "smirk", *lib], capsys)
    assert rc == 0
    rc, _, err = run_cli(["expressions", "show", "smirk", *lib], capsys)
    assert rc == 2 and "unknown expression" in err


def test_cli_check(capsys, tmp_path):
    rc, out, _ = run_cli(["check", "Is it true? This is nonsense!", "--context", "news"], capsys)
    assert rc == 0 and "text.question" in out and "Disapproval" in out
    ev = tmp_path / "ev.json"
    ev.write_text(json.dumps([{"name": "disgust", "start": 0, "duration": 3}]))
    rc, out, _ = run_cli(["check", "--events", str(ev), "--json"], capsys)
    assert rc == 1 and json.loads(out)["findings"][0]["rule"] == "timing.possible"
    f = tmp_path / "script.txt"
    f.write_text("Tak, rozumiem.")
    rc, out, _ = run_cli(["check", str(f), "--lang", "pl"], capsys)
    assert "text.assent" in out
