#!/usr/bin/env python3
"""Plots image error against run time from mrt-compare's DIR/results.json, one curve per method,
and derives the equal-time and equal-error figures (DIR/derived.json and a table on stdout).

How a method's runs become a curve: its runs are sorted by time and only the non-dominated ones
are kept — a run that is no faster than another run of the same method and has no lower error is
dominated (nobody would choose it at any time budget), is drawn hollow and is ignored below. The
kept runs have strictly increasing time and strictly decreasing error; between neighbours the
curve is the straight line in log(time)–log(RMSE) space, i.e. the power law through both, which
is what a Monte Carlo estimator's error does (RMSE ∝ t^-1/2). Values are never extrapolated: a
level outside [error of the slowest kept run, error of the fastest kept run] or a time outside
[fastest, slowest] gives null. (This is the monotone part of the curve, not its convex hull: the
hull would bridge over measured runs and promise errors that no run achieved.)

The derived figures always use RMSE; --metric only changes what is plotted (PSNR and SSIM are
interpolated linearly against log time, which for PSNR is the same line as RMSE's log–log).

The baseline is the first run of method `cone` in the file, else the fastest `whitted` run,
else the fastest run (or the run named by --baseline SPEC). Equal time is the baseline's time;
equal error the baseline's RMSE.

derived.json (times in seconds of --time, errors RMSE, null = outside the measured runs):
  time        "render_seconds" or "total_seconds"
  baseline    {method, spec, seconds, rmse, chosen_as}
  levels      the RMSE levels below, descending: the baseline's and those of 0.05, 0.02, 0.01,
              0.005 within [lowest, highest] error of all curves
  time_to_error              {METHOD: {LEVEL: seconds|null}}, LEVEL keyed as repr(float): "0.05"
  equal_time                 {METHOD: rmse|null} at the baseline's time
  error_ratio_at_equal_time  {METHOD: that rmse / the baseline's rmse | null}
  speedup_at_equal_error     [{faster, slower, error, speedup = slower's time / faster's}] for
                             each pair of methods and each level both reach
  dominated_runs             [{method, spec}] left out of the curves
"""

import argparse
import json
import math
import os
import sys
from dataclasses import dataclass

# mrt-trace options that only say how many samples a run takes: runs differing in these alone
# are points on one curve.
SAMPLE_COUNT_OPTIONS = {"spp", "spp-max", "spp-initial", "target-error", "time-budget"}

# RMSE levels reported besides the baseline's when they lie within the range of the curves.
ERROR_LEVELS = (0.05, 0.02, 0.01, 0.005)

# Relative tolerance for "exactly at a measured run": interpolation snaps to the run's value.
SNAP = 1e-9

METRICS = {
    # name: (axis label, lower is better)
    "rmse": ("RMSE against the reference", True),
    "psnr": ("PSNR against the reference (dB)", False),
    "ssim": ("SSIM against the reference", False),
}

TIME_KEYS = {"render": "render_seconds", "total": "total_seconds"}


class ResultsError(Exception):
    """A malformed or unusable input; the message is one line naming the file and the place."""


@dataclass
class Reference:
    spp: int  # samples per pixel of the reference image
    seconds: float  # its render time (s)
    std_error: float | None  # standard error of its pixel values (RMSE units), None if unknown
    image: str  # file name, relative to DIR


@dataclass
class Run:
    index: int  # position in results.json's "runs"
    method: str  # tracer name: whitted, distributed, cone, cone-classic…
    spec: str  # full method specification with its options
    render_seconds: float  # rendering only (s)
    total_seconds: float  # loading, building and rendering (s)
    rays: int
    samples: int
    rmse: float  # against the reference, > 0
    psnr: float | None  # dB; None when the tool wrote null
    ssim: float | None
    image: str  # file names relative to DIR
    error_image: str

    @property
    def curve(self):
        """The curve the run belongs to: its method; runs stopped by a time budget form their own
        curve (they allocate samples differently from fixed-count runs, and mixing the two would
        hide one behind the other), and so do runs with an option that changes what is computed
        rather than how many samples (e.g. texture-filter=none)."""
        options = self.spec.split(":", 1)[1] if ":" in self.spec else ""
        labels = []
        for option in filter(None, options.split(",")):
            key = option.split("=", 1)[0]
            if key == "time-budget":
                labels.insert(0, "time budget")
            elif key not in SAMPLE_COUNT_OPTIONS:
                labels.append(option)
        return f"{self.method} ({', '.join(labels)})" if labels else self.method

    def seconds(self, time_key):
        return getattr(self, time_key)

    def metric(self, name):
        return getattr(self, name)


