"""The numba kernel: time steps of the lumped-parameter net, its contacts with the target
and the drawstring closing, ``n_steps`` at a time.

Numerical method
----------------
Symplectic (semi-implicit) Euler: forces at the start of the step, then v += dt F/m and
x += dt v.  It is explicit, second-order in its energy behaviour (no secular drift of the
energy of an undamped system, a bounded oscillation of size O(omega dt)), conserves linear
momentum to round-off (every force has an equal and opposite one, on the target too), and
converges to the continuous Kelvin-Voigt model of the SPEC as dt -> 0: snap loads, which an
implicit or constraint-based integrator at large steps would absorb as inelastic impacts,
rebound with the restitution the thread damping gives.

Its stable step is set by the stiffest thread: omega_max^2 <= max_i sum_l k_l (w_i +
sqrt(w_i w_j)) (Gershgorin bound of M^-1 K) and dt <= 2 / omega_max; for a net of mesh side
l0 this is dt ~ l0 / sqrt(2 E / rho) ~ 1.2e-4 s at l0 = 1.25 m, independent of the thread
radius.  ``stable_step`` computes it and the configuration takes a safety fraction of it.

Forces:
  * thread (tension-only Kelvin-Voigt): F = k C + c dC/dt along the thread while C > 0 and
    F > 0 (a thread never pushes), k = E A / l0, c = 2 zeta sqrt(k m_eff);
  * contact (Kelvin-Voigt penalty, never pulling): F_n = k_i delta - c_i v_n > 0 with
    k_i = m_i omega_c^2, c_i = 2 zeta_c m_i omega_c per body (a contact natural frequency,
    so penetration at impact speed v is about v / omega_c whatever the body's mass, and
    the contact never limits the stable step); regularised Coulomb friction of magnitude
    min(mu F_n, m |v_t| / dt) against the tangential slip (a scaled box that cannot
    reverse the slip within a step);
  * drawstring: constant F_c along each adjacent closing pair; a locked pair is a one-sided
    distance joint whose maximum distance ratchets down toward 0 (positions projected,
    separating velocity removed, momentum kept).

Forces on a body are gathered in a fixed, mirror-invariant order (left + right) + (down +
up) + (others), so that a symmetric state stays symmetric to the last bit.  The grid
threads are computed branch-free on structure-of-arrays copies of the state, which lets
LLVM vectorise the two loops that dominate the cost.

Units: SI throughout (m, s, kg, N).
"""
from __future__ import annotations

import numpy as np
from numba import njit

# indices into the float parameter vector ``prm``
(P_DT, P_CLOSE_FORCE, P_CLOSE_THRESHOLD, P_LOCK_DIST, P_MU, P_OMEGA_CONTACT, P_ZETA_CONTACT,
 P_TGT_INV_MASS, P_TGT_BOUND, P_TETHER_LIN_DENSITY, P_TETHER_EA, P_ZETA_THREAD) = range(12)
N_PRM = 12
# indices into the integer state vector ``ev``
E_STEP, E_CLOSING_ARMED, E_CLOSING_ACTIVE, E_CLOSING_STEP, E_TETHER_LOCKED = range(5)
N_EV = 5
#: slots of ``node_links``: the (non-grid) threads acting on a body
N_SLOTS = 2
#: Jacobi passes of the drawstring-lock projection per step
LOCK_PASSES = 4


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


def stable_step(links, link_k, link_active, w, n_bodies):
    """Upper bound of the highest natural frequency omega_max (rad/s) of the active
    threads (Gershgorin bound of M^-1 K), and the stable step 2 / omega_max (s)."""
    lam = np.zeros(n_bodies)
    act = link_active == 1
    a, b, k = links[act, 0], links[act, 1], link_k[act]
    cross = np.sqrt(w[a] * w[b])
    np.add.at(lam, a, k * (w[a] + cross))
    np.add.at(lam, b, k * (w[b] + cross))
    omega = float(np.sqrt(lam.max()))
    return omega, 2.0 / omega


