"""The robot arm of the cell: which URDF, where it stands, what it carries, its joint limits.

``resources.robot.model`` names either a bundled arm or a URDF file (a path relative to the
product file). Bundled arms come from packages asmplan already depends on:

========  ==========================================  ======================================
name      URDF                                        notes
========  ==========================================  ======================================
xarm6     ``pybullet_data``: xarm/xarm6_robot.urdf    UFACTORY xArm 6, 6 revolute joints,
                                                      nominal reach 700 mm, payload 5 kg
========  ==========================================  ======================================

(``pybullet_data`` also ships the 7-axis KUKA iiwa and Franka Panda; asmplan plans 6-axis arms,
whose inverse kinematics has a finite set of solution branches, so those are refused.)

The URDF is read here with the standard library only (no kinematics): it must describe one
serial chain of exactly six revolute joints from its root link to the flange link (default:
the last link of the chain), every joint with position and velocity limits, and every
collision mesh it names must exist. URDF lengths are metres and are never rescaled by the
product file's length unit. Accelerations are not part of URDF: they come from the product
file (``joints``) or default to :data:`DEFAULT_JOINT_ACCELERATION_RAD_S2`.

Problems are returned as messages for the loader to locate (file, line, column, key path).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import AsmplanError
from .frames import make_T

ARM_JOINTS = 6
DEFAULT_JOINT_ACCELERATION_RAD_S2 = 10.0
"""Joint acceleration limit used when the product file gives none (URDF has no such field),
rad/s^2. The xArm 6's controller allows 20 rad/s^2 at most (UFACTORY user manual); half of it
is a conservative default for a loaded arm."""

BUNDLED_ARMS: dict[str, tuple[str, str]] = {
    "xarm6": ("pybullet_data", "xarm/xarm6_robot.urdf"),
}
LINK_NAMES: dict[str, dict[str, str]] = {
    "xarm6": {"link_base": "base", "link1": "shoulder", "link2": "upper arm", "link3": "forearm",
              "link4": "wrist 1", "link5": "wrist 2", "link6": "flange"},
}
"""What a process engineer calls the links of a bundled arm (for messages)."""


@dataclass(frozen=True)
class JointLimit:
    """Limits of one revolute joint (SI: rad, rad/s, rad/s^2)."""

    name: str
    lower_rad: float
    upper_rad: float
    velocity_rad_s: float
    acceleration_rad_s2: float

    def __post_init__(self) -> None:
        if not (self.lower_rad < self.upper_rad):
            raise ValueError(f"joint {self.name}: expected lower < upper, found "
                             f"{self.lower_rad:g} >= {self.upper_rad:g} rad")
        if not (self.velocity_rad_s > 0 and self.acceleration_rad_s2 > 0):
            raise ValueError(f"joint {self.name}: expected positive velocity and acceleration "
                             f"limits, found {self.velocity_rad_s:g}, {self.acceleration_rad_s2:g}")


@dataclass(frozen=True)
class UrdfCollision:
    """One collision geometry of a link: a mesh file or a primitive, in the link frame."""

    link: str
    T_link_geom: np.ndarray
    kind: str  # "mesh", "box", "cylinder", "sphere"
    mesh_path: Path | None = None
    mesh_scale: tuple[float, float, float] = (1.0, 1.0, 1.0)
    size_m: tuple[float, ...] = ()


@dataclass(frozen=True)
class UrdfArm:
    """The serial chain read from a URDF: joint names and limits (URDF values), the root and
    flange links, the chain's links in order and their collision geometry."""

    path: Path
    name: str
    root_link: str
    flange_link: str
    links: tuple[str, ...]
    joints: tuple[JointLimit, ...]
    collisions: tuple[UrdfCollision, ...]


class UrdfError(AsmplanError, ValueError):
    """A URDF file cannot be used as the cell's arm; the message says what was expected."""


def bundled_urdf(name: str) -> Path | None:
    """The URDF file of a bundled arm, or None when ``name`` is not one."""
    entry = BUNDLED_ARMS.get(name.lower())
    if entry is None:
        return None
    package, rel = entry
    if package == "pybullet_data":
        import pybullet_data  # a data folder only; it does not import pybullet

        return Path(pybullet_data.getDataPath()) / rel
    raise AssertionError(package)  # pragma: no cover


