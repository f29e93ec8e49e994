"""The photon kernels on a device: Dr.Jit, the JIT compiler under Mitsuba 3, compiles one
Python description of each stage for the CPU (LLVM, rays cast by Embree) and for an NVIDIA GPU
(CUDA, rays cast by OptiX).  :mod:`.choice` picks the device (``auto``, ``cpu``, ``gpu`` or
``host``, the numpy, numba and embree code that stays as the oracle), :mod:`.geometry` holds a
scene's triangles and materials as device arrays, :mod:`.emission` and :mod:`.caustic` emit and
trace the caustic photons."""
