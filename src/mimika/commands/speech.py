"""``mimika say`` / ``mimika align`` / ``mimika voices``: speech, lip-sync AU tracks, visemes."""

from __future__ import annotations

import argparse
from pathlib import Path

from mimika.commands._util import add_voice_args, limit_options
from mimika.errors import ParameterError

VISEME_FORMATS = ("oculus", "rhubarb", "mpeg4", "seed004", "talkinghead", "ovr")


def _check_suffix(path: str | None, suffixes: tuple[str, ...], what: str) -> None:
    if path and not path.lower().endswith(suffixes):
        raise ParameterError(f"{what} {path!r} must end in {' or '.join(suffixes)}")


def _write_outputs(args: argparse.Namespace, utt, *, sound_file: str) -> list[str]:
    from mimika.speech.coarticulation import mouth_track
    from mimika.speech.export import write_au_csv, write_visemes

    done = []
    track = None
    if args.aus:
        track = mouth_track(utt, fps=args.fps)
        write_au_csv(args.aus, track)
        done.append(f"{args.aus} ({track.n_frames} frames × {len(track.channels)} AUs "
                    f"at {args.fps:g} fps)")
    if args.visemes:
        write_visemes(args.visemes, utt, format=args.format, sound_file=sound_file, fps=args.fps)
        done.append(f"{args.visemes} ({args.format} visemes)")
    return done


def cmd_say(args: argparse.Namespace) -> int:
    from mimika.speech.audio import write_wav
    from mimika.speech.tts import synthesize

    _check_suffix(args.output, (".wav",), "output")
    _check_suffix(args.aus, (".csv",), "--aus")
    _check_suffix(args.visemes, (".json", ".csv"), "--visemes")
    if not (args.output or args.aus or args.visemes or args.timing):
        raise ParameterError("nothing to write; give -o FILE.wav, --aus, --visemes or --timing")
    text = args.text
    if args.text_file:
        try:
            text = Path(args.text_file).read_text("utf-8")
        except OSError as e:
            raise ParameterError(f"cannot read --text-file {args.text_file!r}: {e}") from None
    if text is None:
        raise ParameterError("give the text to speak, or --text-file FILE")
    utt = synthesize(text, lang=args.lang, voice=args.voice, rate=args.rate, pitch=args.pitch,
                     ssml=args.ssml, engine=args.engine)
    done = []
    if args.output:
        write_wav(args.output, utt.audio, sr=utt.sr)
        done.append(f"{args.output} ({utt.duration:.2f} s, {utt.sr} Hz, "
                    f"{len(utt.sentences)} sentence{'s' if len(utt.sentences) != 1 else ''}, "
                    f"{len(utt.phonemes)} phones)")
    if args.timing:
        utt.save_timing(args.timing)
        done.append(f"{args.timing} (timing)")
    done += _write_outputs(args, utt, sound_file=args.output or "")
    if not args.quiet:
        for d in done:
            print(f"wrote {d}")
    return 0


def cmd_align(args: argparse.Namespace) -> int:
    from mimika.speech.alignment import align, recognise
    from mimika.speech.audio import read_media

    _check_suffix(args.output, (".json",), "output")
    _check_suffix(args.aus, (".csv",), "--aus")
    _check_suffix(args.visemes, (".json", ".csv"), "--visemes")
    if args.transcript is not None and args.transcript_file is not None:
        raise ParameterError("give one of --transcript TEXT or --transcript-file FILE, not both")
    if not (args.output or args.aus or args.visemes):
        raise ParameterError("nothing to write; give -o timing.json, --aus or --visemes")
    text = args.transcript
    if args.transcript_file:
        try:
            text = Path(args.transcript_file).read_text("utf-8")
        except OSError as e:
            raise ParameterError(
                f"cannot read --transcript-file {args.transcript_file!r}: {e}") from None
    audio, sr = read_media(args.audio)
    if text is None:
        utt = recognise(audio, sr=sr, lang=args.lang)
    else:
        utt = align(audio, sr=sr, transcript=text, lang=args.lang, voice=args.voice,
                    engine=args.engine)
    done = []
    if args.output:
        utt.save_timing(args.output)
        done.append(f"{args.output} ({len(utt.phonemes)} phones, {len(utt.words)} words, "
                    f"{utt.duration:.2f} s, {utt.meta['engine']})")
    done += _write_outputs(args, utt, sound_file=args.audio)
    if not args.quiet:
        for d in done:
            print(f"wrote {d}")
    return 0


