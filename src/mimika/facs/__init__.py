"""FACS knowledge: the Action Unit catalogue and the one canonical AU naming."""

from mimika.facs.catalogue import (
    AU_CATALOGUE,
    SEED_AUS,
    ActionUnit,
    base_code,
    parse_au,
    parse_au_values,
    side_of,
)

__all__ = [
    "AU_CATALOGUE",
    "SEED_AUS",
    "ActionUnit",
    "base_code",
    "parse_au",
    "parse_au_values",
    "side_of",
]
