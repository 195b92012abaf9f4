"""Risk measures of a batch of per-member costs, over the members that count (weights 1, the
SUCCESS members; 0 for the rest), differentiable with respect to the costs.

    mean        E[x]                             (sum w x / sum w)
    mean_std(k) E[x] + k std[x]                  (std: the population standard deviation
                                                  of the counted members)
    cvar(b)     CVaR_b[x] = E[x | x >= VaR_b[x]]  the mean of the worst (1 - b) fraction
                (Rockafellar & Uryasev 2000: CVaR_b = min_t t + E[(x - t)_+] / (1 - b), its
                minimiser t = VaR_b the b-quantile; the gradient is that of the mean of the
                tail above VaR_b, the quantile held fixed: exact by the envelope theorem)

A measure is a frozen dataclass (hashable: a static argument of a compiled design step) whose
`__call__(x, w)` gives the statistic of x (n,) with weights w (n,) in {0, 1}.
"""

from dataclasses import dataclass

import jax
import jax.numpy as jnp


def _moments(x, w):
    count = jnp.maximum(jnp.sum(w), 1.0)
    mean = jnp.sum(w * x) / count
    var = jnp.sum(w * (x - mean) ** 2) / count
    # sqrt's derivative at 0 is infinite: a batch of one (or of equal costs) has std 0 and a
    # zero gradient of it, not NaN
    std = jnp.where(var > 0.0, jnp.sqrt(jnp.where(var > 0.0, var, 1.0)), 0.0)
    return mean, std


@dataclass(frozen=True)
class Mean:
    """E[x] over the counted members."""

    def __call__(self, x, w):
        return _moments(x, w)[0]

    def describe(self):
        return "mean"


@dataclass(frozen=True)
class MeanStd:
    """E[x] + k std[x] over the counted members (population standard deviation)."""

    k: float = 2.0

    def __call__(self, x, w):
        mean, std = _moments(x, w)
        return mean + self.k * std

    def describe(self):
        return f"mean + {self.k:g} std"


@dataclass(frozen=True)
class CVaR:
    """Conditional value at risk at level b in (0, 1): the mean of the worst (1 - b) fraction
    of the counted members (Rockafellar & Uryasev 2000)."""

    level: float = 0.9

    def __post_init__(self):
        if not 0.0 < self.level < 1.0:
            raise ValueError(f"the CVaR level must lie in (0, 1), got {self.level!r}")

    def __call__(self, x, w):
        count = jnp.maximum(jnp.sum(w), 1.0)
        # VaR_b: the b-quantile of the counted members (the others sorted last)
        ranked = jnp.sort(jnp.where(w > 0, x, jnp.inf))
        index = jnp.clip(jnp.ceil(self.level * count).astype(jnp.int32) - 1, 0, x.size - 1)
        var = jax.lax.stop_gradient(ranked[index])
        excess = jnp.where(x > var, x - var, 0.0)     # (x - t)_+, no gradient at the quantile
        return var + jnp.sum(w * excess) / ((1.0 - self.level) * count)

    def describe(self):
        return f"CVaR at {self.level:g}"


def mean() -> Mean:
    """E[x]."""
    return Mean()


def mean_std(k: float = 2.0) -> MeanStd:
    """E[x] + k std[x]."""
    return MeanStd(float(k))


def cvar(level: float = 0.9) -> CVaR:
    """CVaR_level[x]: the mean of the worst (1 - level) fraction."""
    return CVaR(float(level))
