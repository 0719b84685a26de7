"""Start-up wiring: upper layers plug their features into the registries of lower layers.

Lower layers never import upper ones (``timeline`` does not know ``learn``); whoever starts a
process — the command line, a batch worker — calls :func:`load_plugins` once. Light: no torch.
"""

from __future__ import annotations

__all__ = ["load_plugins"]


def load_plugins() -> None:
    """Register every built-in plug-in (idempotent): the timeline's ``learned`` easing."""
    import mimika.learn  # noqa: F401  registers the easing; its model loads on first use
