"""Lights of a render: a key, fill and rim light, sky/ground ambient, soft shadows from the key
and ambient occlusion, and the backdrop — as presets and a one-line spec for ``--light``.

Directions are in camera space (x right, y up, +z toward the viewer), so a light keeps its
place in the picture whatever the view; colours are linear RGB, backdrop colours sRGB.

``--light`` takes ``PRESET[,name=value …]``::

    --light studio                       # the default of pose, batch and stimuli
    --light news,shadows=off             # the newsreader set without shadows
    --light studio,key=1.3,fill=0.2,azimuth=60,elevation=40
    --light flat                         # mimika's old look: no shadows, no occlusion

names: ``key``, ``fill``, ``rim``, ``ambient`` (intensity factors, 0–4), ``azimuth`` (the
key's angle from the camera, degrees, positive from the viewer's left, −90…90),
``elevation`` (the key's height, degrees, −30…90), ``shadows`` (``soft``, ``hard`` or
``off``), ``ao`` (ambient-occlusion strength, 0–1), ``exposure`` (0.25–4).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from mimika.errors import ParameterError

V3 = tuple[float, float, float]

__all__ = ["LIGHTS", "Lighting", "light_help", "parse_light", "set_lights", "unit"]


@dataclass(frozen=True)
class Lighting:
    """Lights, shadows and backdrop. ``backdrop``: ``plain`` (grey-blue gradient) or ``studio``
    (news set); ``desk``: the height (fraction of the image) of a foreground news desk, 0 for
    none. ``shadows``: the key light's shadow — ``soft`` (filtered over a penumbra),
    ``hard`` or ``off``; ``ao``: how much ambient occlusion darkens the ambient and fill light
    in creases and cavities (0 none, 1 full)."""

    key_dir: V3 = (-0.55, 0.55, 0.62)
    key_col: V3 = (1.0, 0.93, 0.85)
    fill_dir: V3 = (0.75, 0.05, 0.55)
    fill_col: V3 = (0.30, 0.34, 0.40)
    rim_dir: V3 = (0.45, 0.55, -0.7)
    rim_col: V3 = (0.55, 0.55, 0.6)
    sky: V3 = (0.24, 0.26, 0.30)
    ground: V3 = (0.10, 0.085, 0.075)
    exposure: float = 1.05
    bg_top: V3 = (0.25, 0.28, 0.33)
    bg_bottom: V3 = (0.09, 0.10, 0.12)
    bg_glow: V3 = (0.05, 0.055, 0.06)
    backdrop: str = "plain"
    desk: float = 0.0
    shadows: str = "soft"
    ao: float = 1.0


#: mimika's look before shadows: the same three lights, no shadows, no occlusion
FLAT = Lighting(shadows="off", ao=0.0)

#: a portrait key/fill/rim set: a warm key high on the viewer's left (≈ 3:1 against the
#: fill), a cool fill, a rim from behind on the right, soft key shadows and occlusion
STUDIO = Lighting(
    key_dir=(-0.58, 0.6, 0.55),
    key_col=(1.12, 1.0, 0.88),
    fill_dir=(0.8, 0.05, 0.6),
    fill_col=(0.26, 0.29, 0.34),
    rim_dir=(0.5, 0.55, -0.65),
    rim_col=(0.6, 0.6, 0.66),
    sky=(0.22, 0.235, 0.27),
    ground=(0.09, 0.08, 0.07),
    exposure=1.08,
)

#: the newsreader studio: a warm, tungsten-like key (seed 004's viewers asked for warmer
#: light: blue/red 0.54, was 0.62), a near-neutral soft fill, warm rim, blue set behind, desk
#: in front
NEWS = Lighting(
    key_dir=(-0.62, 0.5, 0.6),
    key_col=(1.14, 0.88, 0.62),
    fill_dir=(0.8, 0.1, 0.6),
    fill_col=(0.23, 0.23, 0.27),
    rim_dir=(0.55, 0.6, -0.6),
    rim_col=(0.66, 0.54, 0.40),
    sky=(0.20, 0.205, 0.23),
    ground=(0.11, 0.085, 0.07),
    exposure=1.08,
    bg_top=(0.10, 0.15, 0.24),
    bg_bottom=(0.025, 0.035, 0.06),
    bg_glow=(0.09, 0.075, 0.06),
    backdrop="studio",
    desk=0.085,
)

#: beauty light: a broad frontal key and a strong fill, faint shadows
SOFT = replace(STUDIO, key_dir=(-0.3, 0.45, 0.84), key_col=(0.95, 0.88, 0.8),
               fill_col=(0.42, 0.44, 0.48), sky=(0.27, 0.28, 0.31), exposure=1.0)

#: low-key drama: a hard key from the side, little fill
DRAMATIC = replace(STUDIO, key_dir=(-0.85, 0.45, 0.27), key_col=(1.35, 1.2, 1.02),
                   fill_col=(0.08, 0.09, 0.11), sky=(0.1, 0.105, 0.12),
                   ground=(0.04, 0.035, 0.03), shadows="hard")

#: the presets ``--light`` names
LIGHTS: dict[str, Lighting] = {"studio": STUDIO, "news": NEWS, "soft": SOFT,
                               "dramatic": DRAMATIC, "flat": FLAT}

_FACTORS = {"key": "key_col", "fill": "fill_col", "rim": "rim_col"}
_RANGES = {"key": (0.0, 4.0), "fill": (0.0, 4.0), "rim": (0.0, 4.0), "ambient": (0.0, 4.0),
           "azimuth": (-90.0, 90.0), "elevation": (-30.0, 90.0), "ao": (0.0, 1.0),
           "exposure": (0.25, 4.0)}
_SHADOWS = ("soft", "hard", "off")


def light_help() -> str:
    """One line for the ``--light`` option's help."""
    return (f"lights: a preset ({', '.join(LIGHTS)}) and optional name=value changes, e.g. "
            "studio,key=1.2,fill=0.3,azimuth=45,elevation=35,shadows=soft,ao=1 "
            "(default: studio)")


