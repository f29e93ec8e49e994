"""The unbiased reference: takes a scene; gives its caustic image by light tracing
(:mod:`.lighttrace`), with no photon map and no density estimate, cached on disk by the
scene's content and the code's version.  The images of :mod:`blockhash.frame` are
measured against it.
"""
