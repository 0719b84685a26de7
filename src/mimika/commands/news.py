"""``mimika news``: an article read by the virtual newsreader, to MP4 (+ SRT subtitles)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from mimika.commands._util import (
    add_head_arg,
    add_light_arg,
    add_voice_args,
    limit_options,
    progress_bar,
    size_arg,
)
from mimika.errors import DataError, ParameterError

VIEWS = ("front", "three-quarter", "profile")


def title_arg(text: str) -> str:
    """``--title``: a name strap's text, checked now (one line and exit 2 when bad)."""
    from mimika.render.video import check_title

    try:
        return check_title(text)
    except ParameterError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def _say(args: argparse.Namespace, msg: str) -> None:
    if not args.quiet:
        print(msg)


def _read_article(args: argparse.Namespace) -> tuple[str, str]:
    from mimika.newsreader import example_bulletin

    if (args.article is None) == (args.example is None):
        raise ParameterError("give an article file (or - for stdin) or --example en|de, "
                             "not both or neither")
    if args.example is not None:
        return example_bulletin(args.example), f"example bulletin ({args.example})"
    from mimika.limits import check_text, current, over

    if args.article == "-":
        text = sys.stdin.read(current().max_text + 1)
        check_text(text, "the article on stdin")
        return text, "<stdin>"
    p = Path(args.article)
    try:
        size = p.stat().st_size  # not read into memory when surely too long
        if size > 4 * current().max_text:
            raise over("max_text", f"article {str(p)!r} has at least {size // 4} characters")
        return p.read_text("utf-8"), str(p)
    except FileNotFoundError:
        raise DataError(f"article {str(p)!r} does not exist") from None
    except (OSError, UnicodeDecodeError) as e:
        raise DataError(f"cannot read article {str(p)!r}: {e}") from None


def _layers(args: argparse.Namespace) -> set[str]:
    from mimika.newsreader import FEATURES, FLAG_NAMES

    on = set(FEATURES)
    for feat in FEATURES:
        if getattr(args, "no_" + FLAG_NAMES[feat].replace("-", "_")):
            on.discard(feat)
    return on