@dataclass
class Results:
    path: str
    scene: str
    width: int
    height: int
    filter: str
    reference: Reference
    runs: list


# ---------------------------------------------------------------------------------------------
# Loading: every value is checked, and an error names the file, the JSON pointer and what was
# expected. Keys beyond the contract are ignored, so mrt-compare may add fields without breaking
# older plots.


def _describe(value):
    text = json.dumps(value) if not isinstance(value, float) or math.isfinite(value) else str(value)
    return text if len(text) <= 40 else text[:37] + "..."


class _Reader:
    def __init__(self, path):
        self.path = path

    def fail(self, pointer, message):
        raise ResultsError(f"{self.path}: {pointer or '/'}: {message}")

    def get(self, obj, key, pointer, check, expected, nullable=False):
        where = f"{pointer}/{key}"
        if key not in obj:
            self.fail(where, f"missing (expected {expected})")
        value = obj[key]
        if value is None and nullable:
            return None
        if not check(value):
            self.fail(where, f"expected {expected}, got {_describe(value)}")
        return value

    def string(self, obj, key, pointer):
        return self.get(obj, key, pointer, lambda v: isinstance(v, str) and v != "",
                        "a non-empty string")

    def integer(self, obj, key, pointer, minimum):
        return self.get(obj, key, pointer,
                        lambda v: isinstance(v, int) and not isinstance(v, bool) and v >= minimum,
                        f"an integer >= {minimum}")

    def number(self, obj, key, pointer, positive=False, nullable=False):
        def ok(v):
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                return False
            return v > 0 if positive else v >= 0

        expected = "a finite number > 0" if positive else "a finite number >= 0"
        value = self.get(obj, key, pointer, ok, expected + (" or null" if nullable else ""),
                         nullable)
        return None if value is None else float(value)

    def any_number(self, obj, key, pointer):
        value = self.get(obj, key, pointer,
                         lambda v: isinstance(v, (int, float)) and not isinstance(v, bool),
                         "a number or null", nullable=True)
        return None if value is None else float(value)

    def obj(self, parent, key, pointer):
        return self.get(parent, key, pointer, lambda v: isinstance(v, dict), "an object")


def load_results(path):
    """Reads and checks results.json; raises ResultsError with a one-line message."""
    try:
        with open(path, encoding="utf-8") as f:
            data = json.load(f)
    except FileNotFoundError:
        raise ResultsError(f"{path}: no such file") from None
    except json.JSONDecodeError as e:
        raise ResultsError(f"{path}: not valid JSON: {e.msg} at line {e.lineno} column {e.colno}") \
            from None
    except (OSError, UnicodeDecodeError) as e:
        raise ResultsError(f"{path}: cannot read: {e}") from None
    r = _Reader(path)
    if not isinstance(data, dict):
        r.fail("", f"expected an object, got {_describe(data)}")
    ref = r.obj(data, "reference", "")
    reference = Reference(spp=r.integer(ref, "spp", "/reference", 1),
                          seconds=r.number(ref, "seconds", "/reference"),
                          std_error=r.number(ref, "std_error", "/reference", nullable=True),
                          image=r.string(ref, "image", "/reference"))
    runs_json = r.get(data, "runs", "", lambda v: isinstance(v, list) and len(v) > 0,
                      "a non-empty array of runs")
    runs = []
    for i, run in enumerate(runs_json):
        p = f"/runs/{i}"
        if not isinstance(run, dict):
            r.fail(p, f"expected an object, got {_describe(run)}")
        if type(run.get("rmse")) in (int, float) and run["rmse"] == 0:
            r.fail(p + "/rmse", "is 0 (the run equals the reference, PSNR infinite); "
                   "an error of 0 has no place on log axes")
        runs.append(Run(index=i, method=r.string(run, "method", p), spec=r.string(run, "spec", p),
                        render_seconds=r.number(run, "render_seconds", p, positive=True),
                        total_seconds=r.number(run, "total_seconds", p, positive=True),
                        rays=r.integer(run, "rays", p, 0), samples=r.integer(run, "samples", p, 0),
                        rmse=r.number(run, "rmse", p, positive=True),
                        psnr=r.any_number(run, "psnr", p), ssim=r.any_number(run, "ssim", p),
                        image=r.string(run, "image", p),
                        error_image=r.string(run, "error_image", p)))
    return Results(path=path, scene=r.string(data, "scene", ""),
                   width=r.integer(data, "width", "", 1), height=r.integer(data, "height", "", 1),
                   filter=r.string(data, "filter", ""), reference=reference, runs=runs)


