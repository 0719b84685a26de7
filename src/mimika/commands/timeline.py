"""``mimika render``, ``mimika replay``, ``mimika plot`` and ``mimika project``: scripts and
recorded takes to glTF, CSV, PNG and project files."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from mimika.commands._util import add_head_arg, add_voice_args, limit_options, size_arg
from mimika.errors import ParameterError

CSV_FORMATS = ("au", "openface", "arkit")
INPUT_FORMATS = (*CSV_FORMATS, "pyfeat")
#: reader keyword → (argparse dest, flag) of the replay options that set it
READER_FLAGS = {"fill": ("fill", "--fill"), "source": ("source", "--from"),
                "fps": ("take_fps", "--take-fps"), "scale": ("scale", "--scale"),
                "timecodes": ("timecodes", "--timecodes"), "max_gap": ("max_gap", "--max-gap")}
OUTPUTS = (".glb", ".gltf", ".vrm", ".csv", ".json", ".png", ".xml", ".mp4")
#: most tiles in a .png contact strip
MAX_SHEET = 400


def _say(args, msg: str) -> None:
    if not getattr(args, "quiet", False):
        print(msg)


def _load_timeline(path: str, rate: float | None = None):
    """A script (.xml/.ssml/.txt) or a project (.json) → (timeline, settings)."""
    from mimika.markup import load_script
    from mimika.markup.project import DEFAULT_SETTINGS, load_project

    if Path(path).suffix.lower() == ".json":
        proj = load_project(path)
        return proj.timeline, dict(proj.settings)
    return load_script(path, rate=rate), dict(DEFAULT_SETTINGS)


def _sync(args, tl):
    from mimika.timeline import synchronise

    if args.sync == "off":
        return tl
    res = synchronise(tl, mode=args.sync)
    for f in res.findings:
        if f.level != "suggestion" or args.verbose:
            print(f"mimika: {f.level}: {f.message}", file=sys.stderr)
    return res.timeline


def _supported(track, rig):
    sup = set(rig.supported)
    drop = [c for c in track.channels if c not in sup]
    if drop:
        print(f"mimika: note: the {rig.head.name!r} head does not model {', '.join(drop)}; "
              "they are left out", file=sys.stderr)
    return track.with_channels([c for c in track.channels if c in sup])


def _write_outputs(args, track, *, timeline=None, settings=None) -> None:
    out = Path(args.output)
    ext = out.suffix.lower()
    if ext not in OUTPUTS:
        raise ParameterError(f"output {str(out)!r}: use one of {', '.join(OUTPUTS)}")
    if args.format and ext != ".csv":
        raise ParameterError("--format applies to .csv outputs only")
    if ext == ".vrm" and not str(getattr(args, "head", "") or "").lower().endswith(".vrm"):
        raise ParameterError(f"output {str(out)!r}: .vrm is for a VRM avatar given as --head "
                             "(avatar.vrm); write .glb (or .gltf)")
    if ext == ".csv":
        from mimika.io.livelink import livelink_rate
        from mimika.io.tracks import write_track

        fmt = args.format or "au"
        write_track(track, out, format=fmt)
        fps = livelink_rate(track.fps) if fmt == "arkit" else track.fps
        n = track.n_frames if fps == track.fps else round(track.n_frames * fps / track.fps)
        _say(args, f"wrote {out} ({fmt} CSV, {n} frames at {fps:g} fps, "
                   f"{len(track.channels)} AUs)")
        return
    if ext in (".xml", ".json"):
        if timeline is None:
            raise ParameterError(f"{ext} output needs a script or project as input")
        if ext == ".xml":
            from mimika.io.atomic import atomic_write
            from mimika.markup import to_script

            atomic_write(out, to_script(timeline))
        else:
            from mimika.markup.project import Project, save_project

            s = dict(settings or {})
            s.update({"head": args.head, "fps": float(args.fps or s.get("fps", 25.0))})
            save_project(Project(timeline, s), out)
        _say(args, f"wrote {out}")
        return
    from mimika.face.heads import load_head

    _, rig = load_head(args.head, resolution=getattr(args, "resolution", 1))
    track = _supported(track, rig)
    if ext in (".glb", ".gltf", ".vrm"):
        from mimika.face.heads.gltf_export import avatar_export

        kept = avatar_export(rig, track)
        note = ""
        if kept is not None:  # an avatar file: written again, with the animation added
            from mimika.io.gltf_avatar import write_avatar_gltf

            write_avatar_gltf(out, kept, track)
            add, fill = kept.extras["added_morphs"], kept.extras["filled_morphs"]
            note = (f"; {kept.source.name} kept as it was, its own morphs and joints "
                    f"animated, {len(add)} morph targets added for shapes it lacked"
                    + (f", {len(fill)} empty target(s) filled" if fill else ""))
        else:
            from mimika.io.gltf import write_gltf
            from mimika.render.appearance import export_appearance

            attributes, extras = export_appearance(rig.head)
            write_gltf(out, rig, track, attributes=attributes, extras=extras)
        last = max(track.n_frames - 1, 1)
        _say(args, f"wrote {out} ({track.n_frames} frames at {track.fps:g} fps, 0–"
                   f"{last / track.fps:.2f} s, {len(track.channels)} animated AUs{note}; in "
                   f"Blender set {track.fps:g} fps before importing, frames 0–{last})")
        return
    from mimika.render import Renderer, contact_sheet, save_png

    n = max(1, min(args.frames, track.n_frames))
    idx = [round(i * (track.n_frames - 1) / max(n - 1, 1)) for i in range(n)]
    pos = rig.deform_batch(track.values[idx], track.channels)
    with Renderer(rig.head, size=args.size) as r:
        imgs = [r.render({k: v[i] for k, v in pos.items()}, view=args.view,
                         aus=track.frame(j)) for i, j in enumerate(idx)]
    sheet = contact_sheet(imgs, [f"{i / track.fps:.2f} s" for i in idx], columns=args.columns,
                          title=str(track.meta.get("source", "")) or None)
    save_png(sheet, out)
    _say(args, f"wrote {out} ({len(idx)} frames)")


def _render_video(args: argparse.Namespace, tl) -> int:
    """A spoken video of a script: its speech through espeak-ng's SSML mode, lip-sync, the
    script's events on the words they wrap, blinks and skin shading."""
    from dataclasses import replace

    from mimika.commands._util import progress_bar
    from mimika.newsreader import parse_article, render_news

    if Path(args.script).suffix.lower() == ".json":
        raise ParameterError("an .mp4 needs a script with speech (.xml/.ssml/.txt), not a "
                             "project")
    text = Path(args.script).read_text("utf-8")
    art = replace(parse_article(text, source=args.script), script=tl)
    res = render_news(art, out=args.output, lang=args.lang, head=args.head,
                      fps=float(args.fps or 25.0), layers=("blink", "skin"),
                      voice=args.voice, engine=args.engine, audio=args.audio, mood=args.mood,
                      progress=progress_bar(args.quiet, "rendering"))
    _say(args, f"wrote {res.video} ({res.n_frames} frames, {res.duration:.2f} s of speech)")
    return 0


