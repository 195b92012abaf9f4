"""Solver status codes: every solver returns one of these instead of raising inside jit."""

import enum


class Status(enum.IntEnum):
    """Outcome of a solve. Stored in solutions as an int32 array (batched runs: one per member)."""

    SUCCESS = 0
    SINGULAR = 1
    INVALID_INPUT = 2
    NONFINITE = 3
    MAX_ITERATIONS = 4
    STALLED = 5
    NOT_STABILISABLE = 6
    NOT_DETECTABLE = 7
    INFEASIBLE = 8
    INACCURATE = 9

    def __str__(self) -> str:
        return self.name

    @property
    def message(self) -> str:
        return _MESSAGES[self]


_MESSAGES = {
    Status.SUCCESS: "converged: constraints and optimality conditions satisfied",
    Status.SINGULAR: (
        "singular system: the Gramian or KKT matrix is rank deficient (zero-length transfer, "
        "a removed control channel, or boundary states the controls cannot reach)"
    ),
    Status.INVALID_INPUT: (
        "invalid input under jit/vmap: a field that raises ValueError when concrete (e "
        "outside [0, 1), a non-positive a, mu or duration, a non-finite state or angle, a "
        "perigee below the surface on a nonlinear model, ...); outputs are zeroed"
    ),
    Status.NONFINITE: "the solve produced non-finite numbers",
    Status.MAX_ITERATIONS: "the iteration limit was reached before convergence",
    Status.STALLED: (
        "the line search could not decrease the merit function: the iterate is not a KKT "
        "point (a poor initial guess, or an infeasible problem)"
    ),
    Status.NOT_STABILISABLE: (
        "no stabilising Riccati solution: (A, B) is not stabilisable (a mode with Re >= 0 "
        "that the controls cannot move)"
    ),
    Status.NOT_DETECTABLE: (
        "no stabilising Riccati solution: (Q, A) is not detectable (a mode on the imaginary "
        "axis that the state weight Q does not see, e.g. an unweighted HCW axis)"
    ),
    Status.INACCURATE: (
        "converged on its grid, but the grid does not resolve the transfer: the error estimate "
        "between the nodes (stats['error_position'] m, stats['error_velocity'] m/s, or a path "
        "or safety constraint's violation: stats['path_violation'], "
        "stats['constraint_violation']) exceeds the tolerance; solve without a grid (mesh "
        "refinement) or on a finer one"
    ),
    Status.INFEASIBLE: (
        "locally infeasible: the constraint violation stopped decreasing with the penalty at "
        "its limit (e.g. a thrust too weak for the allowed final time, or boundary states the "
        "bounded control cannot reach)"
    ),
}


def describe(status) -> str:
    """Readable message for a status code (an int or a 0-d array)."""
    return Status(int(status)).message
