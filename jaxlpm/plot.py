"""Figures of solutions and studies (matplotlib), for scripts, notebooks and the reproductions.

    trajectory(solution, planes=("yx", "yz"), keep_out=None, ax=None)   the path in two planes
    controls(solution, ax=None)                    u_x, u_y, u_z and |u| against time
    convergence(points, values, status=None)       a quantity against the number of points
    sweep_map(x, y, values, status)                a study's colour map, non-SUCCESS greyed
    design_map(brute, results=())                  a design objective map, optimisers' paths
    histogram(values, status)                      a Monte Carlo column over its SUCCESS members
    save(figure, path)                             write a PNG (or any format) and close it

Frames and units. Positions are drawn in the solution's frame: for the relative families the
chief's LVLH frame (x radial outward, y along-track, z along the orbit normal, centred on the
chief, which is drawn at the origin), for the intercepts the Earth-centred inertial frame
(X, Y, Z). Lengths in m or km (`unit`; by default km once the drawing spans 2 km or more),
times in s (or min, h: `time_unit`), accelerations in m/s^2. A plane "yx" puts y on the
horizontal axis and x on the vertical one (V-bar across, R-bar up, the usual rendezvous view).

Statuses. Every helper that draws several members takes their `Status` (codes, `Status`
values or names): members that did not end SUCCESS are drawn apart (grey, dashed or hatched)
and counted in the legend, never coloured as if they were results.

Each function draws on the Axes it is given (`ax`) or on a new figure, and returns the Axes
(a list of Axes for `trajectory`); `ax.figure` is the figure. matplotlib is imported only when
a function is called, so `import jaxlpm` does not import it; figures are created through
`matplotlib.pyplot`, whose backend is matplotlib's choice (a non-interactive one where there
is no display; set MPLBACKEND=Agg to force it).
"""

from pathlib import Path

import numpy as np

from .status import Status

__all__ = ["GREY", "controls", "convergence", "histogram", "save", "sweep_map", "trajectory"]

GREY = "0.62"
"""The colour of members that did not end SUCCESS."""

_LENGTH_UNITS = {"m": 1.0, "km": 1e3}
_TIME_UNITS = {"s": 1.0, "min": 60.0, "h": 3600.0}
_AXIS_NAMES = {"LVLH": {"x": "x radial", "y": "y along-track", "z": "z normal"},
               "inertial": {"x": "X", "y": "Y", "z": "Z"}}
_TARGET_GID = "jaxlpm-chief"


def _pyplot():
    import matplotlib.pyplot as plt
    return plt


# ---- statuses -------------------------------------------------------------------------------

def _status_codes(status, shape) -> np.ndarray:
    """`status` (codes, Status values or names; None: all SUCCESS) as an int array of `shape`."""
    if status is None:
        return np.full(shape, int(Status.SUCCESS))
    s = np.asarray(status)
    if s.dtype.kind in "USO":
        try:
            s = np.vectorize(lambda name: int(Status[str(name)]), otypes=[int])(s)
        except KeyError as err:
            raise ValueError(f"unknown status name {err.args[0]!r}; the names are "
                             f"{[m.name for m in Status]}") from None
    s = np.asarray(s, dtype=int)
    if s.shape != tuple(shape):
        try:
            s = np.broadcast_to(s, shape)
        except ValueError:
            raise ValueError(f"status has shape {s.shape}, the values {tuple(shape)}") from None
    return s


def _status_name(code: int) -> str:
    try:
        return Status(int(code)).name
    except ValueError:
        return f"UNKNOWN({int(code)})"


def _not_success_label(codes) -> str:
    """'not SUCCESS: 3 of 100 (2 INACCURATE, 1 MAX_ITERATIONS)'."""
    codes = np.asarray(codes).ravel()
    bad = codes[codes != Status.SUCCESS]
    text = f"not SUCCESS: {bad.size} of {codes.size}"
    if bad.size:
        kinds, counts = np.unique(bad, return_counts=True)
        text += " (" + ", ".join(f"{c} {_status_name(k)}" for k, c in zip(kinds, counts)) + ")"
    return text


# ---- sampling solutions ---------------------------------------------------------------------

_EVALUATE = None


