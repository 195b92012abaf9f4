"""Linear-quadratic regulator (LQR) rendezvous on the HCW equations (Jiang, Li, Zhang & Tan
2011, §2-3) and the checks of a regulator's weights.

    minimise    J = 1/2 x(T)^T S_T x(T) + 1/2 int_0^T (x^T Q x + u^T R u) dt
    subject to  x_dot = A x + B u   (HCW about a circular chief of mean motion n, B = [0; I]),
                x(0) = x0, and by `terminal`:
      "hard"      x(T) = xf = 0 (no terminal term: the limit S_T -> inf);
      "weight"    S_T = terminal_weight, x(T) free;
      "infinite"  S_T = P, the stabilising solution of the algebraic Riccati equation
                  A^T P + P A - P B R^-1 B^T P + Q = 0: the stationary infinite-horizon law
                  u = -R^-1 B^T P x (the paper's) flown over [0, T]; J is then the cost spent
                  up to T plus the cost still to come, 1/2 x(T)^T P x(T), which is the
                  infinite-horizon cost 1/2 x0^T P x0.

LVLH state x = [x, y, z, vx, vy, vz] (m, m/s; x radial outward, y along-track, z orbit normal),
the target at the origin; u the thrust acceleration (m/s^2). The weights are in consistent
units, so that x^T Q x and u^T R u share one unit (e.g. Q's position block in 1/m^2, its
velocity block in s^2/m^2 and R in s^4/m^2 make both dimensionless; then J is in s). S_T has
the units of Q times s. The optimal law does not depend on J's unit.

`weight_rules`, `matrix_rules`: the checks of a regulator's weight
matrices (finite, symmetric, positive (semi)definite) as `Rule`s, for this problem and for the
generic CARE (`jaxlpm.solvers.riccati`).
"""

import functools
from dataclasses import dataclass, field, replace

import jax
import jax.numpy as jnp
import numpy as np

from .._validation import Checked, Rule, array_module, check_shape, coerce_sequences
from ..linalg import cholesky_factor
from ..orbits import KeplerOrbit

TERMINALS = ("hard", "weight", "infinite")
SYMMETRY_TOL = 1e-10    # |M - M^T|_F / |M|_F allowed for a weight matrix
PSD_TOL = 1e-12         # a semidefinite weight may have eigenvalues down to -PSD_TOL |M|_F


def _symmetric(M):
    nm = jnp.linalg.norm(M)
    return jnp.linalg.norm(M - M.T) <= SYMMETRY_TOL * jnp.where(nm > 0, nm, 1.0)


def _positive_definite(M):
    """Finite and Cholesky-factorable: a flag, not differentiated."""
    finite = jnp.all(jnp.isfinite(M))
    M = jax.lax.stop_gradient(jnp.where(finite, M, 1.0))
    return finite & jnp.all(jnp.isfinite(cholesky_factor(M)))


def _positive_semidefinite(M):
    """M + PSD_TOL |M|_F I is positive definite."""
    M = jax.lax.stop_gradient(M)
    shift = PSD_TOL * jnp.linalg.norm(M) + jnp.finfo(M.dtype).tiny
    return _positive_definite(M + shift * jnp.eye(M.shape[0], dtype=M.dtype))


@functools.partial(jax.jit, static_argnames="definite")
def _matrix_flags(M, definite):
    """(finite, symmetric, positive (semi)definite) in one compiled call: concrete input
    evaluated op by op would take ~2 ms a matrix (under an outer trace this inlines)."""
    positive = _positive_definite(M) if definite else _positive_semidefinite(M)
    return jnp.all(jnp.isfinite(M)), _symmetric(M), positive


def matrix_rules(name, M, what, definite=False):
    """`Rule`s: `M` (the field `name`, a `what`) finite, symmetric and positive semidefinite
    (or, with `definite`, positive definite)."""
    finite, symmetric, positive = _matrix_flags(jnp.asarray(M, jnp.float64), definite)
    kind = "definite" if definite else "semidefinite"
    return [Rule(name, finite, "finite"),
            Rule(name, symmetric, f"symmetric ({what}; |M - M^T|_F <= {SYMMETRY_TOL:g} "
                                  f"|M|_F)"),
            Rule(name, positive, f"positive {kind} ({what})")]


