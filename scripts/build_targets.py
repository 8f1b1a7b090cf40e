#!/usr/bin/env python3
"""Build the debris-target catalogue's meshes and renders from cited dimensions.

Writes, for every target in TARGETS below:
  tethernet_ros/data/targets/<name>.stl   binary STL, metres, a closed, outward-oriented,
                                          single-body triangle mesh (a true union);
  docs/targets/<name>.png                 a 600 x 450 px render, equal axis scales;
then reloads every STL and prints its checks (watertight, winding, volume, area, bounds,
faces) and its uniform-density mass properties at the catalogue's mass
(tethernet_ros/core/shapes/catalogue.py). The output is deterministic: a rerun writes the
same bytes. Numbers and sources: docs/targets.md.

    .venv/bin/python scripts/build_targets.py

Needs trimesh, matplotlib and manifold3d (the boolean-union engine).
"""
from __future__ import annotations

import io
import math
import pathlib
import sys

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]

# ---------------------------------------------------------------------------------------
# Dimensions (m), each with the key of its source in SOURCES.  "assumed" marks a modelling
# choice with no source (its physical range is given in docs/targets.md).
SOURCES = {
    "text": "Botta et al. tether-net capture study, the project's 'text' (docs/model.md §1)",
    "project": "tethernet_ros core/target.py TargetConfig nozzle defaults (project assumption)",
    "esa-envisat": "ESA Earth Online, Envisat space segment: in orbit 26 m x 10 m x 5 m",
    "eduspace": "ESA Eduspace, Envisat fast facts: 10 m x 4 m x 4 m stowed",
    "space.com": "Space.com 2012, Pleiades view of Envisat: array 5 m wide, 14 m long",
    "adras-j": "Astroscale / JAXA CRD2 (ADRAS-J target): about 11 m long, about 4 m diameter",
    "esa-proba": "ESA Proba-1 facts and figures: 60 x 60 x 80 cm box",
    "assumed": "modelling assumption (docs/targets.md gives its range)",
}

DIMENSIONS = {
    "zenit-2": {
        "diameter": (3.9, "text"), "length": (10.4, "text"),
        "nozzle_length": (2.0, "project"), "nozzle_base_radius": (0.5, "project"),
        "nozzle_exit_radius": (1.0, "project"),
    },
    "envisat": {
        "body_length": (10.0, "eduspace"), "body_width": (4.0, "eduspace"),
        "body_height": (4.0, "eduspace"),
        "span": (26.0, "esa-envisat"),              # body + boom + array, along x
        "array_length": (14.0, "space.com"), "array_width": (5.0, "space.com"),
        "array_thickness": (0.03, "assumed"),
        "boom_side": (0.3, "assumed"),              # square cross-section
        "boom_embed": (0.1, "assumed"),             # boom ends sunk into body and array root
    },
    "h-iia-upper-stage": {"diameter": (4.0, "adras-j"), "length": (11.0, "adras-j")},
    "proba-1": {"x": (0.8, "esa-proba"), "y": (0.6, "esa-proba"), "z": (0.6, "esa-proba")},
}

#: Sections around every solid of revolution (the analytic target's comparison meshes).
SECTIONS = 128


def dim(target: str, key: str) -> float:
    return float(DIMENSIONS[target][key][0])


# ---------------------------------------------------------------------------------------
def _revolve_x(profile):
    """Solid of revolution about x from a meridian profile [(a, r), ...] (m) that starts and
    ends on the axis: trimesh revolves (r, a) about z, then z is turned onto x."""
    import trimesh

    prof = np.array([(r, a) for a, r in profile], dtype=float)
    mesh = trimesh.creation.revolve(prof, sections=SECTIONS)
    mesh.apply_transform(trimesh.transformations.rotation_matrix(math.pi / 2, [0, 1, 0]))
    return mesh


def zenit_cylinder():
    R, L = dim("zenit-2", "diameter") / 2, dim("zenit-2", "length")
    return _revolve_x([(-L / 2, 0.0), (-L / 2, R), (L / 2, R), (L / 2, 0.0)])


def zenit_nozzle():
    """Cylinder and nozzle frustum as one meridian polygon: their union by construction
    (the frustum's base disk lies on the -x end cap, as in core/target.py)."""
    R, L = dim("zenit-2", "diameter") / 2, dim("zenit-2", "length")
    h = dim("zenit-2", "nozzle_length")
    r0, r1 = dim("zenit-2", "nozzle_base_radius"), dim("zenit-2", "nozzle_exit_radius")
    a0 = -L / 2
    return _revolve_x([(a0 - h, 0.0), (a0 - h, r1), (a0, r0), (a0, R), (L / 2, R),
                       (L / 2, 0.0)])


def h2a_stage():
    R, L = dim("h-iia-upper-stage", "diameter") / 2, dim("h-iia-upper-stage", "length")
    return _revolve_x([(-L / 2, 0.0), (-L / 2, R), (L / 2, R), (L / 2, 0.0)])


