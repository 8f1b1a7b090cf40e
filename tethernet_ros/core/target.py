"""The target's settings: which object the net is shot at (docs/model.md §1, §15,
docs/targets.md).

The default is the source's Zenit-2 second stage as exact solids of revolution (a cylinder
of diameter 3.9 m and length 10.4 m, dry mass 8300 kg, uniform density, an optional engine
nozzle behind its -x end): the ``revolution`` shape kind, whose fields are ``diameter``,
``length`` and the ``nozzle*`` ones.  Any other target is a closed triangle mesh (the
``mesh`` kind): a name of the catalogue (``core.shapes.catalogue``) or a file that trimesh
reads (STL, OBJ, PLY, GLB/glTF, OFF), with its mass and, where measured, its centre of
mass and inertia tensor.  The shapes themselves are built by ``core.shapes.target_shape``.
"""
from __future__ import annotations

import hashlib
import math
from dataclasses import asdict, dataclass
from pathlib import Path

from .checks import declared_floats, finite_numbers

#: the default target, the only one of the ``revolution`` kind
DEFAULT_NAME = "zenit-2"
#: mass of the default (kg): the Zenit-2 second stage's dry mass (docs/model.md §1)
ZENIT_MASS = 8300.0
#: the fields of the revolution kind (a results file written before shapes had only these)
_REVOLUTION_FIELDS = ("diameter", "length", "mass", "nozzle", "nozzle_length",
                      "nozzle_base_radius", "nozzle_exit_radius")
#: the largest plausible target mass (kg): the International Space Station's, about 4.2e5
MAX_MASS = 1e6


class TargetError(ValueError):
    """A target setting is outside its allowed range (the message names the field)."""