def weight_rules(Q, R):
    """A regulator's weights as `Rule`s: Q symmetric positive semidefinite (state weight), R
    symmetric positive definite (control weight), both finite."""
    return [*matrix_rules("Q", Q, "state weight"),
            *matrix_rules("R", R, "control weight", definite=True)]


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class LQRTransfer(Checked):
    """LQR rendezvous from x0 to the origin on the HCW equations (module docstring).

    orbit            the chief's circular `KeplerOrbit` (e = 0: HCW; SI, rad); t = 0 at its
                     epoch
    x0               the chaser's LVLH state [x, y, z, vx, vy, vz] at t = 0 (m, m/s; x radial
                     outward, y along-track, z orbit normal)
    duration         T (s): the horizon of "hard" and "weight", the time the stationary law
                     is flown for "infinite"
    Q                (6, 6) state weight, symmetric positive semidefinite (e.g. 1/m^2 on
                     positions, s^2/m^2 on velocities)
    R                (3, 3) control weight on u (m/s^2), symmetric positive definite (e.g.
                     s^4/m^2)
    terminal_weight  (6, 6) S_T, symmetric positive semidefinite, in Q's units times s; used by
                     terminal="weight" (zero otherwise; default zero)
    terminal         "hard" (x(T) = 0), "weight" or "infinite" (static; module docstring)

    `xf` is the target, the origin (zeros): where a "hard" transfer ends, and what
    `jaxlpm.verify.fly` measures the terminal error against.
    """

    orbit: KeplerOrbit
    x0: jax.Array
    duration: jax.Array
    Q: jax.Array
    R: jax.Array
    terminal_weight: jax.Array = None
    terminal: str = field(default="hard", metadata=dict(static=True))

    def __post_init__(self):
        if self.terminal_weight is None:
            object.__setattr__(self, "terminal_weight", np.zeros((6, 6)))
        coerce_sequences(self)

    def replace(self, **kwargs) -> "LQRTransfer":
        return replace(self, **kwargs)

    @property
    def xf(self):
        """The target state: the origin (m, m/s)."""
        return jnp.zeros_like(self.x0)

    def rules(self):
        """Validity rules, written once (`jaxlpm._validation.Checked`)."""
        xp = array_module(self)
        S = self.terminal_weight
        if self.terminal == "weight":
            terminal = matrix_rules("terminal_weight", S, "terminal weight")
        else:
            terminal = [Rule("terminal_weight", xp.all(S == 0.0),
                             f"zero for terminal={self.terminal!r} (a terminal weight needs "
                             f"terminal='weight')")]
        return [*self.orbit.rules(),
                Rule("orbit.e", self.orbit.e == 0.0,
                     "0: the LQR family uses the HCW equations (circular chief)"),
                Rule("x0", xp.all(xp.isfinite(self.x0)), "finite (m, m/s)"),
                Rule("duration", xp.isfinite(self.duration) & (self.duration > 0.0),
                     "a positive, finite duration in s"),
                *weight_rules(self.Q, self.R), *terminal]

    def static_rules(self) -> None:
        if self.terminal not in TERMINALS:
            raise ValueError(f"terminal must be one of {TERMINALS}, got {self.terminal!r}")
        for name, shape in (("x0", (6,)), ("duration", ()), ("Q", (6, 6)), ("R", (3, 3)),
                            ("terminal_weight", (6, 6))):
            check_shape(name, getattr(self, name), shape)
        self.orbit.static_rules()

    def harmless(self) -> "LQRTransfer":
        """A valid, well-scaled transfer of the same terminal kind: 100 m along-track to the
        origin in 1000 s, Bryson's weights for 1 km, 1 m/s and 1 mm/s^2."""
        return LQRTransfer(orbit=self.orbit.harmless(),
                           x0=jnp.array([0.0, 100.0, 0.0, 0.0, 0.0, 0.0]), duration=1000.0,
                           Q=jnp.diag(jnp.array([1e-6, 1e-6, 1e-6, 1.0, 1.0, 1.0])),
                           R=1e6 * jnp.eye(3), terminal_weight=jnp.zeros((6, 6)),
                           terminal=self.terminal)
