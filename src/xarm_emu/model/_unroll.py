"""Unrolled scalar code of a joint chain (the speed behind ``kinematics.fk``, ``jacobian`` and ``ik``).

A tiny symbolic emitter writes each model's chain as straight-line Python, with zero offsets and the exact
+/-pi/2 origin rotations (frames of ``robots.py``) folded away, and compiles it once: forward kinematics,
the geometric Jacobian, and the damped least-squares (Levenberg-Marquardt) loop with an unrolled Cholesky
solve. Pure code generation: which tolerances and caches apply is the caller's (``kinematics``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from .robots import RobotModel
from .rotations import matrix_to_axis_angle, pose_to_matrix


def _snap(v: float) -> float:
    if abs(v) < 1e-15:
        return 0.0
    if abs(abs(v) - 1.0) < 1e-15:
        return math.copysign(1.0, v)
    return v


class _Gen:
    """Tiny symbolic emitter: entries are float constants or variable names (optionally negated)."""

    def __init__(self) -> None:
        self.lines: list[str] = []
        self.n = 0

    def assign(self, expr: float | str) -> float | str:
        if isinstance(expr, float):
            return expr
        bare = expr[1:] if expr.startswith("-") else expr
        if bare.isidentifier():
            return expr
        self.n += 1
        name = f"t{self.n}"
        self.lines.append(f"    {name} = {expr}")
        return name

    @staticmethod
    def scale(e: float | str, k: float | str) -> float | str:
        """Product of a symbolic entry and a constant or a variable name."""
        if isinstance(e, float) and isinstance(k, float):
            return e * k
        if isinstance(k, float):
            e, k = k, e
        assert isinstance(k, str)
        if isinstance(e, float):
            if e == 0.0:
                return 0.0
            if e == 1.0:
                return k
            if e == -1.0:
                return k[1:] if k.startswith("-") else "-" + k
            return f"{e!r}*{k}"
        return f"{e}*{k}"

    @staticmethod
    def add(*terms: float | str) -> float | str:
        const = sum(t for t in terms if isinstance(t, float))
        syms = [t for t in terms if isinstance(t, str)]
        if not syms:
            return float(const)
        parts = syms + ([repr(const)] if const != 0.0 else [])
        out = parts[0]
        for p in parts[1:]:
            out += f" - {p[1:]}" if p.startswith("-") else f" + {p}"
        return out


    def raw(self, expr: str) -> str:
        """Assign any expression (e.g. a function call) to a fresh variable."""
        self.n += 1
        name = f"t{self.n}"
        self.lines.append(f"    {name} = {expr}")
        return name

    def dot(self, xs: Sequence[float | str], ys: Sequence[float | str]) -> float | str:
        return self.add(*(self.scale(x, y) for x, y in zip(xs, ys, strict=True)))

    def neg(self, e: float | str) -> float | str:
        return self.scale(e, -1.0)


Sym = float | str


Axes = list[tuple[list[Sym], list[Sym]]]


def _chain_code(g: _Gen, model: RobotModel, unit: float) -> tuple[list[list[Sym]], list[Sym], Axes]:
    """Emit the chain; returns flange R (3x3), p (3) and each joint's (z axis, origin)."""
    R: list[list[Sym]] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    p: list[Sym] = [0.0, 0.0, 0.0]
    axes: list[tuple[list[Sym], list[Sym]]] = []
    for i, j in enumerate(model.joints):
        g.lines.append(f"    c{i} = cos(q{i}); s{i} = sin(q{i})")
        po = [float(v) * unit for v in j.origin_xyz]
        p = [g.assign(g.add(p[k], g.dot(R[k], po))) for k in range(3)]
        Ro = pose_to_matrix((0.0, 0.0, 0.0, *j.origin_rpy))[:3, :3]
        Rc = [[_snap(float(Ro[a][b])) for a in range(3)] for b in range(3)]  # columns of Ro
        R = [[g.assign(g.dot(R[k], Rc[b])) for b in range(3)] for k in range(3)]
        axes.append(([R[k][2] for k in range(3)], list(p)))
        c, s = f"c{i}", f"s{i}"
        new0 = [g.assign(g.add(g.scale(R[k][0], c), g.scale(R[k][1], s))) for k in range(3)]
        new1 = [g.assign(g.add(g.scale(R[k][1], c), g.scale(g.neg(R[k][0]), s))) for k in range(3)]
        R = [[new0[k], new1[k], R[k][2]] for k in range(3)]
    return R, p, axes


