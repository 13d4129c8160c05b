"""Headless offscreen rendering of assembly scenes through OSMesa (no display, no GPU).

The renderer is pyrender (PyPI package ``pyrender2``) on PyOpenGL's OSMesa platform, which
draws in software into a memory buffer. Nothing here imports pyrender or OpenGL at module
import: the first call that renders selects the OSMesa platform
(``PYOPENGL_PLATFORM=osmesa``), checks that OpenGL was not already loaded for another
platform, and checks that ``libOSMesa`` (Debian package ``libosmesa6``) can be loaded.

One ``pyrender.OffscreenRenderer`` is kept per ``(width_px, height_px)`` and per process,
because creating the OSMesa context is the slow part (~0.25 s vs ~20 ms per 800x600 frame);
:func:`clear_renderer_cache` frees them. Each render uploads the scene's meshes and frees the
previous scene's GL buffers. Two process-wide settings are made on the first render, both
documented where they are made: ``LP_NUM_THREADS=0`` (unless set) so that processes forked
after a render can render, and value equality for PyOpenGL's opaque context pointers, without
which pyrender recompiles its shaders every frame and leaks ~3.5 MB per frame on OSMesa.

The scene items and the camera are in :mod:`asmplan.report.camera`.
"""

from __future__ import annotations

import atexit
import contextlib
import ctypes
import io
import os
import sys
import threading
from collections import OrderedDict
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from .camera import Camera, SceneItem, _union_bounds_m

__all__ = [
    "clear_renderer_cache",
    "render",
    "render_labels",
    "render_mask",
    "save_png",
]

_OSMESA_HINT = "install Debian package libosmesa6 (apt-get install libosmesa6)"
# The file names PyOpenGL's OSMesa platform tries, in its order (it returns None instead of
# raising when none loads, which later surfaces as an obscure error; so we probe first).
_OSMESA_LIBRARY_NAMES: tuple[str, ...] = (
    "libOSMesa.so",
    *(f"libOSMesa.so.{i}" for i in reversed(range(10))),
)

_AMBIENT_RGB = (0.15, 0.15, 0.15)
_HEADLIGHT_INTENSITY = 1.2
_KEY_LIGHT_INTENSITY = 1.5
_POINT_LIGHT_INTENSITY_PER_M2 = 0.4


# --------------------------------------------------------------------------------------------
# OSMesa / pyrender plumbing
# --------------------------------------------------------------------------------------------


def _check_osmesa_library(names: Sequence[str] | None = None) -> str:
    """Return the first loadable libOSMesa file name, or raise RuntimeError with a fix."""
    if names is None:
        names = _OSMESA_LIBRARY_NAMES
    errors = []
    for name in names:
        try:
            ctypes.CDLL(name, mode=ctypes.RTLD_GLOBAL)
        except OSError as error:
            errors.append(str(error))
            continue
        return name
    raise RuntimeError(
        f"offscreen rendering needs libOSMesa, which could not be loaded ({_OSMESA_HINT}); "
        f"tried {', '.join(names)}; last error: {errors[-1] if errors else 'none'}"
    )


def _import_pyrender() -> Any:
    """Select PyOpenGL's OSMesa platform, check it can work, and import pyrender."""
    os.environ.setdefault("PYOPENGL_PLATFORM", "osmesa")
    # llvmpipe rasterizes in the calling thread: up to ~1.5x slower per 800x600 frame on two
    # cores (measured 21-35 ms vs 15-22 ms for a small scene; noisy), but a process forked
    # after a render can still render (rasterizer threads do not survive fork, and Mesa then
    # hangs waiting for them).
    os.environ.setdefault("LP_NUM_THREADS", "0")
    requested = os.environ["PYOPENGL_PLATFORM"]
    if requested != "osmesa":
        raise RuntimeError(
            f"offscreen rendering needs PYOPENGL_PLATFORM=osmesa, found PYOPENGL_PLATFORM="
            f"{requested!r}; unset it or set it to 'osmesa' before OpenGL is imported"
        )
    opengl_platform = sys.modules.get("OpenGL.platform")
    loaded = getattr(opengl_platform, "PLATFORM", None)
    if loaded is not None and type(loaded).__name__ != "OSMesaPlatform":
        raise RuntimeError(
            "offscreen rendering needs PyOpenGL's OSMesa platform, but OpenGL was already "
            f"imported with {type(loaded).__module__}.{type(loaded).__name__}; set "
            "PYOPENGL_PLATFORM=osmesa before anything imports OpenGL or pyrender"
        )
    _check_osmesa_library()
    try:
        import pyrender
    except ImportError as error:
        raise RuntimeError(
            f"could not import pyrender on the OSMesa platform ({error}); "
            f"needs PyPI packages pyrender2 and PyOpenGL>=3.1.9, and {_OSMESA_HINT}"
        ) from error
    _compare_opaque_pointers_by_address()
    return pyrender


