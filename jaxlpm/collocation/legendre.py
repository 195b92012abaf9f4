"""Legendre polynomials and Gauss-type nodes/weights on [-1, 1], computed on the host in float64.

Nodes: Golub-Welsch eigenvalues of the Jacobi matrix of the matching Gauss-Jacobi family
(Golub & Welsch 1969) as initial guesses, polished by Newton steps on the Legendre expressions.
"""

import numpy as np

_NEWTON_STEPS = 3


def legendre_table(n: int, x):
    """P_0..P_n and P'_0..P'_n at x, each of shape (n+1, *x.shape).

    (m+1) P_{m+1} = (2m+1) x P_m - m P_{m-1};   P'_{m+1} = P'_{m-1} + (2m+1) P_m.
    The derivative recurrence has no 1/(1-x^2) and stays accurate at x = ±1.
    """
    x = np.asarray(x, dtype=np.float64)
    p = np.empty((n + 1, *x.shape))
    dp = np.empty((n + 1, *x.shape))
    p[0], dp[0] = 1.0, 0.0
    if n >= 1:
        p[1], dp[1] = x, 1.0
    for m in range(1, n):
        p[m + 1] = ((2 * m + 1) * x * p[m] - m * p[m - 1]) / (m + 1)
        dp[m + 1] = dp[m - 1] + (2 * m + 1) * p[m]
    return p, dp


def legendre(n: int, x):
    """(P_n(x), P_n'(x)) by the three-term recurrences of `legendre_table`."""
    p, dp = legendre_table(n, x)
    return p[n], dp[n]


def _gauss_jacobi_guess(m: int, alpha: float, beta: float) -> np.ndarray:
    """Zeros of the Jacobi polynomial P_m^{(alpha, beta)}: eigenvalues of its Jacobi matrix.

    Monic recurrence p_{j+1} = (x - a_j) p_j - b_j^2 p_{j-1} with s = 2j + alpha + beta:
    a_j = (beta^2 - alpha^2) / (s (s + 2))  (a_0 = (beta - alpha)/(alpha + beta + 2)),
    b_j^2 = 4 j (j+alpha)(j+beta)(j+alpha+beta) / (s^2 (s+1)(s-1)).
    """
    if m == 0:
        return np.empty(0)
    j = np.arange(m, dtype=np.float64)
    s = 2 * j + alpha + beta
    a = np.empty(m)
    a[0] = (beta - alpha) / (alpha + beta + 2)
    a[1:] = (beta**2 - alpha**2) / (s[1:] * (s[1:] + 2))
    j, s = j[1:], s[1:]
    b2 = 4 * j * (j + alpha) * (j + beta) * (j + alpha + beta) / (s**2 * (s + 1) * (s - 1))
    jac = np.diag(a) + np.diag(np.sqrt(b2), 1) + np.diag(np.sqrt(b2), -1)
    return np.sort(np.linalg.eigvalsh(jac))


def _check_count(name: str, n: int, minimum: int) -> None:
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < minimum:
        raise ValueError(f"{name} needs an integer number of points >= {minimum}, got {n!r}")


def lgl_nodes_weights(n_points: int):
    """Legendre-Gauss-Lobatto nodes and weights, N = n_points - 1 (ascending).

    Nodes: -1, +1 and the N-1 zeros of P'_N (= zeros of Jacobi P^{(1,1)}_{N-1}).
    Weights: w_i = 2 / (N (N+1) P_N(t_i)^2), exact for degree 2N-1.
    Mei (2010) prints P'_N(t_i) in place of P_N(t_i); P'_N vanishes at interior nodes,
    so the formula as printed is wrong and P_N is used here.
    Newton on P'_N uses P''_N = (2x P'_N - N(N+1) P_N) / ((1-x)(1+x)) (Legendre ODE).
    """
    _check_count("lgl_nodes_weights", n_points, 2)
    n = n_points - 1
    x = _gauss_jacobi_guess(n - 1, 1.0, 1.0)
    for _ in range(_NEWTON_STEPS):
        p, dp = legendre(n, x)
        d2p = (2 * x * dp - n * (n + 1) * p) / ((1 - x) * (1 + x))
        x = x - dp / d2p
    x = np.concatenate(([-1.0], np.sort(x), [1.0]))
    p, _ = legendre(n, x)
    return x, 2.0 / (n * (n + 1) * p**2)


def lg_nodes_weights(k: int):
    """Legendre-Gauss nodes (zeros of P_k, ascending) and weights w = 2 / ((1-x^2) P_k'(x)^2).

    Exact for degree 2k-1.
    """
    _check_count("lg_nodes_weights", k, 1)
    x = _gauss_jacobi_guess(k, 0.0, 0.0)
    for _ in range(_NEWTON_STEPS):
        p, dp = legendre(k, x)
        x = x - p / dp
    x = np.sort(x)
    _, dp = legendre(k, x)
    return x, 2.0 / ((1 - x) * (1 + x) * dp**2)


def lgr_nodes_weights(k: int):
    """Legendre-Gauss-Radau nodes including -1 (Garg et al. 2010 / GPOPS convention), ascending.

    Nodes: -1 and the k-1 zeros of q = (P_{k-1} + P_k)/(1+x) (q is Jacobi P^{(0,1)}_{k-1}).
    Weights: w_0 = 2/k^2, w_i = (1 - x_i) / (k^2 P_{k-1}(x_i)^2); exact for degree 2k-2.
    The interior weights are evaluated in the equal form w_i = 4 / ((1-x_i) (P'_{k-1} + P'_k)^2)
    (the Gauss-Jacobi weight 4/((1-x^2) q'^2) divided by 1+x): it is stationary in the node
    to O(1), whereas the P_{k-1} form amplifies node rounding by O(k) (4e-14 vs 9e-16 error in
    sum w at k = 257).
    """
    _check_count("lgr_nodes_weights", k, 1)
    x = _gauss_jacobi_guess(k - 1, 0.0, 1.0)
    for _ in range(_NEWTON_STEPS):
        p, dp = legendre_table(k, x)
        x = x - (p[k - 1] + p[k]) / (dp[k - 1] + dp[k])
    x = np.sort(x)
    _, dp = legendre_table(k, x)
    w = 4.0 / ((1 - x) * (dp[k - 1] + dp[k]) ** 2)
    return np.concatenate(([-1.0], x)), np.concatenate(([2.0 / k**2], w))