def _scale(c: V3, k: float) -> V3:
    return (c[0] * k, c[1] * k, c[2] * k)


def parse_light(spec: str | Lighting | None, default: str = "studio") -> Lighting:
    """The :class:`Lighting` of a ``--light`` spec (see the module docstring); ``None`` gives
    the ``default`` preset. Errors are one line naming the part at fault and what is allowed."""
    if isinstance(spec, Lighting):
        return spec
    text = default if spec is None else str(spec).strip()
    name, *changes = [p.strip() for p in text.split(",")]
    where = f"--light {text!r}"
    if name not in LIGHTS:
        raise ParameterError(f"{where}: unknown preset {name!r}; presets: {', '.join(LIGHTS)}")
    lit = LIGHTS[name]
    az = el = None
    for part in changes:
        key, eq, value = part.partition("=")
        key = key.strip()
        if not eq or not key:
            raise ParameterError(f"{where}: {part!r} is not name=value (names: "
                                 f"{', '.join([*_RANGES, 'shadows'])})")
        if key == "shadows":
            if value not in _SHADOWS:
                raise ParameterError(f"{where}: shadows={value!r} must be one of "
                                     f"{', '.join(_SHADOWS)}")
            lit = replace(lit, shadows=value)
            continue
        if key not in _RANGES:
            raise ParameterError(f"{where}: unknown name {key!r}; names: "
                                 f"{', '.join([*_RANGES, 'shadows'])}")
        try:
            x = float(value)
        except ValueError:
            raise ParameterError(f"{where}: {key}={value!r} is not a number") from None
        lo, hi = _RANGES[key]
        if not (math.isfinite(x) and lo <= x <= hi):
            raise ParameterError(f"{where}: {key}={value} must be in [{lo:g}, {hi:g}]")
        if key in _FACTORS:
            lit = replace(lit, **{_FACTORS[key]: _scale(getattr(lit, _FACTORS[key]), x)})
        elif key == "ambient":
            lit = replace(lit, sky=_scale(lit.sky, x), ground=_scale(lit.ground, x))
        elif key == "azimuth":
            az = x
        elif key == "elevation":
            el = x
        else:
            lit = replace(lit, **{key: x})
    if az is not None or el is not None:
        x, y, z = lit.key_dir
        az0 = math.degrees(math.atan2(-x, z))
        el0 = math.degrees(math.asin(y / math.sqrt(x * x + y * y + z * z)))
        a, e = math.radians(az0 if az is None else az), math.radians(el0 if el is None else el)
        lit = replace(lit, key_dir=(-math.sin(a) * math.cos(e), math.sin(e),
                                    math.cos(a) * math.cos(e)))
    return lit



def unit(v: V3) -> V3:
    """``v`` scaled to length 1."""
    n = math.sqrt(sum(x * x for x in v))
    return (v[0] / n, v[1] / n, v[2] / n)


def set_lights(prog, lighting: Lighting) -> None:
    """Write ``lighting``'s lights into a shader program's uniforms (those it has)."""
    vals = {"u_key_dir": unit(lighting.key_dir), "u_key_col": lighting.key_col,
            "u_fill_dir": unit(lighting.fill_dir), "u_fill_col": lighting.fill_col,
            "u_rim_dir": unit(lighting.rim_dir), "u_rim_col": lighting.rim_col,
            "u_sky": lighting.sky, "u_ground": lighting.ground, "u_exposure": lighting.exposure,
            "u_ao": lighting.ao}
    for k, v in vals.items():
        if k in prog:
            prog[k].value = v