def _compare_opaque_pointers_by_address() -> None:
    """Make PyOpenGL's opaque context pointers compare equal when they hold the same address.

    PyOpenGL (3.1.10) returns a new ``OSMesaContext_pointer`` object each time it asks for the
    current context. The class hashes by address but compares by identity, so every lookup
    keyed on the context misses: pyrender's shader-program cache compiles the shaders again
    on every frame and never frees them (measured: +3.5 MB resident memory per 800x600 frame),
    and ``OpenGL.contextdata`` adds a new per-context dict on every vertex-attribute upload.
    Equality by address (matching the hash) fixes both. Applied once, only if the class does
    not define equality itself.
    """
    from OpenGL import _opaque

    pointer_class = _opaque._opaque_pointer
    if "__eq__" in pointer_class.__dict__:
        return

    def __eq__(self: Any, other: object) -> bool:
        if not isinstance(other, pointer_class):
            return NotImplemented
        address = ctypes.cast(self, ctypes.c_void_p).value
        return address == ctypes.cast(other, ctypes.c_void_p).value

    # Assigned after class creation, so the class keeps its address-based __hash__.
    pointer_class.__eq__ = __eq__


class _RendererCache:
    """One pyrender OffscreenRenderer per (width, height) in this process, used under a lock.

    Fork: contexts inherited from the parent are never used nor freed in the child (they may
    belong to rasterizer threads that do not exist there); the child creates its own. That
    works when llvmpipe ran single-threaded in the parent (``LP_NUM_THREADS=0``, our default);
    with rasterizer threads, Mesa hangs in a forked child, so rendering there raises instead.
    """

    def __init__(self) -> None:
        self.lock = threading.RLock()
        self._renderers: dict[tuple[int, int], Any] = {}
        self._meshes: dict[tuple[int, int], OrderedDict[tuple[Any, ...], tuple[Any, Any]]] = {}
        self._inherited: list[dict[tuple[int, int], Any]] = []
        self._pyrender: Any = None
        self._started_threads: str | None = None  # LP_NUM_THREADS when the first context began
        self._forked_from_threaded = False

    def get(self, width_px: int, height_px: int) -> tuple[Any, Any]:
        """Return ``(pyrender module, OffscreenRenderer)``; call with ``self.lock`` held."""
        if self._forked_from_threaded:
            raise RuntimeError(
                "cannot render in a process forked after OSMesa started with rasterizer "
                f"threads (LP_NUM_THREADS={self._started_threads!r}): Mesa would hang. Use a "
                "'spawn' or 'forkserver' multiprocessing context, or leave LP_NUM_THREADS "
                "unset (this module then sets it to 0) before the first render"
            )
        if self._pyrender is None:
            self._pyrender = _import_pyrender()
        pyrender = self._pyrender
        key = (width_px, height_px)
        renderer = self._renderers.get(key)
        if renderer is None:
            if self._started_threads is None:
                self._started_threads = os.environ.get("LP_NUM_THREADS", "<unset: one per CPU>")
                os.register_at_fork(after_in_child=self._after_fork_in_child)
            renderer = pyrender.OffscreenRenderer(width_px, height_px)
            self._renderers[key] = renderer
        return pyrender, renderer

    def mesh(self, pyrender: Any, size: tuple[int, int], item: SceneItem) -> Any:
        """The ``pyrender.Mesh`` of ``item`` for the renderer of ``size``, reused while the
        same trimesh (same object, same content hash) is drawn in the same colour: a mesh
        drawn in consecutive renders (the still parts of an animation, the gripper, the
        table) keeps its GL buffers instead of being rebuilt and uploaded each time. Call
        with ``self.lock`` held."""
        cache = self._meshes.setdefault(size, OrderedDict())
        key = (id(item.mesh), hash(item.mesh), item.color_rgba, item.name)
        hit = cache.get(key)
        if hit is not None and hit[0] is item.mesh:
            cache.move_to_end(key)
            return hit[1]
        mesh = _pyrender_mesh(pyrender, item)
        cache[key] = (item.mesh, mesh)  # the trimesh is kept so that its id stays its own
        while len(cache) > MESH_CACHE_SIZE:
            cache.popitem(last=False)
        return mesh

    def _after_fork_in_child(self) -> None:
        self.lock = threading.RLock()  # the parent's lock may have been held by another thread
        self._inherited.append(self._renderers)  # kept referenced: freeing them could hang
        self._inherited.append(self._meshes)
        self._meshes = {}
        self._renderers = {}
        if self._started_threads != "0":
            self._forked_from_threaded = True

    def clear(self) -> None:
        with self.lock:
            renderers, self._renderers = self._renderers, {}
            self._meshes = {}
            for renderer in renderers.values():
                with contextlib.suppress(Exception):
                    renderer.delete()

    def __len__(self) -> int:
        return len(self._renderers)


