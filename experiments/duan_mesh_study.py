"""Mesh study of the duan minimum-time case: K = 40, 60, 100, 150 points on LG, LGR and LGL
grids (lg(K), lgr(K), lgl(K)), each t_f against the grid-independent optimum from shooting on
the necessary conditions, and each solution's direction (renormalised) flown through the CW
equations (`jaxlpm.verify.fly`).

    python experiments/duan_mesh_study.py [--K 40,60,100,150] [--out results/duan_mesh.json]

Rows are appended to the JSON file as they finish; a rerun skips the (scheme, K) rows already
there (delete the file to start over). Prints a table at the end.
"""

import argparse
import json
import time
from pathlib import Path

from jaxlpm.cli import _setup_jax

_setup_jax()

import jax  # noqa: E402

from jaxlpm import make_grid, solve  # noqa: E402
from jaxlpm.cases import duan  # noqa: E402
from jaxlpm.status import Status  # noqa: E402
from jaxlpm.verify import fly, min_time_shooting  # noqa: E402

SCHEMES = ("LG", "LGR", "LGL")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--K", default="40,60,100,150")
    ap.add_argument("--out", default="results/duan_mesh.json")
    args = ap.parse_args()
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    data = json.loads(out.read_text()) if out.exists() else {"rows": []}
    done = {(r["scheme"], r["K"]) for r in data["rows"]}
    prob = duan.problem()
    for k in [int(v) for v in args.K.split(",")]:
        for scheme in SCHEMES:
            if (scheme, k) in done:
                continue
            t = time.perf_counter()
            sol = solve(prob, make_grid(scheme, k), throw=False)
            jax.block_until_ready(sol.duration)
            flight = fly(sol)                  # the CW flight of the renormalised direction
            row = {"scheme": scheme, "K": k, "points": k, "tf": float(sol.duration),
                   "status": Status(int(sol.status)).name,
                   "terminal_miss": [float(v) for v in flight.terminal_error],
                   "drift_rate": float(duan.drift_rate(flight.states[-1])),
                   "outer_iterations": int(sol.stats["outer_iterations"]),
                   "inner_iterations": int(sol.stats["inner_iterations"]),
                   "seconds_incl_compile": time.perf_counter() - t}
            if "tf_indirect" not in data and scheme == "LG" and row["status"] == "SUCCESS":
                shot = min_time_shooting(prob, sol.stats["costates_scaled"][0], sol.duration)
                if int(shot.status) == Status.SUCCESS:
                    data["tf_indirect"] = float(shot.duration)
                    data["tf_indirect_residual"] = float(shot.residual)
            data["rows"].append(row)
            out.write_text(json.dumps(data, indent=2))
            print(f"{scheme:>4} K = {k:>3}: t_f = {row['tf']:.9f} s ({row['status']}), "
                  f"{row['seconds_incl_compile']:.0f} s", flush=True)
    ref = data.get("tf_indirect")
    print(f"\nshooting optimum t_f* = {ref:.9f} s\n")
    print(f"{'scheme':>6}{'K':>5}{'t_f (s)':>18}{'t_f - t_f*':>12}{'miss (m)':>11}"
          f"{'miss (m/s)':>12}{'drift (m/s)':>13}  status")
    for r in sorted(data["rows"], key=lambda r: (SCHEMES.index(r["scheme"]), r["K"])):
        print(f"{r['scheme']:>6}{r['K']:>5}{r['tf']:>18.9f}{r['tf'] - ref:>12.2e}"
              f"{r['terminal_miss'][0]:>11.2e}{r['terminal_miss'][1]:>12.2e}"
              f"{r['drift_rate']:>13.2e}  {r['status']}")


if __name__ == "__main__":
    main()