def _box(lo, hi):
    import trimesh

    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    return trimesh.creation.box(extents=hi - lo,
                                transform=trimesh.transformations.translation_matrix((lo + hi) / 2))


def envisat():
    """Body box centred on the origin, a square boom along +x from the body's end face to the
    array's root, and the array plate in the x-y plane: their boolean union (manifold3d)."""
    import trimesh

    g = lambda k: dim("envisat", k)  # noqa: E731
    bl, bw, bh = g("body_length"), g("body_width"), g("body_height")
    al, aw, at = g("array_length"), g("array_width"), g("array_thickness")
    boom_len = g("span") - bl - al                      # 2.0 m between body and array
    b, e = g("boom_side") / 2, g("boom_embed")
    x_body, x_root = bl / 2, bl / 2 + boom_len
    body = _box((-bl / 2, -bw / 2, -bh / 2), (bl / 2, bw / 2, bh / 2))
    boom = _box((x_body - e, -b, -b), (x_root + e, b, b))
    plate = _box((x_root, -aw / 2, -at / 2), (x_root + al, aw / 2, at / 2))
    return trimesh.boolean.union([body, boom, plate], engine="manifold")


def proba1():
    x, y, z = (dim("proba-1", k) for k in ("x", "y", "z"))
    return _box((-x / 2, -y / 2, -z / 2), (x / 2, y / 2, z / 2))


#: name -> (builder, catalogue entry, the mesh's expected bounding box (lo, hi) in m).
def _targets():
    zr, zl = dim("zenit-2", "diameter") / 2, dim("zenit-2", "length")
    zh = dim("zenit-2", "nozzle_length")
    hr, hl = dim("h-iia-upper-stage", "diameter") / 2, dim("h-iia-upper-stage", "length")
    g = lambda k: dim("envisat", k)  # noqa: E731
    ew = max(g("body_width"), g("array_width")) / 2
    px, py, pz = (dim("proba-1", k) / 2 for k in ("x", "y", "z"))
    return {
        "zenit-2-nozzle": (zenit_nozzle, "zenit-2-nozzle",
                           ((-zl / 2 - zh, -zr, -zr), (zl / 2, zr, zr)),
                           f"Zenit-2 stage + nozzle: Ø{2 * zr:g} m x {zl:g} m + {zh:g} m"),
        "zenit-2-cylinder": (zenit_cylinder, "zenit-2-cylinder",
                             ((-zl / 2, -zr, -zr), (zl / 2, zr, zr)),
                             f"Zenit-2 stage: Ø{2 * zr:g} m x {zl:g} m"),
        "envisat": (envisat, "envisat",
                    ((-g("body_length") / 2, -ew, -g("body_height") / 2),
                     (g("span") - g("body_length") / 2, ew, g("body_height") / 2)),
                    f"Envisat: body {g('body_length'):g} x {g('body_width'):g} x "
                    f"{g('body_height'):g} m, array {g('array_length'):g} x "
                    f"{g('array_width'):g} m, span {g('span'):g} m"),
        "h-iia-upper-stage": (h2a_stage, "h-iia-upper-stage",
                              ((-hl / 2, -hr, -hr), (hl / 2, hr, hr)),
                              f"H-IIA upper stage: Ø{2 * hr:g} m x {hl:g} m"),
        "proba-1": (proba1, "proba-1", ((-px, -py, -pz), (px, py, pz)),
                    f"PROBA-1: {2 * px:g} x {2 * py:g} x {2 * pz:g} m box"),
    }


# ---------------------------------------------------------------------------------------
def write_stl(mesh, path: pathlib.Path, name: str) -> None:
    """Binary STL (little-endian float32) with a fixed 80-byte header naming the target."""
    header = f"tethernet_ros target {name}; metres; scripts/build_targets.py".encode("ascii")
    rec = np.zeros(len(mesh.faces), dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])
    rec["n"] = mesh.face_normals
    rec["v"] = mesh.triangles
    path.write_bytes(header.ljust(80, b" ")[:80] + np.uint32(len(mesh.faces)).tobytes()
                     + rec.tobytes())


