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


ANGLE = np.array([True, False, False, True, True] * 6)


def fk(params_deg, tool, q_deg):
    """Tool positions (mm) for parameter rows params_deg (N × 30, mm and degrees) at q_deg
    (m × 6): N × m × 3, by 4×4 matrix products (independent of the library's point form)."""
    p = np.where(ANGLE, np.radians(params_deg), params_deg)[:, None, :]  # N × 1 × 30
    q = np.radians(q_deg)[None, :, :]  # 1 × m × 6
    t = np.broadcast_to(np.eye(4), np.broadcast(p[..., 0], q[..., 0]).shape + (4, 4))
    for j in range(6):
        th, d, a, al, be = (p[..., 5 * j + k] for k in range(5))
        t = t @ joint_transform(th, d, a, al, be, q[..., j])
    tool_h = np.append(np.asarray(tool, float), 1.0)
    return (t @ tool_h)[..., :3]


def max_error(params_deg, tool, q_deg, reference, rows=4096):
    """w of each parameter row: max over the m points of ‖P(params, q_j) − reference_j‖ (mm);
    ``reference`` is m × 3. Evaluated ``rows`` rows at a time to bound the memory."""
    params_deg = np.asarray(params_deg, dtype=float)
    out = np.empty(len(params_deg))
    for s in range(0, len(params_deg), rows):
        p = params_deg[s:s + rows]
        out[s:s + rows] = np.linalg.norm(fk(p, tool, q_deg) - reference, axis=-1).max(axis=1)
    return out
