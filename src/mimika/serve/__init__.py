"""``mimika serve``: a headless server that gives talking agents a living face.

One WebSocket at ``/ws`` (see :mod:`mimika.serve.session` and ``serve/data/protocol.json``):
an agent sends ``speak`` (text or SSML) and gets audio and timed frames (AUs, ARKit-52
weights, head and eye rotations, visemes) sentence by sentence; ``emote``, ``look`` and
``mood`` change the face; ``interrupt`` stops speech. ``/`` serves an example page with the
embeddable three.js player (``/player.js``), ``/head.glb`` the default head.
"""