MESH_CACHE_SIZE = 256
"""Display meshes kept per renderer size for reuse (see :meth:`_RendererCache.mesh`)."""

_RENDERER_CACHE = _RendererCache()
atexit.register(_RENDERER_CACHE.clear)


def clear_renderer_cache() -> None:
    """Free every cached OSMesa context and its GL resources (the next render recreates one)."""
    _RENDERER_CACHE.clear()


def _pyrender_mesh(pyrender: Any, item: SceneItem) -> Any:
    mesh = item.mesh
    faces = np.asarray(mesh.faces)
    # Flat shading: one vertex per face corner, each carrying its face normal (crisp CAD edges).
    positions = np.asarray(mesh.vertices, dtype=np.float32)[faces].reshape(-1, 3)
    normals = np.repeat(np.asarray(mesh.face_normals, dtype=np.float32), 3, axis=0)
    opaque = item.color_rgba[3] >= 1.0
    material = pyrender.MetallicRoughnessMaterial(
        baseColorFactor=list(item.color_rgba),
        metallicFactor=0.0,
        roughnessFactor=0.6,
        alphaMode="OPAQUE" if opaque else "BLEND",
    )
    primitive = pyrender.Primitive(positions=positions, normals=normals, material=material)
    return pyrender.Mesh(primitives=[primitive], name=item.name or None)


def _near_far_m(items: Sequence[SceneItem], camera: Camera) -> tuple[float, float]:
    bounds = _union_bounds_m(items)
    corners = trimesh.bounds.corners(bounds)
    view = camera.target_m - camera.eye_m
    view = view / np.linalg.norm(view)
    depths = (corners - camera.eye_m) @ view
    extent = max(float(np.linalg.norm(bounds[1] - bounds[0])), 1e-6)
    far = max(float(depths.max()), 0.0) * 1.05 + 0.05 * extent
    near = max(float(depths.min()) * 0.95, far * 1e-4)
    return near, far


def _build_scene(
    pyrender: Any,
    items: Sequence[SceneItem],
    camera: Camera,
    background: Sequence[float],
) -> tuple[Any, list[Any]]:
    near_m, far_m = _near_far_m(items, camera)
    scene = pyrender.Scene(
        bg_color=[float(c) for c in background], ambient_light=[float(c) for c in _AMBIENT_RGB]
    )
    size = (camera.width_px, camera.height_px)
    nodes = [
        scene.add(_RENDERER_CACHE.mesh(pyrender, size, item), pose=np.array(item.T_world_item))
        for item in items
    ]
    pose = camera.T_world_camera
    scene.add(
        pyrender.PerspectiveCamera(
            yfov=camera.yfov_rad,
            aspectRatio=camera.width_px / camera.height_px,
            znear=near_m,
            zfar=far_m,
        ),
        pose=pose,
    )
    # Lights are given FLOAT colours: integer colours are read as 0-255 and do nothing visible.
    white = [1.0, 1.0, 1.0]
    scene.add(pyrender.DirectionalLight(color=white, intensity=_HEADLIGHT_INTENSITY), pose=pose)
    # Key light from above-left of the viewer so that faces facing different ways differ.
    key = np.array(pose)
    key_direction = pose[:3, :3] @ np.array([-0.3, 0.8, 0.6])  # light travels along -this
    key[:3, :3] = Camera(key_direction, np.zeros(3), pose[:3, 1]).T_world_camera[:3, :3]
    scene.add(pyrender.DirectionalLight(color=white, intensity=_KEY_LIGHT_INTENSITY), pose=key)
    distance_m = float(np.linalg.norm(camera.target_m - camera.eye_m))
    scene.add(
        pyrender.PointLight(
            color=white, intensity=_POINT_LIGHT_INTENSITY_PER_M2 * distance_m**2
        ),
        pose=pose,
    )
    return scene, nodes


def _validate_background(background: Sequence[float]) -> tuple[float, ...]:
    rgba = tuple(float(c) for c in background)
    if len(rgba) not in (3, 4) or not all(0.0 <= c <= 1.0 for c in rgba):
        raise ValueError(
            f"render: expected background as 3 or 4 floats in [0, 1], found {background!r}"
        )
    return rgba if len(rgba) == 4 else (*rgba, 1.0)


