"""Which GL: the EGL display vislod's contexts live on — ``auto``, ``software`` or ``device:N``.

- ``auto``: Mesa's surfaceless platform (``EGL_MESA_platform_surfaceless``). Through libglvnd it
  goes to the first vendor that offers it: NVIDIA's driver where it is installed, else Mesa
  (a GPU's render node, else llvmpipe).
- ``software``: llvmpipe even on a machine with a GPU, so one machine can compare both. The EGL
  device that offers ``EGL_MESA_device_software`` (``EGL_EXT_device_enumeration``), opened on
  the device platform (``EGL_EXT_platform_device``). Where it is the only device the GL is
  llvmpipe anyway, and the surfaceless display is used instead: VTK and moderngl's EGL backend
  open device 0 on the device platform and VTK terminates that display when a plot closes
  (which would destroy every context on it).
- ``device:N``: the N-th EGL device (``eglQueryDevicesEXT``) on the device platform. Beware:
  that display is shared with VTK and moderngl's EGL backend when they use the same device.

The choice is a *where* (ARCHITECTURE: environment variables only say where things are): the
``gl`` argument of :class:`soc.gl.context.GLContext`, else the ``VISLOD_GL`` environment
variable, else ``auto``. Displays are initialized once per process and never terminated.
"""

from __future__ import annotations

import ctypes
import os
import re
from dataclasses import dataclass

from soc.errors import GLUnavailableError
from soc.gl.raw import (
    EGL_EXTENSIONS,
    EGL_PLATFORM_DEVICE_EXT,
    EGL_PLATFORM_SURFACELESS_MESA,
    EGL_VENDOR,
    egl,
)

ENV = "VISLOD_GL"
FORMS = "'auto', 'software' or 'device:N'"
APT_HINT = "apt-get install -y libegl1 libgl1 libegl-mesa0 libgl1-mesa-dri"
SOFTWARE_EXTENSION = "EGL_MESA_device_software"
_EGL_DRM_DEVICE_FILE_EXT = 0x3233
_EGL_DRM_RENDER_NODE_FILE_EXT = 0x3377

_displays: dict[tuple, int] = {}  # (platform, device index) -> initialized EGLDisplay


@dataclass(frozen=True)
class EGLDevice:
    """One EGL device (``eglQueryDevicesEXT``).

    Attributes
    ----------
    index : int
        Its N in ``device:N``.
    extensions : tuple of str
        The device's extensions (``EGL_MESA_device_software`` marks Mesa's llvmpipe device).
    path : str
        Its DRM render node or device file, "" where it has none (the software device).
    """

    index: int
    extensions: tuple[str, ...]
    path: str

    @property
    def software(self) -> bool:
        return SOFTWARE_EXTENSION in self.extensions

    def describe(self) -> str:
        what = "software (llvmpipe)" if self.software else (self.path or "a device")
        return f"device:{self.index} = {what}"


@dataclass(frozen=True)
class GLChoice:
    """Where a context's GL comes from, resolved (see the module).

    Attributes
    ----------
    name : str
        ``"auto"``, ``"software"`` or ``"device:N"``, as chosen.
    device : int or None
        The EGL device opened on the device platform; None: the surfaceless platform.
    where : str
        In words, for results ("surfaceless platform", "EGL device:1 = software (llvmpipe)").
    """

    name: str
    device: int | None
    where: str


def egl_devices() -> list[EGLDevice]:
    """The EGL devices of this process's libEGL (empty where it cannot enumerate them)."""
    e = egl()
    client = (e.eglQueryString(None, EGL_EXTENSIONS) or b"").decode().split()
    if "EGL_EXT_device_enumeration" not in client and "EGL_EXT_device_base" not in client:
        return []
    query = _proc("eglQueryDevicesEXT", ctypes.c_uint, ctypes.c_int, ctypes.c_void_p,
                  ctypes.POINTER(ctypes.c_int))  # fmt: skip
    string = _proc("eglQueryDeviceStringEXT", ctypes.c_char_p, ctypes.c_void_p, ctypes.c_int)
    if query is None or string is None:
        return []
    n = ctypes.c_int()
    if not query(0, None, ctypes.byref(n)) or n.value <= 0:
        return []
    handles = (ctypes.c_void_p * n.value)()
    if not query(n.value, handles, ctypes.byref(n)):
        return []
    out = []
    for i, h in enumerate(handles[: n.value]):
        ext = tuple((string(h, EGL_EXTENSIONS) or b"").decode().split())
        path = b""
        if "EGL_EXT_device_drm_render_node" in ext:
            path = string(h, _EGL_DRM_RENDER_NODE_FILE_EXT) or b""
        if not path and "EGL_EXT_device_drm" in ext:
            path = string(h, _EGL_DRM_DEVICE_FILE_EXT) or b""
        out.append(EGLDevice(i, ext, path.decode()))
    return out


