"""The shaders' studies: :mod:`.bench`, the measuring behind ``blockhash bench`` (the lookups
against exact kNN, and the caustic pass's peers, :mod:`.splat_pass` the GL photon splat among
them), and :mod:`.gpu_compiler`, a GPU compiler's view of the shaders (registers, scratch,
occupancy on Mesa RADV's null device; ``tools/shader_stats.py``)."""