# ---------------------------------------------------------------------------------------------
# Curves


class Curve:
    """One method's runs as a monotone piecewise-linear curve in (log time, badness), where
    badness is log(value) for a lower-is-better metric and -value otherwise."""

    def __init__(self, method, runs, metric, time_key):
        self.method = method
        self.metric = metric
        self.time_key = time_key
        self.lower_is_better = METRICS[metric][1]
        self.runs = sorted(runs, key=lambda run: (run.seconds(time_key), self._bad(run)))
        self.kept = []  # non-dominated runs, time and value strictly improving
        self.dominated = []
        for run in self.runs:
            if self.kept and self._bad(run) >= self._bad(self.kept[-1]):
                self.dominated.append(run)
            else:
                self.kept.append(run)
        self._lt = [math.log(run.seconds(time_key)) for run in self.kept]
        self._b = [self._bad(run) for run in self.kept]

    def _badness(self, value):
        return math.log(value) if self.lower_is_better else -value

    def _value(self, badness):
        return math.exp(badness) if self.lower_is_better else -badness

    def _bad(self, run):
        return self._badness(run.metric(self.metric))

    def times(self):
        return [run.seconds(self.time_key) for run in self.kept]

    def values(self):
        return [run.metric(self.metric) for run in self.kept]

    def value_at(self, seconds):
        """The curve's value at a time budget, None outside the measured times."""
        lt = math.log(seconds)
        i = _segment(self._lt, lt, increasing=True)
        if i is None:
            return None
        if isinstance(i, tuple):
            return self.kept[i[0]].metric(self.metric)
        u = (lt - self._lt[i]) / (self._lt[i + 1] - self._lt[i])
        return self._value(self._b[i] + u * (self._b[i + 1] - self._b[i]))

    def time_to(self, value):
        """Time the curve needs to reach a value, None outside the measured values."""
        b = self._badness(value)
        i = _segment(self._b, b, increasing=False)
        if i is None:
            return None
        if isinstance(i, tuple):
            return self.kept[i[0]].seconds(self.time_key)
        u = (b - self._b[i]) / (self._b[i + 1] - self._b[i])
        return math.exp(self._lt[i] + u * (self._lt[i + 1] - self._lt[i]))

    def value_range(self):
        values = self.values()
        return min(values), max(values)


def _segment(xs, x, increasing):
    """Where x falls in the strictly monotone xs: (k,) when within SNAP of xs[k], the index i of
    the bracketing pair xs[i], xs[i+1] otherwise, None when outside."""
    tolerance = SNAP * max(1.0, abs(x))
    for k, xk in enumerate(xs):
        if abs(x - xk) <= tolerance:
            return (k,)
    for i in range(len(xs) - 1):
        lo, hi = (xs[i], xs[i + 1]) if increasing else (xs[i + 1], xs[i])
        if lo < x < hi:
            return i
    return None


def build_curves(results, metric, time_key):
    """Curves by method, in the order methods first appear in the file."""
    methods = {}
    for run in results.runs:
        value = run.metric(metric)
        if value is None or not math.isfinite(value):
            raise ResultsError(f"{results.path}: /runs/{run.index}/{metric}: is "
                               f"{_describe(value)}, which cannot be plotted")
        methods.setdefault(run.curve, []).append(run)
    return {m: Curve(m, runs, metric, time_key) for m, runs in methods.items()}


