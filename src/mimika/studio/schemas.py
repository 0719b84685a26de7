"""Request bodies of the studio API (pydantic models with size and range limits)."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator

from mimika.facs import parse_au

MAX_AUS = 200
MAX_TEXT = 5000
LANGS = ("en", "de", "pl", "en-us", "en-gb")

AUValues = dict[str, float]


def _check_aus(v: dict[str, float]) -> dict[str, float]:
    if len(v) > MAX_AUS:
        raise ValueError(f"{len(v)} AUs given; at most {MAX_AUS}")
    out: dict[str, float] = {}
    for code, val in v.items():
        c = parse_au(code)  # ParameterError is a ValueError: pydantic reports it
        if not 0.0 <= float(val) <= 1.0:
            raise ValueError(f"{c}={val:g} is outside [0, 1]")
        out[c] = float(val)
    return out


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class BlendRequest(_Strict):
    aus: AUValues = Field(default_factory=dict)
    disabled: list[str] = Field(default_factory=list, max_length=100)

    check_aus = field_validator("aus")(_check_aus)


class ExpressionCreate(_Strict):
    name: str = Field(min_length=1, max_length=64, pattern=r"^[A-Za-z0-9][A-Za-z0-9 _\-/]*$")
    aus: AUValues
    onset: float = Field(0.25, ge=0, le=60)
    duration: float = Field(1.0, gt=0, le=120)
    offset: float = Field(0.25, ge=0, le=60)
    description: str = Field("", max_length=500)
    force: bool = False

    check_aus = field_validator("aus")(_check_aus)


class SampleRequest(_Strict):
    project: dict[str, Any]
    fps: float = Field(25.0, ge=1, le=120)
    duration: float | None = Field(None, gt=0, le=600)


class SpeakRequest(_Strict):
    text: str = Field(min_length=1, max_length=MAX_TEXT)
    lang: str = Field("en", pattern=r"^[a-z]{2}(-[a-z]{2})?$")
    rate: int = Field(175, ge=80, le=450)
    fps: float = Field(30.0, ge=10, le=120)
    blend: bool = False
    project: dict[str, Any] | None = None

    @field_validator("text")
    @classmethod
    def _text(cls, v: str) -> str:
        if not v.strip():
            raise ValueError("text is empty; type something to speak")
        return v


class FramesRequest(_Strict):
    project: dict[str, Any] | None = None
    fps: float = Field(30.0, ge=10, le=120)
    blend: bool = False


class ExportRequest(_Strict):
    project: dict[str, Any] | None = None
    aus: AUValues | None = None
    speech: bool = True
    fps: float = Field(30.0, ge=1, le=120)
    format: Literal["au", "openface", "arkit"] = "au"
    name: str = Field("mimika", min_length=1, max_length=64, pattern=r"^[A-Za-z0-9_\-]+$")
    #: for a pose (a project names its own): the head, view and look
    head: str | None = Field(None, max_length=200)
    view: Literal["front", "three-quarter", "profile"] = "front"
    look: Literal["plain", "news"] = "plain"
    #: speech the page has (a recording): used instead of synthesising the project's text
    speech_key: str | None = Field(None, pattern=r"^[0-9a-f]{20}$")

    check_aus = field_validator("aus")(lambda v: None if v is None else _check_aus(v))


class LatentRequest(_Strict):
    z: list[float] = Field(min_length=1, max_length=64)
    label: str | None = Field(None, max_length=64)

    @field_validator("z")
    @classmethod
    def _z(cls, v: list[float]) -> list[float]:
        if any(not -5.0 <= x <= 5.0 for x in v):
            raise ValueError("latent values must be within [-5, 5]")
        return v


class StillRequest(_Strict):
    """A PNG of one pose (``aus``) on a head, as the renderer draws it."""

    aus: AUValues = Field(default_factory=dict)
    head: str | None = Field(None, max_length=200)
    view: Literal["front", "three-quarter", "profile"] = "front"
    look: Literal["plain", "news"] = "plain"
    width: int = Field(640, ge=64, le=1920)
    height: int = Field(480, ge=64, le=1920)
    blend: bool = False
    disabled: list[str] = Field(default_factory=list, max_length=100)

    check_aus = field_validator("aus")(_check_aus)


class SheetRequest(_Strict):
    """A contact sheet of library expressions (default: all) on a head."""

    names: list[str] | None = Field(None, max_length=120)
    head: str | None = Field(None, max_length=200)
    view: Literal["front", "three-quarter", "profile"] = "front"
    look: Literal["plain", "news"] = "plain"
    tile: int = Field(200, ge=96, le=512)
    columns: int = Field(6, ge=1, le=12)