def _jac_rows(g: _Gen, axes: Axes, p: list[Sym]) -> list[list[Sym]]:
    """Emit the geometric Jacobian rows (6 x dof): z_i x (p - o_i) over z_i."""
    rows: list[list[Sym]] = [[] for _ in range(6)]
    for z, o in axes:
        d = [g.assign(g.add(p[k], g.neg(o[k]))) for k in range(3)]
        cross = [
            g.add(g.scale(z[1], d[2]), g.scale(g.neg(z[2]), d[1])),
            g.add(g.scale(z[2], d[0]), g.scale(g.neg(z[0]), d[2])),
            g.add(g.scale(z[0], d[1]), g.scale(g.neg(z[1]), d[0])),
        ]
        for k in range(3):
            rows[k].append(g.assign(cross[k]))
            rows[3 + k].append(z[k])
    return rows


def _lm_code(g: _Gen, R: list[list[Sym]], p: list[Sym], axes: Axes, n: int) -> list[Sym]:
    """Emit the body of one damped least-squares iteration (error and its convergence test, J J^T +
    lambda I, unrolled Cholesky, J^T x, the capped and clamped step into q)."""
    E = [[g.assign(g.dot([f"T{3 * a + k}" for k in range(3)], R[b])) for b in range(3)] for a in range(3)]
    entries = ", ".join(str(E[a][b]) for a in range(3) for b in range(3))
    g.lines.append(f"    wx, wy, wz = _rotvec({entries})")
    g.lines.append(f"    px = tx - {p[0]}; py = ty - {p[1]}; pz = tz - {p[2]}")
    g.lines.append("    pe = px*px + py*py + pz*pz; re = wx*wx + wy*wy + wz*wz")
    qs = "".join(f"q{i}, " for i in range(n))
    g.lines.append(f"    if pe <= PTOL2 and re <= RTOL2: return (it + 1, {qs})")
    g.lines.append("    err2 = pe + re; lam = mu*err2 + 1e-12")
    g.lines.append("    if err2 > prev: mu *= 10.0  # diverging: damp the next step harder")
    g.lines.append("    prev = err2")
    J = _jac_rows(g, axes, p)  # only needed when not converged
    e = ["px", "py", "pz", "wx", "wy", "wz"]
    A = [[g.assign(g.add(g.dot(J[a], J[b]), *(["lam"] if a == b else []))) for b in range(a + 1)]
         for a in range(6)]
    L: list[list[Sym]] = [[0.0] * 6 for _ in range(6)]
    dinv: list[str] = []
    for i in range(6):
        for j in range(i):
            s = g.add(A[i][j], *(g.neg(g.scale(L[i][k], L[j][k])) for k in range(j)))
            L[i][j] = g.assign(g.scale(g.assign(s), dinv[j]))
        s = g.assign(g.add(A[i][i], *(g.neg(g.scale(L[i][k], L[i][k])) for k in range(i))))
        L[i][i] = g.raw(f"sqrt({s})")
        dinv.append(g.raw(f"1.0/{L[i][i]}"))
    y: list[Sym] = []
    for i in range(6):
        s = g.assign(g.add(e[i], *(g.neg(g.scale(L[i][k], y[k])) for k in range(i))))
        y.append(g.assign(g.scale(s, dinv[i])))
    x: list[Sym] = [0.0] * 6
    for i in range(5, -1, -1):
        s = g.assign(g.add(y[i], *(g.neg(g.scale(L[k][i], x[k])) for k in range(i + 1, 6))))
        x[i] = g.assign(g.scale(s, dinv[i]))
    dq = [g.assign(g.dot([J[a][k] for a in range(6)], x)) for k in range(n)]
    # step capped at MAX_STEP on any joint, then each joint clamped into its limits (projected step)
    g.lines.append("    big = max(" + ", ".join(f"abs({d})" for d in dq) + ")")
    g.lines.append("    k = MAX_STEP/big if big > MAX_STEP else 1.0")
    out: list[Sym] = []
    for i, d in enumerate(dq):
        g.lines.append(f"    n{i} = q{i} + {d}*k")
        g.lines.append(f"    n{i} = LO[{i}] if n{i} < LO[{i}] else (HI[{i}] if n{i} > HI[{i}] else n{i})")
        out.append(f"n{i}")
    g.lines.append("    " + "; ".join(f"q{i} = n{i}" for i in range(n)))
    return out