def render(
    items: Sequence[SceneItem],
    camera: Camera,
    background: Sequence[float] = (1.0, 1.0, 1.0, 1.0),
) -> np.ndarray:
    """Render items with a headlight, a key light and a point light at the eye.

    Parameters
    ----------
    items : sequence of SceneItem
        What to draw (at least one item).
    camera : Camera
        Viewpoint and image size.
    background : 3 or 4 floats in [0, 1]
        Colour of pixels where nothing is drawn.

    Returns
    -------
    (camera.height_px, camera.width_px, 3) uint8 array
        RGB image, row 0 at the top.

    Raises
    ------
    RuntimeError
        If OpenGL was already imported for another platform, or libOSMesa cannot be loaded.
    """
    rgba = _validate_background(background)
    with _RENDERER_CACHE.lock:
        pyrender, renderer = _RENDERER_CACHE.get(camera.width_px, camera.height_px)
        scene, _ = _build_scene(pyrender, items, camera, rgba)
        color, _depth = renderer.render(scene, flags=pyrender.RenderFlags.NONE)
    return np.ascontiguousarray(color[:, :, :3], dtype=np.uint8)


def render_labels(items: Sequence[SceneItem], camera: Camera) -> np.ndarray:
    """Which item each pixel shows, occlusion included (flat segmentation render).

    Parameters
    ----------
    items : sequence of SceneItem
        What to draw (at least one item, fewer than 2**24).
    camera : Camera
        Viewpoint and image size.

    Returns
    -------
    (camera.height_px, camera.width_px) int32 array
        Index into ``items`` of the visible item at each pixel, -1 for background.
    """
    if len(items) >= 2**24 - 1:
        raise ValueError(f"render_labels: expected fewer than 2**24 items, found {len(items)}")
    with _RENDERER_CACHE.lock:
        pyrender, renderer = _RENDERER_CACHE.get(camera.width_px, camera.height_px)
        scene, nodes = _build_scene(pyrender, items, camera, (0.0, 0.0, 0.0, 1.0))
        # Label k is drawn as the 24-bit colour k + 1 (pyrender divides these by 255).
        seg_node_map = {
            node: [((k + 1) >> 16) & 255, ((k + 1) >> 8) & 255, (k + 1) & 255]
            for k, node in enumerate(nodes)
        }
        color, _depth = renderer.render(
            scene, flags=pyrender.RenderFlags.SEG, seg_node_map=seg_node_map
        )
    rgb = color[:, :, :3].astype(np.int32)
    return (rgb[:, :, 0] << 16 | rgb[:, :, 1] << 8 | rgb[:, :, 2]) - 1


def render_mask(items: Sequence[SceneItem], camera: Camera, name: str) -> np.ndarray:
    """Pixels where the item called ``name`` is visible (occluded parts excluded).

    Parameters
    ----------
    items : sequence of SceneItem
        The whole scene (other items can hide parts of the named one).
    camera : Camera
        Viewpoint and image size.
    name : str
        ``SceneItem.name`` to look up; must match exactly one item.

    Returns
    -------
    (camera.height_px, camera.width_px) bool array
    """
    indices = [k for k, item in enumerate(items) if item.name == name]
    if len(indices) != 1:
        known = sorted({item.name for item in items})
        raise ValueError(
            f"render_mask: expected exactly one item named {name!r}, found {len(indices)}; "
            f"names: {known}"
        )
    return render_labels(items, camera) == indices[0]


# --------------------------------------------------------------------------------------------
# Output
# --------------------------------------------------------------------------------------------


def save_png(image: np.ndarray, path: str | os.PathLike[str]) -> Path:
    """Write an image as PNG atomically (see :func:`asmplan.fileio.atomic_write_bytes`).

    The PNG is encoded in memory with Pillow (fixed compression level, no metadata), so the
    bytes depend only on the pixels, then written to a temporary file in the same folder,
    fsynced and swapped in with ``os.replace``: readers see the old file or the complete new
    one, never a partial write.

    Parameters
    ----------
    image : (H, W, 3) or (H, W, 4) uint8 array, or (H, W) uint8 or bool array
        RGB, RGBA or grey pixels; a bool mask is written as black (False) and white (True).
    path : str or os.PathLike
        Destination; missing parent folders are created.

    Returns
    -------
    Path
        The destination path.
    """
    from PIL import Image

    from ..fileio import atomic_write_bytes

    pixels = np.asarray(image)
    if pixels.dtype == bool and pixels.ndim == 2:
        pixels = pixels.astype(np.uint8) * 255
    if pixels.dtype != np.uint8 or not (
        pixels.ndim == 2 or (pixels.ndim == 3 and pixels.shape[2] in (3, 4))
    ):
        raise ValueError(
            "save_png: expected a uint8 array of shape (H, W), (H, W, 3) or (H, W, 4), "
            f"found dtype {pixels.dtype} and shape {pixels.shape}"
        )
    encoded = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(pixels)).save(encoded, format="PNG", compress_level=6)
    return atomic_write_bytes(path, encoded.getvalue())
