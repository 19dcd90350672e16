"""Everything that talks to OpenGL (moderngl over EGL, plus a few raw ctypes entry points)."""
