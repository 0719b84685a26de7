"""AU tracks as CSV files: one entry point for every layout mimika reads and writes.

* **AU CSV** (``au``) — ``time,AU01,AU12L,…``: :mod:`mimika.io.au_csv`.
* **OpenFace 2** (``openface``) — :mod:`mimika.io.openface`.
* **Live Link Face** (``arkit``) — :mod:`mimika.io.livelink`.
* **py-feat** (``pyfeat``, read only) — :mod:`mimika.io.pyfeat`.

:func:`read_track` recognises the layout from the header; every reader raises
:class:`~mimika.errors.DataError` naming ``file:line[:column]`` for malformed input, and
:class:`~mimika.errors.ParameterError` for options that do not apply. Writers are atomic.
"""

from __future__ import annotations

import os
from pathlib import Path

from mimika.errors import DataError, ParameterError
from mimika.io.au_csv import read_au_csv, write_au_csv
from mimika.io.gaps import FILLS, fill_gaps
from mimika.io.livelink import read_livelink_csv, write_livelink_csv
from mimika.io.openface import OPENFACE_AUS, read_openface_csv, write_openface_csv
from mimika.io.pyfeat import is_pyfeat_header, read_pyfeat_csv
from mimika.tracks import AUTrack

__all__ = ["FILLS", "FORMATS", "FORMAT_NAMES", "OPENFACE_AUS", "READ_FORMATS", "READ_OPTIONS",
           "detect_format", "fill_gaps", "read_au_csv", "read_livelink_csv",
           "read_openface_csv", "read_pyfeat_csv", "read_track", "write_au_csv",
           "write_livelink_csv", "write_openface_csv", "write_track"]

#: layouts mimika writes
FORMATS = ("au", "openface", "arkit")
#: layouts mimika reads
READ_FORMATS = (*FORMATS, "pyfeat")
_READERS = {"au": read_au_csv, "openface": read_openface_csv, "arkit": read_livelink_csv,
            "pyfeat": read_pyfeat_csv}
_WRITERS = {"au": write_au_csv, "openface": write_openface_csv, "arkit": write_livelink_csv}
#: the keyword options each reader takes
READ_OPTIONS = {"au": {"fps"}, "openface": {"fill", "face_id", "scale", "fps"},
            "arkit": {"fill", "timecode_fps", "timecodes", "max_gap"},
            "pyfeat": {"fill", "source", "fps"}}
FORMAT_NAMES = {"au": "AU CSV", "openface": "OpenFace", "arkit": "Live Link Face",
          "pyfeat": "py-feat"}


def detect_format(path: str | os.PathLike) -> str:
    """``au``, ``openface``, ``arkit`` or ``pyfeat`` from a CSV's header."""
    p = Path(path)
    try:
        with open(p, encoding="utf-8-sig", newline="") as f:
            first = f.readline(1 << 20)
    except FileNotFoundError:
        raise DataError(f"{p} does not exist") from None
    except IsADirectoryError:
        raise DataError(f"{p} is a folder, not a CSV file") from None
    except UnicodeDecodeError:
        raise DataError(f"{p}: not UTF-8 text; save the file as UTF-8 CSV") from None
    except OSError as e:
        raise DataError(f"cannot read {p}: {e.strerror or e}") from None
    cols = [c.strip() for c in first.split(",")]
    if cols[:2] == ["Timecode", "BlendShapeCount"]:
        return "arkit"
    if is_pyfeat_header(cols):
        return "pyfeat"
    if "frame" in cols and "timestamp" in cols:
        return "openface"
    if cols and cols[0].lower() == "time":
        return "au"
    shown = first[:60].strip()
    raise DataError(f"{p}:1: unknown CSV layout (header starts {shown!r}); expected 'time,AU01,"
                    "…' (AU CSV), OpenFace ('frame, face_id, timestamp, …'), Live Link Face "
                    "('Timecode,BlendShapeCount,…') or py-feat ('FaceRectX,…,frame,…')")


def read_track(path: str | os.PathLike, *, format: str | None = None, **options) -> AUTrack:
    """Read any supported CSV (``format`` auto-detected from the header). ``options`` go to
    the format's reader; one that does not apply to the file's format is an error."""
    fmt = format or detect_format(path)
    if fmt not in _READERS:
        raise ParameterError(f"format={fmt!r} must be one of {', '.join(READ_FORMATS)}")
    extra = sorted(set(options) - READ_OPTIONS[fmt])
    if extra:
        raise ParameterError(f"{', '.join(extra)} does not apply to {FORMAT_NAMES[fmt]} files "
                             f"({path})")
    return _READERS[fmt](path, **options)


def write_track(track: AUTrack, path: str | os.PathLike, *, format: str = "au",
                **options) -> Path:
    """Write ``track`` as ``au``, ``openface`` or ``arkit`` (Live Link Face) CSV, atomically."""
    if format not in _WRITERS:
        raise ParameterError(f"format={format!r} must be one of {', '.join(FORMATS)}")
    return _WRITERS[format](track, path, **options)
