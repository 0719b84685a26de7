"""The renderer's look for the page (lights, materials, skin shader settings, backdrop,
framing) and renderers set up with it, so the live view, PNG stills and videos match.

Two looks: ``plain`` — mimika's renders (``mimika pose``, the standard shader, grey-blue
backdrop) — and ``news`` — the newsreader's video (texture-space skin shader, warm studio
lights, news set and desk). Everything here is read from :mod:`mimika.render`.
"""

from __future__ import annotations

from dataclasses import asdict
from typing import Any

from mimika.render.camera import FILL as PLAIN_FILL

#: how much of the image height the face fills, per look (render.camera / the newsreader)
FILL = {"plain": PLAIN_FILL, "news": 0.62}


def lighting(look: str) -> Any:
    from mimika.render.lighting import NEWS, STUDIO

    return NEWS if look == "news" else STUDIO


def look_info() -> dict[str, Any]:
    """Everything the page's materials need to draw like the renderer."""
    from mimika.render.camera import FOV_Y, VIEW_ANGLES
    from mimika.render.lighting import unit
    from mimika.render.renderer import BACKFACE, load_materials
    from mimika.render.skin import SKIN_MATERIALS, SkinParams

    looks = {}
    for name in FILL:
        lit = asdict(lighting(name))
        for k in ("key_dir", "fill_dir", "rim_dir"):
            lit[k] = list(unit(lit[k]))
        looks[name] = {**lit, "fill": FILL[name], "skin_shader": name == "news"}
    from mimika.newsreader.pipeline import BUST_FILL, EYE_LINE

    # heads with a body get the newsreader's head-and-shoulders shot in the news look
    looks["news"].update(bust_fill=BUST_FILL, eye_line=EYE_LINE)
    sp = SkinParams()
    return {
        "looks": looks,
        "materials": {k: {**asdict(m), "color": list(m.color), "scatter": list(m.scatter)}
                      for k, m in load_materials().items()},
        "skin": {"materials": list(SKIN_MATERIALS), "roughness": sp.roughness,
                 "specular": sp.specular},
        "backface": BACKFACE,
        "fov": FOV_Y,
        "views": dict(VIEW_ANGLES),
        "shaders": {name: _shader(f"{name}.glsl") for name in SHADERS},
    }


#: the renderer's shaders the page runs as they are (backdrops, desk, the skin's light)
SHADERS = ("background.vert", "background.frag", "studio.frag", "desk.frag", "lights",
           "skin_light", "wrinkles")


def _shader(name: str) -> str:
    """The source of ``render/shaders/name`` without its ``#include`` lines (the page joins
    ``lights`` and ``skin_light`` itself)."""
    from importlib import resources

    text = resources.files("mimika.render").joinpath(f"shaders/{name}").read_text("utf-8")
    return "\n".join(x for x in text.splitlines() if not x.startswith("#include"))


def renderer(rig: Any, look: str, size: tuple[int, int]) -> Any:
    """A :class:`~mimika.render.Renderer` drawing ``rig``'s head in ``look``."""
    from mimika.render import Renderer
    from mimika.render.skin import SkinParams

    return Renderer(rig.head, size=size, skin_shader=SkinParams() if look == "news" else False,
                    lighting=lighting(look))


def camera(rig: Any, look: str, view: str, size: tuple[int, int]) -> Any:
    """The camera of ``view`` framed as the look frames the face (the news look: as the
    newsreader frames it, head and shoulders for heads with a body)."""
    if look == "news":
        from mimika.newsreader.pipeline import news_camera

        return news_camera(rig.head, view, size[0] / size[1])
    from mimika.render.camera import frame_head

    return frame_head(rig.head, view, aspect=size[0] / size[1], fill=FILL[look])