def choose_baseline(results, time_key, spec=None):
    """The run the equal-time and equal-error comparisons are made at, and why it was chosen."""
    runs = results.runs
    if spec is not None:
        named = [run for run in runs if run.spec == spec]
        if not named:
            raise ResultsError(f"{results.path}: no run has spec {spec!r} (--baseline)")
        return named[0], "named by --baseline"
    cone = [run for run in runs if run.method == "cone"]
    if cone:
        return cone[0], "first cone run"
    whitted = [run for run in runs if run.method == "whitted"]
    if whitted:
        return min(whitted, key=lambda run: run.seconds(time_key)), "fastest whitted run"
    return min(runs, key=lambda run: run.seconds(time_key)), "fastest run (no cone or whitted run)"


def level_key(level):
    """derived.json's key for an error level: the shortest text that reads back as the same
    float (0.05 → "0.05")."""
    return repr(float(level))


def derive(results, time_key="render_seconds", baseline_spec=None):
    """The derived figures (derived.json's content), always in RMSE."""
    curves = build_curves(results, "rmse", time_key)
    baseline, why = choose_baseline(results, time_key, baseline_spec)
    t_base = baseline.seconds(time_key)
    lo = min(c.value_range()[0] for c in curves.values())
    hi = max(c.value_range()[1] for c in curves.values())
    levels = {baseline.rmse} | {e for e in ERROR_LEVELS if lo * (1 - SNAP) <= e <= hi * (1 + SNAP)}
    levels = sorted(levels, reverse=True)

    time_to_error = {m: {level_key(e): c.time_to(e) for e in levels} for m, c in curves.items()}
    equal_time = {m: c.value_at(t_base) for m, c in curves.items()}
    ratio = {m: (None if v is None else v / baseline.rmse) for m, v in equal_time.items()}

    speedups = []
    methods = list(curves)
    for a in range(len(methods)):
        for b in range(a + 1, len(methods)):
            for e in levels:
                ta = time_to_error[methods[a]][level_key(e)]
                tb = time_to_error[methods[b]][level_key(e)]
                if ta is None or tb is None:
                    continue
                fast, slow = (methods[a], methods[b]) if ta <= tb else (methods[b], methods[a])
                speedups.append({"faster": fast, "slower": slow, "error": e,
                                 "speedup": max(ta, tb) / min(ta, tb)})
    return {
        "time": time_key,
        "baseline": {"method": baseline.method, "curve": baseline.curve, "spec": baseline.spec,
                     "seconds": t_base,
                     "rmse": baseline.rmse, "chosen_as": why},
        "levels": levels,
        "time_to_error": time_to_error,
        "equal_time": equal_time,
        "error_ratio_at_equal_time": ratio,
        "speedup_at_equal_error": speedups,
        "dominated_runs": [{"method": run.method, "spec": run.spec}
                           for c in curves.values() for run in c.dominated],
    }


# ---------------------------------------------------------------------------------------------
# Text


def fmt3(x):
    """A number to 3 significant digits without exponent in the usual range: 0.0412, 41.2, 1230."""
    if x is None:
        return "—"
    if not math.isfinite(x):
        return "∞" if x > 0 else ("-∞" if x < 0 else "NaN")
    if x == 0:
        return "0"
    rounded = float(f"{x:.3g}")
    exponent = math.floor(math.log10(abs(rounded)))
    if exponent < -4 or exponent >= 6:
        return f"{rounded:.2e}"
    return f"{rounded:.{max(0, 2 - exponent)}f}"


def fmt_count(n):
    """A count to 3 significant digits with k/M/G: 123 k, 1.60 M."""
    for scale, suffix in ((1e9, "G"), (1e6, "M"), (1e3, "k")):
        if n >= scale:
            return f"{fmt3(n / scale)} {suffix}"
    return str(n)


def describe_time_to(curve, level, seconds):
    """A time-to-error cell: the time, or why there is none."""
    if seconds is not None:
        return fmt3(seconds)
    lo, hi = curve.value_range()
    if level > hi:
        return f"<{fmt3(curve.times()[0])}"  # the fastest kept run is already better
    return "not reached"


