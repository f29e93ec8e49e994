"""OpenGL side of blockhash: contexts, texture packing, the GLSL library and lookups."""