def _sample_member(solution, tau):
    """(t, states(t), controls(t), and the node values) of one solution at fractions tau of
    its duration."""
    t = tau * solution.duration
    return (t, solution.states(t), solution.controls(t), solution.state_times,
            solution.node_states, solution.times, solution.node_controls)


def _sample_members(solutions, tau):
    """`_sample_member` over a leading member axis."""
    import jax

    return jax.vmap(_sample_member, in_axes=(0, None))(solutions, tau)


def _evaluator():
    """`_sample_members`, compiled once per trajectory structure and number of samples (and
    kept on disk: `jaxlpm.compilation`)."""
    global _EVALUATE
    if _EVALUATE is None:
        from .compilation import compiled

        _EVALUATE = compiled(_sample_members)
    return _EVALUATE


def _flatten_members(tree, batch: tuple):
    """Every array leaf of a batched pytree reshaped to one member axis in front."""
    import jax
    m = int(np.prod(batch, dtype=int))
    return jax.tree_util.tree_map(lambda x: np.reshape(np.asarray(x), (m,) + np.shape(x)[
        len(batch):]), tree)


def _is_solution(obj) -> bool:
    return hasattr(obj, "trajectory") and hasattr(obj, "controls")


def _members(source, samples: int) -> dict:
    """Samples of a Solution (batched or not) or a `verify.Flight`, one member axis in front:
    t (m, n) s, states (m, n, 6), controls (m, n, 3) or None, status (m,), node_t and
    node_states (or None), frame, target (the problem's final position or None)."""
    if _is_solution(source):
        batch = np.shape(source.status)
        flat = _flatten_members(source, batch)
        # its evaluable part only: one program serves every solution of a trajectory kind and
        # size, whatever its problem and stats (the whole solution's pytree made a key per
        # stats layout, and JAX's cache then served the second without a disk entry: 0.5 s of
        # tracing in every warm `jaxlpm reproduce mei2010`)
        t, x, u, node_t, node_x, node_ct, node_u = (np.asarray(a) for a in _evaluator()(
            flat.evaluable(), np.linspace(0.0, 1.0, int(samples))))
        xf = getattr(source.problem, "xf", None)
        target = None
        if xf is not None and source.frame == "LVLH":
            target = np.reshape(np.asarray(xf), (-1, np.shape(xf)[-1]))[:, :3]
        return dict(t=t, states=x, controls=u, status=np.asarray(flat.status).reshape(-1),
                    node_t=node_t, node_states=node_x, node_ct=node_ct, node_u=node_u,
                    frame=source.frame, target=target)
    if hasattr(source, "times") and hasattr(source, "states"):          # a verify.Flight
        t = np.asarray(source.times)
        x = np.asarray(source.states)
        t, x = t.reshape(-1, t.shape[-1]), x.reshape(-1, *x.shape[-2:])
        status = np.asarray(getattr(source, "status", Status.SUCCESS)).reshape(-1)
        return dict(t=t, states=x, controls=None, status=np.broadcast_to(status, t.shape[:1]),
                    node_t=None, node_states=None, frame="LVLH", target=None)
    raise ValueError(f"expected a jaxlpm Solution or a verify.Flight, got "
                     f"{type(source).__name__}")


def _length_unit(unit, extent: float) -> str:
    if unit is None:
        return "km" if extent >= 2e3 else "m"
    if unit not in _LENGTH_UNITS:
        raise ValueError(f"unit must be one of {tuple(_LENGTH_UNITS)} or None, got {unit!r}")
    return unit


def _time_unit(time_unit) -> float:
    if time_unit not in _TIME_UNITS:
        raise ValueError(f"time_unit must be one of {tuple(_TIME_UNITS)}, got {time_unit!r}")
    return _TIME_UNITS[time_unit]


def _axes(ax, count: int, figsize):
    """`count` Axes: the given ones (one Axes or a sequence of `count`) or a new figure's."""
    if ax is None:
        _, axes = _pyplot().subplots(1, count, figsize=figsize, squeeze=False)
        return list(axes[0])
    axes = list(ax) if isinstance(ax, (list, tuple, np.ndarray)) else [ax]
    if len(axes) != count:
        raise ValueError(f"expected {count} Axes, got {len(axes)}")
    return axes


