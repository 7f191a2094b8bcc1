"""Pictures of worlds and rollouts: overlays through the camera, top-down stills and replays.

* ``render.style``    colours and marker sizes (the web viewer mirrors them).
* ``render.scene``    geometry: footprint polygons, the top-down view box, diverging events.
* ``render.draw``     Pillow drawing of one overlay frame, one top-down panel, the event timeline.
* ``render.compose``  whole products: overlay frames, side-by-side top-down frames, the still PNG.
* ``render.video``    h264 mp4 encoding with PyAV.
* ``render.cli``      ``physmind render``.

Imports ``world`` (types, camera, engine) and ``tools`` (edits as tool arguments), never ``planner``.
"""