@njit(cache=True, nogil=True, error_model='numpy')
def advance(n_steps, x, v, w, mass, radius, contact_mask,
            grid_n, grid_rest, grid_kh, grid_ch, grid_kv, grid_cv,
            links, link_rest, link_k, link_c, link_active, node_links, node_link_sign,
            net_nodes, ring_pairs, pair_locked, pair_maxdist, pair_lock_step,
            tether_nodes, tether_links, centre_node, winch_body,
            tgt_pos, tgt_quat, tgt_vel, tgt_omega, tgt_inertia, cyl, verts, offsets,
            prm, ev, contact_count, max_penetration):
    """Advance the state ``n_steps`` steps of dt = prm[P_DT] in place.

    x, v: (N, 3) positions (m) and velocities (m/s); w: (N,) inverse masses (1/kg, 0 for
    kinematic bodies); mass (N,) (kg); radius (N,) contact sphere radii (m);
    contact_mask (N,) 1 where the body collides with the target.
    The net's grid threads are implicit: bodies [0, grid_n^2) form a grid_n x grid_n grid
    (node (i, j) = grid_n i + j) whose x-threads (i, j)-(i, j+1) have stiffness grid_kh and
    damping grid_ch ((grid_n, grid_n - 1), N/m and N s/m) and y-threads (i, j)-(i+1, j)
    grid_kv, grid_cv ((grid_n - 1, grid_n)), all of rest length grid_rest (m).
    Other threads (corner threads, tether segments): links (M, 2) with rest length (m),
    stiffness k (N/m), damping c (N s/m) and an active flag; node_links (N, 2) the links
    acting on each body (or -1) and node_link_sign (N, 2) +1 where the body is the link's
    first end, -1 where second.
    ring_pairs (P, 2): adjacent drawstring nodes; pair_locked/pair_maxdist/pair_lock_step
    hold the lock state.  tether_nodes: indices of the tether's lumped masses (kinematic
    on a straight line while the winch pays out); tether_links: their link indices.
    Target: position (m), quaternion (w,x,y,z), velocity (m/s), angular velocity (rad/s,
    world), principal inertia (kg m^2), cylinder [axial centre, half length, radius] (m)
    and meridional polygons of any extra solid (verts, offsets).
    ev: integer episode state (see E_* indices); contact_count accumulates body-steps in
    contact; max_penetration[0] the deepest penetration (m) seen.

    The state is copied to structure-of-arrays form for the step loop (so the grid loops
    vectorise) and back at the end; the result does not depend on how steps are chunked.
    The kernel releases the GIL: other Python threads of the process (the ROS node's
    publisher, a Dask worker's event loop) run beside it.
    """
    dt = prm[P_DT]
    N = x.shape[0]
    n_links = links.shape[0]
    n_pairs = ring_pairs.shape[0]
    n_tether = tether_nodes.shape[0]
    close_force = prm[P_CLOSE_FORCE]
    mu = prm[P_MU]
    om_c = prm[P_OMEGA_CONTACT]
    k_c_unit = om_c * om_c                      # contact stiffness per kg
    c_c_unit = 2.0 * prm[P_ZETA_CONTACT] * om_c  # contact damping per kg
    tgt_w = prm[P_TGT_INV_MASS]
    bound = prm[P_TGT_BOUND]
    inv_i = 1.0 / tgt_inertia
    net_mass = 0.0
    for k in range(net_nodes.shape[0]):
        net_mass += mass[net_nodes[k]]
    R = np.empty((3, 3))
    pair_f = np.zeros((max(n_pairs, 1), 3))
    lock_sep = np.zeros((n_pairs, 3))
    acc = np.zeros((3, N))
    lock_count = np.zeros(N)
    # structure of arrays
    X = np.empty(N)
    Y = np.empty(N)
    Z = np.empty(N)
    VX = np.empty(N)
    VY = np.empty(N)
    VZ = np.empty(N)
    FX = np.zeros(N)
    FY = np.zeros(N)
    FZ = np.zeros(N)
    for i in range(N):
        X[i] = x[i, 0]
        Y[i] = x[i, 1]
        Z[i] = x[i, 2]
        VX[i] = v[i, 0]
        VY[i] = v[i, 1]
        VZ[i] = v[i, 2]
    ng = grid_n
    n_grid = ng * ng
    # thread forces on the first end (+F n), padded with zero threads beyond the edges:
    # x-thread (i, j) at HX[i * (ng + 1) + j + 1], y-thread (i, j) at VYp[(i + 1) * ng + j]
    HX = np.zeros(ng * (ng + 1))
    HY = np.zeros(ng * (ng + 1))
    HZ = np.zeros(ng * (ng + 1))
    UX = np.zeros((ng + 1) * ng)
    UY = np.zeros((ng + 1) * ng)
    UZ = np.zeros((ng + 1) * ng)
    EF = np.zeros((max(n_links, 1), 3))

    for _ in range(n_steps):
        quat_to_matrix_into(tgt_quat, R)
        ox, oy, oz = tgt_omega[0], tgt_omega[1], tgt_omega[2]
        # ---- 1a. grid threads (tension-only Kelvin-Voigt), branch-free and vectorised ----
        # (row views indexed by the loop counter: numba then needs no negative-index
        # wrap-around, and LLVM vectorises the loops)
        for i in range(ng):
            r0 = i * ng
            rx_ = X[r0:r0 + ng]
            ry_ = Y[r0:r0 + ng]
            rz_ = Z[r0:r0 + ng]
            rvx = VX[r0:r0 + ng]
            rvy = VY[r0:r0 + ng]
            rvz = VZ[r0:r0 + ng]
            kk = grid_kh[i]
            cc = grid_ch[i]
            h0 = i * (ng + 1)
            hx = HX[h0:h0 + ng + 1]
            hy = HY[h0:h0 + ng + 1]
            hz = HZ[h0:h0 + ng + 1]
            for j in range(ng - 1):
                dx = rx_[j + 1] - rx_[j]
                dy = ry_[j + 1] - ry_[j]
                dz = rz_[j + 1] - rz_[j]
                length = np.sqrt(dx * dx + dy * dy + dz * dz)
                C = length - grid_rest
                inv = 1.0 / max(length, 1e-12)
                cdot = (dx * (rvx[j + 1] - rvx[j]) + dy * (rvy[j + 1] - rvy[j]) + dz * (rvz[j + 1] - rvz[j])) * inv
                F = kk[j] * C + cc[j] * cdot
                F = F if C > 0.0 else 0.0
                F = F if F > 0.0 else 0.0       # a thread never pushes, not even its damper
                s_ = F * inv
                hx[j + 1] = s_ * dx
                hy[j + 1] = s_ * dy
                hz[j + 1] = s_ * dz
        for i in range(ng - 1):
            r0 = i * ng
            r1 = r0 + ng
            xa = X[r0:r0 + ng]
            ya = Y[r0:r0 + ng]
            za = Z[r0:r0 + ng]
            vxa = VX[r0:r0 + ng]
            vya = VY[r0:r0 + ng]
            vza = VZ[r0:r0 + ng]
            xb = X[r1:r1 + ng]
            yb = Y[r1:r1 + ng]
            zb = Z[r1:r1 + ng]
            vxb = VX[r1:r1 + ng]
            vyb = VY[r1:r1 + ng]
            vzb = VZ[r1:r1 + ng]
            kk = grid_kv[i]
            cc = grid_cv[i]
            ux = UX[r1:r1 + ng]
            uy = UY[r1:r1 + ng]
            uz = UZ[r1:r1 + ng]
            for j in range(ng):
                dx = xb[j] - xa[j]
                dy = yb[j] - ya[j]
                dz = zb[j] - za[j]
                length = np.sqrt(dx * dx + dy * dy + dz * dz)
                C = length - grid_rest
                inv = 1.0 / max(length, 1e-12)
                cdot = (dx * (vxb[j] - vxa[j]) + dy * (vyb[j] - vya[j]) + dz * (vzb[j] - vza[j])) * inv
                F = kk[j] * C + cc[j] * cdot
                F = F if C > 0.0 else 0.0
                F = F if F > 0.0 else 0.0
                s_ = F * inv
                ux[j] = s_ * dx
                uy[j] = s_ * dy
                uz[j] = s_ * dz
        # ---- 1b. other threads: corner threads, tether ---------------------------------
        for m in range(n_links):
            EF[m, 0] = 0.0
            EF[m, 1] = 0.0
            EF[m, 2] = 0.0
            if link_active[m] == 0:
                continue
            i = links[m, 0]
            j = links[m, 1]
            dx = X[j] - X[i]
            dy = Y[j] - Y[i]
            dz = Z[j] - Z[i]
            len2 = dx * dx + dy * dy + dz * dz
            if len2 <= link_rest[m] * link_rest[m] or len2 < 1e-28:
                continue
            length = np.sqrt(len2)
            inv = 1.0 / length
            cdot = (dx * (VX[j] - VX[i]) + dy * (VY[j] - VY[i]) + dz * (VZ[j] - VZ[i])) * inv
            F = link_k[m] * (length - link_rest[m]) + link_c[m] * cdot
            if F <= 0.0:
                continue
            EF[m, 0] = F * inv * dx
            EF[m, 1] = F * inv * dy
            EF[m, 2] = F * inv * dz
        # ---- 2. gather per body in a mirror-invariant order ----------------------------
        # (left + right) + (down + up) for grid nodes: each pair's sum is commutative
        for i in range(ng):
            r0 = i * ng
            h0 = i * (ng + 1)
            fx = FX[r0:r0 + ng]
            fy = FY[r0:r0 + ng]
            fz = FZ[r0:r0 + ng]
            hx = HX[h0:h0 + ng + 1]
            hy = HY[h0:h0 + ng + 1]
            hz = HZ[h0:h0 + ng + 1]
            dxu = UX[r0:r0 + ng]
            dyu = UY[r0:r0 + ng]
            dzu = UZ[r0:r0 + ng]
            uxu = UX[r0 + ng:r0 + 2 * ng]
            uyu = UY[r0 + ng:r0 + 2 * ng]
            uzu = UZ[r0 + ng:r0 + 2 * ng]
            for j in range(ng):
                fx[j] = (hx[j + 1] - hx[j]) + (uxu[j] - dxu[j])
                fy[j] = (hy[j + 1] - hy[j]) + (uyu[j] - dyu[j])
                fz[j] = (hz[j + 1] - hz[j]) + (uzu[j] - dzu[j])
        for a in range(n_grid, N):
            FX[a] = 0.0
            FY[a] = 0.0
            FZ[a] = 0.0
        for a in range(N):
            m0 = node_links[a, 0]
            m1 = node_links[a, 1]
            if m0 < 0 and m1 < 0:
                continue
            ex = 0.0
            ey = 0.0
            ez = 0.0
            if m0 >= 0:
                sg = node_link_sign[a, 0]
                ex = sg * EF[m0, 0]
                ey = sg * EF[m0, 1]
                ez = sg * EF[m0, 2]
            if m1 >= 0:
                sg = node_link_sign[a, 1]
                ex += sg * EF[m1, 0]
                ey += sg * EF[m1, 1]
                ez += sg * EF[m1, 2]
            FX[a] += ex
            FY[a] += ey
            FZ[a] += ez
        # ---- 3. drawstring closing force ---------------------------------------------
        if ev[E_CLOSING_ACTIVE] == 1:
            for p in range(n_pairs):
                a = ring_pairs[p, 0]
                b = ring_pairs[p, 1]
                dx = X[b] - X[a]
                dy = Y[b] - Y[a]
                dz = Z[b] - Z[a]
                d = np.sqrt(dx * dx + dy * dy + dz * dz)
                if d > 1e-12:
                    s_ = close_force / d
                    pair_f[p, 0] = s_ * dx
                    pair_f[p, 1] = s_ * dy
                    pair_f[p, 2] = s_ * dz
                else:
                    pair_f[p, 0] = 0.0
                    pair_f[p, 1] = 0.0
                    pair_f[p, 2] = 0.0
            # a ring node is in two pairs: sum both (commutative) before adding
            for p in range(n_pairs):
                for c in range(3):
                    acc[c, ring_pairs[p, 0]] += pair_f[p, c]
                    acc[c, ring_pairs[p, 1]] -= pair_f[p, c]
            for p in range(n_pairs):
                for e in range(2):
                    a = ring_pairs[p, e]
                    FX[a] += acc[0, a]
                    FY[a] += acc[1, a]
                    FZ[a] += acc[2, a]
                    acc[0, a] = 0.0
                    acc[1, a] = 0.0
                    acc[2, a] = 0.0
        # ---- 4. contact with the target ----------------------------------------------
        n_contacts = 0
        fx_t = 0.0
        fy_t = 0.0
        fz_t = 0.0
        tx_t = 0.0
        ty_t = 0.0
        tz_t = 0.0
        for i in range(N):
            if contact_mask[i] == 0 or w[i] == 0.0:
                continue
            rx = X[i] - tgt_pos[0]
            ry = Y[i] - tgt_pos[1]
            rz = Z[i] - tgt_pos[2]
            rb = bound + radius[i]
            if rx * rx + ry * ry + rz * rz > rb * rb:
                continue
            bx = R[0, 0] * rx + R[1, 0] * ry + R[2, 0] * rz
            by = R[0, 1] * rx + R[1, 1] * ry + R[2, 1] * rz
            bz = R[0, 2] * rx + R[1, 2] * ry + R[2, 2] * rz
            sd, nbx, nby, nbz = _local_sdf(bx, by, bz, cyl, verts, offsets)
            delta = radius[i] - sd
            if delta <= 0.0:
                continue
            if delta > max_penetration[0]:
                max_penetration[0] = delta
            nx = R[0, 0] * nbx + R[0, 1] * nby + R[0, 2] * nbz
            ny = R[1, 0] * nbx + R[1, 1] * nby + R[1, 2] * nbz
            nz = R[2, 0] * nbx + R[2, 1] * nby + R[2, 2] * nbz
            # velocity relative to the target's material point at the body
            vrx = VX[i] - (tgt_vel[0] + oy * rz - oz * ry)
            vry = VY[i] - (tgt_vel[1] + oz * rx - ox * rz)
            vrz = VZ[i] - (tgt_vel[2] + ox * ry - oy * rx)
            vn = vrx * nx + vry * ny + vrz * nz
            Fn = mass[i] * (k_c_unit * delta - c_c_unit * vn)
            if Fn <= 0.0:  # a contact never pulls
                continue
            n_contacts += 1
            fx = Fn * nx
            fy = Fn * ny
            fz = Fn * nz
            tvx = vrx - vn * nx
            tvy = vry - vn * ny
            tvz = vrz - vn * nz
            vt = np.sqrt(tvx * tvx + tvy * tvy + tvz * tvz)
            if vt > 1e-12 and mu > 0.0:
                Ft = mu * Fn
                stop = mass[i] * vt / dt
                if stop < Ft:
                    Ft = stop
                fx -= Ft * tvx / vt
                fy -= Ft * tvy / vt
                fz -= Ft * tvz / vt
            FX[i] += fx
            FY[i] += fy
            FZ[i] += fz
            # equal and opposite on the target, acting at the body's centre
            fx_t -= fx
            fy_t -= fy
            fz_t -= fz
            tx_t -= ry * fz - rz * fy
            ty_t -= rz * fx - rx * fz
            tz_t -= rx * fy - ry * fx
        contact_count[0] += n_contacts
        # ---- 5. integrate bodies (symplectic Euler), vectorised -------------------------
        for i in range(N):
            hw = dt * w[i]
            VX[i] += hw * FX[i]
            VY[i] += hw * FY[i]
            VZ[i] += hw * FZ[i]
            X[i] += dt * VX[i]
            Y[i] += dt * VY[i]
            Z[i] += dt * VZ[i]
        if ev[E_TETHER_LOCKED] == 0:
            # the winch pays out freely: the deployed tether lies straight and slack
            for k in range(n_tether):
                f = (k + 1.0) / (n_tether + 1.0)
                t = tether_nodes[k]
                X[t] = X[winch_body] + f * (X[centre_node] - X[winch_body])
                Y[t] = Y[winch_body] + f * (Y[centre_node] - Y[winch_body])
                Z[t] = Z[winch_body] + f * (Z[centre_node] - Z[winch_body])
                VX[t] = VX[winch_body] + f * (VX[centre_node] - VX[winch_body])
                VY[t] = VY[winch_body] + f * (VY[centre_node] - VY[winch_body])
                VZ[t] = VZ[winch_body] + f * (VZ[centre_node] - VZ[winch_body])
        # ---- 6. integrate the target (free rigid body) -------------------------------
        tgt_vel[0] += dt * tgt_w * fx_t
        tgt_vel[1] += dt * tgt_w * fy_t
        tgt_vel[2] += dt * tgt_w * fz_t
        # Euler's equations in the body frame: I dw/dt = tau - w x I w
        tbx = R[0, 0] * tx_t + R[1, 0] * ty_t + R[2, 0] * tz_t
        tby = R[0, 1] * tx_t + R[1, 1] * ty_t + R[2, 1] * tz_t
        tbz = R[0, 2] * tx_t + R[1, 2] * ty_t + R[2, 2] * tz_t
        wbx = R[0, 0] * ox + R[1, 0] * oy + R[2, 0] * oz
        wby = R[0, 1] * ox + R[1, 1] * oy + R[2, 1] * oz
        wbz = R[0, 2] * ox + R[1, 2] * oy + R[2, 2] * oz
        nwx = wbx + dt * inv_i[0] * (tbx + (tgt_inertia[1] - tgt_inertia[2]) * wby * wbz)
        nwy = wby + dt * inv_i[1] * (tby + (tgt_inertia[2] - tgt_inertia[0]) * wbz * wbx)
        nwz = wbz + dt * inv_i[2] * (tbz + (tgt_inertia[0] - tgt_inertia[1]) * wbx * wby)
        ox = R[0, 0] * nwx + R[0, 1] * nwy + R[0, 2] * nwz
        oy = R[1, 0] * nwx + R[1, 1] * nwy + R[1, 2] * nwz
        oz = R[2, 0] * nwx + R[2, 1] * nwy + R[2, 2] * nwz
        tgt_omega[0] = ox
        tgt_omega[1] = oy
        tgt_omega[2] = oz
        for c in range(3):
            tgt_pos[c] += dt * tgt_vel[c]
        q0, q1, q2, q3 = tgt_quat[0], tgt_quat[1], tgt_quat[2], tgt_quat[3]
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
        # ---- 7. drawstring locks: one-sided distance joints (ratchet) ---------------
        if ev[E_CLOSING_ACTIVE] == 1:
            _project_locks(X, Y, Z, VX, VY, VZ, w, ring_pairs, pair_locked, pair_maxdist,
                           acc, lock_count, lock_sep)

        ev[E_STEP] += 1
        # ---- 8. events: closing trigger, tether lock, drawstring locks -----------------
        if ev[E_CLOSING_ARMED] == 1 and ev[E_CLOSING_ACTIVE] == 0:
            zc = 0.0
            for k in range(net_nodes.shape[0]):
                zc += mass[net_nodes[k]] * Z[net_nodes[k]]
            zc /= net_mass
            if zc - tgt_pos[2] >= prm[P_CLOSE_THRESHOLD]:
                ev[E_CLOSING_ACTIVE] = 1
                ev[E_CLOSING_STEP] = ev[E_STEP]
                if ev[E_TETHER_LOCKED] == 0:
                    _lock_tether(X, Y, Z, w, mass, contact_mask, links, link_rest, link_k,
                                 link_c, link_active, tether_nodes, tether_links, prm)
                    ev[E_TETHER_LOCKED] = 1
        if ev[E_CLOSING_ACTIVE] == 1:
            for p in range(n_pairs):
                a = ring_pairs[p, 0]
                b = ring_pairs[p, 1]
                dx = X[b] - X[a]
                dy = Y[b] - Y[a]
                dz = Z[b] - Z[a]
                d = np.sqrt(dx * dx + dy * dy + dz * dz)
                if pair_locked[p] == 0:
                    if d < prm[P_LOCK_DIST]:
                        pair_locked[p] = 1
                        pair_maxdist[p] = d
                        pair_lock_step[p] = ev[E_STEP]
                elif d < pair_maxdist[p]:
                    pair_maxdist[p] = d
    for i in range(N):
        x[i, 0] = X[i]
        x[i, 1] = Y[i]
        x[i, 2] = Z[i]
        v[i, 0] = VX[i]
        v[i, 1] = VY[i]
        v[i, 2] = VZ[i]
    return 0