def resolve(gl: str | None = None) -> GLChoice:
    """The :class:`GLChoice` for ``gl`` (None: ``$VISLOD_GL``, else ``"auto"``).

    Raises
    ------
    ValueError
        If the choice is none of the accepted forms, or names a device that does not exist;
        the message lists this machine's EGL devices. Nothing is initialized before.
    GLUnavailableError
        If ``software`` is asked for and no EGL device is llvmpipe.
    """
    source = "gl" if gl is not None else ENV
    if gl is None:
        gl = os.environ.get(ENV, "").strip() or "auto"
    spec = gl.strip().lower() if isinstance(gl, str) else gl
    if spec == "auto":
        return GLChoice("auto", None, "surfaceless platform")
    if spec == "software":
        devices = egl_devices()
        soft = [d for d in devices if d.software]
        if not soft:
            raise GLUnavailableError(
                f"{source}={gl!r}: no EGL device is Mesa's llvmpipe ({SOFTWARE_EXTENSION}); "
                f"{_found(devices)}. Install Mesa's EGL: as root run `{APT_HINT}`"
            )
        if len(devices) == 1:  # llvmpipe is all there is: the surfaceless display is it
            return GLChoice("software", None, "surfaceless platform (llvmpipe, the only device)")
        return GLChoice("software", soft[0].index, f"EGL {soft[0].describe()}")
    m = re.fullmatch(r"device:(\d+)", spec) if isinstance(spec, str) else None
    if m is None:
        raise ValueError(
            f"{source}={gl!r} is not a GL choice: use {FORMS} (N = an EGL device); "
            f"{_found(egl_devices())}"
        )
    devices = egl_devices()
    index = int(m.group(1))
    if index >= len(devices):
        raise ValueError(f"{source}={gl!r}: there is no EGL device {index}; {_found(devices)}")
    return GLChoice(f"device:{index}", index, f"EGL {devices[index].describe()}")


def display(choice: GLChoice) -> int:
    """The initialized EGLDisplay of ``choice`` (made once per process, never terminated;
    initialized again should someone else have terminated it)."""
    e = egl()
    key = ("surfaceless",) if choice.device is None else ("device", choice.device)
    dpy = _displays.get(key)
    if dpy is None:
        if choice.device is None:
            extensions = (e.eglQueryString(None, EGL_EXTENSIONS) or b"").decode().split()
            if "EGL_MESA_platform_surfaceless" not in extensions:
                raise GLUnavailableError(
                    "this EGL has no EGL_MESA_platform_surfaceless (it is not Mesa's): vislod "
                    f"needs Mesa's EGL and llvmpipe: as root run `{APT_HINT}` (or `make setup`)"
                )
            dpy = e.eglGetPlatformDisplay(EGL_PLATFORM_SURFACELESS_MESA, None, None)
        else:
            handle = _device_handle(choice.device)
            dpy = e.eglGetPlatformDisplay(EGL_PLATFORM_DEVICE_EXT, handle, None)
    # eglInitialize is cheap on an initialized display, and revives a terminated one.
    if not dpy or not e.eglInitialize(dpy, None, None):
        raise GLUnavailableError(
            f"cannot open the EGL display of the {choice.where} (EGL error "
            f"0x{e.eglGetError():x}): vislod needs Mesa's EGL and llvmpipe: as root run "
            f"`{APT_HINT}` (or `make setup`)"
        )
    _displays[key] = dpy
    return dpy


def vendor(dpy: int) -> str:
    """The EGL vendor of an initialized display (e.g. "Mesa Project", "NVIDIA")."""
    return (egl().eglQueryString(dpy, EGL_VENDOR) or b"").decode()


def _found(devices: list[EGLDevice]) -> str:
    if not devices:
        return "this EGL enumerates no devices (no EGL_EXT_device_enumeration)"
    return "EGL devices found: " + ", ".join(d.describe() for d in devices)


def _device_handle(index: int) -> int:
    query = _proc("eglQueryDevicesEXT", ctypes.c_uint, ctypes.c_int, ctypes.c_void_p,
                  ctypes.POINTER(ctypes.c_int))  # fmt: skip
    n = ctypes.c_int()
    handles = (ctypes.c_void_p * (index + 1))()
    if query is None or not query(index + 1, handles, ctypes.byref(n)) or n.value <= index:
        raise GLUnavailableError(f"EGL device {index} disappeared; {_found(egl_devices())}")
    return handles[index]


def _proc(name: str, restype, *argtypes):
    """An EGL extension function through ``eglGetProcAddress`` (None where it is missing)."""
    addr = egl().eglGetProcAddress(name.encode())
    return ctypes.CFUNCTYPE(restype, *argtypes)(addr) if addr else None
