"""Learned expression transitions (seed 000's LSTM and an RTN-style improvement).

Importing this package is light (numpy only): torch loads when a model is trained or first
used. It registers the timeline's ``learned`` easing (:mod:`mimika.learn.interp`), which loads
the shipped model (``learn/data/transitions.pt``) on first use.
"""

from mimika.learn.interp import LearnedInterpolator, register_learned, transition

__all__ = ["LearnedInterpolator", "register_learned", "transition"]

register_learned()
