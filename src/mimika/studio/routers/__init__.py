"""The studio's API routers, one module per topic."""

from mimika.studio.routers import (
    export,
    expressions,
    face,
    latent,
    look,
    projects,
    recording,
    speech,
)

ROUTERS = (face.router, expressions.router, projects.router, speech.router, export.router,
           latent.router, look.router, recording.router)

__all__ = ["ROUTERS"]
