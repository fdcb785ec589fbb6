#!/usr/bin/env python3
"""The steps of `feedscope estimate` written as a NumPy/SciPy user would write them.

A yardstick for speed (issue 14: feedscope must be >= 50x this) and a second opinion on the
numbers: with `--compare` it reports how far feedscope's friction is from this script's on the
same grid. It is not part of feedscope and is not run by CI; it needs numpy, scipy and pandas
(`pip install numpy scipy pandas`).

Steps, as in docs/estimation.md:
1. read the trace CSV (long layout `time_s,channel,value` or wide `time_s,position_mm,current_a`);
2. segmentation: turning points by hysteresis (8 position quanta, 1e-4 of the travel), each
   move's plateau speed the median chord speed above a quarter of its 95th percentile, steady
   runs at >= half of it, 2 knots trimmed at each end;
3. per stroke: the position smoothed by a cubic smoothing spline
   (`scipy.interpolate.make_smoothing_spline`, lam = 1/(h (2 pi f_c)^4), the same functional as
   feedscope's Reinsch smoother) over the stroke and a settling margin of 6 tau
   (tau = sqrt(2)/(2 pi f_c)) on each side, kept inside the move; the effort interpolated by a
   not-a-knot cubic spline (`scipy.interpolate.CubicSpline`);
4. t(z) on the grid z_k = k p/1024 inside the settled window by vectorised Newton steps on the
   position spline; friction by paper 000 Eq. 5: F = g e(t) - m_eq a(t) - b_eq v(t);
5. the friction CSV written with pandas.

The cut-off f_c is an argument (`--cutoff-hz`, default 10 Hz) or, with `--cutoff-from JSON`,
taken stroke by stroke from feedscope's summary of the same trace, so both smooth alike (a null
cut-off there: paper 000's not-a-knot interpolating spline, no margin).
feedscope chooses f_c from the data (docs/estimation.md); this script does not.

Usage:
    python3 scripts/reference_estimate.py TRACE.csv --axis AXIS.toml -o OUT.csv
        [--cutoff-hz F | --cutoff-from FEEDSCOPE.json] [--compare FEEDSCOPE.csv] [--no-write]
"""

import argparse
import json
import math
import sys
import time
import tomllib

import numpy as np
import pandas as pd
from scipy.interpolate import CubicSpline, make_smoothing_spline

SAMPLES_PER_LEAD = 1024
SETTLE_TIME_CONSTANTS = 6.0


def read_trace(path):
    """(t_pos, z_m, t_eff, effort, kind) from a feedscope trace CSV."""
    df = pd.read_csv(path, comment="#")
    cols = list(df.columns)
    if cols[:3] == ["time_s", "channel", "value"]:
        pos = df[df["channel"].isin(["position_mm", "position_m"])]
        scale = np.where(pos["channel"].to_numpy() == "position_mm", 1e-3, 1.0)
        for kind in ("current_a", "torque_nm"):
            eff = df[df["channel"] == kind]
            if len(eff):
                break
        return (pos["time_s"].to_numpy(), pos["value"].to_numpy() * scale,
                eff["time_s"].to_numpy(), eff["value"].to_numpy(), kind)
    kind = "current_a" if "current_a" in cols else "torque_nm"
    p = df[["time_s", "position_mm"]].dropna()
    e = df[["time_s", kind]].dropna()
    return (p["time_s"].to_numpy(), p["position_mm"].to_numpy() * 1e-3,
            e["time_s"].to_numpy(), e[kind].to_numpy(), kind)


def turning_points(z, eps, chunk=1 << 20):
    """Indices of alternating extremes: a running extreme must be left by more than eps before
    a reversal counts (the first and last sample included), searched a chunk at a time."""
    n = len(z)
    rmin, rmax = np.minimum.accumulate(z), np.maximum.accumulate(z)
    up_at = np.flatnonzero(z - rmin > eps)
    down_at = np.flatnonzero(rmax - z > eps)
    if len(up_at) == 0 and len(down_at) == 0:
        return [0, n - 1]
    up = len(down_at) == 0 or (len(up_at) > 0 and up_at[0] < down_at[0])
    k = int(up_at[0] if up else down_at[0])
    # The first extreme: its first occurrence before k (a strictly lower/higher value moves it).
    ref = rmin[k] if up else rmax[k]
    tp = [int(np.flatnonzero(z[: k + 1] == ref)[0])]
    ext = k
    while True:
        # Search forward from k for the first sample eps beyond the running extreme.
        best, best_i, start, hit = z[k], k, k, None
        while start < n:
            seg = z[start:start + chunk]
            run = (np.maximum if up else np.minimum)(
                (np.maximum if up else np.minimum).accumulate(seg), best)
            gone = np.flatnonzero((run - seg > eps) if up else (seg - run > eps))
            upto = len(seg) if len(gone) == 0 else int(gone[0])
            # The extreme so far: its last occurrence (a value equal to it moves it on).
            if upto > 0:
                top = run[upto - 1]
                at = np.flatnonzero(seg[:upto] == top)
                if len(at):
                    best, best_i = top, start + int(at[-1])
            if len(gone):
                hit = start + int(gone[0])
                break
            start += len(seg)
        ext = best_i
        if hit is None:
            break
        tp.append(ext)
        up, k = not up, hit
        ext = k
    if tp[-1] != ext:
        tp.append(ext)
    return tp


