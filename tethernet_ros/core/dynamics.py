"""The numba kernels: one time step of the lumped-parameter net, its contacts with the
target and the drawstring closing, repeated ``n_steps`` times.

Numerical method
----------------
Threads have axial stiffness k = E pi r^2 / l0 up to ~1e7 N/m on nodes of a few grams:
their axial modes (omega ~ sqrt(E/rho)/l0 ~ 6000 rad/s) would force an explicit integrator
to dt < ~1.5e-4 s.  Those modes are also damped by the threads' own damping (zeta = 0.106,
decay time 1/(zeta omega) ~ 2 ms), so nothing of them survives to the time scale of a
capture (seconds).  We therefore integrate with small-step XPBD (Macklin et al. 2016,
2019): each step predicts positions with the external forces, then makes one Gauss-Seidel
pass over the compliant constraints.  With one pass per step this is the implicit (backward)
Euler method for each spring-damper in turn:

    * thread (tension-only Kelvin-Voigt): compliance alpha = 1/k, damping c = 2 zeta
      sqrt(k m_eff); force only while stretched and never pushing;
    * contact (Kelvin-Voigt penalty, never pulling) with stiffness k_c and damping c_c;
    * drawstring lock: a distance joint whose maximum distance ratchets down toward 0
      (rigid, one-sided);

then velocities are v = (x - x_prev)/dt, and Coulomb friction is applied as a velocity
projection bounded by mu times the normal impulse.  Implicit Euler is unconditionally
stable for the springs, first-order accurate, and dissipates: slow modes (pendulum,
flight, wrapping; omega dt << 1) are integrated accurately, the stiff axial modes are
damped at once.  Linear momentum is conserved to round-off by every constraint and contact
(equal and opposite impulses act on the target).

Units: SI throughout (m, s, kg, N).
"""
from __future__ import annotations

import numpy as np
from numba import njit

# indices into the float parameter vector ``prm``
P_DT, P_CLOSE_FORCE, P_CLOSE_THRESHOLD, P_LOCK_DIST, P_MU, P_K_CONTACT, P_ZETA_CONTACT, \
    P_TGT_INV_MASS, P_TGT_BOUND, P_TETHER_LIN_DENSITY, P_TETHER_EA, P_ZETA_THREAD = range(12)
N_PRM = 12
# indices into the integer state vector ``ev``
E_STEP, E_CLOSING_ARMED, E_CLOSING_ACTIVE, E_CLOSING_STEP, E_TETHER_LOCKED, E_MAX_CONTACTS = range(6)
N_EV = 6


@njit(cache=True, inline='always', error_model='numpy')
def polygon_sdf(pa, pr, verts, start, stop):
    """Signed distance (m) of the 2D point (pa, pr) to the convex polygon
    verts[start:stop] and its gradient (ga, gr).  Negative inside."""
    d = (pa - verts[start, 0]) ** 2 + (pr - verts[start, 1]) ** 2
    ba = pa - verts[start, 0]
    br = pr - verts[start, 1]
    s = 1.0
    n = stop - start
    for k in range(n):
        i = start + k
        j = i - 1 if k > 0 else stop - 1
        ea = verts[j, 0] - verts[i, 0]
        er = verts[j, 1] - verts[i, 1]
        wa = pa - verts[i, 0]
        wr = pr - verts[i, 1]
        t = (wa * ea + wr * er) / (ea * ea + er * er)
        if t < 0.0:
            t = 0.0
        elif t > 1.0:
            t = 1.0
        qa = wa - ea * t
        qr = wr - er * t
        dd = qa * qa + qr * qr
        if dd < d:
            d = dd
            ba = qa
            br = qr
        c1 = pr >= verts[i, 1]
        c2 = pr < verts[j, 1]
        c3 = ea * wr > er * wa
        if (c1 and c2 and c3) or ((not c1) and (not c2) and (not c3)):
            s = -s
    dist = np.sqrt(d)
    if dist > 1e-14:
        ga = s * ba / dist
        gr = s * br / dist
    else:
        ga = 0.0
        gr = 1.0
    return s * dist, ga, gr