def render(mesh, path: pathlib.Path, title: str) -> None:
    """Flat-shaded Poly3DCollection, equal scales on the three axes, 600 x 450 px."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import MaxNLocator
    from PIL import Image
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    elev, azim = math.radians(22.0), math.radians(-58.0)
    eye = np.array([math.cos(elev) * math.cos(azim), math.cos(elev) * math.sin(azim),
                    math.sin(elev)])
    front = mesh.face_normals @ eye > 0.0          # back faces culled: matplotlib's depth
    normals = mesh.face_normals[front]             # sort then cannot paint them on top
    light = np.array([0.35, -0.55, 0.76])
    light /= np.linalg.norm(light)
    shade = 0.30 + 0.70 * np.round(np.clip(normals @ light, 0.0, 1.0) * 24) / 24  # 25 tones
    colours = np.column_stack([np.outer(shade, (0.55, 0.62, 0.72)), np.ones(len(shade))])
    fig = plt.figure(figsize=(6.0, 4.5), dpi=100)
    ax = fig.add_subplot(projection="3d")
    ax.add_collection3d(Poly3DCollection(mesh.triangles[front], facecolors=colours,
                                         edgecolors=colours, linewidths=0.3))
    lo, hi = mesh.bounds
    span = hi - lo
    pad = 0.04 * span.max()
    for setter, a, b in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), lo - pad, hi + pad):
        setter(a, b)
    zoom = 1.1 if span.max() < 4.0 * span.min() else 0.95   # keep long bodies' labels in
    ax.set_box_aspect(tuple(span + 2 * pad), zoom=zoom)  # equal scales: aspect = data span
    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        axis.set_major_locator(MaxNLocator(nbins=5))
    ax.view_init(elev=math.degrees(elev), azim=math.degrees(azim))
    ax.set_xlabel("x (m)", fontsize=8)
    ax.set_ylabel("y (m)", fontsize=8)
    ax.set_zlabel("z (m)", fontsize=8)
    ax.tick_params(labelsize=7)
    ax.set_title(title, fontsize=9)
    fig.subplots_adjust(left=0.0, right=1.0, bottom=0.02, top=0.92)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    plt.close(fig)
    buf.seek(0)
    # a 64-colour palette (no dithering) keeps the file near 25 KB instead of 100 KB
    image = Image.open(buf).convert("RGB").quantize(colors=64, method=Image.Quantize.MEDIANCUT,
                                                    dither=Image.Dither.NONE)
    image.save(path, format="PNG", optimize=True)


def check(mesh, name: str, bounds, mass: float) -> dict:
    """The mesh's checks and its uniform-density mass properties at ``mass`` (kg)."""
    import manifold3d

    lo, hi = mesh.bounds
    status = manifold3d.Manifold(manifold3d.Mesh(
        vert_properties=np.asarray(mesh.vertices, np.float32),
        tri_verts=np.asarray(mesh.faces, np.uint32))).status()
    out = {
        "name": name, "faces": len(mesh.faces), "watertight": bool(mesh.is_watertight),
        "winding": bool(mesh.is_winding_consistent), "bodies": int(mesh.body_count),
        "euler": int(mesh.euler_number), "manifold": str(status).split(".")[-1],
        "volume": float(mesh.volume), "area": float(mesh.area), "lo": lo, "hi": hi,
    }
    ok = (out["watertight"] and out["winding"] and out["volume"] > 0 and out["bodies"] == 1
          and out["euler"] == 2 and out["manifold"] == "NoError"
          and np.allclose([lo, hi], bounds, atol=1e-5) and out["faces"] <= 4000)
    if not ok:
        raise SystemExit(f"{name}: mesh check failed: {out}")
    rho = mass / mesh.volume
    out["com"] = mesh.center_mass
    out["inertia"] = mesh.moment_inertia * rho      # about the CoM, mesh axes, kg m^2
    return out


def main() -> int:
    sys.path.insert(0, str(ROOT))
    import trimesh
    from tethernet_ros.core.shapes.catalogue import CATALOGUE

    mesh_dir = ROOT / "tethernet_ros" / "data" / "targets"
    png_dir = ROOT / "docs" / "targets"
    mesh_dir.mkdir(parents=True, exist_ok=True)
    png_dir.mkdir(parents=True, exist_ok=True)
    rows = []
    for name, (build, entry_name, bounds, label) in _targets().items():
        entry = CATALOGUE[entry_name]
        assert entry.mesh == f"{name}.stl", (entry.mesh, name)
        mesh = build()
        if mesh.volume < 0:
            mesh.invert()
        write_stl(mesh, mesh_dir / f"{name}.stl", name)
        loaded = trimesh.load(mesh_dir / f"{name}.stl", file_type="stl", force="mesh")
        rows.append(check(loaded, name, bounds, entry.mass))
        render(loaded, png_dir / f"{name}.png", f"{name} — {label}, {entry.mass:g} kg")
    np.set_printoptions(precision=4, suppress=True, linewidth=120)
    for r in rows:
        size = (mesh_dir / f"{r['name']}.stl").stat().st_size
        print(f"{r['name']}: faces {r['faces']} ({size} B), watertight {r['watertight']}, "
              f"winding consistent {r['winding']}, bodies {r['bodies']}, euler {r['euler']}, "
              f"manifold3d {r['manifold']}")
        print(f"  volume {r['volume']:.6g} m^3, area {r['area']:.6g} m^2, "
              f"bounds {np.round(r['lo'], 6).tolist()} .. {np.round(r['hi'], 6).tolist()} m")
        print(f"  uniform density: CoM {np.round(r['com'], 4).tolist()} m, inertia (kg m^2)\n"
              f"{np.round(r['inertia'], 1)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