# ---- trajectory -----------------------------------------------------------------------------

def _keep_out_zones(keep_out) -> list:
    """keep_out as a list of (centre (3,), semi-axes (3,)) in m."""
    if keep_out is None:
        return []
    def is_point(v):
        try:
            return np.asarray(v, dtype=float).shape == (3,)
        except (TypeError, ValueError):
            return False

    single = len(keep_out) == 2 and is_point(keep_out[0])      # one (centre, radius) pair
    zones = [keep_out] if single else keep_out
    out = []
    for zone in zones:
        try:
            centre, radius = zone
        except (TypeError, ValueError):
            raise ValueError("keep_out must be (centre, radius) or a list of them: centre 3 "
                             "LVLH coordinates (m), radius a sphere's radius or an "
                             "ellipsoid's 3 semi-axes along x, y, z (m)") from None
        centre = np.asarray(centre, dtype=float)
        radius = np.broadcast_to(np.asarray(radius, dtype=float), (3,)) \
            if np.size(radius) in (1, 3) else None
        if centre.shape != (3,) or radius is None:
            raise ValueError(f"keep_out zone: centre needs 3 coordinates and radius 1 or 3 "
                             f"values, got {np.shape(centre)} and {np.shape(zone[1])}")
        if not (np.all(np.isfinite(centre)) and np.all(np.isfinite(radius))
                and np.all(radius > 0)):
            raise ValueError(f"keep_out zone: centre must be finite and the radius positive, "
                             f"got {centre}, {radius}")
        out.append((centre, radius))
    return out


def trajectory(solution, planes=("yx", "yz"), keep_out=None, ax=None, *, unit=None,
               samples: int = 400, label=None, color=None, nodes: bool = True):
    """Draw the relative path of `solution` in coordinate planes; return the Axes (a list, one
    per plane).

    solution  a `Solution` (or a batch of them: one line per member, the non-SUCCESS members
              grey and dashed, counted in the legend) or a `verify.Flight` (a flown path);
              its states are sampled at `samples` uniform times (a dot at the start, an
              open square at the end) and its state nodes marked (`nodes`). Positions in
              the solution's frame: LVLH (x radial, y along-track, z normal) centred on the
              chief, drawn as a black star at the origin; the problem's target position,
              where it is not the origin, as a black cross.
    planes    two letters each, the horizontal axis first: "yx" (along-track across, radial
              up), "yz", "xz", ...; one string for one plane
    keep_out  an approach keep-out zone: (centre, radius) in LVLH m, radius a sphere's or an
              ellipsoid's three semi-axes along x, y, z (axis-aligned); or a list of them;
              drawn as its section through each plane (red, hatched)
    ax        None (a new figure) or the Axes to draw on, one per plane: call again with the
              returned list to overlay another solution or flight (the chief and each zone
              are drawn once)
    unit      "m", "km" or None (km when the drawing spans 2 km or more)
    label, color  the line's legend label and colour (default: matplotlib's cycle)

    The aspect ratio is equal (distances read the same along both axes).
    """
    planes = (planes,) if isinstance(planes, str) else tuple(planes)
    for p in planes:
        if len(p) != 2 or set(p) - set("xyz") or p[0] == p[1]:
            raise ValueError(f"a plane is two different letters of 'xyz', horizontal axis "
                             f"first (e.g. 'yx'), got {p!r}")
    zones = _keep_out_zones(keep_out)
    data = _members(solution, samples)
    if zones and data["frame"] != "LVLH":
        raise ValueError("keep_out zones are given in the chief's LVLH frame; this solution's "
                         f"frame is {data['frame']!r}")
    axes = _axes(ax, len(planes), (5.2 * len(planes), 4.6))
    existing = [a.get_xlabel() for a in axes]
    extent = float(np.nanmax(np.abs(data["states"][..., :3]))) if data["states"].size else 0.0
    if any(existing):            # overlaying: keep the unit the axes already show
        unit = unit or ("km" if "(km)" in existing[0] else "m")
    unit = _length_unit(unit, extent)
    scale = _LENGTH_UNITS[unit]
    names = _AXIS_NAMES.get(data["frame"], _AXIS_NAMES["LVLH"])
    ok = data["status"] == Status.SUCCESS
    for a, plane in zip(axes, planes):
        h, v = ("xyz".index(c) for c in plane)
        base = None
        for k in range(data["states"].shape[0]):
            r = data["states"][k, :, :3] / scale
            style = dict(color=color, lw=1.6) if ok[k] else dict(color=GREY, lw=1.0, ls="--")
            if base is not None and ok[k]:
                style["color"] = base.get_color()
            line, = a.plot(r[:, h], r[:, v], **style, label=(
                label if ok[k] and base is None else None))
            if ok[k] and base is None:
                base = line
            a.plot(r[0, h], r[0, v], "o", ms=5, color=line.get_color())
            a.plot(r[-1, h], r[-1, v], "s", ms=4, mfc="none", color=line.get_color())
            if nodes and data["node_states"] is not None:
                rn = data["node_states"][k, :, :3] / scale
                a.plot(rn[:, h], rn[:, v], ".", ms=3.5, color=line.get_color())
        if (~ok).any():
            a.plot([], [], color=GREY, lw=1.0, ls="--", label=_not_success_label(
                data["status"]) + (f" ({label})" if label else ""))
        drawn = {artist.get_gid() for artist in a.get_children()}
        if data["frame"] == "LVLH" and _TARGET_GID not in drawn:
            a.plot([0.0], [0.0], "*", color="k", ms=11, gid=_TARGET_GID, label="chief (origin)",
                   zorder=5)
        _draw_zones(a, zones, h, v, scale, drawn)
        if data["target"] is not None:
            for p in np.unique(data["target"], axis=0):
                if np.any(p != 0.0) and f"target{tuple(p)}" not in drawn:
                    a.plot(p[h] / scale, p[v] / scale, "kx", ms=8, mew=2, zorder=5,
                           gid=f"target{tuple(p)}", label="target")
        a.set(xlabel=f"{names[plane[0]]} ({unit})", ylabel=f"{names[plane[1]]} ({unit})")
        a.set_aspect("equal", adjustable="datalim")
        a.grid(alpha=0.3)
        a.legend(fontsize=8)
    return axes