@dataclass(frozen=True)
class TargetConfig:
    """Geometry (m) and mass (kg) of the target.

    name: 'zenit-2' (the analytic stage), another catalogue name, or a label for ``mesh``;
    mesh: path of a mesh file ('' for a catalogue name); mesh_sha256: the file's SHA-256
    (filled in when the target is read; given, the file must match it); units: the file's
    length unit (m, cm, mm, in, ft); mass: total mass (kg; None: the catalogue's, 8300 for
    the Zenit-2; a file needs it); com: a measured centre of mass (3 values, m, in the
    file's frame; () for uniform density); inertia: a measured inertia tensor about that
    CoM (kg m^2, 6 values Ixx, Iyy, Izz, Ixy, Iyz, Ixz or 9; () for uniform density).
    attitude_deg: the target's initial attitude, which face the chaser sees: turns (deg)
    about the world x, then y, then z axis from the nominal attitude (body axes along the
    world's: the long axis across the line of sight, the flat-spin axis y up); () none.
    Revolution kind only: diameter, length; the nozzle, a frustum of length
    ``nozzle_length`` behind the -x end cap, radius ``nozzle_base_radius`` at the cap and
    ``nozzle_exit_radius`` at its exit, used only if ``nozzle`` is True.
    """

    diameter: float = 3.9
    length: float = 10.4
    mass: float | None = None
    nozzle: bool = False
    nozzle_length: float = 2.0
    nozzle_base_radius: float = 0.5
    nozzle_exit_radius: float = 1.0
    name: str = DEFAULT_NAME
    mesh: str = ""
    mesh_sha256: str = ""
    units: str = "m"
    com: tuple = ()
    inertia: tuple = ()
    attitude_deg: tuple = ()

    def __post_init__(self):
        declared_floats(self)
        if not isinstance(self.name, str) or not self.name:
            raise TargetError(f"target field 'name': got {self.name!r}; must be a non-empty name")
        mesh = str(self.mesh) if self.mesh else ""
        object.__setattr__(self, "mesh", mesh)
        if mesh and self.name == DEFAULT_NAME:          # a file is not the analytic stage
            object.__setattr__(self, "name", Path(mesh).stem)
        if not mesh and self.name != DEFAULT_NAME:
            from .shapes import catalogue

            if self.name not in catalogue.CATALOGUE:
                raise TargetError(f"target field 'name': got {self.name!r}; must be one of "
                                  f"{', '.join(target_names())} or a label with a mesh file")
        if self.mass is None:
            if mesh:
                raise TargetError("target field 'mass': a mesh file's target needs its total "
                                  "mass in kg")
            if self.name == DEFAULT_NAME:
                mass = ZENIT_MASS
            else:
                from .shapes import catalogue

                mass = catalogue.entry(self.name).mass
            object.__setattr__(self, "mass", float(mass))
        for name in ("diameter", "length", "mass", "nozzle_length", "nozzle_base_radius",
                     "nozzle_exit_radius"):
            v = getattr(self, name)
            if isinstance(v, bool) or not (isinstance(v, (int, float)) and math.isfinite(v)
                                           and v > 0):
                raise TargetError(f"target field '{name}': got {v!r}; must be a finite number > 0")
        if self.mass > MAX_MASS:
            raise TargetError(f"target field 'mass': got {self.mass!r}; must be a mass in "
                              f"(0, {MAX_MASS:g}] kg")
        if self.nozzle and self.nozzle_base_radius > self.diameter / 2:
            raise TargetError("target field 'nozzle_base_radius': must not exceed the stage radius")
        if self.kind == "mesh" and self.nozzle:
            raise TargetError("target field 'nozzle': only the analytic Zenit-2 has a nozzle "
                              "option; a mesh carries its own")
        if self.kind == "revolution" and (self.com or self.inertia or self.units != "m"):
            raise TargetError("target fields 'com', 'inertia', 'units': only a mesh's target "
                              "takes them; the analytic Zenit-2 is uniform, in m")
        from .shapes.mesh import UNITS

        if self.units not in UNITS:
            raise TargetError(f"target field 'units': got {self.units!r}; must be one of "
                              f"{sorted(UNITS)}")
        for name, sizes in (("com", (0, 3)), ("inertia", (0, 6, 9)), ("attitude_deg", (0, 3))):
            v = getattr(self, name)
            t = finite_numbers(v)
            if t is None or len(t) not in sizes:
                raise TargetError(f"target field '{name}': got {v!r}; must be "
                                  f"{' or '.join(str(s) for s in sizes if s)} finite numbers "
                                  "(or empty for uniform density)")
            object.__setattr__(self, name, t)
        if self.kind == "mesh":
            path = self.mesh_path
            if not path.is_file():
                raise TargetError(f"target field 'mesh': {str(path)!r} is not a file")
            sha = file_sha256(path)
            if self.mesh_sha256 and self.mesh_sha256 != sha:
                raise TargetError(f"target field 'mesh_sha256': {path} has SHA-256 {sha[:12]}..., "
                                  f"not the recorded {self.mesh_sha256[:12]}...; the file changed")
            object.__setattr__(self, "mesh_sha256", sha)
            from .shapes import target_shape

            try:
                target_shape(self)                  # refused here, with the file's defect
            except ValueError as exc:
                raise TargetError(str(exc)) from None

    @property
    def kind(self) -> str:
        """The shape kind: 'revolution' (the analytic Zenit-2) or 'mesh'."""
        return "revolution" if self.name == DEFAULT_NAME and not self.mesh else "mesh"

    @property
    def mesh_path(self) -> Path:
        """The mesh file (the catalogue's for a catalogue name)."""
        if self.mesh:
            return Path(self.mesh).expanduser()
        from .shapes import catalogue

        return catalogue.mesh_path(catalogue.entry(self.name))

    def identity(self) -> dict:
        """Which target this is, as results records, capture outputs and replay report it:
        name, kind, mesh file, its SHA-256 and units."""
        return {"name": self.name, "kind": self.kind, "mesh": self.mesh,
                "mesh_sha256": self.mesh_sha256, "units": self.units}

    def to_dict(self) -> dict:
        """The settings as plain values; the revolution kind's new fields at their defaults
        are left out, so that a default target keeps the run keys it had before shapes."""
        d = asdict(self)
        d["com"], d["inertia"] = list(self.com), list(self.inertia)
        d["attitude_deg"] = list(self.attitude_deg)
        if self.kind == "revolution":
            keep = _REVOLUTION_FIELDS + (("attitude_deg",) if self.attitude_deg else ())
            return {k: d[k] for k in keep}
        return d


def target_names() -> list[str]:
    """The targets known by name: the analytic default, then the catalogue's."""
    from .shapes.catalogue import CATALOGUE

    return [DEFAULT_NAME, *CATALOGUE]


def target_fields(text: str) -> dict:
    """The TargetConfig fields a target is given by in one word (``--target``, a request's
    ``target``): a name of :func:`target_names`, or a mesh file (named by its stem)."""
    if text in target_names():
        return {"name": text, "mesh": ""}
    path = Path(text).expanduser()
    if path.suffix.lower() not in (".stl", ".obj", ".ply", ".glb", ".gltf", ".off"):
        raise TargetError(f"target: got {text!r}; must be one of {', '.join(target_names())} "
                          "or a mesh file (.stl, .obj, .ply, .glb, .gltf, .off)")
    if not path.is_file():
        raise TargetError(f"target: {text!r} is not a file")
    return {"name": path.stem, "mesh": str(path)}


def file_sha256(path: Path) -> str:
    """SHA-256 (hex) of a file's bytes."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()
