"""Photon tracing: takes a :class:`~blockhash.scene.model.Scene`; gives caustic photons
(positions, directions, powers) for the index.

:mod:`.emission` samples photons leaving the lights, :mod:`.tracing` follows them through
mirrors and glass to the diffuse surfaces where they are stored.
"""
