"""Implicit gradients of the fuel (issue 22, item 2) against central differences, on the
linear (Tschauner-Hempel) and two-body models: the case of tests/test_fuel_eccentric.py
(a = 10000 km, e = 0.3, 8 km along-track in one period, 0.3 N on 50 kg), each on the mesh its
default solve refined to, held fixed. d fuel / d y_f (steps 0.05 m) and d fuel / d e (steps
1e-6): the gradient by `jax.grad` through `jaxlpm.solve` (the implicit function theorem on the
dual residual and, on two-body, the linearisation's fixed point), the differences from the
same solves. Prints each pair, their relative difference and the compile time of the
gradient.

    python experiments/fuel_gradients.py
"""

import sys
import time
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from test_fuel_eccentric import fraction_breaks, problem  # noqa: E402

import jaxlpm as lpm  # noqa: E402


def main():
    y, e = 8000.0, 0.3
    for model in ("linear", "two-body"):
        mesh = lpm.segmented_lgr(fraction_breaks(lpm.solve(problem(model), throw=False)), 8)

        def fuel(y, e):
            return lpm.solve(problem(model, e=e, y=y), mesh, throw=False).stats["fuel"]

        t = time.perf_counter()
        grad = jax.grad(fuel, argnums=(0, 1))(y, e)
        compile_s = time.perf_counter() - t
        value = jax.jit(fuel)
        for i, (name, x0, h) in enumerate((("y_f", y, 0.05), ("e", e, 1e-6))):
            args = [y, e]
            args[i] = x0 + h
            up = float(value(*args))
            args[i] = x0 - h
            fd = (up - float(value(*args))) / (2 * h)
            print(f"{model:>8} d fuel/d {name:>3}: implicit {float(grad[i]):.10e}, differences "
                  f"{fd:.10e}, relative {abs(float(grad[i]) - fd) / abs(fd):.1e} "
                  f"(gradient's first call {compile_s:.0f} s)", flush=True)


if __name__ == "__main__":
    main()