def cmd_news(args: argparse.Namespace) -> int:
    from mimika.limits import check_count
    from mimika.newsreader import parse_article, render_ablations, render_news
    from mimika.speech.espeak import check_lang

    text, source = _read_article(args)
    lang = args.lang or (args.example or "en")
    check_lang(lang)
    if args.workers is not None and args.workers < 1:
        raise ParameterError(f"--workers={args.workers} must be 1 or more")
    if args.workers is not None:
        check_count("max_workers", args.workers, "--workers")
    if args.ablations is None and args.output is None:
        raise ParameterError("give the output video with -o news.mp4 (or --ablations DIR)")
    article = parse_article(text, source=source)
    if args.mood is not None:
        from mimika.knowledge import get_mood

        get_mood(args.mood)
    if args.audio is not None and args.ablations is not None:
        raise ParameterError("--audio works with -o, not with --ablations")
    kw = dict(lang=lang, head=args.head, fps=args.fps, size=args.size, view=args.view,
              voice=args.voice, rate=args.rate, samples=args.samples, seed=args.seed,
              workers=args.workers, mood=args.mood, light=args.light, engine=args.engine,
              shot=args.shot, title=args.title)
    if args.ablations is not None:
        def prog(name: str, done: int, total: int, _bars: dict = {}) -> None:  # noqa: B006
            bar = _bars.setdefault(name, progress_bar(args.quiet, f"{name:<18}"))
            if bar is not None:
                bar(done, total)

        results = render_ablations(article, out_dir=args.ablations, progress=prog, **kw)
        for r in results:
            _say(args, f"wrote {r.video} ({r.n_frames} frames, {r.duration:.2f} s)")
        _say(args, f"ablation set: {len(results)} videos in {args.ablations}")
        return 0
    res = render_news(article, out=args.output, layers=_layers(args), aus=args.aus,
                      audio=args.audio, progress=progress_bar(args.quiet, "rendering"), **kw)
    wall = res.timings.get("total", 0.0)
    _say(args, f"wrote {res.video} ({res.n_frames} frames at {res.fps:g} fps, "
               f"{res.duration:.2f} s of speech, rendered in {wall:.1f} s = "
               f"{wall / max(res.duration, 1e-9):.2f}× real time)")
    if res.subtitles is not None:
        _say(args, f"wrote {res.subtitles} (subtitles, one cue per sentence)")
    if res.aus is not None:
        _say(args, f"wrote {res.aus} (AU track, {len(res.track.channels)} AUs)")
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    from mimika.newsreader import FEATURES, FLAG_NAMES
    from mimika.newsreader.pipeline import DEFAULT_SHOT, DEFAULT_SIZE, SHOT_NAMES

    p = sub.add_parser(
        "news", help="the virtual newsreader: an article → MP4 video with SRT subtitles",
        description="Read an article (plain text, paragraphs separated by blank lines, or a "
                    "mimika <speak> script) as a virtual newsreader: speech, lip-sync, head "
                    "motion, gaze at the camera, blinks, brow raises, smiles, skin shader. "
                    "Writes an MP4 (H.264 + AAC) and an .srt beside it.")
    p.add_argument("article", nargs="?", help="article text file (- reads stdin)")
    p.add_argument("--example", choices=("en", "de"),
                   help="read the bundled example bulletin instead of a file")
    p.add_argument("-o", "--output", help="output video (.mp4); subtitles go beside it (.srt)")
    p.add_argument("--lang", help="language: en, de, pl … (default en)")
    add_head_arg(p)
    add_voice_args(p)
    p.add_argument("--audio", metavar="FILE",
                   help="a recording of the article (WAV, MP3 …, any voice): align the text "
                        "to it and use it as the sound instead of espeak-ng")
    p.add_argument("--mood", help="mood of the behaviour (happy, depressed, nervous …): how "
                                  "often and how strongly the reader nods, raises brows, smiles")
    p.add_argument("--rate", type=int, default=165, help="words per minute (165)")
    p.add_argument("--fps", type=float, default=25.0, help="frames per second (25)")
    size = "x".join(map(str, DEFAULT_SIZE))
    p.add_argument("--size", type=size_arg, default=DEFAULT_SIZE,
                   help=f"video size WxH, even numbers ({size}: HD 16:9)")
    p.add_argument("--view", choices=VIEWS, default="front", help="camera (front)")
    p.add_argument("--shot", choices=SHOT_NAMES, default=DEFAULT_SHOT,
                   help=f"framing of a character with a body: close (head and collar), "
                        f"medium (a TV medium close-up: eyes on the upper third line, head a "
                        f"third of the height, shoulders in), wide (to the desk) "
                        f"({DEFAULT_SHOT}); a bare head is framed closer at each")
    p.add_argument("--title", type=title_arg, metavar="TEXT",
                   help="a lower-third name strap over the first seconds, e.g. "
                        "'Amara Okafor — News at Nine' (name — programme)")
    p.add_argument("--samples", type=int, default=0,
                   help="multisample anti-aliasing samples (0: fastest)")
    add_light_arg(p, "news")
    p.add_argument("--seed", type=int, help="random seed of the behaviours")
    p.add_argument("--workers", type=int, metavar="N",
                   help="rendering processes (default: one per core, up to 4, for videos "
                        "over 6 s; 1 renders in this process)")
    p.add_argument("--aus", metavar="CSV", help="also write the final AU track as CSV")
    p.add_argument("--ablations", metavar="DIR",
                   help="render the seed 004 ablation set (all features, then each off) "
                        "into DIR instead of -o")
    for feat in FEATURES:
        name = FLAG_NAMES[feat]
        p.add_argument(f"--no-{name}", action="store_true", help=f"switch {name} off")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar or messages")
    limit_options(p, "max_duration", "max_frames", "max_text")
    p.set_defaults(func=cmd_news)
