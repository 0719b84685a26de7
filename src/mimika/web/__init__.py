"""What the studio and ``mimika serve`` share, below both: the uvicorn server (:mod:`.server`),
Host validation against DNS rebinding (:mod:`.guard`), the vendored three.js (:mod:`.three`)
and a cache of loaded heads and their GLB (:mod:`.heads`)."""