@njit(cache=True, inline='always', error_model='numpy')
def cylinder_sdf(pa, pr, cyl):
    """Signed distance (m) of the meridional point (pa, pr >= 0) to the cylinder
    cyl = [axial centre, half length, radius] and its gradient (ga, gr).  Written with
    |pa - centre| so that it is exactly mirror-symmetric about the mid-plane."""
    da = pa - cyl[0]
    sa = 1.0 if da >= 0.0 else -1.0
    qa = abs(da) - cyl[1]
    qr = pr - cyl[2]
    if qa > 0.0 and qr > 0.0:
        d = np.sqrt(qa * qa + qr * qr)
        return d, sa * qa / d, qr / d
    if qa > qr:
        return qa, sa, 0.0
    return qr, 0.0, 1.0


@njit(cache=True, inline='always', error_model='numpy')
def _local_sdf(lx, ly, lz, cyl, verts, offsets):
    """Signed distance and outward unit normal (body frame) of a body-frame point to the
    union of the cylinder and the extra solids of revolution."""
    r = np.sqrt(ly * ly + lz * lz)
    if r > 1e-12:
        uy = ly / r
        uz = lz / r
    else:
        uy = 1.0
        uz = 0.0
    best, ga, gr = cylinder_sdf(lx, r, cyl)
    for p in range(offsets.shape[0] - 1):
        sd, pa_, pr_ = polygon_sdf(lx, r, verts, offsets[p], offsets[p + 1])
        if sd < best:
            best = sd
            ga = pa_
            gr = pr_
    return best, ga, gr * uy, gr * uz


@njit(cache=True)
def target_signed_distance(p_local, cyl, verts, offsets):
    """Signed distance (m) of a body-frame point to the target and the outward normal."""
    sd, nx, ny, nz = _local_sdf(p_local[0], p_local[1], p_local[2], cyl, verts, offsets)
    return sd, np.array([nx, ny, nz])


@njit(cache=True)
def quat_to_matrix(q):
    """Rotation matrix of the unit quaternion q = (w, x, y, z) (body -> world)."""
    R = np.empty((3, 3))
    quat_to_matrix_into(q, R)
    return R


@njit(cache=True, inline='always')
def quat_to_matrix_into(q, R):
    w, x, y, z = q[0], q[1], q[2], q[3]
    R[0, 0] = 1 - 2 * (y * y + z * z)
    R[0, 1] = 2 * (x * y - w * z)
    R[0, 2] = 2 * (x * z + w * y)
    R[1, 0] = 2 * (x * y + w * z)
    R[1, 1] = 1 - 2 * (x * x + z * z)
    R[1, 2] = 2 * (y * z - w * x)
    R[2, 0] = 2 * (x * z - w * y)
    R[2, 1] = 2 * (y * z + w * x)
    R[2, 2] = 1 - 2 * (x * x + y * y)


@njit(cache=True, inline='always', error_model='numpy')
def _link_multiplier(x, xp, w, i, j, rest, gamma, inv_den, rigid, out_n):
    """XPBD multiplier increment (N s^2; <= 0 means tension) of a tension-only
    spring-damper between bodies i and j; its unit direction i -> j goes to out_n.

    gamma = c / (k dt) is the damping factor and inv_den = 1 / ((1 + gamma)(w_i + w_j)
    + 1/(k dt^2)) the inverse of the effective mass term; with ``rigid`` the link is a
    one-sided rigid distance limit instead."""
    dx = x[j, 0] - x[i, 0]
    dy = x[j, 1] - x[i, 1]
    dz = x[j, 2] - x[i, 2]
    length = np.sqrt(dx * dx + dy * dy + dz * dz)
    C = length - rest
    if C <= 0.0 or length < 1e-14:
        return 0.0
    inv_len = 1.0 / length
    nx = dx * inv_len
    ny = dy * inv_len
    nz = dz * inv_len
    out_n[0] = nx
    out_n[1] = ny
    out_n[2] = nz
    if rigid:
        wsum = w[i] + w[j]
        if wsum == 0.0:
            return 0.0
        return -C / wsum
    rel = (nx * ((x[j, 0] - xp[j, 0]) - (x[i, 0] - xp[i, 0]))
           + ny * ((x[j, 1] - xp[j, 1]) - (x[i, 1] - xp[i, 1]))
           + nz * ((x[j, 2] - xp[j, 2]) - (x[i, 2] - xp[i, 2])))
    dlam = (-C - gamma * rel) * inv_den
    if dlam > 0.0:  # the damper would push: a thread never pushes
        dlam = 0.0
    return dlam