def cmd_render(args: argparse.Namespace) -> int:
    from mimika.timeline import sample

    tl, settings = _load_timeline(args.script, rate=args.rate)
    if tl.end <= 0:
        raise ParameterError(f"{args.script}: nothing to render: the script has no text, no "
                             "element and no duration")
    tl = _sync(args, tl)
    if Path(args.output).suffix.lower() == ".mp4":
        return _render_video(args, tl)
    fps = float(args.fps or settings.get("fps", 25.0))
    track = sample(tl, fps=fps, blend=args.blend or bool(settings.get("blend")))
    track = type(track)(track.values, track.channels, track.fps,
                        {**track.meta, "source": args.script})
    _write_outputs(args, track, timeline=tl, settings=settings)
    return 0


def _reader_options(args, fmt: str) -> dict:
    """The replay options given on the command line, checked against the take's format."""
    from mimika.io.tracks import FORMAT_NAMES, READ_OPTIONS

    given = {k: getattr(args, dest) for k, (dest, _) in READER_FLAGS.items()
             if getattr(args, dest, None) is not None}
    wrong = [READER_FLAGS[k][1] for k in given if k not in READ_OPTIONS[fmt]]
    if wrong:
        raise ParameterError(f"{', '.join(wrong)} does not apply to {FORMAT_NAMES[fmt]} "
                             f"files ({args.take})")
    return given