def table(rows, header):
    widths = [max(len(str(r[i])) for r in [header] + rows) for i in range(len(header))]

    def line(r):
        return "  ".join(str(c).ljust(w) for c, w in zip(r, widths)).rstrip()

    return "\n".join([line(header), line(["-" * w for w in widths])] + [line(r) for r in rows])


def summary(results, derived):
    curves = build_curves(results, "rmse", derived["time"])
    base = derived["baseline"]
    out = [f"baseline: {base['spec']} ({base['chosen_as']}), {fmt3(base['seconds'])} s, "
           f"RMSE {fmt3(base['rmse'])}",
           "",
           "time (s) to reach RMSE, log-log interpolation between the non-dominated runs "
           "('<t': better already at its fastest run, 'not reached': never that good):"]
    levels = derived["levels"]
    header = ["method"] + [fmt3(e) + (" (baseline)" if e == base["rmse"] else "") for e in levels]
    rows = [[m] + [describe_time_to(curves[m], e, times[level_key(e)]) for e in levels]
            for m, times in derived["time_to_error"].items()]
    out += [table(rows, header), "", f"RMSE at the baseline's time ({fmt3(base['seconds'])} s):"]
    rows = [[m, fmt3(v), fmt3(derived["error_ratio_at_equal_time"][m])]
            for m, v in derived["equal_time"].items()]
    out.append(table(rows, ["method", "RMSE", "ratio to baseline"]))
    out += ["", "speed-up at equal RMSE:"]
    if derived["speedup_at_equal_error"]:
        rows = [[s["faster"], s["slower"], fmt3(s["error"]), fmt3(s["speedup"]) + "×"]
                for s in derived["speedup_at_equal_error"]]
        out.append(table(rows, ["faster", "slower", "RMSE", "speed-up"]))
    else:
        out.append("(no two methods reach a common error level)")
    if derived["dominated_runs"]:
        out += ["", "dominated runs (ignored for interpolation): " +
                ", ".join(d["spec"] for d in derived["dominated_runs"])]
    return "\n".join(out)


# ---------------------------------------------------------------------------------------------
# Plot


def _noise_level(results, metric, baseline):
    """The reference's noise floor in the plotted metric, None when unknown."""
    s = results.reference.std_error
    if s is None or s <= 0:
        return None
    if metric == "rmse":
        return s
    if metric == "psnr" and baseline.psnr is not None and math.isfinite(baseline.psnr):
        # PSNR = 20·log10(peak / RMSE); the tool's peak follows from any run's pair.
        peak = baseline.rmse * 10 ** (baseline.psnr / 20)
        return 20 * math.log10(peak / s)
    return None  # SSIM has no mapping from a pixel standard error