def find_strokes(t, z):
    """(first, last, move_first, move_last, direction) of every steady stroke."""
    steps = np.abs(np.diff(z))
    steps = steps[steps > 1e-12]
    quantum = steps.min() if len(steps) else 0.0
    eps = max(8 * quantum, 1e-4 * (z.max() - z.min()), 1e-7)
    tp = turning_points(z, eps)
    out = []
    for i0, i1 in zip(tp[:-1], tp[1:]):
        if i1 <= i0 + 1 or abs(z[i1] - z[i0]) <= eps:
            continue
        s = 1.0 if z[i1] > z[i0] else -1.0
        mean_step = abs(z[i1] - z[i0]) / (i1 - i0)
        w = min(max(math.ceil(8 * quantum / mean_step), 1), max((i1 - i0) // 4, 1))
        if i1 < i0 + w:
            continue
        k = np.arange(i0, i1 - w + 1)
        speed = s * (z[k + w] - z[k]) / (t[k + w] - t[k])
        p95 = np.sort(speed)[int(round((len(speed) - 1) * 0.95))]
        if not p95 > 0:
            continue
        fast = np.sort(speed[speed >= 0.25 * p95])
        plateau = fast[len(fast) // 2]
        steady = np.concatenate(([False], speed >= 0.5 * plateau, [False]))
        edges = np.flatnonzero(np.diff(steady.astype(np.int8)))
        for c0, c1 in zip(edges[::2], edges[1::2] - 1):
            first = i0 + c0 + (w - 1) + 2
            last = i0 + c1 + 1 - 2
            if last < first or last + 1 - first < 8 or abs(z[last] - z[first]) < 1e-3:
                continue
            out.append((first, last, i0, i1, s))
    return out


def invert(spline, z_grid, t_knots, z_knots, s):
    """t with spline(t) = z_grid (z monotone in the direction s), by Newton from the chords."""
    zk = s * z_knots
    k = np.clip(np.searchsorted(zk, s * z_grid) - 1, 0, len(zk) - 2)
    frac = (z_grid - z_knots[k]) / (z_knots[k + 1] - z_knots[k])
    t = t_knots[k] + frac * (t_knots[k + 1] - t_knots[k])
    d1 = spline.derivative(1)
    for _ in range(6):
        t = t - (spline(t) - z_grid) / d1(t)
    return t


def estimate(args):
    axis = tomllib.load(open(args.axis, "rb"))
    lead = axis["lead_mm"] * 1e-3
    m_eq = axis["table_mass_kg"] + 4 * math.pi**2 * axis["inertia_kgm2"] / lead**2
    b_eq = 4 * math.pi**2 * axis.get("damping_nms_per_rad", 0.0) / lead**2
    t_pos, z, t_eff, eff, kind = read_trace(args.trace)
    gain = 2 * math.pi / lead * (axis["torque_constant_nm_per_a"] if kind == "current_a" else 1.0)
    cutoffs = None
    if args.cutoff_from:
        summary = json.load(open(args.cutoff_from))
        cutoffs = [s.get("position_cutoff_hz") for s in summary["strokes"]]
    step = lead / SAMPLES_PER_LEAD
    rows = []
    for n, (first, last, mf, ml, s) in enumerate(find_strokes(t_pos, z)):
        # feedscope's summary says null where it kept paper 000's interpolating spline.
        f_c = cutoffs[n] if cutoffs is not None and n < len(cutoffs) else args.cutoff_hz
        margin = SETTLE_TIME_CONSTANTS * math.sqrt(2) / (2 * math.pi * f_c) if f_c else 0.0
        h = (t_pos[last] - t_pos[first]) / (last - first)
        extra = int(math.ceil(margin / h)) + 2 if f_c else 0
        k0, k1 = max(first - extra, mf), max(min(last + extra, ml), last)
        tz, zz = t_pos[k0:k1 + 1], z[k0:k1 + 1]
        if f_c:
            hw = (tz[-1] - tz[0]) / (len(tz) - 1)
            lam = 1.0 / (hw * (2 * math.pi * f_c) ** 4)
            zs = make_smoothing_spline(tz, zz, lam=lam)
        else:
            zs = CubicSpline(tz, zz, bc_type="not-a-knot")
        v = zs.derivative(1)
        # The settled window: from the end of the acceleration ramp + margin to the start of
        # the deceleration - margin (98 % of the stroke's mid speed).
        ts = t_pos[first:last + 1]
        q1, q3 = (last - first) // 4, 3 * (last - first) // 4
        v_mid = s * (z[first + q3] - z[first + q1]) / (ts[q3] - ts[q1])
        if f_c:
            fast = np.nonzero(s * v(ts) >= 0.98 * v_mid)[0]
            if len(fast) == 0:
                continue
            w_lo, w_hi = ts[fast[0]] + margin, ts[fast[-1]] - margin
        else:
            w_lo, w_hi = ts[0], ts[-1]
        e0, e1 = np.searchsorted(t_eff, tz[0]), np.searchsorted(t_eff, tz[-1], side="right")
        es = CubicSpline(t_eff[e0:e1], eff[e0:e1], bc_type="not-a-knot")
        w_lo, w_hi = max(w_lo, t_eff[e0]), min(w_hi, t_eff[e1 - 1])
        if w_hi <= w_lo:
            continue
        za, zb = zs(w_lo), zs(w_hi)
        if s > 0:
            kg = np.arange(math.ceil(za / step), math.floor(zb / step) + 1)
        else:
            kg = np.arange(math.floor(za / step), math.ceil(zb / step) - 1, -1)
        zg = kg * step
        tg = invert(zs, zg, tz, zs(tz), s)
        vg, ag = v(tg), zs.derivative(2)(tg)
        eg = es(tg)
        fg = gain * eg - m_eq * ag - b_eq * vg
        rows.append(pd.DataFrame({
            "stroke": n, "direction": "forward" if s > 0 else "backward",
            "position_mm": zg * 1e3, "time_s": tg, "velocity_mm_s": vg * 1e3,
            "accel_mm_s2": ag * 1e3, kind: eg, "friction_n": fg}))
    return pd.concat(rows, ignore_index=True) if rows else pd.DataFrame()


def compare(ours, path):
    """Friction of feedscope's CSV against ours at the same grid positions, per stroke."""
    theirs = pd.read_csv(path)
    for (stroke, mine), (_, fs) in zip(ours.groupby("stroke"), theirs.groupby("stroke")):
        # Grid positions as feedscope prints them (6 decimals of a mm).
        mine = mine.assign(position_mm=mine["position_mm"].round(6))
        both = mine.merge(fs, on="position_mm", suffixes=("", "_fs"), how="inner")
        if both.empty:
            print(f"stroke {stroke}: no common grid positions")
            continue
        d = both["friction_n"] - both["friction_n_fs"]
        spread = fs["friction_n"].std()
        print(f"stroke {stroke}: {len(both)} common points, friction difference "
              f"{np.sqrt(np.mean(d**2)):.4f} N RMS, {np.abs(d).max():.4f} N max "
              f"(feedscope's friction varies by {spread:.3f} N RMS)")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("trace")
    ap.add_argument("--axis", required=True)
    ap.add_argument("-o", "--output", default="reference_friction.csv")
    ap.add_argument("--cutoff-hz", type=float, default=10.0)
    ap.add_argument("--cutoff-from", help="feedscope's summary JSON of the same trace")
    ap.add_argument("--compare", help="feedscope's friction CSV of the same trace")
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    t0 = time.perf_counter()
    out = estimate(args)
    t1 = time.perf_counter()
    if not args.no_write:
        out.round(6).to_csv(args.output, index=False)
    t2 = time.perf_counter()
    print(f"{len(out)} points in {out['stroke'].nunique() if len(out) else 0} strokes: "
          f"read + estimate {t1 - t0:.2f} s, write {t2 - t1:.2f} s, total {t2 - t0:.2f} s",
          file=sys.stderr)
    if args.compare:
        compare(out, args.compare)


if __name__ == "__main__":
    main()
