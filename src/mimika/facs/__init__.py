"""FACS knowledge: the Action Unit catalogue and the one canonical AU naming."""

from mimika.facs.catalogue import (
    AU_CATALOGUE,
    BODY_CHANNELS,
    SEED_AUS,
    ActionUnit,
    base_code,
    is_body,
    parse_au,
    parse_au_values,
    side_of,
)

__all__ = [
    "AU_CATALOGUE",
    "BODY_CHANNELS",
    "SEED_AUS",
    "ActionUnit",
    "base_code",
    "is_body",
    "parse_au",
    "parse_au_values",
    "side_of",
]
