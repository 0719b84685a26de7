"""mimika studio: a web editor over the library (seed 002's designer + seed 004's editor).

A FastAPI server (:func:`create_app`) with a three.js front end in ``static/``. Importing
``mimika.studio`` is light; FastAPI loads with :mod:`mimika.studio.app`.
"""

from __future__ import annotations

from typing import Any

__all__ = ["create_app"]


def create_app(*args: Any, **kwargs: Any) -> Any:
    """Build the studio's FastAPI app; see :func:`mimika.studio.app.create_app`."""
    from mimika.studio.app import create_app as _create

    return _create(*args, **kwargs)