def _draw_zones(a, zones, h, v, scale, drawn):
    """Each zone's section through the plane, once per Axes (one legend entry in all)."""
    from matplotlib.patches import Ellipse
    labelled = any(str(g).startswith("keep-out") for g in drawn)
    for centre, radius in zones:
        gid = f"keep-out{tuple(centre)}{tuple(radius)}"
        if gid in drawn:
            continue
        a.add_patch(Ellipse((centre[h] / scale, centre[v] / scale), 2 * radius[h] / scale,
                            2 * radius[v] / scale, facecolor="tab:red", alpha=0.25,
                            edgecolor="tab:red", hatch="//", zorder=1, gid=gid,
                            label=None if labelled else "keep-out zone"))
        labelled = True


# ---- controls -------------------------------------------------------------------------------

def controls(solution, ax=None, *, samples: int = 600, time_unit: str = "s",
             nodes: bool = True, title=None):
    """Draw the control acceleration against time; return the Axes.

    One solution: its components u_x, u_y, u_z (in the solution's frame: LVLH radial,
    along-track, normal) and |u| (black), sampled at `samples` uniform times, with |u| at the
    collocation points as dots (`nodes`). A batch: |u| of every member, the non-SUCCESS
    members grey and dashed, counted in the legend. Accelerations in m/s^2, times since the
    start in `time_unit` ("s", "min" or "h").
    """
    data = _members(solution, samples)
    if data["controls"] is None:
        raise ValueError("controls needs a Solution (a verify.Flight carries no controls)")
    tscale = _time_unit(time_unit)
    a, = _axes(ax, 1, (7.5, 4.2))
    t, u = data["t"] / tscale, data["controls"]
    norm = np.linalg.norm(u, axis=-1)
    names = ("x", "y", "z") if data["frame"] == "LVLH" else ("X", "Y", "Z")
    if u.shape[0] == 1:
        for k, name in enumerate(names):
            a.plot(t[0], u[0, :, k], lw=1.2, label=f"u_{name}")
        a.plot(t[0], norm[0], "k", lw=1.8, label="|u|")
        if nodes:
            a.plot(data["node_ct"][0] / tscale, np.linalg.norm(data["node_u"][0], axis=-1),
                   "k.", ms=4, label="|u| at the collocation points")
        if data["status"][0] != Status.SUCCESS:
            a.plot([], [], " ", label=f"status {_status_name(data['status'][0])}")
    else:
        ok = data["status"] == Status.SUCCESS
        for k in range(u.shape[0]):
            a.plot(t[k], norm[k], **(dict(color="C0", lw=0.8, alpha=0.7) if ok[k] else
                                     dict(color=GREY, lw=0.8, ls="--")))
        a.plot([], [], color="C0", lw=0.8, label=f"|u|, SUCCESS: {int(ok.sum())}")
        a.plot([], [], color=GREY, lw=0.8, ls="--", label=_not_success_label(data["status"]))
    frame = "LVLH" if data["frame"] == "LVLH" else "inertial"
    a.set(xlabel=f"t ({time_unit})", ylabel=f"acceleration, {frame} (m/s²)", title=title)
    a.grid(alpha=0.3)
    a.legend(fontsize=8)
    return a