def _track_code(g: _Gen, R: list[list[Sym]], p: list[Sym], model: RobotModel, max_step: float,
                max_move: float) -> None:
    """Emit the body of one chord iteration: the error and its convergence test (exactly the LM's), then
    the step dq = M e with the stored matrix M (dof x 6, row-major m0...), capped at ``max_step`` on
    any joint and clamped into the joint limits (the LM's projected step), into q."""
    n = model.dof
    E = [[g.assign(g.dot([f"T{3 * a + k}" for k in range(3)], R[b])) for b in range(3)] for a in range(3)]
    entries = ", ".join(str(E[a][b]) for a in range(3) for b in range(3))
    g.lines.append(f"    px = tx - {p[0]}; py = ty - {p[1]}; pz = tz - {p[2]}")
    # the rotation vector of E = R_target R^T, as _rotvec computes it (its rare branch near pi called)
    g.lines.append(f"    vx = {E[2][1]} - {E[1][2]}; vy = {E[0][2]} - {E[2][0]}; vz = {E[1][0]} - {E[0][1]}")
    g.lines.append(f"    c = ({E[0][0]} + {E[1][1]} + {E[2][2]} - 1.0)/2.0")
    g.lines.append(f"    if c < -0.99: wx, wy, wz = _rotvec({entries})")
    g.lines.append("    else:")
    g.lines.append("        s = sqrt(vx*vx + vy*vy + vz*vz)")
    g.lines.append("        if s < 1e-300: wx = wy = wz = 0.0")
    g.lines.append("        else: k = atan2(s/2.0, c)/s; wx = vx*k; wy = vy*k; wz = vz*k")
    g.lines.append("    if px*px + py*py + pz*pz <= PTOL2 and wx*wx + wy*wy + wz*wz <= RTOL2:")
    near = " and ".join(f"{-max_move!r} <= q{i} - a{i} <= {max_move!r}" for i in range(n))
    g.lines.append("        return (" + "".join(f"q{i}, " for i in range(n)) + f") if {near} else ()")
    g.lines.append("    if it == chords: break")
    e = ("px", "py", "pz", "wx", "wy", "wz")
    for i in range(n):
        g.lines.append(f"    d{i} = " + " + ".join(f"m{6 * i + a}*{e[a]}" for a in range(6)))
    within = " and ".join(f"{-max_step!r} <= d{i} <= {max_step!r}" for i in range(n))
    g.lines.append(f"    if not ({within}):")
    g.lines.append(f"        k = {max_step!r}/max(" + ", ".join(f"abs(d{i})" for i in range(n)) + "); "
                   + "; ".join(f"d{i} *= k" for i in range(n)))
    for i in range(n):
        g.lines.append(f"    q{i} += d{i}")
        g.lines += _clamp(model, i, "    ")


def _clamp(model: RobotModel, i: int, indent: str) -> list[str]:
    """Lines that clamp joint ``i`` (variable q{i}) into its limits."""
    lo, hi = float(model.joints[i].lower), float(model.joints[i].upper)
    return [f"{indent}if q{i} < {lo!r}: q{i} = {lo!r}", f"{indent}elif q{i} > {hi!r}: q{i} = {hi!r}"]