def cmd_replay(args: argparse.Namespace) -> int:
    from mimika.io.tracks import detect_format, read_track
    from mimika.limits import check_frames

    fmt = args.input_format or detect_format(args.take)
    track = read_track(args.take, format=fmt, **_reader_options(args, fmt))
    check_frames(track.n_frames, f"take {args.take}")
    if args.fps:
        track = track.resample(fps=args.fps)
    meta = track.meta
    for note in meta.get("notes", []):
        print(f"mimika: note: {note}", file=sys.stderr)
    if meta.get("dropouts"):
        print(f"mimika: note: {args.take}: {meta['dropouts']} drop-out rows filled "
              f"({meta.get('fill', 'linear')})", file=sys.stderr)
    _write_outputs(args, track)
    return 0


def cmd_plot(args: argparse.Namespace) -> int:
    from mimika.timeline.plot import plot_track

    src = Path(args.input)
    if not args.output.lower().endswith(".png"):
        raise ParameterError(f"output {args.output!r} must be a .png file")
    if src.suffix.lower() == ".csv":
        from mimika.io.tracks import read_track

        track = read_track(src)
    else:
        from mimika.timeline import sample

        tl, settings = _load_timeline(str(src))
        track = sample(tl, fps=float(args.fps or settings.get("fps", 25.0)), blend=args.blend)
    aus = [a for part in (args.aus or "").split(",") for a in [part.strip()] if a] or None
    plot_track(track, args.output, aus=aus, title=str(src))
    _say(args, f"wrote {args.output}")
    return 0


def cmd_project(args: argparse.Namespace) -> int:
    from mimika.markup.project import Project, load_project, save_project

    if args.action == "check":
        p = load_project(args.file)
        n = sum(len(c.events) for c in p.timeline.channels)
        print(f"{args.file}: ok — {len(p.timeline.channels)} channels, {n} events, "
              f"{p.timeline.end:.2f} s, head {p.settings['head']}, {p.settings['fps']:g} fps")
        return 0
    if not args.output:
        raise ParameterError(f"'mimika project {args.action}' needs -o FILE")
    if args.action == "new":
        from mimika.markup import load_script
        from mimika.markup.project import DEFAULT_SETTINGS

        tl = load_script(args.file)
        settings = dict(DEFAULT_SETTINGS)
        if args.head:
            settings["head"] = args.head
        if args.fps:
            settings["fps"] = float(args.fps)
        save_project(Project(tl, settings), args.output)
    else:  # script
        from mimika.io.atomic import atomic_write
        from mimika.markup import to_script

        atomic_write(args.output, to_script(load_project(args.file).timeline))
    print(f"wrote {args.output}")
    return 0


def _common(p, *, head: bool = True) -> None:
    p.add_argument("-o", "--output", required=True,
                   help="output: .glb/.gltf (animated head; an avatar file --head is kept as "
                        "it was), .vrm (a VRM avatar), .csv (--format), .png (frames), "
                        ".json (project), .xml (script), .mp4 (spoken video; render only)")
    p.add_argument("--format", choices=CSV_FORMATS,
                   help="CSV layout: au (time,AU01,…; default), openface, arkit (Live Link Face)")
    p.add_argument("--fps", type=float, help="frames per second (default: project or 25)")
    if head:
        add_head_arg(p)
    p.add_argument("--view", default="front", choices=("front", "three-quarter", "profile"),
                   help="camera for .png")
    p.add_argument("--size", type=size_arg, default=(320, 240), help="tile size for .png")
    p.add_argument("--frames", type=_count(MAX_SHEET), default=8,
                   help=f"frames in a .png contact strip (1–{MAX_SHEET})")
    p.add_argument("--columns", type=_count(MAX_SHEET), default=8, help="tiles per row in a .png")
    p.add_argument("-q", "--quiet", action="store_true")
    limit_options(p, "max_duration", "max_frames", "max_text")