# ---- convergence ----------------------------------------------------------------------------

def convergence(points, values, status=None, ax=None, *, label=None, ylabel=None,
                xlabel="collocation points", logx: bool = False, marker: str = "o",
                title=None):
    """Draw a quantity against the number of points on a logarithmic y axis (and x axis with
    `logx`); return the Axes.

    points  the number of collocation points of each solve (or any resolution parameter)
    values  the quantity per point count (an error in m, a cost difference, ...), or a dict
            {label: values} for several series; values <= 0 or not finite are not drawn (no
            place on a log axis)
    status  per point count (codes, `Status` or names; a dict per series with `values`):
            the SUCCESS points are joined by a line, the others marked with a cross of the
            same colour and named in the legend, not joined
    """
    series = values if isinstance(values, dict) else {label: values}
    statuses = status if isinstance(status, dict) else {name: status for name in series}
    points = np.asarray(points)
    a, = _axes(ax, 1, (6.0, 4.2))
    for name, vals in series.items():
        vals = np.asarray(vals, dtype=float)
        if vals.shape != points.shape:
            raise ValueError(f"values{'' if name is None else f' of {name!r}'} have shape "
                             f"{vals.shape}, points {points.shape}")
        codes = _status_codes(statuses.get(name), points.shape)
        drawable = np.isfinite(vals) & (vals > 0)
        ok = drawable & (codes == Status.SUCCESS)
        line, = a.plot(points[ok], vals[ok], marker + "-", ms=5, label=name)
        bad = drawable & ~ok
        if bad.any():
            kinds = ", ".join(sorted({_status_name(c) for c in codes[bad]}))
            a.plot(points[bad], vals[bad], "x", ms=9, mew=2, color=line.get_color(),
                   label=(f"{name}: " if name else "") + kinds)
    a.set_yscale("log")
    if logx:
        a.set_xscale("log")
    a.set(xlabel=xlabel, ylabel=ylabel, title=title)
    a.grid(alpha=0.3, which="both")
    if a.get_legend_handles_labels()[1]:
        a.legend(fontsize=8)
    return a


# ---- studies --------------------------------------------------------------------------------

def _regular_grid(x, y):
    """(unique x, unique y, row, column) when the members fill a rectangular grid, else None."""
    ux, ix = np.unique(x, return_inverse=True)
    uy, iy = np.unique(y, return_inverse=True)
    if ux.size * uy.size != x.size or ux.size < 2 or uy.size < 2:
        return None
    filled = np.zeros((uy.size, ux.size), dtype=bool)
    filled[iy, ix] = True
    return (ux, uy, iy, ix) if filled.all() else None


def _edges(c):
    mid = 0.5 * (c[1:] + c[:-1])
    return np.concatenate([[c[0] - (mid[0] - c[0])], mid, [c[-1] + (c[-1] - mid[-1])]])