def resolve_model(model: str, base_dir: Path) -> Path:
    """The URDF file that ``model`` names: a bundled arm or a path (relative to ``base_dir``).

    Raises
    ------
    UrdfError
        Unknown name or missing file, saying which names are bundled.
    """
    found = bundled_urdf(model)
    if found is not None:
        return found
    looks_like_path = model.lower().endswith(".urdf") or "/" in model or "\\" in model
    if not looks_like_path:
        from .errors import did_you_mean

        raise UrdfError(f'expected a bundled arm ({", ".join(sorted(BUNDLED_ARMS))}) or a path '
                        f'to a .urdf file, found unknown model "{model}"'
                        f'{did_you_mean(model.lower(), BUNDLED_ARMS)}')
    path = (base_dir / model).resolve()
    if not path.is_file():
        raise UrdfError(f'expected an existing URDF file, found no file "{model}" '
                        f"(looked for {path})")
    return path


def _floats(text: str | None, n: int, default: tuple[float, ...], what: str) -> tuple[float, ...]:
    if text is None:
        return default
    try:
        vals = tuple(float(v) for v in text.split())
    except ValueError:
        raise UrdfError(f"expected {n} numbers in {what}, found {text!r}") from None
    if len(vals) != n or not all(math.isfinite(v) for v in vals):
        raise UrdfError(f"expected {n} finite numbers in {what}, found {text!r}")
    return vals


def _origin(el: ET.Element | None, what: str) -> np.ndarray:
    if el is None:
        return np.eye(4)
    return make_T(_floats(el.get("xyz"), 3, (0.0, 0.0, 0.0), f"{what} origin xyz"),
                  _floats(el.get("rpy"), 3, (0.0, 0.0, 0.0), f"{what} origin rpy"))


def _mesh_file(filename: str, urdf: Path) -> Path:
    """Resolve ``package://pkg/rest`` (the package folder searched beside the URDF and up to
    three folders above it) or a path relative to the URDF."""
    if filename.startswith("package://"):
        pkg, _, rest = filename[len("package://"):].partition("/")
        for folder in [urdf.parent, *list(urdf.parents)[:3]]:
            cand = folder / pkg / rest
            if cand.is_file():
                return cand
        raise UrdfError(f'expected the mesh "{filename}" named in {urdf.name} to exist, found no '
                        f'folder "{pkg}" holding it beside the URDF or above it')
    if filename.startswith("file://"):
        filename = filename[len("file://"):]
    p = (urdf.parent / filename).resolve()
    if not p.is_file():
        raise UrdfError(f'expected the mesh "{filename}" named in {urdf.name} to exist, found no '
                        f"file {p}")
    return p