def draw(results, derived, metric, output):
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise ResultsError(f"{sys.executable} has no matplotlib (Debian's python3-matplotlib; "
                           "scripts/setup installs it)") from None

    time_key = derived["time"]
    curves = build_curves(results, metric, time_key)
    baseline = next(run for run in results.runs if run.spec == derived["baseline"]["spec"])
    t_base, v_base = baseline.seconds(time_key), baseline.metric(metric)
    label, lower_is_better = METRICS[metric]

    fig, ax = plt.subplots(figsize=(8, 5.5), dpi=150)
    ax.set_xscale("log")
    if lower_is_better:
        ax.set_yscale("log")
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    markers = "osD^vP*X"
    for k, (method, curve) in enumerate(curves.items()):
        colour, marker = colours[k % len(colours)], markers[k % len(markers)]
        ax.plot(curve.times(), curve.values(), marker=marker, color=colour, label=method,
                linestyle="-" if len(curve.kept) > 1 else "none")
        if curve.dominated:
            ax.plot([r.seconds(time_key) for r in curve.dominated],
                    [r.metric(metric) for r in curve.dominated], marker=marker, color=colour,
                    markerfacecolor="none", linestyle="none")
        for run in curve.runs:
            option = run.spec.split(":", 1)[1] if ":" in run.spec else ""
            if option:
                ax.annotate(option, (run.seconds(time_key), run.metric(metric)),
                            xytext=(4, 4), textcoords="offset points", fontsize=6, color=colour)
        if method == baseline.curve:
            continue
        # Where this curve stands at the baseline's time and at the baseline's error.
        for point in ((t_base, curve.value_at(t_base)), (curve.time_to(v_base), v_base)):
            if None not in point:
                ax.plot(*point, marker="s", markersize=9, markerfacecolor="none",
                        markeredgecolor=colour, linestyle="none")

    ax.axvline(t_base, color="0.35", linestyle=":", linewidth=1,
               label=f"equal time ({baseline.spec}, {fmt3(t_base)} s)")
    ax.axhline(v_base, color="0.35", linestyle="-.", linewidth=1,
               label=f"equal {metric.upper()} ({baseline.spec}, {fmt3(v_base)})")
    ax.plot([], [], marker="s", markerfacecolor="none", markeredgecolor="0.2", linestyle="none",
            markersize=9, label="interpolated at equal time / error")
    if derived["dominated_runs"]:
        ax.plot([], [], marker="o", markerfacecolor="none", color="0.2", linestyle="none",
                label="dominated run (not interpolated)")
    noise = _noise_level(results, metric, baseline)
    if noise is not None:
        ax.axhline(noise, color="0.5", linestyle="--", linewidth=1, label="reference noise")

    ref = results.reference
    ax.set_title(f"{os.path.basename(results.scene)}, {results.width}×{results.height}, "
                 f"{results.filter} filter; reference {ref.spp} spp", fontsize=10)
    ax.set_xlabel("render time (s)" if time_key == "render_seconds" else "total time (s)")
    ax.set_ylabel(label)
    ax.grid(True, which="both", color="0.9", linewidth=0.6)
    ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    fig.savefig(output)
    plt.close(fig)


# ---------------------------------------------------------------------------------------------


def run_reporting_errors(prog, work):
    """Runs work() and returns its result, or prints a malformed input or an unwritable file as
    one line on stderr (no traceback) and returns None."""
    try:
        return work()
    except ResultsError as e:
        print(f"{prog}: {e}", file=sys.stderr)
    except OSError as e:
        where = f"{e.filename}: " if e.filename else ""
        print(f"{prog}: {where}{e.strerror or e}", file=sys.stderr)
    return None


def main(argv=None):
    parser = argparse.ArgumentParser(
        description="Plots error against run time from DIR/results.json (written by "
                    "mrt-compare), writes DIR/error_time.png and DIR/derived.json and prints "
                    "the equal-time and equal-error figures.")
    parser.add_argument("dir", metavar="DIR", help="directory holding results.json")
    parser.add_argument("--metric", choices=sorted(METRICS), default="rmse",
                        help="plotted error metric (default rmse; derived figures are always RMSE)")
    parser.add_argument("-o", "--output", metavar="FILE", help="plot (default DIR/error_time.png)")
    parser.add_argument("--derived", metavar="FILE", help="figures (default DIR/derived.json)")
    parser.add_argument("--time", choices=sorted(TIME_KEYS), default="render",
                        help="x axis: render_seconds (default) or total_seconds")
    parser.add_argument("--baseline", metavar="SPEC",
                        help="run to compare at (default: first cone run, else fastest whitted)")
    parser.add_argument("--quiet", action="store_true", help="don't print the table")
    args = parser.parse_args(argv)
    prog = os.path.basename(sys.argv[0])
    output = args.output or os.path.join(args.dir, "error_time.png")
    derived_path = args.derived or os.path.join(args.dir, "derived.json")

    def work():
        results = load_results(os.path.join(args.dir, "results.json"))
        derived = derive(results, TIME_KEYS[args.time], args.baseline)
        draw(results, derived, args.metric, output)
        with open(derived_path, "w", encoding="utf-8") as f:
            json.dump(derived, f, indent=2)
            f.write("\n")
        return results, derived

    done = run_reporting_errors(prog, work)
    if done is None:
        return 1
    results, derived = done
    if not args.quiet:
        print(summary(results, derived))
        print(f"\nwrote {output} and {derived_path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