def sweep_map(x, y, values, status, ax=None, *, log: bool = False, cmap: str = "viridis",
              colorbar_label=None, xlabel=None, ylabel=None, title=None):
    """Draw a study's values over two of its parameters, colouring only the SUCCESS members;
    return the Axes.

    x, y, values, status  one entry per member (any shape, flattened; status as codes,
              `Status` or names). Members filling a rectangular grid of (x, y) values are
              drawn as cells (pcolormesh, cell edges half-way between the values), the others
              as points (scatter).
    The non-SUCCESS members are not coloured: grey hatched cells (grey crosses for points),
    counted by status in the legend ("not SUCCESS: 3 of 100 (3 INACCURATE)"). The colour
    scale spans the SUCCESS values only (logarithmic with `log`: positive values), with a
    colour bar labelled `colorbar_label`. Units are the caller's (say them in the labels).
    The legend and the `title` stand above the Axes.
    """
    from matplotlib.colors import LogNorm, Normalize
    from matplotlib.patches import Patch, Rectangle
    from matplotlib.collections import PatchCollection

    x, y = np.ravel(np.asarray(x, dtype=float)), np.ravel(np.asarray(y, dtype=float))
    values = np.ravel(np.asarray(values, dtype=float))
    if not (x.size == y.size == values.size):
        raise ValueError(f"x, y and values need one entry per member, got sizes {x.size}, "
                         f"{y.size}, {values.size}")
    codes = _status_codes(status, np.shape(status)).ravel() if status is not None else \
        _status_codes(None, x.shape)
    if codes.size != x.size:
        raise ValueError(f"status has {codes.size} entries, the members {x.size}")
    ok = (codes == Status.SUCCESS) & np.isfinite(values) & ((values > 0) if log else True)
    good = values[ok]
    norm = (LogNorm if log else Normalize)(*(good.min(), good.max()) if good.size else (None,
                                                                                         None))
    a, = _axes(ax, 1, (6.4, 4.8))
    grid = _regular_grid(x, y)
    mappable = None
    if grid is not None:
        ux, uy, iy, ix = grid
        z = np.ma.masked_all((uy.size, ux.size))
        z[iy[ok], ix[ok]] = good
        ex, ey = _edges(ux), _edges(uy)
        mappable = a.pcolormesh(ex, ey, z, cmap=cmap, norm=norm, shading="flat")
        cells = [Rectangle((ex[j], ey[i]), ex[j + 1] - ex[j], ey[i + 1] - ey[i])
                 for i, j in zip(iy[~ok], ix[~ok])]
        if cells:
            a.add_collection(PatchCollection(cells, facecolor=GREY, edgecolor="0.35",
                                             hatch="//", linewidth=0.5))
        handle = Patch(facecolor=GREY, edgecolor="0.35", hatch="//")
    else:
        mappable = a.scatter(x[ok], y[ok], c=good, cmap=cmap, norm=norm, s=22)
        a.scatter(x[~ok], y[~ok], marker="x", color=GREY, s=30)
        handle = a.scatter([], [], marker="x", color=GREY)
    if good.size:
        a.figure.colorbar(mappable, ax=a, label=colorbar_label)
    a.set(xlabel=xlabel, ylabel=ylabel)
    _legend_above(a, [handle], [_not_success_label(codes)], title)
    return a


