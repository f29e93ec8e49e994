"""The GL part: offscreen contexts, texture packing, the GLSL library and lookups.

Sits between the index (:mod:`blockhash.index`, which it uploads) and the renderer
(:mod:`blockhash.frame`, which draws with it); it imports the index, never the
renderer.  ``GLLookup(index).query(points)`` answers like ``index.query(points)``.
:mod:`.merge_network` generates the select=merge networks of ``glsl/bh_merge_net.glsl``.
"""

from blockhash.gl.lookup import GLLookup

__all__ = ["GLLookup"]
