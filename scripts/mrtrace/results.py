"""Reads mrt-compare's DIR/results.json, checking every value this package uses: an error names
the file, the JSON pointer and what was expected, on one line. Keys beyond the contract are
ignored, so mrt-compare may add fields without breaking older pages. Also the number formats of
the pages and the one-line reporting of a failure."""

import json
import math
import sys
from dataclasses import dataclass


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
    display_rmse: float | None  # the same of values clamped to [0, 1]; None when not written
    psnr: float | None  # dB; None when the tool wrote null
    ssim: float | None
    image: str  # file names relative to DIR
    error_image: str

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
    headline: dict  # "headline" as mrt-compare wrote it (headline_ratios.h)
    derived: dict  # "derived": the equal-time and equal-error figures (derived_figures.h)


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

    def array(self, parent, key, pointer):
        return self.get(parent, key, pointer, lambda v: isinstance(v, list), "an array")


def _check_derived(r, data, runs):
    """The parts of "derived" the pages and the plot read, against the runs."""
    p = "/derived"
    if data.get("derived", 0) is None:
        r.fail(p, "is null: no run has a positive time and RMSE, so there is nothing to plot")
    derived = r.obj(data, "derived", "")
    base = r.obj(derived, "baseline", p)
    r.integer(base, "run", p + "/baseline", 0)
    if base["run"] >= len(runs):
        r.fail(p + "/baseline/run", f"expected the index of a run (< {len(runs)})")
    for key in ("spec", "curve", "chosen_as"):
        r.string(base, key, p + "/baseline")
    r.number(base, "seconds", p + "/baseline", positive=True)
    r.number(base, "rmse", p + "/baseline", positive=True)
    levels = r.array(derived, "levels", p)
    if not all(isinstance(e, (int, float)) and not isinstance(e, bool) and e > 0 for e in levels):
        r.fail(p + "/levels", "expected positive numbers")
    labels = []
    for i, curve in enumerate(r.array(derived, "curves", p)):
        q = f"{p}/curves/{i}"
        labels.append(r.string(curve, "label", q))
        for key in ("runs", "dominated"):
            if not all(isinstance(k, int) and 0 <= k < len(runs) for k in r.array(curve, key, q)):
                r.fail(f"{q}/{key}", "expected indices of runs")
    for key in ("time_to_error", "equal_time", "error_ratio_at_equal_time"):
        table = r.obj(derived, key, p)
        if list(table) != labels:
            r.fail(f"{p}/{key}", f"expected one entry per curve ({', '.join(labels)})")
    for label, times in derived["time_to_error"].items():
        q = f"{p}/time_to_error/{label}"
        if not isinstance(times, list) or len(times) != len(levels):
            r.fail(q, f"expected one entry per level ({len(levels)})")
        for i, t in enumerate(times):
            if t is not None:
                r.number(t, "seconds", f"{q}/{i}", positive=True)
                r.get(t, "relation", f"{q}/{i}", lambda v: v in ("equal", "at most", "at least"),
                      '"equal", "at most" or "at least"')
    for i, s in enumerate(r.array(derived, "speedup_at_equal_error", p)):
        q = f"{p}/speedup_at_equal_error/{i}"
        for key in ("faster", "slower"):
            if r.string(s, key, q) not in labels:
                r.fail(f"{q}/{key}", "expected the label of a curve")
        for key in ("error", "speedup", "faster_seconds", "slower_seconds"):
            r.number(s, key, q, positive=True)
    return derived


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
        display = run.get("display_rmse")
        runs.append(Run(index=i, method=r.string(run, "method", p), spec=r.string(run, "spec", p),
                        render_seconds=r.number(run, "render_seconds", p, positive=True),
                        total_seconds=r.number(run, "total_seconds", p, positive=True),
                        rays=r.integer(run, "rays", p, 0), samples=r.integer(run, "samples", p, 0),
                        rmse=r.number(run, "rmse", p, positive=True),
                        display_rmse=None if display is None else r.any_number(run, "display_rmse", p),
                        psnr=r.any_number(run, "psnr", p), ssim=r.any_number(run, "ssim", p),
                        image=r.string(run, "image", p),
                        error_image=r.string(run, "error_image", p)))
    headline = data.get("headline", {})
    if not isinstance(headline, dict):
        r.fail("/headline", f"expected an object, got {_describe(headline)}")
    return Results(path=path, scene=r.string(data, "scene", ""),
                   width=r.integer(data, "width", "", 1), height=r.integer(data, "height", "", 1),
                   filter=r.string(data, "filter", ""), reference=reference, runs=runs,
                   headline=headline, derived=_check_derived(r, data, runs))


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


# What goes before a value that is a bound (results.json's "relation").
RELATION_PREFIX = {"equal": "", "at most": "≤ ", "at least": "≥ "}


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
