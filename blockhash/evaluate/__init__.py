"""Evaluation: takes rendered images and photon lookups; gives their errors.

Images: :mod:`.images` reads and writes them (EXR layers and PNG through OpenImageIO),
:mod:`.imagediff` compares two renders layer by layer (RMS, FLIP), :mod:`.plots` draws
difference maps and strips, :mod:`.tolerance` measures how far a render moves from seed to
seed, :mod:`.testing` is the pytest helper that holds renders to a reference and
:mod:`.specular_identity` compares what a mirror shows with the same point seen directly.

Lookups: :mod:`.metrics` the exact k nearest (cKDTree) and the paper's section 6 metrics, on
photon sets from :mod:`.datasets` and photon maps from :mod:`.photon_maps` (the accuracy
runs on them that the tools tabulate are a study, :mod:`blockhash.studies.lookups.accuracy_runs`).
"""
