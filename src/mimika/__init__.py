"""mimika — animate 3D faces with FACS Action Units.

The top-level namespace is light: it loads no OpenGL, torch, espeak or web code.
Heavy pieces are imported where they are used (``mimika.render``, ``mimika.face.heads.ict``).
"""

from mimika.errors import DataError, MimikaError, ParameterError
from mimika.facs import AU_CATALOGUE, parse_au, parse_au_values
from mimika.tracks import AUTrack

__version__ = "0.1.0"

__all__ = [
    "AU_CATALOGUE",
    "AUTrack",
    "DataError",
    "MimikaError",
    "ParameterError",
    "__version__",
    "parse_au",
    "parse_au_values",
]