def _count(top: int):
    def parse(text: str) -> int:
        try:
            n = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
        if not 1 <= n <= top:
            raise argparse.ArgumentTypeError(f"{n} must be within 1…{top}")
        return n

    return parse


def register(sub) -> None:
    r = sub.add_parser("render", help="a script or project → glTF, CSV, PNG, project or script")
    r.add_argument("script", help="script (.xml, .ssml, .txt) or project (.json)")
    _common(r)
    r.add_argument("--blend", action="store_true", help="apply the AU Blender (FACS rules)")
    r.add_argument("--sync", choices=("warn", "clamp", "error", "off"), default="warn",
                   help="knowledge-base timing rules: warn (default), clamp, error or off")
    r.add_argument("--rate", type=float, help="seconds per vowel unit for text timing (0.16)")
    r.add_argument("-v", "--verbose", action="store_true", help="also show suggestions")
    r.add_argument("--lang", default="en", help="espeak language of the speech (.mp4; en)")
    add_voice_args(r)
    r.add_argument("--audio", metavar="FILE", help="a recording of the script's text (.mp4)")
    r.add_argument("--mood", help="mood of the behaviour (.mp4; default the script's)")
    r.set_defaults(func=cmd_render)

    p = sub.add_parser("replay", help="replay a recorded take (Live Link Face / OpenFace / "
                       "py-feat / AU CSV) on a head → glTF, CSV or PNG")
    p.add_argument("take", help="the CSV take")
    _common(p)
    p.add_argument("--input-format", choices=INPUT_FORMATS, help="override header detection")
    p.add_argument("--fill", choices=("linear", "nearest", "hold", "quadratic", "cubic"),
                   help="how drop-outs are filled (default linear)")
    p.add_argument("--from", dest="source", choices=("blendshapes", "aus"),
                   help="py-feat: drive the face from its blendshapes (default) or its AU "
                        "probabilities")
    p.add_argument("--take-fps", type=float, metavar="FPS",
                   help="frame rate of the recording when the file does not tell it (py-feat "
                        "video, OpenFace image sequences)")
    p.add_argument("--scale", choices=("auto", "5", "1"),
                   help="OpenFace AUxx_r scale: 5 (OpenFace), 1 (already 0–1, e.g. FACSvatar), "
                        "auto (default: 5 if any value exceeds 1 or all have OpenFace's 2 "
                        "decimals)")
    p.add_argument("--timecodes", choices=("strict", "repair"),
                   help="Live Link: refuse (default) or repair rows out of order, duplicates "
                        "and long gaps")
    p.add_argument("--max-gap", type=float, metavar="SECONDS",
                   help="Live Link: the longest gap between rows (default 2 s)")
    p.set_defaults(func=cmd_replay)

    q = sub.add_parser("plot", help="AU curves of a script, project or CSV take as a PNG")
    q.add_argument("input", help="script, project (.json) or CSV")
    q.add_argument("-o", "--output", required=True, help="PNG file")
    q.add_argument("--aus", help="comma-separated AUs to draw, e.g. AU12,AU25")
    q.add_argument("--fps", type=float)
    q.add_argument("--blend", action="store_true")
    q.add_argument("-q", "--quiet", action="store_true")
    limit_options(q, "max_duration", "max_frames", "max_text")
    q.set_defaults(func=cmd_plot)

    j = sub.add_parser("project", help="create, check or print project files")
    j.add_argument("action", choices=("new", "check", "script"),
                   help="new: script → project; check: validate; script: project → script")
    j.add_argument("file", help="script (new) or project (check, script)")
    j.add_argument("-o", "--output", help="file to write (new, script)")
    j.add_argument("--head", help="head setting (new)")
    j.add_argument("--fps", type=float, help="fps setting (new)")
    limit_options(j, "max_duration", "max_text")
    j.set_defaults(func=cmd_project)
