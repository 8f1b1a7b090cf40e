"""`tethernet target show NAME|FILE`: what the tool made of a target (docs/targets.md,
docs/model.md §15): its kind, mass, volume, surface area, principal moments and axes,
L_c, bounding radius, the optimiser's design bounds for it, the repairs made to its mesh
file, and the tug test's required pull on it (docs/model.md §17); with ``--png`` a
drawing of it in its body frame."""
from __future__ import annotations

from pathlib import Path

from .common import add_target_file_arguments, print_json, target_fields

NAME = "target"
HELP = ("show what the tool made of a target (a catalogue name or a mesh file): mass, "
        "volume, area, principal moments and axes, L_c, bounding radius, design bounds, "
        "repairs, the required pull; --png draws it")


def add_arguments(p):
    p.add_argument("action", choices=("show",), help="show: print the target's properties")
    p.add_argument("target", metavar="NAME|FILE",
                   help="a catalogue name (zenit-2, envisat, h-iia-upper-stage, proba-1, "
                        "zenit-2-nozzle, zenit-2-cylinder) or a mesh file (.stl, .obj, .ply, "
                        ".glb, .gltf, .off; give --target-mass)")
    add_target_file_arguments(p)
    p.add_argument("--png", default=None, metavar="FILE.png", help="draw it into FILE.png")
    p.add_argument("--json", action="store_true", help="print one JSON object")


def target_report(config) -> dict:
    """The properties of a target configuration (``core.target.TargetConfig``), SI units."""
    import numpy as np

    from ..core.config import SimConfig
    from ..core.shapes import target_shape
    from ..core.shapes.catalogue import design_bounds_of
    from ..core.tug import TugConfig, breaking_load, required_pull

    shape = target_shape(config)
    axes = np.asarray(getattr(shape, "axes", np.eye(3)), dtype=float)
    tug = TugConfig()
    radius = SimConfig().tether_radius          # the default main tether's
    limit = breaking_load(tug, radius)
    return {
        "target": config.name or config.mesh, "kind": shape.kind, "mass": float(shape.mass),
        "volume": float(shape.volume), "area": float(shape.area),
        "principal_moments": [float(m) for m in shape.inertia],
        "principal_axes": [[float(c) for c in axes[:, j]] for j in range(3)],
        "L_c": float(shape.min_surface_distance),
        "bounding_radius": float(shape.bounding_radius),
        "extent": [float(e) for e in shape.extent],
        "design_bounds": {k: [float(lo), float(hi)]
                          for k, (lo, hi) in design_bounds_of(config).items()},
        "repairs": list(getattr(shape, "repairs", ()) or []),
        "required_pull": required_pull(tug, float(shape.mass), radius),
        "tether_radius": radius,
        "tow_acceleration": tug.tow_acceleration,
        "largest_tow_acceleration": limit / float(shape.mass),
    }


def report_text(r: dict) -> str:
    def vec(v, digits=4):
        return "(" + ", ".join(f"{c + 0.0:.{digits}g}" for c in v) + ")"   # (no -0)
    lines = [f"target {r['target']} ({r['kind']})",
             f"  mass               {r['mass']:.6g} kg",
             f"  volume             {r['volume']:.6g} m^3",
             f"  surface area       {r['area']:.6g} m^2",
             f"  principal moments  {vec(r['principal_moments'], 6)} kg m^2 (body x, y, z; "
             "x the long axis)",
             "  principal axes     " + ", ".join(vec(a, 4) for a in r["principal_axes"])
             + " (body x, y, z in the file's frame)",
             f"  L_c                {r['L_c']:.4g} m (centre of mass to the nearest surface)",
             f"  bounding radius    {r['bounding_radius']:.4g} m",
             f"  extent             {vec(r['extent'])} m (half length along body x, "
             "radius about it)",
             "  design bounds      " + ", ".join(f"{k} [{lo:.4g}, {hi:.4g}]"
                                                 for k, (lo, hi) in r["design_bounds"].items()),
             "  repairs            " + ("; ".join(r["repairs"]) or "none"),
             f"  required pull      {r['required_pull']:.4g} N at {r['tow_acceleration']:g} "
             f"m/s^2 (the tug test, docs/model.md §17; at most "
             f"{r['largest_tow_acceleration']:.4g} m/s^2 on the default "
             f"{r['tether_radius'] * 1e3:g} mm tether)"]
    return "\n".join(lines)


def draw(config, png: Path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    from ..core.shapes import target_shape

    mesh = target_shape(config).trimesh()
    tris = mesh.vertices[mesh.faces]
    fig = plt.figure(figsize=(6.4, 5.0))
    ax = fig.add_subplot(projection="3d")
    ax.add_collection3d(Poly3DCollection(tris, facecolor=(0.6, 0.62, 0.68, 0.9),
                                         edgecolor=(0.2, 0.2, 0.25, 0.3), linewidth=0.2))
    lo, hi = mesh.vertices.min(axis=0), mesh.vertices.max(axis=0)
    centre, half = (lo + hi) / 2, max(hi - lo) / 2
    for setter, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), centre):
        setter(c - half, c + half)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")
    ax.set_title(title)
    png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(png, dpi=110)
    plt.close(fig)


def run(args) -> int:
    from ..core.target import TargetConfig, TargetError
    from ..errors import UserError

    fields = target_fields(args.target)
    if args.target_mass is not None:
        fields["mass"] = args.target_mass
    if args.target_units is not None:
        fields["units"] = args.target_units
    try:
        config = TargetConfig(**fields)
    except TargetError as exc:
        raise UserError(f"target: {exc}") from None
    report = target_report(config)
    if args.png:
        draw(config, Path(args.png), f"{report['target']} (body frame)")
        report["png"] = args.png
    if args.json:
        print_json(report)
    else:
        print(report_text(report) + (f"\n  figure             {args.png}" if args.png else ""))
    return 0