def generate(model: RobotModel, mode: str, ptol2: float, rtol2: float, max_step: float,
             max_move: float = math.inf, arrays: bool = False) -> Callable[..., tuple[float, ...]]:
    """Unrolled code of ``model`` as a Python function; mode is "fk", "jac", "lm", "track" or "track3".
    With ``arrays`` (for "fk": ``kinematics.tcp_positions``) the same code runs on numpy arrays of
    joint values (each ``q`` an array, many states at once): its entries are arrays, constants floats.

    fk: (R row-major 9, p 3) in mm.  jac: the same plus the 6 x dof Jacobian row-major.
    lm: args (q..., T0..T8, tx, ty, tz, mu, max_iter) in metres; the whole damped least-squares loop,
    at most ``max_iter`` iterations of one capped, limit-clamped step, with lambda = mu |e|^2 + 1e-12 and
    mu raised tenfold whenever the error grows. Returns (iterations, q...) once converged, else
    (max_iter,). ``ptol2`` and ``rtol2`` are the squared convergence tolerances (m^2, rad^2),
    ``max_step`` the step cap (rad).
    track: args (q, target, matrix, chords, anchor): the start q (dof floats, clamped into the limits
    first), the target (the rows of the 4x4 flange pose in mm), the step matrix M (dof x 6 row-major,
    metres), the number of chord steps, the joints the answer must stay near. The chord loop: the LM's
    convergence test, then a step dq = M e capped and clamped as the LM's, at most ``chords`` times.
    Returns the joints once converged within ``max_move`` (rad, any joint) of ``anchor``, () when
    converged farther away, and (q..., None) at the last iterate when not converged.
    track3: args (h0, h1, h2, h3, target, matrix, chords): the same chord loop from the third-order
    extrapolation over equal path-time steps of four answers h0...h3 (oldest first, dof floats each),
    4 (h3 + h1) - 6 h2 - h0 per joint, with h3 as the anchor.
    """
    g = _Gen()
    args = [f"q{i}" for i in range(model.dof)]
    unit = 1e-3 if mode in ("lm", "track", "track3") else 1.0
    R, p, axes = _chain_code(g, model, unit)
    out: list[Sym] = [R[a][b] for a in range(3) for b in range(3)] + p
    if mode == "jac":
        out += [e for row in _jac_rows(g, axes, p) for e in row]
    elif mode == "lm":
        args += [f"T{k}" for k in range(9)] + ["tx", "ty", "tz", "mu", "max_iter"]
        _lm_code(g, R, p, axes, model.dof)
        body = "\n".join("    " + line for line in g.lines)
        src = (f"def _chain({', '.join(args)}):\n    prev = INF\n    for it in range(max_iter):\n{body}\n"
               "    return (max_iter,)\n")
    elif mode in ("track", "track3"):
        _track_code(g, R, p, model, max_step, max_move)
        body = "\n".join("    " + line for line in g.lines)
        qs = ", ".join(args)
        n = model.dof
        if mode == "track":
            head = ["def _chain(q, target, matrix, chords, anchor):", f"    {qs}, = q",
                    f"    {', '.join(f'a{i}' for i in range(n))}, = anchor"]
        else:  # the start: third-order extrapolation over equal steps, 4 (h3 + h1) - 6 h2 - h0
            head = ["def _chain(h0, h1, h2, anchor, target, matrix, chords):",
                    f"    {', '.join(f'a{i}' for i in range(n))}, = anchor"]
            head += [f"    {', '.join(f'{x}{i}' for i in range(n))}, = h{k}" for k, x in enumerate("efg")]
            head += [f"    q{i} = 4.0 * (a{i} + f{i}) - 6.0 * g{i} - e{i}" for i in range(n)]
        head += [line for i in range(n) for line in _clamp(model, i, "    ")]
        head += ["    (T0, T1, T2, tx), (T3, T4, T5, ty), (T6, T7, T8, tz) = target[:3]",
                 "    tx *= 0.001; ty *= 0.001; tz *= 0.001",
                 f"    {', '.join(f'm{k}' for k in range(6 * n))}, = matrix",
                 "    for it in range(chords + 1):"]
        src = "\n".join(head) + f"\n{body}\n    return ({qs}, None)\n"
    if mode not in ("lm", "track", "track3"):
        src = f"def _chain({', '.join(args)}):\n" + "\n".join(g.lines)
        src += "\n    return (" + ", ".join(repr(e) if isinstance(e, float) else e for e in out) + ",)\n"
    namespace: dict[str, object] = {
        "cos": np.cos if arrays else math.cos, "sin": np.sin if arrays else math.sin,
        "sqrt": math.sqrt, "atan2": math.atan2, "_rotvec": _rotvec,
        "INF": math.inf,
        "PTOL2": ptol2, "RTOL2": rtol2, "MAX_STEP": max_step,
        "LO": tuple(j.lower for j in model.joints), "HI": tuple(j.upper for j in model.joints),
    }
    exec(compile(src, f"<kinematics {model.name} {mode}>", "exec"), namespace)  # noqa: S102
    fn = namespace["_chain"]
    fn.__doc__ = src  # type: ignore[union-attr]
    return fn  # type: ignore[return-value]


def _rotvec(e00: float, e01: float, e02: float, e10: float, e11: float, e12: float,
            e20: float, e21: float, e22: float) -> tuple[float, float, float]:
    """Rotation vector of a rotation matrix given entry by entry (the IK orientation error)."""
    vx, vy, vz = e21 - e12, e02 - e20, e10 - e01
    c = (e00 + e11 + e22 - 1.0) / 2.0
    if c < -0.99:  # near pi: the skew part loses the axis
        w = matrix_to_axis_angle(np.array(((e00, e01, e02), (e10, e11, e12), (e20, e21, e22))))
        return float(w[0]), float(w[1]), float(w[2])
    s2 = math.sqrt(vx * vx + vy * vy + vz * vz)
    if s2 < 1e-300:
        return 0.0, 0.0, 0.0
    k = math.atan2(s2 / 2.0, c) / s2
    return vx * k, vy * k, vz * k
