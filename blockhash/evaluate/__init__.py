"""Image evaluation: takes rendered images (EXR files or arrays); gives their differences.

:mod:`.imagediff` compares two renders layer by layer (RMS, FLIP), :mod:`.plots` draws
difference maps and strips, :mod:`.tolerance` measures how far a render moves from seed
to seed, and :mod:`.testing` is the pytest helper that holds renders to a reference.
"""