def design_map(brute, results=(), ax=None, *, x=None, y=None, colorbar_label="objective",
               xlabel=None, ylabel=None, title=None):
    """Draw a design objective over two design parameters (`jaxlpm.design.brute_force`'s
    grid, cells without a SUCCESS member grey) with optimisers' paths on it (one
    `jaxlpm.design.optimise` result or a list: start, iterates, last iterate each) and the
    grid's least cell; return the Axes. x, y: the two names (default: the grid's two
    axes). Units are the design's (say them in the labels)."""
    names = list(brute.axes)
    x, y = x or names[0], y or names[1]
    if {x, y} != set(names) or len(names) != 2:
        raise ValueError(f"design_map draws a grid of two parameters as (x, y); the grid has "
                         f"{names}, asked for ({x!r}, {y!r})")
    gx, gy = np.meshgrid(brute.axes[names[0]], brute.axes[names[1]], indexing="ij")
    cols = {names[0]: gx, names[1]: gy}
    status = np.where(brute.success > 0, Status.SUCCESS, Status.MAX_ITERATIONS)
    a = sweep_map(cols[x], cols[y], brute.objective, status, ax=ax, cmap="viridis",
                  colorbar_label=colorbar_label, xlabel=xlabel or x, ylabel=ylabel or y,
                  title=title)
    best = brute.argmin
    a.plot(best[x], best[y], "*", ms=16, color="white", mec="black", label="grid's least cell")
    results = [results] if hasattr(results, "history") else list(results)
    for k, result in enumerate(results):
        path = {n: np.array([h["theta"][n] for h in result.history]
                            + [float(np.asarray(result.theta[n]))]) for n in (x, y)}
        # a periodic parameter's wrap (a jump over half its axis) is not drawn across the map
        jump = np.zeros(path[x].size - 1, bool)
        for n in (x, y):
            jump |= np.abs(np.diff(path[n])) > 0.5 * np.ptp(brute.axes[n])
        line = {n: np.insert(path[n], np.flatnonzero(jump) + 1, np.nan) for n in (x, y)}
        labels = ("optimiser's path", "start", "last iterate") if k == 0 else (None,) * 3
        a.plot(line[x], line[y], ".-", color="red", ms=4, lw=1, label=labels[0])
        a.plot(path[x][0], path[y][0], "o", color="red", mec="black", ms=7, label=labels[1])
        a.plot(path[x][-1], path[y][-1], "D", color="red", mec="black", ms=7, label=labels[2])
    a.legend(fontsize=8, loc="lower right", framealpha=0.8)
    return a


def histogram(values, status=None, ax=None, *, bins=20, xlabel=None,
              percentiles=(5.0, 50.0, 95.0), title=None):
    """Draw the histogram of a study's column over its SUCCESS members; return the Axes.

    values  one entry per member (a Monte Carlo's delta-v in m/s, its cost, ...); status
            their statuses (codes, `Status` or names; None: all SUCCESS). The other members
            are left out and counted in the legend; the mean (solid) and the `percentiles`
            (dashed) of the SUCCESS values are drawn as vertical lines. Units are the
            caller's (say them in `xlabel`). The legend and the `title` stand above the Axes.
    """
    values = np.ravel(np.asarray(values, dtype=float))
    codes = _status_codes(status, np.shape(status) if status is not None else values.shape)
    codes = codes.ravel()
    if codes.size != values.size:
        raise ValueError(f"status has {codes.size} entries, the values {values.size}")
    ok = (codes == Status.SUCCESS) & np.isfinite(values)
    good = values[ok]
    a, = _axes(ax, 1, (6.0, 4.2))
    if good.size:
        a.hist(good, bins=bins, color="C0", alpha=0.8,
               label=f"SUCCESS: {good.size} of {values.size}")
        a.axvline(good.mean(), color="k", lw=1.5, label=f"mean {good.mean():.4g}")
        for q in percentiles:
            a.axvline(np.percentile(good, q), color="k", lw=1.0, ls="--")
        a.plot([], [], "k--", lw=1.0, label="percentiles " + ", ".join(
            f"{q:g}" for q in percentiles) + " %")
    a.plot([], [], " ", label=_not_success_label(codes) + " (left out)")
    a.set(xlabel=xlabel, ylabel="members")
    a.yaxis.get_major_locator().set_params(integer=True)
    a.grid(alpha=0.3)
    _legend_above(a, *a.get_legend_handles_labels(), title)
    return a


def _legend_above(a, handles, labels, title):
    """The legend above the Axes, out of the data's way, headed by the title."""
    a.legend(handles, labels, title=title, fontsize=8, title_fontsize=10, loc="lower left",
             bbox_to_anchor=(0.0, 1.01), borderaxespad=0.0, frameon=False, alignment="left",
             ncols=2 if len(labels) > 2 else 1)


# ---- output ---------------------------------------------------------------------------------

def save(figure, path, *, dpi: int = 100):
    """Lay out and write `figure` (a Figure, or an Axes or list of Axes on it) to `path` (the
    format from its suffix; folders created), close it, and return the path."""
    if isinstance(figure, (list, tuple, np.ndarray)):
        figure = figure[0]
    figure = getattr(figure, "figure", figure)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.tight_layout()
    figure.savefig(path, dpi=dpi)
    _pyplot().close(figure)
    return path