@njit(cache=True, error_model='numpy')
def _solve_group(x, xp, w, pairs, start, stop, rest, gamma, inv_den, active, rigid, relax,
                 dl, dn, corr):
    """Project the links pairs[start:stop] together (Jacobi within the group): every
    multiplier is computed from the same positions, the corrections are summed per body
    and then applied.  Groups of links that share no body are exactly Gauss-Seidel; the
    result never depends on the order of links inside a group (mirror symmetry).  A group
    with ``relax`` == 1 must share no body and is projected link by link (the same result,
    cheaper).  Where links of a group share bodies, ``relax`` (0.5 for a body in two links)
    scales the multipliers so that the summed correction cannot overshoot."""
    if relax == 1.0:
        # links of the group share no body: project and apply one after the other
        for m in range(start, stop):
            if active[m] == 1:
                d = _link_multiplier(x, xp, w, pairs[m, 0], pairs[m, 1], rest[m],
                                     gamma[m], inv_den[m], rigid, dn[m])
                if d != 0.0:
                    i = pairs[m, 0]
                    j = pairs[m, 1]
                    for c in range(3):
                        x[i, c] -= w[i] * d * dn[m, c]
                        x[j, c] += w[j] * d * dn[m, c]
        return
    for m in range(start, stop):
        dl[m] = 0.0
        if active[m] == 1:
            dl[m] = _link_multiplier(x, xp, w, pairs[m, 0], pairs[m, 1], rest[m],
                                     gamma[m], inv_den[m], rigid, dn[m]) * relax
    for m in range(start, stop):
        if dl[m] != 0.0:
            i = pairs[m, 0]
            j = pairs[m, 1]
            for c in range(3):
                corr[i, c] -= w[i] * dl[m] * dn[m, c]
                corr[j, c] += w[j] * dl[m] * dn[m, c]
    for m in range(start, stop):
        if dl[m] != 0.0:
            i = pairs[m, 0]
            j = pairs[m, 1]
            for c in range(3):
                x[i, c] += corr[i, c]
                corr[i, c] = 0.0
                x[j, c] += corr[j, c]
                corr[j, c] = 0.0


@njit(cache=True, error_model='numpy')
def _link_factors(links, link_compliance, link_damping, w, dt, gamma, inv_den):
    """Per-link constants of the XPBD update (see _solve_link)."""
    for m in range(links.shape[0]):
        a = links[m, 0]
        b = links[m, 1]
        wsum = w[a] + w[b]
        g = link_compliance[m] * link_damping[m] / dt
        den = (1.0 + g) * wsum + link_compliance[m] / (dt * dt)
        gamma[m] = g
        inv_den[m] = 1.0 / den if den > 0.0 else 0.0


