"""Mitsuba 3 XML, read and written as Mitsuba 3.9 reads it.

:mod:`.importer` reads the subset blockhash models (``blockhash render scene.xml``), on
:mod:`.xml_values` (values, transforms and ``<default>`` parameters) and :mod:`.sensor` (the
sensor, film, sampler and integrator); :mod:`.exporter` writes a scene as XML with PLY meshes
(``blockhash export``) for the Mitsuba reference (:mod:`blockhash.reference.mitsuba`).
"""
