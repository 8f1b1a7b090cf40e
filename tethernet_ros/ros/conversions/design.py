"""Design.msg from and to the core's Design."""
from __future__ import annotations

from ...core.design import Design, DesignError
from .errors import RequestError, detail


#: core design field -> Design.msg field
DESIGN_FIELDS = {"m_c": "corner_mass", "L_n": "net_side", "r_n": "thread_radius",
                 "d_L": "distance_to_target", "V_e": "launch_velocity",
                 "d_c": "closing_displacement"}

def design_msg(design: Design):
    from tethernet_msgs.msg import Design as DesignMsg

    m = DesignMsg()
    m.corner_mass = float(design.m_c)
    m.net_side = float(design.L_n)
    m.thread_radius = float(design.r_n)
    m.distance_to_target = float(design.d_L)
    m.launch_velocity = [float(v) for v in design.V_e]
    m.closing_displacement = float(design.d_c)
    return m


def design_from_msg(m, prefix: str = "design") -> Design:
    """Core Design of a Design message; RequestError naming ``design.<field>`` if invalid."""
    try:
        ve = [float(v) for v in m.launch_velocity]
        if len(ve) != 3:
            raise RequestError(f"{prefix}.launch_velocity", f"expected 3 values, got {len(ve)}")
        return Design(m_c=float(m.corner_mass), L_n=float(m.net_side), r_n=float(m.thread_radius),
                      d_L=float(m.distance_to_target), V_e=tuple(ve),
                      d_c=float(m.closing_displacement))
    except DesignError as exc:
        core = exc.field.split("[")[0]
        name = DESIGN_FIELDS.get(core, core)
        index = exc.field[len(core):]
        raise RequestError(f"{prefix}.{name}{index}", f"({exc.field}) {detail(exc)}") from None