def cmd_voices(args: argparse.Namespace) -> int:
    from mimika.speech import piper
    from mimika.speech.espeak import check_lang, list_variants, list_voices

    if args.lang:
        check_lang(args.lang)
    neural = piper.list_voices(args.lang)
    print("Piper neural voices (--voice NAME or PATH.onnx; the first of a language is its "
          "default):")
    for v in neural:
        print(f"  {v.language:14} {v.name:32} {v.quality:8} {v.sample_rate} Hz  {v.source}")
    if not neural:
        print("  none" + ("" if piper.available() else
                          " (Piper is not installed: pip install 'mimika[speech]')"))
    print(f"  voice folders: {', '.join(str(d) for d in piper.voice_dirs())}")
    print("\nespeak-ng voices (every language; --engine espeak):")
    voices = list_voices(args.lang)
    for v in sorted(voices, key=lambda v: v.languages[0] if v.languages else ""):
        print(f"  {(v.languages[0] if v.languages else ''):16} {v.name:40} {v.gender}")
    if args.variants:
        print("\nvariants (use as --voice NAME or LANG+NAME):")
        print("  " + " ".join(list_variants()))
    return 0


def _fps(text: str) -> float:
    try:
        f = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"fps {text!r} is not a number") from None
    if not 1 <= f <= 1000:
        raise argparse.ArgumentTypeError(f"fps {text!r} must be in 1…1000")
    return f


def _outputs(q: argparse.ArgumentParser) -> None:
    q.add_argument("--aus", metavar="FILE.csv",
                   help="mouth AU track as CSV (time,AU10,…; time in seconds)")
    q.add_argument("--visemes", metavar="FILE.json",
                   help="viseme cues as JSON (see --format); FILE.csv: per-frame Oculus "
                        "viseme weights at --fps")
    q.add_argument("--format", default="oculus", choices=VISEME_FORMATS,
                   help="viseme set for --visemes (default oculus)")
    q.add_argument("--fps", type=_fps, default=25.0,
                   help="frame rate of --aus and of per-frame visemes (ovr, .csv; default 25)")
    q.add_argument("-q", "--quiet", action="store_true")


def register(sub) -> None:
    q = sub.add_parser("say", help="speak text (Piper or espeak-ng) → WAV, mouth AU CSV, "
                                   "viseme JSON")
    q.add_argument("text", nargs="?", help="text to speak (or --text-file)")
    q.add_argument("--text-file", metavar="FILE", help="read the text from a UTF-8 file")
    q.add_argument("--lang", default="en", help="espeak language: en, en-us, de, pl … (en)")
    q.add_argument("--rate", type=int, default=175, help="words per minute, 80–450 (175)")
    q.add_argument("--pitch", type=int, default=50, help="base pitch 0–100 (50; espeak-ng)")
    add_voice_args(q)
    q.add_argument("--ssml", action="store_true",
                   help="the text is SSML (<prosody rate pitch>, <break time>)")
    q.add_argument("-o", "--output", metavar="FILE.wav", help="WAV file to write (16-bit mono)")
    q.add_argument("--timing", metavar="FILE.json", help="phoneme/word/sentence timing JSON")
    _outputs(q)
    limit_options(q, "max_duration", "max_text")
    q.set_defaults(func=cmd_say)

    a = sub.add_parser("align", help="recorded speech (+ transcript) → phoneme timing, AUs, "
                                     "visemes; without a transcript the phones are recognised")
    a.add_argument("audio", help="WAV file (MP3, M4A … through PyAV)")
    a.add_argument("--transcript", help="what is said (without it: phone recognition)")
    a.add_argument("--engine", default="auto", choices=("auto", "sphinx", "dtw"),
                   help="auto: pocketsphinx for English, DTW against espeak-ng otherwise")
    a.add_argument("--transcript-file", metavar="FILE", help="read the transcript from a file")
    a.add_argument("--lang", default="en", help="espeak language of the transcript (en)")
    a.add_argument("--voice", help="espeak-ng variant of the DTW reference (f3, m2 …)")
    a.add_argument("-o", "--output", metavar="FILE.json", help="timing JSON to write")
    _outputs(a)
    limit_options(a, "max_duration")
    a.set_defaults(func=cmd_align)

    v = sub.add_parser("voices", help="list Piper neural voices and espeak-ng voices "
                                      "(and --variants)")
    v.add_argument("--lang", help="only voices for this language (prefix: en lists en-us)")
    v.add_argument("--variants", action="store_true", help="also list voice variants")
    v.set_defaults(func=cmd_voices)
