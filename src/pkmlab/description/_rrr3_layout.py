"""The layout of the paper's 3-RRR's packed parameter vector ``P`` (:attr:`pkmlab.paper.geometry.Planar3RRR.packed`):
the index where each group of parameters starts, read by the compiled kernels of :mod:`pkmlab.paper.rrr3`."""

BASE = 0  # 6: b1x, b1y, b2x, b2y, b3x, b3y
ACTIVE_LENGTH = 6  # 3: l1, l2, l3
PASSIVE_LENGTH = 9  # 3: r1, r2, r3
PLATFORM = 12  # 4: P2x, P2y, P3x, P3y (platform frame, P1 = origin)
REFERENCE = 16  # 2: platform reference point (centroid) in the platform frame
ACTIVE_MASS = 18  # 3
PASSIVE_MASS = 21  # 3
PLATFORM_MASS = 24  # 1
ACTIVE_INERTIA = 25  # 3 (about each link's own mass centre)
PASSIVE_INERTIA = 28  # 3
PLATFORM_INERTIA = 31  # 1
ACTIVE_COM = 32  # 6: (along, across) each active link, in its link frame
PASSIVE_COM = 38  # 6
PLATFORM_COM = 44  # 2: platform frame
N_PACKED = 46
