"""GLSL shader library of blockhash (shipped inside the wheel as ``blockhash.glsl``)."""
