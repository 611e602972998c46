"""The angle between two rotations given as rotation vectors (rad), in degrees: what the
mounting tables (scripts/prefilter-table.sh, scripts/declared-mounting-table.sh) print
between the mounting found before the filter and the drawn one."""
import math


def matrix(v):
    """Rotation matrix of rotation vector v (Rodrigues)."""
    th = math.sqrt(sum(x * x for x in v))
    if th == 0:
        return [[float(i == j) for j in range(3)] for i in range(3)]
    k = [x / th for x in v]
    K = [[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]]
    KK = [[sum(K[i][l] * K[l][j] for l in range(3)) for j in range(3)] for i in range(3)]
    return [[float(i == j) + math.sin(th) * K[i][j] + (1 - math.cos(th)) * KK[i][j] for j in range(3)] for i in range(3)]


def angle_deg(a, b):
    """Angle (°) of the rotation taking rotation vector a to rotation vector b."""
    A, B = matrix(a), matrix(b)
    tr = sum(A[l][i] * B[l][i] for i in range(3) for l in range(3))
    return math.degrees(math.acos(max(-1.0, min(1.0, (tr - 1) / 2))))
