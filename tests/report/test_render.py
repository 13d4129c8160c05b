"""Offscreen OSMesa rendering checked against the pinhole camera model.

Scene: a 40 mm red cube centred at (-30, 20, 0) mm and a blue cylinder (radius 15 mm, height
50 mm) centred at (60, -10, 0) mm, seen by a camera 300 mm above the origin looking down -z
with world +y up in the image (so world +x is image right). The expected silhouette of the
cube is computed here from the intrinsics (focal length from the vertical field of view,
principal point at the image centre), independently of the library's Camera code.
"""

from __future__ import annotations

import multiprocessing
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
import trimesh
from scipy.ndimage import binary_erosion
from scipy.spatial import ConvexHull

from asmplan.report import camera as rc
from asmplan.report import render as rr

WIDTH_PX, HEIGHT_PX, YFOV_RAD = 800, 600, 0.6
EYE_HEIGHT_M = 0.3
BOX_SIZE_M = 0.04
BOX_CENTER_M = np.array([-0.03, 0.02, 0.0])
CYLINDER_CENTER_M = np.array([0.06, -0.01, 0.0])


def _translation(xyz: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = xyz
    return T


def _scene() -> list[rc.SceneItem]:
    box = trimesh.creation.box(extents=(BOX_SIZE_M,) * 3)
    cylinder = trimesh.creation.cylinder(radius=0.015, height=0.05, sections=64)
    return [
        rc.SceneItem(box, _translation(BOX_CENTER_M), (0.9, 0.1, 0.1, 1.0), "box"),
        rc.SceneItem(cylinder, _translation(CYLINDER_CENTER_M), (0.1, 0.2, 0.9, 1.0), "pin"),
    ]


def _top_camera() -> rc.Camera:
    return rc.Camera(
        eye_m=(0.0, 0.0, EYE_HEIGHT_M),
        target_m=(0.0, 0.0, 0.0),
        up=(0.0, 1.0, 0.0),
        yfov_rad=YFOV_RAD,
        width_px=WIDTH_PX,
        height_px=HEIGHT_PX,
    )


def _project_top_down(points_m: np.ndarray) -> np.ndarray:
    """Pinhole projection for the top camera: (N, 3) world points -> (N, 2) (column, row)."""
    focal_px = (HEIGHT_PX / 2) / np.tan(YFOV_RAD / 2)
    depth_m = EYE_HEIGHT_M - points_m[:, 2]
    column = WIDTH_PX / 2 + focal_px * points_m[:, 0] / depth_m
    row = HEIGHT_PX / 2 - focal_px * points_m[:, 1] / depth_m
    return np.column_stack([column, row])


def _box_silhouette() -> tuple[float, np.ndarray]:
    """Area (px^2) and area centroid (column, row) of the projected cube's convex outline."""
    corners = BOX_CENTER_M + BOX_SIZE_M / 2 * np.array(
        [[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float
    )
    outline = _project_top_down(corners)
    polygon = outline[ConvexHull(outline).vertices]
    x, y = polygon[:, 0], polygon[:, 1]
    cross = x * np.roll(y, -1) - np.roll(x, -1) * y
    area = cross.sum() / 2
    centroid = np.array(
        [
            ((x + np.roll(x, -1)) * cross).sum() / (6 * area),
            ((y + np.roll(y, -1)) * cross).sum() / (6 * area),
        ]
    )
    return abs(float(area)), centroid


def _pixel_centroid(mask: np.ndarray) -> np.ndarray:
    rows, columns = np.nonzero(mask)
    # Pixel (i, j) covers [j, j + 1] x [i, i + 1]; its centre is (j + 0.5, i + 0.5).
    return np.array([columns.mean() + 0.5, rows.mean() + 0.5])


def _red(image: np.ndarray) -> np.ndarray:
    r, g, b = (image[:, :, k].astype(int) for k in range(3))
    return (r > 100) & (r - g > 60) & (r - b > 60)


def _blue(image: np.ndarray) -> np.ndarray:
    r, g, b = (image[:, :, k].astype(int) for k in range(3))
    return (b > 100) & (b - r > 60) & (b - g > 40)


@pytest.fixture(scope="module")
def top_view() -> dict[str, np.ndarray]:
    items, camera = _scene(), _top_camera()
    return {
        "image": rr.render(items, camera),
        "labels": rr.render_labels(items, camera),
        "box_mask": rr.render_mask(items, camera, "box"),
    }


def test_render_returns_rgb_image_that_is_not_blank(top_view):
    image = top_view["image"]
    assert image.shape == (HEIGHT_PX, WIDTH_PX, 3)
    assert image.dtype == np.uint8
    assert float(image.std()) > 10.0


def test_red_centroid_matches_pinhole_projection_of_the_box(top_view):
    red = _red(top_view["image"])
    _area, expected = _box_silhouette()
    # The silhouette includes the side face seen in perspective; its area centroid is the
    # exact expectation. The projected box centre is within a few pixels of it.
    np.testing.assert_allclose(_pixel_centroid(red), expected, atol=1.5)
    box_center_px = _project_top_down(BOX_CENTER_M[None, :])[0]
    np.testing.assert_allclose(_pixel_centroid(red), box_center_px, atol=6.0)
    # The library's own projection agrees with the intrinsics used here.
    np.testing.assert_allclose(_top_camera().project(BOX_CENTER_M), box_center_px, atol=1e-9)


def test_box_coverage_equals_projected_area(top_view):
    expected_area, _centroid = _box_silhouette()
    box_mask = top_view["box_mask"]
    assert box_mask.sum() == pytest.approx(expected_area, rel=0.05)
    red = _red(top_view["image"])
    intersection = (red & box_mask).sum()
    union = (red | box_mask).sum()
    assert intersection / union > 0.97, "red pixels and the box mask should coincide"


def test_blue_cylinder_is_right_of_red_box(top_view):
    red, blue = _red(top_view["image"]), _blue(top_view["image"])
    assert blue.sum() > 1000
    assert _pixel_centroid(blue)[0] > _pixel_centroid(red)[0] + 100
    # The pin's mask is where its labels are, and the blue pixels are in it.
    pin_mask = top_view["labels"] == 1
    assert (blue & pin_mask).sum() / blue.sum() > 0.98


def test_background_is_white_where_nothing_is(top_view):
    image, labels = top_view["image"], top_view["labels"]
    empty = binary_erosion(labels == -1, structure=np.ones((3, 3), bool))
    assert empty.mean() > 0.8
    assert np.all(image[empty] == 255)
    assert set(np.unique(labels).tolist()) == {-1, 0, 1}


def test_render_mask_rejects_unknown_name():
    with pytest.raises(ValueError, match=r"exactly one item named 'lid', found 0"):
        rr.render_mask(_scene(), _top_camera(), "lid")


def test_rendering_twice_in_one_process_gives_identical_images(top_view):
    items, camera = _scene(), _top_camera()
    small = rc.Camera(camera.eye_m, camera.target_m, camera.up, YFOV_RAD, 160, 120)
    small_image = rr.render(items, small)  # another cached context in between
    assert small_image.shape == (120, 160, 3)
    assert _red(small_image).any()
    np.testing.assert_array_equal(rr.render(items, camera), top_view["image"])


def _render_top_view() -> np.ndarray:
    return rr.render(_scene(), _top_camera())


def test_rendering_works_in_a_process_forked_after_a_render(top_view):
    # With llvmpipe's rasterizer threads a forked child hangs; the module runs llvmpipe
    # single-threaded by default so that process pools (fork on Linux) can render.
    with multiprocessing.get_context("fork").Pool(1) as pool:
        image = pool.apply_async(_render_top_view).get(timeout=120)
    np.testing.assert_array_equal(image, top_view["image"])


def _rss_bytes() -> int:
    with open("/proc/self/statm") as statm:
        return int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


@pytest.mark.slow
def test_repeated_renders_do_not_leak_memory():
    # ~1.9 MB of vertex data per scene (20480 flat-shaded faces): a leak of the scene's GPU
    # buffers or of the frame buffers would add well over 50 MB in 40 renders.
    sphere = trimesh.creation.icosphere(subdivisions=5, radius=0.03)
    items = [rc.SceneItem(sphere, np.eye(4), (0.2, 0.7, 0.2, 1.0), "sphere")]
    camera = rc.fit_camera(items)
    for _ in range(5):
        rr.render(items, camera)
    before = _rss_bytes()
    for _ in range(40):
        rr.render(items, camera)
    growth_mb = (_rss_bytes() - before) / 1e6
    assert growth_mb < 20.0, f"resident memory grew {growth_mb:.1f} MB over 40 renders"


def test_fit_camera_keeps_every_corner_inside_the_margin():
    items = _scene()
    margin = 1.15
    camera = rc.fit_camera(items, margin=margin, width_px=640, height_px=480)
    bounds = np.array([item.world_bounds_m() for item in items])
    low, high = bounds[:, 0].min(axis=0), bounds[:, 1].max(axis=0)
    corners = np.array([[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1])
                        for z in (low[2], high[2])])
    offset = np.abs(camera.project(corners) - [320.0, 240.0])
    # Normalised by the half-size the margin leaves: all <= 1, and one is (almost) 1.
    used = np.max(offset / [320.0 / margin, 240.0 / margin], axis=1)
    assert used.max() == pytest.approx(1.0, abs=1e-9)
    mask = rr.render_labels(items, camera) >= 0
    rows, columns = np.nonzero(mask)
    assert rows.min() > 0 and columns.min() > 0
    assert rows.max() < 479 and columns.max() < 639


def test_exploded_moves_items_along_centroid_direction():
    items = _scene()
    center = np.array([0.0, 0.0, 0.0])
    moved = rc.exploded(items, center, 0.5)
    for before, after in zip(items, moved, strict=True):
        shift = after.T_world_item[:3, 3] - before.T_world_item[:3, 3]
        np.testing.assert_allclose(shift, 0.5 * (before.T_world_item[:3, 3] - center), atol=1e-12)
        np.testing.assert_array_equal(after.T_world_item[:3, :3], before.T_world_item[:3, :3])
        assert after.name == before.name and after.mesh is before.mesh
    unmoved = rc.exploded(items, center, 0.0)
    for before, after in zip(items, unmoved, strict=True):
        np.testing.assert_array_equal(after.T_world_item, before.T_world_item)
    with pytest.raises(ValueError, match="expected factor >= 0"):
        rc.exploded(items, center, -1.0)


def test_scene_item_and_camera_validate_inputs():
    box = trimesh.creation.box(extents=(0.01, 0.01, 0.01))
    with pytest.raises(ValueError, match=r"expected a \(4, 4\) transform, found shape \(3, 3\)"):
        rc.SceneItem(box, np.eye(3), (1.0, 0.0, 0.0, 1.0))
    with pytest.raises(ValueError, match="expected a rotation block"):
        rc.SceneItem(box, np.diag([2.0, 1.0, 1.0, 1.0]), (1.0, 0.0, 0.0, 1.0))
    with pytest.raises(ValueError, match=r"expected color_rgba as 4 floats in \[0, 1\]"):
        rc.SceneItem(box, np.eye(4), (255, 0, 0, 255))
    with pytest.raises(ValueError, match="expected up not parallel to the view direction"):
        rc.Camera(eye_m=(0.0, 0.0, 1.0), target_m=(0.0, 0.0, 0.0))


def test_save_png_is_atomic_and_deterministic(tmp_path: Path):
    from PIL import Image

    rng = np.random.default_rng(7)
    first = rng.integers(0, 256, size=(60, 80, 3), dtype=np.uint8)
    second = rng.integers(0, 256, size=(30, 40, 3), dtype=np.uint8)
    target = tmp_path / "view.png"
    assert rr.save_png(first, target) == target
    first_bytes = target.read_bytes()
    rr.save_png(first, tmp_path / "again.png")
    assert (tmp_path / "again.png").read_bytes() == first_bytes
    # An existing file is replaced whole: same name, new content, nothing of the old left.
    old_inode = target.stat().st_ino
    rr.save_png(second, target)
    assert target.stat().st_ino != old_inode
    with Image.open(target) as reread:
        np.testing.assert_array_equal(np.asarray(reread), second)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["again.png", "view.png"]


def test_save_png_leaves_no_temp_file_when_writing_fails(tmp_path: Path, monkeypatch):
    from PIL import Image

    target = tmp_path / "view.png"
    original = np.full((10, 10, 3), 200, np.uint8)
    rr.save_png(original, target)

    def fail(*_args, **_kwargs):
        raise OSError("rename failed (simulated)")

    monkeypatch.setattr(os, "replace", fail)
    with pytest.raises(OSError, match="rename failed"):
        rr.save_png(np.zeros((10, 10, 3), np.uint8), target)
    monkeypatch.undo()
    assert [p.name for p in tmp_path.iterdir()] == ["view.png"]
    with Image.open(target) as reread:
        np.testing.assert_array_equal(np.asarray(reread), original)
    with pytest.raises(ValueError, match="expected a uint8 array"):
        rr.save_png(np.zeros((10, 10, 3), np.float32), target)


def test_save_png_writes_bool_masks_black_and_white(tmp_path: Path):
    from PIL import Image

    mask = np.zeros((6, 8), bool)
    mask[2:4, 3:7] = True
    with Image.open(rr.save_png(mask, tmp_path / "mask.png")) as reread:
        np.testing.assert_array_equal(np.asarray(reread), mask.astype(np.uint8) * 255)


_PLATFORM_SCRIPT = textwrap.dedent(
    """
    import os
    import numpy as np
    import trimesh
    from asmplan.report import camera as rc
    from asmplan.report import render as rr

    items = [rc.SceneItem(trimesh.creation.box(extents=(0.01, 0.01, 0.01)), np.eye(4),
                          (1.0, 0.0, 0.0, 1.0))]
    camera = rc.fit_camera(items, width_px=64, height_px=48)

    def message():
        try:
            rr.render(items, camera)
        except RuntimeError as error:
            return str(error)
        return "no error"

    os.environ.pop("PYOPENGL_PLATFORM", None)
    good_names = rr._OSMESA_LIBRARY_NAMES
    rr._OSMESA_LIBRARY_NAMES = ("libOSMesa-missing-for-test.so",)
    print("MISSING:", message())
    rr._OSMESA_LIBRARY_NAMES = good_names
    os.environ["PYOPENGL_PLATFORM"] = "egl"
    print("EGL:", message())
    del os.environ["PYOPENGL_PLATFORM"]
    import OpenGL.GL  # noqa: F401  (no PYOPENGL_PLATFORM: PyOpenGL picks GLX on Linux)
    print("GLX:", message())
    """
)


@pytest.mark.slow
def test_platform_errors_are_clear():
    env = {k: v for k, v in os.environ.items() if k != "PYOPENGL_PLATFORM"}
    result = subprocess.run(
        [sys.executable, "-c", _PLATFORM_SCRIPT],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
        check=True,
    )
    lines = dict(line.split(": ", 1) for line in result.stdout.splitlines() if ": " in line)
    assert "install Debian package libosmesa6" in lines["MISSING"]
    assert "needs PYOPENGL_PLATFORM=osmesa, found PYOPENGL_PLATFORM='egl'" in lines["EGL"]
    assert "already imported with OpenGL.platform.glx.GLXPlatform" in lines["GLX"]


def test_a_mesh_changed_in_place_is_drawn_as_it_is_now():
    # display meshes are reused between renders (same trimesh, same colour): a mesh moved in
    # place must not be drawn from the stale copy
    items, camera = _scene(), _top_camera()
    before = _pixel_centroid(_red(rr.render(items, camera)))
    items[0].mesh.apply_translation((0.02, 0.0, 0.0))
    after = _pixel_centroid(_red(rr.render(items, camera)))
    focal_px = (HEIGHT_PX / 2) / np.tan(YFOV_RAD / 2)
    # the top face, 20 mm above the origin plane, sets most of the silhouette's shift
    assert after[0] - before[0] > 0.9 * focal_px * 0.02 / EYE_HEIGHT_M
    assert abs(after[1] - before[1]) < 0.5