@njit(cache=True, error_model='numpy')
def advance(n_steps, x, v, w, mass, radius, contact_mask,
            links, link_groups, link_relax, link_rest, link_compliance, link_damping, link_active,
            net_nodes, ring_pairs, pair_locked, pair_maxdist, pair_lock_step,
            tether_nodes, tether_links, centre_node, winch_body,
            tgt_pos, tgt_quat, tgt_vel, tgt_omega, tgt_inertia, cyl, verts, offsets,
            prm, ev, contact_count, max_penetration, work_xp, work_cn, work_cj, work_cb):
    """Advance the state ``n_steps`` steps of dt = prm[P_DT] in place.

    x, v: (N, 3) positions (m) and velocities (m/s); w: (N,) inverse masses (1/kg, 0 for
    kinematic bodies); mass (N,) (kg); radius (N,) contact sphere radii (m);
    contact_mask (N,) 1 where the body collides with the target.
    links (M, 2) body pairs of the threads and tether segments with rest length (m),
    compliance 1/k (m/N), damping c (N s/m) and an active flag; link_groups (G + 1,) the
    start of each group of links projected together and link_relax (G,) its relaxation
    (see _solve_group).
    ring_pairs (12, 2): adjacent drawstring nodes; pair_locked/pair_maxdist/pair_lock_step
    hold the lock state.  tether_nodes: indices of the tether's lumped masses (kinematic
    on a straight line while the winch pays out); tether_links: their link indices.
    Target: position (m), quaternion (w,x,y,z), velocity (m/s), angular velocity (rad/s,
    world), principal inertia (kg m^2), cylinder [axial centre, half length, radius] (m)
    and meridional polygons of any extra solid (verts, offsets).
    ev: integer episode state (see E_* indices); contact_count accumulates body-steps in
    contact; max_penetration[0] the deepest penetration (m) seen.
    """
    dt = prm[P_DT]
    n_bodies = x.shape[0]
    n_links = links.shape[0]
    n_pairs = ring_pairs.shape[0]
    n_tether = tether_nodes.shape[0]
    close_force = prm[P_CLOSE_FORCE]
    mu = prm[P_MU]
    kc = prm[P_K_CONTACT]
    tgt_w = prm[P_TGT_INV_MASS]
    bound = prm[P_TGT_BOUND]
    inv_i = 1.0 / tgt_inertia
    link_dl = np.zeros(n_links)
    link_dn = np.zeros((n_links, 3))
    pair_dl = np.zeros(n_pairs)
    pair_dn = np.zeros((n_pairs, 3))
    pair_zero = np.zeros(n_pairs)
    corr = np.zeros((n_bodies, 3))
    R = np.empty((3, 3))
    link_gamma = np.empty(n_links)
    link_inv_den = np.empty(n_links)
    _link_factors(links, link_compliance, link_damping, w, dt, link_gamma, link_inv_den)
    # per-body contact constants: damping factor and inverse effective mass term
    body_gamma = np.empty(n_bodies)
    body_inv_den = np.empty(n_bodies)
    at_c = 1.0 / (kc * dt * dt)
    for i in range(n_bodies):
        cc = 2.0 * prm[P_ZETA_CONTACT] * np.sqrt(kc * mass[i])
        body_gamma[i] = cc / (kc * dt)
        body_inv_den[i] = 1.0 / ((1.0 + body_gamma[i]) * w[i] + at_c)
    net_mass = 0.0
    for k in range(net_nodes.shape[0]):
        net_mass += mass[net_nodes[k]]

    for _ in range(n_steps):
        # ---- 1. external forces: drawstring closing -------------------------------
        if ev[E_CLOSING_ACTIVE] == 1:
            for p in range(n_pairs):
                a = ring_pairs[p, 0]
                b = ring_pairs[p, 1]
                dx = x[b, 0] - x[a, 0]
                dy = x[b, 1] - x[a, 1]
                dz = x[b, 2] - x[a, 2]
                d = np.sqrt(dx * dx + dy * dy + dz * dz)
                if d > 1e-12:
                    s = close_force * dt / d
                    corr[a, 0] += s * dx
                    corr[a, 1] += s * dy
                    corr[a, 2] += s * dz
                    corr[b, 0] -= s * dx
                    corr[b, 1] -= s * dy
                    corr[b, 2] -= s * dz
            # summed per node before use, so the result is independent of pair order
            for p in range(n_pairs):
                for e in range(2):
                    a = ring_pairs[p, e]
                    for c in range(3):
                        v[a, c] += w[a] * corr[a, c]
                        corr[a, c] = 0.0
        # ---- 2. prediction ----------------------------------------------------------
        for i in range(n_bodies):
            for c in range(3):
                work_xp[i, c] = x[i, c]
                x[i, c] += dt * v[i, c]
        if ev[E_TETHER_LOCKED] == 0:
            # the winch pays out freely: the deployed tether lies straight and slack
            for k in range(n_tether):
                f = (k + 1.0) / (n_tether + 1.0)
                t = tether_nodes[k]
                for c in range(3):
                    x[t, c] = x[winch_body, c] + f * (x[centre_node, c] - x[winch_body, c])
        # target pose
        for c in range(3):
            tgt_pos[c] += dt * tgt_vel[c]
        q0, q1, q2, q3 = tgt_quat[0], tgt_quat[1], tgt_quat[2], tgt_quat[3]
        ox, oy, oz = tgt_omega[0], tgt_omega[1], tgt_omega[2]
        h = 0.5 * dt
        n0 = q0 + h * (-ox * q1 - oy * q2 - oz * q3)
        n1 = q1 + h * (ox * q0 + oy * q3 - oz * q2)
        n2 = q2 + h * (-ox * q3 + oy * q0 + oz * q1)
        n3 = q3 + h * (ox * q2 - oy * q1 + oz * q0)
        qn = np.sqrt(n0 * n0 + n1 * n1 + n2 * n2 + n3 * n3)
        tgt_quat[0] = n0 / qn
        tgt_quat[1] = n1 / qn
        tgt_quat[2] = n2 / qn
        tgt_quat[3] = n3 / qn
        quat_to_matrix_into(tgt_quat, R)
        # ---- 3. constraints: threads, tether, locks ------------------------------------
        for g in range(link_groups.shape[0] - 1):
            _solve_group(x, work_xp, w, links, link_groups[g], link_groups[g + 1], link_rest,
                         link_gamma, link_inv_den, link_active, False, link_relax[g],
                         link_dl, link_dn, corr)
        _solve_group(x, work_xp, w, ring_pairs, 0, n_pairs, pair_maxdist, pair_zero,
                     pair_zero, pair_locked, True, 0.5, pair_dl, pair_dn, corr)
        # ---- 4. contacts with the target (compliant, never pulling) --------------------
        n_contacts = 0
        jx = 0.0
        jy = 0.0
        jz = 0.0
        lx_ = 0.0
        ly_ = 0.0
        lz_ = 0.0
        for i in range(n_bodies):
            if contact_mask[i] == 0 or w[i] == 0.0:
                continue
            rx = x[i, 0] - tgt_pos[0]
            ry = x[i, 1] - tgt_pos[1]
            rz = x[i, 2] - tgt_pos[2]
            rb = bound + radius[i]
            if rx * rx + ry * ry + rz * rz > rb * rb:
                continue
            # to the body frame: R^T r
            bx = R[0, 0] * rx + R[1, 0] * ry + R[2, 0] * rz
            by = R[0, 1] * rx + R[1, 1] * ry + R[2, 1] * rz
            bz = R[0, 2] * rx + R[1, 2] * ry + R[2, 2] * rz
            sd, nbx, nby, nbz = _local_sdf(bx, by, bz, cyl, verts, offsets)
            C = sd - radius[i]
            if C >= 0.0:
                continue
            if -C > max_penetration[0]:
                max_penetration[0] = -C
            nx = R[0, 0] * nbx + R[0, 1] * nby + R[0, 2] * nbz
            ny = R[1, 0] * nbx + R[1, 1] * nby + R[1, 2] * nbz
            nz = R[2, 0] * nbx + R[2, 1] * nby + R[2, 2] * nbz
            # displacement of the body relative to the target's surface point this step
            svx = tgt_vel[0] + oy * rz - oz * ry
            svy = tgt_vel[1] + oz * rx - ox * rz
            svz = tgt_vel[2] + ox * ry - oy * rx
            rel = (nx * (x[i, 0] - work_xp[i, 0] - dt * svx)
                   + ny * (x[i, 1] - work_xp[i, 1] - dt * svy)
                   + nz * (x[i, 2] - work_xp[i, 2] - dt * svz))
            dlam = (-C - body_gamma[i] * rel) * body_inv_den[i]
            if dlam <= 0.0:  # a contact never pulls
                continue
            x[i, 0] += w[i] * dlam * nx
            x[i, 1] += w[i] * dlam * ny
            x[i, 2] += w[i] * dlam * nz
            jn = dlam / dt  # normal impulse on the body (N s)
            work_cb[n_contacts] = i
            work_cn[n_contacts, 0] = nx
            work_cn[n_contacts, 1] = ny
            work_cn[n_contacts, 2] = nz
            work_cj[n_contacts] = jn
            n_contacts += 1
        contact_count[0] += n_contacts
        # ---- 5. velocities -------------------------------------------------------------
        for i in range(n_bodies):
            for c in range(3):
                v[i, c] = (x[i, c] - work_xp[i, c]) / dt
        # ---- 6. Coulomb friction (velocity projection) and impulses on the target -----
        for k in range(n_contacts):
            i = work_cb[k]
            nx = work_cn[k, 0]
            ny = work_cn[k, 1]
            nz = work_cn[k, 2]
            jn = work_cj[k]
            rx = x[i, 0] - tgt_pos[0]
            ry = x[i, 1] - tgt_pos[1]
            rz = x[i, 2] - tgt_pos[2]
            svx = tgt_vel[0] + oy * rz - oz * ry
            svy = tgt_vel[1] + oz * rx - ox * rz
            svz = tgt_vel[2] + ox * ry - oy * rx
            vrx = v[i, 0] - svx
            vry = v[i, 1] - svy
            vrz = v[i, 2] - svz
            vn = vrx * nx + vry * ny + vrz * nz
            tx = vrx - vn * nx
            ty = vry - vn * ny
            tz = vrz - vn * nz
            vt = np.sqrt(tx * tx + ty * ty + tz * tz)
            # impulse on the body: normal jn n, friction -min(mu jn, m |v_t|) t_hat
            fx = jn * nx
            fy = jn * ny
            fz = jn * nz
            if vt > 1e-12 and mu > 0.0:
                dv = mu * jn * w[i]
                if dv > vt:
                    dv = vt
                v[i, 0] -= dv * tx / vt
                v[i, 1] -= dv * ty / vt
                v[i, 2] -= dv * tz / vt
                fm = dv * mass[i] / vt
                fx -= fm * tx
                fy -= fm * ty
                fz -= fm * tz
            # equal and opposite impulse on the target, acting at the body's centre
            jx -= fx
            jy -= fy
            jz -= fz
            lx_ -= ry * fz - rz * fy
            ly_ -= rz * fx - rx * fz
            lz_ -= rx * fy - ry * fx
        # ---- 7. target velocities: impulses, then torque-free Euler equations ----------
        tgt_vel[0] += tgt_w * jx
        tgt_vel[1] += tgt_w * jy
        tgt_vel[2] += tgt_w * jz
        # angular momentum change in the body frame
        Lbx = R[0, 0] * lx_ + R[1, 0] * ly_ + R[2, 0] * lz_
        Lby = R[0, 1] * lx_ + R[1, 1] * ly_ + R[2, 1] * lz_
        Lbz = R[0, 2] * lx_ + R[1, 2] * ly_ + R[2, 2] * lz_
        wbx = R[0, 0] * ox + R[1, 0] * oy + R[2, 0] * oz
        wby = R[0, 1] * ox + R[1, 1] * oy + R[2, 1] * oz
        wbz = R[0, 2] * ox + R[1, 2] * oy + R[2, 2] * oz
        wbx += Lbx * inv_i[0] + dt * inv_i[0] * (tgt_inertia[1] - tgt_inertia[2]) * wby * wbz
        wby += Lby * inv_i[1] + dt * inv_i[1] * (tgt_inertia[2] - tgt_inertia[0]) * wbz * wbx
        wbz += Lbz * inv_i[2] + dt * inv_i[2] * (tgt_inertia[0] - tgt_inertia[1]) * wbx * wby
        tgt_omega[0] = R[0, 0] * wbx + R[0, 1] * wby + R[0, 2] * wbz
        tgt_omega[1] = R[1, 0] * wbx + R[1, 1] * wby + R[1, 2] * wbz
        tgt_omega[2] = R[2, 0] * wbx + R[2, 1] * wby + R[2, 2] * wbz

        ev[E_STEP] += 1
        # ---- 8. events: closing trigger, tether lock, drawstring locks -----------------
        if ev[E_CLOSING_ARMED] == 1 and ev[E_CLOSING_ACTIVE] == 0:
            zc = 0.0
            for k in range(net_nodes.shape[0]):
                zc += mass[net_nodes[k]] * x[net_nodes[k], 2]
            zc /= net_mass
            if zc - tgt_pos[2] >= prm[P_CLOSE_THRESHOLD]:
                ev[E_CLOSING_ACTIVE] = 1
                ev[E_CLOSING_STEP] = ev[E_STEP]
                if ev[E_TETHER_LOCKED] == 0:
                    # the winch locks the paid-out length; the tether's mass joins in
                    # (the winch end is the chaser, the other the net's centre node)
                    ev[E_TETHER_LOCKED] = 1
                    for k in range(tether_links.shape[0]):
                        m = tether_links[k]
                        a = links[m, 0]
                        b = links[m, 1]
                        dx = x[b, 0] - x[a, 0]
                        dy = x[b, 1] - x[a, 1]
                        dz = x[b, 2] - x[a, 2]
                        link_rest[m] = np.sqrt(dx * dx + dy * dy + dz * dz)
                        link_active[m] = 1
                    for k in range(n_tether):
                        # each lumped mass carries one segment of tether
                        t = tether_nodes[k]
                        mass[t] = prm[P_TETHER_LIN_DENSITY] * link_rest[tether_links[0]]
                        w[t] = 1.0 / mass[t]
                        contact_mask[t] = 1
                    for k in range(tether_links.shape[0]):
                        # spring-damper constants of the segment, now that its length is known
                        m = tether_links[k]
                        a = links[m, 0]
                        b = links[m, 1]
                        kk = prm[P_TETHER_EA] / link_rest[m]
                        link_compliance[m] = 1.0 / kk
                        meff = mass[a] * mass[b] / (mass[a] + mass[b])
                        link_damping[m] = 2.0 * prm[P_ZETA_THREAD] * np.sqrt(kk * meff)
                    _link_factors(links, link_compliance, link_damping, w, dt, link_gamma, link_inv_den)
                    for k in range(n_tether):
                        t = tether_nodes[k]
                        cc = 2.0 * prm[P_ZETA_CONTACT] * np.sqrt(kc * mass[t])
                        body_gamma[t] = cc / (kc * dt)
                        body_inv_den[t] = 1.0 / ((1.0 + body_gamma[t]) * w[t] + at_c)
        if ev[E_CLOSING_ACTIVE] == 1:
            for p in range(n_pairs):
                a = ring_pairs[p, 0]
                b = ring_pairs[p, 1]
                dx = x[b, 0] - x[a, 0]
                dy = x[b, 1] - x[a, 1]
                dz = x[b, 2] - x[a, 2]
                d = np.sqrt(dx * dx + dy * dy + dz * dz)
                if pair_locked[p] == 0:
                    if d < prm[P_LOCK_DIST]:
                        pair_locked[p] = 1
                        pair_maxdist[p] = d
                        pair_lock_step[p] = ev[E_STEP]
                elif d < pair_maxdist[p]:
                    pair_maxdist[p] = d
    return 0
