"""An independent, deliberately plain NumPy statement of the paper's equations.

Written from the paper and conventions §1–§2 only (not from pkmlab's kernels), for the tests to
check pkmlab against: loop closure (eqs. 2, 3, 5, 6), platform pose, eq. (19), and a
polynomial-free count of assembly modes by scanning the loop-closure residual over α.
"""

import numpy as np

B = 0.52
L = 0.25
R = 0.1667
A = 0.125
BASE = np.array([[0.0, 0.0], [B, 0.0], [B / 2, np.sqrt(3) / 2 * B]])


def u(x):
    return np.array([np.cos(x), np.sin(x)])


def eta(q, base=BASE, l=(L, L, L), r=(R, R, R), a=A):
    """Eqs. (2), (3), (5), (6) as printed, generalised to per-leg lengths."""
    t1, t2, t3, f1, f2, f3, al = q
    (xb2, yb2), (xb3, yb3) = base[1], base[2]
    x1, y1 = base[0]
    e1 = x1 + l[0] * np.cos(t1) + r[0] * np.cos(f1) + a * np.cos(al) - r[1] * np.cos(f2) - l[1] * np.cos(t2) - xb2
    e2 = y1 + l[0] * np.sin(t1) + r[0] * np.sin(f1) + a * np.sin(al) - r[1] * np.sin(f2) - l[1] * np.sin(t2) - yb2
    e3 = (xb2 + l[1] * np.cos(t2) + r[1] * np.cos(f2) + a * np.cos(2 * np.pi / 3 + al)
          - r[2] * np.cos(f3) - l[2] * np.cos(t3) - xb3)
    e4 = (yb2 + l[1] * np.sin(t2) + r[1] * np.sin(f2) + a * np.sin(2 * np.pi / 3 + al)
          - r[2] * np.sin(f3) - l[2] * np.sin(t3) - yb3)
    return np.array([e1, e2, e3, e4])


def pose(q, base=BASE, l=(L, L, L), r=(R, R, R), a=A):
    """Centroid and orientation: p1 + (a/√3) u(α + π/6) (conventions §1)."""
    p1 = base[0] + l[0] * u(q[0]) + r[0] * u(q[3])
    c = p1 + a / np.sqrt(3) * u(q[6] + np.pi / 6)
    return np.array([c[0], c[1], q[6]])


def S_closed_form(q):
    """Eq. (19) as printed."""
    f1, f2, f3, al = q[3], q[4], q[5], q[6]
    return np.sin(f1 - al) * np.sin(f2 - f3) + np.sin(f1 - f2) * np.sin(al + 2 * np.pi / 3 - f3)


def numeric_jacobian(fun, x, h=1e-6):
    x = np.asarray(x, dtype=float)
    cols = []
    for i in range(x.size):
        dx = np.zeros_like(x)
        dx[i] = h
        cols.append((fun(x + dx) - fun(x - dx)) / (2 * h))
    return np.stack(cols, axis=-1)


def count_assembly_modes(theta, base=BASE, l=(L, L, L), r=(R, R, R), a=A, n_alpha=20000):
    """Number of assembly modes from a dense scan over α — no polynomial involved.

    For each α, vertex p1 lies on the circle of leg 1 (centre e1, radius r1) and on the
    circle of leg 2 shifted back by the platform (centre e2 - a u(α), radius r2): zero or two
    intersections, the two branches ±. Along each branch the residual of leg 3,
    g = |p1 + a u(α + π/3) - e3|² - r3², is scanned for sign changes; where the branches
    end (circles tangent) they join, and a sign difference between them there is a root
    crossing the junction.
    """
    l, r = np.asarray(l, float), np.asarray(r, float)
    e = base + l[:, None] * np.stack([np.cos(theta), np.sin(theta)], axis=-1)
    alpha = np.linspace(-np.pi, np.pi, n_alpha, endpoint=False)
    c2 = e[1][None, :] - a * np.stack([np.cos(alpha), np.sin(alpha)], axis=-1)
    d = c2 - e[0][None, :]
    dist = np.hypot(d[:, 0], d[:, 1])
    along = (r[0] ** 2 - r[1] ** 2 + dist**2) / (2 * dist)
    h2 = r[0] ** 2 - along**2
    exists = h2 > 0
    h = np.sqrt(np.where(exists, h2, 0.0))
    mid = e[0][None, :] + along[:, None] * d / dist[:, None]
    perp = np.stack([-d[:, 1], d[:, 0]], axis=-1) / dist[:, None]
    off3 = a * np.stack([np.cos(alpha + np.pi / 3), np.sin(alpha + np.pi / 3)], axis=-1)
    g = []
    for sign in (1.0, -1.0):
        p1 = mid + sign * h[:, None] * perp
        v = p1 + off3 - e[2][None, :]
        g.append(np.where(exists, v[:, 0] ** 2 + v[:, 1] ** 2 - r[2] ** 2, np.nan))
    g_plus, g_minus = g
    count = 0
    nxt = np.roll(np.arange(n_alpha), -1)
    both = exists & exists[nxt]
    for branch in (g_plus, g_minus):
        count += int(np.sum(both & (np.sign(branch) != np.sign(branch[nxt]))))
    # junctions: a sample that exists next to one that does not (either side)
    prv = np.roll(np.arange(n_alpha), 1)
    ends = exists & (~exists[nxt] | ~exists[prv])
    count += int(np.sum(ends & (np.sign(g_plus) != np.sign(g_minus))))
    return count