@njit(cache=True, error_model='numpy')
def _project_locks(X, Y, Z, VX, VY, VZ, w, ring_pairs, pair_locked, pair_maxdist, corr, count,
                   sep):
    """Hold every locked pair within its maximum distance: positions are projected along
    the pair (mass-weighted, so momentum is kept) and the separating relative velocity is
    removed.  A node in two locked pairs takes the mean of both corrections (Jacobi with
    mass splitting, order-independent); LOCK_PASSES passes per step."""
    n_pairs = ring_pairs.shape[0]
    # each pair's separation before the projection (m; sep: (n_pairs, 3) scratch): the
    # direction of its separating motion where the projection leaves it coincident (below)
    for p in range(n_pairs):
        sep[p, 0] = X[ring_pairs[p, 1]] - X[ring_pairs[p, 0]]
        sep[p, 1] = Y[ring_pairs[p, 1]] - Y[ring_pairs[p, 0]]
        sep[p, 2] = Z[ring_pairs[p, 1]] - Z[ring_pairs[p, 0]]
    for _ in range(LOCK_PASSES):
        any_active = False
        for p in range(n_pairs):
            if pair_locked[p] == 1:
                count[ring_pairs[p, 0]] += 1.0
                count[ring_pairs[p, 1]] += 1.0
        for p in range(n_pairs):
            if pair_locked[p] == 0:
                continue
            a = ring_pairs[p, 0]
            b = ring_pairs[p, 1]
            dx = X[b] - X[a]
            dy = Y[b] - Y[a]
            dz = Z[b] - Z[a]
            d = np.sqrt(dx * dx + dy * dy + dz * dz)
            C = d - pair_maxdist[p]
            wsum = w[a] + w[b]
            if C <= 0.0 or d < 1e-14 or wsum == 0.0:
                continue
            any_active = True
            s = C / (wsum * d)
            corr[0, a] += w[a] * s * dx
            corr[1, a] += w[a] * s * dy
            corr[2, a] += w[a] * s * dz
            corr[0, b] -= w[b] * s * dx
            corr[1, b] -= w[b] * s * dy
            corr[2, b] -= w[b] * s * dz
        for p in range(n_pairs):
            for e in range(2):
                a = ring_pairs[p, e]
                if count[a] > 0.0:
                    X[a] += corr[0, a] / count[a]
                    Y[a] += corr[1, a] / count[a]
                    Z[a] += corr[2, a] / count[a]
                    corr[0, a] = 0.0
                    corr[1, a] = 0.0
                    corr[2, a] = 0.0
                    count[a] = 0.0
        if not any_active:
            break
    # velocities: no separating relative velocity along a pair at its limit
    for p in range(n_pairs):
        if pair_locked[p] == 0:
            continue
        a = ring_pairs[p, 0]
        b = ring_pairs[p, 1]
        dx = X[b] - X[a]
        dy = Y[b] - Y[a]
        dz = Z[b] - Z[a]
        d = np.sqrt(dx * dx + dy * dy + dz * dz)
        wsum = w[a] + w[b]
        if d < 1e-14:
            # A pair locked at (nearly) zero distance is projected onto one point, which
            # has no direction; its separating motion had the direction of the separation
            # before the projection.  (Skipping it left the relative velocity in place: it
            # then grew step after step while the projection kept the nodes together, a
            # pure gain of kinetic energy that ended 3 of 1000 time-min samples at
            # max_speed.)
            dx = sep[p, 0]
            dy = sep[p, 1]
            dz = sep[p, 2]
            d = np.sqrt(dx * dx + dy * dy + dz * dz)
            if d <= pair_maxdist[p] or d < 1e-14:
                continue
        if wsum == 0.0 or d < pair_maxdist[p] * (1.0 - 1e-9):
            continue
        nx = dx / d
        ny = dy / d
        nz = dz / d
        vsep = nx * (VX[b] - VX[a]) + ny * (VY[b] - VY[a]) + nz * (VZ[b] - VZ[a])
        if vsep > 0.0:
            s = vsep / wsum
            VX[a] += w[a] * s * nx
            VY[a] += w[a] * s * ny
            VZ[a] += w[a] * s * nz
            VX[b] -= w[b] * s * nx
            VY[b] -= w[b] * s * ny
            VZ[b] -= w[b] * s * nz


