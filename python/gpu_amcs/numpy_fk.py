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


# The 33 inputs of a row: 30 MDH parameters joint-major [θ, d, a, α, β] (angles in degrees),
# then the tool point's x, y, z in the flange frame (mm), as gpu_amcs.Model.params orders them.
N_PARAMS = 30
N_UNCERTAIN = 33
ANGLE = np.array([True, False, False, True, True] * 6 + [False] * 3)


def inputs(params_deg, tool):
    """Rows of the 33 inputs from rows of the 30 parameters (N × 30) and one tool point (3,)."""
    params_deg = np.atleast_2d(np.asarray(params_deg, dtype=float))
    return np.hstack([params_deg, np.broadcast_to(np.asarray(tool, float), (len(params_deg), 3))])


def fk(inputs_deg, q_deg):
    """Tool positions (mm) for input rows inputs_deg (N × 33: the 30 parameters in mm and
    degrees, then each row's own tool point x, y, z in mm) at q_deg (m × 6, degrees): N × m × 3,
    by 4×4 matrix products (independent of the library's point form). The base frame: the
    model's own (a model's base transform is not applied; errors do not depend on it)."""
    inputs_deg = np.asarray(inputs_deg, dtype=float)
    if inputs_deg.ndim != 2 or inputs_deg.shape[1] != N_UNCERTAIN:
        raise ValueError(f"inputs_deg: expected shape (N, {N_UNCERTAIN}), got {inputs_deg.shape}")
    p = np.where(ANGLE, np.radians(inputs_deg), inputs_deg)[:, None, :]  # N × 1 × 33
    q = np.radians(q_deg)[None, :, :]  # 1 × m × 6
    t = np.broadcast_to(np.eye(4), np.broadcast(p[..., 0], q[..., 0]).shape + (4, 4))
    for j in range(6):
        th, d, a, al, be = (p[..., 5 * j + k] for k in range(5))
        t = t @ joint_transform(th, d, a, al, be, q[..., j])
    tool_h = np.concatenate([p[..., N_PARAMS:], np.ones(p.shape[:-1] + (1,))], axis=-1)
    return (t @ tool_h[..., None])[..., :3, 0]


def max_error(inputs_deg, q_deg, reference, rows=4096):
    """w of each input row (N × 33): max over the m points of ‖P(row, q_j) − reference_j‖ (mm);
    ``reference`` is m × 3. Evaluated ``rows`` rows at a time to bound the memory."""
    inputs_deg = np.asarray(inputs_deg, dtype=float)
    out = np.empty(len(inputs_deg))
    for s in range(0, len(inputs_deg), rows):
        p = inputs_deg[s:s + rows]
        out[s:s + rows] = np.linalg.norm(fk(p, q_deg) - reference, axis=-1).max(axis=1)
    return out
