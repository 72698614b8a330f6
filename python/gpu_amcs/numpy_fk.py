"""Forward kinematics and maximum point error in plain NumPy: an implementation independent of
the Rust engine (4×4 matrix products instead of its point form), for checks and for timing the
engine against a vectorised Python model. Units as in ``gpu_amcs``: mm and degrees.
"""

import numpy as np


def joint_transform(theta, d, a, alpha, beta, q):
    """MDH (Hayati) joint transform Rz(θ+q)·Tz(d)·Tx(a)·Rx(α)·Ry(β), radians and mm
    (docs/METHOD.md §1), as 4×4 matrices stacked over the leading axes."""
    shape = np.broadcast(theta, q).shape
    cz, sz = np.cos(theta + q), np.sin(theta + q)
    ca, sa = np.cos(alpha), np.sin(alpha)
    cb, sb = np.cos(beta), np.sin(beta)
    one = np.ones(shape)
    zero = np.zeros(shape)

    def m(rows):
        return np.stack([np.stack([np.broadcast_to(v, shape) for v in r], -1) for r in rows], -2)

    rz = m([[cz, -sz, zero, zero], [sz, cz, zero, zero], [zero, zero, one, zero],
            [zero, zero, zero, one]])
    tr = m([[one, zero, zero, a * one], [zero, one, zero, zero], [zero, zero, one, d * one],
            [zero, zero, zero, one]])
    rx = m([[one, zero, zero, zero], [zero, ca, -sa, zero], [zero, sa, ca, zero],
            [zero, zero, zero, one]])
    ry = m([[cb, zero, sb, zero], [zero, one, zero, zero], [-sb, zero, cb, zero],
            [zero, zero, zero, one]])
    return rz @ tr @ rx @ ry


# A row of inputs of an n-joint model (n = 4 … 7): the 5n MDH parameters joint-major
# [θ, d, a, α, β] (angles in degrees), then the tool point's x, y, z in the flange frame (mm), as
# gpu_amcs.Model.params orders them: 5n + 3 numbers. The joint count is taken from the width of
# the rows. N_PARAMS, N_UNCERTAIN and ANGLE are the six-joint values (30, 33), kept for callers
# of a six-joint model; angle_mask(n) is the mask of any n.
PARAMS_PER_JOINT = 5
TOOL_COORDS = 3
N_PARAMS = 30
N_UNCERTAIN = 33


def angle_mask(joints):
    """Which of the 5n + 3 inputs of an n-joint model are angles (θ, α, β; degrees)."""
    return np.array([True, False, False, True, True] * joints + [False] * TOOL_COORDS)


ANGLE = angle_mask(6)


def joints_of(width):
    """The joint count n of rows ``width`` numbers wide: 5n + 3 (parameters, then the tool
    point) or 5n (parameters alone); a ValueError for any other width."""
    for n in range(1, width // PARAMS_PER_JOINT + 1):
        if width in (PARAMS_PER_JOINT * n, PARAMS_PER_JOINT * n + TOOL_COORDS):
            return n
    raise ValueError(
        f"a row of {width} numbers is neither 5n parameters nor 5n + 3 inputs of an n-joint "
        "model (30 or 33 for six joints, 35 or 38 for seven)"
    )


def inputs(params_deg, tool):
    """Rows of the 5n + 3 inputs from rows of the 5n parameters (N × 5n; N × 30 for six
    joints) and one tool point (3,)."""
    params_deg = np.atleast_2d(np.asarray(params_deg, dtype=float))
    return np.hstack([params_deg, np.broadcast_to(np.asarray(tool, float), (len(params_deg), 3))])


def fk(inputs_deg, q_deg, tool=None):
    """Tool positions (mm) for input rows inputs_deg (N × (5n + 3): the 5n parameters of an
    n-joint model in mm and degrees, then each row's own tool point x, y, z in mm; N × 33 for
    six joints) at q_deg (m × n, degrees): N × m × 3, by 4×4 matrix products (independent of
    the library's point form). Rows of the 5n parameters alone (N × 5n) take the tool point
    ``tool`` (3,). The joint count n comes from the width of the rows. The base frame: the
    model's own (a model's base transform is not applied; errors do not depend on it)."""
    inputs_deg = np.asarray(inputs_deg, dtype=float)
    if inputs_deg.ndim != 2:
        raise ValueError(f"inputs_deg: expected a 2-D array (N, 5n + 3), got {inputs_deg.shape}")
    n = joints_of(inputs_deg.shape[1])
    n_params = PARAMS_PER_JOINT * n
    if inputs_deg.shape[1] == n_params:
        if tool is None:
            raise ValueError(f"inputs_deg: rows of the {n_params} parameters of a {n}-joint "
                             "model need tool (x, y, z in mm)")
        inputs_deg = inputs(inputs_deg, tool)
    elif tool is not None:
        raise ValueError(f"tool: the rows (N, {n_params + TOOL_COORDS}) carry their own tool "
                         "point")
    q_deg = np.asarray(q_deg, dtype=float)
    if q_deg.ndim != 2 or q_deg.shape[1] != n:
        raise ValueError(f"q_deg: expected shape (m, {n}) for rows of a {n}-joint model, got "
                         f"{q_deg.shape}")
    p = np.where(angle_mask(n), np.radians(inputs_deg), inputs_deg)[:, None, :]  # N × 1 × 5n+3
    q = np.radians(q_deg)[None, :, :]  # 1 × m × n
    t = np.broadcast_to(np.eye(4), np.broadcast(p[..., 0], q[..., 0]).shape + (4, 4))
    for j in range(n):
        th, d, a, al, be = (p[..., PARAMS_PER_JOINT * j + k] for k in range(PARAMS_PER_JOINT))
        t = t @ joint_transform(th, d, a, al, be, q[..., j])
    tool_h = np.concatenate([p[..., n_params:], np.ones(p.shape[:-1] + (1,))], axis=-1)
    return (t @ tool_h[..., None])[..., :3, 0]


def max_error(inputs_deg, q_deg, reference, rows=4096):
    """w of each input row (N × (5n + 3) of an n-joint model, N × 33 for six joints; q_deg is
    m × n): max over the m points of ‖P(row, q_j) − reference_j‖ (mm); ``reference`` is m × 3.
    Evaluated ``rows`` rows at a time to bound the memory."""
    inputs_deg = np.asarray(inputs_deg, dtype=float)
    out = np.empty(len(inputs_deg))
    for s in range(0, len(inputs_deg), rows):
        p = inputs_deg[s:s + rows]
        out[s:s + rows] = np.linalg.norm(fk(p, q_deg) - reference, axis=-1).max(axis=1)
    return out
