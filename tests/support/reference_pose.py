"""The pose GLR's step search as first written — one least-squares problem per candidate fix, in a Python loop —
kept as the reference for the batched :func:`ftc_mj.estimation.diagnosis.pose.step_statistics`
(tests/estimation/test_pose_reference.py)."""

from __future__ import annotations

import numpy as np


def reference_step_statistics(D: np.ndarray, cand: np.ndarray, Q: np.ndarray, y_perp: np.ndarray
                              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per candidate ``i0``: the drop of the residual sum of squares with a displacement beyond a kink, the
    displacement and its unscaled covariance (the batched function's contract), and the condition number of
    the normal matrix (a step at the last fixes is confounded with the kink there: singular but for the
    1e-12 ridge)."""
    n = D.shape[0]
    zero = np.zeros(n)
    stats, offsets, covs, conds = [], [], [], []
    for i0 in cand:
        after = (np.arange(n) >= i0).astype(float)
        K = (D - D[i0 - 1]) * after[:, None]
        A = np.column_stack([np.concatenate((K[:, 0], K[:, 1])), np.concatenate((-K[:, 1], K[:, 0])),
                             np.concatenate((after, zero)), np.concatenate((zero, after))])
        A = A - Q @ (Q.T @ A)
        G, g = A.T @ A + 1e-12 * np.eye(4), A.T @ y_perp
        Ginv = np.linalg.pinv(G)
        kink = float(g[:2] @ np.linalg.pinv(G[:2, :2]) @ g[:2])
        stats.append(float(g @ Ginv @ g) - kink)
        offsets.append((Ginv @ g)[2:])
        covs.append(Ginv[2:, 2:])
        conds.append(np.linalg.cond(G))
    return np.asarray(stats), np.asarray(offsets), np.asarray(covs), np.asarray(conds)