# Complexity above C (radon): one check per URDF requirement (XML, robot, one serial chain to
# the flange, six revolute joints with limits, collision geometry), each its own UrdfError.
def read_urdf_arm(path: Path, flange: str | None = None) -> UrdfArm:
    """Read and check the serial arm in a URDF file.

    Raises
    ------
    UrdfError
        Not XML, not a ``<robot>``, not one serial chain of six revolute joints up to the
        flange, a joint without limits, a missing collision mesh.
    """
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise UrdfError(f"expected a URDF (XML) file, found invalid XML in {path.name}: {exc}"
                        ) from None
    except OSError as exc:
        raise UrdfError(f"expected a readable URDF file, found {exc}") from None
    if root.tag != "robot":
        raise UrdfError(f"expected a URDF file whose root element is <robot>, found <{root.tag}> "
                        f"in {path.name}")
    links = {str(el.get("name")): el for el in root.findall("link")}
    joints = root.findall("joint")
    child_of: dict[str, ET.Element] = {}
    children: dict[str, list[ET.Element]] = {}
    for j in joints:
        p, c = j.find("parent"), j.find("child")
        if p is None or c is None:
            raise UrdfError(f'expected <parent> and <child> in joint "{j.get("name")}" of '
                            f"{path.name}, found none")
        child_of[str(c.get("link", ""))] = j
        children.setdefault(str(p.get("link", "")), []).append(j)
    roots = [n for n in links if n not in child_of]
    if len(roots) != 1:
        raise UrdfError(f"expected one root link in {path.name}, found {len(roots)}: "
                        f"{', '.join(sorted(str(r) for r in roots))}")
    if flange is None:
        # follow the chain from the root to its end (one child per link)
        chain_links = [roots[0]]
        while children.get(chain_links[-1]):
            kids = children[chain_links[-1]]
            moving = [k for k in kids if k.get("type") != "fixed"]
            if len(kids) > 1 and len(moving) != 1:
                raise UrdfError(f'expected a serial chain in {path.name}, found link '
                                f'"{chain_links[-1]}" branching into {len(kids)} joints; name '
                                f"the flange link (resources.robot.flange)")
            nxt = (moving or kids)[0]
            chain_links.append(str(nxt.find("child").get("link")))  # type: ignore[union-attr]
        flange = chain_links[-1]
    if flange not in links:
        from .errors import did_you_mean

        raise UrdfError(f'expected the flange to be a link of {path.name}, found unknown link '
                        f'"{flange}"{did_you_mean(flange, [str(n) for n in links])}')
    chain: list[ET.Element] = []
    link: str = flange
    while link in child_of:
        chain.append(child_of[link])
        link = str(child_of[link].find("parent").get("link"))  # type: ignore[union-attr]
    chain.reverse()
    chain_links = [str(link), *[str(j.find("child").get("link"))  # type: ignore[union-attr]
                                for j in chain]]
    moving = [j for j in chain if j.get("type") != "fixed"]
    bad = [j for j in moving if j.get("type") not in ("revolute", "continuous")]
    if bad:
        raise UrdfError(f'expected revolute joints only, found {bad[0].get("type")} joint '
                        f'"{bad[0].get("name")}" in {path.name}')
    if len(moving) != ARM_JOINTS:
        raise UrdfError(f"expected a {ARM_JOINTS}-axis arm (six revolute joints from "
                        f'"{chain_links[0]}" to the flange "{flange}"), found {len(moving)} in '
                        f"{path.name}")
    limits = []
    for j in moving:
        name = j.get("name", "")
        lim = j.find("limit")
        if j.get("type") == "continuous":
            lower, upper = -2 * math.pi, 2 * math.pi
        elif lim is None or lim.get("lower") is None or lim.get("upper") is None:
            raise UrdfError(f'expected <limit lower upper velocity> on joint "{name}" of '
                            f"{path.name}, found none")
        else:
            lower = _floats(lim.get("lower"), 1, (0.0,), f"joint {name} lower")[0]
            upper = _floats(lim.get("upper"), 1, (0.0,), f"joint {name} upper")[0]
        vel = _floats(None if lim is None else lim.get("velocity"), 1, (0.0,),
                      f"joint {name} velocity")[0]
        if vel <= 0:
            raise UrdfError(f'expected a positive velocity limit on joint "{name}" of '
                            f"{path.name}, found {vel:g}")
        if not lower < upper:
            raise UrdfError(f'expected lower < upper on joint "{name}" of {path.name}, found '
                            f"{lower:g}, {upper:g}")
        limits.append(JointLimit(name, lower, upper, vel, DEFAULT_JOINT_ACCELERATION_RAD_S2))
    collisions: list[UrdfCollision] = []
    for ln in chain_links:
        for col in links[ln].findall("collision"):
            geo = col.find("geometry")
            if geo is None or not len(geo):
                continue
            T = _origin(col.find("origin"), f"link {ln} collision")
            g = geo[0]
            if g.tag == "mesh":
                f = _mesh_file(g.get("filename", ""), path)
                scale = _floats(g.get("scale"), 3, (1.0, 1.0, 1.0), f"link {ln} mesh scale")
                collisions.append(UrdfCollision(ln, T, "mesh", f, scale))  # type: ignore[arg-type]
            elif g.tag == "box":
                collisions.append(UrdfCollision(ln, T, "box",
                                                size_m=_floats(g.get("size"), 3, (), "box size")))
            elif g.tag == "cylinder":
                r = _floats(g.get("radius"), 1, (), f"link {ln} cylinder radius")[0]
                length = _floats(g.get("length"), 1, (), f"link {ln} cylinder length")[0]
                collisions.append(UrdfCollision(ln, T, "cylinder", size_m=(r, length)))
            elif g.tag == "sphere":
                r = _floats(g.get("radius"), 1, (), f"link {ln} sphere radius")[0]
                collisions.append(UrdfCollision(ln, T, "sphere", size_m=(r,)))
    return UrdfArm(path=path, name=root.get("name", path.stem), root_link=chain_links[0],
                   flange_link=flange, links=tuple(chain_links), joints=tuple(limits),
                   collisions=tuple(collisions))