@njit(cache=True, error_model='numpy')
def _lock_tether(X, Y, Z, w, mass, contact_mask, links, link_rest, link_k, link_c, link_active,
                 tether_nodes, tether_links, prm):
    """The winch locks the paid-out length: the tether segments get their rest lengths
    (the current ones), stiffness E A / l and damping, and the tether's lumped masses
    (one segment of tether each) join the dynamics."""
    for k in range(tether_links.shape[0]):
        m = tether_links[k]
        a = links[m, 0]
        b = links[m, 1]
        dx = X[b] - X[a]
        dy = Y[b] - Y[a]
        dz = Z[b] - Z[a]
        link_rest[m] = max(np.sqrt(dx * dx + dy * dy + dz * dz), 1e-6)
        link_active[m] = 1
    for k in range(tether_nodes.shape[0]):
        t = tether_nodes[k]
        mass[t] = prm[P_TETHER_LIN_DENSITY] * link_rest[tether_links[0]]
        w[t] = 1.0 / mass[t]
        contact_mask[t] = 1
    for k in range(tether_links.shape[0]):
        m = tether_links[k]
        a = links[m, 0]
        b = links[m, 1]
        kk = prm[P_TETHER_EA] / link_rest[m]
        link_k[m] = kk
        meff = (mass[a] * mass[b]) / (mass[a] + mass[b])
        link_c[m] = 2.0 * prm[P_ZETA_THREAD] * np.sqrt(kk * meff)
